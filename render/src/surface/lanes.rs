//! Surface reconstruction for up to eight triangle hits at once: [`Scene::surface`] in lanes.
//!
//! A gather loop reads, per lane, the triangle's vertex indices, positions, normals and uvs and the
//! instance's transforms (scalar loads into `[f32; 8]` columns); lane loops then move instanced
//! vertices to world space, interpolate the point, build the geometric normal (cross, normalize,
//! flip towards `wo`), the shading normal (interpolate, instance normal transform, normalize, the
//! facing fallbacks), uv, `dp/du`, `dp/dv` and the ray cone's uv footprint (with the head-on
//! fallback axis `Frame::new(d).t` computed in lanes too). Every branch of the scalar code is a
//! per-lane select, and each part only runs when some lane of the group needs it (no uvs, no
//! normals, no instance: skipped). The arithmetic is the scalar code's (`triangle_surface` in
//! [`crate::surface`]) IEEE operation for IEEE operation, in the same order, using glam 0.34's
//! formulas: `dot` is `(x·x' + y·y') + z·z'`, `cross` is `(y·z' − y'·z, z·x' − z'·x, x·y' − x'·y)`,
//! `try_normalize` multiplies by `1 / sqrt(v·v)` when that is finite and positive, `Vec3 / f32`
//! divides each component; Rust never contracts into FMAs. So every lane equals [`Scene::surface`]
//! bit for bit (tested on random hits below).
//!
//! An earlier lane version lost (1.8× the instructions of the scalar calls it replaced): it ran
//! every branch in every lane whether or not a lane needed it, called the accel's out-of-line
//! vertex and normal helpers per lane, built the fallback axis per lane with a scalar call, and
//! always filled eight lanes. This one gates each part on the group, keeps the lane loops free of
//! calls and branches so that LLVM vectorises them 8-wide in the AVX2 clone (`vmulps`, `vdivps`,
//! `vsqrtps`, `vblendvps` on `ymm`; the only calls left are the bounds-check panics), and leaves
//! groups of [`MIN_LANES`]` − 1` hits or fewer to the scalar function.
//!
//! Used by the sort-key pass (textured hits, whose surfaces are kept for shading;
//! `wavefront/intersect.rs`) and by shading's runs for the hits it did not keep (`wavefront/shade.rs`).
//! The kernel's columns live in the worker (one [`HitGroup`], ~2.5 KiB), not on the stack: zeroed
//! per call they were two `memset`s per group, and per stage ~1 M instructions on shading-heavy.
//!
//! The gather runs in AVX2 ([`avx2::gather`], chosen at run time: 31 eight-lane gathers by byte
//! offset, optional attributes masked by the lanes' mesh flags); the portable gather is the fallback,
//! and both are tested against the scalar function. Instance transforms are still read per instanced
//! lane (`gather_instance`). measurements: `docs/perf.md#surface-lanes-surfacelanesrs`.

// Lane loops index several columns by the same lane number.
#![allow(clippy::needless_range_loop)]

use crate::accel::Hit;
use crate::scene::Scene;
use crate::shading::{MeshPoint, UvFootprint};
use crate::surface::Surface;
use glam::Vec3;
use lanekit::{Lanes, Lanes3, U32Lanes, LANES, V};

type Lanes2 = [Lanes; 2];

/// Groups smaller than this are built by the scalar [`Scene::surface`], one call per hit: the
/// lane kernel's fixed cost (gather setup, eight-lane arithmetic) does not pay for one or two hits.
pub const MIN_LANES: usize = 3;

/// Up to eight triangle hits waiting for their surfaces, with the direction towards each ray's
/// origin and its ray cone's width at the hit, and the kernel's working columns.
///
/// Reused group after group (one per stage): the columns (~2.5 KiB) are not cleared per group.
/// Cleared per call, they were two `memset` calls per group (+1.9 M instructions on the
/// shading-heavy bench scene); the kernel writes every column it reads for the group's lanes, and
/// what it computes in the other lanes from stale values is never read.
#[derive(Clone, Copy, Debug)]
pub struct HitGroup {
    hits: [Hit; LANES],
    wo: [Vec3; LANES],
    footprint: Lanes,
    len: usize,
    gathered: Gathered,
    out: Columns,
}

impl Default for HitGroup {
    fn default() -> Self {
        let none = Hit { t: 0.0, triangle: blob::NONE, b1: 0.0, b2: 0.0, instance: blob::NONE, time: 0.0 };
        HitGroup {
            hits: [none; LANES],
            wo: [Vec3::ZERO; LANES],
            footprint: [0.0; LANES],
            len: 0,
            gathered: Gathered::default(),
            out: Columns::default(),
        }
    }
}

impl HitGroup {
    /// Adds a triangle hit seen along `-wo` by a cone of width `footprint` there (lane `self.len()`).
    #[inline]
    pub fn push(&mut self, hit: &Hit, wo: Vec3, footprint: f32) {
        let k = self.len;
        (self.hits[k], self.wo[k], self.footprint[k]) = (*hit, wo, footprint);
        self.len += 1;
    }

