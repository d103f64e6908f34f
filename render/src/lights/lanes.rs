//! Next-event light sampling ([`crate::lights::Lights::sample`], the scalar reference) for eight
//! shading points at once, inside the shading stage's lane pass over a scatter group (its inputs
//! are the group's columns, its outputs feed the BSDF and MIS kernels without a transposition).
//!
//! The selection list is laid out once per scene as a [`LightTable`]: one 80-byte record per light
//! (kind, radiance and the shape's vectors) and one per emissive triangle (vertices, normal,
//! emission, and everything `Lights::sample` derives from its distribution entry). Records rather
//! than one column per field: lanes pick lights by random index, so a record costs one or two cache
//! lines per lane where columns would cost one per field.
//!
//! The table also knows which kinds the scene has ([`LightTable::new`] keeps a kind mask), and
//! each group knows which kinds its lanes picked. The kernel runs in four steps over the lanes:
//! 1. selection, gathering each lane's record into AoSoA columns: the uniform pick 8-wide when every
//!    light is at infinity (the table is then `uniform`), else
//!    [`crate::lights::tree::LightSelector::select_lanes`] (the eight lanes' light-tree descents
//!    interleaved level by level, each lane `select`'s result, its probability kept for step 4's
//!    pdfs); then only the columns the scene's kinds read (a rect's or disk's axes and normal only
//!    when the scene has one), and for up to `BLEND_GATHER_MAX` lights by blending each light's
//!    record into the lanes that picked it (8-wide bit masks) rather than copying a record per
//!    lane; then, if a lane picked the emissive-triangle entry, a branchless binary search of the
//!    power CDF, eight lanes in step (`partition_point`'s index on the validated, non-decreasing CDF);
//! 2. the angle each lane's sampling needs (φ = 2πu₁ for domes, spheres and cones; the concentric
//!    disk's θ, computed only when a lane picked a disk);
//! 3. its cosine and sine, 8-wide on every lane ([`crate::trig::sin_cos_lanes`]: the polynomial
//!    `Lights::sample` calls too; lanes whose kind has no angle ignore theirs);
//! 4. straight-line arithmetic per lane, with the scalar code's IEEE operations in the same order
//!    (glam's `dot` is `(x·x' + y·y') + z·z'`, `normalize` multiplies by `1 / length`, `Vec3 / f32`
//!    divides each component), the kind choosing the result by select; LLVM vectorises it to 8-wide
//!    AVX2 under [`multiversion`]. Only the kinds the group picked: lights at infinity alone (the
//!    tractor's dome and sun: no shading-point arithmetic), spheres and points without the patches'
//!    points (groups of sphere lights alone), or every kind.
//!    Groups whose lanes all picked lights at infinity or sphere lights seen from outside take a
//!    fourth form, `cones`: every result is a direction in a cone, so the point on a light, its
//!    distance, cosine and area pdf are not computed.
//!
//! Each lane equals `Lights::sample` bit for bit (the tests check it on random points and samples for
//! every light kind). Textured emitters stay scalar: [`crate::scene::Scene::emission_at`] per lane
//! that sampled an emissive triangle, as the scalar integrator calls it, and `Lights::sample` itself
//! per lane that picked a textured dome (its map's CDF search and lookup).
//!
//! The descent stays one lane at a time (interleaved, [`crate::lights::tree`]): a lane-parallel
//! descent with gathered node records saved too little to keep a second copy of the importance
//! arithmetic; measurements: `docs/perf.md#light-sampling-lanes-lightslanesrs`.

use crate::lights::tree::LightSelector;
use crate::lights::{Lights, Shape};
use glam::Vec3;
use lanekit::saturating_i32;
use lanekit::{Lanes, Lanes3, U32Lanes, LANES, V};
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI, TAU};
use std::ops::{Add, Div, Sub};

/// A dome light.
pub const KIND_DOME: u32 = 0;
/// A distant light of angle 0 (a delta direction).
pub const KIND_DELTA: u32 = 1;
/// A distant light with a cone of directions.
pub const KIND_CONE: u32 = 2;
/// A point light (sphere with `treatAsPoint`).
pub const KIND_POINT: u32 = 3;
/// A sphere light.
pub const KIND_SPHERE: u32 = 4;
/// A rect light.
pub const KIND_RECT: u32 = 5;
/// A disk light.
pub const KIND_DISK: u32 = 6;
/// The entry standing for all emissive triangles.
pub const KIND_TRIANGLES: u32 = 7;

/// One entry of the selection list.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(16))]
struct LaneLight {
    kind: u32,
    radiance: [f32; 3],
    /// Centre, position, or the direction towards a distant light.
    center: [f32; 3],
    /// Rect/disk half-axis X.
    ex: [f32; 3],
    /// Rect/disk half-axis Y.
    ey: [f32; 3],
    /// Rect/disk emission normal.
    normal: [f32; 3],
    /// Sphere radius, rect/disk area, or a distant cone's 1 − cos θmax.
    scalar: f32,
}

/// One emissive triangle with what `Lights::sample` computes from it, computed the same way.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(16))]
struct LaneEmitter {
    a: [f32; 3],
    b: [f32; 3],
    c: [f32; 3],
    /// Unit normal (`normalize_or_zero` of the edge cross product).
    n: [f32; 3],
    /// Area over pmf: the area the solid-angle pdf divides by.
    area: f32,
    pmf: f32,
    /// The CDF before this entry, and at it.
    lo: f32,
    cdf: f32,
    /// Emitted radiance of the triangle's material.
    emission: [f32; 3],
    triangle: u32,
}

const _: () = assert!(std::mem::size_of::<LaneLight>() == 80 && std::mem::size_of::<LaneEmitter>() == 80);

/// The selection list in the kernel's layout.
#[derive(Clone, Debug, Default)]
pub struct LightTable {
    lights: Vec<LaneLight>,
    /// Bit `1 << kind` for every kind in `lights` (which columns the gather must fill).
    kinds: u32,
    /// The scalar light selection, run per lane.
    selector: LightSelector,
    /// Every light is at infinity and has a slot of the uniform choice, in list order: selection
    /// is then `((u · count) as usize).min(count − 1)` with one probability, 8-wide.
    uniform: bool,
    /// That probability when `uniform`.
    uniform_pmf: f32,
    /// The emissive triangles' CDF, contiguous for the search.
    cdf: Vec<f32>,
    emitters: Vec<LaneEmitter>,
}

