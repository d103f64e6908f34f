//! USD reader: a composed stage becomes a [`Scene`].
//!
//! Composition (sublayers, references, payloads, variants, instancing) is done by the `openusd`
//! crate behind the thin `stage` wrapper; everything USD *means* beyond composition is done here,
//! because the crate applies no schema fallbacks and computes no transforms:
//!
//! - `xform`: the xformOp stack; local-to-world is accumulated during the walk in `f64`.
//! - `mesh`: Mesh topology, n-gon triangulation, primvars (normals, st), face-corner splitting.
//! - `implicit`: the implicit Cube, Sphere, Cylinder, Cone, Capsule and Plane, tessellated by one
//!   documented rule into meshes that take the Mesh path from there.
//! - `material`: material binding resolution and UsdPreviewSurface constant inputs, with the
//!   displayColor fallback for unbound gprims; `material::mtlx_network` reads MaterialX networks
//!   (`outputs:mtlx:surface`, `ND_*` shaders) and maps standard_surface and open_pbr_surface onto
//!   UsdPreviewSurface.
//! - `mtlx_document`: `.mtlx` files as USD layers in usdMtlx's layout (the resolver serves them), so
//!   looks that reference MaterialX documents compose.
//! - `subdivision`: subdivision surfaces, queued during the walk and diced against the render
//!   camera after it.
//! - `curves`: BasisCurves, NurbsCurves and Points (to cubic Bézier segments and spheres).
//! - `lux`: UsdLux lights (with their light and shadow linking), UsdGeomCamera, UsdRender settings.
//! - `collection`: UsdCollectionAPI membership (includes, excludes, expansion rules, includeRoot).
//! - `compat`: the workarounds for openusd 0.6 bugs (crate-file checks and repair, text-layer
//!   fixes, path syntax, the panic backstop), each with what would make it removable.
//!
//! The walk itself (`Reader::visit`) carries the inherited state down the hierarchy: the world
//! transform, visibility, purpose. Instances are expanded: instanceable prims are walked through
//! their instance proxies, PointInstancer prototypes are walked once per instance.
//!
//! Schema fallback values live in [`fallback`], in one place.

mod bake_cache;
mod collection;
mod compat;
mod curves;
mod implicit;
mod lens;
mod lux;
mod material;
mod mesh;
mod motion;
mod mtlx_document;
mod origin;
mod products;
mod renderman;
mod resolver;
mod stage;
mod subdivision;
mod texture_files;
mod xform;

#[cfg(test)]
mod budget_tests;
#[cfg(test)]
mod composition_tests;
#[cfg(test)]
mod implicit_tests;
#[cfg(test)]
mod subdivision_tests;
#[cfg(test)]
mod tests;

use std::collections::{HashMap, HashSet};
use std::fmt;
use std::path::{Path, PathBuf};

use glam::{DMat4, DQuat, DVec3};

use crate::scene::{Scene, UpAxis};
pub use compat::reader_panic::quiet_reader_panics;
/// For [`crate::fuzz_entry`]: the MaterialX translation on its own.
pub(crate) use mtlx_document::translate as translate_mtlx;
use stage::{Stage, Value};

/// USD schema fallbacks (values used when an attribute is unauthored).
pub mod fallback {
    /// `Mesh.subdivisionScheme`.
    pub const SUBDIVISION_SCHEME: &str = "catmullClark";
    /// `Mesh.orientation`.
    pub const ORIENTATION: &str = "rightHanded";
    /// `Gprim.doubleSided`.
    pub const DOUBLE_SIDED: bool = false;
    /// `LightAPI.intensity`.
    pub const LIGHT_INTENSITY: f32 = 1.0;
    /// `LightAPI.exposure`.
    pub const LIGHT_EXPOSURE: f32 = 0.0;
    /// `LightAPI.color`.
    pub const LIGHT_COLOR: [f32; 3] = [1.0, 1.0, 1.0];
    /// `LightAPI.normalize`.
    pub const LIGHT_NORMALIZE: bool = false;
    /// `DistantLight.angle` (degrees).
    pub const DISTANT_ANGLE: f32 = 0.53;
    /// `SphereLight.radius`.
    pub const SPHERE_RADIUS: f32 = 0.5;
    /// `SphereLight.treatAsPoint`.
    pub const SPHERE_TREAT_AS_POINT: bool = false;
    /// `RectLight.width` and `.height`.
    pub const RECT_SIZE: f32 = 1.0;
    /// `DiskLight.radius`.
    pub const DISK_RADIUS: f32 = 0.5;
    /// `Camera.focalLength`.
    pub const FOCAL_LENGTH: f32 = 50.0;
    /// `Camera.horizontalAperture`.
    pub const HORIZONTAL_APERTURE: f32 = 20.955;
    /// `Camera.verticalAperture`.
    pub const VERTICAL_APERTURE: f32 = 15.2908;
    /// `Camera.clippingRange`.
    pub const CLIPPING_RANGE: [f32; 2] = [1.0, 1_000_000.0];
    /// Stage `metersPerUnit`.
    pub const METERS_PER_UNIT: f64 = 0.01;
    /// `Sphere.radius`.
    pub const SPHERE_SHAPE_RADIUS: f64 = 1.0;
    /// `Cube.size`.
    pub const CUBE_SIZE: f64 = 2.0;
    /// `Cylinder.radius`.
    pub const CYLINDER_RADIUS: f64 = 1.0;
    /// `Cylinder.height`.
    pub const CYLINDER_HEIGHT: f64 = 2.0;
    /// `Cone.radius`.
    pub const CONE_RADIUS: f64 = 1.0;
    /// `Cone.height`.
    pub const CONE_HEIGHT: f64 = 2.0;
    /// `Capsule.radius`.
    pub const CAPSULE_RADIUS: f64 = 0.5;
    /// `Capsule.height` (the spine between the hemispheres' centres).
    pub const CAPSULE_HEIGHT: f64 = 1.0;
    /// `Plane.width`.
    pub const PLANE_WIDTH: f64 = 2.0;
    /// `Plane.length`.
    pub const PLANE_LENGTH: f64 = 2.0;
    /// `Plane.doubleSided`: the one gprim whose schema overrides `Gprim.doubleSided`.
    pub const PLANE_DOUBLE_SIDED: bool = true;
    /// `axis` of Cylinder, Cone, Capsule and Plane.
    pub const SHAPE_AXIS: &str = "Z";
    /// `BasisCurves.type`.
    pub const CURVE_TYPE: &str = "cubic";
    /// `BasisCurves.basis`.
    pub const CURVE_BASIS: &str = "bezier";
    /// `BasisCurves.wrap`.
    pub const CURVE_WRAP: &str = "nonperiodic";
    /// Width of curves and points without `widths`: usd-core has no schema fallback; Hydra draws 1.
    pub const CURVE_WIDTH: f32 = 1.0;
}

