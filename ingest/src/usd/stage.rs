//! The reader's view of a composed stage: the only module that touches the `openusd` crate.
//!
//! Everything the reader needs is a handful of queries (children, type name, attribute value and
//! metadata, connections, relationship targets, stage metadata, composition errors) over plain
//! `&str` prim paths, with values converted once into the small [`Value`] enum. Swapping the
//! composition backend means rewriting this file only (with [`super::resolver`], the crate
//! extension it opens layers through).

use std::cell::{Cell, RefCell};
use std::collections::{HashMap, HashSet};
use std::path::Path;

use openusd::ar::{ResolvedPath, Resolver};
use openusd::{pcp, sdf, usd};

use super::compat::class_arcs::ClassArcs;
use super::compat::layer_fix::{list_op_field, parse_error_location};
use super::resolver::IngestResolver;
use super::{LoadOptions, UsdError, UsdErrorKind};

/// A resolved attribute value, reduced to what the reader consumes.
///
/// Precision is widened to `f64`; `token`, `string` and `asset` all become [`Value::Str`].
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Value {
    /// `bool`, any integer or floating-point scalar.
    Scalar(f64),
    /// `token`, `string`, `asset` (the authored path).
    Str(String),
    /// A fixed-size tuple: `vec2/3/4` of any precision (quaternions are [`Value::Quat`]).
    Tuple(Vec<f64>),
    /// A quaternion as `[x, y, z, w]` (USD authors `(w, x, y, z)`; reordered here).
    Quat([f64; 4]),
    /// A `matrix4d` in USD's row-major, row-vector layout (translation in elements 12..15).
    Matrix([f64; 16]),
    /// A numeric array; `arity` numbers per element (1 for `float[]`, 3 for `point3f[]`, ...).
    Array { data: Vec<f64>, arity: usize },
    /// A quaternion array, each `[x, y, z, w]`.
    QuatArray(Vec<[f64; 4]>),
    /// `token[]` / `string[]` / `asset[]`.
    StrArray(Vec<String>),
    /// Anything else (dictionaries, list ops, matrix arrays, ...).
    Other,
}

impl Value {
    /// The scalar, if this is one.
    pub(crate) fn as_f64(&self) -> Option<f64> {
        match self {
            Value::Scalar(v) => Some(*v),
            _ => None,
        }
    }

    /// The string, if this is a token/string/asset.
    pub(crate) fn as_str(&self) -> Option<&str> {
        match self {
            Value::Str(s) => Some(s),
            _ => None,
        }
    }

    /// A tuple of exactly `N` components.
    pub(crate) fn as_tuple<const N: usize>(&self) -> Option<[f64; N]> {
        match self {
            Value::Tuple(t) if t.len() == N => t.as_slice().try_into().ok(),
            _ => None,
        }
    }

    /// An array with `N` numbers per element as fixed-size elements.
    pub(crate) fn as_array<const N: usize>(&self) -> Option<Vec<[f64; N]>> {
        match self {
            Value::Array { data, arity } if *arity == N => {
                Some(data.chunks_exact(N).map(|c| c.try_into().expect("chunk of N")).collect())
            }
            _ => None,
        }
    }

    /// A scalar array as integers (`int[]`, `uint[]`, ...).
    pub(crate) fn as_ints(&self) -> Option<Vec<i64>> {
        match self {
            Value::Array { data, arity: 1 } => Some(data.iter().map(|&v| v as i64).collect()),
            _ => None,
        }
    }
}

fn tuple<T: Copy + Into<f64>>(v: &[T]) -> Value {
    Value::Tuple(v.iter().map(|&x| x.into()).collect())
}

fn array<T: Copy + Into<f64>>(v: &[T], arity: usize) -> Value {
    Value::Array { data: v.iter().map(|&x| x.into()).collect(), arity }
}

fn h(x: openusd::gf::f16) -> f64 {
    x.to_f64()
}

