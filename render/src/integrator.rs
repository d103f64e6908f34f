//! The scalar, depth-first, unidirectional path tracer.
//!
//! Per path vertex: gather emission (area lights crossed by the incoming segment, the emissive triangle
//! hit, or dome/distant lights on escape — all MIS-weighted against light sampling with the power
//! heuristic), resolve stochastic transparency, sample one light (next-event estimation, MIS-weighted
//! against BSDF sampling), sample the BSDF, and after [`RR_START_BOUNCE`] bounces play unbiased Russian
//! roulette on the throughput. Every random number is [`sample_1d`]/[`sample_2d`] of the path's
//! [`SampleKey`], its vertex counter and a fixed dimension (see [`crate::sampler::dim`]), so the result is
//! a pure function of the keys.

use crate::accel::offset_ray_origin;
use crate::bsdf::{Bsdf, BsdfSample};
use crate::curves::CurveHit;
use crate::hair::HairBsdf;
use crate::lights::power_heuristic;
use crate::sampler::{dim, hash_combine, hash_u32, sample_1d, sample_2d, SampleKey};
use crate::scene::Scene;
use glam::Vec3;

/// Bounces before Russian roulette starts.
pub const RR_START_BOUNCE: u32 = 3;
/// Null (pass-through) events allowed per path on top of `max_depth`, so stacks of transparent cards
/// cannot loop forever.
pub const MAX_NULL_EVENTS: u32 = 64;

/// First-hit data for the AOVs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FirstHit {
    /// Diffuse albedo of the first scattering surface.
    pub albedo: Vec3,
    /// World-space shading normal there (facing the camera).
    pub normal: Vec3,
    /// Distance from the camera.
    pub depth: f32,
}

/// Result of one camera path.
#[derive(Clone, Copy, Debug, Default)]
pub struct PathResult {
    /// Radiance along the camera ray.
    pub radiance: Vec3,
    /// `Some` if the camera ray reached a surface.
    pub first_hit: Option<FirstHit>,
}

/// Ray counts, summed per tile.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    /// Camera rays.
    pub camera: u64,
    /// Closest-hit rays after the first (BSDF continuations and pass-throughs).
    pub bounce: u64,
    /// Any-hit shadow rays.
    pub shadow: u64,
}

impl RayCounts {
    /// All rays.
    pub fn total(&self) -> u64 {
        self.camera + self.bounce + self.shadow
    }
    /// Adds `other` into `self`.
    pub fn add(&mut self, other: &RayCounts) {
        self.camera += other.camera;
        self.bounce += other.bounce;
        self.shadow += other.shadow;
    }
}

/// UsdPreviewSurface opacity as a pass-through probability: `opacityThreshold > 0` makes it a cut-out.
#[inline]
fn effective_opacity(m: &blob::Material) -> f32 {
    if m.opacity_threshold > 0.0 {
        if m.opacity < m.opacity_threshold {
            0.0
        } else {
            1.0
        }
    } else {
        m.opacity.clamp(0.0, 1.0)
    }
}

/// Surface data at a hit.
struct Surface {
    p: Vec3,
    /// Geometric normal facing the incoming ray's origin.
    ng: Vec3,
    /// Shading normal on the same side as `ng`.
    ns: Vec3,
    material: u32,
    /// Triangle hit, or [`blob::NONE`] for curves and points.
    triangle: u32,
    /// Curve and point hits.
    curve: Option<CurveSurface>,
}

/// What a curve or point hit adds to [`Surface`].
struct CurveSurface {
    /// Hair BSDF (curves) rather than UsdPreviewSurface (points).
    hair: Option<HairBsdf>,
    /// Diffuse colour (points with per-point colours).
    color: Vec3,
    /// Rays leave a fibre from `p + w · spawn` (its diameter and then some): a fibre's own hair BSDF
    /// already accounts for light crossing it, so the ray must not meet the same fibre again. Zero for
    /// points (offset along the normal like triangles).
    spawn: f32,
}

impl Surface {
    /// Origin for a ray leaving the surface in direction `w`.
    fn spawn(&self, w: Vec3) -> Vec3 {
        match &self.curve {
            Some(c) if c.spawn > 0.0 => self.p + w * c.spawn,
            _ => offset_ray_origin(self.p, if w.dot(self.ng) >= 0.0 { self.ng } else { -self.ng }),
        }
    }
}

/// The BSDF at a hit: UsdPreviewSurface (triangles, points) or hair (curves).
enum SurfaceBsdf {
    Preview(Bsdf),
    Hair(HairBsdf),
}