/// How to read a stage.
#[derive(Clone, Debug)]
pub struct LoadOptions {
    /// Load payload arcs (default `true`).
    pub load_payloads: bool,
    /// A missing or unreadable sublayer/reference/payload, or a composition cycle, becomes a
    /// warning instead of an error.
    pub lenient: bool,
    /// Directories searched, in order, for asset paths not found next to the layer naming them
    /// (relative paths not starting with `./` or `../`), as usd-core's search paths.
    pub asset_paths: Vec<std::path::PathBuf>,
    /// Time code at which attributes are evaluated; `None` for the stage's `startTimeCode`.
    pub frame: Option<f64>,
    /// How subdivision surfaces are diced.
    pub subdiv: crate::dicing::SubdivOptions,
    /// Decode and bake the texture files materials name (default `true`). Off, texture lookups
    /// return their fallback: for listings (`ingest --dump-json` without `-o`), which name
    /// materials but never shade.
    pub bake_textures: bool,
    /// Most pixels (width × height) a texture file may declare (default
    /// [`texture::DEFAULT_MAX_PIXELS`], 2^28: a 16k × 16k image). A larger one is refused from its
    /// header before anything is allocated, with a warning naming the file and the material or
    /// light, and its lookups return their fallback.
    pub max_texture_pixels: u64,
    /// Files this run will write (the blob, the listing). A layer composition opens or a texture
    /// file baked that is one of them is refused ([`UsdErrorKind::OutputIsInput`]) once the stage
    /// is read, before anything is written (see [`crate::outputs`]).
    pub outputs: Vec<std::path::PathBuf>,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions {
            load_payloads: true,
            lenient: false,
            asset_paths: Vec::new(),
            frame: None,
            subdiv: crate::dicing::SubdivOptions::default(),
            bake_textures: true,
            max_texture_pixels: texture::DEFAULT_MAX_PIXELS,
            outputs: Vec::new(),
        }
    }
}

/// What went wrong; see [`UsdError`] for where.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum UsdErrorKind {
    /// The root layer could not be opened or parsed.
    #[error("cannot open stage: {0}")]
    Open(String),
    /// A sublayer, reference or payload names a file that does not exist.
    #[error("{arc} @{asset}@ not found")]
    MissingAsset {
        /// `sublayer`, `reference` or `payload`.
        arc: String,
        /// The asset path as authored.
        asset: String,
    },
    /// A sublayer, reference or payload file exists but could not be read.
    #[error("{arc} @{asset}@ could not be read: {reason}")]
    MalformedAsset {
        /// `sublayer`, `reference` or `payload`.
        arc: String,
        /// The asset path as authored.
        asset: String,
        /// The parser's message.
        reason: String,
    },
    /// Authored data is inconsistent (index out of range, wrong type, ...).
    #[error("{0}")]
    Invalid(String),
    /// Any other failure reported by the composition engine.
    #[error("{0}")]
    Stage(String),
    /// An input file (the error's layer: a layer of the stage or a texture it bakes) is also one
    /// of [`LoadOptions::outputs`].
    #[error("is also an output of this run ({output}); refusing to overwrite an input")]
    OutputIsInput {
        /// The output path as given.
        output: String,
    },
    /// Several gprims have bad data (each a [`UsdErrorKind::Invalid`] error, as text naming its
    /// layer, prim and attribute); `--lenient` skips them instead.
    #[error("{count} prims have bad data (--lenient skips them): {}", errors.join("; "))]
    BadPrims {
        /// How many.
        count: usize,
        /// Each prim's error.
        errors: Vec<String>,
    },
    /// The composition engine panicked (a bug in it); the panic's message and place.
    #[error("the USD reader failed unexpectedly: {0}")]
    Internal(String),
}

/// A USD reading error with its location: the layer file, the prim and the attribute where known.
///
/// Displays as `layer: /Prim/Path.attribute: message`. Boxed: it travels through every `Result`
/// of the reader, whose `Ok` side is small.
#[derive(Clone, Debug, PartialEq)]
pub struct UsdError(Box<ErrorData>);

