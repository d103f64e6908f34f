//! The walk over the object hierarchy: each object becomes a prim of the USD layer, by schema.

use std::collections::HashMap;

use super::archive::{Compound, Object, ObjectHeader};
use super::sample::Sampler;
use super::usda::{identifier, Layer};

/// Scope holding the generated materials (reserved at the root of the layer).
pub(super) const MATERIALS: &str = "_alembic_materials";
/// The material of faces in no face set.
pub(super) const DEFAULT_MATERIAL: &str = "default";

/// Deepest object nesting read (a corrupt archive can make a group its own descendant).
const MAX_DEPTH: usize = 128;
/// Most objects translated (shared groups can make a small file name exponentially many).
const MAX_OBJECTS: usize = 1_000_000;

/// The schemas read; any other object is an untyped prim holding its children.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Group,
    Xform,
    PolyMesh,
    SubD,
    Curves,
    Points,
    Camera,
}

/// `curveBasisAndType[0]` of NURBS curves.
const VARIABLE_ORDER: u8 = 2;

/// An error at one object: (Alembic path, message).
pub(super) type ObjectError = (String, String);

/// Translation state.
pub(super) struct Translator {
    pub sampler: Sampler,
    pub layer: Layer,
    /// Non-fatal findings as (Alembic path, message).
    pub warnings: Vec<(String, String)>,
    /// USD material name per face-set name, in first-use order.
    pub materials: Vec<(String, String)>,
    material_names: HashMap<String, String>,
    /// Alembic path of the object being written (for warnings).
    pub current: String,
    /// Group offsets of the objects being written, outermost first.
    ancestors: Vec<u64>,
    /// Objects written so far.
    objects: usize,
}

impl Translator {
    pub(super) fn new(sampler: Sampler) -> Self {
        let mut layer = Layer::new();
        layer.reserve(MATERIALS);
        let mut t = Translator {
            sampler,
            layer,
            warnings: Vec::new(),
            materials: Vec::new(),
            material_names: HashMap::new(),
            current: String::new(),
            ancestors: Vec::new(),
            objects: 0,
        };
        t.material(DEFAULT_MATERIAL);
        t
    }

    /// The USD path of the (default grey) material standing for face set `name`.
    pub(super) fn material(&mut self, name: &str) -> String {
        if let Some(usd) = self.material_names.get(name) {
            return format!("/{MATERIALS}/{usd}");
        }
        let base = identifier(name);
        let mut usd = base.clone();
        let mut n = 1;
        while self.materials.iter().any(|(_, u)| *u == usd) {
            usd = format!("{base}_{n}");
            n += 1;
        }
        self.materials.push((name.to_string(), usd.clone()));
        self.material_names.insert(name.to_string(), usd.clone());
        format!("/{MATERIALS}/{usd}")
    }

    /// Translates the children of the top object, then writes the materials.
    pub(super) fn run(&mut self) -> Result<(), ObjectError> {
        let top = self.sampler.archive.top().map_err(|e| ("/".to_string(), e))?;
        self.children(&top)?;
        self.write_materials();
        Ok(())
    }

    fn children(&mut self, parent: &Object) -> Result<(), ObjectError> {
        for i in 0..parent.children.len() {
            let header = &parent.children[i];
            if schema(header) == Some("AbcGeom_FaceSet_v1") {
                continue; // written with its mesh
            }
            let child = self.sampler.archive.child(parent, i).map_err(|e| (header.path.clone(), e))?;
            self.objects += 1;
            let problem = if self.ancestors.contains(&child.offset()) {
                Some("the object contains itself (a cycle of Ogawa groups)".to_string())
            } else if self.ancestors.len() >= MAX_DEPTH {
                Some(format!("objects nest deeper than {MAX_DEPTH} levels"))
            } else if self.objects > MAX_OBJECTS {
                Some(format!("the archive has more than {MAX_OBJECTS} objects"))
            } else {
                None
            };
            if let Some(problem) = problem {
                return Err((header.path.clone(), problem));
            }
            self.ancestors.push(child.offset());
            self.object(&child)?;
            self.ancestors.pop();
        }
        Ok(())
    }

