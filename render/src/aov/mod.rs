//! Arbitrary output variables from the blob's RenderProducts and RenderVars: what each product's
//! layers are ([`Plan`]), what a path records for them beyond the beauty ([`PathAovs`]), the
//! per-pixel sums they add up to, and the channels of each product's multi-layer EXR
//! ([`Plan::channels`]).
//!
//! Design:
//! * **Raw sources** the beauty's own sums already hold (colour, alpha, albedo, normal, depth,
//!   sample count) cost nothing: they are read from [`PixelSum`]. Position and the light-path
//!   expressions add `f32` sums of their own, [`Plan::stride`] per pixel, added in sample order like
//!   the beauty's, so any split into tiles, passes or threads gives the same bits.
//! * **Light-path expressions** of every var compile into one automaton ([`lpe::Automaton`]); a path
//!   carries one `u32` state, stepped at each scattering vertex by the lobe the vertex chose (its
//!   lobe sample: diffuse or specular, reflection or transmission), and at each emission (emission
//!   found by BSDF sampling, next-event estimation) the contribution — the same value the beauty
//!   adds — goes to every expression that accepts. A vertex's light sample is labelled with the lobe
//!   that vertex chose for its continuation (glass: by the side the light is on), so the lobe
//!   AOVs of one sample add up to its beauty exactly (up to float rounding of the different sums),
//!   and each lobe AOV is the expected share of its lobe where the lobe's selection probability
//!   follows its value (the diffuse of a Lambertian surface is exact).
//! * **Emission by light**: only when the expressions tell lights apart (a label naming a group
//!   or a light) is emission found by BSDF sampling evaluated light by light; otherwise the summed
//!   emission takes the one mask all lights share.
//! * **Channel names**: the first `color` var of a product is its bare `R G B` (`A` with four
//!   channels), as compositors expect of a file's main layer; every other var is the layer named
//!   by its prim's last element: `diffuse.R diffuse.G diffuse.B`, `N.X N.Y N.Z`, `depth` for one
//!   channel; a Cryptomatte var is its `<name>00` … `<name>02` RGBA layers ([`cryptomatte`]).

pub mod cryptomatte;
pub mod lpe;

use crate::error::RenderError;
use crate::film::PixelSum;
use blob::outputs::{data_type, source_type, RawSource};
use glam::Vec3;
use lpe::{Automaton, LightNames, Scatter};

/// A product's channels: each name and its values, row-major over the window.
pub type Channels = Vec<(String, Vec<f32>)>;

/// What a layer shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// A raw value.
    Raw(RawSource),
    /// Light-path expression `i` of the automaton.
    Lpe(usize),
}

/// One layer of a product.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Layer {
    /// The RenderVar's prim path.
    pub var: String,
    /// Its channel names, in component order.
    pub channels: Vec<String>,
    /// What it shows.
    pub source: Source,
}

/// One product: a file and its layers.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Product {
    /// The RenderProduct's prim path.
    pub path: String,
    /// `productName`: the file to write.
    pub name: String,
    /// Its layers in `orderedVars` order.
    pub layers: Vec<Layer>,
}

/// The render's outputs beyond the beauty EXR.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Plan {
    /// The products.
    pub products: Vec<Product>,
    /// The automaton of every LPE var (each distinct expression once), if there is one.
    pub lpe: Option<Automaton>,
    /// The distinct expressions, in automaton order.
    pub expressions: Vec<String>,
    /// Whether a layer shows the first-hit position.
    pub position: bool,
    /// Whether a layer shows the first hit's screen-space motion ([`MotionProjection`]).
    pub motion: bool,
    /// Whether emission must be split by light (see the module docs).
    pub per_light: bool,
    /// Whether a layer shows Cryptomatte objects, and materials.
    pub crypto: [bool; 2],
    /// The Cryptomatte id of each mesh's prim path, then of each material's path.
    pub ids: [Vec<u32>; 2],
    /// The blob's world origin: the position layer adds it back, so `P` is in the stage's world
    /// space although the blob's positions are camera-relative.
    pub world_origin: [f64; 3],
}