impl From<sdf::Value> for Value {
    fn from(value: sdf::Value) -> Self {
        use sdf::Value as V;
        match value {
            V::Bool(b) => Value::Scalar(if b { 1.0 } else { 0.0 }),
            V::Uchar(v) => Value::Scalar(v.into()),
            V::Int(v) => Value::Scalar(v.into()),
            V::Uint(v) => Value::Scalar(v.into()),
            V::Int64(v) => Value::Scalar(v as f64),
            V::Uint64(v) => Value::Scalar(v as f64),
            V::Half(v) => Value::Scalar(h(v)),
            V::Float(v) => Value::Scalar(v.into()),
            V::Double(v) => Value::Scalar(v),
            V::String(s) => Value::Str(s),
            V::Token(t) => Value::Str(t.as_str().to_string()),
            V::AssetPath(a) => Value::Str(a.authored_path),
            V::StringVec(v) => Value::StrArray(v),
            V::TokenVec(v) => Value::StrArray(v.iter().map(|t| t.as_str().to_string()).collect()),
            V::AssetPathVec(v) => Value::StrArray(v.into_iter().map(|a| a.authored_path).collect()),
            V::BoolVec(v) => {
                Value::Array { data: v.iter().map(|&b| f64::from(u8::from(b))).collect(), arity: 1 }
            }
            V::UcharVec(v) => array(&v, 1),
            V::IntVec(v) => array(&v, 1),
            V::UintVec(v) => array(&v, 1),
            V::Int64Vec(v) => Value::Array { data: v.iter().map(|&x| x as f64).collect(), arity: 1 },
            V::Uint64Vec(v) => Value::Array { data: v.iter().map(|&x| x as f64).collect(), arity: 1 },
            V::HalfVec(v) => Value::Array { data: v.iter().map(|&x| h(x)).collect(), arity: 1 },
            V::FloatVec(v) => array(&v, 1),
            V::DoubleVec(v) => array(&v, 1),
            V::Quath(q) => Value::Quat([h(q.x), h(q.y), h(q.z), h(q.w)]),
            V::Quatf(q) => Value::Quat([q.x.into(), q.y.into(), q.z.into(), q.w.into()]),
            V::Quatd(q) => Value::Quat([q.x, q.y, q.z, q.w]),
            V::QuathVec(v) => Value::QuatArray(v.iter().map(|q| [h(q.x), h(q.y), h(q.z), h(q.w)]).collect()),
            V::QuatfVec(v) => {
                Value::QuatArray(v.iter().map(|q| [q.x.into(), q.y.into(), q.z.into(), q.w.into()]).collect())
            }
            V::QuatdVec(v) => Value::QuatArray(v.iter().map(|q| [q.x, q.y, q.z, q.w]).collect()),
            V::Vec2h(v) => Value::Tuple(vec![h(v.x), h(v.y)]),
            V::Vec2f(v) => tuple(&[v.x, v.y]),
            V::Vec2d(v) => tuple(&[v.x, v.y]),
            V::Vec2i(v) => tuple(&[v.x, v.y]),
            V::Vec3h(v) => Value::Tuple(vec![h(v.x), h(v.y), h(v.z)]),
            V::Vec3f(v) => tuple(&[v.x, v.y, v.z]),
            V::Vec3d(v) => tuple(&[v.x, v.y, v.z]),
            V::Vec3i(v) => tuple(&[v.x, v.y, v.z]),
            V::Vec4h(v) => Value::Tuple(vec![h(v.x), h(v.y), h(v.z), h(v.w)]),
            V::Vec4f(v) => tuple(&[v.x, v.y, v.z, v.w]),
            V::Vec4d(v) => tuple(&[v.x, v.y, v.z, v.w]),
            V::Vec4i(v) => tuple(&[v.x, v.y, v.z, v.w]),
            V::Vec2hVec(v) => {
                Value::Array { data: v.iter().flat_map(|e| [h(e.x), h(e.y)]).collect(), arity: 2 }
            }
            V::Vec2fVec(v) => {
                Value::Array { data: v.iter().flat_map(|e| [e.x.into(), e.y.into()]).collect(), arity: 2 }
            }
            V::Vec2dVec(v) => Value::Array { data: v.iter().flat_map(|e| [e.x, e.y]).collect(), arity: 2 },
            V::Vec2iVec(v) => {
                Value::Array { data: v.iter().flat_map(|e| [e.x.into(), e.y.into()]).collect(), arity: 2 }
            }
            V::Vec3hVec(v) => {
                Value::Array { data: v.iter().flat_map(|e| [h(e.x), h(e.y), h(e.z)]).collect(), arity: 3 }
            }
            V::Vec3fVec(v) => Value::Array {
                data: v.iter().flat_map(|e| [e.x.into(), e.y.into(), e.z.into()]).collect(),
                arity: 3,
            },
            V::Vec3dVec(v) => {
                Value::Array { data: v.iter().flat_map(|e| [e.x, e.y, e.z]).collect(), arity: 3 }
            }
            V::Vec3iVec(v) => Value::Array {
                data: v.iter().flat_map(|e| [e.x.into(), e.y.into(), e.z.into()]).collect(),
                arity: 3,
            },
            V::Vec4hVec(v) => Value::Array {
                data: v.iter().flat_map(|e| [h(e.x), h(e.y), h(e.z), h(e.w)]).collect(),
                arity: 4,
            },
            V::Vec4fVec(v) => Value::Array {
                data: v.iter().flat_map(|e| [e.x.into(), e.y.into(), e.z.into(), e.w.into()]).collect(),
                arity: 4,
            },
            V::Vec4dVec(v) => {
                Value::Array { data: v.iter().flat_map(|e| [e.x, e.y, e.z, e.w]).collect(), arity: 4 }
            }
            V::Matrix4d(m) => Value::Matrix(m.0),
            _ => Value::Other,
        }
    }
}

/// Prim types whose descendants the traversal leaves out: shading networks.
const SHADING_NETWORK: &[&str] = &["Material", "NodeGraph", "Shader"];

/// A composition problem found while opening or traversing, already mapped out of the crate's types.
#[derive(Clone, Debug)]
pub(crate) struct CompositionIssue {
    /// Layer that authored the failing arc (or the root layer).
    pub layer: String,
    /// Prim the arc is authored on, when known.
    pub prim: Option<String>,
    /// What went wrong.
    pub kind: UsdErrorKind,
    /// An error unless lenient: a missing or unreadable sublayer/reference/payload, or a
    /// composition cycle.
    pub fatal: bool,
}

/// A composed stage opened through `openusd`.
pub(crate) struct Stage {
    inner: usd::Stage,
    root_layer: String,
    /// A second resolver like the stage's, to re-read a layer the crate rejected and locate
    /// the construct it stopped at.
    resolver: IngestResolver,
    /// Time at which attributes are evaluated: [`LoadOptions::frame`], else the stage's
    /// `startTimeCode` (0 when unauthored). The crate interpolates time samples at it (linear
    /// for interpolable types, held otherwise) after applying layer offsets. A frame sequence
    /// moves it from frame to frame ([`Stage::set_time`]) over one composition.
    time: Cell<f64>,
    /// Non-fatal problems met while reading values, as (prim, message); see [`Stage::take_notes`].
    notes: RefCell<Vec<(String, String)>>,
    /// Texts of the composition errors [`Stage::composition_issues`] has returned.
    reported_issues: RefCell<HashSet<String>>,
    /// Every payload is loaded (no load rules), so active prims are loaded.
    all_payloads_loaded: bool,
    /// Nested instances whose contents openusd composes wrongly, found by [`Stage::traverse`]:
    /// queries below them are redirected (see [`NestedInstance`]).
    nested: RefCell<Vec<NestedInstance>>,
    /// The class arcs of the layers loaded so far, checked before each prim composes (see
    /// [`Stage::check_class_arcs`]).
    class_arcs: RefCell<ClassArcs>,
    /// The `fallbackPrimTypes` stage metadata: for a type name no schema registers, the types to
    /// draw it as, in order of preference (see [`Stage::type_name`]).
    fallback_types: HashMap<String, Vec<String>>,
}

/// The schema types usd-core registers that can appear on a drawn stage (UsdGeom, UsdLux,
/// UsdShade, UsdRender, UsdSkel, UsdVol, UsdMedia): a type outside this list takes its
/// `fallbackPrimTypes` entry, as usd-core does for types its schema registry lacks.
const SCHEMA_TYPES: &[&str] = &[
    "Xform",
    "Scope",
    "Mesh",
    "GeomSubset",
    "BasisCurves",
    "NurbsCurves",
    "HermiteCurves",
    "Points",
    "NurbsPatch",
    "TetMesh",
    "PointInstancer",
    "Camera",
    "Cube",
    "Sphere",
    "Cylinder",
    "Cylinder_1",
    "Cone",
    "Capsule",
    "Capsule_1",
    "Plane",
    "DomeLight",
    "DomeLight_1",
    "SphereLight",
    "RectLight",
    "DiskLight",
    "DistantLight",
    "CylinderLight",
    "PortalLight",
    "GeometryLight",
    "PluginLight",
    "LightFilter",
    "PluginLightFilter",
    "Material",
    "Shader",
    "NodeGraph",
    "RenderSettings",
    "RenderProduct",
    "RenderVar",
    "RenderPass",
    "SkelRoot",
    "Skeleton",
    "SkelAnimation",
    "BlendShape",
    "Volume",
    "OpenVDBAsset",
    "Field3DAsset",
    "SpatialAudio",
];

