//! The surface model both integrators share: a hit rebuilt from the blob ([`Scene::surface`]), its
//! BSDF, its shading inputs, and how shadow rays pass transparent surfaces.
//!
//! # Surface reconstruction ([`Scene::surface`])
//! Both integrators rebuild each hit's position, normals, uvs and uv footprint from the blob; it was
//! 6–7 % of either one's samples. Tuned without changing a bit (the test `surface_tests` compares every
//! field with the pre-tuning code on random hits; the bench renders' EXR files are byte-identical):
//! one triangle and one instance lookup per hit, the instance transform inline (it was three
//! out-of-line `array::map` closure calls), no `array::map` left (its instantiation stayed out of line
//! and the call spilled every live register), vertex indices bounds-checked once, and an AVX2 clone
//! (`multiversion`; baseline SSE2 spent a quarter of the ~590 instructions per hit on `movaps` copies).
//! Measurements: `docs/perf.md#surface-reconstruction-surfacemodrs`.
//!
//! Kept out: `0 < 1/|v| < ∞` in place of glam's `is_finite() && > 0` in the three normalizations
//! (the same answer, but LLVM compiled it to 0.9 M more instructions on shading-heavy); a shared
//! reciprocal for the divisions by the uv determinant and the Gram determinant (`x / d` and
//! `x · (1 / d)` differ in the last bit); computing the footprint lazily, only for materials that
//! read uvs (on the bench scenes every hit with uvs is on a textured material: tractor 37 300 of
//! 88 326 hits have uvs, all textured, shading-heavy all 90 601, so there is nothing to skip). `Surface` was
//! 248 bytes, 116 of them the hair BSDF of curve hits, and moving one cost a `memcpy` call (29
//! instructions; 0.35–0.5 % of the process on tractor and shading-heavy); it now keeps the fibre
//! (tangent, offset, colour, spawn distance; `CurveSurface`) and is 148 bytes, the hair BSDF built
//! where a curve hit is shaded.

pub mod lanes;

use crate::accel::curves::CurveHit;
use crate::accel::offset_ray_origin;
use crate::bsdf::dielectric::{normal_transmittance, Dielectric};
use crate::bsdf::{Bsdf, BsdfSample, Frame};
use crate::hair::HairBsdf;
use crate::path::MAX_NULL_EVENTS;
use crate::sampler::hash_combine;
use crate::scene::Scene;
use crate::shading::{ShadingInputs, UvFootprint};
use glam::Vec3;
use texture::{Filter, Touch};

/// Surface data at a hit.
#[derive(Clone, Copy)]
pub struct Surface {
    /// Hit point.
    pub p: Vec3,
    /// Geometric normal facing the incoming ray's origin.
    pub ng: Vec3,
    /// Shading normal on the same side as `ng` (normal map applied by the caller).
    pub ns: Vec3,
    /// Material index.
    pub material: u32,
    /// Texture coordinates and pixel footprint.
    pub uv: UvFootprint,
    /// `dp/du` of the triangle's uv parametrization (zero without uvs), for normal-map tangents.
    pub dpdu: Vec3,
    /// `dp/dv`.
    pub dpdv: Vec3,
    /// Triangle hit, or [`blob::NONE`] for curves and points.
    pub triangle: u32,
    /// Curve and point hits.
    pub(crate) curve: Option<CurveSurface>,
}

// Moved (and, in the wavefront, stored) for every hit: 248 bytes while it carried the built hair
// BSDF (116 bytes), 148 since it keeps the fibre's 32 bytes instead.
const _: () = assert!(std::mem::size_of::<Surface>() == 148);

/// What a curve or point hit adds to [`Surface`]: 36 bytes (with the `Option` around it, whose
/// tag hides in this enum's) where the built hair BSDF was 116 and was moved with every triangle
/// hit's surface too. The BSDF is built from it where the hit is shaded ([`Scene::bsdf`]).
#[derive(Clone, Copy, Debug)]
pub(crate) enum CurveSurface {
    /// A fibre (Chiang hair BSDF).
    Hair(HairFibre),
    /// A point: UsdPreviewSurface with this diffuse colour (its per-point colour or the material's).
    Point {
        /// Diffuse colour.
        color: Vec3,
    },
}