impl Plan {
    /// The plan of a validated blob; an LPE that does not parse is an error naming its var.
    pub fn new(view: &blob::SceneView) -> Result<Self, RenderError> {
        let mut plan = Plan { world_origin: view.info.world_origin, ..Plan::default() };
        for p in view.outputs.products {
            let vars = &view.outputs.vars[p.first_var as usize..(p.first_var + p.var_count) as usize];
            let mut layers = Vec::new();
            let mut main_taken = false;
            for v in vars {
                let var = view.string(v.path).to_string();
                let source_name = view.string(v.source);
                let source = match v.source_type {
                    source_type::LPE => {
                        let e = source_name.strip_prefix("lpe:").unwrap_or(source_name).to_string();
                        let i = plan.expressions.iter().position(|x| *x == e).unwrap_or_else(|| {
                            plan.expressions.push(e);
                            plan.expressions.len() - 1
                        });
                        Source::Lpe(i)
                    }
                    // Ingest stores only the raw names it recognised; a crafted blob's other names are
                    // refused here rather than written as zeros.
                    _ => Source::Raw(RawSource::from_name(source_name).ok_or_else(|| {
                        RenderError::InvalidOption(format!(
                            "RenderVar {var}: sourceName {source_name:?} is not a raw value render computes"
                        ))
                    })?),
                };
                plan.position |= source == Source::Raw(RawSource::Position);
                plan.motion |= source == Source::Raw(RawSource::Motion);
                plan.crypto[0] |= source == Source::Raw(RawSource::CryptoObject);
                plan.crypto[1] |= source == Source::Raw(RawSource::CryptoMaterial);
                let main = source == Source::Raw(RawSource::Color) && !main_taken;
                main_taken |= main;
                let layer = var.rsplit('/').next().unwrap_or(&var).to_string();
                let suffixes: &[&str] = match v.data_type {
                    data_type::FLOAT => &[""],
                    data_type::COLOR3 => &["R", "G", "B"],
                    data_type::COLOR4 => &["R", "G", "B", "A"],
                    _ => &["X", "Y", "Z"],
                };
                let crypto =
                    matches!(source, Source::Raw(RawSource::CryptoObject | RawSource::CryptoMaterial));
                let crypto_channels = (0..cryptomatte::RANKS / 2)
                    .flat_map(|k| ["R", "G", "B", "A"].map(|c| format!("{layer}{k:02}.{c}")))
                    .collect();
                let channels = if crypto {
                    crypto_channels
                } else {
                    suffixes
                        .iter()
                        .map(|s| match (main, s.is_empty()) {
                            (true, _) => s.to_string(),
                            (false, true) => layer.clone(),
                            (false, false) => format!("{layer}.{s}"),
                        })
                        .collect()
                };
                layers.push(Layer { var, channels, source });
            }
            plan.products.push(Product {
                path: view.string(p.path).to_string(),
                name: view.string(p.name).to_string(),
                layers,
            });
        }
        if plan.crypto[0] {
            plan.ids[0] = view.meshes.iter().map(|m| cryptomatte::id_of(view.string(m.name))).collect();
        }
        if plan.crypto[1] {
            plan.ids[1] = view.materials.iter().map(|m| cryptomatte::id_of(view.string(m.name))).collect();
        }
        if !plan.expressions.is_empty() {
            let lights: Vec<LightNames> = view
                .lights
                .iter()
                .enumerate()
                .map(|(i, l)| LightNames {
                    group: view
                        .outputs
                        .light_groups
                        .get(i)
                        .map(|&g| view.string(g).to_string())
                        .filter(|g| !g.is_empty()),
                    path: view.string(l.name).to_string(),
                })
                .collect();
            let exprs: Vec<&str> = plan.expressions.iter().map(String::as_str).collect();
            let automaton = Automaton::compile(&exprs, &lights).map_err(|e| {
                let var = plan
                    .products
                    .iter()
                    .flat_map(|p| &p.layers)
                    .find(|l| {
                        l.source
                            == Source::Lpe(exprs.iter().position(|x| e.expression.contains(x)).unwrap_or(0))
                    })
                    .map_or(String::new(), |l| l.var.clone());
                RenderError::InvalidOption(format!("RenderVar {var}: {e}"))
            })?;
            plan.per_light = automaton.light_classes() > 1;
            plan.lpe = Some(automaton);
        }
        Ok(plan)
    }

