//! MaterialX documents (`.mtlx`) as USD layers, laid out the way usdMtlx (OpenUSD's MaterialX file
//! format plugin) lays them out, so that a look layer's
//! `references = @Pawn_mat.mtlx@</MaterialX/Materials>` composes the materials the document
//! defines and the reader finds ordinary UsdShade networks whose shaders carry `info:id = "ND_…"`
//! ([`super::mtlx_network`] compiles those, inline or translated alike).
//!
//! The resolver ([`super::resolver`]) hands `.mtlx` files to the stage through this module: the
//! XML (parsed with `roxmltree`) becomes USDA text, which the crate then parses like any layer.
//! Going through USD keeps one reader for both ways a studio publishes a look.
//!
//! Layout (the prim paths usdMtlx produces, which looks reference):
//!
//! ```text
//! /MaterialX                      the default prim
//!   /Materials
//!     /<surfacematerial>          def Material, outputs:mtlx:surface (and :displacement, :volume)
//!       /<shader node>            def Shader, info:id = ND_<category>_<type>, outputs:out
//!       /<nodegraph>              def NodeGraph: interface inputs, outputs, its nodes as Shaders
//!       /<top-level node>         nodes outside any nodegraph the shader reads, as Shaders
//! ```
//!
//! usdMtlx also writes `/MaterialX/NodeGraphs` and references each material's graphs from there;
//! this translation writes the graph beneath each material that reads it instead, which composes
//! to the same `/MaterialX/Materials/<name>` subtrees without an internal reference.
//!
//! What is resolved here, so the layer is self-contained:
//! - **nodedefs**: a node's `info:id` is its `nodedef` attribute, else a `<nodedef>` of the
//!   document for its category and type, else the standard library's name for its signature:
//!   `ND_<category>_<type>`, with the library's exceptions (`convert`, `swizzle`: input and output
//!   types; `extract`, `separateN`: the input type; `FA` for a float second operand of a
//!   vector/colour `add`/`subtract`/`multiply`/`divide`/`modulo`/`power`/`min`/`max`/`clamp`;
//!   `mix` with a vector mix amount; `normalmap` by version (`ND_normalmap` before 1.39,
//!   `ND_normalmap_float` from 1.39); shaders `ND_<category>_surfaceshader`).
//! - **`fileprefix`** and **`colorspace`**: inherited from the nearest element that sets them
//!   (input, node, nodegraph, document); a `filename` input's value is prefixed and carries its
//!   colour space as `colorSpace` metadata, as usdMtlx writes it. File paths stay relative, so
//!   they resolve against the `.mtlx` file's folder, like any layer's asset paths.
//! - **connections**: `nodename` (with `output` for multi-output nodes), `nodegraph` + `output`,
//!   `interfacename` inside a graph, and a top-level `<output>` an input names by `output` alone.
//! - **geomprop defaults**: an image's unconnected `texcoord` stays unauthored: the standard
//!   library's default, `UV0`, is what the reader gives an unauthored `texcoord`.
//!
//! Elements the renderer has no use for (`look`, `materialassign`, `typedef`, `implementation`,
//! nodegraphs implementing a nodedef, nodes no material reads) are not translated.

use std::collections::{HashMap, HashSet};
use std::fmt::Write as _;

use roxmltree::{Document, Node};

/// Whether `path` names a MaterialX document (by extension, `.mtlx` in any case).
pub(crate) fn is_mtlx(path: &std::path::Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("mtlx"))
}

/// The USDA text of the MaterialX document `text` (read from `file`, named in errors), or what
/// is wrong with it as `file: line L, column C: problem`.
pub(crate) fn translate(text: &str, file: &str) -> Result<String, String> {
    let doc = Document::parse(text).map_err(|e| format!("{file}: {e}"))?;
    let root = doc.root_element();
    if root.tag_name().name() != "materialx" {
        return Err(format!(
            "{file}: {}: the root element is <{}>, not <materialx>",
            position(&doc, root),
            root.tag_name().name()
        ));
    }
    let context = Context::new(&doc, file);
    let mut out = String::new();
    let version = root.attribute("version").unwrap_or("");
    let _ = write!(
        out,
        "#usda 1.0\n(\n    defaultPrim = \"MaterialX\"\n    doc = \"{}\"\n)\n\ndef \"MaterialX\"\n{{\n    def \"Materials\"\n    {{\n",
        escape(&format!("MaterialX {version} document {file}, translated by ingest"))
    );
    let mut written = HashSet::new();
    for material in root.children().filter(|n| n.is_element() && is_material(n)) {
        let name = prim_name(material.attribute("name").unwrap_or(""));
        if !written.insert(name.clone()) {
            return Err(context.at(material, format!("two materials are named {name:?}")));
        }
        context.material(material, &name, &mut out)?;
    }
    out.push_str("    }\n}\n");
    Ok(out)
}