/// What the hair BSDF of a fibre hit is built from ([`HairBsdf::from_view_axis`], with the
/// surface's `ns` as the frame's z axis).
#[derive(Clone, Copy, Debug)]
pub(crate) struct HairFibre {
    /// Unit tangent along the fibre.
    pub(crate) tangent: Vec3,
    /// Offset across the fibre, in [−1, 1].
    pub(crate) h: f32,
    /// Fibre colour.
    pub(crate) color: Vec3,
    /// Rays leave a fibre from `p + w · spawn` (its diameter and then some): a fibre's own hair BSDF
    /// already accounts for light crossing it, so the ray must not meet the same fibre again.
    pub(crate) spawn: f32,
}

impl Surface {
    /// Origin for a ray leaving the surface in direction `w`.
    pub(crate) fn spawn(&self, w: Vec3) -> Vec3 {
        match &self.curve {
            Some(CurveSurface::Hair(fibre)) => self.p + w * fibre.spawn,
            _ => offset_ray_origin(self.p, if w.dot(self.ng) >= 0.0 { self.ng } else { -self.ng }),
        }
    }
}

/// Glass surfaces a shadow ray towards a delta light may cross before it counts as blocked.
const MAX_GLASS_CROSSINGS: usize = 16;

/// The BSDF at a hit: UsdPreviewSurface (triangles, points), hair (curves), or the dielectric of a
/// transmissive UsdPreviewSurface's `1 − opacity` part (triangles).
pub(crate) enum SurfaceBsdf {
    Preview(Bsdf),
    Hair(HairBsdf),
    Glass(Dielectric),
}

impl SurfaceBsdf {
    // A hair BSDF was built for the hit's `wo` ([`Scene::bsdf`]), the one these are called with.
    pub(crate) fn eval(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        match self {
            SurfaceBsdf::Preview(b) => b.eval(wo, wi),
            SurfaceBsdf::Hair(h) => h.eval(wi),
            SurfaceBsdf::Glass(g) => g.eval(wo, wi),
        }
    }
    pub(crate) fn sample(&self, wo: Vec3, u_lobe: f32, u: [f32; 2]) -> Option<BsdfSample> {
        match self {
            SurfaceBsdf::Preview(b) => b.sample(wo, u_lobe, u),
            SurfaceBsdf::Hair(h) => h.sample(u_lobe, u),
            SurfaceBsdf::Glass(g) => g.sample(wo, u_lobe, u),
        }
    }
    pub(crate) fn albedo(&self) -> Vec3 {
        match self {
            SurfaceBsdf::Preview(b) => b.diffuse_albedo(),
            SurfaceBsdf::Hair(h) => h.color(),
            // Clear glass: what is seen through it keeps its colour.
            SurfaceBsdf::Glass(_) => Vec3::ONE,
        }
    }
}

