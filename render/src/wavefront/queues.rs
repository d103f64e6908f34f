//! The queue driver (MoonRay §4–6): bounded queues that flush into their handler when full, a path
//! pool topped up by the camera generator, and a drain phase ending each chunk of a tile.
//!
//! ```text
//! camera generator ──(free path slots)──► ray queue ─(full)─► closest hit + area/escaped emission
//!        ▲                                   ▲                  │ escaped ─► ended
//!        │                                   │                  └► shade queue of the hit's material
//!        │                                   │                        ─(full)─► sort keys, radix sort,
//!        │                                   │                          shade (phase 1 runs, phase 2 groups)
//!        │                                   └───────────── continuations ◄┤ ended ─► ended
//!        │                                                 occlusion queue ◄┘
//!        │   (flushed when full and before every ray flush) ─► any hit ─► radiance += contribution
//!        │                                                       then every ended path ─► radiance queue
//!        └──────────────────────────── its slot is free again ◄──┘   ─(full)─► film, sorted by slot
//! ```
//!
//! One worker (a rayon task per tile) owns all its queues: no locks, no central scheduler; every
//! queue's storage is allocated in [`QueueState::new`] and never grows ([`Queue`]). The handlers are
//! called by one loop (`render_chunk`), "flush whichever queue is full", in this order: occlusion,
//! a full shade queue, the ray queue; when nothing is full and no path is free (or the chunk's camera
//! paths are all out) it flushes the longest waiting queue: the drain. The loop keeps the depth
//! bounded where MoonRay's handlers call each other from inside `push`.
//!
//! # Queue entries
//! | queue | entry | bits |
//! |---|---|---|
//! | ray | path index | 32: [`super::RayState`] slot |
//! | shade, one per material | path index; on flush `key << 32 \| index` | 64: [`super::sort`]'s layout |
//! | occlusion | path index ([`super::ShadowRay`] in a side table) | 32 |
//! | radiance | `Finished`: film slot + radiance + first hit | 32 + 96 + 256 bits |
//!
//! # Bit-exactness
//! Paths add their radiance terms in the scalar integrator's order: the occlusion queue is flushed
//! before every ray flush, so the light sample of vertex k is added before the emission the
//! continuation finds at vertex k + 1; a path that ends with a shadow ray pending waits in `ended`
//! until the next occlusion flush. Paths finish in any order: each writes its (pixel, sample) slot of
//! the chunk's film, and `accumulate::film` sums the slots in sample order, as the scalar
//! film loop does. Scheduling therefore never changes the image: the equivalence tests render with
//! tiny capacities (every flush path, the drain, the regeneration) and compare bit for bit.
//!
//! # Why per-worker shade queues
//! Shade queues shared between threads would need a lock or a lock-free multi-producer queue on the
//! hot path, and the order in which threads' hits meet in a shared batch would differ from run to
//! run (the image would not change, since every path's terms keep their order, but the batches,
//! counters and timings would). They would pay only if per-worker batches ran short of full 8-lane
//! groups, and they do not: a tile's paths already fill them (`--stats`: 99.4–99.9 % lane use with the
//! wave driver, 98.8–99.8 % with this one), so the queues stay per worker.
//!
//! # Against the wave driver (the default: [`super::DEFAULT_DRIVER`])
//! Both drivers run the same kernels and give the same bytes. The queue driver is slower here:
//! +4.1 / +2.3 / +6.9 % instructions and +27 / +12 / +39 % D1 misses (tractor / shading-heavy /
//! simple; cachegrind, 120×80, 8 spp, 1 thread), and timed no faster within the shared machine's
//! noise. Retiring a path reads its radiance and first hit once they have gone cold, the film is
//! read back, and the per-path bookkeeping costs ~100 instructions per ray-queue entry; what the
//! queues could win (regeneration filling short waves) does not arise, because the wave driver's
//! waves keep the 8-lane groups full to the last bounce (99.7 %). Smaller queues and pools took more
//! D1 misses, and sorting each radiance batch by film slot cost 7.3 M instructions for 1 % fewer
//! misses (left out, `accumulate::write_film`); measurements: `docs/perf.md#queue-driver-wavefrontqueuesrs`.

