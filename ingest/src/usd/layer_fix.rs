//! Token-level fixes for `.usda` text that usd-core reads but the `openusd` 0.6 parser rejects.
//!
//! The resolver ([`super::resolver`]) passes every text layer through [`normalize`] before the
//! crate parses it. The rewrite works on tokens of the USDA grammar, so the inside of strings,
//! asset paths (`@...@`), path references (`<...>`) and comments is never touched, and it never
//! adds or removes a line break, so line numbers in the crate's errors still point into the file
//! as authored.
//!
//! | authored                                  | rewritten                  | why |
//! |-------------------------------------------|----------------------------|-----|
//! | `.5`, `-.5`, `5.`, `1.e3`                 | `0.5`, `-0.5`, `5.0`, `1.0e3` | the crate's number token needs a digit on both sides of `.` |
//! | `Vec3f x`, `PointFloat[] p`, `PointIndex[] i` | `float3 x`, `point3f[] p`, `int[] i` | Sdf's legacy type-name aliases, which the crate does not know |
//! | `asset a = "x.png"`                       | `asset a = @x.png@`        | usd-core accepts a string where an asset path is expected |
//! | `asset a.timeSamples = { 1: @x.png@ }`    | `{ 1: "x.png" }`           | the crate reads scalar time samples type-blind and rejects `@...@` there; the string reads back as the same authored path |
//! | `append inactiveIds = [3]` (prim metadata) | `inactiveIds__append = [3]` | the crate rejects list ops on prim metadata it does not know; [`list_op_field`] names the field the stage reads back |
//!
//! A construct the crate still rejects after this pass is reported with its file, line and
//! column by [`parse_error_location`].

use std::borrow::Cow;
use std::ops::Range;

/// Legacy Sdf value type names and the modern name of the same value type, from usd-core's
/// `Sdf.ValueTypeNames` (each entry's `aliasesAsStrings`). `PointIndex`, `EdgeIndex` and
/// `FaceIndex` are `int` with an index role and `Transform` is `matrix4d` with a transform role;
/// the roles carry no meaning for rendering.
const TYPE_ALIASES: &[(&str, &str)] = &[
    ("Vec2d", "double2"),
    ("Vec3d", "double3"),
    ("Vec4d", "double4"),
    ("Vec2f", "float2"),
    ("Vec3f", "float3"),
    ("Vec4f", "float4"),
    ("Vec2h", "half2"),
    ("Vec3h", "half3"),
    ("Vec4h", "half4"),
    ("Vec2i", "int2"),
    ("Vec3i", "int3"),
    ("Vec4i", "int4"),
    ("Matrix2d", "matrix2d"),
    ("Matrix3d", "matrix3d"),
    ("Matrix4d", "matrix4d"),
    ("Quatd", "quatd"),
    ("Quatf", "quatf"),
    ("Quath", "quath"),
    ("Color", "color3d"),
    ("ColorFloat", "color3f"),
    ("Normal", "normal3d"),
    ("NormalFloat", "normal3f"),
    ("Point", "point3d"),
    ("PointFloat", "point3f"),
    ("Vector", "vector3d"),
    ("VectorFloat", "vector3f"),
    ("Frame", "frame4d"),
    ("Transform", "matrix4d"),
    ("PointIndex", "int"),
    ("EdgeIndex", "int"),
    ("FaceIndex", "int"),
];

/// Prim metadata that usd-core composes as a list op but the crate does not know (it rejects
/// `append KEY = [...]` for them): PointInstancer's `inactiveIds`.
pub(crate) const LIST_OP_METADATA: &[&str] = &["inactiveIds"];

/// List-op operations as spelled in USDA.
pub(crate) const LIST_OPS: &[&str] = &["add", "append", "prepend", "delete", "reorder"];

/// The plain metadata field that holds the `op` items of list-op metadata `key` after
/// [`normalize`] (`inactiveIds__append`).
pub(crate) fn list_op_field(key: &str, op: &str) -> String {
    format!("{key}__{op}")
}

/// A lexical token class of USDA.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// Spaces, tabs, line breaks.
    Space,
    /// `# ...` to the end of the line (including the `#usda 1.0` header) or `/* ... */`.
    Comment,
    /// `"..."`, `'...'`, `"""..."""`, `'''...'''`.
    Str,
    /// `@...@` or `@@@...@@@`.
    Asset,
    /// `<...>`.
    PathRef,
    /// A number without its sign: `12`, `1.5`, `.5`, `5.`, `1e-3`.
    Number,
    /// An identifier, possibly namespaced (`inputs:file`).
    Ident,
    /// Any other single character.
    Punct,
}