impl LightTable {
    /// Lays out the lights of `lights`.
    pub fn new(lights: &Lights) -> Self {
        let records: Vec<LaneLight> = lights
            .lights()
            .iter()
            .map(|light| {
                let mut r = LaneLight { radiance: light.radiance.to_array(), ..LaneLight::default() };
                match light.shape {
                    // A textured dome's lanes are replaced by the scalar sample (`shade::scatter`).
                    Shape::Dome | Shape::TexturedDome { .. } => r.kind = KIND_DOME,
                    Shape::Distant { to_light, one_minus_cos_max } => {
                        r.kind = if one_minus_cos_max == 0.0 { KIND_DELTA } else { KIND_CONE };
                        r.center = to_light.to_array();
                        r.scalar = one_minus_cos_max;
                    }
                    Shape::Point { position } => {
                        r.kind = KIND_POINT;
                        r.center = position.to_array();
                    }
                    Shape::Sphere { center, radius } => {
                        r.kind = KIND_SPHERE;
                        r.center = center.to_array();
                        r.scalar = radius;
                    }
                    Shape::Rect { center, ex, ey, normal, area }
                    | Shape::Disk { center, ex, ey, normal, area } => {
                        r.kind =
                            if matches!(light.shape, Shape::Rect { .. }) { KIND_RECT } else { KIND_DISK };
                        (r.center, r.ex, r.ey, r.normal) =
                            (center.to_array(), ex.to_array(), ey.to_array(), normal.to_array());
                        r.scalar = area;
                    }
                    Shape::Triangles => r.kind = KIND_TRIANGLES,
                }
                r
            })
            .collect();
        let emissive = lights.emissive();
        let emitters = emissive
            .iter()
            .enumerate()
            .map(|(k, e)| {
                let [a, b, c] = lights.triangle_points(e.triangle);
                LaneEmitter {
                    a: a.to_array(),
                    b: b.to_array(),
                    c: c.to_array(),
                    n: (b - a).cross(c - a).normalize_or_zero().to_array(),
                    area: e.area / e.pmf.max(f32::MIN_POSITIVE),
                    pmf: e.pmf,
                    lo: if k == 0 { 0.0 } else { emissive[k - 1].cdf },
                    cdf: e.cdf,
                    emission: lights.triangle_emission(e.triangle).to_array(),
                    triangle: e.triangle,
                }
            })
            .collect();
        let selector = lights.selector().clone();
        let uniform = selector.is_uniform_over(records.len());
        LightTable {
            kinds: records.iter().fold(0, |m, r: &LaneLight| m | 1 << r.kind),
            lights: records,
            uniform_pmf: selector.infinite_pmf(),
            uniform,
            selector,
            cdf: emissive.iter().map(|e| e.cdf).collect(),
            emitters,
        }
    }

    /// True if there is nothing to sample.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }
}

lanekit::soa! {
    /// Eight shading points and their light-sample random numbers.
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct LightInputs for struct LightInput {
        /// Shading point.
        pub p: Vec3 as [f32; 3],
        /// Light choice.
        pub u_select: f32,
        /// Position (or direction) sample on the light.
        pub u: [f32; 2],
    }
}

lanekit::soa! {
    /// Eight light samples; lanes with `ok == 0` have none (`Lights::sample` returned `None`).
    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct LightSampleLanes for struct LightSampleLane {
        /// 1 where the sample exists.
        pub ok: bool,
        /// Unit direction towards the light.
        pub wi: Vec3 as [f32; 3],
        /// Distance to the sampled point (infinite for dome and distant lights).
        pub distance: f32,
        /// Incident radiance (irradiance or intensity over d² for delta lights).
        pub li: Vec3 as [f32; 3],
        /// Solid-angle pdf with the selection probability.
        pub pdf: f32,
        /// 1 for a delta light.
        pub delta: bool,
        /// The emissive triangle sampled, or [`blob::NONE`].
        pub triangle: u32,
        /// Barycentric weights of the triangle's vertices 1 and 2 at the sampled point.
        pub b: [f32; 2],
    }
}

/// Each lane's light record, gathered by the selection step.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct Gathered {
    kind: U32Lanes,
    radiance: Lanes3,
    /// Centre / position / direction, or a triangle's first vertex.
    center: Lanes3,
    /// Rect/disk X axis, or a triangle's second vertex.
    ex: Lanes3,
    /// Rect/disk Y axis, or a triangle's third vertex.
    ey: Lanes3,
    /// Rect/disk/triangle normal.
    normal: Lanes3,
    scalar: Lanes,
    /// The probability the light was selected with.
    sel: Lanes,
    /// `u[0]`, or for a triangle its value stretched within the chosen CDF bucket.
    u0: Lanes,
    triangle: U32Lanes,
}

/// `Frame::new(n).to_world(v)` (Duff et al. 2017), in its operation order.
#[inline(always)]
fn frame_to_world(n: V, v: V) -> V {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = V { x: 1.0 + sign * n.x * n.x * a, y: sign * b, z: -sign * n.x };
    let bt = V { x: b, y: sign + n.y * n.y * a, z: -n.y };
    t.scale(v.x).add(bt.scale(v.y)).add(n.scale(v.z))
}

/// Step 1 for the lanes that picked the emissive triangles: the CDF search and the record.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn pick_emitters(table: &LightTable, u0: &Lanes, g: &mut Gathered) {
    let cdf = &table.cdf;
    // `partition_point(|c| c <= choice)`: the same halving in step on every lane, so the loop count
    // depends on the CDF's length only.
    let mut base = [0usize; LANES];
    let mut size = cdf.len();
    while size > 1 {
        let half = size / 2;
        for k in 0..LANES {
            let mid = base[k] + half;
            base[k] = if cdf[mid] <= u0[k] { mid } else { base[k] };
        }
        size -= half;
    }
    for k in 0..LANES {
        if g.kind[k] != KIND_TRIANGLES {
            continue;
        }
        let choice = u0[k];
        let index = (base[k] + (cdf[base[k]] <= choice) as usize).min(cdf.len() - 1);
        let e = &table.emitters[index];
        let u = if e.pmf > 0.0 { ((choice - e.lo) / (e.cdf - e.lo)).clamp(0.0, 0.999_999_94) } else { 0.5 };
        for c in 0..3 {
            g.center[c][k] = e.a[c];
            g.ex[c][k] = e.b[c];
            g.ey[c][k] = e.c[c];
            g.normal[c][k] = e.n[c];
            g.radiance[c][k] = e.emission[c];
        }
        g.scalar[k] = e.area;
        g.u0[k] = u;
        g.triangle[k] = e.triangle;
    }
}

