//! Writes the USD layer an archive is translated into, and remembers which Alembic object each
//! prim came from.
//!
//! Alembic names are any string; USD prim names are identifiers, so names are sanitized
//! (`Cube.001` → `Cube_001`) and made unique among siblings. [`PathMap::restore`] maps the USD
//! paths the scene reports back to the Alembic paths.

use std::fmt::Write as _;

/// USD paths of the generated layer and the Alembic paths they stand for.
#[derive(Clone, Debug, Default)]
pub(super) struct PathMap {
    /// `(usd, alembic)` pairs.
    pairs: Vec<(String, String)>,
}

impl PathMap {
    /// The Alembic path for a USD path (a prim path, or a path with a `.suffix` such as the
    /// reader's `<gprim>.displayColor` materials): the longest mapped prefix is replaced.
    pub(super) fn restore(&self, usd: &str) -> String {
        let best = self
            .pairs
            .iter()
            .filter(|(u, _)| {
                usd.strip_prefix(u.as_str())
                    .is_some_and(|rest| rest.is_empty() || rest.starts_with(['/', '.']))
            })
            .max_by_key(|(u, _)| u.len());
        match best {
            Some((u, a)) => format!("{a}{}", &usd[u.len()..]),
            None => usd.to_string(),
        }
    }
}

/// A USD identifier for an Alembic name.
pub(super) fn identifier(name: &str) -> String {
    let mut out: String =
        name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '_' }).collect();
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert(0, '_');
    }
    out
}

/// The layer being written: nested `def` blocks.
pub(super) struct Layer {
    text: String,
    /// Open prims: USD path and the child names used so far.
    stack: Vec<(String, Vec<String>)>,
    pub(super) paths: PathMap,
}

impl Layer {
    /// A Y-up layer in meters (Alembic's convention; Blender writes meters).
    pub(super) fn new() -> Self {
        Layer {
            text: "#usda 1.0\n(\n    metersPerUnit = 1\n    upAxis = \"Y\"\n)\n".into(),
            stack: vec![(String::new(), Vec::new())],
            paths: PathMap::default(),
        }
    }

    fn indent(&mut self) {
        for _ in 1..self.stack.len() {
            self.text.push_str("    ");
        }
    }

    /// Opens `def TYPE "name"` for the Alembic object at `alembic_path` (an empty type for an
    /// untyped prim) and returns its USD path.
    pub(super) fn open(&mut self, ty: &str, name: &str, alembic_path: &str, binds_material: bool) -> String {
        let (parent, used) = self.stack.last_mut().expect("root entry");
        let base = identifier(name);
        let mut unique = base.clone();
        let mut n = 1;
        while used.contains(&unique) {
            unique = format!("{base}_{n}");
            n += 1;
        }
        used.push(unique.clone());
        let path = format!("{parent}/{unique}");
        self.indent();
        let ty = if ty.is_empty() { String::new() } else { format!("{ty} ") };
        let api = if binds_material { " (prepend apiSchemas = [\"MaterialBindingAPI\"])" } else { "" };
        let _ = writeln!(self.text, "def {ty}\"{unique}\"{api}");
        self.indent();
        self.text.push_str("{\n");
        self.stack.push((path.clone(), Vec::new()));
        self.paths.pairs.push((path.clone(), alembic_path.to_string()));
        path
    }

    /// Keeps `name` free at the root for [`Layer::open_reserved`].
    pub(super) fn reserve(&mut self, name: &str) {
        self.stack[0].1.push(name.to_string());
    }

    /// Opens a root prim under a name kept by [`Layer::reserve`].
    pub(super) fn open_reserved(&mut self, ty: &str, name: &str, alembic_path: &str) {
        let path = format!("/{name}");
        let _ = writeln!(self.text, "def {ty} \"{name}\"\n{{");
        self.stack.push((path.clone(), Vec::new()));
        self.paths.pairs.push((path, alembic_path.to_string()));
    }

    /// Closes the innermost prim.
    pub(super) fn close(&mut self) {
        self.stack.pop();
        self.indent();
        self.text.push_str("}\n");
    }

    /// One attribute line: `decl = value (metadata)`.
    pub(super) fn attr(&mut self, decl: &str, value: &str, metadata: Option<&str>) {
        self.indent();
        let _ = match metadata {
            Some(m) => writeln!(self.text, "{decl} = {value} ({m})"),
            None => writeln!(self.text, "{decl} = {value}"),
        };
    }

    /// A raw line (relationships).
    pub(super) fn line(&mut self, line: &str) {
        self.indent();
        self.text.push_str(line);
        self.text.push('\n');
    }

    /// The finished layer.
    pub(super) fn finish(self) -> (String, PathMap) {
        (self.text, self.paths)
    }
}

/// `[a, b, c]` of integers.
pub(super) fn ints(values: &[i64]) -> String {
    list(values.iter().map(|v| v.to_string()))
}

/// `[a, b, c]` of single-precision numbers (shortest text that reads back to the same `f32`).
pub(super) fn floats(values: &[f64]) -> String {
    list(values.iter().map(|&v| (v as f32).to_string()))
}

/// `[(x, y, z), ...]` (or pairs for `n = 2`) of single-precision tuples.
pub(super) fn tuples(values: &[f64], n: usize) -> String {
    list(values.chunks_exact(n).map(|c| {
        let parts: Vec<String> = c.iter().map(|&v| (v as f32).to_string()).collect();
        format!("({})", parts.join(", "))
    }))
}

/// `((r0), (r1), (r2), (r3))` of a row-major matrix in double precision.
pub(super) fn matrix(rows: &[[f64; 4]; 4]) -> String {
    let rows: Vec<String> = rows
        .iter()
        .map(|r| format!("({})", r.iter().map(|v| format!("{v:?}")).collect::<Vec<_>>().join(", ")))
        .collect();
    format!("({})", rows.join(", "))
}

fn list(items: impl Iterator<Item = String>) -> String {
    let items: Vec<String> = items.collect();
    format!("[{}]", items.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_become_unique_identifiers_and_map_back() {
        let mut layer = Layer::new();
        let a = layer.open("Xform", "Cube.001", "/Cube.001", false);
        let b = layer.open("Mesh", "1st shape", "/Cube.001/1st shape", false);
        layer.close();
        let c = layer.open("Mesh", "1st:shape", "/Cube.001/1st:shape", false);
        layer.close();
        layer.close();
        assert_eq!(
            (a.as_str(), b.as_str(), c.as_str()),
            ("/Cube_001", "/Cube_001/_1st_shape", "/Cube_001/_1st_shape_1")
        );
        let (text, paths) = layer.finish();
        assert!(text.contains("def Mesh \"_1st_shape_1\""), "{text}");
        assert_eq!(paths.restore("/Cube_001/_1st_shape_1"), "/Cube.001/1st:shape");
        assert_eq!(paths.restore("/Cube_001/_1st_shape.displayColor"), "/Cube.001/1st shape.displayColor");
        assert_eq!(paths.restore("/Cube_001x"), "/Cube_001x");
    }

    #[test]
    fn numbers_round_trip_as_text() {
        let v = [0.1f32 as f64, 1e-7f32 as f64, 3.0e7f32 as f64];
        let text = floats(&v);
        let back: Vec<f32> = text.trim_matches(['[', ']']).split(", ").map(|s| s.parse().unwrap()).collect();
        assert_eq!(back, [0.1f32, 1e-7, 3.0e7]);
        assert_eq!(tuples(&[1.0, 2.0, 3.0, 4.0], 2), "[(1, 2), (3, 4)]");
    }
}