    /// Whether the paths must record anything for this plan beyond the beauty's sums.
    pub fn traces(&self) -> bool {
        self.stride() > 0
    }

    /// `f32` sums per pixel: 3 per expression, 3 for the position, 2 for the motion, then
    /// [`cryptomatte::SLOTS`] (id, count) pairs for objects and for materials.
    pub fn stride(&self) -> usize {
        self.crypto_offset(2)
    }

    /// Where the motion sums start in a pixel's sums.
    fn motion_offset(&self) -> usize {
        3 * self.expressions.len() + if self.position { 3 } else { 0 }
    }

    /// Bytes per pixel the products add at the render's peak: their sums twice (the frame's and
    /// the tiles' returned copies, as [`crate::film::PEAK_BYTES_PER_PIXEL`] counts the beauty's),
    /// and every product channel twice (the resolved values and their EXR encoding).
    pub fn memory_per_pixel(&self) -> u64 {
        let channels: usize = self.products.iter().flat_map(|p| &p.layers).map(|l| l.channels.len()).sum();
        8 * self.stride() as u64 + 8 * channels as u64
    }

    /// Bytes per path in flight the products add (the wavefront's AOV columns: state, lobe,
    /// shadow mask, position, first hit, each expression's radiance; the tile's sums per pixel
    /// are within a path's share too), 0 when the paths record nothing.
    pub fn memory_per_path(&self) -> u64 {
        if !self.traces() {
            return 0;
        }
        (4 + 1 + 8 + 12 + 12 + 12 * self.expressions.len() + 4 * self.stride()) as u64
    }

    /// Adds a later sample slice's sums `later` of one pixel to `sums` (one [`Plan::stride`] each),
    /// as `render merge` does: radiance and position sums added, Cryptomatte slots merged by id
    /// ([`cryptomatte::merge`]).
    pub fn add_slice(&self, sums: &mut [f32], later: &[f32]) {
        let summed = self.crypto_offset(0);
        for (a, b) in sums[..summed].iter_mut().zip(&later[..summed]) {
            *a += b;
        }
        let width = 2 * cryptomatte::SLOTS;
        for kind in 0..2 {
            if self.crypto[kind] {
                let at = self.crypto_offset(kind);
                cryptomatte::merge(&mut sums[at..at + width], &later[at..at + width]);
            }
        }
    }

    /// Where Cryptomatte kind `kind`'s slots start in a pixel's sums (0 objects, 1 materials; 2 the
    /// end).
    fn crypto_offset(&self, kind: usize) -> usize {
        let slots = 2 * cryptomatte::SLOTS;
        let before = self.crypto[..kind].iter().filter(|&&c| c).count();
        self.motion_offset() + if self.motion { 2 } else { 0 } + before * slots
    }

    /// The EXR header attributes of `product`: each Cryptomatte layer's name, hash, conversion and
    /// manifest under `cryptomatte/<key>/` ([`cryptomatte`]), sorted by attribute name.
    pub fn attributes(&self, product: &Product, view: &blob::SceneView) -> Vec<(String, String)> {
        let mut out = Vec::new();
        for layer in &product.layers {
            let names: Vec<&str> = match layer.source {
                Source::Raw(RawSource::CryptoObject) => {
                    view.meshes.iter().map(|m| view.string(m.name)).collect()
                }
                Source::Raw(RawSource::CryptoMaterial) => {
                    view.materials.iter().map(|m| view.string(m.name)).collect()
                }
                _ => continue,
            };
            let name = layer.var.rsplit('/').next().unwrap_or(&layer.var);
            let key = format!("cryptomatte/{}", cryptomatte::key_of(name));
            out.push((format!("{key}/name"), name.to_string()));
            out.push((format!("{key}/hash"), "MurmurHash3_32".to_string()));
            out.push((format!("{key}/conversion"), "uint32_to_float32".to_string()));
            out.push((format!("{key}/manifest"), cryptomatte::manifest(names)));
        }
        out.sort();
        out
    }