    fn object(&mut self, object: &Object) -> Result<(), ObjectError> {
        let path = object.header.path.clone();
        self.current = path.clone();
        let at = |e: String| (path.clone(), e);
        let kind = match schema(&object.header) {
            Some("AbcGeom_Xform_v3") => Kind::Xform,
            Some("AbcGeom_PolyMesh_v1") => Kind::PolyMesh,
            Some("AbcGeom_SubD_v1") => Kind::SubD,
            Some("AbcGeom_Curve_v2") => Kind::Curves,
            Some("AbcGeom_Points_v1") => Kind::Points,
            Some("AbcGeom_Camera_v1") => Kind::Camera,
            None => Kind::Group,
            Some(other) => {
                self.warnings.push((path.clone(), format!("{other} objects are not supported; ignored")));
                Kind::Group
            }
        };
        let properties = match kind {
            Kind::Group => None,
            _ => Some(self.schema_properties(object).map_err(at)?),
        };
        let nurbs = match (&properties, kind) {
            (Some(p), Kind::Curves) => self.curve_kind(p).map_err(at)?[0] == VARIABLE_ORDER,
            _ => false,
        };
        let ty = match kind {
            Kind::Group => "",
            Kind::Xform => "Xform",
            Kind::PolyMesh | Kind::SubD => "Mesh",
            Kind::Curves if nurbs => "NurbsCurves",
            Kind::Curves => "BasisCurves",
            Kind::Points => "Points",
            Kind::Camera => "Camera",
        };
        self.layer.open(ty, &object.header.name, &path, matches!(kind, Kind::PolyMesh | Kind::SubD));
        if let Some(p) = &properties {
            match kind {
                Kind::Group => {}
                Kind::Xform => self.xform(p).map_err(at)?,
                Kind::PolyMesh => self.mesh(object, p, false).map_err(at)?,
                Kind::SubD => self.mesh(object, p, true).map_err(at)?,
                Kind::Curves if nurbs => self.nurbs_curves(p).map_err(at)?,
                Kind::Curves => self.basis_curves(p).map_err(at)?,
                Kind::Points => self.points(p).map_err(at)?,
                Kind::Camera => self.camera(p).map_err(at)?,
            }
        }
        self.visibility(object).map_err(at)?;
        self.children(object)?;
        self.layer.close();
        Ok(())
    }

    /// The schema's compound property (`.geom`, `.xform`, named after the colon of
    /// `schemaObjTitle`).
    fn schema_properties(&mut self, object: &Object) -> Result<Compound, String> {
        let title =
            object.header.metadata.get("schemaObjTitle").and_then(|t| t.split_once(':')).map(|(_, n)| n);
        let candidates = title.into_iter().chain([".geom", ".xform", ".faceset"]);
        for name in candidates {
            if let Some(c) = self.sampler.archive.compound(&object.properties, name)? {
                return Ok(c);
            }
        }
        Err("the schema's property compound is missing".into())
    }

    /// `visible` (int8: −1 deferred, 0 hidden, 1 visible) of the object.
    fn visibility(&mut self, object: &Object) -> Result<(), String> {
        if let Some(v) = self.sampler.held(&object.properties, "visible")? {
            if v.first() == Some(&0.0) {
                self.layer.attr("token visibility", "\"invisible\"", None);
            }
        }
        Ok(())
    }

    fn write_materials(&mut self) {
        self.layer.open_reserved("Scope", MATERIALS, "materials");
        for (name, usd) in self.materials.clone() {
            let alembic =
                if name == DEFAULT_MATERIAL { "default grey".to_string() } else { format!("faceset:{name}") };
            let path = self.layer.open("Material", &usd, &alembic, false);
            self.layer.line(&format!("token outputs:surface.connect = <{path}/Surface.outputs:surface>"));
            self.layer.open("Shader", "Surface", &format!("{alembic}/Surface"), false);
            self.layer.line("uniform token info:id = \"UsdPreviewSurface\"");
            self.layer.line("token outputs:surface");
            self.layer.close();
            self.layer.close();
        }
        self.layer.close();
    }
}

/// The object's `schema` metadata.
pub(super) fn schema(header: &ObjectHeader) -> Option<&str> {
    header.metadata.get("schema").map(String::as_str)
}

/// Checks that every value is finite (the text layer has no spelling for NaN).
pub(super) fn finite(name: &str, values: &[f64]) -> Result<(), String> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(format!("{name}[{i}] is not a finite number")),
        None => Ok(()),
    }
}

/// Integer values (Alembic indices and counts are stored as integers; the decode widened them).
pub(super) fn as_ints(values: &[f64]) -> Vec<i64> {
    values.iter().map(|&v| v as i64).collect()
}
