//! Dicing: the uniform subdivision level of each mesh, chosen from the render camera.
//!
//! A mesh is refined until its longest refined edge projects to about `dicing_rate` pixels at the
//! render resolution. The projection is conservative: the longest *cage* edge (in world space) is
//! placed at the point of the mesh's world bounding box nearest to the camera, so no part of the
//! mesh comes out coarser than the rate; each level halves the edges
//! ([`subdiv::level_for_dicing_rate`]). Meshes wholly outside the view frustum still cast shadows
//! and show in reflections, so they keep a coarse level (≤ 1) rather than the cage.
//!
//! The render camera is the scene's default camera (RenderSettings, else the first camera) at the
//! RenderSettings resolution, else 512 pixels wide at the aperture's aspect, as `render` uses.
//! A stage without a camera is diced for the camera `render` frames it with
//! ([`DicingCamera::framing`]); [`DEFAULT_LEVEL`] is left for callers without any view.
//!
//! Two guards keep the conservative estimate from running away, as it does when a mesh has a few
//! long edges among many short ones (the shader ball's cage diced to level 5 was 16 M triangles
//! for a 512 × 512 image; 1000 camera-less teapots at a fixed level 2 were 40 M triangles and
//! 18 GB of ingest): a mesh is never diced past the level at which it has more triangles than
//! the image has pixels per `dicing_rate²`, twice over (`2·W·H / rate²`: a triangle pair per
//! rate-sized square), and the level is capped by `max_level`.
//!
//! ## Adaptive dicing (the default)
//!
//! One level per mesh is set by its largest on-screen faces, so a dense cage, or a mesh that
//! recedes from the camera or leaves the frame, is refined everywhere as finely as its nearest
//! big face needs. [`SubdivMode::Adaptive`] instead gives every cage *edge* its own number of
//! segments ([`choose_edge_rates`]): the edge's length at the depth of its nearer end
//! ([`DicingCamera::segment_pixels`]), divided by the dicing rate, capped at `2^max_level`. Edges whose
//! faces are all outside the view get at most `2^OFF_SCREEN_LEVEL`. The same triangle budget
//! holds: while the mesh would exceed it, every edge's pixel length is scaled down by 3/4.
//! Rates live on edges, so the two faces of an edge split it alike and the tessellation is
//! watertight (`subdiv::AdaptiveRefiner`). `--subdiv-level N` and `--subdiv-mode uniform` keep
//! uniform refinement.

use glam::DVec3;

/// The render camera as dicing sees it: `scene-pack`'s, which curve splitting shares.
pub use scene_pack::camera::{DicingCamera, DEFAULT_WIDTH};

/// Level used for every subdivision mesh when the stage has no camera (capped by the maximum).
pub const DEFAULT_LEVEL: u32 = 2;
/// Level cap for meshes outside the view frustum (capped by the maximum).
pub const OFF_SCREEN_LEVEL: u32 = 1;

/// How a subdivision surface diced from the camera is tessellated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SubdivMode {
    /// One uniform level per mesh, from its longest on-screen cage edge ([`choose_level`]).
    Uniform,
    /// Segments per cage edge from that edge's on-screen length ([`choose_edge_rates`]).
    #[default]
    Adaptive,
}

/// How subdivision surfaces are diced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubdivOptions {
    /// Refine every subdivision mesh to this level, ignoring the camera (`--subdiv-level`).
    pub forced_level: Option<u32>,
    /// Target length of a refined edge on screen, in pixels (`--dicing-rate`, default 1).
    pub dicing_rate: f32,
    /// Highest level chosen by dicing (`--max-subdiv-level`, default 5); adaptive dicing caps
    /// edges at `2^max_level` segments.
    pub max_level: u32,
    /// Uniform or adaptive dicing (`--subdiv-mode`); ignored with `forced_level`.
    pub mode: SubdivMode,
    /// Tessellate the limit surfaces (default `true`). Off, the level or edge rates are chosen
    /// and the triangle counts planned from the topology ([`crate::scene::Subdivision`]), but no
    /// limit surface is evaluated: for listings (`ingest --dump-json` without `-o`), which report
    /// counts and cage bounds only.
    pub tessellate: bool,
}

impl SubdivOptions {
    /// Whether meshes are tessellated per edge ([`choose_edge_rates`]) rather than uniformly.
    pub fn adaptive(&self) -> bool {
        self.forced_level.is_none() && self.mode == SubdivMode::Adaptive
    }