    /// A path record for this plan.
    pub(crate) fn path(&self) -> PathAovs<'_> {
        PathAovs {
            lpe: self.lpe.as_ref(),
            per_light: self.per_light,
            radiance: vec![Vec3::ZERO; self.expressions.len()],
            position: Vec3::ZERO,
            first: None,
            ends: None,
            motion: self.motion,
            state: lpe::DEAD,
        }
    }

    /// Adds one path's record to a pixel's sums `sums` (one [`Plan::stride`]), with the beauty's
    /// rule: a sample whose radiance was not finite adds no light.
    pub(crate) fn add(
        &self,
        sums: &mut [f32],
        radiance_finite: bool,
        path: &PathAovs,
        motion: &MotionProjection,
    ) {
        let parts = (path.position, path.first, motion.pixels(self.motion, path.ends));
        self.add_parts(sums, radiance_finite, &path.radiance, parts);
    }

    /// [`Plan::add`] of a path whose record lives in columns (the wavefront's
    /// [`crate::wavefront`] pool): each expression's radiance, the first hit's position, its
    /// mesh and material, and its motion in pixels ([`MotionProjection::pixels`]).
    pub(crate) fn add_parts(
        &self,
        sums: &mut [f32],
        radiance_finite: bool,
        radiance: &[Vec3],
        (position, first, motion): (Vec3, Option<[u32; 2]>, [f32; 2]),
    ) {
        let n = self.expressions.len();
        if radiance_finite {
            for (s, r) in sums.chunks_exact_mut(3).zip(radiance) {
                s[0] += r.x;
                s[1] += r.y;
                s[2] += r.z;
            }
        }
        if self.position {
            let s = &mut sums[3 * n..3 * n + 3];
            s[0] += position.x;
            s[1] += position.y;
            s[2] += position.z;
        }
        if self.motion {
            let at = self.motion_offset();
            sums[at] += motion[0];
            sums[at + 1] += motion[1];
        }
        if let Some(first) = first {
            for (kind, &index) in first.iter().enumerate() {
                let id = self.ids[kind].get(index as usize);
                if let (true, Some(&id)) = (self.crypto[kind], id) {
                    let at = self.crypto_offset(kind);
                    cryptomatte::add(&mut sums[at..at + 2 * cryptomatte::SLOTS], id);
                }
            }
        }
    }

    /// The channels of `product` over `pixels` pixels: each channel's name and values, from the
    /// beauty's sums `sums`, this plan's sums `aov` ([`Plan::stride`] per pixel) and each pixel's
    /// sample count `counts(i)` (one for all but an adaptive render's).
    pub fn channels(
        &self,
        product: &Product,
        sums: &[PixelSum],
        aov: &[f32],
        counts: &dyn Fn(usize) -> u32,
    ) -> Channels {
        let stride = self.stride();
        let n_expr = self.expressions.len();
        let mut out = Vec::new();
        for layer in &product.layers {
            let mut columns: Vec<Vec<f32>> = vec![Vec::with_capacity(sums.len()); layer.channels.len()];
            for (i, p) in sums.iter().enumerate() {
                let samples = counts(i);
                let inv = 1.0 / samples.max(1) as f32;
                let (beauty, albedo, normal, depth) = p.resolve(samples.max(1));
                let alpha = beauty[3];
                let extra = aov.get(i * stride..(i + 1) * stride).unwrap_or(&[]);
                let at = |k: usize| extra.get(k).copied().unwrap_or(0.0);
                let crypto = match layer.source {
                    Source::Raw(RawSource::CryptoObject) => Some(0),
                    Source::Raw(RawSource::CryptoMaterial) => Some(1),
                    _ => None,
                };
                if let Some(kind) = crypto {
                    let at = self.crypto_offset(kind);
                    let slots = extra.get(at..at + 2 * cryptomatte::SLOTS).unwrap_or(&[]);
                    let ranks = cryptomatte::ranked(slots, samples);
                    let flat = ranks.iter().flat_map(|&(id, c)| [id, c]);
                    for (column, v) in columns.iter_mut().zip(flat) {
                        column.push(v);
                    }
                    continue;
                }
                let value: [f32; 4] = match layer.source {
                    Source::Raw(RawSource::Color) => beauty,
                    Source::Raw(RawSource::Alpha) => [alpha; 4],
                    Source::Raw(RawSource::Albedo) => [albedo[0], albedo[1], albedo[2], 1.0],
                    Source::Raw(RawSource::Normal) => [normal[0], normal[1], normal[2], 0.0],
                    Source::Raw(RawSource::Depth) => [depth; 4],
                    Source::Raw(RawSource::SampleCount) => [samples as f32; 4],
                    Source::Raw(RawSource::CryptoObject | RawSource::CryptoMaterial) => [0.0; 4],
                    Source::Raw(RawSource::Position) => {
                        // The mean over the samples that hit, as the depth's.
                        let hits = p.hits.max(1) as f32;
                        let k = 3 * n_expr;
                        let [ox, oy, oz] = self.world_origin;
                        // A pixel no sample hit stays 0, not the origin.
                        let o = if p.hits == 0 { [0.0; 3] } else { [ox, oy, oz] };
                        let world = |c: usize, o: f64| (f64::from(at(k + c) / hits) + o) as f32;
                        [world(0, o[0]), world(1, o[1]), world(2, o[2]), 1.0]
                    }
                    Source::Raw(RawSource::Motion) => {
                        // The mean over the samples that hit, as the depth's; 0 where none did.
                        let (k, hits) = (self.motion_offset(), p.hits.max(1) as f32);
                        [at(k) / hits, at(k + 1) / hits, 0.0, 1.0]
                    }
                    Source::Lpe(e) => [at(3 * e) * inv, at(3 * e + 1) * inv, at(3 * e + 2) * inv, alpha],
                };
                for (c, column) in columns.iter_mut().enumerate() {
                    column.push(value[c]);
                }
            }
            out.extend(layer.channels.iter().cloned().zip(columns));
        }
        out
    }
}