/// An instance reached through an instance proxy (an instanceable prim inside another instance's
/// prototype) whose own prototype openusd 0.6 composes empty.
///
/// The crate registers such a proxy (`/World/Outer/Nested`) as an instance in its own right and
/// mints a fresh prototype for it from the proxy's index, which comes out empty when the nested
/// prim internally references a prim of the enclosing prototype's source (usd-core shares
/// `/World/Inner/Nested`'s prototype). The prim it stands for inside the enclosing prototype
/// (`/__Prototype_1/Nested`) is an instance with the right prototype, so every query below the
/// proxy is asked there instead, and paths in the answers are mapped back.
#[derive(Clone, Debug)]
struct NestedInstance {
    /// The instance proxy path the reader sees (`/World/Outer/Nested`).
    proxy: String,
    /// The same prim inside the enclosing prototype (`/__Prototype_1/Nested`).
    in_prototype: String,
    /// That prim's own prototype (`/__Prototype_0`), in which relationship targets and
    /// connections below it may also be expressed.
    prototype: String,
}

/// `path` with its prefix `from` replaced by `to`, if it has that (whole-element) prefix.
fn replace_prefix(path: &str, from: &str, to: &str) -> Option<String> {
    let rest = path.strip_prefix(from)?;
    (rest.is_empty() || rest.starts_with(['/', '.'])).then(|| format!("{to}{rest}"))
}

/// Parses `s` into an `sdf::Path`.
fn path(s: &str) -> sdf::Path {
    sdf::Path::from(s)
}

impl Stage {
    /// Opens and composes the stage rooted at `file`.
    pub(crate) fn open(file: &Path, options: &LoadOptions) -> Result<Stage, UsdError> {
        let root_layer = file.display().to_string();
        let load =
            if options.load_payloads { usd::InitialLoadSet::LoadAll } else { usd::InitialLoadSet::LoadNone };
        let resolver = IngestResolver::new(&options.asset_paths);
        let inner = usd::Stage::builder()
            .resolver(IngestResolver::new(&options.asset_paths))
            .load(load)
            .open(&root_layer)
            .map_err(|e| {
                let mut message = format!("{e:#}");
                let root = resolver.resolve(&resolver.create_identifier(&root_layer, None));
                if let Some(location) = root.and_then(|r| locate_parse_error(&resolver, &r)) {
                    message = format!("{location} ({message})");
                }
                UsdError::new(&root_layer, UsdErrorKind::Open(message))
            })?;
        let time = options.frame.unwrap_or_else(|| inner.start_time_code());
        let fallback_types = match inner.stage_metadata("fallbackPrimTypes").ok().flatten() {
            Some(sdf::Value::Dictionary(map)) => map
                .into_iter()
                .filter_map(|(name, types)| match Value::from(types) {
                    Value::StrArray(types) => Some((name, types)),
                    _ => None,
                })
                .collect(),
            _ => HashMap::new(),
        };
        Ok(Stage {
            inner,
            root_layer,
            resolver,
            time: Cell::new(time),
            all_payloads_loaded: options.load_payloads,
            reported_issues: RefCell::new(HashSet::new()),
            notes: RefCell::new(Vec::new()),
            nested: RefCell::new(Vec::new()),
            class_arcs: RefCell::new(ClassArcs::default()),
            fallback_types,
        })
    }

    /// Refuses the stage if the layers loaded so far author an inherits/specializes cycle (or an
    /// exponentially branching class hierarchy), which openusd would recurse into until the
    /// stack overflows (see [`super::compat::class_arcs`]). Called before each prim of the
    /// traversal composes: the layers its pre-cache reads are those of its parent's index,
    /// loaded by then. Cheap when no layer loaded since the last call.
    fn check_class_arcs(&self) -> Result<(), UsdError> {
        let mut arcs = self.class_arcs.borrow_mut();
        if self.inner.layer_count() > arcs.scanned_count() {
            for identifier in self.inner.layer_identifiers() {
                if !arcs.has_scanned(&identifier) {
                    if let Some(layer) = self.inner.layer(&identifier) {
                        arcs.scan(&identifier, layer.data());
                    }
                }
            }
        }
        arcs.check().map_err(|p| UsdError::new(&p.layer, UsdErrorKind::Stage(p.message)).at(&p.prim))
    }

    /// The identifiers of every layer composition has opened so far (the root layer, sublayers,
    /// references, payloads), for the check that no output overwrites one.
    pub(crate) fn layer_files(&self) -> Vec<String> {
        self.inner.layer_identifiers()
    }

    fn err(&self, e: anyhow::Error) -> UsdError {
        UsdError::new(&self.root_layer, UsdErrorKind::Stage(format!("{e:#}")))
    }

    /// Every prim of the default traversal region (active, loaded, defined, non-abstract), in
    /// depth-first pre-order, descending into instances (instance proxies).
    ///
    /// The contents of a nested instance openusd composes empty (see [`NestedInstance`]) are
    /// listed from the prim it stands for inside the enclosing prototype.
    ///
    /// Walked here rather than through `usd::Stage::traverse`: the crate resolves every prim's
    /// status bits by re-reading all its ancestors' `active` and `specifier` (three walks to the
    /// root per prim, about a third of a listing's CPU on the teapot scene, measured with perf).
    /// Top-down, a prim is in the region exactly when its parent was and its own opinions say
    /// so, and whether it lies inside an instance is known from its ancestors.
    pub(crate) fn traverse(&self) -> Result<Vec<String>, UsdError> {
        // With every payload loaded (no load rules) a prim is loaded whenever it is active;
        // otherwise the crate's own answer is asked, ancestors and all.
        let check_loaded = !self.all_payloads_loaded;
        let mut out = Vec::new();
        // (prim, whether an ancestor is an instance), popped in pre-order.
        let mut stack: Vec<(sdf::Path, bool)> = Vec::new();
        self.push_children(&sdf::Path::abs_root(), false, &mut stack)?;
        while let Some((prim_path, in_instance)) = stack.pop() {
            self.check_class_arcs()?;
            let prim = self.inner.prim(prim_path.clone());
            // `Attribute::get_metadata` on a prim path reads the prim's own composed field:
            // the crate exposes no prim-level metadata getter.
            let active = self
                .inner
                .attribute(prim_path.clone())
                .get_metadata::<bool>("active")
                .map_err(|e| self.err(e))?
                .unwrap_or(true);
            // No spec composes no specifier: such a prim is not defined either.
            let specifier = prim.specifier().map_err(|e| self.err(e))?;
            let defined = matches!(specifier, Some(sdf::Specifier::Def | sdf::Specifier::Class));
            let is_class = specifier == Some(sdf::Specifier::Class);
            if !active || !defined || is_class || (check_loaded && !prim.is_loaded().unwrap_or(false)) {
                continue;
            }
            let name = prim_path.as_str().to_string();
            out.push(name.clone());
            let instanceable = self
                .inner
                .attribute(prim_path.clone())
                .get_metadata::<bool>("instanceable")
                .map_err(|e| self.err(e))?
                .unwrap_or(false);
            let is_instance = instanceable && prim.is_instance().unwrap_or(false);
            if in_instance && is_instance {
                if let Some(in_prototype) = self.misplaced_nested_instance(&name) {
                    self.redirect_nested(&name, &in_prototype);
                    self.list_below(&name, &in_prototype, &mut out)?;
                    continue;
                }
            }
            // The reader never walks below a shading prim: a material's network is read on
            // demand from its bound path, so unbound networks are never composed (half of the
            // teapot scene's prims). See [`Stage::composition_issues`] for their errors.
            let ty = prim.type_name().map_err(|e| self.err(e))?;
            if ty.is_some_and(|t| SHADING_NETWORK.contains(&t.as_str())) {
                continue;
            }
            self.push_children(&prim_path, in_instance || is_instance, &mut stack)?;
        }
        // The last prim may have loaded layers of its own.
        self.check_class_arcs()?;
        Ok(out)
    }