/// [`Scene::surface`]: hot (6–7 % of either integrator's samples), so written for the compiler.
///
/// * Compiled per target with `multiversion` (AVX2+FMA and a baseline fallback). The work is scalar
///   `Vec3` arithmetic; on baseline SSE2 a quarter of its ~590 instructions were register copies of
///   two-operand encodings (`movaps`), which AVX's three-operand forms drop. Rust never contracts a
///   multiply and an add into an FMA, so both clones perform the same IEEE operations and return the
///   same bits.
/// * The triangle record and the instance record are looked up once and the instance transform is
///   applied inline (it was three out-of-line closure calls and three lookups).
/// * The normal and uv slices are re-sliced to the position count (equal, validated by the blob), so
///   the vertex indices are bounds-checked once, against the positions.
///
/// Every float operation is the one the straightforward version performed, in the same order.
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
fn triangle_surface(scene: &Scene, hit: &crate::accel::Hit, wo: Vec3, footprint: f32) -> Option<Surface> {
    let view = &scene.view;
    let tri = &view.triangles[hit.triangle as usize];
    // Spelled out rather than `array::map`: its instantiation stayed out of line here, and a call in
    // the middle of this function spills every live vector register.
    let [v0, v1, v2] = [tri.vertices[0] as usize, tri.vertices[1] as usize, tri.vertices[2] as usize];
    let positions = view.positions;
    let stored = [Vec3::from(positions[v0]), Vec3::from(positions[v1]), Vec3::from(positions[v2])];
    // World space, also for a prototype triangle (moved by its instance).
    let instance =
        (hit.instance != blob::NONE).then(|| scene.accel.instances().placement(hit.instance, hit.time));
    let [p0, p1, p2] = match &instance {
        Some(inst) => {
            let to_world = |p| crate::accel::instanced::point_to_world(inst, p);
            [to_world(stored[0]), to_world(stored[1]), to_world(stored[2])]
        }
        // A deforming triangle is where its mesh is at the hit's time.
        None => scene.accel.deformation().triangle_at(hit.triangle, hit.time).unwrap_or(stored),
    };
    let b0 = 1.0 - hit.b1 - hit.b2;
    let p = p0 * b0 + p1 * hit.b1 + p2 * hit.b2;
    let (e1, e2) = (p1 - p0, p2 - p0);
    let mut ng = e1.cross(e2).try_normalize()?;
    if ng.dot(wo) < 0.0 {
        ng = -ng;
    }
    let mesh = &view.meshes[tri.mesh as usize];
    let mut ns = ng;
    if mesh.flags & blob::MESH_HAS_NORMALS != 0 {
        // As long as `positions` (validated): the slicing is the only bounds check.
        let normals = &view.normals[..positions.len()];
        let [n0, n1, n2] = [Vec3::from(normals[v0]), Vec3::from(normals[v1]), Vec3::from(normals[v2])];
        let n = n0 * b0 + n1 * hit.b1 + n2 * hit.b2;
        let n = match &instance {
            Some(inst) => crate::accel::instanced::normal_to_world(inst, n),
            None => n,
        };
        if let Some(n) = n.try_normalize() {
            ns = if n.dot(ng) < 0.0 { -n } else { n };
            // A shading normal facing away from the viewer would make the BSDF black; fall back to
            // the true surface there.
            if ns.dot(wo) < 1e-4 {
                ns = ng;
            }
        }
    }
    let (mut uv, mut dpdu, mut dpdv) = (UvFootprint::default(), Vec3::ZERO, Vec3::ZERO);
    if mesh.flags & blob::MESH_HAS_UVS != 0 {
        let uvs = &view.uvs[..positions.len()];
        let [t0, t1, t2] = [glam::Vec2::from(uvs[v0]), glam::Vec2::from(uvs[v1]), glam::Vec2::from(uvs[v2])];
        let at = t0 * b0 + t1 * hit.b1 + t2 * hit.b2;
        let (d1, d2) = (t1 - t0, t2 - t0);
        let det = d1.x * d2.y - d1.y * d2.x;
        if det != 0.0 && det.is_finite() {
            dpdu = (e1 * d2.y - e2 * d1.y) / det;
            dpdv = (e2 * d1.x - e1 * d2.x) / det;
        }
        uv = UvFootprint {
            uv: at.to_array(),
            has_uv: true,
            ..uv_footprint(e1, e2, d1, d2, ng, wo, footprint)
        };
    }
    uv.point = Some(crate::shading::MeshPoint { triangle: hit.triangle, b1: hit.b1, b2: hit.b2 });
    Some(Surface {
        p,
        ng,
        ns,
        material: view.triangle_materials[hit.triangle as usize],
        uv,
        dpdu,
        dpdv,
        triangle: hit.triangle,
        curve: None,
    })
}