/// What one path records for the plan: each expression's radiance, the first hit's position, and
/// the automaton's state.
#[derive(Clone, Debug)]
pub(crate) struct PathAovs<'p> {
    pub(crate) lpe: Option<&'p Automaton>,
    /// Emission is split by light (see the module docs).
    pub(crate) per_light: bool,
    pub(crate) radiance: Vec<Vec3>,
    pub(crate) position: Vec3,
    /// The first hit's mesh and material (Cryptomatte), if it hit a triangle.
    pub(crate) first: Option<[u32; 2]>,
    /// Where the first hit's point is at shutter open and close (world), if the path hit and the
    /// plan shows motion ([`motion_ends`]).
    pub(crate) ends: Option<[Vec3; 2]>,
    /// The plan shows motion: the first hit records its `ends`.
    pub(crate) motion: bool,
    /// The automaton's state after the path's events so far.
    pub(crate) state: u32,
}

impl<'p> PathAovs<'p> {
    /// Starts a camera path.
    pub(crate) fn begin(&mut self) {
        self.radiance.iter_mut().for_each(|r| *r = Vec3::ZERO);
        self.position = Vec3::ZERO;
        self.first = None;
        self.ends = None;
        self.state = self.lpe.map_or(lpe::DEAD, Automaton::start);
    }

    /// The path's expression sums and state as a [`LpeSink`], when the plan has expressions.
    #[inline]
    pub(crate) fn sink(&mut self) -> Option<LpeSink<'_>> {
        let automaton = self.lpe?;
        Some(LpeSink {
            automaton,
            per_light: self.per_light,
            state: self.state,
            radiance: &mut self.radiance,
        })
    }

    /// The state after scattering event `scatter` from `state`.
    #[inline]
    pub(crate) fn after(&self, state: u32, scatter: Scatter) -> u32 {
        self.lpe.map_or(lpe::DEAD, |a| a.scatter(state, scatter))
    }
}

/// One path's light-path-expression sums and automaton state, borrowed from wherever the path
/// keeps them: the scalar integrator's [`PathAovs`] or a row of the wavefront's columns. Both
/// integrators add through it, so a contribution reaches the same expressions in the same order.
pub(crate) struct LpeSink<'r> {
    pub(crate) automaton: &'r Automaton,
    /// Emission is split by light (see the module docs).
    pub(crate) per_light: bool,
    /// The automaton's state after the path's events so far.
    pub(crate) state: u32,
    /// Each expression's radiance.
    pub(crate) radiance: &'r mut [Vec3],
}