/// Bit of a kind in a kind mask.
const fn bit(kind: u32) -> u32 {
    1 << kind
}
/// The kinds at infinity: their samples need no shading point.
const AT_INFINITY: u32 = bit(KIND_DOME) | bit(KIND_DELTA) | bit(KIND_CONE);
/// The kinds sampled by a point on a patch (their records fill `ex`, `ey` and `normal`).
const PATCHES: u32 = bit(KIND_RECT) | bit(KIND_DISK) | bit(KIND_TRIANGLES);
/// Up to this many lights the gather blends each light's record into the lanes that picked it (a
/// few 8-wide blends per light) instead of copying a record per lane (scalar loads and stores).
const BLEND_GATHER_MAX: usize = 4;

/// Step 1 without the emissive triangles: each lane's light index and record, only the columns the
/// scene's kinds read (`ex`, `ey` and `normal` only for rects and disks: triangles fill them in
/// [`pick_emitters`]).
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn gather(
    table: &LightTable,
    inp: &LightInputs,
    g: &mut Gathered,
    heads: impl Fn(&[LaneLight], &U32Lanes, &mut Gathered),
) {
    let count = table.lights.len();
    let mut index = [0u32; LANES];
    if table.uniform {
        // `((u_select · count) as usize).min(count − 1)`: the cast saturates (NaN and negatives to 0).
        for k in 0..LANES {
            let picked = saturating_i32(inp.u_select[k] * count as f32).max(0) as u32;
            index[k] = picked.min(count as u32 - 1);
        }
        g.sel = [table.uniform_pmf; LANES];
    } else {
        // The tree's descents of the lanes, interleaved (each lane as `Lights::sample`'s).
        table.selector.select_lanes(&inp.p, &inp.u_select, &mut index, &mut g.sel);
    }
    let axes = table.kinds & (bit(KIND_RECT) | bit(KIND_DISK)) != 0;
    if count <= BLEND_GATHER_MAX {
        // Bit masks rather than `if hit { mine } else { column }`: LLVM turned that select into a
        // per-lane choice of the address to load from (scalar code, ~255 instructions per group
        // for the tractor's two lights); `and`/`andnot`/`or` on the bits stays 8-wide.
        let blend = |mine: f32, column: &mut f32, mask: u32| {
            *column = f32::from_bits((mine.to_bits() & mask) | (column.to_bits() & !mask));
        };
        for (j, r) in table.lights.iter().enumerate() {
            for k in 0..LANES {
                let mask = ((index[k] == j as u32) as u32).wrapping_neg();
                g.kind[k] = (r.kind & mask) | (g.kind[k] & !mask);
                for c in 0..3 {
                    blend(r.radiance[c], &mut g.radiance[c][k], mask);
                    blend(r.center[c], &mut g.center[c][k], mask);
                }
                blend(r.scalar, &mut g.scalar[k], mask);
                if axes {
                    for c in 0..3 {
                        blend(r.ex[c], &mut g.ex[c][k], mask);
                        blend(r.ey[c], &mut g.ey[c][k], mask);
                        blend(r.normal[c], &mut g.normal[c][k], mask);
                    }
                }
            }
        }
    } else {
        heads(&table.lights, &index, g);
        for k in 0..LANES {
            let r = &table.lights[index[k] as usize];
            g.scalar[k] = r.scalar;
            if axes {
                for c in 0..3 {
                    g.ex[c][k] = r.ex[c];
                    g.ey[c][k] = r.ey[c];
                    g.normal[c][k] = r.normal[c];
                }
            }
        }
    }
    g.u0 = inp.u[0];
    g.triangle = [blob::NONE; LANES];
}

/// Each lane's record's kind, radiance and centre into the columns, copied per lane.
#[inline(always)]
fn heads(lights: &[LaneLight], index: &U32Lanes, g: &mut Gathered) {
    for k in 0..LANES {
        let r = &lights[index[k] as usize];
        g.kind[k] = r.kind;
        for c in 0..3 {
            g.radiance[c][k] = r.radiance[c];
            g.center[c][k] = r.center[c];
        }
    }
}

/// [`heads`] as one 8×8 transposition: each lane's record's first 32 bytes (kind, radiance,
/// centre, and `ex.x`, unused) in one load, then the standard unpack/shuffle/permute
/// transposition into columns: 8 loads, 24 shuffles and 7 stores where the per-lane copy took 14
/// scalar loads and stores a lane ([`sample_lanes`] 17.64 → 16.57 M instructions on the
/// shading-heavy bench scene's 51 lights, callgrind 120×80, 8 spp). Bits are moved, never
/// computed on.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx")]
fn heads_avx(lights: &[LaneLight], index: &U32Lanes, g: &mut Gathered) {
    use std::arch::x86_64::*;
    const _: () =
        assert!(std::mem::offset_of!(LaneLight, center) == 16 && std::mem::size_of::<LaneLight>() >= 32);
    let row = |k: usize| {
        let r: *const LaneLight = &lights[index[k] as usize];
        // SAFETY: a `LaneLight` is `repr(C)` plain 4-byte fields, at least 32 bytes: the load reads
        // `kind`, `radiance`, `center` and `ex.x` of a record in bounds; unaligned.
        unsafe { _mm256_loadu_ps(r.cast()) }
    };
    let r: [__m256; LANES] = std::array::from_fn(row);
    let t: [__m256; LANES] = std::array::from_fn(|i| {
        let (a, b) = (r[i / 4 * 4 + i % 4 / 2 * 2], r[i / 4 * 4 + i % 4 / 2 * 2 + 1]);
        if i % 2 == 0 {
            _mm256_unpacklo_ps(a, b)
        } else {
            _mm256_unpackhi_ps(a, b)
        }
    });
    // `tt[4h + j]`: fields j and j + 4 of lanes 4h..4h + 4, in the low and high halves.
    let tt: [__m256; LANES] = std::array::from_fn(|i| {
        let (h, j) = (i / 4, i % 4);
        let (a, b) = (t[4 * h + j / 2], t[4 * h + j / 2 + 2]);
        if j % 2 == 0 {
            _mm256_shuffle_ps::<0x44>(a, b)
        } else {
            _mm256_shuffle_ps::<0xEE>(a, b)
        }
    });
    let column = |j: usize| {
        if j < 4 {
            _mm256_permute2f128_ps::<0x20>(tt[j], tt[4 + j])
        } else {
            _mm256_permute2f128_ps::<0x31>(tt[j - 4], tt[j])
        }
    };
    let store = |out: &mut Lanes, v: __m256| {
        // SAFETY: `out` is eight writable `f32`s; the store is unaligned.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), v) }
    };
    let mut kind = [0.0f32; LANES];
    store(&mut kind, column(0));
    g.kind = kind.map(f32::to_bits);
    for c in 0..3 {
        store(&mut g.radiance[c], column(1 + c));
        store(&mut g.center[c], column(4 + c));
    }
}

