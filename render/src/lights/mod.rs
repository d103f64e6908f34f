//! UsdLux lights and emissive triangles: sampling for next-event estimation, and the emission and pdf
//! a BSDF-sampled ray sees when it reaches a light (for multiple importance sampling).
//!
//! Conventions (UsdLux schema text):
//! * Every light's radiance is `color · intensity · 2^exposure` (the blob's `radiance`).
//! * `normalize` divides the radiance of rect, disk and sphere lights by their world-space surface area
//!   (rect w·h, disk πr², sphere 4πr²), so power does not depend on size. Dome lights ignore it.
//! * A DomeLight with a lat-long `texture:file` shows `radiance × map(direction)` and is sampled by
//!   the map's luminance distribution ([`crate::lights::dome_map`]); an untextured one is uniform.
//! * DistantLight: with `normalize` the intensity is the illuminance E at normal incidence whatever the
//!   angle, so the radiance over the cone of half-angle θ/2 is E / (π sin²(θ/2)); without `normalize`
//!   the radiance over the cone is the intensity itself. An angle of 0 is a delta light of illuminance
//!   E = intensity.
//! * Rect and disk lights emit from their light-space XY plane along −Z only; sphere lights and emissive
//!   triangles emit from both sides of their surface. `treatAsPoint` turns a sphere into a point light
//!   of the same power (intensity I = L·πr²).
//! * Area lights (rect, disk, sphere) are not in the BVH: they are intersected analytically by every
//!   camera and BSDF ray, and neither block rays nor shadow rays (lights are not geometry).
//! * A light flagged [`blob::LIGHT_CAMERA_HIDDEN`] is not seen by camera rays (no previous
//!   vertex: straight from the camera or through cut-outs); it lights the scene and shows in
//!   reflections as any other. Light and shadow linking: [`links`].
//!
//! The selection list holds the UsdLux lights plus one entry standing for all emissive triangles
//! (which are then chosen by the blob's power-proportional distribution). A light is selected by
//! [`tree::LightSelector`]: a uniform first choice among the lights at infinity (dome, distant: their
//! "power" depends on the scene's extent) and one slot for the light BVH over the others, which
//! picks by importance at the shading point.

pub mod area_groups;
pub mod dome_map;
pub mod emission_lanes;
pub mod lanes;
pub mod light;
pub mod links;
pub mod mis;

pub mod tree;

use crate::bsdf::sample_concentric_disk;
use crate::camera::affine_from_rows;
use crate::lights::dome_map::DomeMap;
use glam::Vec3;
use light::{ray_sphere, sample_cone, uniform_sphere};
pub use light::{Light, LightSample, Shape};
use links::LightLinks;
pub use mis::power_heuristic;
use std::f32::consts::{PI, TAU};

/// The scene's lights, ready for sampling.
#[derive(Clone, Debug)]
pub struct Lights<'a> {
    lights: Vec<Light>,
    /// The textured domes' maps, by [`Shape::TexturedDome::map`].
    dome_maps: Vec<DomeMap<'a>>,
    /// Indices into `lights` of the rect/disk/sphere lights rays can hit, in the order rays sum
    /// their emission ([`area_groups::morton_order`]).
    area: Vec<usize>,
    /// The box of each run of [`area_groups::GROUP`] lights of `area`.
    area_boxes: Vec<area_groups::GroupBox>,
    /// Indices into `lights` of the dome and non-delta distant lights escaping rays can see.
    infinite: Vec<usize>,
    /// Which light to sample at a point, and with what probability.
    selector: tree::LightSelector,
    emissive: &'a [blob::EmissiveTriangle],
    /// (triangle, index into `emissive`), sorted by triangle.
    emissive_by_triangle: Vec<(u32, u32)>,
    positions: &'a [[f32; 3]],
    triangles: &'a [blob::Triangle],
    triangle_materials: &'a [u32],
    materials: &'a [blob::Material],
    /// Light and shadow linking ([`links`]); `None` when nothing is linked.
    links: Option<LightLinks<'a>>,
    /// Per entry of `lights`: camera rays do not see it ([`blob::LIGHT_CAMERA_HIDDEN`]); empty
    /// when every light is visible.
    camera_hidden: Vec<bool>,
}