use super::accumulate::{self, FilmSample, Finished};
use super::queue::{BatchHistogram, Queue};
use super::{generate, intersect, occlusion, shade, sort, timed, Context, Worker};
use crate::film::Tile;
use crate::path::RayCounts;
use crate::stats::Phase;
use texture::Touch;

/// Capacities of the queue driver's queues and pools.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct QueueConfig {
    /// Paths in flight (slots of the [`super::RayState`] pool the generator keeps topped up).
    pub paths: usize,
    /// Film slots per chunk: a chunk holds `chunk_slots / pixels` samples of every pixel of a tile
    /// (at least one).
    pub chunk_slots: usize,
    /// Ray queue capacity (the closest-hit handler's batch).
    pub rays: usize,
    /// Capacity of each material's shade queue.
    pub shade: usize,
    /// Occlusion queue capacity.
    pub occlusion: usize,
    /// Radiance queue capacity.
    pub radiance: usize,
}

impl QueueConfig {
    /// The capacities renders use.
    pub const DEFAULT: QueueConfig = QueueConfig {
        paths: 4096,
        chunk_slots: 4 * 4096,
        rays: 1024,
        shade: 256,
        occlusion: 1024,
        radiance: 256,
    };
}

/// Which loop renders a tile.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Driver {
    /// Bounce-synchronous waves: every stage over a whole chunk's surviving paths.
    Wave,
    /// Bounded queues flushed into their handlers when full (this module).
    Queues(QueueConfig),
}

/// How many entries each handler was given per call.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct QueueBatches {
    /// Camera paths generated per top-up.
    pub generate: BatchHistogram,
    /// Rays per closest-hit flush.
    pub rays: BatchHistogram,
    /// Hits per shade flush.
    pub shade: BatchHistogram,
    /// Shadow rays per occlusion flush.
    pub occlusion: BatchHistogram,
    /// Finished paths per radiance flush.
    pub radiance: BatchHistogram,
}

impl QueueBatches {
    /// Adds `other` into `self`.
    pub fn add(&mut self, other: &QueueBatches) {
        self.generate.add(&other.generate);
        self.rays.add(&other.rays);
        self.shade.add(&other.shade);
        self.occlusion.add(&other.occlusion);
        self.radiance.add(&other.radiance);
    }
}

impl std::fmt::Display for QueueBatches {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "generate:  {}", self.generate)?;
        writeln!(f, "rays:      {}", self.rays)?;
        writeln!(f, "shade:     {}", self.shade)?;
        writeln!(f, "occlusion: {}", self.occlusion)?;
        write!(f, "radiance:  {}", self.radiance)
    }
}

/// The queue driver's queues, pools and side tables, allocated once per worker.
pub struct QueueState {
    config: QueueConfig,
    /// Paths waiting for the closest-hit handler.
    rays: Queue<u32>,
    /// Per material (the last one also takes out-of-range indices): hits waiting to be shaded.
    shade: Vec<Queue<u32>>,
    /// Materials whose shade queue filled (each at most once: a queue only grows until flushed).
    full_shade: Vec<u32>,
    /// Paths that ended, waiting for the occlusion queue to be flushed before they leave.
    ended: Vec<u32>,
    /// Free path slots (a stack: the lowest indices first).
    free: Vec<u32>,
    /// Per path: its film slot in the current chunk.
    path_slot: Vec<u32>,
    /// Per path: scratch flag marking the paths a handler passed on (all false between handlers).
    passed_on: Vec<bool>,
    /// Finished paths on their way to the film.
    radiance: Queue<Finished>,
    /// The chunk's film: one slot per (pixel, sample).
    film: Vec<FilmSample>,
    /// Batch sizes per handler.
    pub batches: QueueBatches,
}