/// The uv change across a ray cone of width `footprint` arriving along `-wo` at a triangle with
/// edges `e1`, `e2` (uv edges `d1`, `d2`) and unit normal `ng`: `duv_dx` and `duv_dy` of a
/// [`UvFootprint`] (its other fields default).
///
/// The cone's footprint on the triangle's plane is an ellipse whose axes are the in-plane direction of
/// steepest tilt (stretched by 1/cos) and the direction across it. Each axis, written in the edges
/// `e1`, `e2` (a 2×2 Gram solve), maps to uv through the same weights.
#[inline(always)]
fn uv_footprint(
    e1: Vec3,
    e2: Vec3,
    d1: glam::Vec2,
    d2: glam::Vec2,
    ng: Vec3,
    wo: Vec3,
    footprint: f32,
) -> UvFootprint {
    let d = -wo;
    let axis1 = (ng - d * ng.dot(d)).try_normalize().unwrap_or_else(|| Frame::new(d).t);
    let axis2 = d.cross(axis1);
    let cos = ng.dot(d);
    let cos = if cos.abs() < 1e-4 { 1e-4f32.copysign(cos) } else { cos };
    let on_plane = |v: Vec3| v - d * (v.dot(ng) / cos);
    let (g11, g12, g22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let gram = g11 * g22 - g12 * g12;
    let to_uv = |v: Vec3| {
        if gram <= 0.0 {
            return [0.0; 2];
        }
        let (r1, r2) = (v.dot(e1), v.dot(e2));
        let a = (r1 * g22 - r2 * g12) / gram;
        let b = (r2 * g11 - r1 * g12) / gram;
        (d1 * a + d2 * b).to_array()
    };
    UvFootprint {
        duv_dx: to_uv(on_plane(axis1 * footprint)),
        duv_dy: to_uv(on_plane(axis2 * footprint)),
        ..UvFootprint::default()
    }
}

impl<'a> Scene<'a> {
    /// Surface data at `hit` seen along `-wo`, with the uv footprint of a ray cone of width
    /// `footprint` (one pixel, scene units) there. `None` for a degenerate triangle.
    #[inline]
    pub fn surface(&self, hit: &crate::accel::Hit, wo: Vec3, footprint: f32) -> Option<Surface> {
        triangle_surface(self, hit, wo, footprint)
    }

    /// Surface data at a curve or point hit.
    pub(crate) fn curve_surface(&self, hit: &CurveHit, wo: Vec3) -> Surface {
        let curves = self.curves.view();
        let group = self.curves.group_of(hit.prim);
        let material = &self.view.materials[group.material as usize];
        let has_colors = group.flags & blob::curves::CURVE_HAS_COLORS != 0;
        let segments = curves.segments.len() as u32;
        let (ns, curve) = if group.kind == blob::curves::CURVE_POINTS {
            let sphere = &curves.spheres[(hit.prim - segments) as usize];
            let color =
                if has_colors { Vec3::from(sphere.color) } else { Vec3::from(material.diffuse_color) };
            (hit.n, CurveSurface::Point { color })
        } else {
            let attr = &curves.attributes[hit.prim as usize];
            let color = if has_colors {
                Vec3::from(attr.color[0]).lerp(Vec3::from(attr.color[1]), hit.u)
            } else {
                Vec3::from(material.diffuse_color)
            };
            let spawn = 2.5 * hit.radius + 1e-5 * hit.p.abs().max_element().max(1.0);
            // The hair frame's z axis is the shading normal; the BSDF's other parameters are
            // built from the fibre where the hit is shaded.
            let z = crate::hair::view_axis(hit.tangent, wo);
            (z, CurveSurface::Hair(HairFibre { tangent: hit.tangent, h: hit.h, color, spawn }))
        };
        Surface {
            p: hit.p,
            ng: hit.n,
            ns,
            material: group.material,
            uv: UvFootprint::default(),
            dpdu: Vec3::ZERO,
            dpdv: Vec3::ZERO,
            triangle: blob::NONE,
            curve: Some(curve),
        }
    }

    /// The BSDF at `s` seen from `wo` (the direction `s` was built for) from its evaluated shading
    /// inputs.
    ///
    /// Always inlined: a hair BSDF (252 bytes with its per-view terms) makes the enum too large for
    /// LLVM to inline this on its own, and the out-of-line call returning it through memory cost
    /// the scalar integrator's triangle hits 0.4–0.8 % of its instructions (callgrind, bench scenes).
    #[inline(always)]
    pub(crate) fn bsdf(&self, s: &Surface, inputs: &crate::shading::ShadingInputs, wo: Vec3) -> SurfaceBsdf {
        match &s.curve {
            // `ns` is still the frame's z axis: a normal map cannot move it on a curve, which has no
            // `dpdu` ([`Scene::mapped_normal`] keeps `ns` then).
            Some(CurveSurface::Hair(f)) => {
                SurfaceBsdf::Hair(HairBsdf::from_view_axis(f.tangent, wo, s.ns, f.h, f.color))
            }
            Some(CurveSurface::Point { color }) => SurfaceBsdf::Preview(Bsdf::from_inputs(
                &crate::shading::ShadingInputs { diffuse_color: *color, ..*inputs },
                s.ns,
                s.ng,
            )),
            None => SurfaceBsdf::Preview(Bsdf::from_inputs(inputs, s.ns, s.ng)),
        }
    }

    /// The dielectric BSDF of a transmissive hit `hit` on triangle surface `s` (normal map applied to
    /// `s.ns`): entering where the ray meets the triangle's front (its winding's normal faces `wo`,
    /// which `s.ng` was flipped towards).
    pub(crate) fn glass_bsdf(
        &self,
        hit: &crate::accel::Hit,
        s: &Surface,
        inputs: &ShadingInputs,
    ) -> SurfaceBsdf {
        let [p0, p1, p2] = self.accel.hit_vertices(hit);
        let entering = (p1 - p0).cross(p2 - p0).dot(s.ng) > 0.0;
        let transmission = crate::bsdf::dielectric::Transmission {
            color: inputs.transmission_color,
            depth: inputs.transmission_depth,
            thin_walled: inputs.thin_walled,
        };
        SurfaceBsdf::Glass(Dielectric::with_transmission(
            inputs.ior,
            inputs.roughness,
            s.ns,
            s.ng,
            entering,
            transmission,
        ))
    }

    /// The shading sort key of `hit` (UDIM tile, mip level and uv of its material's first texture;
    /// see [`crate::shading::Shading::sort_key`]) for a ray cone of width `footprint` there: what a
    /// wavefront integrator sorts its shade queue by.
    pub fn shading_sort_key(&self, hit: &crate::accel::Hit, wo: Vec3, footprint: f32) -> u32 {
        self.surface(hit, wo, footprint).map_or(0, |s| self.shading.sort_key(s.material, &s.uv))
    }

    /// The shading normal with the material's tangent-space normal map applied: tangent from
    /// `dp/du` (Gram-Schmidt against the interpolated normal), bitangent `n × t` flipped to agree with
    /// `dp/dv`. Keeps `s.ns` where there are no uvs or the mapped normal would face away from `wo`.
    pub(crate) fn mapped_normal(s: &Surface, tangent_normal: Vec3, wo: Vec3) -> Vec3 {
        let Some(t) = (s.dpdu - s.ns * s.ns.dot(s.dpdu)).try_normalize() else { return s.ns };
        let mut b = s.ns.cross(t);
        if b.dot(s.dpdv) < 0.0 {
            b = -b;
        }
        match (t * tangent_normal.x + b * tangent_normal.y + s.ns * tangent_normal.z).try_normalize() {
            Some(n) if n.dot(wo) >= 1e-4 && n.dot(s.ng) > 0.0 => n,
            _ => s.ns,
        }
    }

    /// Shading inputs at a surface point.
    #[inline]
    pub(crate) fn shade<T: Touch>(&self, s: &Surface, filter: Filter, touch: &T) -> ShadingInputs {
        self.shading.evaluate(s.material, &s.uv, filter, touch)
    }

    /// How much of a light sample a shadow ray from `origin` along unit `dir` carries to distance
    /// `tmax` (0: blocked; 1 through nothing or only holes). Pass-through odds are decided once per
    /// triangle by a hash of `seed` (the same odds as camera and BSDF rays). The refracting part of a
    /// transmissive surface ([`ShadingInputs::refracts`]) blocks light from area lights, domes and
    /// emitters, which paths that refract through it find by BSDF sampling (counting it here too
    /// would count it twice); towards a `delta` light, which no sampled direction can reach, the ray
    /// goes on straight with the interface's normal-incidence transmittance
    /// ([`normal_transmittance`]): the stated approximation that keeps shadows under clear glass
    /// from going black (no refraction offset, no focusing, no angle dependence). When some
    /// material's opacity is textured, the ray walks closest hits and evaluates opacity at each;
    /// otherwise one any-hit query answers. `light` is the light the ray goes to when the scene
    /// has light sets: triangles that do not shadow it are not there (shadow linking). `time` is
    /// the path's ray time (moving instances are where they are then).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn shadow_transmittance<T: Touch>(
        &self,
        origin: Vec3,
        dir: Vec3,
        tmax: f32,
        time: f32,
        seed: u32,
        delta: bool,
        light: Option<usize>,
        filter: Filter,
        touch: &T,
    ) -> f32 {
        // Shadow linking: triangles whose light set does not shadow `light` are not there for
        // this ray ([`crate::lights::links`]).
        let links = light.and_then(|l| Some((self.lights.links()?, l)));
        let ignored = |tri: u32| links.is_some_and(|(links, l)| !links.shadows(links.set_of(tri), l));
        // Instances of one prototype triangle decide independently (the instance joins the hash).
        let passes = |tri: u32, instance: u32, opacity: f32| {
            let h = if instance == blob::NONE { seed } else { hash_combine(seed, instance) };
            opacity < 1.0 && (hash_combine(h, tri) >> 8) as f32 * (1.0 / 16_777_216.0) >= opacity
        };
        // What a crossing the hash let through keeps: all of it through a hole, the interface's
        // transmittance through glass towards a delta light, nothing through glass otherwise.
        let crossing = |inputs: &ShadingInputs| match (inputs.refracts(), delta) {
            (false, _) => 1.0,
            (true, true) => normal_transmittance(inputs.ior),
            (true, false) => 0.0,
        };
        let constant = |tri: u32| {
            let m = &self.view.materials[self.view.triangle_materials[tri as usize] as usize];
            ShadingInputs::constant(m)
        };
        if !self.shading.any_textured_opacity() {
            // An any-hit query may report a triangle more than once (pre-split triangles sit in
            // several leaves), so each glass crossing is counted once, by (triangle, instance).
            let mut crossed = [(blob::NONE, blob::NONE); MAX_GLASS_CROSSINGS];
            let mut crossings = 0;
            let mut kept = 1.0f32;
            let blocked = self.accel.any_hit_at(origin, dir, tmax, time, |tri, inst| {
                if ignored(tri) {
                    return false;
                }
                let inputs = constant(tri);
                if !passes(tri, inst, inputs.effective_opacity()) {
                    return true;
                }
                let through = crossing(&inputs);
                if through == 1.0 || crossed[..crossings].contains(&(tri, inst)) {
                    return false;
                }
                if through == 0.0 || crossings == MAX_GLASS_CROSSINGS {
                    return true;
                }
                crossed[crossings] = (tri, inst);
                crossings += 1;
                kept *= through;
                false
            });
            return if blocked { 0.0 } else { kept };
        }
        let end = origin + dir * tmax;
        let mut o = origin;
        let mut kept = 1.0f32;
        for _ in 0..MAX_NULL_EVENTS {
            let remaining = if tmax.is_finite() { (end - o).dot(dir) } else { f32::INFINITY };
            if remaining <= 0.0 {
                return kept;
            }
            let Some(hit) = self.accel.closest_hit_at(o, dir, remaining, time) else { return kept };
            let Some(s) = self.surface(&hit, -dir, 0.0) else { return 0.0 };
            if ignored(hit.triangle) {
                o = offset_ray_origin(s.p, -s.ng);
                continue;
            }
            let inputs = if self.shading.flags(s.material).textured_opacity {
                self.shade(&s, filter, touch)
            } else {
                constant(hit.triangle)
            };
            if !passes(hit.triangle, hit.instance, inputs.effective_opacity()) {
                return 0.0;
            }
            kept *= crossing(&inputs);
            if kept == 0.0 {
                return 0.0;
            }
            o = offset_ray_origin(s.p, -s.ng);
        }
        0.0
    }

    /// Emitted radiance at barycentrics `(b1, b2)` of emissive triangle `tri` (a light sample), with
    /// a point lookup (a light sample has no pixel footprint).
    pub(crate) fn emission_at<T: Touch>(
        &self,
        tri: u32,
        b1: f32,
        b2: f32,
        filter: Filter,
        touch: &T,
    ) -> Vec3 {
        let material = self.view.triangle_materials[tri as usize];
        if !self.shading.flags(material).textured_emission {
            return self.lights.triangle_emission(tri);
        }
        let [p0, p1, p2] = self.accel.triangle_vertices(tri);
        // Any direction off the surface will do: emission is two-sided and only uv matters here.
        let wo = (p1 - p0).cross(p2 - p0).normalize_or_zero();
        // Emissive triangles are always top level (ingest never instances them).
        let hit = crate::accel::Hit { t: 0.0, triangle: tri, b1, b2, instance: blob::NONE, time: 0.0 };
        self.surface(&hit, wo, 0.0)
            .map_or(Vec3::ZERO, |s| self.shade(&s, filter, touch).emissive_color.max(Vec3::ZERO))
    }
}