#[derive(Clone, Debug, PartialEq)]
struct ErrorData {
    layer: String,
    prim: Option<String>,
    attribute: Option<String>,
    kind: UsdErrorKind,
}

impl UsdError {
    fn new(layer: &str, kind: UsdErrorKind) -> Self {
        UsdError(Box::new(ErrorData { layer: layer.to_string(), prim: None, attribute: None, kind }))
    }

    fn at(mut self, prim: &str) -> Self {
        self.0.prim = Some(prim.to_string());
        self
    }

    fn attribute(mut self, name: &str) -> Self {
        self.0.attribute = Some(name.to_string());
        self
    }

    fn in_layer(mut self, layer: String) -> Self {
        self.0.layer = layer;
        self
    }

    /// The layer file the problem was authored in (or that asked for the missing file).
    pub fn layer(&self) -> &str {
        &self.0.layer
    }

    /// The prim path, if known.
    pub fn prim(&self) -> Option<&str> {
        self.0.prim.as_deref()
    }

    /// The attribute name, if known.
    pub fn attribute_name(&self) -> Option<&str> {
        self.0.attribute.as_deref()
    }

    /// What went wrong.
    pub fn kind(&self) -> &UsdErrorKind {
        &self.0.kind
    }
}

impl fmt::Display for UsdError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", self.0.layer)?;
        match (&self.0.prim, &self.0.attribute) {
            (Some(prim), Some(attr)) => write!(f, "{prim}.{attr}: ")?,
            (Some(prim), None) => write!(f, "{prim}: ")?,
            _ => {}
        }
        write!(f, "{}", self.0.kind)
    }
}

impl std::error::Error for UsdError {}

/// Reads the stage rooted at `path` into a world-space [`Scene`].
///
/// A panic while reading (a bug in the composition engine) is returned as
/// [`UsdErrorKind::Internal`] naming the root layer; see [`quiet_reader_panics`].
///
/// Out-of-range [`LoadOptions::subdiv`] (see [`crate::dicing::SubdivOptions::validate`]) are
/// [`UsdErrorKind::Invalid`] naming the root layer, before anything is read.
pub fn load(path: &Path, options: &LoadOptions) -> Result<Scene, UsdError> {
    check_options(path, options)?;
    on_reader_stack(path, || {
        compat::reader_panic::catch(&path.display().to_string(), || load_stage(path, options, Teardown::Free))
    })
}

/// [`load`] for a process that exits once it has used the scene (the `ingest` binary): the
/// composed stage and the reader's tables are left for the OS to reclaim at exit instead of
/// being freed one allocation at a time (prim indices, specs, paths: 4-5 % of the CPU time of
/// a listing of the shader ball or the teapot scene, measured with perf). Memory is not
/// returned until the process exits, so a long-lived caller uses [`load`].
pub fn load_until_exit(path: &Path, options: &LoadOptions) -> Result<Scene, UsdError> {
    check_options(path, options)?;
    on_reader_stack(path, || {
        compat::reader_panic::catch(&path.display().to_string(), || {
            load_stage(path, options, Teardown::AtExit)
        })
    })
}

/// Stack of the thread the stage is composed and read on.
///
/// openusd composes on the native stack: each nested arc of a prim (up to its depth limit of
/// 100) and each class of an inherits/specializes chain (up to
/// [`compat::class_arcs::MAX_CLASS_DEPTH`]) is a few recursive frames of several KiB, which
/// overflow a 2 MiB test thread and come close on the 8 MiB main thread. The reservation is
/// virtual: only the pages a deep stage touches are committed.
const READER_STACK_BYTES: usize = 512 << 20;

/// Runs `read` on a thread with a [`READER_STACK_BYTES`] stack and returns its result.
fn on_reader_stack<T: Send>(
    root_layer: &Path,
    read: impl FnOnce() -> Result<T, UsdError> + Send,
) -> Result<T, UsdError> {
    std::thread::scope(|scope| {
        let reader = std::thread::Builder::new().name("ingest-reader".into()).stack_size(READER_STACK_BYTES);
        match reader.spawn_scoped(scope, read) {
            Ok(handle) => handle.join().unwrap_or_else(|payload| std::panic::resume_unwind(payload)),
            Err(e) => Err(UsdError::new(
                &root_layer.display().to_string(),
                UsdErrorKind::Internal(format!("cannot start the reader thread: {e}")),
            )),
        }
    })
}

/// The options [`load`] refuses, as an error naming the root layer.
fn check_options(path: &Path, options: &LoadOptions) -> Result<(), UsdError> {
    options.subdiv.validate().map_err(|e| {
        UsdError::new(
            &path.display().to_string(),
            UsdErrorKind::Invalid(format!("invalid subdivision options: {e}")),
        )
    })
}