impl QueueState {
    /// Queues for `config`, at most `pool` paths in flight, `pixels` pixels per tile and
    /// `materials` shade queues.
    pub fn new(config: QueueConfig, pool: usize, pixels: usize, materials: usize) -> Self {
        let paths = config.paths.clamp(1, pool);
        let rays = config.rays.clamp(1, paths);
        // A ray flush adds at most `rays` hits to a shade queue that was below its capacity.
        let shade_storage = (config.shade + rays).min(paths);
        QueueState {
            config: QueueConfig { paths, rays, ..config },
            rays: Queue::new(rays, paths),
            shade: (0..materials.max(1)).map(|_| Queue::new(config.shade, shade_storage)).collect(),
            full_shade: Vec::with_capacity(materials.max(1)),
            ended: Vec::with_capacity(paths),
            free: Vec::with_capacity(paths),
            path_slot: vec![0; paths],
            passed_on: vec![false; paths],
            radiance: Queue::new(config.radiance, config.radiance),
            film: vec![FilmSample::default(); config.chunk_slots.max(pixels)],
            batches: QueueBatches::default(),
        }
    }

    /// The storage of every queue and pool, to check that rendering allocates nothing.
    pub fn storage(&self) -> Vec<usize> {
        let mut s = vec![
            self.rays.storage(),
            self.full_shade.capacity(),
            self.ended.capacity(),
            self.free.capacity(),
            self.path_slot.capacity(),
            self.passed_on.capacity(),
            self.radiance.storage(),
            self.film.capacity(),
        ];
        s.extend(self.shade.iter().map(|q| q.storage()));
        s
    }

    /// Nothing waits anywhere and every path slot is free (true after every chunk's drain).
    pub fn is_drained(&self) -> bool {
        self.is_empty() && self.free.len() == self.config.paths
    }

    /// Nothing waits anywhere.
    fn is_empty(&self) -> bool {
        self.rays.is_empty()
            && self.ended.is_empty()
            && self.radiance.is_empty()
            && self.shade.iter().all(|q| q.is_empty())
    }
}

/// Renders one tile with the queue driver, chunk by chunk of its samples.
pub(super) fn render(ctx: &Context<'_, '_, impl Touch>, w: &mut Worker, tile: &Tile, rays: &mut RayCounts) {
    let npix = ((tile.x1 - tile.x0) * (tile.y1 - tile.y0)) as usize;
    let spp = ctx.sampling.spp as usize;
    let q = w.queues.as_mut().expect("the queue driver's worker has queues");
    let per_chunk = (q.film.len() / npix).clamp(1, spp);
    let paths = q.config.paths;
    // Every slot of the pool, as path states (no allocation: the pool's storage holds them).
    w.states.resize(paths.max(w.states.len()), super::RayState::default());
    q.free.clear();
    q.free.extend((0..paths as u32).rev());
    let mut s0 = 0;
    while s0 < spp {
        let samples = per_chunk.min(spp - s0);
        render_chunk(ctx, w, tile, s0 as u32, samples as u32, rays);
        let mut secs = w.seconds;
        // The film leaves the worker while it is summed (a move, no copy).
        let q = w.queues.as_mut().expect("queues");
        let film = std::mem::take(&mut q.film);
        timed(&mut secs.accumulate, || accumulate::film(w, &film, samples));
        w.queues.as_mut().expect("queues").film = film;
        w.seconds = secs;
        w.clock.lap(Phase::Overhead);
        s0 += samples;
    }
}

/// Camera paths are generated in top-ups of at least this many (or the chunk's rest): a few free
/// slots at a time would run the camera lanes on partial groups.
const TOP_UP: usize = 64;