/// A `surfacematerial` (or any node whose type is `material`).
fn is_material(node: &Node) -> bool {
    node.attribute("type") == Some("material") || node.tag_name().name() == "surfacematerial"
}

/// Elements that are not nodes.
const NOT_NODES: &[&str] = &[
    "nodegraph",
    "nodedef",
    "output",
    "input",
    "look",
    "lookgroup",
    "materialassign",
    "variant",
    "variantset",
    "variantassign",
    "collection",
    "geominfo",
    "geompropdef",
    "typedef",
    "implementation",
    "propertyset",
    "propertysetassign",
    "visibility",
    "token",
    "unitdef",
    "unittypedef",
    "member",
    "attributedef",
    "targetdef",
    "backdrop",
];

fn is_node(node: &Node) -> bool {
    node.is_element() && !NOT_NODES.contains(&node.tag_name().name())
}

/// `line L, column C` of an element.
fn position(doc: &Document, node: Node) -> String {
    let p = doc.text_pos_at(node.range().start);
    format!("line {}, column {}", p.row, p.col)
}

/// A USD identifier for a MaterialX name (they share the alphabet; anything else becomes `_`).
fn prim_name(name: &str) -> String {
    let mut out: String =
        name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '_' }).collect();
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert(0, '_');
    }
    out
}

fn escape(s: &str) -> String {
    s.replace('\\', "\\\\").replace('"', "\\\"").replace('\n', "\\n")
}

/// The nearest value of `attr` on `node` or an ancestor (MaterialX's inheritance of `colorspace`
/// and `fileprefix`).
fn inherited<'a>(node: Node<'a, 'a>, attr: &str) -> &'a str {
    node.ancestors().find_map(|n| n.attribute(attr)).unwrap_or("")
}

/// The USD type of a MaterialX type, or `None` for types USD has no attribute for.
fn usd_type(mtlx: &str) -> Option<&'static str> {
    Some(match mtlx {
        "float" => "float",
        "integer" => "int",
        "boolean" => "bool",
        "color3" => "color3f",
        "color4" => "color4f",
        "vector2" => "float2",
        "vector3" => "float3",
        "vector4" => "float4",
        "matrix33" => "matrix3d",
        "matrix44" => "matrix4d",
        "string" => "string",
        "filename" => "asset",
        "floatarray" => "float[]",
        "integerarray" => "int[]",
        "surfaceshader" | "displacementshader" | "volumeshader" | "lightshader" | "material" => "token",
        _ => return None,
    })
}

/// Numbers of a MaterialX value (`"0.8, 0.8, 0.8"`, `"0.5 0.5"`).
fn numbers(value: &str) -> Option<Vec<f64>> {
    value
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().ok())
        .collect()
}

/// A USDA literal of `value` as `mtlx_type`, or `None` when the text does not fit the type.
fn literal(mtlx_type: &str, value: &str) -> Option<String> {
    let list = |v: &[f64]| v.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(", ");
    let tuple = |n: usize| numbers(value).filter(|v| v.len() == n).map(|v| format!("({})", list(&v)));
    match mtlx_type {
        "float" => numbers(value).filter(|v| v.len() == 1).map(|v| format!("{}", v[0])),
        "integer" => value.trim().parse::<i64>().ok().map(|v| v.to_string()),
        "boolean" => match value.trim() {
            "true" | "1" => Some("1".into()),
            "false" | "0" => Some("0".into()),
            _ => None,
        },
        "color3" | "vector3" => tuple(3),
        "color4" | "vector4" => tuple(4),
        "vector2" => tuple(2),
        "matrix33" | "matrix44" => {
            let n = if mtlx_type == "matrix33" { 3 } else { 4 };
            let v = numbers(value).filter(|v| v.len() == n * n)?;
            let rows: Vec<String> = v.chunks(n).map(|r| format!("({})", list(r))).collect();
            Some(format!("({})", rows.join(", ")))
        }
        "floatarray" | "integerarray" => numbers(value).map(|v| format!("[{}]", list(&v))),
        "string" | "surfaceshader" | "displacementshader" | "volumeshader" | "lightshader" | "material" => {
            Some(format!("\"{}\"", escape(value)))
        }
        _ => None,
    }
}