    /// Pushes the composed children of `parent` so that the first child pops first.
    fn push_children(
        &self,
        parent: &sdf::Path,
        in_instance: bool,
        stack: &mut Vec<(sdf::Path, bool)>,
    ) -> Result<(), UsdError> {
        let names = self.inner.prim(parent.clone()).child_names().map_err(|e| self.err(e))?;
        for name in names.iter().rev() {
            if let Ok(child) = parent.append_path(name.as_str()) {
                stack.push((child, in_instance));
            }
        }
        Ok(())
    }

    /// For an instance proxy that is itself an instance whose prototype differs from that of the
    /// prim it stands for inside the enclosing prototype, that prim (see [`NestedInstance`]).
    fn misplaced_nested_instance(&self, query: &str) -> Option<String> {
        let prim = self.inner.prim(path(query));
        if !prim.is_instance().unwrap_or(false) || !prim.is_instance_proxy().unwrap_or(false) {
            return None;
        }
        let stands_for = prim.prim_in_prototype().ok().flatten()?;
        let own = prim.prototype().ok().flatten();
        let shared = stands_for.prototype().ok().flatten()?;
        (own.as_ref() != Some(&shared)).then(|| stands_for.path().as_str().to_string())
    }

    fn redirect_nested(&self, proxy: &str, in_prototype: &str) {
        let prototype = self
            .inner
            .prim(path(in_prototype))
            .prototype()
            .ok()
            .flatten()
            .map(|p| p.as_str().to_string())
            .unwrap_or_default();
        self.nested.borrow_mut().push(NestedInstance {
            proxy: proxy.to_string(),
            in_prototype: in_prototype.to_string(),
            prototype,
        });
    }

    /// Appends the default-region descendants of `proxy` in pre-order, composed at `query`.
    fn list_below(&self, proxy: &str, query: &str, out: &mut Vec<String>) -> Result<(), UsdError> {
        let children = self.inner.prim(path(query)).children().map_err(|e| self.err(e))?;
        for child in children {
            let in_region = child.is_active().unwrap_or(false)
                && child.is_loaded().unwrap_or(false)
                && child.is_defined().unwrap_or(false)
                && !child.is_abstract().unwrap_or(true);
            if !in_region {
                continue;
            }
            let child_query = child.path().as_str().to_string();
            let Some(child_proxy) = replace_prefix(&child_query, query, proxy) else { continue };
            out.push(child_proxy.clone());
            match self.misplaced_nested_instance(&child_query) {
                Some(in_prototype) => {
                    self.redirect_nested(&child_proxy, &in_prototype);
                    self.list_below(&child_proxy, &in_prototype, out)?;
                }
                None => self.list_below(&child_proxy, &child_query, out)?,
            }
        }
        Ok(())
    }

    /// The path openusd composes the reader's prim path `prim` at: itself, or for a prim below a
    /// [`NestedInstance`] the same prim below the instance's stand-in.
    fn query(&self, prim: &str) -> sdf::Path {
        let nested = self.nested.borrow();
        if nested.is_empty() {
            return path(prim);
        }
        let deepest = nested
            .iter()
            .filter_map(|n| {
                let rest = prim.strip_prefix(&n.proxy)?;
                rest.starts_with('/').then(|| format!("{}{rest}", n.in_prototype))
            })
            .max_by_key(String::len);
        path(deepest.as_deref().unwrap_or(prim))
    }

    /// Maps a path answered for a query on `prim` back to the reader's namespace (see
    /// [`NestedInstance`]): paths below the stand-in or its prototype become paths below the proxy.
    fn answer(&self, prim: &str, answer: String) -> String {
        let nested = self.nested.borrow();
        let owner = nested
            .iter()
            .filter(|n| prim.strip_prefix(&n.proxy).is_some_and(|rest| rest.starts_with('/')))
            .max_by_key(|n| n.proxy.len());
        let Some(n) = owner else { return answer };
        replace_prefix(&answer, &n.in_prototype, &n.proxy)
            .or_else(|| {
                (!n.prototype.is_empty()).then(|| replace_prefix(&answer, &n.prototype, &n.proxy)).flatten()
            })
            .unwrap_or(answer)
    }

    /// The prim's schema type name (`""` when untyped). A type no schema registers is drawn as
    /// the first registered type of its `fallbackPrimTypes` entry, when the stage authors one.
    pub(crate) fn type_name(&self, prim: &str) -> String {
        let authored = self
            .inner
            .prim(self.query(prim))
            .type_name()
            .ok()
            .flatten()
            .map(|t| t.as_str().to_string())
            .unwrap_or_default();
        if authored.is_empty() || SCHEMA_TYPES.contains(&authored.as_str()) {
            return authored;
        }
        let fallback = self
            .fallback_types
            .get(&authored)
            .and_then(|types| types.iter().find(|t| SCHEMA_TYPES.contains(&t.as_str())));
        fallback.cloned().unwrap_or(authored)
    }

    /// Whether a `def` (not only `over`s, or nothing) composes at the prim's path.
    pub(crate) fn is_defined(&self, prim: &str) -> bool {
        self.inner.prim(self.query(prim)).is_defined().unwrap_or(false)
    }