    /// Hits in the group.
    #[inline]
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when the group holds no hit.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// True when the group holds eight hits.
    #[inline]
    pub fn is_full(&self) -> bool {
        self.len == LANES
    }

    /// Empties the group (its lanes are overwritten by the next pushes).
    #[inline]
    pub fn clear(&mut self) {
        self.len = 0;
    }
}

/// Calls `emit(k, scene.surface(hit k, …))` for every hit of `group`, in lane order: in lanes
/// ([`surface_columns`]) for groups of [`MIN_LANES`] or more, else by the scalar function.
#[inline]
pub fn surfaces(scene: &Scene, group: &mut HitGroup, emit: impl FnMut(usize, Option<Surface>)) {
    surfaces_with(scene, group, Gather::detect(), emit)
}

/// How the kernel reads its inputs into columns.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Gather {
    /// Lane by lane, scalar loads and stores.
    Portable,
    /// With AVX2 gathers ([`avx2::gather`]); only chosen where the CPU has AVX2.
    #[cfg(target_arch = "x86_64")]
    Avx2,
}

impl Gather {
    /// The fastest gather this CPU runs (std caches the feature test: one load per call).
    #[inline]
    fn detect() -> Gather {
        #[cfg(target_arch = "x86_64")]
        if lanekit::cpu::has_avx2() {
            return Gather::Avx2;
        }
        Gather::Portable
    }
}

/// [`surfaces`] with the kernel's inputs read by `gather`.
#[inline]
fn surfaces_with(
    scene: &Scene,
    group: &mut HitGroup,
    gather: Gather,
    mut emit: impl FnMut(usize, Option<Surface>),
) {
    if group.len < MIN_LANES {
        for k in 0..group.len {
            emit(k, scene.surface(&group.hits[k], group.wo[k], group.footprint[k]));
        }
        return;
    }
    surface_columns(scene, group, gather);
    for k in 0..group.len {
        emit(k, group.out.surface(&group.hits[k], k));
    }
}

/// The lane kernel's results, one column per scalar.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct Columns {
    p: Lanes3,
    ng: Lanes3,
    ns: Lanes3,
    uv: Lanes2,
    duv_dx: Lanes2,
    duv_dy: Lanes2,
    dpdu: Lanes3,
    dpdv: Lanes3,
    /// Non-zero where the triangle is not degenerate.
    valid: U32Lanes,
    /// Non-zero where the mesh has uvs.
    has_uv: U32Lanes,
    material: U32Lanes,
}

impl Columns {
    /// Lane `k` as a [`Surface`] for `hit`: `None` for a degenerate triangle.
    #[inline(always)]
    fn surface(&self, hit: &Hit, k: usize) -> Option<Surface> {
        if self.valid[k] == 0 {
            return None;
        }
        let at = |c: &Lanes3| Vec3::new(c[0][k], c[1][k], c[2][k]);
        let point = Some(MeshPoint { triangle: hit.triangle, b1: hit.b1, b2: hit.b2 });
        let (uv, dpdu, dpdv) = if self.has_uv[k] != 0 {
            let uv = UvFootprint {
                uv: [self.uv[0][k], self.uv[1][k]],
                duv_dx: [self.duv_dx[0][k], self.duv_dx[1][k]],
                duv_dy: [self.duv_dy[0][k], self.duv_dy[1][k]],
                has_uv: true,
                point,
            };
            (uv, at(&self.dpdu), at(&self.dpdv))
        } else {
            (UvFootprint { point, ..UvFootprint::default() }, Vec3::ZERO, Vec3::ZERO)
        };
        Some(Surface {
            p: at(&self.p),
            ng: at(&self.ng),
            ns: at(&self.ns),
            material: self.material[k],
            uv,
            dpdu,
            dpdv,
            triangle: hit.triangle,
            curve: None,
        })
    }
}

/// What the gather loop reads per lane. Lanes past the group's hits, and the normal, uv and
/// instance columns of lanes whose mesh has none, hold stale values (from an earlier group) whose
/// results the selects drop or nobody reads.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct Gathered {
    /// Vertex positions as stored (prototype space for instanced triangles).
    p: [Lanes3; 3],
    /// Vertex normals.
    n: [Lanes3; 3],
    /// Vertex uvs.
    t: [Lanes2; 3],
    b1: Lanes,
    b2: Lanes,
    wo: Lanes3,
    footprint: Lanes,
    /// The instance's row-major `world_from_object` rows.
    world_from_object: [[Lanes; 4]; 3],
    /// `normal_from_object[r][c]` = the instance's `object_from_world[c][r]` (its transpose).
    normal_from_object: [Lanes3; 3],
    /// Non-zero where the mesh has normals, has uvs, the hit is on an instance.
    has_normals: U32Lanes,
    has_uvs: U32Lanes,
    instanced: U32Lanes,
}