#[derive(Clone, Debug)]
struct Token {
    kind: Kind,
    span: Range<usize>,
}

/// Splits `text` into tokens covering every byte. Unterminated strings, asset paths and comments
/// run to the end of the text (the crate reports them).
fn tokenize(text: &str) -> Vec<Token> {
    let b = text.as_bytes();
    let mut out: Vec<Token> = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let start = i;
        let c = b[i];
        let kind = match c {
            b' ' | b'\t' | b'\r' | b'\n' | b'\x0c' => {
                while i < b.len() && matches!(b[i], b' ' | b'\t' | b'\r' | b'\n' | b'\x0c') {
                    i += 1;
                }
                Kind::Space
            }
            b'#' => {
                i = find_from(b, i, b"\n").unwrap_or(b.len());
                Kind::Comment
            }
            b'/' if b.get(i + 1) == Some(&b'*') => {
                i = find_from(b, i + 2, b"*/").map_or(b.len(), |e| e + 2);
                Kind::Comment
            }
            b'"' | b'\'' => {
                let triple = [c, c, c];
                if b[i..].starts_with(&triple) {
                    i = find_from(b, i + 3, &triple).map_or(b.len(), |e| e + 3);
                } else {
                    i += 1;
                    while i < b.len() && b[i] != c && b[i] != b'\n' {
                        i += if b[i] == b'\\' { 2 } else { 1 };
                    }
                    i = (i + 1).min(b.len());
                }
                Kind::Str
            }
            b'@' => {
                if b[i..].starts_with(b"@@@") {
                    i = find_from(b, i + 3, b"@@@").map_or(b.len(), |e| e + 3);
                } else {
                    i = find_from(b, i + 1, b"@").map_or(b.len(), |e| e + 1);
                }
                Kind::Asset
            }
            b'<' => {
                i = find_from(b, i + 1, b">").map_or(b.len(), |e| e + 1);
                Kind::PathRef
            }
            b'0'..=b'9' => {
                i = number_end(b, i);
                Kind::Number
            }
            // `.5` is a number unless the dot is glued to a name (`attr.timeSamples`, `a.5`).
            b'.' if b.get(i + 1).is_some_and(u8::is_ascii_digit)
                && !out.last().is_some_and(|t| matches!(t.kind, Kind::Ident | Kind::Number)) =>
            {
                i = number_end(b, i);
                Kind::Number
            }
            c if c.is_ascii_alphabetic() || c == b'_' => {
                while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_' || b[i] == b':') {
                    i += 1;
                }
                Kind::Ident
            }
            _ => {
                // One (possibly multi-byte) character.
                i += text[i..].chars().next().map_or(1, char::len_utf8);
                Kind::Punct
            }
        };
        out.push(Token { kind, span: start..i });
    }
    out
}

fn find_from(b: &[u8], from: usize, needle: &[u8]) -> Option<usize> {
    b.get(from..)?.windows(needle.len()).position(|w| w == needle).map(|p| p + from)
}

/// End of the number starting at `i`: `digits [. digits] [e [+-] digits]`, either side of the
/// dot possibly empty. A trailing `.` is part of the number only when no name follows it (`5.`
/// but not `5.timeSamples`, which no valid layer has anyway).
fn number_end(b: &[u8], mut i: usize) -> usize {
    while i < b.len() && b[i].is_ascii_digit() {
        i += 1;
    }
    if i < b.len()
        && b[i] == b'.'
        && !b.get(i + 1).is_some_and(|c| c.is_ascii_alphabetic() && !matches!(c, b'e' | b'E'))
    {
        i += 1;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
    }
    if i < b.len() && matches!(b[i], b'e' | b'E') {
        let mut j = i + 1;
        if j < b.len() && matches!(b[j], b'+' | b'-') {
            j += 1;
        }
        if j < b.len() && b[j].is_ascii_digit() {
            while j < b.len() && b[j].is_ascii_digit() {
                j += 1;
            }
            i = j;
        }
    }
    i
}