    /// Whether the prim is an instance (instanceable with a composition arc).
    pub(crate) fn is_instance(&self, prim: &str) -> bool {
        self.inner.prim(self.query(prim)).is_instance().unwrap_or(false)
    }

    /// Composed property names of the prim.
    pub(crate) fn property_names(&self, prim: &str) -> Vec<String> {
        self.inner
            .prim(self.query(prim))
            .property_names()
            .map(|v| v.iter().map(|t| t.as_str().to_string()).collect())
            .unwrap_or_default()
    }

    fn attr_handle(&self, prim: &str, name: &str) -> Result<usd::Attribute, UsdError> {
        // Names can come from values (`xformOpOrder`, a primvar reader's `varname`); the crate
        // appends any text and then loops forever on the parents of a malformed path (found by
        // the layer fuzzer: an xformOpOrder entry holding `}` and line breaks).
        super::compat::path_syntax::check_element(name, super::compat::path_syntax::Element::Property)
            .map_err(|e| {
                self.attr_err(prim, &name.escape_debug().to_string(), format!("not a property name: {e}"))
            })?;
        let p = self
            .query(prim)
            .append_property(name)
            .map_err(|e| self.attr_err(prim, name, format!("{e:#}")))?;
        Ok(self.inner.attribute(p))
    }

    fn attr_err(&self, prim: &str, name: &str, message: String) -> UsdError {
        UsdError::new(&self.root_layer, UsdErrorKind::Invalid(message)).at(prim).attribute(name)
    }

    /// The attribute's value at the stage's start time (time samples win, else the default),
    /// `None` when unauthored or blocked.
    pub(crate) fn attr(&self, prim: &str, name: &str) -> Result<Option<Value>, UsdError> {
        self.attr_at(prim, name, self.time.get())
    }

    /// [`Stage::attr`] at time code `time` (time samples interpolated as USD does: linearly,
    /// quaternions by slerp; held before the first and after the last).
    pub(crate) fn attr_at(&self, prim: &str, name: &str, time: f64) -> Result<Option<Value>, UsdError> {
        let handle = self.attr_handle(prim, name)?;
        let value = match handle.get_at::<sdf::Value>(usd::TimeCode::new(time)) {
            Ok(value) => value,
            Err(timed) => {
                // openusd cannot decode some time-sample encodings; the default value may still be
                // readable, which beats failing the whole stage.
                let value = handle.get::<sdf::Value>().map_err(|_| {
                    self.attr_err(prim, name, format!("{timed:#}")).in_layer(self.authoring_layer(prim, name))
                })?;
                self.notes.borrow_mut().push((
                    prim.to_string(),
                    format!("{name}: time samples unreadable ({timed:#}); using the default value"),
                ));
                value
            }
        };
        Ok(value.map(Value::from))
    }

    /// How many time samples the attribute has (0 when unauthored, unreadable or only a default).
    pub(crate) fn time_sample_count(&self, prim: &str, name: &str) -> usize {
        self.attr_handle(prim, name).ok().and_then(|h| h.num_time_samples().ok()).unwrap_or(0)
    }

    /// The authored sample times of the attribute inside `[lo, hi]`, ascending (empty when it has
    /// none there or they cannot be read).
    pub(crate) fn sample_times_in(&self, prim: &str, name: &str, lo: f64, hi: f64) -> Vec<f64> {
        self.attr_handle(prim, name)
            .ok()
            .and_then(|h| h.time_samples_in_interval(lo..=hi).ok())
            .unwrap_or_default()
    }

    /// The time code attributes are evaluated at.
    pub(crate) fn time(&self) -> f64 {
        self.time.get()
    }

    /// Evaluates attributes at `time` from now on (the next frame of a sequence). Composition is
    /// time-independent, so nothing composed so far changes.
    pub(crate) fn set_time(&self, time: f64) {
        self.time.set(time);
    }

    /// Drains the non-fatal problems recorded while reading values, as (prim, message).
    pub(crate) fn take_notes(&self) -> Vec<(String, String)> {
        std::mem::take(&mut self.notes.borrow_mut())
    }

    /// The attribute's declared type name (`point3f[]`, `texCoord2f[]`, ...).
    pub(crate) fn attr_type(&self, prim: &str, name: &str) -> Option<String> {
        let handle = self.attr_handle(prim, name).ok()?;
        handle.type_name().ok().flatten().map(|t| t.as_str().to_string())
    }

    /// A metadata field on an attribute (`interpolation`, `elementSize`, ...).
    pub(crate) fn attr_metadata(&self, prim: &str, name: &str, key: &str) -> Option<Value> {
        let handle = self.attr_handle(prim, name).ok()?;
        handle.get_metadata::<sdf::Value>(key).ok().flatten().map(Value::from)
    }

    /// Connection sources of an attribute, as property paths (`/Mat/Shader.outputs:surface`).
    pub(crate) fn connections(&self, prim: &str, name: &str) -> Vec<String> {
        let Ok(handle) = self.attr_handle(prim, name) else { return Vec::new() };
        handle
            .connections()
            .map(|v| v.iter().map(|p| self.answer(prim, p.as_str().to_string())).collect())
            .unwrap_or_default()
    }

    /// Targets of a relationship.
    pub(crate) fn targets(&self, prim: &str, name: &str) -> Vec<String> {
        let Ok(p) = self.query(prim).append_property(name) else { return Vec::new() };
        self.inner
            .relationship(p)
            .targets()
            .map(|v| v.iter().map(|p| self.answer(prim, p.as_str().to_string())).collect())
            .unwrap_or_default()
    }

    /// A composed integer list-op metadata field of a prim (`inactiveIds`): every layer's list op
    /// applied from the weakest to the strongest opinion.
    ///
    /// A `.usdc` layer holds a real `int64ListOp`; a `.usda` layer holds the explicit items under
    /// `key` and each operation's items under [`list_op_field`] (see [`super::compat::layer_fix`]).
    pub(crate) fn prim_id_list(&self, prim: &str, key: &str) -> Vec<i64> {
        let Ok(stack) = self.inner.prim(self.query(prim)).prim_stack() else { return Vec::new() };
        let mut ids: Vec<i64> = Vec::new();
        for (layer_id, spec_path) in stack.iter().rev() {
            let Some(layer) = self.inner.layer(layer_id) else { continue };
            let Some(spec) = layer.prim(spec_path.clone()) else { continue };
            let field = |name: &str| spec.field(name).ok().flatten();
            let items = |name: &str| match field(name) {
                Some(sdf::Value::Int64Vec(v)) => Some(v),
                Some(sdf::Value::IntVec(v)) => Some(v.into_iter().map(i64::from).collect()),
                _ => None,
            };
            let op = match field(key) {
                Some(sdf::Value::Int64ListOp(op)) => op,
                Some(sdf::Value::IntListOp(op)) => sdf::Int64ListOp {
                    explicit: op.explicit,
                    explicit_items: op.explicit_items.into_iter().map(i64::from).collect(),
                    added_items: op.added_items.into_iter().map(i64::from).collect(),
                    prepended_items: op.prepended_items.into_iter().map(i64::from).collect(),
                    appended_items: op.appended_items.into_iter().map(i64::from).collect(),
                    deleted_items: op.deleted_items.into_iter().map(i64::from).collect(),
                    ordered_items: op.ordered_items.into_iter().map(i64::from).collect(),
                },
                _ => {
                    let explicit = items(key);
                    let listed = |op: &str| items(&list_op_field(key, op)).unwrap_or_default();
                    sdf::Int64ListOp {
                        explicit: explicit.is_some(),
                        explicit_items: explicit.unwrap_or_default(),
                        added_items: listed("add"),
                        prepended_items: listed("prepend"),
                        appended_items: listed("append"),
                        deleted_items: listed("delete"),
                        ordered_items: listed("reorder"),
                    }
                }
            };
            ids = op.compose_over(&ids);
        }
        ids
    }

