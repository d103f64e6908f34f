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

use glam::{DMat4, DVec3, DVec4};

use crate::scene::Camera;

/// Level used for every subdivision mesh when the stage has no camera (capped by the maximum).
pub const DEFAULT_LEVEL: u32 = 2;
/// Level cap for meshes outside the view frustum (capped by the maximum).
pub const OFF_SCREEN_LEVEL: u32 = 1;
/// Image width `render` uses when RenderSettings authors no resolution.
pub const DEFAULT_WIDTH: u32 = 512;

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

/// How world lengths become pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Projection {
    /// Pixels per world unit at unit distance: `focal_length / horizontal_aperture × width`.
    Perspective { focal_px: f64 },
    /// Pixels per world unit anywhere: `width / (horizontal_aperture / 10)` (apertures are in
    /// tenths of a scene unit).
    Orthographic { px_per_unit: f64 },
}

/// The render camera, reduced to what dicing needs.
#[derive(Clone, Debug, PartialEq)]
pub struct DicingCamera {
    /// Image size in pixels.
    resolution: [u32; 2],
    camera_from_world: DMat4,
    eye: DVec3,
    near: f64,
    projection: Projection,
    /// The image window `[x_min, x_max, y_min, y_max]`: at unit distance in front of the camera
    /// (perspective) or in camera-space units (orthographic).
    window: [f64; 4],
    /// The view frustum's sides (behind the camera, then left, right, bottom, top of the image)
    /// as world-space planes `n·x + d` (`xyz` = n, `w` = d), negative outside.
    world_planes: [DVec4; 5],
}

impl DicingCamera {
    /// The camera rendered at `resolution` (`None`: [`DEFAULT_WIDTH`] wide at the aperture's
    /// aspect, as `render` does).
    pub fn new(camera: &Camera, resolution: Option<[u32; 2]>) -> Self {
        let world_from_camera = camera.world_from_camera.as_dmat4();
        let h_ap = f64::from(camera.horizontal_aperture).max(1e-6);
        let v_ap = f64::from(camera.vertical_aperture).max(1e-6);
        let [width, height] = resolution.unwrap_or_else(|| {
            [DEFAULT_WIDTH, ((f64::from(DEFAULT_WIDTH) * v_ap / h_ap).round() as u32).max(1)]
        });
        let resolution = [width.max(1), height.max(1)];
        let (width, height) = (f64::from(resolution[0]), f64::from(resolution[1]));
        // The horizontal aperture spans the image width; the vertical extent follows the image
        // aspect, as in `render`.
        let half_w = h_ap / 2.0;
        let half_h = half_w * height / width;
        let (off_x, off_y) =
            (f64::from(camera.horizontal_aperture_offset), f64::from(camera.vertical_aperture_offset));
        let film = [off_x - half_w, off_x + half_w, off_y - half_h, off_y + half_h];
        let (projection, window) = if camera.orthographic {
            (Projection::Orthographic { px_per_unit: width / (h_ap / 10.0) }, film.map(|v| v / 10.0))
        } else {
            let focal = f64::from(camera.focal_length).max(1e-6);
            (Projection::Perspective { focal_px: focal / h_ap * width }, film.map(|v| v / focal))
        };
        let camera_from_world = world_from_camera.inverse();
        DicingCamera {
            resolution,
            camera_from_world,
            eye: world_from_camera.transform_point3(DVec3::ZERO),
            near: f64::from(camera.clipping_range[0]).max(1e-6),
            projection,
            window,
            world_planes: frustum_planes(camera.orthographic, window, camera_from_world),
        }
    }