/// Step 4 of [`sample_lanes`] when every lane picked a dome or a distant light: the same operations
/// as the general loop's for those kinds. The triangle weights `b` stay zero (read only for
/// triangles).
#[inline(always)]
fn at_infinity(g: &Gathered, cos: &Lanes, sin: &Lanes, out: &mut LightSampleLanes) {
    for k in 0..LANES {
        let (kind, sel) = (g.kind[k], g.sel[k]);
        let u0 = g.u0[k];
        let (c, s) = (V::at(&g.center, k), g.scalar[k]);
        let z = 1.0 - 2.0 * u0;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let on_sphere = V { x: r * cos[k], y: r * sin[k], z };
        let one_minus_cos = u0 * s;
        let cos_theta = 1.0 - one_minus_cos;
        let sin_theta = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0).sqrt();
        let local = V { x: sin_theta * cos[k], y: sin_theta * sin[k], z: cos_theta };
        let cone_dir = frame_to_world(c, local).normalize();
        let (wi, pdf) = match kind {
            KIND_DOME => (on_sphere, sel / (4.0 * PI)),
            KIND_DELTA => (c, sel),
            _ => (cone_dir, sel / (TAU * s)),
        };
        V::at(&g.radiance, k).store(&mut out.li, k);
        wi.store(&mut out.wi, k);
        out.ok[k] = 1;
        out.distance[k] = f32::INFINITY;
        out.pdf[k] = pdf;
        out.delta[k] = (kind == KIND_DELTA) as u32;
        out.triangle[k] = g.triangle[k];
        out.b[0][k] = 0.0;
        out.b[1][k] = 0.0;
    }
}

/// [`Lights::sample`] on eight lanes; `table` must not be empty.
#[allow(clippy::needless_range_loop)]
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn sample_lanes(table: &LightTable, inp: &LightInputs, out: &mut LightSampleLanes) {
    // 1. Selection and gather, and the kinds this group picked.
    let mut g = Gathered::default();
    multiversion::target::match_target! {
        "x86_64+avx+avx2+fma" => gather(table, inp, &mut g, |lights, index, g| heads_avx(lights, index, g)),
        _ => gather(table, inp, &mut g, heads),
    }
    let mut group = 0u32;
    for k in 0..LANES {
        group |= bit(g.kind[k]);
    }
    if group & bit(KIND_TRIANGLES) != 0 {
        pick_emitters(table, &inp.u[0], &mut g);
    }

    // 2. The angle: the concentric disk's θ for disks, φ = 2πu₁ for everything else that has one.
    let mut angle = [0.0f32; LANES];
    for k in 0..LANES {
        angle[k] = TAU * inp.u[1][k];
    }
    if group & bit(KIND_DISK) != 0 {
        for k in 0..LANES {
            let (a, b) = (2.0 * g.u0[k] - 1.0, 2.0 * inp.u[1][k] - 1.0);
            let theta = if a.abs() > b.abs() { FRAC_PI_4 * (b / a) } else { FRAC_PI_2 - FRAC_PI_4 * (a / b) };
            angle[k] = if g.kind[k] == KIND_DISK { theta } else { angle[k] };
        }
    }
    // 3. Its cosine and sine, 8-wide on every lane (the kinds without an angle ignore theirs).
    let (mut cos, mut sin) = ([0.0f32; LANES], [0.0f32; LANES]);
    crate::trig::sin_cos_lanes(&angle, &mut sin, &mut cos);

    // 4. The arithmetic of the kinds this group picked: only lights at infinity (a scene lit by a
    // dome and a sun), no patches (spheres and points with them), or everything.
    if group & !AT_INFINITY == 0 {
        at_infinity(&g, &cos, &sin, out);
    } else if group & !(AT_INFINITY | bit(KIND_SPHERE)) == 0 && !inside_a_sphere(&g, inp) {
        cones(&g, inp, &cos, &sin, out);
    } else if group & PATCHES == 0 {
        every_kind::<false>(&g, inp, &cos, &sin, out);
    } else {
        every_kind::<true>(&g, inp, &cos, &sin, out);
    }
}

/// Whether a lane picked a sphere light from inside it (the test [`every_kind`] makes: such a lane
/// samples the sphere's surface, not its cone).
#[inline(always)]
fn inside_a_sphere(g: &Gathered, inp: &LightInputs) -> bool {
    let mut inside = false;
    for k in 0..LANES {
        let (p, c, s) = (V::at(&inp.p, k), V::at(&g.center, k), g.scalar[k]);
        let dc = c.sub(p);
        inside |= g.kind[k] == KIND_SPHERE && dc.dot(dc) <= s * s * (1.0 + 1e-4);
    }
    inside
}

/// What every kind's step 4 shares for one lane: the uniform direction on the unit sphere (the dome's,
/// a sphere's normal seen from inside), and the cone a distant light or a sphere seen from outside
/// subtends at `p`: a direction in it, its `1 − cos θmax`, and the distance to the sphere along that
/// direction (else along the axis); `dc2` is the squared distance to the centre.
struct ConeLane {
    on_sphere: V,
    dc2: f32,
    one_minus_cos_max: f32,
    cone_dir: V,
    cone_distance: f32,
}

/// [`ConeLane`] with the scalar code's operations (`uniform_sphere`, `sample_cone`, `ray_sphere`).
// `!(a < b)` as in the scalar `ray_sphere`: NaN does not return early.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
#[inline(always)]
fn cone_lane(distant: bool, p: V, (c, s): (V, f32), u0: f32, (cos, sin): (f32, f32)) -> ConeLane {
    // `uniform_sphere(u)`.
    let z = 1.0 - 2.0 * u0;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let on_sphere = V { x: r * cos, y: r * sin, z };

    // A sphere seen from outside: the cone it subtends.
    let dc = c.sub(p);
    let dc2 = dc.dot(dc);
    let sin2 = s * s / dc2;
    let cos_max = (1.0 - sin2).max(0.0).sqrt();
    let sphere_one_minus_cos_max = sin2 / (1.0 + cos_max);
    let sphere_axis = dc.div(dc2.sqrt());

    // `sample_cone`: a distant cone or a sphere's.
    let axis = V::select(distant, c, sphere_axis);
    let one_minus_cos_max = if distant { s } else { sphere_one_minus_cos_max };
    let one_minus_cos = u0 * one_minus_cos_max;
    let cos_theta = 1.0 - one_minus_cos;
    let sin_theta = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0).sqrt();
    let local = V { x: sin_theta * cos, y: sin_theta * sin, z: cos_theta };
    let cone_dir = frame_to_world(axis, local).normalize();

    // `ray_sphere(p, cone_dir, centre, radius)`, else the distance along the axis.
    let oc = p.sub(c);
    let b = oc.dot(cone_dir);
    let cc = oc.dot(oc) - s * s;
    let disc = b * b - cc;
    let sq = disc.sqrt();
    let q = if b > 0.0 { -b - sq } else { -b + sq };
    let (t0, t1) = (q, if q != 0.0 { cc / q } else { 0.0 });
    let (t0, t1) = if t0 > t1 { (t1, t0) } else { (t0, t1) };
    let sphere_hit = !(disc < 0.0) && (t0 > 0.0 || t1 > 0.0);
    let t = if t0 > 0.0 { t0 } else { t1 };
    let cone_distance = if sphere_hit { t } else { dc.dot(cone_dir) };
    ConeLane { on_sphere, dc2, one_minus_cos_max, cone_dir, cone_distance }
}