impl<'a> Lights<'a> {
    /// Collects the lights of a validated scene.
    pub fn new(view: &blob::SceneView<'a>) -> Self {
        let mut lights: Vec<Light> = view.lights.iter().map(Light::from_blob).collect();
        // One map per textured dome (each with its own rotation); a map that cannot be viewed (never,
        // on a validated blob) leaves the dome uniform.
        let mut dome_maps = Vec::new();
        for (light, rec) in lights.iter_mut().zip(view.lights) {
            if let Shape::TexturedDome { map } = &mut light.shape {
                let m = affine_from_rows(&rec.world_from_light).matrix3.into();
                match DomeMap::new(view, rec.dome_map, m) {
                    Some(dome) => {
                        *map = dome_maps.len() as u32;
                        dome_maps.push(dome);
                    }
                    None => light.shape = Shape::Dome,
                }
            }
        }
        if !view.emissive_triangles.is_empty() {
            lights.push(Light { shape: Shape::Triangles, radiance: Vec3::ONE });
        }
        let area_bounds: Vec<(usize, Vec3, Vec3)> =
            (0..lights.len()).filter_map(|i| lights[i].bounds().map(|(lo, hi)| (i, lo, hi))).collect();
        let area = area_groups::morton_order(&area_bounds);
        let area_boxes = area
            .chunks(area_groups::GROUP)
            .map(|group| area_groups::group_box(group.iter().filter_map(|&i| lights[i].bounds())))
            .collect();
        let infinite = (0..lights.len())
            .filter(|&i| match lights[i].shape {
                Shape::Dome | Shape::TexturedDome { .. } => true,
                Shape::Distant { one_minus_cos_max, .. } => one_minus_cos_max > 0.0,
                _ => false,
            })
            .collect();
        let mut camera_hidden: Vec<bool> =
            view.lights.iter().map(|l| l.flags & blob::LIGHT_CAMERA_HIDDEN != 0).collect();
        if !camera_hidden.contains(&true) {
            camera_hidden.clear();
        }
        let mut emissive_by_triangle: Vec<(u32, u32)> =
            view.emissive_triangles.iter().enumerate().map(|(i, e)| (e.triangle, i as u32)).collect();
        emissive_by_triangle.sort_unstable();
        let triangle_points =
            |t: u32| view.triangles[t as usize].vertices.map(|v| Vec3::from(view.positions[v as usize]));
        let emission = |t: u32| {
            let m = &view.materials[view.triangle_materials[t as usize] as usize];
            Vec3::from(m.emissive_color).max(Vec3::ZERO).max_element()
        };
        // Two-sided Lambertian emitters: 2π L A each. Textured emission may leave the constant at
        // zero; then area alone (unit radiance) keeps the entry selectable.
        let power: f32 = view.emissive_triangles.iter().map(|e| TAU * e.area * emission(e.triangle)).sum();
        let power = if power > 0.0 {
            power
        } else {
            view.emissive_triangles.iter().map(|e| TAU * e.area).sum::<f32>().max(f32::MIN_POSITIVE)
        };
        let triangle_bounds = tree::LightBounds::of_triangles(
            view.emissive_triangles.iter().flat_map(|e| triangle_points(e.triangle)),
            power,
        );
        Lights {
            selector: tree::LightSelector::new(&lights, triangle_bounds),
            lights,
            dome_maps,
            area,
            area_boxes,
            infinite,
            emissive: view.emissive_triangles,
            emissive_by_triangle,
            positions: view.positions,
            triangles: view.triangles,
            triangle_materials: view.triangle_materials,
            materials: view.materials,
            links: LightLinks::new(view),
            camera_hidden,
        }
    }

    /// Whether [`Lights::area_emission_linked`] and [`Lights::escaped_emission_linked`] differ
    /// from the unlinked sums for some ray (light sets, or lights camera rays do not see): the
    /// wavefront then sums emission per ray with them instead of its lane kernel.
    #[inline]
    pub fn emission_per_ray(&self) -> bool {
        self.links.is_some() || !self.camera_hidden.is_empty()
    }

    /// Whether camera rays see light `light` (an index into [`Lights::lights`]).
    #[inline]
    fn camera_sees(&self, light: usize) -> bool {
        !self.camera_hidden.get(light).copied().unwrap_or(false)
    }