/// Categories whose vector/colour variants take a float second operand as `…FA`.
const FA_CATEGORIES: &[&str] = &["add", "subtract", "multiply", "divide", "modulo", "power", "min", "max"];

/// The document's facts every element needs.
struct Context<'a> {
    doc: &'a Document<'a>,
    file: &'a str,
    /// Top-level nodes, nodegraphs and outputs by name.
    nodes: HashMap<&'a str, Node<'a, 'a>>,
    graphs: HashMap<&'a str, Node<'a, 'a>>,
    outputs: HashMap<&'a str, Node<'a, 'a>>,
    /// The document's own nodedefs: `(node category, output type)` → nodedef name.
    nodedefs: HashMap<(&'a str, &'a str), &'a str>,
    /// `ND_normalmap` (1.38) or `ND_normalmap_float` (1.39 on).
    normalmap_1_39: bool,
}

/// Where a node is written: the prim path of its scope and, inside a graph, the graph's path.
#[derive(Clone, Copy)]
struct Scope<'s> {
    /// The material's path (top-level elements are written beneath it).
    material: &'s str,
    /// The graph's path when the node is inside a nodegraph.
    graph: Option<&'s str>,
}

impl<'a> Context<'a> {
    fn new(doc: &'a Document<'a>, file: &'a str) -> Self {
        let root = doc.root_element();
        let mut context = Context {
            doc,
            file,
            nodes: HashMap::new(),
            graphs: HashMap::new(),
            outputs: HashMap::new(),
            nodedefs: HashMap::new(),
            normalmap_1_39: false,
        };
        for child in root.children().filter(Node::is_element) {
            let name = child.attribute("name").unwrap_or("");
            match child.tag_name().name() {
                "nodegraph" => {
                    context.graphs.insert(name, child);
                }
                "output" => {
                    context.outputs.insert(name, child);
                }
                "nodedef" => {
                    if let Some(category) = child.attribute("node") {
                        let ty = child.attribute("type").or_else(|| {
                            child
                                .children()
                                .find(|c| c.tag_name().name() == "output")
                                .and_then(|o| o.attribute("type"))
                        });
                        context.nodedefs.insert((category, ty.unwrap_or("")), name);
                    }
                }
                _ if is_node(&child) => {
                    context.nodes.insert(name, child);
                }
                _ => {}
            }
        }
        let version = root.attribute("version").unwrap_or("1.38");
        let mut parts = version.split('.').map(|p| p.parse::<u32>().unwrap_or(0));
        let (major, minor) = (parts.next().unwrap_or(1), parts.next().unwrap_or(38));
        context.normalmap_1_39 = (major, minor) >= (1, 39);
        context
    }

    fn at(&self, node: Node, problem: String) -> String {
        format!("{}: {}: {problem}", self.file, position(self.doc, node))
    }