/// The number in the crate's spelling: a digit on both sides of any `.`.
fn fix_number(n: &str) -> Option<String> {
    let (mantissa, exponent) = match n.find(['e', 'E']) {
        Some(p) => n.split_at(p),
        None => (n, ""),
    };
    let dot = mantissa.find('.')?;
    let (int, frac) = (&mantissa[..dot], &mantissa[dot + 1..]);
    if !int.is_empty() && !frac.is_empty() {
        return None;
    }
    let int = if int.is_empty() { "0" } else { int };
    let frac = if frac.is_empty() { "0" } else { frac };
    Some(format!("{int}.{frac}{exponent}"))
}

/// A replacement for one token: (token index, new text).
type Edit = (usize, String);

/// Rewrites the constructs listed in the module docs; borrows `text` when nothing changes.
pub(crate) fn normalize(text: &str) -> Cow<'_, str> {
    let tokens = tokenize(text);
    let significant: Vec<usize> =
        (0..tokens.len()).filter(|&i| !matches!(tokens[i].kind, Kind::Space | Kind::Comment)).collect();
    let tok = |s: usize| &tokens[significant[s]];
    let src = |s: usize| &text[tok(s).span.clone()];
    let is_punct = |s: usize, c: &str| s < significant.len() && tok(s).kind == Kind::Punct && src(s) == c;

    let mut edits: Vec<Edit> = Vec::new();
    let mut s = 0;
    while s < significant.len() {
        let t = tok(s);
        match t.kind {
            Kind::Number => {
                if let Some(fixed) = fix_number(src(s)) {
                    edits.push((significant[s], fixed));
                }
            }
            Kind::Ident
                if LIST_OPS.contains(&src(s))
                    && s + 2 < significant.len()
                    && LIST_OP_METADATA.contains(&src(s + 1))
                    && is_punct(s + 2, "=") =>
            {
                edits.push((significant[s], String::new()));
                edits.push((significant[s + 1], list_op_field(src(s + 1), src(s))));
            }
            Kind::Ident => {
                // Type position: `TYPE name` or `TYPE[] name`.
                let array = is_punct(s + 1, "[") && is_punct(s + 2, "]");
                let name = s + if array { 3 } else { 1 };
                let typed = name < significant.len() && tok(name).kind == Kind::Ident;
                if typed {
                    if let Some((_, modern)) = TYPE_ALIASES.iter().find(|(alias, _)| *alias == src(s)) {
                        edits.push((significant[s], (*modern).to_string()));
                    }
                    if src(s) == "asset" {
                        asset_value(name, array, &significant, &tokens, text, &mut edits);
                    }
                }
            }
            _ => {}
        }
        s += 1;
    }
    if edits.is_empty() {
        return Cow::Borrowed(text);
    }
    // An asset value's edits are pushed when its type is met, before the numbers that precede it.
    edits.sort_by_key(|(at, _)| *at);
    let mut out = String::with_capacity(text.len() + edits.len());
    let mut next = edits.iter().peekable();
    for (i, token) in tokens.iter().enumerate() {
        match next.peek() {
            Some((at, with)) if *at == i => {
                out.push_str(with);
                next.next();
            }
            _ => out.push_str(&text[token.span.clone()]),
        }
    }
    Cow::Owned(out)
}

/// Rewrites the value of an `asset`/`asset[]` attribute whose name is significant token `name`:
/// strings become asset paths, except in scalar time samples where asset paths become strings.
fn asset_value(
    name: usize,
    array: bool,
    significant: &[usize],
    tokens: &[Token],
    text: &str,
    edits: &mut Vec<Edit>,
) {
    let src = |s: usize| significant.get(s).map_or("", |&i| &text[tokens[i].span.clone()]);
    let mut s = name + 1;
    let time_samples = src(s) == "." && src(s + 1) == "timeSamples";
    if src(s) == "." {
        s += 2;
    }
    if src(s) != "=" {
        return;
    }
    s += 1;
    // The value: one token, or a bracketed group up to its matching close.
    let mut depth = 0usize;
    let to_string = time_samples && !array;
    while s < significant.len() {
        let i = significant[s];
        let token = &tokens[i];
        let raw = &text[token.span.clone()];
        match token.kind {
            Kind::Punct if matches!(raw, "[" | "{" | "(") => depth += 1,
            Kind::Punct if matches!(raw, "]" | "}" | ")") => depth = depth.saturating_sub(1),
            Kind::Str if !to_string => {
                if let Some(path) = string_as_asset(raw) {
                    edits.push((i, path));
                }
            }
            Kind::Asset if to_string => {
                if let Some(string) = asset_as_string(raw) {
                    edits.push((i, string));
                }
            }
            _ => {}
        }
        if depth == 0 {
            return;
        }
        s += 1;
    }
}