impl LpeSink<'_> {
    /// Adds `c` to every expression of `mask`.
    #[inline]
    pub(crate) fn add(&mut self, mask: u64, c: Vec3) {
        add_masked(self.radiance, mask, c);
    }

    /// Light `light`'s emission `c` seen from state `state`.
    #[inline]
    pub(crate) fn add_light(&mut self, state: u32, light: usize, c: Vec3) {
        let mask = self.automaton.light_accepts(state, light);
        self.add(mask, c);
    }

    /// Surface emission `c` seen from state `state`.
    #[inline]
    pub(crate) fn add_object(&mut self, state: u32, c: Vec3) {
        let mask = self.automaton.object_accepts(state);
        self.add(mask, c);
    }
}

/// Adds `c` to `radiance[i]` for every bit `i` of `mask`.
#[inline]
pub(crate) fn add_masked(radiance: &mut [Vec3], mask: u64, c: Vec3) {
    let mut m = mask;
    while m != 0 {
        let i = m.trailing_zeros() as usize;
        if let Some(r) = radiance.get_mut(i) {
            *r += c;
        }
        m &= m - 1;
    }
}

/// Where the point `p` of a hit on `instance` (blob::NONE: not instanced) at ray time `time` is at
/// the shutter's open and close, in world space: carried back to the instance's prototype space
/// with its placement at `time`, then out with its placements at open and close (the motion keys
/// the ray interpolated: [`crate::accel::instanced::Instances::placement`]). Geometry outside
/// instances does not move.
pub(crate) fn motion_ends(
    scene: &crate::scene::Scene,
    p: Vec3,
    instance: u32,
    time: f32,
    shutter: crate::camera::Shutter,
) -> [Vec3; 2] {
    if instance == blob::NONE || !shutter.is_open() {
        return [p, p];
    }
    let instances = scene.accel.instances();
    let m = instances.placement(instance, time).object_from_world;
    let object =
        Vec3::from_array(std::array::from_fn(|r| m[r][0] * p.x + m[r][1] * p.y + m[r][2] * p.z + m[r][3]));
    [shutter.open, shutter.close].map(|t| instances.to_world_point(instance, t, object))
}

/// What projects a first hit's motion onto the film: the camera at the shutter's open and close,
/// each with its inverse, and the film's size. The motion AOV of a sample is
/// `raster(close) − raster(open)` of its first hit's [`motion_ends`], in pixels with x to the
/// right and y up (the compositor's convention: Nuke's VectorBlur, Arnold's `motionvector`).
///
/// A moving camera is projected where it stands at the shutter's opening and at its closing, so
/// its own screen motion adds to the objects'.
#[derive(Clone, Debug)]
pub(crate) struct MotionProjection {
    open: (crate::camera::Camera, glam::Affine3A),
    close: (crate::camera::Camera, glam::Affine3A),
    size: [u32; 2],
}

impl MotionProjection {
    /// The projection of `camera`'s `width × height` film over `shutter`: the camera at the
    /// shutter's open and close times (one and the same for a still camera).
    pub(crate) fn new(
        camera: &crate::camera::Camera,
        shutter: crate::camera::Shutter,
        width: u32,
        height: u32,
    ) -> Self {
        Self::between(&camera.at_time(shutter.open), &camera.at_time(shutter.close), width, height)
    }

    /// The projection of a camera that is `open` at the shutter's opening and `close` at its
    /// closing.
    pub(crate) fn between(
        open: &crate::camera::Camera,
        close: &crate::camera::Camera,
        width: u32,
        height: u32,
    ) -> Self {
        MotionProjection {
            open: (open.clone(), open.camera_from_world()),
            close: (close.clone(), close.camera_from_world()),
            size: [width, height],
        }
    }

    /// The screen motion in pixels (x right, y up) of a first hit at `ends` (zero without one, or
    /// when the plan shows no motion: `wanted` false).
    #[inline]
    pub(crate) fn pixels(&self, wanted: bool, ends: Option<[Vec3; 2]>) -> [f32; 2] {
        let (true, Some([a, b])) = (wanted, ends) else { return [0.0; 2] };
        let [w, h] = self.size;
        let from = self.open.0.raster_from_world(&self.open.1, a, w, h);
        let to = self.close.0.raster_from_world(&self.close.1, b, w, h);
        [to[0] - from[0], from[1] - to[1]]
    }
}