/// Refuses a stage one of whose layers or baked texture files is one of `outputs`.
fn check_inputs_are_not_outputs(stage: &Stage, scene: &Scene, outputs: &[PathBuf]) -> Result<(), UsdError> {
    if outputs.is_empty() {
        return Ok(());
    }
    // A file inside a `.usdz` package (`pkg.usdz[inner.usdc]`) is the package file on disk.
    let on_disk = |name: &str| -> PathBuf {
        openusd::ar::split_package_relative_path_outer(name)
            .map_or_else(|| PathBuf::from(name), |(p, _)| PathBuf::from(p))
    };
    let mut inputs: Vec<PathBuf> = stage.layer_files().iter().map(|l| on_disk(l)).collect();
    for texture in &scene.textures {
        let text = texture.path.to_string_lossy();
        // A dome map scaled into half-float range is keyed `file#/scale`.
        let file = on_disk(text.split("#/").next().unwrap_or(&text));
        if texture::udim::is_udim(&file) {
            inputs.extend(texture::udim::expand(&file).into_iter().flatten().map(|t| t.path));
        } else {
            inputs.push(file);
        }
    }
    for input in &inputs {
        if let Some(output) = crate::outputs::output_named_by(input, outputs) {
            let output = output.display().to_string();
            return Err(UsdError::new(&input.display().to_string(), UsdErrorKind::OutputIsInput { output }));
        }
    }
    Ok(())
}

/// What becomes of the composed stage once the scene is read.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Teardown {
    /// Freed before returning.
    Free,
    /// Left to the OS at process exit (see [`load_until_exit`]).
    AtExit,
}

fn load_stage(path: &Path, options: &LoadOptions, teardown: Teardown) -> Result<Scene, UsdError> {
    let stage = Stage::open(path, options)?;
    let prims = stage.traverse()?;
    let scene = read_frame(&stage, &prims, options, None, teardown)?;
    if teardown == Teardown::AtExit {
        std::mem::forget(stage);
    }
    Ok(scene)
}

/// Reads the traversed `stage` into a [`Scene`] at the stage's current time; `bakes` shares the
/// texture bakes of a sequence's earlier frames.
fn read_frame(
    stage: &Stage,
    prims: &[String],
    options: &LoadOptions,
    bakes: Option<&bake_cache::BakeCache>,
    teardown: Teardown,
) -> Result<Scene, UsdError> {
    // Prim indices compose lazily, so composition errors are complete only after the traversal.
    let mut scene = Scene { meters_per_unit: fallback::METERS_PER_UNIT, ..Scene::default() };
    report_composition_issues(stage, options, &mut scene)?;
    let mut reader = Reader::new(stage, prims, scene);
    reader.bake_cache = bakes;
    reader.bake_textures = options.bake_textures;
    reader.texture_limits = texture::DecodeLimits { max_pixels: options.max_texture_pixels };
    reader.lenient = options.lenient;
    reader.read_stage_metadata();
    reader.collect_instancer_prototypes()?;
    reader.scene.world_origin = origin::camera_origin(stage, prims);
    let root = Inherited::root(reader.scene.world_origin);
    reader.root_from_world = root.world_from_local;
    reader.visit("/", &root, false)?;
    reader.bad_prims_error()?;
    reader.finish()?;
    // Bound materials' shading networks are composed as they are read (see Stage::traverse).
    report_composition_issues(stage, options, &mut reader.scene)?;
    let start = std::time::Instant::now();
    reader.tessellate_subdivisions(&options.subdiv);
    reader.scene.load_timings.subdivision_seconds = start.elapsed().as_secs_f64();
    reader.read_motion()?;
    reader.assign_light_sets();
    let width = reader.scene.resolution.map_or(crate::dicing::DEFAULT_WIDTH, |r| r[0]);
    if let Some((camera, message)) = origin::precision_warning(&reader.scene, width) {
        reader.scene.warn(&camera, message);
    }
    for (prim, message) in stage.take_notes() {
        reader.scene.warn(prim, message);
    }
    check_inputs_are_not_outputs(stage, &reader.scene, &options.outputs)?;
    let scene = std::mem::take(&mut reader.scene);
    if teardown == Teardown::AtExit {
        std::mem::forget(reader);
    }
    Ok(scene)
}

/// What [`load_sequence`] shared between frames, for its report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SequenceSharing {
    /// Texture bakes (a file and its options, a UDIM tile, a dome map) served from an earlier
    /// frame instead of being decoded and baked again.
    pub texture_bakes_reused: usize,
}

/// Reads the stage rooted at `path` at every time code of `frames`, composing it once, and hands
/// each frame's [`Scene`] to `on_frame` (in order; an error from it stops the sequence).
///
/// Shared between frames: the composed stage (layers parsed once, prim indices and the
/// traversal's prim list composed once, with the composition checks; a composition warning is
/// reported with the first frame only) and every texture bake ([`bake_cache`]). Read again per
/// frame, because any of it may be time-sampled: transforms, geometry, primvars, materials,
/// lights, cameras, the world origin, subdivision dicing and tessellation, curves, motion keys.
/// Each frame's scene equals [`load`] with [`LoadOptions::frame`] set to that frame.
///
/// `options.frame` is ignored (the frames are given). Errors are as [`load`]'s; `wrap` turns them
/// into `on_frame`'s error type, with the frame being read (`None`: opening the stage).
pub fn load_sequence<E: Send>(
    path: &Path,
    options: &LoadOptions,
    frames: &[f64],
    wrap: impl Fn(Option<f64>, UsdError) -> E + Send + Sync,
    mut on_frame: impl FnMut(f64, Scene) -> Result<(), E> + Send,
) -> Result<SequenceSharing, E> {
    check_options(path, options).map_err(|e| wrap(None, e))?;
    let layer = path.display().to_string();
    let wrap = &wrap;
    let read = || -> Result<Result<SequenceSharing, E>, UsdError> {
        compat::reader_panic::catch(&layer, || {
            let first = LoadOptions { frame: frames.first().copied(), ..options.clone() };
            let stage = Stage::open(path, &first)?;
            let prims = stage.traverse()?;
            let bakes = bake_cache::BakeCache::default();
            for &frame in frames {
                stage.set_time(frame);
                let scene = match read_frame(&stage, &prims, options, Some(&bakes), Teardown::Free) {
                    Ok(scene) => scene,
                    Err(e) => return Ok(Err(wrap(Some(frame), e))),
                };
                if let Err(e) = on_frame(frame, scene) {
                    return Ok(Err(e));
                }
            }
            Ok(Ok(SequenceSharing { texture_bakes_reused: bakes.hits() }))
        })
    };
    on_reader_stack(path, read).map_err(|e| wrap(None, e))?
}