    /// A metadata field on a relationship (`bindMaterialAs`), from the strongest spec authoring it.
    pub(crate) fn rel_metadata(&self, prim: &str, name: &str, key: &str) -> Option<Value> {
        let p = self.query(prim).append_property(name).ok()?;
        let stack = self.inner.relationship(p).property_stack().ok()?;
        stack.iter().find_map(|(layer_id, spec_path)| {
            let layer = self.inner.layer(layer_id)?;
            let spec = layer.relationship(spec_path.clone())?;
            spec.field(key).ok().flatten().map(Value::from)
        })
    }

    /// The layer holding the strongest opinion for an attribute (the root layer when unknown).
    pub(crate) fn authoring_layer(&self, prim: &str, name: &str) -> String {
        self.attr_handle(prim, name)
            .ok()
            .and_then(|h| h.property_stack().ok())
            .and_then(|s| s.into_iter().next())
            .map(|(layer, _)| layer)
            .unwrap_or_else(|| self.root_layer.clone())
    }

    /// Composed stage metadata (`upAxis`, `metersPerUnit`, ...).
    pub(crate) fn metadata(&self, key: &str) -> Option<Value> {
        self.inner.stage_metadata(key).ok().flatten().map(Value::from)
    }

    /// Composition errors found since the last call (call after traversal: prim indices compose
    /// lazily).
    ///
    /// The traversal leaves shading networks uncomposed, and the reader composes a bound
    /// material's network when it reads it, so this is called again once the scene is read.
    /// An arc that fails inside a network no gprim binds is never reported (usd-core, which
    /// composes every prim, warns about it).
    pub(crate) fn composition_issues(&self) -> Vec<CompositionIssue> {
        let mut reported = self.reported_issues.borrow_mut();
        let mut out = Vec::new();
        for error in self.inner.composition_errors() {
            let text = error.to_string();
            if !reported.insert(text.clone()) {
                continue;
            }
            out.push(self.map_issue(error, text));
        }
        // The crate keeps prim-index errors in a randomly seeded hash map, so its order changes
        // from run to run: sorted for the same warnings in the same order (and the same first
        // fatal error) on every run.
        out.sort_by_cached_key(|issue| (issue.prim.clone(), issue.layer.clone(), issue.kind.to_string()));
        out
    }

    fn map_issue(&self, error: pcp::Error, text: String) -> CompositionIssue {
        let arc_name = |arc: pcp::ArcType| format!("{arc:?}").to_lowercase();
        match error {
            pcp::Error::UnresolvedLayer { asset_path, arc, introduced_by, site_path } => CompositionIssue {
                layer: authoring_layer(&asset_path).unwrap_or(introduced_by),
                prim: Some(site_path.as_str().to_string()),
                kind: UsdErrorKind::MissingAsset { arc: arc_name(arc), asset: asset_path },
                fatal: true,
            },
            pcp::Error::MalformedLayer { asset_path, arc, introduced_by, site_path, reason } => {
                let reason = self.locate(&asset_path, &introduced_by, reason);
                CompositionIssue {
                    prim: Some(site_path.as_str().to_string()),
                    // A file that exists in a format openusd cannot read (`.mtlx` references in
                    // MaterialX-only looks) is not a missing asset: usd-core skips it with a warning too.
                    fatal: !reason.contains("no file format registered"),
                    kind: UsdErrorKind::MalformedAsset { arc: arc_name(arc), asset: asset_path, reason },
                    layer: introduced_by,
                }
            }
            pcp::Error::UnresolvedSublayer { asset_path, introduced_by } => CompositionIssue {
                layer: introduced_by,
                prim: None,
                kind: UsdErrorKind::MissingAsset { arc: "sublayer".into(), asset: asset_path },
                fatal: true,
            },
            pcp::Error::MalformedSublayer { asset_path, introduced_by, reason } => CompositionIssue {
                prim: None,
                kind: UsdErrorKind::MalformedAsset {
                    arc: "sublayer".into(),
                    reason: self.locate(&asset_path, &introduced_by, reason),
                    asset: asset_path,
                },
                layer: introduced_by,
                fatal: true,
            },
            pcp::Error::ArcCycle(chain) => CompositionIssue {
                layer: chain.root_layer.clone(),
                prim: Some(chain.composing.as_str().to_string()),
                kind: UsdErrorKind::Stage(describe_cycle(&chain)),
                fatal: true,
            },
            pcp::Error::SublayerCycle { root_layer, seen_layer } => CompositionIssue {
                kind: UsdErrorKind::Stage(format!(
                    "sublayer cycle: {root_layer} includes {seen_layer}, which already includes it"
                )),
                layer: root_layer,
                prim: None,
                fatal: true,
            },
            _ => CompositionIssue {
                layer: self.root_layer.clone(),
                prim: None,
                kind: UsdErrorKind::Stage(text),
                fatal: false,
            },
        }
    }

    /// `reason` with the line and construct the parser stopped at in the layer `asset_path`
    /// (as authored in `introduced_by`), when it is a text layer that fails to parse.
    fn locate(&self, asset_path: &str, introduced_by: &str, reason: String) -> String {
        let anchor = ResolvedPath::new(introduced_by);
        let identifier = self.resolver.create_identifier(asset_path, Some(&anchor));
        match self.resolver.resolve(&identifier).and_then(|r| locate_parse_error(&self.resolver, &r)) {
            Some(location) => format!("{location} ({reason})"),
            None => reason,
        }
    }
}