    /// The camera `render` uses for a blob without one: 45° horizontal field of view, the world
    /// box `lo..hi`'s bounding sphere fit in view from +Z (from −Y for a Z-up stage), at
    /// [`DEFAULT_WIDTH`] × [`DEFAULT_WIDTH`] (`render::camera::Camera::framing`).
    pub fn framing(lo: DVec3, hi: DVec3, z_up: bool) -> Self {
        let (centre, radius) = ((lo + hi) / 2.0, ((hi - lo).length() / 2.0).max(1e-3));
        let half_fov = 22.5f64.to_radians();
        let distance = radius / half_fov.sin() * 1.05;
        let (eye, x, y, z) = if z_up {
            (centre - DVec3::Y * distance, DVec3::X, DVec3::Z, -DVec3::Y)
        } else {
            (centre + DVec3::Z * distance, DVec3::X, DVec3::Y, DVec3::Z)
        };
        let world_from_camera =
            DMat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), eye.extend(1.0));
        let camera = Camera {
            path: String::new(),
            world_from_camera: world_from_camera.as_mat4(),
            orthographic: false,
            focal_length: (18.0 / half_fov.tan()) as f32,
            horizontal_aperture: 36.0,
            vertical_aperture: 36.0,
            horizontal_aperture_offset: 0.0,
            vertical_aperture_offset: 0.0,
            // No clipping in `render`; the near distance only bounds the projection.
            clipping_range: [(distance * 1e-3) as f32, f32::MAX],
        };
        DicingCamera::new(&camera, Some([DEFAULT_WIDTH, DEFAULT_WIDTH]))
    }

    /// Image size in pixels.
    pub fn resolution(&self) -> [u32; 2] {
        self.resolution
    }

    /// The most triangles worth dicing one mesh into at `rate_px`: `2·W·H / rate²`.
    pub fn triangle_budget(&self, rate_px: f32) -> u64 {
        let pixels = f64::from(self.resolution[0]) * f64::from(self.resolution[1]);
        (2.0 * pixels / f64::from(rate_px).powi(2).max(1e-6)).min(u64::MAX as f64) as u64
    }

    /// Whether the world box `lo..hi` lies wholly outside the view frustum (behind the camera or
    /// beyond one side of the image). Conservative: a box straddling the frustum's corner
    /// planes counts as visible.
    pub fn outside(&self, lo: DVec3, hi: DVec3) -> bool {
        // A box is wholly outside a plane when its corner furthest along the normal is: per axis,
        // `hi` where the normal is positive, `lo` elsewhere. (Run per cage face by adaptive
        // dicing: transforming the eight corners to camera space instead was 4 % of a listing.)
        self.world_planes.iter().any(|plane| {
            let n = plane.truncate();
            let furthest = DVec3::select(n.cmpge(DVec3::ZERO), hi, lo);
            n.dot(furthest) + plane.w < 0.0
        })
    }

    /// Whether the world box `lo..hi` lies wholly inside the view frustum: its corner nearest
    /// each side is on the inner side.
    pub fn inside(&self, lo: DVec3, hi: DVec3) -> bool {
        self.world_planes.iter().all(|plane| {
            let n = plane.truncate();
            let nearest = DVec3::select(n.cmpge(DVec3::ZERO), lo, hi);
            n.dot(nearest) + plane.w >= 0.0
        })
    }

    /// [`DicingCamera::segment_pixels`] of every edge (vertex pairs into `points`), with each
    /// point's depth computed once rather than once per edge; the same values.
    pub fn edge_pixels(&self, points: &[DVec3], edges: &[[u32; 2]]) -> Vec<f64> {
        let length = |[a, b]: [u32; 2]| points[a as usize].distance(points[b as usize]);
        match self.projection {
            Projection::Orthographic { px_per_unit } => {
                edges.iter().map(|&e| length(e) * px_per_unit).collect()
            }
            Projection::Perspective { focal_px } => {
                let depth: Vec<f64> =
                    points.iter().map(|&p| -self.camera_from_world.transform_point3(p).z).collect();
                edges
                    .iter()
                    .map(|&e| {
                        let [a, b] = e.map(|v| depth[v as usize]);
                        length(e) * focal_px / a.min(b).max(self.near)
                    })
                    .collect()
            }
        }
    }

    /// Conservative on-screen length, in pixels, of a world length `length` anywhere in the world
    /// box `lo..hi`.
    pub fn pixels(&self, length: f64, lo: DVec3, hi: DVec3) -> f64 {
        match self.projection {
            Projection::Orthographic { px_per_unit } => length * px_per_unit,
            Projection::Perspective { focal_px } => {
                let nearest = self.eye.clamp(lo, hi);
                length * focal_px / self.eye.distance(nearest).max(self.near)
            }
        }
    }

    /// On-screen length, in pixels, of the world segment `a`–`b` if it lay parallel to the
    /// image at its nearest depth: `|a − b| · focal_px / min depth` (at least the near
    /// distance). The perspective scale of a point is set by its depth, not its distance: at the
    /// corner of a 53° view the distance overstates the depth by 22 %, and the segments of a
    /// rate chosen from the distance came out 2.2 px long for a 2 px rate.
    pub fn segment_pixels(&self, a: DVec3, b: DVec3) -> f64 {
        let length = a.distance(b);
        match self.projection {
            Projection::Orthographic { px_per_unit } => length * px_per_unit,
            Projection::Perspective { focal_px } => {
                let depth = |p: DVec3| -self.camera_from_world.transform_point3(p).z;
                length * focal_px / depth(a).min(depth(b)).max(self.near)
            }
        }
    }

    /// Pixels per world unit at world point `p` (for error measurements): perspective scale at
    /// its depth (at least the near distance).
    pub fn pixels_per_unit_at(&self, p: DVec3) -> f64 {
        match self.projection {
            Projection::Orthographic { px_per_unit } => px_per_unit,
            Projection::Perspective { focal_px } => {
                let depth = -self.camera_from_world.transform_point3(p).z;
                focal_px / depth.max(self.near)
            }
        }
    }
}