/// Composition errors not reported yet: the first fatal one is the error (unless lenient),
/// the others are warnings.
fn report_composition_issues(
    stage: &Stage,
    options: &LoadOptions,
    scene: &mut Scene,
) -> Result<(), UsdError> {
    for issue in stage.composition_issues() {
        if issue.fatal && !options.lenient {
            let mut error = UsdError::new(&issue.layer, issue.kind);
            if let Some(prim) = &issue.prim {
                error = error.at(prim);
            }
            return Err(error);
        }
        let prim = issue.prim.clone().unwrap_or_else(|| "/".to_string());
        scene.warn(prim, format!("{}: {}", issue.layer, issue.kind));
    }
    Ok(())
}

/// `purpose` of a prim, inherited from the nearest ancestor that authors one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Purpose {
    Default,
    Render,
    Proxy,
    Guide,
}

/// State inherited down the namespace walk.
#[derive(Clone, Debug)]
struct Inherited {
    world_from_local: DMat4,
    invisible: bool,
    purpose: Purpose,
    /// The outermost instance this prim is inside, if any.
    instance: Option<InstanceFrame>,
}

/// Where a prim sits inside its outermost instance: gprims record their geometry in the instance's
/// space as well, so that `crate::instancing` can share identical instances. Nested instances
/// (instanceable prims or instancers inside a prototype) are expanded inside the outermost one:
/// the blob has two levels, world and prototype.
#[derive(Clone, Copy, Debug)]
struct InstanceFrame {
    /// Index into `Scene::instances`.
    index: u32,
    /// Local-to-instance transform.
    instance_from_local: DMat4,
}

impl Inherited {
    /// The pseudo-root of a scene whose positions are relative to `world_origin`
    /// ([`origin`]).
    fn root(world_origin: glam::DVec3) -> Self {
        Inherited {
            world_from_local: DMat4::from_translation(-world_origin),
            invisible: false,
            purpose: Purpose::Default,
            instance: None,
        }
    }

    /// Gprims and lights are drawn when visible with purpose default or render.
    fn drawn(&self) -> bool {
        !self.invisible && matches!(self.purpose, Purpose::Default | Purpose::Render)
    }
}

/// Gprims whose bad data is kept to the prim ([`Reader::read_prim_isolated`]): each adds its own
/// geometry only, so dropping what it added leaves the scene as if it were absent.
const ISOLATED_GPRIMS: &[&str] = &[
    "Mesh",
    "Sphere",
    "Cube",
    "Cylinder",
    "Cone",
    "Capsule",
    "Plane",
    "BasisCurves",
    "NurbsCurves",
    "Points",
];

/// Prim types we know to be renderable but do not read yet (warned once per prim).
const UNSUPPORTED: &[&str] = &[
    "HermiteCurves",
    "NurbsPatch",
    "TetMesh",
    "Cylinder_1",
    "Capsule_1",
    "Volume",
    "OpenVDBAsset",
    "Field3DAsset",
    "Skeleton",
    "SkelRoot",
];

/// Prim types whose subtrees never hold geometry we draw.
const SHADING: &[&str] = &[
    "Material",
    "Shader",
    "NodeGraph",
    "GeomSubset",
    "RenderSettings",
    "RenderProduct",
    "RenderVar",
    "RenderPass",
];

struct Reader<'a> {
    stage: &'a Stage,
    scene: Scene,
    /// Every prim of the traversal region, in pre-order.
    prims: Vec<String>,
    /// Child paths per parent path, restricted to the traversal region.
    children: HashMap<String, Vec<String>>,
    /// Root prims of PointInstancer prototypes: drawn only through their instancer.
    instancer_prototypes: HashSet<String>,
    /// Material index per material path (including `<gprim>.displayColor`).
    material_index: HashMap<String, u32>,
    /// RenderSettings prims in traversal order.
    render_settings: Vec<String>,
    /// `translate(−world_origin)`: where a `!resetXformStack!` prim's transform starts.
    root_from_world: DMat4,
    /// Direct binding per (prim, first relationship name tried).
    binding_cache: HashMap<(String, &'static str), Option<(String, bool)>>,
    /// Subdivision meshes waiting for the render camera.
    subdivisions: Vec<subdivision::QueuedSubdivision>,
    /// PointInstancers being expanded, outermost first.
    expanding: Vec<String>,
    /// Instanced gprim geometry, one copy per distinct mesh.
    geometry: mesh::GeometryInterner,
    /// Queued instanced subdivision cages by content hash (indices into `subdivisions`).
    subdivision_groups: HashMap<u64, Vec<usize>>,
    /// [`LoadOptions::bake_textures`].
    bake_textures: bool,
    /// [`LoadOptions::max_texture_pixels`].
    texture_limits: texture::DecodeLimits,
    /// [`LoadOptions::lenient`]: a gprim with bad data is skipped with a warning.
    lenient: bool,
    /// Gprims with bad data, when not lenient (see [`Reader::read_prim_isolated`]).
    bad_prims: Vec<UsdError>,
    /// Each light's `lightLink` and `shadowLink` membership, in `scene.lights` order.
    light_links: Vec<lux::LightLinks>,
    /// The texture bakes of a frame sequence's earlier frames ([`load_sequence`]).
    bake_cache: Option<&'a bake_cache::BakeCache>,
}