/// `file: line L, column C: `source`: message` for a text layer the crate cannot parse.
fn locate_parse_error(resolver: &IngestResolver, resolved: &ResolvedPath) -> Option<String> {
    let text = resolver.layer_text(resolved)?;
    parse_error_location(&text).map(|location| format!("{resolved}: {location}"))
}

/// Most nested composition arcs openusd composes below one prim: its `MAX_DEPTH`, which is not
/// configurable from outside the crate, raised from 100 to 1000 in the vendored copy
/// (vendor/openusd/VENDORED.md) so that the chains usd-core composes (500 deep) compose here too.
const MAX_ARC_DEPTH: usize = 1000;

/// A reference/payload/inherit cycle as `/A (a.usda) -references-> </B> in b.usda -> ...`, or,
/// when the chain's last site repeats none before it, the crate's depth limit it stands for.
///
/// openusd reports a chain deeper than [`MAX_ARC_DEPTH`] arcs as the same `ArcCycle` as a real
/// cycle; an acyclic chain that long is not a cycle, so it is named as the limit it is (with the
/// chain's ends: the middle of a 1000-arc chain is noise).
fn describe_cycle(chain: &pcp::CycleChain) -> String {
    let file =
        |layer: &str| Path::new(layer).file_name().map_or(layer.to_string(), |f| f.to_string_lossy().into());
    let hop_text = |hop: &pcp::CycleHop| {
        let arc = format!("{:?}", hop.arc).to_lowercase();
        format!(" -{arc}-> <{}> in {}", hop.path.as_str(), file(&hop.layer))
    };
    let closes = chain.hops.split_last().is_some_and(|(last, before)| {
        let repeats = |layer: &str, site: &sdf::Path| layer == last.layer && site.is_nested_with(&last.path);
        repeats(&chain.root_layer, &chain.composing) || before.iter().any(|h| repeats(&h.layer, &h.path))
    });
    let start = format!("<{}> in {}", chain.composing.as_str(), file(&chain.root_layer));
    if !closes && chain.hops.len() + 1 >= MAX_ARC_DEPTH {
        let hops = &chain.hops;
        let mut text = format!(
            "composition depth limit: {start} nests more than {MAX_ARC_DEPTH} arcs (the composition depth limit; the deeper arcs are dropped): {start}"
        );
        for hop in &hops[..3.min(hops.len())] {
            text.push_str(&hop_text(hop));
        }
        if hops.len() > 5 {
            text.push_str(&format!(" ... ({} more arcs)", hops.len() - 5));
        }
        for hop in &hops[3.max(hops.len().saturating_sub(2)).min(hops.len())..] {
            text.push_str(&hop_text(hop));
        }
        return text;
    }
    let mut text = format!("composition cycle: {start}");
    for hop in &chain.hops {
        text.push_str(&hop_text(hop));
    }
    text.push_str(" (the last arc closes the cycle and is dropped)");
    text
}

