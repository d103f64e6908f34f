//! What a render counts: [`RenderStats`] (rays, samples, stage and phase seconds, lane counters) and
//! the end-of-run [`Summary`] printed on stderr and optionally written as JSON.

use crate::path::RayCounts;
use serde::Serialize;

/// Render statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Rays by kind.
    pub rays: RayCounts,
    /// Camera samples taken.
    pub samples: u64,
    /// Samples discarded because their radiance was NaN or infinite.
    pub nonfinite_samples: u64,
    /// Wall-clock seconds of the render loop.
    pub seconds: f64,
    /// Worker threads used.
    pub threads: usize,
    /// Texel bytes in the blob.
    pub texture_bytes_total: u64,
    /// Bytes of the 4 KiB texel pages read at least once (0 unless `RenderOptions::texture_stats`).
    pub texture_bytes_touched: u64,
    /// Wavefront stage timers, summed over workers (zero for the scalar integrator).
    pub stages: StageSeconds,
    /// Wavefront work and lane counters (zero for the scalar integrator).
    pub counters: Counters,
    /// CPU seconds per phase, both integrators (zero unless `RenderOptions::phase_stats`).
    pub phases: PhaseSeconds,
    /// Material programs evaluated at path vertices.
    pub shader_evaluations: u64,
}

impl RenderStats {
    /// Adds a later pass of the same frame: counts and seconds add up; the thread count and texture
    /// totals are the pass's; bytes touched keep the largest pass's (pages read again are not new);
    /// non-finite samples are counted from the pixel sums by the caller.
    pub fn add_pass(&mut self, pass: &RenderStats) {
        self.rays.add(&pass.rays);
        self.samples += pass.samples;
        self.seconds += pass.seconds;
        self.threads = pass.threads;
        self.texture_bytes_total = pass.texture_bytes_total;
        self.texture_bytes_touched = self.texture_bytes_touched.max(pass.texture_bytes_touched);
        self.stages.add(&pass.stages);
        self.counters.add(&pass.counters);
        self.phases.add(&pass.phases);
        self.shader_evaluations += pass.shader_evaluations;
    }
}

/// Per-stage wall-clock seconds, summed over workers (so over threads: CPU-seconds).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct StageSeconds {
    /// Camera ray generation.
    pub generate: f64,
    /// Closest-hit queries (plus emission found along rays and the sort key).
    pub intersect: f64,
    /// Sort keys (the surface reconstruction of textured hits), radix sort and per-material bucketing
    /// of the shade queue.
    pub sort: f64,
    /// Shading, light and BSDF sampling, and the 8-lane MIS kernel.
    pub shade: f64,
    /// Any-hit shadow queries.
    pub occlusion: f64,
    /// Per-pixel accumulation.
    pub accumulate: f64,
}

impl StageSeconds {
    /// Adds `other` into `self`.
    pub fn add(&mut self, other: &StageSeconds) {
        self.generate += other.generate;
        self.intersect += other.intersect;
        self.sort += other.sort;
        self.shade += other.shade;
        self.occlusion += other.occlusion;
        self.accumulate += other.accumulate;
    }
}

/// What the wavefront did, for `--stats`: shader evaluations and how full the 8-lane kernels ran.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Counters {
    /// Eight-lane groups run through the BSDF kernels.
    pub bsdf_lane_groups: u64,
    /// Lanes of those groups holding a shading point (the rest idle at a chunk's end).
    pub bsdf_lanes_active: u64,
    /// Lanes of those groups holding a light sample (the light and MIS kernels' useful lanes).
    pub light_lanes_active: u64,
}

impl Counters {
    /// Adds `other` into `self`.
    pub fn add(&mut self, other: &Counters) {
        self.bsdf_lane_groups += other.bsdf_lane_groups;
        self.bsdf_lanes_active += other.bsdf_lanes_active;
        self.light_lanes_active += other.light_lanes_active;
    }
}