/// Step 4 of [`sample_lanes`] when every lane picked a light at infinity or a sphere seen from
/// outside: [`every_kind`]'s operations for those kinds only. Every lane's result is a direction in
/// a cone (a sphere's or a distant light's), the dome's uniform direction or the delta direction,
/// so the point on a light, its distance, its cosine and the area pdf (eight divisions and a
/// square root a lane) are not computed; `b` stays zero.
#[inline(always)]
fn cones(g: &Gathered, inp: &LightInputs, cos: &Lanes, sin: &Lanes, out: &mut LightSampleLanes) {
    for k in 0..LANES {
        let (kind, sel) = (g.kind[k], g.sel[k]);
        let centre = (V::at(&g.center, k), g.scalar[k]);
        let cone = cone_lane(kind == KIND_CONE, V::at(&inp.p, k), centre, g.u0[k], (cos[k], sin[k]));
        let (dome, delta, sphere) = (kind == KIND_DOME, kind == KIND_DELTA, kind == KIND_SPHERE);
        let wi = V::select(dome, cone.on_sphere, V::select(delta, centre.0, cone.cone_dir));
        let cone_pdf = sel / (TAU * cone.one_minus_cos_max);
        let pdf = if dome {
            sel / (4.0 * PI)
        } else if delta {
            sel
        } else {
            cone_pdf
        };
        V::at(&g.radiance, k).store(&mut out.li, k);
        wi.store(&mut out.wi, k);
        out.ok[k] = 1;
        out.distance[k] = if sphere { cone.cone_distance } else { f32::INFINITY };
        out.pdf[k] = pdf;
        out.delta[k] = delta as u32;
        out.triangle[k] = g.triangle[k];
        out.b[0][k] = 0.0;
        out.b[1][k] = 0.0;
    }
}

/// Step 4 of [`sample_lanes`]: every kind's formula with the scalar code's operations, the kind
/// selecting; without `PATCHES` (no lane picked a rect, disk or triangle) their points are not
/// computed and `b` stays zero.
#[inline(always)]
fn every_kind<const PATCHES: bool>(
    g: &Gathered,
    inp: &LightInputs,
    cos: &Lanes,
    sin: &Lanes,
    out: &mut LightSampleLanes,
) {
    for k in 0..LANES {
        let (kind, sel) = (g.kind[k], g.sel[k]);
        let p = V::at(&inp.p, k);
        let (u0, u1) = (g.u0[k], inp.u[1][k]);
        let (c, s) = (V::at(&g.center, k), g.scalar[k]);
        let radiance = V::at(&g.radiance, k);
        let distant = kind == KIND_CONE;
        let ConeLane { on_sphere, dc2, one_minus_cos_max, cone_dir, cone_distance } =
            cone_lane(distant, p, (c, s), u0, (cos[k], sin[k]));
        let inside = dc2 <= s * s * (1.0 + 1e-4);

        // A point on the light: rect, disk, triangle, the sphere from inside, or the point light.
        let x_sphere = c.add(on_sphere.scale(s));
        let (mut x, mut b1, mut b2) = (V::select(kind == KIND_SPHERE, x_sphere, c), 0.0, 0.0);
        if PATCHES {
            let (ex, ey) = (V::at(&g.ex, k), V::at(&g.ey, k));
            let (a, bb) = (2.0 * u0 - 1.0, 2.0 * u1 - 1.0);
            let x_rect = c.add(ex.scale(a)).add(ey.scale(bb));
            let centre = a == 0.0 && bb == 0.0;
            let rd = if a.abs() > bb.abs() { a } else { bb };
            let (da, db) = if centre { (0.0, 0.0) } else { (rd * cos[k], rd * sin[k]) };
            let x_disk = c.add(ex.scale(da)).add(ey.scale(db));
            let su = u0.sqrt();
            let b0 = 1.0 - su;
            (b1, b2) = (u1 * su, 1.0 - b0 - u1 * su);
            let x_triangle = c.scale(b0).add(ex.scale(b1)).add(ey.scale(b2));
            x = match kind {
                KIND_RECT => x_rect,
                KIND_DISK => x_disk,
                KIND_TRIANGLES => x_triangle,
                _ => x,
            };
        }
        let sphere = kind == KIND_SPHERE;
        let n = V::select(sphere, on_sphere, V::at(&g.normal, k));
        let area = if sphere { 4.0 * PI * s * s } else { s };
        let two_sided = sphere || kind == KIND_TRIANGLES;
        let to = x.sub(p);
        let d2 = to.dot(to);
        let distance = d2.sqrt();
        let wi_point = to.div(distance);
        let cos_light = -n.dot(wi_point);
        let cos_light = if two_sided { cos_light.abs() } else { cos_light };
        let area_ok = cos_light > 0.0 && distance > 0.0 && area > 0.0;
        let area_pdf = sel * d2 / (cos_light * area);

        // The kind's result.
        let on_area = matches!(kind, KIND_RECT | KIND_DISK | KIND_TRIANGLES) || (sphere && inside);
        let on_cone = distant || (sphere && !inside);
        let wi = match kind {
            KIND_DOME => on_sphere,
            KIND_DELTA => c,
            _ if on_cone => cone_dir,
            _ => wi_point,
        };
        let (ok, dist, pdf) = if on_area {
            (area_ok, distance, area_pdf)
        } else if on_cone {
            (true, if distant { f32::INFINITY } else { cone_distance }, sel / (TAU * one_minus_cos_max))
        } else {
            match kind {
                KIND_DOME => (true, f32::INFINITY, sel / (4.0 * PI)),
                KIND_DELTA => (true, f32::INFINITY, sel),
                _ => (distance > 0.0, distance, sel), // point
            }
        };
        let point = kind == KIND_POINT;
        V::select(point, radiance.div(d2), radiance).store(&mut out.li, k);
        wi.store(&mut out.wi, k);
        out.ok[k] = ok as u32;
        out.distance[k] = dist;
        out.pdf[k] = pdf;
        out.delta[k] = (point || kind == KIND_DELTA) as u32;
        out.triangle[k] = g.triangle[k];
        out.b[0][k] = b1;
        out.b[1][k] = b2;
    }
}