/// The text layer that authored the arc to `asset_path`, which the crate reports only as its layer
/// stack's root. The crate anchors a relative asset path at the authoring layer's folder, so
/// `asset_path` is `<that folder>/<authored path>`: for each way to split it there, a `.usda`/`.usd`
/// layer in the folder whose text contains `@<authored path>@` is the author. Only runs on errors.
fn authoring_layer(asset_path: &str) -> Option<String> {
    for (i, _) in asset_path.match_indices('/') {
        let (folder, authored) = (&asset_path[..=i], &asset_path[i + 1..]);
        let Ok(entries) = std::fs::read_dir(folder) else { continue };
        let needle = format!("@{authored}@");
        for entry in entries.flatten() {
            let path = entry.path();
            let is_layer = path.extension().is_some_and(|e| e == "usda" || e == "usd");
            if is_layer && std::fs::read_to_string(&path).is_ok_and(|text| text.contains(&needle)) {
                return Some(path.to_string_lossy().into_owned());
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::{replace_prefix, Stage};
    use crate::usd::{load, LoadOptions};

    /// OpenUSD's ni_ni_* pattern: `/World/Outer` instances `/World/Inner`, inside which `Nested`
    /// instances `/World/Inner/Proto`, whose mesh binds a material of its own subtree.
    const NESTED: &str = r#"#usda 1.0
def Xform "World"
{
    def Xform "Inner"
    {
        def Xform "Proto"
        {
            def Mesh "Tri" (prepend apiSchemas = ["MaterialBindingAPI"])
            {
                rel material:binding = </World/Inner/Proto/Red>
                int[] faceVertexCounts = [3]
                int[] faceVertexIndices = [0, 1, 2]
                point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
                uniform token subdivisionScheme = "none"
            }
            def Material "Red"
            {
                token outputs:surface.connect = </World/Inner/Proto/Red/Surface.outputs:surface>
                def Shader "Surface"
                {
                    uniform token info:id = "UsdPreviewSurface"
                    color3f inputs:diffuseColor = (1, 0, 0)
                    token outputs:surface
                }
            }
        }
        def "Nested" (instanceable = true references = </World/Inner/Proto>)
        {
            double3 xformOp:translate = (0, 3, 0)
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }
    }
    def "Outer" (instanceable = true references = </World/Inner>)
    {
        double3 xformOp:translate = (5, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
"#;

    #[test]
    fn a_nested_instance_inside_a_prototype_is_drawn_with_its_own_material() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("nested.usda");
        std::fs::write(&root, NESTED).unwrap();
        let scene = load(&root, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        let mut drawn: Vec<(String, [f32; 2], String)> = scene
            .meshes
            .iter()
            .map(|m| {
                let [lo, _] = m.world_bounds();
                let (x, y) = (lo.x, lo.y);
                let material = scene.materials[m.triangle_materials[0] as usize].path.clone();
                (m.path.clone(), [x, y], material)
            })
            .collect();
        drawn.sort_by(|a, b| a.0.cmp(&b.0));
        // usd-core lists the same four (test_usd_crosscheck's nested_instancing stage).
        let expected = [
            ("/World/Inner/Nested/Tri", [0.0, 3.0], "/World/Inner/Nested/Red"),
            ("/World/Inner/Proto/Tri", [0.0, 0.0], "/World/Inner/Proto/Red"),
            ("/World/Outer/Nested/Tri", [5.0, 3.0], "/World/Outer/Nested/Red"),
            ("/World/Outer/Proto/Tri", [5.0, 0.0], "/World/Outer/Proto/Red"),
        ];
        let expected: Vec<_> =
            expected.iter().map(|(p, xy, m)| (p.to_string(), *xy, m.to_string())).collect();
        assert_eq!(drawn, expected);
    }

    #[test]
    fn a_binding_to_a_material_no_layer_defines_is_warned_as_such() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("unbound.usda");
        let text = r#"#usda 1.0
def Mesh "Tri" (prepend apiSchemas = ["MaterialBindingAPI"])
{
    rel material:binding = </Looks/FromMtlx>
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
}
over "Looks"
{
    over "FromMtlx"
    {
    }
}
def Scope "Scoped"
{
}
def Mesh "Tri2" (prepend apiSchemas = ["MaterialBindingAPI"])
{
    rel material:binding = </Scoped>
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
}
"#;
        std::fs::write(&root, text).unwrap();
        let scene = load(&root, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        let warned = |prim: &str| -> Vec<String> {
            scene.warnings.iter().filter(|w| w.prim == prim).map(|w| w.message.clone()).collect()
        };
        assert_eq!(
            warned("/Looks/FromMtlx"),
            ["bound material is not defined on the stage (no composed layer defines it: see the composition warnings for an arc that failed); using displayColor"]
        );
        assert_eq!(
            warned("/Scoped"),
            ["bound material is a \"Scope\" prim, not a Material; using displayColor"]
        );
    }

    /// Every way a prim leaves the default traversal region: inactive (itself or an ancestor),
    /// not defined (below an `over`), abstract (below a `class`), unloaded (a payload left out).
    const REGION: &str = r#"#usda 1.0
def Xform "World"
{
    def Xform "Off" (active = false)
    {
        def Mesh "Hidden"
        {
        }
    }
    over "Overed"
    {
        def Mesh "UnderOver"
        {
        }
    }
    class "Klass"
    {
        def Mesh "UnderClass"
        {
        }
    }
    def Xform "Proto"
    {
        def Mesh "Leaf"
        {
        }
        def Xform "Deactivated" (active = false)
        {
        }
    }
    def "Inst" (
        instanceable = true
        references = </World/Proto>
    )
    {
    }
    def "Loaded" (payload = @payload.usda@</Thing>)
    {
    }
    def Scope "Last"
    {
    }
}
"#;

    /// The traversal region usd-core lists (`Stage.Traverse(TraverseInstanceProxies())`), with
    /// and without payloads, in its order.
    #[test]
    fn the_traversal_lists_the_default_region_in_pre_order() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("root.usda");
        std::fs::write(&root, REGION).unwrap();
        std::fs::write(
            dir.path().join("payload.usda"),
            r#"#usda 1.0
def Xform "Thing"
{
    def Mesh "Inner"
    {
    }
}
"#,
        )
        .unwrap();
        let listed = |load_payloads: bool| {
            let options = LoadOptions { load_payloads, ..LoadOptions::default() };
            Stage::open(&root, &options).unwrap_or_else(|e| panic!("{e}")).traverse().unwrap()
        };
        let loaded = [
            "/World",
            "/World/Proto",
            "/World/Proto/Leaf",
            "/World/Inst",
            "/World/Inst/Leaf",
            "/World/Loaded",
            "/World/Loaded/Inner",
            "/World/Last",
        ];
        assert_eq!(listed(true), loaded);
        let unloaded: Vec<&str> =
            loaded.iter().copied().filter(|p| !p.starts_with("/World/Loaded")).collect();
        assert_eq!(listed(false), unloaded);
    }

    /// The crate reports prim-index errors in a randomly seeded order; ours are sorted.
    #[test]
    fn composition_issues_come_in_prim_order() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("missing.usda");
        let mut text = String::from("#usda 1.0\n");
        for name in ["Zeta", "Alpha", "Mu", "Beta", "Omega", "Delta"] {
            text.push_str(&format!("def Xform \"{name}\" (references = @{name}.usda@) {{}}\n"));
        }
        std::fs::write(&root, text).unwrap();
        let options = LoadOptions { lenient: true, ..LoadOptions::default() };
        let stage = Stage::open(&root, &options).unwrap();
        stage.traverse().unwrap();
        let prims: Vec<String> =
            stage.composition_issues().into_iter().map(|i| i.prim.unwrap_or_default()).collect();
        assert_eq!(prims, ["/Alpha", "/Beta", "/Delta", "/Mu", "/Omega", "/Zeta"]);
    }

    /// A shader that references a missing file, in a network a gprim binds.
    const BOUND_NETWORK_ARC: &str = r#"#usda 1.0
def Mesh "Tri" (prepend apiSchemas = ["MaterialBindingAPI"])
{
    rel material:binding = </Looks/Red>
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    uniform token subdivisionScheme = "none"
}
def Scope "Looks"
{
    def Material "Red"
    {
        token outputs:surface.connect = </Looks/Red/Surface.outputs:surface>
        def Shader "Surface" (references = @missing_shader.usda@)
        {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (1, 0, 0)
            token outputs:surface
        }
    }
}
"#;

    /// Shading networks are composed only when read, yet an arc failing in a bound one is
    /// still the error it was when the traversal composed every prim (and a warning when lenient).
    #[test]
    fn a_missing_asset_in_a_bound_shading_network_is_still_reported() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("bound.usda");
        std::fs::write(&root, BOUND_NETWORK_ARC).unwrap();
        let stage = Stage::open(&root, &LoadOptions::default()).unwrap();
        assert_eq!(stage.traverse().unwrap(), ["/Tri", "/Looks", "/Looks/Red"]);
        let error = load(&root, &LoadOptions::default()).expect_err("a missing reference is an error");
        assert_eq!(error.prim(), Some("/Looks/Red/Surface"));
        assert!(matches!(error.kind(), crate::usd::UsdErrorKind::MissingAsset { .. }), "{error}");
        let lenient = LoadOptions { lenient: true, ..LoadOptions::default() };
        let scene = load(&root, &lenient).unwrap_or_else(|e| panic!("{e}"));
        let warned: Vec<&str> = scene
            .warnings
            .iter()
            .filter(|w| w.prim == "/Looks/Red/Surface")
            .map(|w| w.message.as_str())
            .collect();
        assert_eq!(warned.len(), 1, "{:?}", scene.warnings);
        assert!(warned[0].contains("missing_shader.usda"), "{warned:?}");
    }

    #[test]
    fn prefixes_are_replaced_on_whole_path_elements_only() {
        assert_eq!(replace_prefix("/A/B/C", "/A/B", "/P").as_deref(), Some("/P/C"));
        assert_eq!(replace_prefix("/A/B.rel", "/A/B", "/P").as_deref(), Some("/P.rel"));
        assert_eq!(replace_prefix("/A/B", "/A/B", "/P").as_deref(), Some("/P"));
        assert_eq!(replace_prefix("/A/BC", "/A/B", "/P"), None);
        assert_eq!(replace_prefix("/X", "/A/B", "/P"), None);
    }
}