    /// One `surfacematerial` as `def Material` with the shaders, graphs and top-level nodes it reads.
    fn material(&self, material: Node<'a, 'a>, name: &str, out: &mut String) -> Result<(), String> {
        let path = format!("/MaterialX/Materials/{name}");
        let _ = writeln!(out, "        def Material \"{name}\"\n        {{");
        // Top-level elements the material reaches, breadth first, each written once.
        let mut queue: Vec<Node<'a, 'a>> = Vec::new();
        for input in material.children().filter(|c| c.tag_name().name() == "input") {
            let Some(shader) = self.upstream_top_level(input)? else { continue };
            let terminal = match input.attribute("name").unwrap_or("") {
                "surfaceshader" => "surface",
                "displacementshader" => "displacement",
                "volumeshader" => "volume",
                _ => continue,
            };
            let shader_name = prim_name(shader.attribute("name").unwrap_or(""));
            let _ = writeln!(
                out,
                "            token outputs:mtlx:{terminal}.connect = <{path}/{shader_name}.outputs:out>"
            );
            queue.push(shader);
        }
        let mut seen: HashSet<&str> = queue.iter().filter_map(|n| n.attribute("name")).collect();
        let mut i = 0;
        while i < queue.len() {
            let element = queue[i];
            i += 1;
            // A graph's nodes read only inside it; a top-level node may read other top-level ones.
            if element.tag_name().name() == "nodegraph" {
                continue;
            }
            for input in element.children().filter(|c| c.tag_name().name() == "input") {
                if let Some(next) = self.upstream_top_level(input)? {
                    if seen.insert(next.attribute("name").unwrap_or("")) {
                        queue.push(next);
                    }
                }
            }
        }
        let scope = Scope { material: &path, graph: None };
        for element in queue {
            if element.tag_name().name() == "nodegraph" {
                self.graph(element, &path, out)?;
            } else {
                self.node(element, scope, 3, out)?;
            }
        }
        out.push_str("        }\n\n");
        Ok(())
    }

    /// The top-level node or nodegraph an input (of a material, or of a top-level node) reads.
    fn upstream_top_level(&self, input: Node<'a, 'a>) -> Result<Option<Node<'a, 'a>>, String> {
        if let Some(graph) = input.attribute("nodegraph") {
            return match self.graphs.get(graph) {
                Some(g) => Ok(Some(*g)),
                None => {
                    Err(self
                        .at(input, format!("input reads nodegraph {graph:?}, which is not in the document")))
                }
            };
        }
        let nodename = match (input.attribute("nodename"), input.attribute("output")) {
            (Some(n), _) => n,
            // A top-level <output> named by `output` alone.
            (None, Some(o)) => match self.outputs.get(o).and_then(|out| out.attribute("nodename")) {
                Some(n) => n,
                None => return Ok(None),
            },
            (None, None) => return Ok(None),
        };
        // Inside a graph, `nodename` names a sibling; only top-level inputs reach here.
        match self.nodes.get(nodename) {
            Some(n) => Ok(Some(*n)),
            None => {
                Err(self.at(input, format!("input reads node {nodename:?}, which is not in the document")))
            }
        }
    }

    /// A nodegraph beneath the material at `material`: interface inputs, outputs, its nodes.
    fn graph(&self, graph: Node<'a, 'a>, material: &str, out: &mut String) -> Result<(), String> {
        let name = prim_name(graph.attribute("name").unwrap_or(""));
        let path = format!("{material}/{name}");
        let _ = writeln!(out, "            def NodeGraph \"{name}\"\n            {{");
        for child in graph.children().filter(Node::is_element) {
            match child.tag_name().name() {
                "input" => self.input(child, Scope { material, graph: Some(&path) }, 4, out)?,
                "output" => {
                    let ty = child.attribute("type").unwrap_or("");
                    let Some(usd) = usd_type(ty) else {
                        return Err(self.at(child, format!("output type {ty:?} has no USD type")));
                    };
                    let output_name = prim_name(child.attribute("name").unwrap_or(""));
                    match (child.attribute("nodename"), child.attribute("interfacename")) {
                        (Some(node), _) => {
                            let port = prim_name(child.attribute("output").unwrap_or("out"));
                            let _ = writeln!(
                                out,
                                "                {usd} outputs:{output_name}.connect = <{path}/{}.outputs:{port}>",
                                prim_name(node)
                            );
                        }
                        (None, Some(interface)) => {
                            let _ = writeln!(
                                out,
                                "                {usd} outputs:{output_name}.connect = <{path}.inputs:{}>",
                                prim_name(interface)
                            );
                        }
                        (None, None) => {
                            let _ = writeln!(out, "                {usd} outputs:{output_name}");
                        }
                    }
                }
                _ => {}
            }
        }
        let scope = Scope { material, graph: Some(&path) };
        for node in graph.children().filter(is_node) {
            self.node(node, scope, 4, out)?;
        }
        out.push_str("            }\n");
        Ok(())
    }