/// Figures of one `render` run.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Summary {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Worker threads.
    pub threads: usize,
    /// Camera rays.
    pub camera_rays: u64,
    /// Continuation rays (BSDF bounces and transparency pass-throughs).
    pub bounce_rays: u64,
    /// Shadow rays.
    pub shadow_rays: u64,
    /// All rays.
    pub rays: u64,
    /// Million rays per second of render time.
    pub mrays_per_second: f64,
    /// Million camera samples per second of render time.
    pub msamples_per_second: f64,
    /// Samples discarded as NaN/∞.
    pub nonfinite_samples: u64,
    /// Seconds mapping and validating the blob.
    pub load_seconds: f64,
    /// Seconds rendering.
    pub render_seconds: f64,
    /// Seconds writing outputs.
    pub write_seconds: f64,
    /// Texel bytes in the blob.
    pub texture_bytes_total: u64,
    /// Bytes of the texel pages the render read (counted only with `--stats`).
    pub texture_bytes_touched: u64,
    /// Integrator (`scalar` or `wavefront`).
    pub integrator: String,
    /// Wavefront CPU-seconds per stage (intersection, shading, sort/queue overhead; zero for scalar).
    pub stages: StageSeconds,
    /// Material programs evaluated at path vertices.
    pub shader_evaluations: u64,
    /// Million shader evaluations per second of render time.
    pub mshaders_per_second: f64,
    /// CPU seconds per phase, both integrators (only with `--stats`).
    pub phases: PhaseSeconds,
    /// The phases as percentages of their sum (only with `--stats`).
    pub phase_percent: PhaseSeconds,
    /// Wavefront: mean fraction of the 8 lanes the BSDF and throughput kernels ran full, in percent.
    pub bsdf_lane_utilisation: f64,
    /// Wavefront: mean fraction of the 8 lanes of the light (MIS) kernel holding a light sample, in
    /// percent.
    pub light_lane_utilisation: f64,
}

impl Summary {
    fn percent(p: &PhaseSeconds) -> PhaseSeconds {
        let total = p.total();
        if total <= 0.0 {
            return PhaseSeconds::default();
        }
        let f = |x: f64| 100.0 * x / total;
        PhaseSeconds {
            intersect: f(p.intersect),
            shading: f(p.shading),
            texturing: f(p.texturing),
            integration: f(p.integration),
            overhead: f(p.overhead),
        }
    }
}

impl Summary {
    /// Fills the render figures from `stats`; timings of the other phases are set by the caller.
    pub fn from_render(stats: &RenderStats, width: u32, height: u32, spp: u32) -> Self {
        let secs = stats.seconds.max(1e-9);
        Summary {
            width,
            height,
            spp,
            threads: stats.threads,
            camera_rays: stats.rays.camera,
            bounce_rays: stats.rays.bounce,
            shadow_rays: stats.rays.shadow,
            rays: stats.rays.total(),
            mrays_per_second: stats.rays.total() as f64 / secs / 1e6,
            msamples_per_second: stats.samples as f64 / secs / 1e6,
            nonfinite_samples: stats.nonfinite_samples,
            render_seconds: stats.seconds,
            texture_bytes_total: stats.texture_bytes_total,
            texture_bytes_touched: stats.texture_bytes_touched,
            stages: stats.stages,
            shader_evaluations: stats.shader_evaluations,
            mshaders_per_second: stats.shader_evaluations as f64 / secs / 1e6,
            phases: stats.phases,
            phase_percent: Self::percent(&stats.phases),
            bsdf_lane_utilisation: lane_percent(
                stats.counters.bsdf_lanes_active,
                stats.counters.bsdf_lane_groups,
            ),
            light_lane_utilisation: lane_percent(
                stats.counters.light_lanes_active,
                stats.counters.bsdf_lane_groups,
            ),
            ..Summary::default()
        }
    }