/// glam's `v0 · b0 + v1 · b1 + v2 · b2` (component-wise products, summed left to right).
#[inline(always)]
fn interpolate(v: [V; 3], b: [f32; 3]) -> V {
    v[0].scale(b[0]) + v[1].scale(b[1]) + v[2].scale(b[2])
}

/// Stores a gathered `[x, y, z]` into lane `k` of `c`.
#[inline(always)]
fn set(c: &mut Lanes3, k: usize, v: [f32; 3]) {
    (c[0][k], c[1][k], c[2][k]) = (v[0], v[1], v[2]);
}

/// glam's `try_normalize` test on `1 / |v|`: finite and positive.
#[inline(always)]
fn normalizable(rcp: f32) -> bool {
    rcp.is_finite() && rcp > 0.0
}

/// The barycentric weights of lane `k`: `(1 − b1 − b2, b1, b2)`.
#[inline(always)]
fn weights(g: &Gathered, k: usize) -> [f32; 3] {
    let (b1, b2) = (g.b1[k], g.b2[k]);
    [1.0 - b1 - b2, b1, b2]
}

/// The three vertices of lane `k` in the columns `v`.
#[inline(always)]
fn vertices(v: &[Lanes3; 3], k: usize) -> [V; 3] {
    [V::at(&v[0], k), V::at(&v[1], k), V::at(&v[2], k)]
}

/// The kernel's inputs of `group`'s hits into its columns, lane by lane.
#[inline(always)]
fn gather_portable(scene: &Scene, group: &mut HitGroup) -> Present {
    let HitGroup { hits, wo, footprint, len, gathered: g, out } = group;
    let view = &scene.view;
    let positions = view.positions;
    // As long as `positions` (validated) when present: the slicing is the only bounds check for
    // those reads, as in the scalar function.
    let normals = &view.normals[..positions.len().min(view.normals.len())];
    let uvs = &view.uvs[..positions.len().min(view.uvs.len())];
    let (mut any_normals, mut any_uvs, mut any_instanced) = (false, false, false);
    for k in 0..*len {
        let hit = &hits[k];
        let tri = &view.triangles[hit.triangle as usize];
        let [v0, v1, v2] = [tri.vertices[0] as usize, tri.vertices[1] as usize, tri.vertices[2] as usize];
        set(&mut g.p[0], k, positions[v0]);
        set(&mut g.p[1], k, positions[v1]);
        set(&mut g.p[2], k, positions[v2]);
        (g.b1[k], g.b2[k], g.footprint[k]) = (hit.b1, hit.b2, footprint[k]);
        set(&mut g.wo, k, wo[k].to_array());
        out.material[k] = view.triangle_materials[hit.triangle as usize];
        let flags = view.meshes[tri.mesh as usize].flags;
        let (has_normals, has_uvs) = (flags & blob::MESH_HAS_NORMALS != 0, flags & blob::MESH_HAS_UVS != 0);
        let instanced = hit.instance != blob::NONE;
        (g.has_normals[k], g.has_uvs[k], g.instanced[k]) =
            (has_normals as u32, has_uvs as u32, instanced as u32);
        (any_normals, any_uvs, any_instanced) =
            (any_normals | has_normals, any_uvs | has_uvs, any_instanced | instanced);
        if has_normals {
            set(&mut g.n[0], k, normals[v0]);
            set(&mut g.n[1], k, normals[v1]);
            set(&mut g.n[2], k, normals[v2]);
        }
        if has_uvs {
            (g.t[0][0][k], g.t[0][1][k]) = (uvs[v0][0], uvs[v0][1]);
            (g.t[1][0][k], g.t[1][1][k]) = (uvs[v1][0], uvs[v1][1]);
            (g.t[2][0][k], g.t[2][1][k]) = (uvs[v2][0], uvs[v2][1]);
        }
        if instanced {
            gather_instance(scene, hit.instance, hit.time, g, k);
        }
    }
    Present { normals: any_normals, uvs: any_uvs, instanced: any_instanced }
}

/// Lane `k`'s instance transforms (instance `instance` at ray time `time`) into the columns.
#[inline(always)]
fn gather_instance(scene: &Scene, instance: u32, time: f32, g: &mut Gathered, k: usize) {
    let inst = scene.accel.instances().placement(instance, time);
    for r in 0..3 {
        for c in 0..4 {
            g.world_from_object[r][c][k] = inst.world_from_object[r][c];
        }
        for c in 0..3 {
            g.normal_from_object[r][c][k] = inst.object_from_world[c][r];
        }
    }
}

/// Which optional inputs some lane of a group has.
#[derive(Clone, Copy, Debug, Default)]
struct Present {
    normals: bool,
    uvs: bool,
    instanced: bool,
}