    /// One node as `def Shader` at `depth` levels of indentation.
    fn node(&self, node: Node<'a, 'a>, scope: Scope, depth: usize, out: &mut String) -> Result<(), String> {
        let pad = "    ".repeat(depth);
        let name = prim_name(node.attribute("name").unwrap_or(""));
        let id = self.nodedef(node);
        let _ =
            writeln!(out, "{pad}def Shader \"{name}\"\n{pad}{{\n{pad}    uniform token info:id = \"{id}\"");
        for input in node.children().filter(|c| c.tag_name().name() == "input") {
            self.input(input, scope, depth + 1, out)?;
        }
        let ty = node.attribute("type").unwrap_or("");
        let declared: Vec<Node> = node.children().filter(|c| c.tag_name().name() == "output").collect();
        if declared.is_empty() {
            let usd = usd_type(ty).unwrap_or("token");
            let _ = writeln!(out, "{pad}    {usd} outputs:out");
        }
        for output in declared {
            let usd = usd_type(output.attribute("type").unwrap_or(ty)).unwrap_or("token");
            let _ = writeln!(
                out,
                "{pad}    {usd} outputs:{}",
                prim_name(output.attribute("name").unwrap_or("out"))
            );
        }
        let _ = writeln!(out, "{pad}}}");
        Ok(())
    }

    /// One input of a node or a graph's interface: a value, or a connection.
    fn input(&self, input: Node<'a, 'a>, scope: Scope, depth: usize, out: &mut String) -> Result<(), String> {
        let pad = "    ".repeat(depth);
        let name = prim_name(input.attribute("name").unwrap_or(""));
        let ty = input.attribute("type").unwrap_or("");
        let Some(usd) = usd_type(ty) else {
            return Err(
                self.at(input, format!("input {name:?} has type {ty:?}, which USD has no attribute for"))
            );
        };
        let port = |o: Option<&str>| prim_name(o.unwrap_or("out"));
        let target = if let Some(interface) = input.attribute("interfacename") {
            match scope.graph {
                Some(graph) => Some(format!("{graph}.inputs:{}", prim_name(interface))),
                None => {
                    return Err(self.at(input, format!("interfacename {interface:?} outside a nodegraph")))
                }
            }
        } else if let Some(graph) = input.attribute("nodegraph") {
            Some(format!(
                "{}/{}.outputs:{}",
                scope.material,
                prim_name(graph),
                port(input.attribute("output"))
            ))
        } else if let Some(node) = input.attribute("nodename") {
            let base = scope.graph.unwrap_or(scope.material);
            Some(format!("{base}/{}.outputs:{}", prim_name(node), port(input.attribute("output"))))
        } else if let Some(output) = input.attribute("output") {
            // A top-level output: the node it names.
            let named = self
                .outputs
                .get(output)
                .and_then(|o| o.attribute("nodename").map(|n| (n, o.attribute("output"))));
            named.map(|(node, o)| format!("{}/{}.outputs:{}", scope.material, prim_name(node), port(o)))
        } else {
            None
        };
        if let Some(target) = target {
            let _ = writeln!(out, "{pad}{usd} inputs:{name}.connect = <{target}>");
            return Ok(());
        }
        let Some(value) = input.attribute("value") else {
            let _ = writeln!(out, "{pad}{usd} inputs:{name}");
            return Ok(());
        };
        if ty == "filename" {
            let file = format!("{}{value}", inherited(input, "fileprefix"));
            if file.contains('@') {
                return Err(self.at(input, format!("file name {file:?} contains '@'")));
            }
            let colorspace = inherited(input, "colorspace");
            let metadata = if colorspace.is_empty() {
                String::new()
            } else {
                format!(" (\n{pad}    colorSpace = \"{}\"\n{pad})", escape(colorspace))
            };
            let _ = writeln!(out, "{pad}{usd} inputs:{name} = @{file}@{metadata}");
            return Ok(());
        }
        match literal(ty, value) {
            Some(v) => {
                let _ = writeln!(out, "{pad}{usd} inputs:{name} = {v}");
                Ok(())
            }
            None => Err(self.at(input, format!("input {name:?}: value {value:?} is not a {ty}"))),
        }
    }