/// `"x.png"` → `@x.png@`, when the string holds nothing an asset path cannot spell.
fn string_as_asset(raw: &str) -> Option<String> {
    let quote = if raw.starts_with("\"\"\"") || raw.starts_with("'''") { 3 } else { 1 };
    let inner = raw.get(quote..raw.len().checked_sub(quote)?)?;
    (!inner.contains(['@', '\\', '\n'])).then(|| format!("@{inner}@"))
}

/// `@x.png@` → `"x.png"`, when the path holds nothing a plain string would need to escape.
fn asset_as_string(raw: &str) -> Option<String> {
    let at = if raw.starts_with("@@@") { 3 } else { 1 };
    let inner = raw.get(at..raw.len().checked_sub(at)?)?;
    (!inner.contains(['"', '\\', '\n'])).then(|| format!("\"{inner}\""))
}

/// Nesting of `{`, `[` and `(` a text layer may use. The crate's parser, its composition and our
/// reader recurse once per level (dictionaries, arrays, prims), so a deeper file overflows the
/// stack, an abort; real layers nest a few dozen levels.
pub(crate) const MAX_NESTING: usize = 256;

/// The first construct in `text` the crate must not be given, as `line L, column C: problem`:
/// a path reference (`<...>`) that is not a well-formed scene path (the crate takes any text
/// between `<` and `>`; see [`super::path_syntax`]), or nesting deeper than [`MAX_NESTING`].
pub(crate) fn structural_problem(text: &str) -> Option<String> {
    use super::path_syntax::{check_element, Element};
    let at = |offset: usize| {
        let before = &text[..offset];
        let line = before.matches('\n').count() + 1;
        let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
        format!("line {line}, column {column}")
    };
    let shown = |s: &str| -> String { s.chars().take(60).collect::<String>().escape_debug().collect() };
    let tokens: Vec<Token> =
        tokenize(text).into_iter().filter(|t| !matches!(t.kind, Kind::Space | Kind::Comment)).collect();
    let source = |i: Option<usize>| i.and_then(|i| tokens.get(i)).map_or("", |t| &text[t.span.clone()]);
    let mut depth = 0usize;
    for (i, t) in tokens.iter().enumerate() {
        let here = &text[t.span.clone()];
        match t.kind {
            Kind::PathRef => {
                // An unterminated `<` runs to the end of the text; the crate reports it.
                let Some(inner) = here.strip_prefix('<').and_then(|s| s.strip_suffix('>')) else { continue };
                if let Err(problem) = super::path_syntax::check(inner) {
                    return Some(format!(
                        "{}: path <{}> is malformed: {problem}",
                        at(t.span.start),
                        shown(inner)
                    ));
                }
            }
            // A quoted name that becomes a path element: a prim's (`def Xform "name" {`), a
            // variant set's (`variantSet "name" =`) or a variant's (`"name" {` inside one).
            Kind::Str => {
                let Some(inner) = unquote(here) else {
                    // Sdf's grammar (and usd-core) end a one-quote string at the line; the crate
                    // reads on, so a prim name could swallow lines of braces (found by the fuzzer).
                    if here.ends_with('\n') {
                        return Some(format!("{}: string not closed on its line", at(t.span.start)));
                    }
                    continue;
                };
                let (before, before2) = (source(i.checked_sub(1)), source(i.checked_sub(2)));
                let opens = matches!(source(Some(i + 1)), "{" | "(");
                let specifier = |s: &str| matches!(s, "def" | "over" | "class");
                let element = if specifier(before) || (specifier(before2) && opens) {
                    Some(("prim name", Element::Prim))
                } else if before == "variantSet" || opens {
                    Some(("variant name", Element::VariantName))
                } else {
                    None
                };
                if let Some((what, element)) = element {
                    if let Err(problem) = check_element(inner, element) {
                        return Some(format!(
                            "{}: {what} \"{}\" is malformed: {problem}",
                            at(t.span.start),
                            shown(inner)
                        ));
                    }
                }
            }
            Kind::Punct if matches!(here, "{" | "[" | "(") => {
                depth += 1;
                if depth > MAX_NESTING {
                    return Some(format!("{}: nested deeper than {MAX_NESTING} levels", at(t.span.start)));
                }
            }
            Kind::Punct if matches!(here, "}" | "]" | ")") => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    None
}

/// The inside of a quoted string token, if it is terminated.
fn unquote(s: &str) -> Option<&str> {
    ["\"\"\"", "'''", "\"", "'"].into_iter().find_map(|q| s.strip_prefix(q).and_then(|r| r.strip_suffix(q)))
}

/// Where the crate's parser stops in `text`: `line:column: source line`, if it rejects it.
pub(crate) fn parse_error_location(text: &str) -> Option<String> {
    let mut parser = openusd::usda::parser::Parser::new(text);
    let error = parser.parse().err()?;
    let where_ = parser
        .last_error_highlight()
        .map(|h| format!("line {}, column {}: `{}`", h.line, h.column, h.line_text.trim()))
        .unwrap_or_else(|| "unknown position".to_string());
    Some(format!("{where_}: {error:#}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deep_nesting_is_located() {
        let deep = format!(
            "#usda 1.0\n{}{}",
            "def \"a\" {\n".repeat(MAX_NESTING + 1),
            "}\n".repeat(MAX_NESTING + 1)
        );
        let problem = structural_problem(&deep).unwrap();
        assert_eq!(problem, format!("line {}, column 9: nested deeper than 256 levels", MAX_NESTING + 2));
        let fine = format!("#usda 1.0\n{}{}", "def \"a\" {\n".repeat(MAX_NESTING), "}\n".repeat(MAX_NESTING));
        assert_eq!(structural_problem(&fine), None);
        // Brackets inside strings, comments and paths do not count.
        assert_eq!(
            structural_problem(&format!("string s = \"{}\" # {}\n", "[".repeat(300), "{".repeat(300))),
            None
        );
    }

    #[test]
    fn malformed_prim_and_variant_names_are_located() {
        let ok = concat!(
            "def Xform \"Root\" (\n variants = { string look = \"a\" }\n prepend variantSets = \"look\"\n)\n{\n",
            " variantSet \"look\" = {\n  \"a\" { def \"A\" {} }\n  \"b-2\" (doc = \"x y\") {}\n }\n}\n",
            "over \"O\" {}\nclass \"C\" {}\ndef \"D\" { custom string s = \"a b\" }\n",
        );
        assert_eq!(structural_problem(ok), None);
        assert_eq!(
            structural_problem("def Xform \"}Root\" (\n)\n{\n}\n").unwrap(),
            "line 1, column 11: prim name \"}Root\" is malformed: expected a name: unexpected '}' at character 0"
        );
        assert_eq!(
            structural_problem("def \"Lo  }\n}\n\naded\" {}").unwrap(),
            "line 1, column 5: string not closed on its line"
        );
        assert_eq!(
            structural_problem("over \"a b\" {}").unwrap(),
            "line 1, column 6: prim name \"a b\" is malformed: unexpected ' ' at character 1"
        );
        assert_eq!(
            structural_problem("def \"R\" {\n variantSet \"v\" = {\n  \"a}\" {}\n }\n}").unwrap(),
            "line 3, column 3: variant name \"a}\" is malformed: unexpected '}' at character 1"
        );
    }

    #[test]
    fn malformed_path_references_are_located() {
        let text = "#usda 1.0\ndef X \"A\" {\n    rel r = </A/B \"q>\n    rel s = </A/B>\n    string t = \"<x y>\"\n}\n";
        assert_eq!(
            structural_problem(text).unwrap(),
            "line 3, column 13: path </A/B \\\"q> is malformed: unexpected ' ' at character 4"
        );
        assert_eq!(structural_problem("rel s = </A/B.c:d>\nstring t = \"<x y>\" # <z w>\n"), None);
    }

    #[test]
    fn numbers_gain_their_missing_digits() {
        assert_eq!(normalize("float a = .5\n"), "float a = 0.5\n");
        assert_eq!(normalize("float[] w = [0, .5, -.5, +.25]"), "float[] w = [0, 0.5, -0.5, +0.25]");
        assert_eq!(normalize("color3f c = (0.2, 0.7, 0.)"), "color3f c = (0.2, 0.7, 0.0)");
        assert_eq!(normalize("double d = 1.e3\ndouble e = .5E-2"), "double d = 1.0e3\ndouble e = 0.5E-2");
        assert!(matches!(normalize("float a = 0.5e-3\nint b = 12"), Cow::Borrowed(_)));
    }

    #[test]
    fn dots_in_names_and_headers_are_not_numbers() {
        let text = "#usda 1.0\nfloat3 xformOp:translate.timeSamples = { 1: (0, 1, 2) }\n";
        assert!(matches!(normalize(text), Cow::Borrowed(_)));
        assert!(matches!(normalize("float a.connect = </A/b.outputs:c>"), Cow::Borrowed(_)));
    }

    #[test]
    fn strings_assets_paths_and_comments_are_untouched() {
        let text = concat!(
            "# .5 Vec3f x\n",
            "/* .5 Vec3f x */\n",
            "string s = \".5 Vec3f x\"\n",
            "string t = \"\"\"\n.5 Vec3f x\n\"\"\"\n",
            "asset[] a = [@./tex/.5.png@, @@@a@b .5@@@]\n",
            "rel r = </Vec3f/.5>\n",
        );
        assert!(matches!(normalize(text), Cow::Borrowed(_)), "{}", normalize(text));
    }

    #[test]
    fn legacy_type_names_become_modern_only_in_type_position() {
        assert_eq!(normalize("Vec3f xformOp:translate = (0, 0, 0)"), "float3 xformOp:translate = (0, 0, 0)");
        assert_eq!(normalize("PointFloat[] points = []"), "point3f[] points = []");
        assert_eq!(normalize("uniform PointIndex[] faceIndices = [1]"), "uniform int[] faceIndices = [1]");
        assert_eq!(normalize("custom Matrix4d m"), "custom matrix4d m");
        // A prim type name, a token value, a metadata key: not a type position.
        let text = "def Point \"Point\" (\n    kind = \"Vec3f\"\n)\n{\n    token t = \"Color\"\n}\n";
        assert!(matches!(normalize(text), Cow::Borrowed(_)));
    }

    #[test]
    fn asset_values_take_the_spelling_the_crate_reads() {
        assert_eq!(normalize("asset inputs:file = \"tex.png\""), "asset inputs:file = @tex.png@");
        assert_eq!(normalize("asset[] files = [\"a.png\", @b.png@]"), "asset[] files = [@a.png@, @b.png@]");
        assert_eq!(
            normalize("asset inputs:file.timeSamples = {\n 1: @grid.png@,\n 2: @grid_1.png@,\n}"),
            "asset inputs:file.timeSamples = {\n 1: \"grid.png\",\n 2: \"grid_1.png\",\n}"
        );
        // Metadata after the value is not part of it.
        assert_eq!(
            normalize("asset a = \"x.png\" (\n doc = \"y\"\n)"),
            "asset a = @x.png@ (\n doc = \"y\"\n)"
        );
        // A string an asset path cannot spell is left for the crate to report.
        assert!(matches!(normalize("asset a = \"x@y.png\""), Cow::Borrowed(_)));
    }

    #[test]
    fn unknown_list_op_metadata_becomes_a_plain_field() {
        assert_eq!(
            normalize("def PointInstancer \"P\" (\n    append inactiveIds = [1, 3]\n)"),
            "def PointInstancer \"P\" (\n     inactiveIds__append = [1, 3]\n)"
        );
        assert_eq!(
            normalize("over \"P\" (delete inactiveIds = [2])"),
            "over \"P\" ( inactiveIds__delete = [2])"
        );
        // Known list-op metadata and plain assignments are the crate's.
        let text = "def \"P\" (\n    prepend references = @a.usda@\n    inactiveIds = [1]\n)";
        assert!(matches!(normalize(text), Cow::Borrowed(_)));
    }

    #[test]
    fn line_breaks_are_preserved() {
        let text = "#usda 1.0\ndef \"A\"\n{\n    Vec3f[] extent = [(-.5, -.5, -.5), (.5, .5, .5)]\n    asset f = \"x\"\n}\n";
        let fixed = normalize(text);
        assert_eq!(fixed.lines().count(), text.lines().count());
        assert!(parse_error_location(&fixed).is_none(), "{:?}", parse_error_location(&fixed));
    }

    #[test]
    fn rejected_constructs_are_located() {
        let text = "#usda 1.0\ndef \"A\"\n{\n    float a = 1\n    bogus3f b = 2\n}\n";
        let location = parse_error_location(text).expect("rejected");
        assert!(location.contains("line 5"), "{location}");
        assert!(location.contains("bogus3f"), "{location}");
    }
}