fn parent_of(path: &str) -> &str {
    match path.rfind('/') {
        Some(0) | None => "/",
        Some(i) => &path[..i],
    }
}

impl<'a> Reader<'a> {
    fn new(stage: &'a Stage, prims: &[String], scene: Scene) -> Self {
        let prims = prims.to_vec();
        // The traversal's pre-order gives every prim's children in one composition pass.
        let mut children: HashMap<String, Vec<String>> = HashMap::new();
        for prim in &prims {
            children.entry(parent_of(prim).to_string()).or_default().push(prim.clone());
        }
        Reader {
            stage,
            scene,
            children,
            prims,
            instancer_prototypes: HashSet::new(),
            material_index: HashMap::new(),
            render_settings: Vec::new(),
            root_from_world: DMat4::IDENTITY,
            binding_cache: HashMap::new(),
            subdivisions: Vec::new(),
            expanding: Vec::new(),
            geometry: mesh::GeometryInterner::default(),
            subdivision_groups: HashMap::new(),
            bake_textures: true,
            texture_limits: texture::DecodeLimits::default(),
            lenient: false,
            bad_prims: Vec::new(),
            light_links: Vec::new(),
            bake_cache: None,
        }
    }

    /// Children of `path` in the traversal region.
    fn children_of(&self, path: &str) -> Vec<String> {
        self.children.get(path).cloned().unwrap_or_default()
    }

    fn warn(&mut self, prim: &str, message: impl Into<String>) {
        self.scene.warn(prim, message);
    }

    fn read_stage_metadata(&mut self) {
        if let Some(up) = self.stage.metadata("upAxis") {
            match up.as_str() {
                Some("Z") => self.scene.up_axis = UpAxis::Z,
                Some("Y") => self.scene.up_axis = UpAxis::Y,
                other => self.scene.warn("/", format!("unknown upAxis {other:?}; using Y")),
            }
        }
        if let Some(mpu) = self.stage.metadata("metersPerUnit").and_then(|v| v.as_f64()) {
            self.scene.meters_per_unit = mpu;
        }
    }

    /// Finds every PointInstancer's prototypes so the plain walk can skip them.
    fn collect_instancer_prototypes(&mut self) -> Result<(), UsdError> {
        let instancers: Vec<String> =
            self.prims.iter().filter(|p| self.stage.type_name(p) == "PointInstancer").cloned().collect();
        for instancer in instancers {
            for proto in self.stage.targets(&instancer, "prototypes") {
                self.instancer_prototypes.insert(proto);
            }
        }
        Ok(())
    }

    /// Walks `path` and its subtree under the `parent` state.
    fn visit(&mut self, path: &str, parent: &Inherited, via_instancer: bool) -> Result<(), UsdError> {
        let mut state = parent.clone();
        if path != "/" {
            if !via_instancer && self.instancer_prototypes.contains(path) {
                return Ok(());
            }
            let ty = self.stage.type_name(path);
            if SHADING.contains(&ty.as_str()) {
                if ty == "RenderSettings" {
                    self.render_settings.push(path.to_string());
                }
                return Ok(());
            }
            // A PointInstancer prototype root reached through its instancer is counted there.
            let is_instance = !via_instancer && self.stage.is_instance(path);
            if is_instance {
                self.scene.instance_count += 1;
            }
            let mut warnings = Vec::new();
            let local = xform::read_local(self.stage, path, &mut |w| warnings.push(w))?;
            for w in warnings {
                self.warn(path, w);
            }
            state.world_from_local = if local.resets {
                self.root_from_world * local.matrix
            } else {
                parent.world_from_local * local.matrix
            };
            state.instance = match parent.instance {
                // resetXformStack inside an instance leaves the instance's frame: such gprims are
                // drawn in world space (rare; the instance's other gprims are still shared).
                Some(_) if local.resets => None,
                Some(frame) => Some(InstanceFrame {
                    instance_from_local: frame.instance_from_local * local.matrix,
                    ..frame
                }),
                None if is_instance => Some(self.begin_instance(path, state.world_from_local)),
                None => None,
            };
            // Visibility and purpose belong to UsdGeomImageable: usd-core ignores them on a
            // typeless prim.
            let imageable = !ty.is_empty();
            if imageable && self.token(path, "visibility")?.as_deref() == Some("invisible") {
                state.invisible = true;
            }
            let purpose = if imageable { self.token(path, "purpose")? } else { None };
            match purpose.as_deref() {
                Some("render") => state.purpose = Purpose::Render,
                Some("proxy") => state.purpose = Purpose::Proxy,
                Some("guide") => state.purpose = Purpose::Guide,
                Some("default") => state.purpose = Purpose::Default,
                None => {}
                // Not a purpose USD draws for rendering (usd-core computes it as authored and
                // excludes it from render and default traversals).
                Some(other) => {
                    self.warn(path, format!("unknown purpose \"{other}\"; not rendered"));
                    state.purpose = Purpose::Guide;
                }
            }
            self.read_prim_isolated(path, &ty, &state)?;
        }
        for child in self.children_of(path) {
            self.visit(&child, &state, false)?;
        }
        Ok(())
    }