    /// Checks the options are in range: levels at most [`subdiv::MAX_LEVEL`] and a finite,
    /// positive dicing rate. [`crate::pipeline`] and [`crate::usd::load`] call it before reading
    /// anything; out of range, dicing would silently clamp (a zero rate dices everything at the
    /// level cap) or the refiner fail mesh by mesh.
    pub fn validate(&self) -> Result<(), SubdivOptionsError> {
        let level = |option, level: u32| {
            if level > subdiv::MAX_LEVEL {
                Err(SubdivOptionsError::LevelOutOfRange { option, level })
            } else {
                Ok(())
            }
        };
        if let Some(forced) = self.forced_level {
            level("forced_level", forced)?;
        }
        level("max_level", self.max_level)?;
        if !(self.dicing_rate.is_finite() && self.dicing_rate > 0.0) {
            return Err(SubdivOptionsError::DicingRate(self.dicing_rate));
        }
        Ok(())
    }
}

/// A [`SubdivOptions`] value out of range (see [`SubdivOptions::validate`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SubdivOptionsError {
    /// A subdivision level above [`subdiv::MAX_LEVEL`].
    #[error("{option} is {level}, above the highest subdivision level {max}", max = subdiv::MAX_LEVEL)]
    LevelOutOfRange {
        /// The field: `forced_level` or `max_level`.
        option: &'static str,
        /// Its value.
        level: u32,
    },
    /// A dicing rate that is not a finite, positive number of pixels.
    #[error("dicing_rate must be a positive number of pixels, not {0}")]
    DicingRate(f32),
}

impl Default for SubdivOptions {
    fn default() -> Self {
        SubdivOptions {
            forced_level: None,
            dicing_rate: 1.0,
            max_level: 5,
            mode: SubdivMode::default(),
            tessellate: true,
        }
    }
}

/// The level of one mesh: forced, else diced against `camera` (off-screen meshes ≤
/// [`OFF_SCREEN_LEVEL`]; on-screen ones no finer than the camera's
/// [`DicingCamera::triangle_budget`]), else [`DEFAULT_LEVEL`]; all but the forced level capped
/// by `options.max_level`. `longest_edge` is the longest cage edge in world units, `lo..hi` the
/// cage's world bounds and `triangles_at(level)` the mesh's triangle count at a level.
pub fn choose_level(
    options: &SubdivOptions,
    camera: Option<&DicingCamera>,
    longest_edge: f64,
    lo: DVec3,
    hi: DVec3,
    triangles_at: impl Fn(u32) -> u64,
) -> u32 {
    if let Some(level) = options.forced_level {
        return level;
    }
    let Some(camera) = camera else { return DEFAULT_LEVEL.min(options.max_level) };
    if camera.outside(lo, hi) {
        return OFF_SCREEN_LEVEL.min(options.max_level);
    }
    let edge_px = camera.pixels(longest_edge, lo, hi);
    let mut level = subdiv::level_for_dicing_rate(edge_px as f32, options.dicing_rate, options.max_level);
    let budget = camera.triangle_budget(options.dicing_rate);
    while level > 0 && triangles_at(level) > budget {
        level -= 1;
    }
    level
}

/// Segments per cage edge of one mesh for adaptive tessellation, in the order of
/// `refiner.edges()`: diced against `camera` (see the module docs), else `2^DEFAULT_LEVEL`
/// everywhere; capped by `2^options.max_level`. `world` holds the cage points in world space.
pub fn choose_edge_rates(
    options: &SubdivOptions,
    camera: Option<&DicingCamera>,
    world: &[DVec3],
    refiner: &subdiv::AdaptiveRefiner,
) -> Vec<u32> {
    let max_level = options.max_level.min(subdiv::MAX_LEVEL);
    let rate_of_level = |level: u32| 1u32 << level.min(max_level);
    let edges = refiner.edges();
    let Some(camera) = camera else { return vec![rate_of_level(DEFAULT_LEVEL); edges.len()] };
    let (lo, hi) =
        world.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let off_screen = rate_of_level(OFF_SCREEN_LEVEL);
    if camera.outside(lo, hi) {
        return vec![off_screen; edges.len()];
    }

    // An edge is on screen when one of its faces may be. A face's limit surface is pulled
    // towards its neighbours' points, so its cage box is grown by half its size on every side.
    // A mesh wholly in view has every face on screen: no box per face to test.
    let whole_mesh_in_view = camera.inside(lo, hi);
    let mut visible = vec![false; edges.len()];
    for f in (0..refiner.face_count()).filter(|&f| !refiner.is_hole(f)) {
        let (vertices, face_edges) = refiner.face(f);
        let on_screen = whole_mesh_in_view || {
            let (lo, hi) = vertices
                .iter()
                .map(|&v| world[v as usize])
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)));
            let grow = (hi - lo) / 2.0;
            !camera.outside(lo - grow, hi + grow)
        };
        if on_screen {
            face_edges.iter().for_each(|&e| visible[e as usize] = true);
        }
    }
    let pixels = camera.edge_pixels(world, edges);
    let max_rate = rate_of_level(max_level);
    let rates_at = |scale: f64| -> Vec<u32> {
        pixels
            .iter()
            .zip(&visible)
            .map(|(&px, &on_screen)| {
                let rate = subdiv::rate_for_dicing_rate(px * scale, options.dicing_rate.into(), max_rate);
                if on_screen {
                    rate
                } else {
                    rate.min(off_screen)
                }
            })
            .collect()
    };
    let budget = camera.triangle_budget(options.dicing_rate);
    let mut scale = 1.0;
    let mut rates = rates_at(scale);
    while refiner.triangle_estimate(&rates) > budget && rates.iter().any(|&r| r > 1) {
        scale *= 0.75;
        rates = rates_at(scale);
    }
    rates
}