#[cfg(test)]
/// A scene with every light kind: dome, delta and cone distant lights, point, sphere, rect and disk
/// lights, and emissive triangles of three powers.
pub(crate) fn every_light_kind() -> scene_pack::Scene {
    use crate::testscene::{self, card, sphere};
    use glam::{Mat4, Vec3};
    use scene_pack::{Light as SceneLight, LightKind, Material, Scene};
    let at = |x: f32, y: f32, z: f32| Mat4::from_translation(Vec3::new(x, y, z));
    let light = |name: &str, kind: LightKind, radiance: f32, m: Mat4| SceneLight {
        path: format!("/{name}"),
        kind,
        radiance: Vec3::new(radiance, 0.8 * radiance, 0.6 * radiance),
        normalize: false,
        world_from_light: m,
    };
    let mut lamp = card(-0.2, 0.3, 1);
    lamp.positions.iter_mut().for_each(|p| *p += Vec3::new(0.0, 1.6, 0.0));
    let mut dim = card(0.4, 0.2, 2);
    dim.positions.iter_mut().for_each(|p| *p += Vec3::new(-1.0, 1.2, 0.0));
    let mut dark = card(0.1, 0.25, 3);
    dark.positions.iter_mut().for_each(|p| *p += Vec3::new(1.0, 1.4, 0.0));
    Scene {
        meshes: vec![
            card(-1.5, 3.0, 0),
            sphere(Vec3::new(0.0, 0.0, -0.5), 0.55, 8, 16, 0, false),
            lamp,
            dim,
            dark,
        ],
        materials: vec![
            testscene::lambert(0.6),
            Material { emissive_color: Vec3::new(4.0, 3.0, 2.0), ..testscene::lambert(0.2) },
            Material { emissive_color: Vec3::new(0.5, 1.0, 0.2), ..testscene::lambert(0.2) },
            Material { emissive_color: Vec3::new(0.05, 0.02, 0.1), ..testscene::lambert(0.2) },
        ],
        lights: vec![
            light("dome", LightKind::Dome, 0.3, Mat4::IDENTITY),
            light("sun", LightKind::Distant { angle_degrees: 3.0 }, 1.5, Mat4::from_rotation_x(-0.6)),
            light("delta", LightKind::Distant { angle_degrees: 0.0 }, 0.7, Mat4::from_rotation_y(0.4)),
            light("point", LightKind::Sphere { radius: 0.1, treat_as_point: true }, 20.0, at(-1.0, 1.0, 1.0)),
            light("sphere", LightKind::Sphere { radius: 0.3, treat_as_point: false }, 3.0, at(1.2, 0.8, 1.2)),
            light("rect", LightKind::Rect { width: 0.6, height: 0.4 }, 2.5, at(0.0, 1.2, 1.5)),
            light("disk", LightKind::Disk { radius: 0.3 }, 2.0, at(-0.8, 0.6, 1.6)),
        ],
        cameras: vec![testscene::camera_looking_down_z(Vec3::new(0.0, 0.3, 4.0), 18.0)],
        default_camera: Some(0),
        meters_per_unit: 1.0,
        ..Scene::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::hash_u32;
    use crate::testscene;
    use glam::Vec3;

    /// The 8×8 transposition of the records' heads gives the per-lane copy's columns bit for bit,
    /// on random records (kinds 0..7 are subnormal as `f32` bits: moved, never flushed) and random
    /// picks with repeats.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn transposed_heads_equal_the_per_lane_copy() {
        if !lanekit::cpu::has_avx() {
            eprintln!("no AVX: nothing to compare");
            return;
        }
        let mut state = 11u32;
        let mut next = || {
            state = hash_u32(state);
            state
        };
        let lights: Vec<LaneLight> = (0..37)
            .map(|_| LaneLight {
                kind: next() % 8,
                radiance: [0; 3].map(|_| f32::from_bits(next())),
                center: [0; 3].map(|_| f32::from_bits(next())),
                ex: [0; 3].map(|_| f32::from_bits(next())),
                ..Default::default()
            })
            .collect();
        for _ in 0..2_000 {
            let index: U32Lanes = std::array::from_fn(|_| next() % lights.len() as u32);
            let (mut want, mut got) = (Gathered::default(), Gathered::default());
            heads(&lights, &index, &mut want);
            // SAFETY: the CPU has AVX (checked above).
            unsafe { heads_avx(&lights, &index, &mut got) };
            assert_eq!(got.kind, want.kind, "{index:?}");
            for c in 0..3 {
                assert_eq!(
                    got.radiance[c].map(f32::to_bits),
                    want.radiance[c].map(f32::to_bits),
                    "{index:?}"
                );
                assert_eq!(got.center[c].map(f32::to_bits), want.center[c].map(f32::to_bits), "{index:?}");
            }
        }
    }

    struct Rng(u32);
    impl Rng {
        fn f(&mut self) -> f32 {
            self.0 = hash_u32(self.0);
            (self.0 >> 8) as f32 / 16_777_216.0
        }
    }

    /// Bits, with every NaN one value (IEEE leaves a NaN's sign and payload open).
    fn bits(v: Vec3) -> [u32; 3] {
        v.to_array().map(|x| if x.is_nan() { u32::MAX } else { x.to_bits() })
    }

    /// `every_light_kind` with only the lights named in `keep`, and without its emissive
    /// triangles unless `emitters`.
    fn some_light_kinds(keep: &[&str], emitters: bool) -> scene_pack::Scene {
        let mut scene = every_light_kind();
        scene.lights.retain(|l| keep.contains(&&l.path[1..]));
        if !emitters {
            scene.materials.iter_mut().for_each(|m| m.emissive_color = Vec3::ZERO);
        }
        scene
    }

    /// Runs the kernel on `rounds` groups of random shading points (3 % of them from `special`) and
    /// samples, one round in five with every lane on the same light, and asserts every lane equals
    /// `Lights::sample` bit for bit. Returns the samples per light and the uniform rounds per light.
    fn assert_lanes_equal_scalar(
        scene: &scene_pack::Scene,
        special: &[Vec3],
        rounds: usize,
        on_sample: &mut dyn FnMut(usize, Vec3),
    ) -> (Vec<u32>, Vec<u32>) {
        let bytes = testscene::bytes(scene);
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let lights = Lights::new(&view);
        let n = lights.lights().len();
        let table = LightTable::new(&lights);
        let mut rng = Rng(11 + n as u32);
        let (mut per_light, mut uniform) = (vec![0u32; n], vec![0u32; n]);
        for round in 0..rounds {
            let mut inp = LightInputs::default();
            let mut points = [Vec3::ZERO; LANES];
            for k in 0..LANES {
                let p = if !special.is_empty() && rng.f() < 0.03 {
                    special[(rng.f() * special.len() as f32) as usize % special.len()]
                } else {
                    Vec3::new(4.0 * rng.f() - 2.0, 3.0 * rng.f() - 1.0, 4.0 * rng.f() - 2.0)
                };
                points[k] = p;
                (inp.p[0][k], inp.p[1][k], inp.p[2][k]) = (p.x, p.y, p.z);
                inp.u_select[k] = rng.f();
                for u in &mut inp.u {
                    u[k] = match rng.f() {
                        r if r < 0.02 => 0.0,
                        r if r < 0.04 => 0.5,
                        _ => rng.f(),
                    };
                }
            }
            if round % 5 == 0 {
                let pick = rng.f();
                inp.u_select = [pick; LANES];
                uniform[lights.selector().select(points[0], pick).0] += 1;
            }
            let mut out = LightSampleLanes::default();
            sample_lanes(&table, &inp, &mut out);
            for (k, p) in points.iter().enumerate() {
                let u = [inp.u[0][k], inp.u[1][k]];
                let scalar = lights.sample(*p, inp.u_select[k], u);
                let index = lights.selector().select(*p, inp.u_select[k]).0;
                assert_eq!(out.ok[k] != 0, scalar.is_some(), "exists, lane {k}: p {p} u {u:?} light {index}");
                let Some(ls) = scalar else { continue };
                per_light[index] += 1;
                on_sample(index, *p);
                let at = |c: &Lanes3| Vec3::new(c[0][k], c[1][k], c[2][k]);
                let what = format!("lane {k}: p {p} u {u:?} light {index}");
                assert_eq!(bits(at(&out.wi)), bits(ls.wi), "wi, {what}");
                assert_eq!(bits(at(&out.li)), bits(ls.li), "li, {what}");
                assert_eq!(
                    bits(Vec3::splat(out.distance[k])),
                    bits(Vec3::splat(ls.distance)),
                    "distance, {what}"
                );
                assert_eq!(bits(Vec3::splat(out.pdf[k])), bits(Vec3::splat(ls.pdf)), "pdf, {what}");
                assert_eq!(out.delta[k] != 0, ls.delta, "delta, {what}");
                let emitter =
                    (out.triangle[k] != blob::NONE).then(|| (out.triangle[k], [out.b[0][k], out.b[1][k]]));
                assert_eq!(
                    emitter.map(|(t, b)| (t, b.map(f32::to_bits))),
                    ls.emitter.map(|(t, b)| (t, b.map(f32::to_bits))),
                    "emitter, {what}"
                );
            }
        }
        (per_light, uniform)
    }

    /// Eight entries (more than `BLEND_GATHER_MAX`): records copied per lane; groups of lights at
    /// infinity only, of spheres and points without patches, and of everything.
    #[test]
    fn lanes_equal_the_scalar_light_sample_bit_for_bit() {
        // Special points: a sphere's centre and inside it, the point light's position, a rect's centre.
        let special = [
            Vec3::new(1.2, 0.8, 1.2),
            Vec3::new(1.1, 0.9, 1.1),
            Vec3::new(1.25, 0.75, 1.3),
            Vec3::new(-1.0, 1.0, 1.0),
            Vec3::new(0.0, 1.2, 1.5),
        ];
        let mut inside_sphere = 0;
        let (per_kind, uniform) =
            assert_lanes_equal_scalar(&every_light_kind(), &special, 4000, &mut |index, p| {
                // A sphere seen from inside samples its surface, from outside its cone.
                inside_sphere += (index == 4 && (p - Vec3::new(1.2, 0.8, 1.2)).length() <= 0.3) as u32;
            });
        eprintln!("samples per light {per_kind:?}, uniform rounds {uniform:?}");
        assert_eq!(per_kind.len(), 8, "seven UsdLux lights and the emissive triangles");
        // The light tree gives the one-sided rect and disk fewer samples: most points are behind them.
        assert!(per_kind.iter().all(|&n| n > 200), "every kind sampled often: {per_kind:?}");
        assert!(inside_sphere > 20, "{inside_sphere} samples from inside the sphere light");
        // Rounds whose first lane picked each light with one `u_select` on every lane.
        assert!(uniform.iter().all(|&n| n > 5), "rounds of one light on every lane: {uniform:?}");
    }

    /// A sphere light with a dome, a sun and a delta light (the bench scene's kinds): groups of
    /// lights at infinity and spheres seen from outside take the cone-only step 4 ([`cones`]),
    /// groups with a lane inside the sphere [`every_kind`]; every lane equals the scalar sample bit
    /// for bit.
    #[test]
    fn lanes_equal_the_scalar_sample_with_spheres_and_lights_at_infinity() {
        let scene = some_light_kinds(&["dome", "sun", "delta", "sphere"], false);
        let centre = Vec3::new(1.2, 0.8, 1.2);
        let special = [centre, Vec3::new(1.1, 0.9, 1.1), Vec3::new(1.25, 0.75, 1.3)];
        let (mut inside, mut outside) = (0, 0);
        let (per_light, _) = assert_lanes_equal_scalar(&scene, &special, 3000, &mut |index, p| {
            let within = (p - centre).length() <= 0.3;
            inside += (index == 3 && within) as u32;
            outside += (index == 3 && !within) as u32;
        });
        assert_eq!(per_light.len(), 4);
        assert!(per_light.iter().all(|&n| n > 2000), "{per_light:?}");
        assert!(inside > 20 && outside > 2000, "sphere samples from inside {inside}, outside {outside}");
    }

    /// `every_light_kind` plus 120 sphere, rect, disk and point lights around the scene.
    fn many_lights() -> scene_pack::Scene {
        use scene_pack::{Light as SceneLight, LightKind};
        let mut scene = every_light_kind();
        let mut rng = Rng(99);
        for i in 0..120 {
            let c = Vec3::new(6.0 * rng.f() - 3.0, 3.0 * rng.f() - 0.5, 6.0 * rng.f() - 3.0);
            let kind = match i % 4 {
                0 => LightKind::Sphere { radius: 0.05 + 0.1 * rng.f(), treat_as_point: false },
                1 => LightKind::Rect { width: 0.2 + 0.3 * rng.f(), height: 0.2 },
                2 => LightKind::Disk { radius: 0.1 + 0.2 * rng.f() },
                _ => LightKind::Sphere { radius: 0.1, treat_as_point: true },
            };
            let turn =
                glam::Mat4::from_rotation_x(6.0 * rng.f()) * glam::Mat4::from_rotation_y(6.0 * rng.f());
            scene.lights.push(SceneLight {
                path: format!("/many_{i}"),
                kind,
                radiance: Vec3::new(1.0 + 9.0 * rng.f(), 2.0, 1.0),
                normalize: i % 3 == 0,
                world_from_light: glam::Mat4::from_translation(c) * turn,
            });
        }
        scene
    }

    /// A many-light table: lanes descend the light tree to different depths and pick different
    /// lights; each equals the scalar sample bit for bit.
    #[test]
    fn lanes_equal_the_scalar_sample_with_many_lights() {
        let (per_light, _) = assert_lanes_equal_scalar(&many_lights(), &[], 3000, &mut |_, _| {});
        let used = per_light.iter().filter(|&&n| n > 0).count();
        assert_eq!(per_light.len(), 128, "127 UsdLux lights and the emissive triangles");
        assert!(used > 110, "only {used} lights sampled");
    }

    /// Whole images under 127 lights and emissive triangles: light-tree selection in the lane
    /// kernel, its pmf in the MIS of the emission BSDF rays meet (the ray-lane emission kernel), and
    /// the wavefront image equals the scalar one bit for bit.
    #[test]
    fn wavefront_equals_scalar_with_many_lights() {
        let bytes = testscene::bytes(&many_lights());
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let options = crate::RenderOptions {
            spp: 4,
            resolution: Some([32, 32]),
            tile_size: 16,
            max_depth: 4,
            ..crate::RenderOptions::default()
        };
        let (scalar, wave) =
            crate::wavefront::equivalence_tests::both_integrators(&view, &options, "many lights");
        let mean = scalar.beauty.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / 1024.0;
        assert!(mean > 0.05, "lit, mean luminance {mean}");
        assert!(wave.stats.counters.light_lanes_active > 0);
    }

    /// A dome and a sun (the tractor's lights): the blended gather and the path for lights at
    /// infinity, with a delta and a cone distant light.
    #[test]
    fn lanes_equal_the_scalar_sample_with_a_dome_and_distant_lights() {
        for keep in [&["dome", "sun"][..], &["dome", "delta"], &["sun"], &["dome", "sun", "delta"]] {
            let scene = some_light_kinds(keep, false);
            let (per_light, _) = assert_lanes_equal_scalar(&scene, &[], 1500, &mut |_, _| {});
            assert_eq!(per_light.len(), keep.len(), "{keep:?}");
            assert!(per_light.iter().all(|&n| n > 2000), "{keep:?}: {per_light:?}");
            let table = LightTable::new(&Lights::new(
                &blob::SceneView::parse(&testscene::bytes(&scene)).expect("valid blob"),
            ));
            assert_eq!(table.kinds & !AT_INFINITY, 0, "{keep:?}: only kinds at infinity");
        }
    }

    /// Up to four entries with patches among them: the blended gather of the rect and disk axes,
    /// the emissive triangles' search, and groups with and without patches.
    #[test]
    fn lanes_equal_the_scalar_sample_with_few_lights_and_patches() {
        let cases: [(&[&str], bool); 3] = [
            (&["dome", "rect", "sphere"], true),
            (&["disk", "point", "sun"], false),
            (&["rect", "disk"], true),
        ];
        for (keep, emitters) in cases {
            let scene = some_light_kinds(keep, emitters);
            let (per_light, uniform) = assert_lanes_equal_scalar(&scene, &[], 1500, &mut |_, _| {});
            let entries = keep.len() + emitters as usize;
            assert!(entries <= BLEND_GATHER_MAX);
            assert_eq!(per_light.len(), entries, "{keep:?}");
            // The light tree gives the one-sided rect few points in front of it.
            assert!(per_light.iter().all(|&n| n > 200), "{keep:?}: {per_light:?}");
            assert!(uniform.iter().all(|&n| n > 3), "{keep:?}: {uniform:?}");
        }
    }

    /// Whole images through each gather and step-4 path: a dome and a sun (lights at infinity
    /// only), a delta light alone, and few lights with patches and emissive triangles; the
    /// wavefront image equals the scalar one bit for bit.
    #[test]
    fn wavefront_equals_scalar_with_few_lights() {
        use crate::RenderOptions;
        let cases: [(&[&str], bool); 3] =
            [(&["dome", "sun"], false), (&["delta"], false), (&["dome", "rect", "sphere"], true)];
        for (keep, emitters) in cases {
            let bytes = testscene::bytes(&some_light_kinds(keep, emitters));
            let view = blob::SceneView::parse(&bytes).expect("valid blob");
            let options = RenderOptions {
                spp: 8,
                resolution: Some([32, 32]),
                tile_size: 16,
                max_depth: 5,
                ..RenderOptions::default()
            };
            let (scalar, wave) =
                crate::wavefront::equivalence_tests::both_integrators(&view, &options, &format!("{keep:?}"));
            let mean = scalar.beauty.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / 1024.0;
            assert!(mean > 0.01, "{keep:?}: lit, mean luminance {mean}");
            assert!(wave.stats.counters.light_lanes_active > 0, "{keep:?}");
        }
    }

    #[test]
    fn cdf_search_finds_the_partition_point() {
        let mut rng = Rng(5);
        for len in [1usize, 2, 3, 7, 8, 9, 64, 100] {
            // Non-decreasing, with repeated entries (zero-pmf triangles) and an exact 1 at the end.
            let mut cdf: Vec<f32> = (0..len).map(|_| if rng.f() < 0.3 { 0.0 } else { rng.f() }).collect();
            for i in 1..len {
                cdf[i] = cdf[i].max(cdf[i - 1]);
            }
            cdf[len - 1] = 1.0;
            let emitters = cdf
                .iter()
                .enumerate()
                .map(|(i, _)| LaneEmitter {
                    triangle: i as u32,
                    pmf: 1.0,
                    cdf: 1.0,
                    ..LaneEmitter::default()
                })
                .collect();
            let table = LightTable { lights: vec![], cdf: cdf.clone(), emitters, ..LightTable::default() };
            for _ in 0..200 {
                let mut u0 = [0.0f32; LANES];
                for (k, u) in u0.iter_mut().enumerate() {
                    *u = match k {
                        0 => cdf[(rng.f() * len as f32) as usize % len],
                        1 => 0.0,
                        _ => rng.f(),
                    };
                }
                let mut g = Gathered { kind: [KIND_TRIANGLES; LANES], ..Gathered::default() };
                pick_emitters(&table, &u0, &mut g);
                for (&triangle, &u) in g.triangle.iter().zip(&u0) {
                    let expected = cdf.partition_point(|&c| c <= u).min(len - 1);
                    assert_eq!(triangle as usize, expected, "cdf {cdf:?} choice {u}");
                }
            }
        }
    }
}