impl SurfaceBsdf {
    fn eval(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        match self {
            SurfaceBsdf::Preview(b) => b.eval(wo, wi),
            SurfaceBsdf::Hair(h) => h.eval(wo, wi),
        }
    }
    fn sample(&self, wo: Vec3, u_lobe: f32, u: [f32; 2]) -> Option<BsdfSample> {
        match self {
            SurfaceBsdf::Preview(b) => b.sample(wo, u_lobe, u),
            SurfaceBsdf::Hair(h) => h.sample(wo, u_lobe, u),
        }
    }
    fn albedo(&self) -> Vec3 {
        match self {
            SurfaceBsdf::Preview(b) => b.diffuse_albedo(),
            SurfaceBsdf::Hair(h) => h.color(),
        }
    }
}

impl<'a> Scene<'a> {
    fn surface(&self, hit: &crate::accel::Hit, wo: Vec3) -> Option<Surface> {
        let view = &self.view;
        let tri = &view.triangles[hit.triangle as usize];
        let [p0, p1, p2] = self.accel.triangle_vertices(hit.triangle);
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
            if let Some(n) = (n0 * b0 + n1 * hit.b1 + n2 * hit.b2).try_normalize() {
                ns = if n.dot(ng) < 0.0 { -n } else { n };
                // A shading normal facing away from the viewer would make the BSDF black; fall back to
                // the true surface there.
                if ns.dot(wo) < 1e-4 {
                    ns = ng;
                }
            }
        }
        Some(Surface {
            p,
            ng,
            ns,
            material: view.triangle_materials[hit.triangle as usize],
            triangle: hit.triangle,
            curve: None,
        })
    }

    /// Surface data at a curve or point hit.
    fn curve_surface(&self, hit: &CurveHit, wo: Vec3) -> Surface {
        let curves = self.curves.view();
        let group = self.curves.group_of(hit.prim);
        let material = &self.view.materials[group.material as usize];
        let has_colors = group.flags & blob::curves::CURVE_HAS_COLORS != 0;
        let segments = curves.segments.len() as u32;
        let (ns, curve) = if group.kind == blob::curves::CURVE_POINTS {
            let sphere = &curves.spheres[(hit.prim - segments) as usize];
            let color =
                if has_colors { Vec3::from(sphere.color) } else { Vec3::from(material.diffuse_color) };
            (hit.n, CurveSurface { hair: None, color, spawn: 0.0 })
        } else {
            let attr = &curves.attributes[hit.prim as usize];
            let color = if has_colors {
                Vec3::from(attr.color[0]).lerp(Vec3::from(attr.color[1]), hit.u)
            } else {
                Vec3::from(material.diffuse_color)
            };
            let hair = HairBsdf::new(hit.tangent, wo, hit.h, color);
            let spawn = 2.5 * hit.radius + 1e-5 * hit.p.abs().max_element().max(1.0);
            (hair.normal(), CurveSurface { hair: Some(hair), color, spawn })
        };
        Surface {
            p: hit.p,
            ng: hit.n,
            ns,
            material: group.material,
            triangle: blob::NONE,
            curve: Some(curve),
        }
    }

    /// The BSDF of `material` at `s`.
    fn bsdf(&self, s: &Surface, material: &blob::Material) -> SurfaceBsdf {
        match &s.curve {
            Some(CurveSurface { hair: Some(h), .. }) => SurfaceBsdf::Hair(*h),
            Some(c) => SurfaceBsdf::Preview(Bsdf::new(
                &blob::Material { diffuse_color: c.color.to_array(), ..*material },
                s.ns,
                s.ng,
            )),
            None => SurfaceBsdf::Preview(Bsdf::new(material, s.ns, s.ng)),
        }
    }

    /// Traces one camera path with keys `key`.
    pub fn trace_path(
        &self,
        mut origin: Vec3,
        mut dir: Vec3,
        key: SampleKey,
        max_depth: u32,
        rays: &mut RayCounts,
    ) -> PathResult {
        let mut result = PathResult::default();
        let mut beta = Vec3::ONE;
        let mut radiance = Vec3::ZERO;
        // Previous scattering vertex and BSDF pdf, for MIS of emission found by BSDF sampling.
        let mut prev: Option<(Vec3, f32)> = None;
        let mut bounces = 0u32;
        let mut vertex = 0u32;
        let mut travelled = 0.0f32;
        let shadow_seed = hash_combine(hash_combine(hash_u32(key.seed), key.pixel), key.sample);
        rays.camera += 1;
        loop {
            let hit = self.accel.closest_hit(origin, dir, f32::INFINITY);
            // Curves and points have their own BVH; only hits closer than the triangle count.
            let curve_hit = self.curves.closest_hit(origin, dir, hit.map_or(f32::INFINITY, |h| h.t));
            let t_hit = curve_hit.map_or(hit.map_or(f32::INFINITY, |h| h.t), |c| c.t);
            radiance += beta * self.lights.area_emission(origin, dir, t_hit, prev);
            let wo = -dir;
            let s = match (curve_hit, hit) {
                (Some(c), _) => self.curve_surface(&c, wo),
                (None, Some(h)) => match self.surface(&h, wo) {
                    Some(s) => s,
                    None => break,
                },
                (None, None) => {
                    radiance += beta * self.lights.escaped_emission(dir, prev.map(|p| p.1));
                    break;
                }
            };
            let material = &self.view.materials[s.material as usize];

            // Stochastic transparency: continue straight with probability 1 − opacity.
            let opacity = effective_opacity(material);
            if opacity < 1.0 && sample_1d(key, vertex, dim::OPACITY) >= opacity {
                vertex += 1;
                if vertex > max_depth + MAX_NULL_EVENTS {
                    break;
                }
                travelled += t_hit;
                origin = s.spawn(dir);
                rays.bounce += 1;
                continue;
            }

            let bsdf = self.bsdf(&s, material);
            if result.first_hit.is_none() && bounces == 0 {
                result.first_hit =
                    Some(FirstHit { albedo: bsdf.albedo(), normal: s.ns, depth: travelled + t_hit });
            }

            let le = Vec3::from(material.emissive_color).max(Vec3::ZERO);
            if le != Vec3::ZERO {
                let w = match prev {
                    // Curves are not sampled as lights: BSDF sampling is their only strategy.
                    Some((p, bsdf_pdf)) if s.triangle != blob::NONE => {
                        power_heuristic(bsdf_pdf, self.lights.triangle_pdf(s.triangle, p, s.p))
                    }
                    _ => 1.0,
                };
                radiance += beta * le * w;
            }
            if bounces >= max_depth {
                break;
            }

            // Next-event estimation.
            let u_select = sample_1d(key, vertex, dim::LIGHT_SELECT);
            let u_light = sample_2d(key, vertex, dim::LIGHT_UV);
            if let Some(ls) = self.lights.sample(s.p, u_select, u_light) {
                let (f, bsdf_pdf) = bsdf.eval(wo, ls.wi);
                let contribution = beta * f * ls.li * (s.ns.dot(ls.wi).abs() / ls.pdf);
                if contribution.max_element() > 0.0 {
                    let w = if ls.delta { 1.0 } else { power_heuristic(ls.pdf, bsdf_pdf) };
                    let shadow_origin = s.spawn(ls.wi);
                    let tmax = if ls.distance.is_finite() {
                        (ls.distance - (shadow_origin - s.p).length()) * (1.0 - 1e-4)
                    } else {
                        f32::INFINITY
                    };
                    rays.shadow += 1;
                    let occluded = self.accel.any_hit(shadow_origin, ls.wi, tmax, |tri| {
                        let m = &self.view.materials[self.view.triangle_materials[tri as usize] as usize];
                        let op = effective_opacity(m);
                        // Same pass-through odds as camera and BSDF rays, decided once per triangle.
                        op >= 1.0
                            || (hash_combine(shadow_seed ^ vertex, tri) >> 8) as f32 * (1.0 / 16_777_216.0)
                                < op
                    }) || self.curves.any_hit(shadow_origin, ls.wi, tmax);
                    if !occluded {
                        radiance += contribution * w;
                    }
                }
            }

            // BSDF sampling.
            let u_lobe = sample_1d(key, vertex, dim::LOBE);
            let u_bsdf = sample_2d(key, vertex, dim::BSDF_UV);
            let Some(bs) = bsdf.sample(wo, u_lobe, u_bsdf) else { break };
            beta *= bs.f * (s.ns.dot(bs.wi).abs() / bs.pdf);
            prev = Some((s.p, bs.pdf));
            bounces += 1;
            if bounces >= RR_START_BOUNCE {
                let survive = beta.max_element().min(0.95);
                if sample_1d(key, vertex, dim::RUSSIAN_ROULETTE) >= survive {
                    break;
                }
                beta /= survive;
            }
            vertex += 1;
            origin = s.spawn(bs.wi);
            dir = bs.wi;
            travelled = 0.0;
            rays.bounce += 1;
        }
        result.radiance = radiance;
        result
    }
}