    /// A few human-readable lines.
    pub fn to_text(&self) -> String {
        format!(
            "{}x{} @ {} spp on {} threads\n\
             rays: {} ({} camera, {} bounce, {} shadow), {:.2} Mrays/s, {:.3} Msamples/s, \
             {:.3} M shader evaluations/s\n\
             time: load {:.3} s, render {:.3} s, write {:.3} s{}{}{}{}",
            self.width,
            self.height,
            self.spp,
            self.threads,
            self.rays,
            self.camera_rays,
            self.bounce_rays,
            self.shadow_rays,
            self.mrays_per_second,
            self.msamples_per_second,
            self.mshaders_per_second,
            self.load_seconds,
            self.render_seconds,
            self.write_seconds,
            if self.texture_bytes_total > 0 && self.texture_bytes_touched == 0 {
                // Page counting costs a shared-bitmap mark per texel fetch, so it runs only with --stats.
                format!(
                    "\ntextures: {:.1} MiB in the blob (pages touched are counted with --stats)",
                    self.texture_bytes_total as f64 / 1048576.0
                )
            } else if self.texture_bytes_total > 0 {
                format!(
                    "\ntextures: {:.1} MiB touched of {:.1} MiB ({:.1}%)",
                    self.texture_bytes_touched as f64 / 1048576.0,
                    self.texture_bytes_total as f64 / 1048576.0,
                    100.0 * self.texture_bytes_touched as f64 / self.texture_bytes_total as f64
                )
            } else {
                String::new()
            },
            {
                let s = &self.stages;
                let total = s.generate + s.intersect + s.sort + s.shade + s.occlusion + s.accumulate;
                if total > 0.0 {
                    format!(
                        "\nwavefront stages (CPU s): intersect {:.3}, occlusion {:.3}, shade {:.3}, \
                         queues/sort {:.3} (generate {:.3}, sort {:.3}, accumulate {:.3})",
                        s.intersect,
                        s.occlusion,
                        s.shade,
                        s.generate + s.sort + s.accumulate,
                        s.generate,
                        s.sort,
                        s.accumulate
                    )
                } else {
                    String::new()
                }
            },
            {
                let p = &self.phase_percent;
                if self.phases.total() > 0.0 {
                    format!(
                        "\nphases (% of {:.3} CPU s): intersection {:.1}, shading {:.1}, texturing {:.1}, \
                         integration {:.1}, overhead (camera, queues, sort, transpose, film) {:.1}{}",
                        self.phases.total(),
                        p.intersect,
                        p.shading,
                        p.texturing,
                        p.integration,
                        p.overhead,
                        if self.bsdf_lane_utilisation > 0.0 {
                            format!(
                                "\nSIMD lane utilisation: BSDF {:.1}%, light {:.1}%",
                                self.bsdf_lane_utilisation, self.light_lane_utilisation
                            )
                        } else {
                            String::new()
                        }
                    )
                } else {
                    String::new()
                }
            },
            if self.nonfinite_samples > 0 {
                format!("\nwarning: {} NaN/inf samples discarded", self.nonfinite_samples)
            } else {
                String::new()
            }
        )
    }
}

/// The phases of path tracing both integrators time alike (`--stats`, MoonRay's Table 2).
///
/// Checked without timers (320×213, 16 spp, one thread): perf samples of untimed renders put 28.7 %
/// (scalar) and 50.8 % (wavefront) of the shading-heavy bench scene's time in the BVH query
/// functions, 26.6 % and 48.6 % of the tractor's; the timed runs charge 33.7 % and 54.1 %, 35.8 %
/// and 52.1 % to [`Phase::Intersect`], which also holds ray set-up, the loops around the queries and
/// part of each lap's own cost. Before the scalar loop lapped after its BSDF sampling, that work
/// (and the light sampling of paths that cast no shadow ray) was charged to intersection: 45 % on
/// shading-heavy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// BVH queries: closest hits and shadow rays.
    Intersect,
    /// Emission the rays found (area lights crossed, lights at infinity for escaped rays), surface
    /// reconstruction, and material programs without texture reads.
    Shading,
    /// Material programs that read textures (the whole program: its texture reads dominate it).
    Texturing,
    /// Light sampling, BSDF construction, evaluation and sampling, MIS, Russian roulette, the
    /// sampler, pass-through and continuation rays.
    Integration,
    /// Everything else: camera rays, accumulation, and the wavefront's queues, sorting and
    /// AoS → SoA transposition.
    Overhead,
}