/// The sides of the view frustum as world-space planes, negative outside (see
/// [`DicingCamera::outside`]). In camera space (looking down −Z) each side is `a·p + b`:
/// perspective sides pass through the eye (`window` is at unit depth), orthographic ones are
/// offset by the window; `p = L·x + t` makes it `(Lᵀa)·x + (a·t + b)` in world space.
fn frustum_planes(orthographic: bool, window: [f64; 4], camera_from_world: DMat4) -> [DVec4; 5] {
    let [x_min, x_max, y_min, y_max] = window;
    let camera_space: [(DVec3, f64); 5] = if orthographic {
        [
            (DVec3::NEG_Z, 0.0),
            (DVec3::X, -x_min),
            (DVec3::NEG_X, x_max),
            (DVec3::Y, -y_min),
            (DVec3::NEG_Y, y_max),
        ]
    } else {
        [
            (DVec3::NEG_Z, 0.0),
            (DVec3::new(1.0, 0.0, x_min), 0.0),
            (DVec3::new(-1.0, 0.0, -x_max), 0.0),
            (DVec3::new(0.0, 1.0, y_min), 0.0),
            (DVec3::new(0.0, -1.0, -y_max), 0.0),
        ]
    };
    let linear = glam::DMat3::from_mat4(camera_from_world);
    let offset = camera_from_world.w_axis.truncate();
    camera_space.map(|(a, b)| (linear.transpose() * a).extend(a.dot(offset) + b))
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
    use glam::{Mat4, Vec3};

    /// A 36 mm lens on 36 mm square film (half-angle atan 0.5 ≈ 26.6°) at `eye`, looking down −Z.
    fn camera(eye: Vec3, orthographic: bool) -> Camera {
        Camera {
            path: "/Cam".into(),
            world_from_camera: Mat4::from_translation(eye),
            orthographic,
            focal_length: 36.0,
            horizontal_aperture: 36.0,
            vertical_aperture: 36.0,
            horizontal_aperture_offset: 0.0,
            vertical_aperture_offset: 0.0,
            clipping_range: [0.1, 1000.0],
        }
    }

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
    fn segment_pixels_use_depth() {
        let cam = DicingCamera::new(&camera(Vec3::ZERO, false), Some([1000, 1000]));
        // A unit segment 10 deep is 100 px on the axis and at the edge of the view alike.
        let px = |a: [f64; 3], b: [f64; 3]| cam.segment_pixels(DVec3::from(a), DVec3::from(b));
        assert!((px([0.0, 0.0, -10.0], [1.0, 0.0, -10.0]) - 100.0).abs() < 1e-9);
        assert!((px([4.0, 4.0, -10.0], [4.0, 5.0, -10.0]) - 100.0).abs() < 1e-9);
        // Receding: the nearer end's depth; behind the camera: the near distance (0.1).
        assert!((px([0.0, 0.0, -10.0], [0.0, 0.0, -20.0]) - 1000.0).abs() < 1e-9);
        assert!((px([0.0, 0.0, 5.0], [1.0, 0.0, 5.0]) / 10_000.0 - 1.0).abs() < 1e-6);
        let ortho = DicingCamera::new(&camera(Vec3::ZERO, true), Some([1000, 1000]));
        assert!((ortho.segment_pixels(DVec3::ZERO, DVec3::X) - 1000.0 / 3.6).abs() < 1e-9);
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

    /// The definition [`DicingCamera::outside`] computes with world planes: some side of the
    /// frustum has all eight corners, in camera space, outside.
    fn outside_by_corners(cam: &DicingCamera, lo: DVec3, hi: DVec3) -> bool {
        let corners: [DVec3; 8] = std::array::from_fn(|i| {
            let p = DVec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), hi, lo);
            cam.camera_from_world.transform_point3(p)
        });
        let [x_min, x_max, y_min, y_max] = cam.window;
        let planes: [&dyn Fn(DVec3) -> f64; 5] = match cam.projection {
            Projection::Perspective { .. } => {
                [&|p| -p.z, &|p| p.x + x_min * p.z, &|p| -x_max * p.z - p.x, &|p| p.y + y_min * p.z, &|p| {
                    -y_max * p.z - p.y
                }]
            }
            Projection::Orthographic { .. } => {
                [&|p| -p.z, &|p| p.x - x_min, &|p| x_max - p.x, &|p| p.y - y_min, &|p| y_max - p.y]
            }
        };
        planes.iter().any(|plane| corners.iter().all(|&c| plane(c) < 0.0))
    }

    #[test]
    fn world_frustum_planes_agree_with_the_camera_space_corners() {
        // A rotated, scaled, offset camera with an off-centre window, and random boxes around it.
        let mut c = camera(Vec3::new(1.0, -2.0, 3.0), false);
        c.world_from_camera = Mat4::from_scale_rotation_translation(
            Vec3::splat(1.5),
            glam::Quat::from_euler(glam::EulerRot::YXZ, 0.7, -0.3, 0.2),
            Vec3::new(1.0, -2.0, 3.0),
        );
        c.horizontal_aperture_offset = 4.0;
        c.vertical_aperture = 24.0;
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut random = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for orthographic in [false, true] {
            c.orthographic = orthographic;
            let cam = DicingCamera::new(&c, Some([640, 480]));
            let (mut inside, mut outside) = (0, 0);
            for _ in 0..4000 {
                let centre = DVec3::new(random(), random(), random()) * 40.0 - 20.0;
                let half = DVec3::new(random(), random(), random()) * 3.0;
                let (lo, hi) = (centre - half, centre + half);
                let expected = outside_by_corners(&cam, lo, hi);
                assert_eq!(cam.outside(lo, hi), expected, "{lo}..{hi}, orthographic {orthographic}");
                if expected {
                    outside += 1;
                } else {
                    inside += 1;
                }
            }
            assert!(inside > 100 && outside > 100, "{inside} in view, {outside} outside");
        }
    }

    #[test]
    fn edge_pixels_equal_segment_pixels_and_inside_means_no_corner_outside() {
        let mut c = camera(Vec3::new(0.5, 0.2, 1.0), false);
        c.world_from_camera *= Mat4::from_rotation_y(0.4);
        let points: Vec<DVec3> = (0..50)
            .map(|i| DVec3::new((i % 7) as f64 - 3.0, (i % 5) as f64 - 2.0, -(i as f64) * 0.7))
            .collect();
        let edges: Vec<[u32; 2]> = (0..49).map(|i| [i, (i * 17 + 3) % 50]).collect();
        for orthographic in [false, true] {
            c.orthographic = orthographic;
            let cam = DicingCamera::new(&c, Some([300, 200]));
            let expected: Vec<f64> = edges
                .iter()
                .map(|&[a, b]| cam.segment_pixels(points[a as usize], points[b as usize]))
                .collect();
            assert_eq!(cam.edge_pixels(&points, &edges), expected);
            // Inside: every corner in view; a box reaching past a side is not inside.
            for w in points.windows(2) {
                let (lo, hi) = (w[0].min(w[1]), w[0].max(w[1]));
                if cam.inside(lo, hi) {
                    for i in 0..8 {
                        let p = DVec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), hi, lo);
                        assert!(!outside_by_corners(&cam, p, p), "{p} of {lo}..{hi}");
                    }
                }
            }
        }
        let cam = DicingCamera::new(&camera(Vec3::ZERO, false), Some([100, 100]));
        assert!(cam.inside(DVec3::new(-0.5, -0.5, -5.0), DVec3::new(0.5, 0.5, -4.0)));
        assert!(!cam.inside(DVec3::new(-0.5, -0.5, -5.0), DVec3::new(4.0, 0.5, -4.0)));
        assert!(!cam.inside(DVec3::new(-0.5, -0.5, -5.0), DVec3::new(0.5, 0.5, 1.0)));
    }

    #[test]
    fn orthographic_pixels_do_not_depend_on_distance() {
        // A 3.6-unit-wide window over 1000 px.
        let cam = DicingCamera::new(&camera(Vec3::ZERO, true), Some([1000, 1000]));
        let near = cam.pixels(1.0, DVec3::new(0.0, 0.0, -2.0), DVec3::new(0.1, 0.1, -1.0));
        let far = cam.pixels(1.0, DVec3::new(0.0, 0.0, -200.0), DVec3::new(0.1, 0.1, -100.0));
        assert!((near - 1000.0 / 3.6).abs() < 1e-9 && near == far);
        assert!(cam.outside(DVec3::new(2.0, 0.0, -2.0), DVec3::new(3.0, 1.0, -1.0)));
    }

    #[test]
    fn default_resolution_is_512_wide_at_the_aperture_aspect() {
        let mut c = camera(Vec3::ZERO, false);
        c.vertical_aperture = 18.0;
        let cam = DicingCamera::new(&c, None);
        assert_eq!(cam.projection, Projection::Perspective { focal_px: 512.0 });
        assert!((cam.window[3] - 0.25).abs() < 1e-3, "{:?}", cam.window);
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
    fn framing_camera_sees_the_box() {
        let (lo, hi) = (DVec3::splat(-1.0), DVec3::splat(1.0));
        for z_up in [false, true] {
            let cam = DicingCamera::framing(lo, hi, z_up);
            assert!(!cam.outside(lo, hi));
            assert!(cam.outside(lo + DVec3::X * 10.0, hi + DVec3::X * 10.0));
            let eye = if z_up { -DVec3::Y } else { DVec3::Z };
            assert!((cam.eye.normalize() - eye).length() < 1e-9, "{}", cam.eye);
        }
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