/// The surfaces of `group`'s hits into `out`, lane `k` equal to `scene.surface(hit k, …)`.
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
fn surface_columns(scene: &Scene, group: &mut HitGroup, gather: Gather) {
    let any = match gather {
        Gather::Portable => gather_portable(scene, group),
        // SAFETY: `Gather::Avx2` is only chosen where the CPU has AVX2.
        #[cfg(target_arch = "x86_64")]
        Gather::Avx2 => {
            unsafe { avx2::gather(scene, group) }.unwrap_or_else(|| gather_portable(scene, group))
        }
    };
    let deform = scene.accel.deformation();
    if !deform.is_empty() {
        // Deforming triangles where their meshes are at the hits' times (the scalar surface's
        // vertices, from the same function); they are never instanced.
        let HitGroup { hits, len, gathered: g, .. } = group;
        for (k, hit) in hits.iter().enumerate().take(*len) {
            if let Some(p) = deform.triangle_at(hit.triangle, hit.time) {
                for (c, v) in g.p.iter_mut().zip(p) {
                    set(c, k, v.to_array());
                }
            }
        }
    }
    let HitGroup { gathered: g, out, .. } = group;
    out.has_uv = g.has_uvs;
    let (any_normals, any_uvs, any_instanced) = (any.normals, any.uvs, any.instanced);

    if any_instanced {
        to_world(g);
    }
    geometry(g, out);
    if any_normals {
        shading_normals(g, any_instanced, out);
    } else {
        out.ns = out.ng;
    }
    if any_uvs {
        texture_coordinates(g, out);
    }
}

/// Instanced lanes' vertices moved to world space (`instanced::point_to_world`'s
/// `((m₀·x + m₁·y) + m₂·z) + m₃·1` per row).
#[inline(always)]
fn to_world(g: &mut Gathered) {
    let m = &g.world_from_object;
    for i in 0..3 {
        let p = &mut g.p[i];
        for k in 0..LANES {
            let v = V::at(p, k);
            let row = |r: usize| m[r][0][k] * v.x + m[r][1][k] * v.y + m[r][2][k] * v.z + m[r][3][k] * 1.0;
            V::select(g.instanced[k] != 0, V { x: row(0), y: row(1), z: row(2) }, v).store(p, k);
        }
    }
}

/// Point and geometric normal (flipped towards `wo`; the lane is invalid where it does not
/// normalize).
#[inline(always)]
fn geometry(g: &Gathered, out: &mut Columns) {
    for k in 0..LANES {
        let [p0, p1, p2] = vertices(&g.p, k);
        let n = (p1 - p0).cross(p2 - p0);
        let rcp = 1.0 / n.dot(n).sqrt();
        let ng = n.scale(rcp);
        let ng = V::select(ng.dot(V::at(&g.wo, k)) < 0.0, -ng, ng);
        interpolate([p0, p1, p2], weights(g, k)).store(&mut out.p, k);
        ng.store(&mut out.ng, k);
        out.valid[k] = normalizable(rcp) as u32;
    }
}

/// The shading normals: interpolated, moved by the instance's normal transform, normalized,
/// turned to `ng`'s side; `ng` where a lane has no normals, they do not normalize, or they face
/// away from the viewer.
#[inline(always)]
fn shading_normals(g: &Gathered, instanced: bool, out: &mut Columns) {
    for k in 0..LANES {
        let mut n = interpolate(vertices(&g.n, k), weights(g, k));
        if instanced {
            // `instanced::normal_to_world`: `object_from_worldᵀ · n`.
            let m = &g.normal_from_object;
            let row = |r: usize| m[r][0][k] * n.x + m[r][1][k] * n.y + m[r][2][k] * n.z;
            n = V::select(g.instanced[k] != 0, V { x: row(0), y: row(1), z: row(2) }, n);
        }
        let rcp = 1.0 / n.dot(n).sqrt();
        let n = n.scale(rcp);
        let ng = V::at(&out.ng, k);
        let ns = V::select(n.dot(ng) < 0.0, -n, n);
        // NaN compares false: the scalar code keeps such a normal too.
        let faces_away = ns.dot(V::at(&g.wo, k)) < 1e-4;
        let keep = g.has_normals[k] != 0 && normalizable(rcp) && !faces_away;
        V::select(keep, ns, ng).store(&mut out.ns, k);
    }
}