/// Renders the chunk of samples `s0 .. s0 + samples` of `tile` into the film: the queue loop, then
/// the drain (the same loop once the camera paths are out).
fn render_chunk(
    ctx: &Context<'_, '_, impl Touch>,
    w: &mut Worker,
    tile: &Tile,
    s0: u32,
    samples: u32,
    rays: &mut RayCounts,
) {
    let npix = ((tile.x1 - tile.x0) * (tile.y1 - tile.y0)) as usize;
    let chunk = npix * samples as usize;
    let mut next = 0;
    loop {
        let q = w.queues.as_mut().expect("queues");
        let top_up = q.free.len().min(chunk - next);
        if top_up >= TOP_UP.min(chunk - next) && top_up > 0 {
            generate(ctx, w, tile, s0, samples, next..next + top_up, rays);
            next += top_up;
            continue;
        }
        if w.occlusion.is_full() {
            flush_occlusion(ctx, w, rays);
            continue;
        }
        if let Some(m) = q.full_shade.pop() {
            flush_shade(ctx, w, m as usize, rays);
            continue;
        }
        if q.rays.is_full() {
            flush_rays(ctx, w, rays);
            continue;
        }
        // Nothing is full: the longest waiting queue (shade queues first on a tie: they free paths).
        let (m, longest) = q
            .shade
            .iter()
            .enumerate()
            .map(|(m, s)| (m, s.len()))
            .max_by_key(|&(m, n)| (n, usize::MAX - m))
            .unwrap_or((0, 0));
        if longest > 0 && longest >= q.rays.len() {
            flush_shade(ctx, w, m, rays);
        } else if !q.rays.is_empty() {
            flush_rays(ctx, w, rays);
        } else if !w.occlusion.is_empty() || !q.ended.is_empty() {
            flush_occlusion(ctx, w, rays);
        } else if top_up > 0 {
            generate(ctx, w, tile, s0, samples, next..next + top_up, rays);
            next += top_up;
        } else {
            break;
        }
    }
    let q = w.queues.as_mut().expect("queues");
    let (radiance, film, batches) = (&mut q.radiance, &mut q.film, &mut q.batches);
    timed(&mut w.seconds.accumulate, || {
        radiance.flush(|batch| {
            batches.radiance.record(batch.len());
            accumulate::write_film(batch, film)
        })
    });
    debug_assert!(q.is_drained());
}

/// Camera paths for chunk positions `positions`, into free pool slots and the ray queue.
fn generate(
    ctx: &Context<'_, '_, impl Touch>,
    w: &mut Worker,
    tile: &Tile,
    s0: u32,
    samples: u32,
    positions: std::ops::Range<usize>,
    rays: &mut RayCounts,
) {
    w.clock.lap(Phase::Overhead);
    let q = w.queues.as_mut().expect("queues");
    q.batches.generate.record(positions.len());
    rays.camera += positions.len() as u64;
    let (states, first_hits) = (&mut w.states, &mut w.first_hits);
    timed(&mut w.seconds.generate, || {
        generate::camera_paths(ctx, tile, s0, samples, positions, |position, state| {
            let i = q.free.pop().expect("a free slot per generated path");
            states[i as usize] = state;
            first_hits[i as usize] = None;
            q.path_slot[i as usize] = position as u32;
            q.rays.push(i);
        })
    });
    w.clock.lap(Phase::Overhead);
}

/// The ray queue's handler, on up to its capacity of rays: closest hits and the emission found along
/// them; hits go to their material's shade queue, escaped paths end. The occlusion queue is flushed
/// first (see the module docs: bit-exactness).
fn flush_rays(ctx: &Context<'_, '_, impl Touch>, w: &mut Worker, rays: &mut RayCounts) {
    flush_occlusion(ctx, w, rays);
    let q = w.queues.as_mut().expect("queues");
    let capacity = q.rays.capacity();
    q.rays.take_into(&mut w.rays, capacity);
    q.batches.rays.record(w.rays.len());
    let mut secs = w.seconds;
    timed(&mut secs.intersect, || intersect::closest(ctx, w));
    timed(&mut secs.sort, || {
        let q = w.queues.as_mut().expect("queues");
        let last = q.shade.len() - 1;
        for &e in &w.shade {
            let i = sort::index(e) as usize;
            let material = intersect::hit_material(ctx.scene, &w.hits[i], &w.curve_hits[i]);
            w.materials[i] = material;
            let m = (material as usize).min(last);
            if q.shade[m].push(i as u32) && q.shade[m].len() == q.shade[m].capacity() {
                q.full_shade.push(m as u32);
            }
        }
        // The escaped paths: the only ones whose hit has an infinite distance (their hits are
        // still in L1 from the emission pass).
        q.ended.extend(w.rays.iter().copied().filter(|&i| w.hits[i as usize].t == f32::INFINITY));
    });
    w.seconds = secs;
    w.clock.lap(Phase::Shading);
}