/// CPU seconds per [`Phase`], summed over threads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct PhaseSeconds {
    /// [`Phase::Intersect`].
    pub intersect: f64,
    /// [`Phase::Shading`].
    pub shading: f64,
    /// [`Phase::Texturing`].
    pub texturing: f64,
    /// [`Phase::Integration`].
    pub integration: f64,
    /// [`Phase::Overhead`].
    pub overhead: f64,
}

impl PhaseSeconds {
    /// Adds `other` into `self`.
    pub fn add(&mut self, other: &PhaseSeconds) {
        self.intersect += other.intersect;
        self.shading += other.shading;
        self.texturing += other.texturing;
        self.integration += other.integration;
        self.overhead += other.overhead;
    }
    /// The sum over phases.
    pub fn total(&self) -> f64 {
        self.intersect + self.shading + self.texturing + self.integration + self.overhead
    }
    fn slot(&mut self, phase: Phase) -> &mut f64 {
        match phase {
            Phase::Intersect => &mut self.intersect,
            Phase::Shading => &mut self.shading,
            Phase::Texturing => &mut self.texturing,
            Phase::Integration => &mut self.integration,
            Phase::Overhead => &mut self.overhead,
        }
    }
}

/// A lap timer over [`Phase`]s: each [`PhaseClock::lap`] charges the time since the previous lap to a
/// phase. Disabled (the default outside `--stats`), a lap is one predictable branch: timing every path
/// vertex costs a few percent, so speed is measured without it and the breakdown with it.
///
/// Laps read the CPU's time-stamp counter and add whole ticks; ticks become seconds once, when the
/// clock is read, at the rate the counter ran against [`std::time::Instant`] over the clock's life.
/// A lap by `Instant::now` cost ~30 ns on the 2-core VM (a vDSO `clock_gettime`) plus a float
/// conversion, against ~10 ns for `rdtsc`; the scalar integrator laps about six times per path vertex
/// (~350 ns of work), so the slower clock added ~40 % to its timed run and shifted its phase shares
/// towards the short phases. The counter is the kernel's own clock source on this machine (`tsc`:
/// invariant, synchronised across cores); elsewhere laps fall back to `Instant`.
#[derive(Clone, Copy, Debug)]
pub struct PhaseClock {
    enabled: bool,
    /// Ticks at the previous lap.
    last: u64,
    /// Ticks charged to each phase ([`Phase`] as index).
    ticks: [u64; 5],
    /// When the clock started, for the tick rate.
    started: (std::time::Instant, u64),
    /// Seconds merged in from other clocks.
    merged: PhaseSeconds,
    /// Material programs evaluated at path vertices.
    pub shader_evaluations: u64,
}

/// The lap clock's ticks: the time-stamp counter, or nanoseconds since the first call elsewhere.
#[inline(always)]
fn ticks() -> u64 {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: `rdtsc` exists on every x86_64 CPU and has no preconditions.
        unsafe { core::arch::x86_64::_rdtsc() }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        static EPOCH: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
        EPOCH.get_or_init(std::time::Instant::now).elapsed().as_nanos() as u64
    }
}