/// uv, `dp/du`, `dp/dv` (zero where the uv triangle's determinant is zero or not finite) and the
/// ray cone's uv footprint (`uv_footprint` in [`crate::surface`]).
#[inline(always)]
fn texture_coordinates(g: &Gathered, out: &mut Columns) {
    for k in 0..LANES {
        let [b0, b1, b2] = weights(g, k);
        let [t0, t1, t2] =
            [[g.t[0][0][k], g.t[0][1][k]], [g.t[1][0][k], g.t[1][1][k]], [g.t[2][0][k], g.t[2][1][k]]];
        let [p0, p1, p2] = vertices(&g.p, k);
        let (e1, e2) = (p1 - p0, p2 - p0);
        out.uv[0][k] = t0[0] * b0 + t1[0] * b1 + t2[0] * b2;
        out.uv[1][k] = t0[1] * b0 + t1[1] * b1 + t2[1] * b2;
        let d1 = [t1[0] - t0[0], t1[1] - t0[1]];
        let d2 = [t2[0] - t0[0], t2[1] - t0[1]];
        let det = d1[0] * d2[1] - d1[1] * d2[0];
        let solvable = det != 0.0 && det.is_finite();
        let dpdu = (e1.scale(d2[1]) - e2.scale(d1[1])) / det;
        let dpdv = (e2.scale(d1[0]) - e1.scale(d2[0])) / det;
        V::select(solvable, dpdu, V::ZERO).store(&mut out.dpdu, k);
        V::select(solvable, dpdv, V::ZERO).store(&mut out.dpdv, k);

        // The footprint: the cone's ellipse axes on the triangle's plane, written in the edges.
        let ng = V::at(&out.ng, k);
        let d = -V::at(&g.wo, k);
        let cos = ng.dot(d);
        let a = ng - d.scale(cos);
        let rcp = 1.0 / a.dot(a).sqrt();
        // Head on: `Frame::new(d).t`.
        let sign = 1.0f32.copysign(d.z);
        let fa = -1.0 / (sign + d.z);
        let fb = d.x * d.y * fa;
        let fallback = V { x: 1.0 + sign * d.x * d.x * fa, y: sign * fb, z: -sign * d.x };
        let axis1 = V::select(normalizable(rcp), a.scale(rcp), fallback);
        let axis2 = d.cross(axis1);
        let cos = if cos.abs() < 1e-4 { 1e-4f32.copysign(cos) } else { cos };
        let (g11, g12, g22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let gram = g11 * g22 - g12 * g12;
        let footprint = g.footprint[k];
        let to_uv = |axis: V| -> [f32; 2] {
            let v = axis.scale(footprint);
            let w = v - d.scale(v.dot(ng) / cos);
            let (r1, r2) = (w.dot(e1), w.dot(e2));
            let a = (r1 * g22 - r2 * g12) / gram;
            let b = (r2 * g11 - r1 * g12) / gram;
            let flat = gram <= 0.0;
            [if flat { 0.0 } else { d1[0] * a + d2[0] * b }, if flat { 0.0 } else { d1[1] * a + d2[1] * b }]
        };
        let (dx, dy) = (to_uv(axis1), to_uv(axis2));
        (out.duv_dx[0][k], out.duv_dx[1][k]) = (dx[0], dx[1]);
        (out.duv_dy[0][k], out.duv_dy[1][k]) = (dy[0], dy[1]);
    }
}

/// The gather with AVX2: each column is one `vpgatherdd`/`vgatherdps` of eight lanes by byte
/// offset (triangle records, then vertex attributes by the triangles' vertex indices), the
/// optional attributes masked by the lanes' mesh flags. Instance transforms stay per lane (rare).
///
/// std::arch rather than a crate: no well-kept portable-SIMD crate exposes gathers on stable.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{gather_instance, HitGroup, Lanes, Present};
    use crate::accel::Hit;
    use crate::scene::Scene;
    use glam::Vec3;
    use std::arch::x86_64::*;
    use std::mem::{offset_of, size_of};

    /// `lane × stride + offset` for the eight lanes (byte offsets into an array of records).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn record_offsets(stride: usize, offset: usize) -> __m256i {
        let s = stride as i32;
        let o = offset as i32;
        _mm256_setr_epi32(o, s + o, 2 * s + o, 3 * s + o, 4 * s + o, 5 * s + o, 6 * s + o, 7 * s + o)
    }

    /// Lanes (all ones) where `index < len`, unsigned; `len` ≥ 1.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn below(index: __m256i, len: usize) -> __m256i {
        let last = _mm256_set1_epi32((len - 1) as i32);
        _mm256_cmpeq_epi32(_mm256_max_epu32(index, last), last)
    }

    /// True where every lane of `mask` is set.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn all(mask: __m256i) -> bool {
        _mm256_movemask_ps(_mm256_castsi256_ps(mask)) == 0xff
    }

    /// Gathers `f32`s at byte offsets `at` from `base`.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn floats(base: *const u8, at: __m256i) -> __m256 {
        unsafe { _mm256_i32gather_ps::<1>(base as *const f32, at) }
    }

    /// Gathers `u32`s at byte offsets `at` from `base`.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn words(base: *const u8, at: __m256i) -> __m256i {
        unsafe { _mm256_i32gather_epi32::<1>(base as *const i32, at) }
    }

    /// The `C` components of a per-vertex attribute (`data`, by vertex index) at the three corners
    /// `v` into `columns`, in the lanes of `mask` (the others keep their stale values), or `false`
    /// (nothing trusted written) when a masked lane's vertex index is out of `data`.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn corner_attribute<const C: usize>(
        columns: &mut [[Lanes; C]; 3],
        data: &[[f32; C]],
        v: &[__m256i; 3],
        mask: __m256i,
    ) -> bool {
        let unmasked = _mm256_xor_si256(mask, _mm256_set1_epi32(-1));
        if data.is_empty() || !v.iter().all(|&v| all(_mm256_or_si256(below(v, data.len()), unmasked))) {
            return false;
        }
        let base = data.as_ptr() as *const f32;
        let record = _mm256_set1_epi32(size_of::<[f32; C]>() as i32);
        for (corner, columns) in v.iter().zip(columns) {
            for (c, column) in columns.iter_mut().enumerate() {
                let at =
                    _mm256_add_epi32(_mm256_mullo_epi32(*corner, record), _mm256_set1_epi32(4 * c as i32));
                // SAFETY: every masked lane's index is below `data.len()` (checked above) and
                // `data` is small enough for 32-bit byte offsets (the caller's `fits`); the column
                // is an aligned `[f32; 8]`.
                unsafe {
                    let old = _mm256_load_ps(column.as_ptr());
                    let got = _mm256_mask_i32gather_ps::<1>(old, base, at, _mm256_castsi256_ps(mask));
                    _mm256_store_ps(column.as_mut_ptr(), got);
                }
            }
        }
        true
    }

    /// [`super::gather_portable`]'s columns and result, or `None` (nothing trusted written) when
    /// an index is out of its array or an array is too large for 32-bit byte offsets: the
    /// portable gather then reports it as the scalar code does.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn gather(scene: &Scene, group: &mut HitGroup) -> Option<Present> {
        unsafe {
            let HitGroup { hits, wo, footprint, len, gathered: g, out } = group;
            let view = &scene.view;
            let len = *len;
            let (positions, triangles, meshes) = (view.positions, view.triangles, view.meshes);
            let normals = &view.normals[..positions.len().min(view.normals.len())];
            let uvs = &view.uvs[..positions.len().min(view.uvs.len())];
            let fits = |count: usize, stride: usize| {
                count.checked_mul(stride).is_some_and(|b| b <= i32::MAX as usize)
            };
            let triangle_count = triangles.len().min(view.triangle_materials.len());
            if len == 0
                || triangle_count == 0
                || meshes.is_empty()
                || positions.is_empty()
                || !fits(triangle_count, size_of::<blob::Triangle>())
                || !fits(meshes.len(), size_of::<blob::Mesh>())
                || !fits(positions.len(), size_of::<[f32; 3]>())
            {
                return None;
            }
            let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
            let used = _mm256_cmpgt_epi32(_mm256_set1_epi32(len as i32), lane);

            // The hits' fields (an array of `Hit`s: one gather per field).
            let hit_base = hits.as_ptr() as *const u8;
            let hit_field = |offset| record_offsets(size_of::<Hit>(), offset);
            // Unused lanes read triangle 0.
            let triangle = _mm256_and_si256(words(hit_base, hit_field(offset_of!(Hit, triangle))), used);
            if !all(below(triangle, triangle_count)) {
                return None;
            }
            _mm256_store_ps(g.b1.as_mut_ptr(), floats(hit_base, hit_field(offset_of!(Hit, b1))));
            _mm256_store_ps(g.b2.as_mut_ptr(), floats(hit_base, hit_field(offset_of!(Hit, b2))));
            let instance = words(hit_base, hit_field(offset_of!(Hit, instance)));
            let instanced =
                _mm256_andnot_si256(_mm256_cmpeq_epi32(instance, _mm256_set1_epi32(blob::NONE as i32)), used);
            _mm256_store_si256(g.instanced.as_mut_ptr() as *mut __m256i, _mm256_srli_epi32::<31>(instanced));
            let wo_base = wo.as_ptr() as *const u8;
            for c in 0..3 {
                let at = record_offsets(size_of::<Vec3>(), 4 * c);
                _mm256_store_ps(g.wo[c].as_mut_ptr(), floats(wo_base, at));
            }
            g.footprint = *footprint;

            // The triangle records and materials.
            let tri_at = _mm256_slli_epi32::<4>(triangle);
            const _: () = assert!(size_of::<blob::Triangle>() == 16);
            let tri_base = triangles.as_ptr() as *const u8;
            let material =
                words(view.triangle_materials.as_ptr() as *const u8, _mm256_slli_epi32::<2>(triangle));
            _mm256_store_si256(out.material.as_mut_ptr() as *mut __m256i, material);
            let field = |c: i32| _mm256_add_epi32(tri_at, _mm256_set1_epi32(c));
            let v = [0, 4, 8].map(|c| words(tri_base, field(c)));
            let mesh = words(tri_base, field(offset_of!(blob::Triangle, mesh) as i32));
            if !all(below(mesh, meshes.len())) || !v.iter().all(|&v| all(below(v, positions.len()))) {
                return None;
            }
            let mesh_at = _mm256_add_epi32(
                _mm256_mullo_epi32(mesh, _mm256_set1_epi32(size_of::<blob::Mesh>() as i32)),
                _mm256_set1_epi32(offset_of!(blob::Mesh, flags) as i32),
            );
            let flags = words(meshes.as_ptr() as *const u8, mesh_at);
            let flag = |bit: u32| {
                let b = _mm256_set1_epi32(bit as i32);
                _mm256_and_si256(_mm256_cmpeq_epi32(_mm256_and_si256(flags, b), b), used)
            };
            let (has_normals, has_uvs) = (flag(blob::MESH_HAS_NORMALS), flag(blob::MESH_HAS_UVS));
            _mm256_store_si256(
                g.has_normals.as_mut_ptr() as *mut __m256i,
                _mm256_srli_epi32::<31>(has_normals),
            );
            _mm256_store_si256(g.has_uvs.as_mut_ptr() as *mut __m256i, _mm256_srli_epi32::<31>(has_uvs));

            // Vertex attributes: `[f32; 3]` / `[f32; 2]` records by vertex index.
            let by_vertex = |v: __m256i, stride: i32, c: i32| {
                _mm256_add_epi32(_mm256_mullo_epi32(v, _mm256_set1_epi32(stride)), _mm256_set1_epi32(4 * c))
            };
            for i in 0..3 {
                for c in 0..3 {
                    let at = by_vertex(v[i], 12, c as i32);
                    _mm256_store_ps(g.p[i][c].as_mut_ptr(), floats(positions.as_ptr() as *const u8, at));
                }
            }
            let any = |mask: __m256i| _mm256_movemask_ps(_mm256_castsi256_ps(mask)) != 0;
            if (any(has_normals) && !corner_attribute(&mut g.n, normals, &v, has_normals))
                || (any(has_uvs) && !corner_attribute(&mut g.t, uvs, &v, has_uvs))
            {
                return None;
            }
            let instanced_lanes = _mm256_movemask_ps(_mm256_castsi256_ps(instanced)) as u32;
            let mut rest = instanced_lanes;
            while rest != 0 {
                let k = rest.trailing_zeros() as usize;
                gather_instance(scene, hits[k].instance, hits[k].time, g, k);
                rest &= rest - 1;
            }
            Some(Present { normals: any(has_normals), uvs: any(has_uvs), instanced: instanced_lanes != 0 })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::surface_tests::{bits, random_unit};
    use crate::testscene::{self, Rng};
    use glam::{Mat4, Vec2};

    /// A scene with every case the kernel selects between: instanced spheres (non-uniform and
    /// mirroring scales; normals through the instance's inverse transpose), a world-space sphere
    /// with normals and uvs (degenerate triangles at its poles), one with uvs but no normals, a
    /// random triangle cloud with neither, a card whose uvs are all equal (uv determinant 0) and
    /// whose normals lean away from its face (shading normals that face away from some viewers),
    /// and a mesh of zero-area triangles.
    fn scene_bytes() -> blob::AlignedBytes {
        let mut scene = testscene::instanced_spheres(10, 0x5eed);
        scene.meshes.push(testscene::sphere(Vec3::new(1.0, 0.5, -1.0), 0.8, 6, 9, 0, false));
        scene.meshes.push(scene_pack::Mesh {
            normals: Vec::new(),
            ..testscene::sphere(Vec3::new(-1.5, -0.5, 1.0), 0.7, 5, 8, 0, true)
        });
        let mut soup = testscene::random_triangles_mesh(40, 9);
        let tilt = Mat4::from_rotation_x(0.7);
        soup.positions.iter_mut().for_each(|p| *p = tilt.transform_point3(*p));
        scene.meshes.push(soup);
        let mut card = testscene::card(-2.0, 1.5, 0);
        card.uvs = vec![Vec2::new(0.25, 0.75); 4];
        card.normals = vec![
            Vec3::new(0.9, 0.0, 0.2).normalize(),
            Vec3::new(-0.3, 0.95, 0.1).normalize(),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(0.7, -0.7, -0.14).normalize(),
        ];
        scene.meshes.push(card);
        let mut flat = testscene::card(1.0, 0.5, 0);
        flat.path = "/flat".into();
        flat.positions = vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::X];
        flat.uvs = vec![Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ONE];
        scene.meshes.push(flat);
        testscene::bytes(&scene)
    }

    /// Lanes equal [`Scene::surface`] bit for bit on random hits, groups of 1 to 8 (both the
    /// scalar shortcut and the kernel), from random directions (flipped normals, back-facing
    /// shading normals), along the axes (head-on hits on the card: the fallback axis), with random
    /// and zero footprints.
    #[test]
    fn lanes_equal_scalar_surfaces() {
        let bytes = scene_bytes();
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let scene = Scene::new(view);
        let triangles = view.triangles.len() as u32;
        let instances = view.instancing.instances.len() as u32;
        // The card's triangles (z = −2), picked often so that axis-aligned views hit it head on.
        let card: Vec<u32> = (0..triangles)
            .filter(|&t| {
                view.triangles[t as usize].vertices.iter().all(|&v| view.positions[v as usize][2] == -2.0)
            })
            .collect();
        assert_eq!(card.len(), 2);
        // Both gathers, where this CPU has AVX2.
        let gathers = [Gather::Portable, Gather::detect()];
        eprintln!("gathers: {gathers:?}");
        let mut rng = Rng(17);
        let mut group = HitGroup::default();
        let mut seen = [0u32; 7]; // compared, degenerate, instanced, uvs, normals, det 0, head on
        for round in 0..3000 {
            group.clear();
            for _ in 0..1 + round % LANES {
                let (mut b1, mut b2) = (rng.next_f32(), rng.next_f32());
                if b1 + b2 > 1.0 {
                    (b1, b2) = (1.0 - b1, 1.0 - b2);
                }
                let (triangle, instance) = if instances > 0 && rng.next_f32() < 0.3 {
                    let instance = (rng.next_f32() * instances as f32) as u32;
                    let inst = &view.instancing.instances[instance as usize];
                    let proto = &view.instancing.prototypes[inst.prototype as usize];
                    (proto.first_triangle + (rng.next_f32() * proto.triangle_count as f32) as u32, instance)
                } else if rng.next_f32() < 0.1 {
                    (card[(rng.next_f32() * card.len() as f32) as usize], blob::NONE)
                } else {
                    ((rng.next_f32() * triangles as f32) as u32, blob::NONE)
                };
                let wo = if rng.next_f32() < 0.15 {
                    [Vec3::Z, -Vec3::Z, Vec3::X][(rng.next_f32() * 3.0) as usize]
                } else {
                    random_unit(&mut rng)
                };
                let footprint = if rng.next_f32() < 0.1 { 0.0 } else { rng.range(0.0, 0.05) };
                group.push(&Hit { t: 1.0, triangle, b1, b2, instance, time: 0.0 }, wo, footprint);
            }
            let mut got = Vec::new();
            for &gather in &gathers {
                let mut by = Vec::new();
                surfaces_with(&scene, &mut group, gather, |k, s| by.push((k, s)));
                assert_eq!(by.len(), group.len());
                got.extend(by);
            }
            for (k, lanes) in got {
                let hit = &group.hits[k];
                let want = scene.surface(hit, group.wo[k], group.footprint[k]);
                assert_eq!(
                    lanes.as_ref().map(bits),
                    want.as_ref().map(bits),
                    "lane {k} of {}: {hit:?}",
                    group.len()
                );
                let tri = &view.triangles[hit.triangle as usize];
                let flags = view.meshes[tri.mesh as usize].flags;
                seen[0] += 1;
                seen[1] += want.is_none() as u32;
                seen[2] += (hit.instance != blob::NONE) as u32;
                seen[3] += (flags & blob::MESH_HAS_UVS != 0) as u32;
                seen[4] += (flags & blob::MESH_HAS_NORMALS != 0) as u32;
                if let Some(s) = &want {
                    seen[5] += (s.uv.has_uv && s.dpdu == Vec3::ZERO) as u32;
                    seen[6] += (s.uv.has_uv && s.ng.cross(group.wo[k]) == Vec3::ZERO) as u32;
                }
            }
        }
        eprintln!("compared, degenerate, instanced, uvs, normals, det 0, head on: {seen:?}");
        let [compared, degenerate, instanced, uvs, normals, det0, head_on] = seen;
        assert!(compared > 20_000 && degenerate > 50 && instanced > 1000, "{seen:?}");
        assert!(uvs > 1000 && compared - uvs > 500 && normals > 1000 && compared - normals > 500, "{seen:?}");
        assert!(det0 > 20 && head_on > 5, "{seen:?}");
    }

    /// The AVX2 gather declines a group with an index out of its array (the portable gather then
    /// reports it as the scalar code does) and accepts the same group with valid indices.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_gather_declines_bad_indices() {
        if Gather::detect() != Gather::Avx2 {
            eprintln!("no AVX2: skipped");
            return;
        }
        let bytes = scene_bytes();
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let scene = Scene::new(view);
        let triangles = view.triangles.len() as u32;
        let mut group = HitGroup::default();
        for triangle in [0, 1, triangles - 1, 2] {
            group.push(
                &Hit { t: 1.0, triangle, b1: 0.2, b2: 0.3, instance: blob::NONE, time: 0.0 },
                Vec3::Z,
                0.01,
            );
        }
        // SAFETY: the CPU has AVX2 (tested above).
        assert!(unsafe { avx2::gather(&scene, &mut group) }.is_some());
        group.hits[2].triangle = triangles;
        assert!(unsafe { avx2::gather(&scene, &mut group) }.is_none());
        group.hits[2].triangle = u32::MAX - 1;
        assert!(unsafe { avx2::gather(&scene, &mut group) }.is_none());
    }
}