/// Triangles a cage yields at uniform `level`, from the face counts alone: Catmull–Clark and
/// bilinear make `4^L` quads of a quad and `n·4^(L−1)` of an n-gon (Catmull–Clark cages with
/// non-quads are refined at least once, as [`subdiv::Refiner::new`] does; bilinear n-gons at
/// level 0 are fanned), loop makes `4^L` triangles of a triangle; quads are split in two.
///
/// `face_sizes` lists the faces that reach the surface (no holes); `all_quads` is whether the
/// whole cage is quads.
pub fn triangles_at_level(
    scheme: subdiv::Scheme,
    face_sizes: impl IntoIterator<Item = usize>,
    all_quads: bool,
    level: u32,
) -> u64 {
    let level = if level == 0 && scheme == subdiv::Scheme::CatmullClark && !all_quads { 1 } else { level };
    let four = |l: u32| 4u64.saturating_pow(l);
    face_sizes
        .into_iter()
        .map(|n| match (scheme, n, level) {
            (subdiv::Scheme::Loop, _, l) => four(l),
            (_, 4, l) => 2 * four(l),
            (_, n, 0) => n.saturating_sub(2) as u64,
            (_, n, l) => 2 * n as u64 * four(l - 1),
        })
        .sum()
}

/// The USD token of a scheme (`subdivisionScheme`).
pub fn scheme_token(scheme: subdiv::Scheme) -> &'static str {
    match scheme {
        subdiv::Scheme::CatmullClark => "catmullClark",
        subdiv::Scheme::Loop => "loop",
        subdiv::Scheme::Bilinear => "bilinear",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    // The 36 mm test camera, shared with scene-pack's camera tests.
    use scene_pack::camera::test_camera as camera;

    #[test]
    fn perspective_pixels_follow_distance() {
        let cam = DicingCamera::new(&camera(Vec3::ZERO, false), Some([1000, 1000]));
        // focal_px = 36 / 36 × 1000: a unit edge 10 units away is 100 px.
        let lo = DVec3::new(-1.0, -1.0, -12.0);
        let hi = DVec3::new(1.0, 1.0, -10.0);
        assert!((cam.pixels(1.0, lo, hi) - 100.0).abs() < 1e-9);
        assert!(!cam.outside(lo, hi));
        // 100 px at 1 px per edge: ceil(log2 100) = 7, capped at 5.
        let options = SubdivOptions::default();
        assert_eq!(choose_level(&options, Some(&cam), 1.0, lo, hi, |_| 0), 5);
        let options = SubdivOptions { dicing_rate: 25.0, ..SubdivOptions::default() };
        assert_eq!(choose_level(&options, Some(&cam), 1.0, lo, hi, |_| 0), 2);
        // The camera inside the box: the near distance.
        assert!((cam.pixels(1.0, -DVec3::ONE, DVec3::ONE) / (1000.0 / 0.1) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn frustum_culling() {
        let cam = DicingCamera::new(&camera(Vec3::ZERO, false), Some([1000, 1000]));
        let unit = |c: DVec3| (c - DVec3::splat(0.5), c + DVec3::splat(0.5));
        // Behind, left, right, above, below; the half-angle is atan(0.5).
        for c in [
            DVec3::new(0.0, 0.0, 5.0),
            DVec3::new(-10.0, 0.0, -5.0),
            DVec3::new(10.0, 0.0, -5.0),
            DVec3::new(0.0, 10.0, -5.0),
            DVec3::new(0.0, -10.0, -5.0),
        ] {
            let (lo, hi) = unit(c);
            assert!(cam.outside(lo, hi), "{c}");
            assert_eq!(choose_level(&SubdivOptions::default(), Some(&cam), 1.0, lo, hi, |_| 0), 1);
        }
        // Straddling the edge of the image: visible.
        let (lo, hi) = unit(DVec3::new(2.6, 0.0, -5.0));
        assert!(!cam.outside(lo, hi));
    }

    #[test]
    fn no_camera_and_forced_levels() {
        let o = SubdivOptions::default();
        assert_eq!(choose_level(&o, None, 1.0, DVec3::ZERO, DVec3::ONE, |_| 0), DEFAULT_LEVEL);
        let o = SubdivOptions { max_level: 1, ..o };
        assert_eq!(choose_level(&o, None, 1.0, DVec3::ZERO, DVec3::ONE, |_| 0), 1);
        let o = SubdivOptions { forced_level: Some(7), ..o };
        assert_eq!(choose_level(&o, None, 1.0, DVec3::ZERO, DVec3::ONE, |_| 0), 7);
    }

    #[test]
    fn triangle_budget_lowers_the_level() {
        let cam = DicingCamera::new(&camera(Vec3::ZERO, false), Some([100, 100]));
        let (lo, hi) = (DVec3::new(-1.0, -1.0, -3.0), DVec3::new(1.0, 1.0, -2.0));
        // 500 px edges want level 9, capped at 5; the budget is 2·100·100 = 20000 triangles.
        let cube = |l: u32| 12 * 4u64.pow(l);
        assert_eq!(cam.triangle_budget(1.0), 20_000);
        assert_eq!(choose_level(&SubdivOptions::default(), Some(&cam), 10.0, lo, hi, cube), 5);
        // 1200·4^L ≤ 20000 up to level 2.
        let big = |l: u32| 100 * cube(l);
        assert_eq!(choose_level(&SubdivOptions::default(), Some(&cam), 10.0, lo, hi, big), 2);
        assert_eq!(choose_level(&SubdivOptions::default(), Some(&cam), 10.0, lo, hi, |_| u64::MAX), 0);
    }

    #[test]
    fn triangle_formula() {
        use subdiv::Scheme::{Bilinear, CatmullClark, Loop};
        assert_eq!(triangles_at_level(CatmullClark, [4; 6], true, 3), 12 * 64);
        assert_eq!(triangles_at_level(CatmullClark, [4; 6], true, 0), 12);
        // A pentagon: refined once even at level 0 by Catmull–Clark, fanned by bilinear.
        assert_eq!(triangles_at_level(CatmullClark, [5], false, 0), 10);
        assert_eq!(triangles_at_level(Bilinear, [5], false, 0), 3);
        assert_eq!(triangles_at_level(CatmullClark, [3, 4], false, 2), 2 * 3 * 4 + 2 * 16);
        assert_eq!(triangles_at_level(Loop, [3; 4], false, 2), 64);
    }

    #[test]
    fn out_of_range_options_are_refused() {
        assert_eq!(SubdivOptions::default().validate(), Ok(()));
        let top = SubdivOptions {
            forced_level: Some(subdiv::MAX_LEVEL),
            max_level: subdiv::MAX_LEVEL,
            ..SubdivOptions::default()
        };
        assert_eq!(top.validate(), Ok(()), "the highest level is allowed");
        let above = subdiv::MAX_LEVEL + 1;
        let forced = SubdivOptions { forced_level: Some(above), ..SubdivOptions::default() };
        assert_eq!(
            forced.validate(),
            Err(SubdivOptionsError::LevelOutOfRange { option: "forced_level", level: above })
        );
        let capped = SubdivOptions { max_level: above, ..SubdivOptions::default() };
        assert_eq!(
            capped.validate().unwrap_err().to_string(),
            format!("max_level is {above}, above the highest subdivision level {}", subdiv::MAX_LEVEL)
        );
        for rate in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            let options = SubdivOptions { dicing_rate: rate, ..SubdivOptions::default() };
            assert!(matches!(options.validate(), Err(SubdivOptionsError::DicingRate(_))), "{rate}");
        }
    }
}