    /// Light and shadow linking, when the scene has any.
    #[inline]
    pub fn links(&self) -> Option<&LightLinks<'a>> {
        self.links.as_ref()
    }

    /// The light [`Lights::sample`] selects at `p` with `u_select` (an index into
    /// [`Lights::lights`]); the selector must not be empty.
    pub fn selected(&self, p: Vec3, u_select: f32) -> usize {
        self.selector.select(p, u_select).0
    }

    /// With linking, the light [`Lights::sample`] selects at `p` with `u_select` when it lights
    /// points of light set `set` (`Some(None)`: it does not; the sample is dropped, the selection
    /// pdf unchanged). `None` without linking.
    pub fn linked_choice(&self, set: u32, p: Vec3, u_select: f32) -> Option<Option<usize>> {
        let links = self.links.as_ref()?;
        if self.selector.is_empty() {
            return Some(None);
        }
        let light = self.selected(p, u_select);
        Some(links.lights(set, light).then_some(light))
    }

    /// The same lights selected uniformly, as before the light tree: the reference of tests.
    #[cfg(test)]
    pub(crate) fn with_uniform_selection(mut self) -> Self {
        self.selector = tree::LightSelector::uniform(self.lights.len());
        self
    }

    /// The light selection (the wavefront's lane kernel runs its descent per lane).
    pub(crate) fn selector(&self) -> &tree::LightSelector {
        &self.selector
    }

    /// The emissive triangles' power distribution.
    pub(crate) fn emissive(&self) -> &[blob::EmissiveTriangle] {
        self.emissive
    }

    /// True if there is nothing to sample.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// The selection list.
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    pub(crate) fn triangle_points(&self, triangle: u32) -> [Vec3; 3] {
        self.triangles[triangle as usize].vertices.map(|v| Vec3::from(self.positions[v as usize]))
    }

    /// Emitted radiance of a triangle's material (zero for non-emissive materials).
    pub fn triangle_emission(&self, triangle: u32) -> Vec3 {
        let m = &self.materials[self.triangle_materials[triangle as usize] as usize];
        Vec3::from(m.emissive_color).max(Vec3::ZERO)
    }

    /// Whether any dome light has a map ([`Lights::is_textured_dome`] is false for every `u_select`
    /// otherwise).
    pub(crate) fn has_textured_dome(&self) -> bool {
        !self.dome_maps.is_empty()
    }

    /// Whether [`Lights::sample`] with `u_select` picks a textured dome.
    pub(crate) fn is_textured_dome(&self, u_select: f32) -> bool {
        !self.dome_maps.is_empty()
            && self
                .selector
                .infinite_choice(u_select)
                .is_some_and(|i| matches!(self.lights[i].shape, Shape::TexturedDome { .. }))
    }

    /// Samples a light as seen from `p`.
    pub fn sample(&self, p: Vec3, u_select: f32, u: [f32; 2]) -> Option<LightSample> {
        if self.selector.is_empty() {
            return None;
        }
        let (index, sel) = self.selector.select(p, u_select);
        let light = &self.lights[index];
        let area_sample = |x: Vec3, n: Vec3, area: f32, two_sided: bool, li: Vec3| {
            let to = x - p;
            let d2 = to.length_squared();
            let distance = d2.sqrt();
            let wi = to / distance;
            let cos = -n.dot(wi);
            let cos = if two_sided { cos.abs() } else { cos };
            (cos > 0.0 && distance > 0.0 && area > 0.0).then(|| LightSample {
                wi,
                distance,
                li,
                pdf: sel * d2 / (cos * area),
                delta: false,
                emitter: None,
            })
        };
        match light.shape {
            Shape::Dome => Some(LightSample {
                wi: uniform_sphere(u),
                distance: f32::INFINITY,
                li: light.radiance,
                pdf: sel / (4.0 * PI),
                delta: false,
                emitter: None,
            }),
            Shape::TexturedDome { map } => {
                let s = self.dome_maps[map as usize].sample(u)?;
                Some(LightSample {
                    wi: s.wi,
                    distance: f32::INFINITY,
                    li: light.radiance * s.texel,
                    pdf: sel * s.pdf,
                    delta: false,
                    emitter: None,
                })
            }
            Shape::Distant { to_light, one_minus_cos_max } => {
                if one_minus_cos_max == 0.0 {
                    Some(LightSample {
                        wi: to_light,
                        distance: f32::INFINITY,
                        li: light.radiance,
                        pdf: sel,
                        delta: true,
                        emitter: None,
                    })
                } else {
                    Some(LightSample {
                        wi: sample_cone(to_light, one_minus_cos_max, u),
                        distance: f32::INFINITY,
                        li: light.radiance,
                        pdf: sel / (TAU * one_minus_cos_max),
                        delta: false,
                        emitter: None,
                    })
                }
            }
            Shape::Point { position } => {
                let to = position - p;
                let d2 = to.length_squared();
                let distance = d2.sqrt();
                (distance > 0.0).then(|| LightSample {
                    wi: to / distance,
                    distance,
                    li: light.radiance / d2,
                    pdf: sel,
                    delta: true,
                    emitter: None,
                })
            }
            Shape::Sphere { center, radius } => {
                let dc = center - p;
                let dc2 = dc.length_squared();
                if dc2 <= radius * radius * (1.0 + 1e-4) {
                    let n = uniform_sphere(u);
                    let x = center + radius * n;
                    area_sample(x, n, 4.0 * PI * radius * radius, true, light.radiance)
                } else {
                    let sin2 = radius * radius / dc2;
                    let cos_max = (1.0 - sin2).max(0.0).sqrt();
                    let one_minus_cos_max = sin2 / (1.0 + cos_max);
                    let axis = dc / dc2.sqrt();
                    let wi = sample_cone(axis, one_minus_cos_max, u);
                    let distance = ray_sphere(p, wi, center, radius).unwrap_or_else(|| dc.dot(wi));
                    Some(LightSample {
                        wi,
                        distance,
                        li: light.radiance,
                        pdf: sel / (TAU * one_minus_cos_max),
                        delta: false,
                        emitter: None,
                    })
                }
            }
            Shape::Rect { center, ex, ey, normal, area } => {
                let x = center + (2.0 * u[0] - 1.0) * ex + (2.0 * u[1] - 1.0) * ey;
                area_sample(x, normal, area, false, light.radiance)
            }
            Shape::Disk { center, ex, ey, normal, area } => {
                let [a, b] = sample_concentric_disk(u);
                area_sample(center + a * ex + b * ey, normal, area, false, light.radiance)
            }
            Shape::Triangles => {
                // u[0] picks the triangle from the cdf and, stretched within its bucket, also serves
                // as the first coordinate of the position on it.
                let choice = u[0];
                let k = self.emissive.partition_point(|e| e.cdf <= choice).min(self.emissive.len() - 1);
                let e = &self.emissive[k];
                let lo = if k == 0 { 0.0 } else { self.emissive[k - 1].cdf };
                let u0 =
                    if e.pmf > 0.0 { ((choice - lo) / (e.cdf - lo)).clamp(0.0, 0.999_999_94) } else { 0.5 };
                let [a, b, c] = self.triangle_points(e.triangle);
                let su = u0.sqrt();
                let (b0, b1) = (1.0 - su, u[1] * su);
                let x = a * b0 + b * b1 + c * (1.0 - b0 - b1);
                let n = (b - a).cross(c - a).normalize_or_zero();
                let area = e.area / e.pmf.max(f32::MIN_POSITIVE);
                area_sample(x, n, area, true, self.triangle_emission(e.triangle))
                    .map(|s| LightSample { emitter: Some((e.triangle, [b1, 1.0 - b0 - b1])), ..s })
            }
        }
    }

    /// Solid-angle pdf (with selection) that NEE would have sampled point `x` of emissive `triangle`
    /// from `p`; 0 if the triangle is not in the distribution.
    pub fn triangle_pdf(&self, triangle: u32, p: Vec3, x: Vec3) -> f32 {
        let Ok(pos) = self.emissive_by_triangle.binary_search_by_key(&triangle, |&(t, _)| t) else {
            return 0.0;
        };
        let e = &self.emissive[self.emissive_by_triangle[pos].1 as usize];
        let [a, b, c] = self.triangle_points(triangle);
        let n = (b - a).cross(c - a).normalize_or_zero();
        let to = x - p;
        let d2 = to.length_squared();
        let cos = n.dot(to).abs() / d2.sqrt();
        if cos <= 0.0 || e.area <= 0.0 {
            return 0.0;
        }
        let Some(entry) = self.lights.len().checked_sub(1) else { return 0.0 };
        // The emissive triangles' entry is the last of the selection list.
        self.selector.pmf(p, entry) * e.pmf / e.area * d2 / cos
    }

    /// Radiance picked up by a ray from `o` along unit `d` from the area lights it crosses before
    /// `tmax`, MIS-weighted against light sampling from `prev` = (previous scattering point, BSDF pdf);
    /// `prev = None` for camera rays (weight 1).
    pub fn area_emission(&self, o: Vec3, d: Vec3, tmax: f32, prev: Option<(Vec3, f32)>) -> Vec3 {
        self.area_emission_where(o, d, tmax, prev, |_| true)
    }

    /// [`Lights::area_emission`] of the lights that light the previous vertex, whose light set is
    /// `prev_set`: for camera rays (`prev = None`, whatever `prev_set` holds) every light camera
    /// rays see; every light without linking.
    pub fn area_emission_linked(
        &self,
        o: Vec3,
        d: Vec3,
        tmax: f32,
        prev: Option<(Vec3, f32)>,
        prev_set: u32,
    ) -> Vec3 {
        match (&self.links, prev) {
            (Some(links), Some(_)) => {
                self.area_emission_where(o, d, tmax, prev, |light| links.lights(prev_set, light))
            }
            (_, None) if !self.camera_hidden.is_empty() => {
                self.area_emission_where(o, d, tmax, prev, |light| self.camera_sees(light))
            }
            _ => self.area_emission(o, d, tmax, prev),
        }
    }

    /// [`Lights::area_emission_linked`] of light `only` alone: the light-path-expression AOVs split
    /// emission by light when their expressions tell lights apart (`crate::aov`).
    pub(crate) fn area_emission_linked_of(
        &self,
        o: Vec3,
        d: Vec3,
        tmax: f32,
        prev: Option<(Vec3, f32)>,
        prev_set: u32,
        only: usize,
    ) -> Vec3 {
        match (&self.links, prev) {
            (Some(links), Some(_)) => {
                self.area_emission_where(o, d, tmax, prev, |l| l == only && links.lights(prev_set, l))
            }
            (_, None) if !self.camera_hidden.is_empty() => {
                self.area_emission_where(o, d, tmax, prev, |l| l == only && self.camera_sees(l))
            }
            _ => self.area_emission_where(o, d, tmax, prev, |l| l == only),
        }
    }

    /// [`Lights::escaped_emission_linked`] of light `only` alone (see
    /// [`Lights::area_emission_linked_of`]).
    pub(crate) fn escaped_emission_linked_of(
        &self,
        d: Vec3,
        bsdf_pdf: Option<f32>,
        prev_set: u32,
        only: usize,
    ) -> Vec3 {
        let mut sum = [Vec3::ZERO];
        match (&self.links, bsdf_pdf) {
            (Some(links), Some(_)) => self.escaped_emission_where(&[d], &[bsdf_pdf], &mut sum, |_, l| {
                l == only && links.lights(prev_set, l)
            }),
            _ => self.escaped_emission_where(&[d], &[bsdf_pdf], &mut sum, |_, l| l == only),
        }
        sum[0]
    }

    /// Whether light `index` of [`Lights::selected`] is the emissive triangles (an `O` event of
    /// the light-path expressions) rather than a UsdLux light.
    pub(crate) fn is_triangles(&self, index: usize) -> bool {
        self.lights.get(index).is_some_and(|l| matches!(l.shape, Shape::Triangles))
    }

    /// [`Lights::area_emission`] over the lights `lit(light)` accepts (indices into
    /// [`Lights::lights`]), in the same order.
    #[inline(always)]
    fn area_emission_where(
        &self,
        o: Vec3,
        d: Vec3,
        tmax: f32,
        prev: Option<(Vec3, f32)>,
        lit: impl Fn(usize) -> bool,
    ) -> Vec3 {
        // Most scenes have no area light: skip the ray's inverse direction and the group walk
        // (callgrind, tractor, scalar, 120×80 at 8 spp: 11.3 M instructions here without it).
        if self.area.is_empty() {
            return Vec3::ZERO;
        }
        let mut sum = Vec3::ZERO;
        let (o_a, inv_d) = (o.to_array(), d.recip().to_array());
        for (g, (group, b)) in self.area.chunks(area_groups::GROUP).zip(&self.area_boxes).enumerate() {
            if !area_groups::ray_meets(b, o_a, inv_d, tmax) {
                continue;
            }
            for (k, &i) in group.iter().enumerate() {
                if !lit(i) {
                    continue;
                }
                if let Some((t, _)) = self.lights[i].intersect(o, d, tmax) {
                    sum += self.area_term(g * area_groups::GROUP + k, o, d, t, prev);
                }
            }
        }
        sum
    }

    /// The area lights rays can hit, in the order [`Lights::area_emission`] sums them (the wavefront's
    /// lane kernel tests them eight at a time).
    pub(crate) fn area_lights(&self) -> impl Iterator<Item = &Light> {
        self.area.iter().map(|&i| &self.lights[i])
    }

    /// The box of each run of [`area_groups::GROUP`] lights of [`Lights::area_lights`].
    pub(crate) fn area_boxes(&self) -> &[area_groups::GroupBox] {
        &self.area_boxes
    }

    /// What [`Lights::area_emission`] adds for the light at position `area` of
    /// [`Lights::area_lights`] met at `t`: its radiance, MIS-weighted against light sampling from
    /// the previous vertex (which selects the light with the probability it had there).
    #[inline]
    pub(crate) fn area_term(&self, area: usize, o: Vec3, d: Vec3, t: f32, prev: Option<(Vec3, f32)>) -> Vec3 {
        let index = self.area[area];
        let light = &self.lights[index];
        let w = match prev {
            None => 1.0,
            Some((p, bsdf_pdf)) => {
                power_heuristic(bsdf_pdf, self.selector.pmf(p, index) * light.pdf_area_light(p, o + d * t))
            }
        };
        light.radiance * w
    }

    /// Radiance from the dome and distant cones along an escaping direction `d`, MIS-weighted
    /// against light sampling (`bsdf_pdf = None` for camera rays).
    pub fn escaped_emission(&self, d: Vec3, bsdf_pdf: Option<f32>) -> Vec3 {
        let mut sum = [Vec3::ZERO];
        self.escaped_emission_rays(&[d], &[bsdf_pdf], &mut sum);
        sum[0]
    }

    /// [`Lights::escaped_emission`] of the lights that light the previous vertex, whose light set
    /// is `prev_set`: for camera rays (`bsdf_pdf = None`, whatever `prev_set` holds) every light
    /// camera rays see; every light without linking.
    pub fn escaped_emission_linked(&self, d: Vec3, bsdf_pdf: Option<f32>, prev_set: u32) -> Vec3 {
        let mut sum = [Vec3::ZERO];
        match (&self.links, bsdf_pdf) {
            (Some(links), Some(_)) => self.escaped_emission_where(&[d], &[bsdf_pdf], &mut sum, |_, light| {
                links.lights(prev_set, light)
            }),
            _ => self.escaped_emission_rays(&[d], &[bsdf_pdf], &mut sum),
        }
        sum[0]
    }

    /// [`Lights::escaped_emission`] of many escaping rays (directions `dirs`, BSDF pdfs
    /// `bsdf_pdfs`), added to `sums` (zero on entry for the single ray's sum): the light list is
    /// walked once, each light's `match` resolved once for all rays (the wavefront passes a batch;
    /// the scalar integrator one ray), so each ray's sum is the same in both.
    // Lane loops index three columns by the same ray number.
    #[allow(clippy::needless_range_loop)]
    pub(crate) fn escaped_emission_rays(&self, dirs: &[Vec3], bsdf_pdfs: &[Option<f32>], sums: &mut [Vec3]) {
        self.escaped_emission_where(dirs, bsdf_pdfs, sums, |_, _| true);
    }

    /// [`Lights::escaped_emission_rays`] where `lit(ray, light)` accepts the light for the ray.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)]
    fn escaped_emission_where(
        &self,
        dirs: &[Vec3],
        bsdf_pdfs: &[Option<f32>],
        sums: &mut [Vec3],
        lit: impl Fn(usize, usize) -> bool,
    ) {
        let weight = |pdf: f32, bsdf_pdf: Option<f32>| {
            bsdf_pdf.map_or(1.0, |b| power_heuristic(b, self.selector.infinite_pmf() * pdf))
        };
        let n = dirs.len().min(bsdf_pdfs.len()).min(sums.len());
        for &i in &self.infinite {
            let light = &self.lights[i];
            match light.shape {
                Shape::Dome => {
                    for j in 0..n {
                        if !lit(j, i) {
                            continue;
                        }
                        sums[j] += light.radiance * weight(1.0 / (4.0 * PI), bsdf_pdfs[j]);
                    }
                }
                Shape::TexturedDome { map } => {
                    let map = &self.dome_maps[map as usize];
                    for j in 0..n {
                        if !lit(j, i) {
                            continue;
                        }
                        let (texel, pdf) = map.texel_and_pdf(dirs[j]);
                        sums[j] += light.radiance * texel * weight(pdf, bsdf_pdfs[j]);
                    }
                }
                Shape::Distant { to_light, one_minus_cos_max } => {
                    for j in 0..n {
                        if 1.0 - dirs[j].dot(to_light) > one_minus_cos_max || !lit(j, i) {
                            continue;
                        }
                        sums[j] += light.radiance * weight(1.0 / (TAU * one_minus_cos_max), bsdf_pdfs[j]);
                    }
                }
                _ => {}
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testscene::Rng;

    fn record(kind: u32, radiance: f32, normalize: bool) -> blob::Light {
        blob::Light {
            kind,
            flags: if normalize { blob::LIGHT_NORMALIZE } else { 0 },
            radiance: [radiance; 3],
            radius: 0.5,
            width: 2.0,
            height: 1.0,
            angle_degrees: 0.53,
            world_from_light: [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 2.0]],
            ..Default::default()
        }
    }

    /// Irradiance at the origin on a +Z-facing surface: ∫ L cos dω, estimated by light sampling.
    fn irradiance(lights: &Lights, n: usize) -> f32 {
        let mut rng = Rng(5);
        let mut e = 0.0f64;
        for _ in 0..n {
            if let Some(s) = lights.sample(Vec3::ZERO, rng.next_f32(), [rng.next_f32(), rng.next_f32()]) {
                e += (s.li.x * s.wi.z.max(0.0) / s.pdf) as f64;
            }
        }
        (e / n as f64) as f32
    }

    fn lights_of(records: &[blob::Light]) -> Lights<'static> {
        let lights: Vec<Light> = records.iter().map(Light::from_blob).collect();
        Lights {
            selector: tree::LightSelector::new(&lights, None),
            lights,
            dome_maps: vec![],
            area: vec![],
            area_boxes: vec![],
            infinite: vec![],
            emissive: &[],
            emissive_by_triangle: vec![],
            positions: &[],
            triangles: &[],
            triangle_materials: &[],
            materials: &[],
            links: None,
            camera_hidden: vec![],
        }
    }

    #[test]
    fn normalized_distant_light_gives_its_intensity_as_irradiance() {
        let l = lights_of(&[record(blob::light_kind::DISTANT, 3.0, true)]);
        let e = irradiance(&l, 20_000);
        assert!((e - 3.0).abs() < 3e-3, "E = {e}");
        // Non-normalized: radiance over the cone; E = L π sin²(θ/2).
        let l = lights_of(&[record(blob::light_kind::DISTANT, 3.0, false)]);
        let half = (0.53f32 / 2.0).to_radians();
        let expected = 3.0 * PI * half.sin().powi(2);
        let e = irradiance(&l, 20_000);
        assert!((e / expected - 1.0).abs() < 1e-3, "E = {e}, expected {expected}");
    }

    #[test]
    fn rect_light_irradiance_matches_the_analytic_value() {
        // A 2×1 rect 2 units above, facing down: E = L · form factor · π. Compare against a brute-force
        // integral over the rectangle instead of a closed form.
        let rec = record(blob::light_kind::RECT, 1.0, false);
        let l = lights_of(&[rec]);
        let e = irradiance(&l, 200_000);
        let mut reference = 0.0f64;
        let n = 400;
        for i in 0..n {
            for j in 0..n {
                let x = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                let y = -0.5 + (j as f64 + 0.5) / n as f64;
                let d2 = x * x + y * y + 4.0;
                // cos at receiver × cos at light / d² × dA
                reference += (2.0 / d2.sqrt()) * (2.0 / d2.sqrt()) / d2 * (2.0 / n as f64) * (1.0 / n as f64);
            }
        }
        assert!((e as f64 / reference - 1.0).abs() < 0.01, "E = {e}, reference {reference}");
        // Normalized: radiance / area (2).
        let l = lights_of(&[record(blob::light_kind::RECT, 1.0, true)]);
        let e2 = irradiance(&l, 200_000);
        assert!((e2 as f64 / (reference / 2.0) - 1.0).abs() < 0.01, "E = {e2}");
    }

    #[test]
    fn sphere_and_disk_lights_match_analytic_irradiance() {
        // Sphere of radius r at distance d on the axis: E = L π (r/d)².
        let l = lights_of(&[record(blob::light_kind::SPHERE, 1.0, false)]);
        let e = irradiance(&l, 50_000);
        let expected = PI * 0.25 / 4.0;
        assert!((e / expected - 1.0).abs() < 0.01, "sphere E = {e}, expected {expected}");
        // Disk of radius r facing the point at distance h: E = L π r² / (h² + r²).
        let l = lights_of(&[record(blob::light_kind::DISK, 1.0, false)]);
        let e = irradiance(&l, 200_000);
        let expected = PI * 0.25 / (4.0 + 0.25);
        assert!((e / expected - 1.0).abs() < 0.01, "disk E = {e}, expected {expected}");
        // treatAsPoint keeps the power: I = L π r², E = I / d².
        let mut rec = record(blob::light_kind::SPHERE, 1.0, false);
        rec.flags |= blob::LIGHT_TREAT_AS_POINT;
        let e = irradiance(&lights_of(&[rec]), 16);
        assert!((e - PI * 0.25 / 4.0).abs() < 1e-5, "point E = {e}");
    }

    #[test]
    fn area_light_pdfs_match_between_sampling_and_intersection() {
        for kind in [blob::light_kind::SPHERE, blob::light_kind::RECT, blob::light_kind::DISK] {
            let light = Light::from_blob(&record(kind, 1.0, false));
            let l = lights_of(&[record(kind, 1.0, false)]);
            let mut rng = Rng(77);
            let p = Vec3::new(0.3, -0.2, 0.0);
            for _ in 0..1000 {
                let Some(s) = l.sample(p, 0.0, [rng.next_f32(), rng.next_f32()]) else { continue };
                let (t, _) =
                    light.intersect(p, s.wi, f32::INFINITY).expect("sampled direction must hit the light");
                assert!((t - s.distance).abs() < 1e-3 * t, "kind {kind}: {t} vs {}", s.distance);
                let pdf = light.pdf_area_light(p, p + s.wi * t);
                assert!((pdf / s.pdf - 1.0).abs() < 1e-2, "kind {kind}: {pdf} vs {}", s.pdf);
            }
        }
    }

    /// Culling by group boxes never drops a light a ray meets: the emission equals the sum over
    /// every area light in the same order, bit for bit, on rays aimed at light centres and at points
    /// on their edges (grazing), from outside and from inside the lights' boxes.
    #[test]
    fn culled_area_emission_equals_the_sum_over_every_light() {
        let mut rng = Rng(11);
        let mut u = || rng.next_f32();
        let records = crate::testscene::area_light_records(100, 10.0, (0.05, 0.3), (0.1, 0.5), &mut u);
        let bytes = crate::testscene::lights_only(records);
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let lights = Lights::new(&view);
        assert_eq!(lights.area.len(), 100);
        assert_eq!(lights.area_boxes.len(), 13);
        let brute = |o: Vec3, d: Vec3, tmax: f32, prev| {
            let mut sum = Vec3::ZERO;
            for (position, &i) in lights.area.iter().enumerate() {
                if let Some((t, _)) = lights.lights[i].intersect(o, d, tmax) {
                    sum += lights.area_term(position, o, d, t, prev);
                }
            }
            sum
        };
        let (mut met, mut skipped_groups) = (0, 0u64);
        for i in 0..40_000 {
            let light = &lights.lights[lights.area[i % 100]];
            let (lo, hi) = light.bounds().unwrap();
            let center = (lo + hi) * 0.5;
            // A point on the light's edge for grazing rays: the sphere's silhouette or a rect corner.
            let target = match light.shape {
                Shape::Sphere { center, radius } => center + uniform_sphere([u(), u()]) * radius,
                Shape::Rect { center, ex, ey, .. } => {
                    center + ex * if u() < 0.5 { 1.0 } else { -1.0 } + ey * (2.0 * u() - 1.0)
                }
                Shape::Disk { center, ex, ey, .. } => {
                    let phi = TAU * u();
                    center + ex * phi.cos() + ey * phi.sin()
                }
                _ => unreachable!(),
            };
            let o = if i % 5 == 0 {
                center + (hi - lo) * 0.25
            } else {
                Vec3::new(30.0 * u() - 15.0, 30.0 * u() - 15.0, 30.0 * u() - 15.0)
            };
            let d = (if i % 2 == 0 { target } else { center } - o).normalize_or(Vec3::Z);
            let tmax = if i % 3 == 0 { f32::INFINITY } else { 40.0 * u() };
            let prev = (i % 2 == 0).then(|| (o - d * u(), 4.0 * u()));
            let expected = brute(o, d, tmax, prev);
            let got = lights.area_emission(o, d, tmax, prev);
            assert_eq!(
                got.to_array().map(f32::to_bits),
                expected.to_array().map(f32::to_bits),
                "ray {i}: o {o} d {d}"
            );
            met += (expected != Vec3::ZERO) as u32;
            let (oa, inv) = (o.to_array(), d.recip().to_array());
            skipped_groups +=
                lights.area_boxes.iter().filter(|b| !area_groups::ray_meets(b, oa, inv, tmax)).count() as u64;
        }
        assert!(met > 15_000, "only {met} rays met a light");
        // The culling must actually cull: most groups are skipped by most rays.
        assert!(skipped_groups > 40_000 * 13 / 2, "skipped {skipped_groups} group tests");
    }

    /// The batched escaped emission equals the scalar per ray bit for bit (a dome and two distant
    /// cones, one wide enough that many rays see it; camera rays and MIS-weighted ones).
    #[test]
    fn escaped_emission_of_many_rays_equals_the_scalar_one() {
        let mut wide = record(blob::light_kind::DISTANT, 2.0, true);
        wide.angle_degrees = 120.0;
        let mut l = lights_of(&[
            record(blob::light_kind::DISTANT, 3.0, false),
            record(blob::light_kind::DOME, 0.7, false),
            wide,
        ]);
        l.infinite = vec![0, 1, 2];
        let mut rng = Rng(11);
        let dirs: Vec<Vec3> = (0..300)
            .map(|_| {
                let z = 1.0 - 2.0 * rng.next_f32();
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = TAU * rng.next_f32();
                Vec3::new(r * phi.cos(), r * phi.sin(), z)
            })
            .collect();
        let pdfs: Vec<Option<f32>> = (0..300).map(|j| (j % 3 != 0).then(|| rng.range(0.01, 5.0))).collect();
        let mut sums = vec![Vec3::ZERO; dirs.len()];
        l.escaped_emission_rays(&dirs, &pdfs, &mut sums);
        let mut in_wide_cone = 0;
        for j in 0..dirs.len() {
            let scalar = l.escaped_emission(dirs[j], pdfs[j]);
            assert_eq!(sums[j].to_array().map(f32::to_bits), scalar.to_array().map(f32::to_bits), "ray {j}");
            // The wide cone (towards +Z, 60° half angle) lights rays with z above cos 60°.
            in_wide_cone += (dirs[j].z > 0.51) as u32;
        }
        assert!(in_wide_cone > 20, "{in_wide_cone} rays saw the wide cone");
    }
}