    /// Reads one prim of type `ty` with its resolved state.
    /// [`Reader::read_prim`], with a gprim's bad data (a NaN point, an out-of-range index, counts
    /// that disagree: [`UsdErrorKind::Invalid`]) kept to that prim: whatever it added is taken
    /// back, and the error becomes one warning naming the prim when lenient, else it is kept for
    /// [`Reader::bad_prims_error`] so that the stage's error names every bad prim, not the first.
    fn read_prim_isolated(&mut self, path: &str, ty: &str, state: &Inherited) -> Result<(), UsdError> {
        if !ISOLATED_GPRIMS.contains(&ty) {
            return self.read_prim(path, ty, state);
        }
        let marks = (
            self.scene.meshes.len(),
            self.scene.curves.len(),
            self.scene.warnings.len(),
            self.subdivisions.len(),
        );
        match self.read_prim(path, ty, state) {
            Err(e) if matches!(e.kind(), UsdErrorKind::Invalid(_)) => {
                self.scene.meshes.truncate(marks.0);
                self.scene.curves.truncate(marks.1);
                self.scene.warnings.truncate(marks.2);
                self.subdivisions.truncate(marks.3);
                if self.lenient {
                    let what = e.to_string();
                    self.warn(path, format!("{ty} skipped (--lenient): {what}"));
                } else {
                    self.bad_prims.push(e);
                }
                Ok(())
            }
            other => other,
        }
    }

    /// The error naming every gprim [`Reader::read_prim_isolated`] found bad, if any: the one error
    /// itself, or for several, all of them in reading order.
    fn bad_prims_error(&mut self) -> Result<(), UsdError> {
        match self.bad_prims.len() {
            0 => Ok(()),
            1 => Err(self.bad_prims.remove(0)),
            n => {
                let first = &self.bad_prims[0];
                let all: Vec<String> = self.bad_prims.iter().map(|e| e.to_string()).collect();
                let mut error =
                    UsdError::new(&first.0.layer, UsdErrorKind::BadPrims { count: n, errors: all });
                error.0.prim = first.0.prim.clone();
                error.0.attribute = first.0.attribute.clone();
                Err(error)
            }
        }
    }