    /// The nodedef name (`info:id`) of a node: its `nodedef`, else the document's nodedef for its
    /// category and type, else the standard library's name for its signature.
    fn nodedef(&self, node: Node) -> String {
        if let Some(explicit) = node.attribute("nodedef") {
            return explicit.to_string();
        }
        let category = node.tag_name().name();
        let ty = node.attribute("type").unwrap_or("");
        if let Some(name) = self.nodedefs.get(&(category, ty)) {
            return name.to_string();
        }
        let input_type = |name: &str| {
            node.children()
                .find(|c| c.tag_name().name() == "input" && c.attribute("name") == Some(name))
                .and_then(|c| c.attribute("type"))
        };
        let scalar = matches!(ty, "float" | "integer");
        match category {
            "surfacematerial" => "ND_surfacematerial".into(),
            _ if ty.ends_with("shader") => format!("ND_{category}_{ty}"),
            "convert" | "swizzle" => format!("ND_{category}_{}_{ty}", input_type("in").unwrap_or("float")),
            "extract" => format!("ND_extract_{}", input_type("in").unwrap_or("vector3")),
            c if c.starts_with("separate") => format!("ND_{c}_{}", input_type("in").unwrap_or(ty)),
            "normalmap" if self.normalmap_1_39 => {
                format!("ND_normalmap_{}", input_type("scale").unwrap_or("float"))
            }
            "normalmap" => "ND_normalmap".into(),
            c if FA_CATEGORIES.contains(&c) && !scalar && input_type("in2") == Some("float") => {
                format!("ND_{c}_{ty}FA")
            }
            "clamp"
                if !scalar && (input_type("low") == Some("float") || input_type("high") == Some("float")) =>
            {
                format!("ND_clamp_{ty}FA")
            }
            "mix" if !scalar && input_type("mix").is_some_and(|t| t != "float") => {
                format!("ND_mix_{ty}_{ty}")
            }
            _ => format!("ND_{category}_{ty}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::translate;

    const PAWN: &str = r#"<?xml version="1.0"?>
<materialx version="1.38" colorspace="lin_rec709" fileprefix="tex/">
  <nodegraph name="NG_Body">
    <image name="diffuse" type="color3">
      <input name="file" type="filename" value="white.jpg" colorspace="srgb_texture" />
    </image>
    <image name="rough" type="float">
      <input name="file" type="filename" value="rough.jpg" />
    </image>
    <normalmap name="nmap" type="vector3">
      <input name="in" type="vector3" nodename="nimage" />
    </normalmap>
    <image name="nimage" type="vector3" fileprefix="maps/">
      <input name="file" type="filename" value="n.jpg" />
    </image>
    <output name="base_color_output" type="color3" nodename="diffuse" />
    <output name="roughness_output" type="float" nodename="rough" />
    <output name="normal_output" type="vector3" nodename="nmap" />
  </nodegraph>
  <multiply name="tint" type="color3">
    <input name="in1" type="color3" nodegraph="NG_Body" output="base_color_output" />
    <input name="in2" type="float" value="0.5" />
  </multiply>
  <standard_surface name="Body" type="surfaceshader">
    <input name="base_color" type="color3" nodename="tint" />
    <input name="specular_roughness" type="float" nodegraph="NG_Body" output="roughness_output" />
    <input name="normal" type="vector3" nodegraph="NG_Body" output="normal_output" />
    <input name="coat" type="float" value="0.25" />
  </standard_surface>
  <surfacematerial name="M_Body" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="Body" />
  </surfacematerial>
</materialx>
"#;

    #[test]
    fn a_document_becomes_the_usdmtlx_prim_layout() {
        let usda = translate(PAWN, "pawn.mtlx").unwrap_or_else(|e| panic!("{e}"));
        let has = |line: &str| assert!(usda.contains(line), "missing {line:?} in\n{usda}");
        has("defaultPrim = \"MaterialX\"");
        has("def Material \"M_Body\"");
        has("token outputs:mtlx:surface.connect = </MaterialX/Materials/M_Body/Body.outputs:out>");
        has("uniform token info:id = \"ND_standard_surface_surfaceshader\"");
        has("color3f inputs:base_color.connect = </MaterialX/Materials/M_Body/tint.outputs:out>");
        has("float inputs:coat = 0.25");
        has("float inputs:specular_roughness.connect = </MaterialX/Materials/M_Body/NG_Body.outputs:roughness_output>");
        // The top-level multiply reads the graph; its float second operand makes it the FA variant.
        has("uniform token info:id = \"ND_multiply_color3FA\"");
        has("color3f inputs:in1.connect = </MaterialX/Materials/M_Body/NG_Body.outputs:base_color_output>");
        has("def NodeGraph \"NG_Body\"");
        has("float3 outputs:normal_output.connect = </MaterialX/Materials/M_Body/NG_Body/nmap.outputs:out>");
        has("uniform token info:id = \"ND_image_color3\"");
        has("uniform token info:id = \"ND_normalmap\"");
        has("float3 inputs:in.connect = </MaterialX/Materials/M_Body/NG_Body/nimage.outputs:out>");
        // fileprefix and colorspace: the nearest element's, the input's own colour space first.
        has("asset inputs:file = @tex/white.jpg@ (\n                        colorSpace = \"srgb_texture\"");
        has("asset inputs:file = @tex/rough.jpg@ (\n                        colorSpace = \"lin_rec709\"");
        has("asset inputs:file = @maps/n.jpg@");
    }

    #[test]
    fn problems_name_the_file_and_line() {
        let err =
            translate("<materialx><image name=\"a\" type=\"color3\"></materialx>", "bad.mtlx").unwrap_err();
        assert!(err.starts_with("bad.mtlx: ") && err.contains("1:"), "{err}");
        let err = translate("<?xml version=\"1.0\"?>\n<mtlx/>\n", "x.mtlx").unwrap_err();
        assert_eq!(err, "x.mtlx: line 2, column 1: the root element is <mtlx>, not <materialx>");
        let bad_value = "<materialx>\n<standard_surface name=\"S\" type=\"surfaceshader\">\n  <input name=\"base\" type=\"float\" value=\"one\"/>\n</standard_surface>\n<surfacematerial name=\"M\" type=\"material\"><input name=\"surfaceshader\" type=\"surfaceshader\" nodename=\"S\"/></surfacematerial>\n</materialx>";
        assert_eq!(
            translate(bad_value, "v.mtlx").unwrap_err(),
            "v.mtlx: line 3, column 3: input \"base\": value \"one\" is not a float"
        );
        let dangling = "<materialx><surfacematerial name=\"M\" type=\"material\"><input name=\"surfaceshader\" type=\"surfaceshader\" nodename=\"Gone\"/></surfacematerial></materialx>";
        assert_eq!(
            translate(dangling, "d.mtlx").unwrap_err(),
            "d.mtlx: line 1, column 54: input reads node \"Gone\", which is not in the document"
        );
    }

    #[test]
    fn nodedef_names_follow_the_standard_library() {
        let doc = r#"<materialx version="1.39">
  <nodedef name="ND_custom_thing" node="thing" type="color3"><output name="out" type="color3"/></nodedef>
  <nodegraph name="G">
    <convert name="c" type="color3"><input name="in" type="vector3" value="1, 2, 3"/></convert>
    <extract name="e" type="float"><input name="in" type="color4" value="1, 2, 3, 4"/><input name="index" type="integer" value="3"/></extract>
    <mix name="m" type="color3"><input name="mix" type="color3" value="0.5, 0.5, 0.5"/></mix>
    <mix name="m2" type="color3"><input name="mix" type="float" value="0.5"/></mix>
    <clamp name="cl" type="color3"><input name="low" type="float" value="0"/></clamp>
    <normalmap name="n" type="vector3"/>
    <thing name="t" type="color3"/>
    <image name="i" type="color3" nodedef="ND_image_color3_custom"/>
    <output name="o" type="color3" nodename="c"/>
  </nodegraph>
  <open_pbr_surface name="S" type="surfaceshader"><input name="base_color" type="color3" nodegraph="G" output="o"/></open_pbr_surface>
  <surfacematerial name="M" type="material"><input name="surfaceshader" type="surfaceshader" nodename="S"/></surfacematerial>
</materialx>"#;
        let usda = translate(doc, "n.mtlx").unwrap_or_else(|e| panic!("{e}"));
        for id in [
            "ND_convert_vector3_color3",
            "ND_extract_color4",
            "ND_mix_color3_color3",
            "ND_mix_color3\"",
            "ND_clamp_color3FA",
            "ND_normalmap_float",
            "ND_custom_thing",
            "ND_image_color3_custom",
            "ND_open_pbr_surface_surfaceshader",
        ] {
            assert!(usda.contains(&format!("info:id = \"{id}")), "{id} missing in\n{usda}");
        }
    }
}