/// Moves the paths of `batch` that the shade handler did not pass on (`passed_on` false) to
/// `ended`, and clears the flags.
fn end_unpassed(q: &mut QueueState, batch: impl Iterator<Item = u32>) {
    for i in batch {
        let passed = &mut q.passed_on[i as usize];
        if !*passed {
            q.ended.push(i);
        }
        *passed = false;
    }
}

/// Material `m`'s shade queue's handler: the sort keys (surfaces of textured hits), the radix sort,
/// then shading; continuations go to the ray queue, shadow rays to the occlusion queue, and paths
/// that stop here end.
fn flush_shade(ctx: &Context<'_, '_, impl Touch>, w: &mut Worker, m: usize, rays: &mut RayCounts) {
    let q = w.queues.as_mut().expect("queues");
    w.shade.clear();
    w.shade.extend(q.shade[m].as_slice().iter().map(|&i| sort::entry(0, i)));
    q.shade[m].clear();
    q.batches.shade.record(w.shade.len());
    let mut secs = w.seconds;
    // Without texels every key is 0 and the ray handler has recorded the materials: nothing to sort.
    if ctx.textured {
        timed(&mut secs.sort, || intersect::sort_keys(ctx, w));
        w.clock.lap(Phase::Shading);
        let n = w.shade.len();
        timed(&mut secs.sort, || sort::radix_sort_by_key(&mut w.shade, &mut w.scratch[..n]));
        w.clock.lap(Phase::Overhead);
    }
    timed(&mut secs.shade, || shade::shade(ctx, w, rays));
    let q = w.queues.as_mut().expect("queues");
    for &i in &w.next_rays {
        q.passed_on[i as usize] = true;
        q.rays.push(i);
    }
    end_unpassed(q, w.shade.iter().map(|&e| sort::index(e)));
    w.seconds = secs;
    w.clock.lap(Phase::Overhead);
}

/// The occlusion queue's handler (any hit, contributions added), then every ended path leaves: its
/// radiance is final, so it goes to the radiance queue (flushed into the film when full) and its
/// slot is free for a new camera path.
fn flush_occlusion(ctx: &Context<'_, '_, impl Touch>, w: &mut Worker, rays: &mut RayCounts) {
    let q = w.queues.as_mut().expect("queues");
    if !w.occlusion.is_empty() {
        q.batches.occlusion.record(w.occlusion.len());
        let mut secs = w.seconds;
        timed(&mut secs.occlusion, || occlusion::any_hit(ctx, w, rays));
        w.seconds = secs;
        w.clock.lap(Phase::Intersect);
    }
    let q = w.queues.as_mut().expect("queues");
    let QueueState { ended, free, path_slot, radiance, film, batches, .. } = q;
    let (states, first_hits) = (&w.states, &w.first_hits);
    timed(&mut w.seconds.accumulate, || {
        for &i in ended.iter() {
            let sample =
                FilmSample { radiance: states[i as usize].radiance, first_hit: first_hits[i as usize] };
            radiance.push_or_flush(Finished { slot: path_slot[i as usize], sample }, |batch| {
                batches.radiance.record(batch.len());
                accumulate::write_film(batch, film)
            });
            free.push(i);
        }
    });
    ended.clear();
    w.clock.lap(Phase::Overhead);
}