    fn read_prim(&mut self, path: &str, ty: &str, state: &Inherited) -> Result<(), UsdError> {
        match ty {
            "Camera" => self.read_camera(path, state),
            "Mesh" if state.drawn() => self.read_mesh(path, state),
            _ if implicit::TYPES.contains(&ty) && state.drawn() => self.read_shape(path, ty, state),
            "BasisCurves" if state.drawn() => self.read_basis_curves(path, state),
            "NurbsCurves" if state.drawn() => self.read_nurbs_curves(path, state),
            "Points" if state.drawn() => self.read_points(path, state),
            "PointInstancer" if state.drawn() => self.expand_point_instancer(path, state),
            "DomeLight" | "DomeLight_1" | "DistantLight" | "SphereLight" | "RectLight" | "DiskLight"
                if state.drawn() =>
            {
                self.read_light(path, ty, state)
            }
            "CylinderLight" | "GeometryLight" | "PortalLight" | "PluginLight" | "LightFilter"
            | "PluginLightFilter" => {
                self.warn(path, format!("{ty} not supported yet; ignored"));
                Ok(())
            }
            _ if UNSUPPORTED.contains(&ty) => {
                self.warn(path, format!("{ty} prims not supported yet; ignored"));
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// Expands a PointInstancer: each visible instance walks its prototype subtree.
    fn expand_point_instancer(&mut self, path: &str, state: &Inherited) -> Result<(), UsdError> {
        let prototypes = self.stage.targets(path, "prototypes");
        let proto_indices = self.ints(path, "protoIndices")?.unwrap_or_default();
        let positions = self.vec3s(path, "positions")?.unwrap_or_default();
        let n = proto_indices.len();
        if positions.len() != n {
            self.warn(
                path,
                format!(
                    "PointInstancer positions has {} entries for {n} protoIndices; ignored",
                    positions.len()
                ),
            );
            return Ok(());
        }
        // usd-core prefers the float `orientationsf` when it holds values, else the half `orientations`.
        let orientations = match self.stage.attr(path, "orientationsf")? {
            Some(Value::QuatArray(q)) if q.len() == n => Some(q),
            _ => match self.stage.attr(path, "orientations")? {
                Some(Value::QuatArray(q)) if q.len() == n => Some(q),
                _ => None,
            },
        };
        let scales = self.vec3s(path, "scales")?.filter(|s| s.len() == n);
        let ids = self.ints(path, "ids")?.filter(|ids| ids.len() == n);
        let mut invisible: HashSet<i64> =
            self.ints(path, "invisibleIds")?.unwrap_or_default().into_iter().collect();
        // `inactiveIds` (list-op metadata) deactivates ids for all time, like invisibleIds.
        invisible.extend(self.stage.prim_id_list(path, "inactiveIds"));
        // A prototype holding this instancer, or one being expanded around it, would expand
        // forever (found by the layer fuzzer: a prototypes target of </>): skipped.
        self.expanding.push(path.to_string());
        let contains = |proto: &str, prim: &str| {
            proto == "/"
                || prim == proto
                || prim.strip_prefix(proto).is_some_and(|rest| rest.starts_with('/'))
        };
        let mut prototypes: Vec<Option<String>> = prototypes.into_iter().map(Some).collect();
        for slot in &mut prototypes {
            if let Some(proto) = slot.take_if(|p| self.expanding.iter().any(|i| contains(p, i))) {
                self.warn(path, format!("prototype <{proto}> contains its own PointInstancer; skipped"));
            }
        }
        let mut expanded = 0;
        for i in 0..n {
            let id = ids.as_ref().map_or(i as i64, |ids| ids[i]);
            if invisible.contains(&id) {
                continue;
            }
            let Some(proto) =
                usize::try_from(proto_indices[i]).ok().and_then(|p| prototypes.get(p)?.as_ref())
            else {
                self.warn(
                    path,
                    format!("protoIndices[{i}] = {} names no prototype; skipped", proto_indices[i]),
                );
                continue;
            };
            let rotation = orientations.as_ref().map_or(DQuat::IDENTITY, |q| {
                let [x, y, z, w] = q[i];
                // As authored, not normalized: usd-core's ComputeInstanceTransformsAtTime builds the
                // rotation from the raw quaternion, and matching it keeps bounds identical.
                DQuat::from_xyzw(x, y, z, w)
            });
            let scale = scales.as_ref().map_or(DVec3::ONE, |s| s[i]);
            let instancer_from_instance =
                DMat4::from_scale_rotation_translation(scale, rotation, positions[i]);
            let world_from_instance = state.world_from_local * instancer_from_instance;
            let frame = match state.instance {
                Some(frame) => InstanceFrame {
                    instance_from_local: frame.instance_from_local * instancer_from_instance,
                    ..frame
                },
                None => self.begin_instance(&format!("{path}[{i}]"), world_from_instance),
            };
            let instance =
                Inherited { world_from_local: world_from_instance, instance: Some(frame), ..state.clone() };
            let proto = proto.clone();
            self.visit(&proto, &instance, true)?;
            expanded += 1;
        }
        self.expanding.pop();
        self.scene.instance_count += expanded;
        Ok(())
    }

    /// Registers an outermost instance placed by `world_from_instance`.
    fn begin_instance(&mut self, path: &str, world_from_instance: DMat4) -> InstanceFrame {
        let index = self.scene.instances.len() as u32;
        self.scene
            .instances
            .push(crate::scene::SceneInstance { path: path.to_string(), world_from_instance });
        InstanceFrame { index, instance_from_local: DMat4::IDENTITY }
    }

    /// Resolves the default camera and resolution once every prim has been read.
    fn finish(&mut self) -> Result<(), UsdError> {
        self.read_render_settings()?;
        if self.scene.default_camera.is_none() && !self.scene.cameras.is_empty() {
            self.scene.default_camera = Some(0);
        }
        self.check_default_camera_image()
    }

    // --- typed attribute helpers -------------------------------------------------------------

    fn invalid(&self, prim: &str, attr: &str, message: String) -> UsdError {
        UsdError::new(&self.stage.authoring_layer(prim, attr), UsdErrorKind::Invalid(message))
            .at(prim)
            .attribute(attr)
    }

    fn token(&self, prim: &str, attr: &str) -> Result<Option<String>, UsdError> {
        Ok(self.stage.attr(prim, attr)?.and_then(|v| v.as_str().map(str::to_string)))
    }

    fn f64(&self, prim: &str, attr: &str) -> Result<Option<f64>, UsdError> {
        Ok(self.stage.attr(prim, attr)?.and_then(|v| v.as_f64()))
    }

    fn bool(&self, prim: &str, attr: &str) -> Result<Option<bool>, UsdError> {
        Ok(self.f64(prim, attr)?.map(|v| v != 0.0))
    }

    fn ints(&self, prim: &str, attr: &str) -> Result<Option<Vec<i64>>, UsdError> {
        match self.stage.attr(prim, attr)? {
            None => Ok(None),
            Some(v) => match v.as_ints() {
                Some(ints) => Ok(Some(ints)),
                None => Err(self.invalid(prim, attr, "expected an integer array".into())),
            },
        }
    }

    fn vec3s(&self, prim: &str, attr: &str) -> Result<Option<Vec<DVec3>>, UsdError> {
        match self.stage.attr(prim, attr)? {
            None => Ok(None),
            Some(v) => match v.as_array::<3>() {
                Some(a) => Ok(Some(a.into_iter().map(DVec3::from_array).collect())),
                None => Err(self.invalid(prim, attr, "expected a 3-vector array".into())),
            },
        }
    }
}

#[cfg(test)]
mod teardown_tests {
    use super::*;

    #[test]
    fn a_stage_left_until_exit_reads_the_same_scene() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/tractor.usda");
        let options = LoadOptions { bake_textures: false, ..LoadOptions::default() };
        let freed = load(&root, &options).unwrap();
        let kept = load_until_exit(&root, &options).unwrap();
        assert!(!freed.meshes.is_empty());
        assert_eq!(crate::pipeline::dump_json(&freed), crate::pipeline::dump_json(&kept));
    }
}