#[cfg(test)]
pub(crate) mod surface_tests {
    use super::*;
    use crate::accel::Hit;
    use crate::testscene::{self, Rng};

    /// [`Scene::surface`] as it was written before it was tuned (kept verbatim as the reference): the
    /// vertices and normals moved to world space through the [`crate::Accel`] helpers, one lookup per
    /// call, `array::map` over the vertices.
    fn reference_surface(scene: &Scene, hit: &Hit, wo: Vec3, footprint: f32) -> Option<Surface> {
        let view = &scene.view;
        let tri = &view.triangles[hit.triangle as usize];
        let [p0, p1, p2] = scene.accel.hit_vertices(hit);
        let b0 = 1.0 - hit.b1 - hit.b2;
        let p = p0 * b0 + p1 * hit.b1 + p2 * hit.b2;
        let mut ng = (p1 - p0).cross(p2 - p0).try_normalize()?;
        if ng.dot(wo) < 0.0 {
            ng = -ng;
        }
        let mesh = &view.meshes[tri.mesh as usize];
        let mut ns = ng;
        if mesh.flags & blob::MESH_HAS_NORMALS != 0 {
            let [n0, n1, n2] = tri.vertices.map(|v| Vec3::from(view.normals[v as usize]));
            let n = scene.accel.normal_to_world(hit, n0 * b0 + n1 * hit.b1 + n2 * hit.b2);
            if let Some(n) = n.try_normalize() {
                ns = if n.dot(ng) < 0.0 { -n } else { n };
                if ns.dot(wo) < 1e-4 {
                    ns = ng;
                }
            }
        }
        let (mut uv, mut dpdu, mut dpdv) = (UvFootprint::default(), Vec3::ZERO, Vec3::ZERO);
        if mesh.flags & blob::MESH_HAS_UVS != 0 {
            let [t0, t1, t2] = tri.vertices.map(|v| glam::Vec2::from(view.uvs[v as usize]));
            let at = t0 * b0 + t1 * hit.b1 + t2 * hit.b2;
            let (e1, e2) = (p1 - p0, p2 - p0);
            let (d1, d2) = (t1 - t0, t2 - t0);
            let det = d1.x * d2.y - d1.y * d2.x;
            if det != 0.0 && det.is_finite() {
                dpdu = (e1 * d2.y - e2 * d1.y) / det;
                dpdv = (e2 * d1.x - e1 * d2.x) / det;
            }
            let d = -wo;
            let axis1 = (ng - d * ng.dot(d)).try_normalize().unwrap_or_else(|| Frame::new(d).t);
            let axis2 = d.cross(axis1);
            let cos = ng.dot(d);
            let cos = if cos.abs() < 1e-4 { 1e-4f32.copysign(cos) } else { cos };
            let on_plane = |v: Vec3| v - d * (v.dot(ng) / cos);
            let (g11, g12, g22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
            let gram = g11 * g22 - g12 * g12;
            let to_uv = |v: Vec3| {
                if gram <= 0.0 {
                    return [0.0; 2];
                }
                let (r1, r2) = (v.dot(e1), v.dot(e2));
                let a = (r1 * g22 - r2 * g12) / gram;
                let b = (r2 * g11 - r1 * g12) / gram;
                (d1 * a + d2 * b).to_array()
            };
            uv = UvFootprint {
                uv: at.to_array(),
                duv_dx: to_uv(on_plane(axis1 * footprint)),
                duv_dy: to_uv(on_plane(axis2 * footprint)),
                has_uv: true,
                point: None,
            };
        }
        uv.point = Some(crate::shading::MeshPoint { triangle: hit.triangle, b1: hit.b1, b2: hit.b2 });
        Some(Surface {
            p,
            ng,
            ns,
            material: view.triangle_materials[hit.triangle as usize],
            uv,
            dpdu,
            dpdv,
            triangle: hit.triangle,
            curve: None,
        })
    }

    /// Every field of a triangle surface as bits (floats compared by their bit patterns, so a
    /// difference in the last place or the sign of a zero fails).
    pub(crate) fn bits(s: &Surface) -> Vec<u32> {
        let point = s.uv.point.expect("triangle surfaces record their point");
        let mut out: Vec<u32> = [s.p, s.ng, s.ns, s.dpdu, s.dpdv]
            .iter()
            .flat_map(|v| v.to_array())
            .chain(s.uv.uv)
            .chain(s.uv.duv_dx)
            .chain(s.uv.duv_dy)
            .chain([point.b1, point.b2])
            .map(f32::to_bits)
            .collect();
        out.extend([s.material, s.triangle, point.triangle, s.uv.has_uv as u32, s.curve.is_some() as u32]);
        out
    }

    pub(crate) fn random_unit(rng: &mut Rng) -> Vec3 {
        loop {
            let v = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
            if let Some(u) = v.try_normalize() {
                return u;
            }
        }
    }

    /// The tuned [`Scene::surface`] returns the reference's bits on random hits: instanced spheres
    /// (mirrored ones too), a world-space sphere with and one without normals (both with uvs, poles
    /// with degenerate uv triangles), a random triangle cloud without either; seen along the ray, from
    /// random directions (flipped and grazing normals) and with random and zero footprints.
    #[test]
    fn tuned_surface_equals_reference_bit_for_bit() {
        let mut ingest_scene = testscene::instanced_spheres(12, 0x5eed);
        ingest_scene.meshes.push(testscene::sphere(Vec3::new(1.0, 0.5, -1.0), 0.8, 7, 11, 0, false));
        ingest_scene.meshes.push(scene_pack::Mesh {
            normals: Vec::new(),
            ..testscene::sphere(Vec3::new(-1.5, -0.5, 1.0), 0.7, 5, 9, 0, true)
        });
        let bytes = testscene::bytes(&ingest_scene);
        let view = blob::SceneView::parse(&bytes).unwrap();
        let scene = Scene::new(view);
        let mut rng = Rng(0xfeed);
        let (mut instanced, mut top, mut with_uvs, mut with_normals) = (0, 0, 0, 0);
        for _ in 0..4000 {
            let origin = random_unit(&mut rng) * 7.0;
            let target = Vec3::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0), rng.range(-3.0, 3.0));
            let dir = (target - origin).normalize();
            let Some(hit) = scene.accel.closest_hit(origin, dir, f32::INFINITY) else { continue };
            let b1 = rng.next_f32();
            let moved = Hit { b1, b2: (1.0 - b1) * rng.next_f32(), ..hit };
            for (hit, wo, footprint) in
                [(hit, -dir, 0.0), (hit, -dir, rng.range(0.0, 0.1)), (moved, random_unit(&mut rng), 0.05)]
            {
                let tuned = scene.surface(&hit, wo, footprint);
                let reference = reference_surface(&scene, &hit, wo, footprint);
                assert_eq!(tuned.as_ref().map(bits), reference.as_ref().map(bits), "{hit:?} wo {wo}");
            }
            let mesh = &scene.view.meshes[scene.view.triangles[hit.triangle as usize].mesh as usize];
            with_uvs += (mesh.flags & blob::MESH_HAS_UVS != 0) as u32;
            with_normals += (mesh.flags & blob::MESH_HAS_NORMALS != 0) as u32;
            if hit.instance == blob::NONE {
                top += 1;
            } else {
                instanced += 1;
            }
        }
        // Every branch is exercised many times.
        assert!(instanced > 300 && top > 300, "instanced {instanced}, top-level {top}");
        assert!(with_uvs > 300 && with_normals > 300 && top + instanced - with_uvs > 50, "uvs {with_uvs}");
    }
}