impl PhaseClock {
    /// A clock that times only if `enabled`.
    pub fn new(enabled: bool) -> Self {
        let now = ticks();
        PhaseClock {
            enabled,
            last: now,
            ticks: [0; 5],
            started: (std::time::Instant::now(), now),
            merged: PhaseSeconds::default(),
            shader_evaluations: 0,
        }
    }
    /// Whether laps are timed.
    #[inline]
    pub fn enabled(&self) -> bool {
        self.enabled
    }
    /// Charges the time since the previous lap to `phase`.
    #[inline]
    pub fn lap(&mut self, phase: Phase) {
        if self.enabled {
            let now = ticks();
            self.ticks[phase as usize] += now.wrapping_sub(self.last);
            self.last = now;
        }
    }
    /// Time charged so far (this clock's laps and the clocks merged into it).
    pub fn seconds(&self) -> PhaseSeconds {
        let mut seconds = self.merged;
        if self.ticks.iter().any(|&t| t > 0) {
            let elapsed = self.started.0.elapsed().as_secs_f64();
            let per_tick = elapsed / ticks().wrapping_sub(self.started.1).max(1) as f64;
            let mut own = PhaseSeconds::default();
            for phase in
                [Phase::Intersect, Phase::Shading, Phase::Texturing, Phase::Integration, Phase::Overhead]
            {
                *own.slot(phase) = self.ticks[phase as usize] as f64 * per_tick;
            }
            seconds.add(&own);
        }
        seconds
    }
    /// Adds `other`'s time and counts into `self`.
    pub fn merge(&mut self, other: &PhaseClock) {
        self.merged.add(&other.seconds());
        self.shader_evaluations += other.shader_evaluations;
    }
}

/// Whether `material`'s program reads a texture (its evaluation counts as [`Phase::Texturing`]).
pub fn reads_textures(view: &blob::SceneView, material: u32) -> bool {
    view.materials.get(material as usize).is_some_and(|m| {
        // In range: validated by `SceneView::parse`.
        let program = &view.shader_ops[m.program_start as usize..][..m.program_len as usize];
        program.iter().any(|op| op.kind == blob::op_kind::TEXTURE)
    })
}

/// `100 · active / (8 · groups)`, 0 without groups.
fn lane_percent(active: u64, groups: u64) -> f64 {
    if groups == 0 {
        0.0
    } else {
        100.0 * active as f64 / (8 * groups) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn laps_charge_elapsed_time_to_their_phase() {
        let mut clock = PhaseClock::new(true);
        std::thread::sleep(std::time::Duration::from_millis(20));
        clock.lap(Phase::Texturing);
        clock.lap(Phase::Intersect);
        let s = clock.seconds();
        assert!(s.texturing >= 0.019 && s.texturing < 1.0, "{s:?}");
        assert!(s.intersect < 0.005 && s.shading == 0.0 && s.overhead == 0.0, "{s:?}");
        let mut off = PhaseClock::new(false);
        off.lap(Phase::Shading);
        assert_eq!(off.seconds().total(), 0.0);
        off.merge(&clock);
        // The tick rate is measured again at each read: equal to rounding.
        let (merged, own) = (off.seconds(), clock.seconds());
        assert!((merged.texturing - own.texturing).abs() < 1e-3 * own.texturing, "{merged:?} {own:?}");
        assert_eq!(merged.shading, 0.0);
    }

    #[test]
    fn summary_reports_percentages_and_lane_use() {
        let stats = RenderStats {
            seconds: 2.0,
            shader_evaluations: 4_000_000,
            phases: PhaseSeconds {
                intersect: 1.0,
                shading: 0.5,
                texturing: 0.25,
                integration: 0.25,
                overhead: 0.0,
            },
            counters: Counters { bsdf_lane_groups: 10, bsdf_lanes_active: 60, light_lanes_active: 40 },
            ..RenderStats::default()
        };
        let s = Summary::from_render(&stats, 4, 4, 1);
        assert_eq!(s.mshaders_per_second, 2.0);
        assert_eq!(s.phase_percent.intersect, 50.0);
        assert_eq!(s.phase_percent.texturing, 12.5);
        assert_eq!(s.bsdf_lane_utilisation, 75.0);
        assert_eq!(s.light_lane_utilisation, 50.0);
        assert!(s.to_text().contains("intersection 50.0"), "{}", s.to_text());
        assert!(s.to_text().contains("BSDF 75.0%"), "{}", s.to_text());
    }
}
