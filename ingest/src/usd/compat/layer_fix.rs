//! Token-level fixes for `.usda` text that usd-core reads but the `openusd` 0.6 parser rejects.
//!
//! The resolver ([`crate::usd::resolver`]) passes every text layer through [`prepare`] (the structural
//! check and this rewrite in one lexing pass) before the crate parses it. The rewrite works on
//! tokens of the USDA grammar, so the inside of strings, asset paths (`@...@`), path references
//! (`<...>`) and comments is never touched, and it never
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

mod numeric_run;
mod tuple_arity;

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
/// [`prepare`] (`inactiveIds__append`).
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

/// Splits a text into tokens covering every byte, one at a time: the passes below look a few
/// tokens ahead by cloning the lexer, so no token list is ever stored (a 3 MB layer has about a
/// million tokens; storing them cost more than lexing them). Unterminated strings, asset paths
/// and comments run to the end of the text (the crate reports them).
#[derive(Clone)]
struct Lexer<'a> {
    text: &'a str,
    at: usize,
    /// Kind of the previous token, of any kind (a `.` after a name or number is not a number).
    last: Option<Kind>,
}

impl<'a> Lexer<'a> {
    fn new(text: &'a str) -> Self {
        Lexer { text, at: 0, last: None }
    }

    /// The next token that is neither space nor comment.
    fn next_significant(&mut self) -> Option<Token> {
        self.find(|t| !matches!(t.kind, Kind::Space | Kind::Comment))
    }
}

impl Iterator for Lexer<'_> {
    type Item = Token;

    fn next(&mut self) -> Option<Token> {
        let b = self.text.as_bytes();
        let start = self.at;
        let mut i = start;
        let &c = b.get(i)?;
        let kind = match c {
            b' ' | b'\t' | b'\r' | b'\n' | b'\x0c' => {
                while i < b.len() && matches!(b[i], b' ' | b'\t' | b'\r' | b'\n' | b'\x0c') {
                    i += 1;
                }
                Kind::Space
            }
            b'#' => {
                i = find_byte(b, i, b'\n').unwrap_or(b.len());
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
                    i = find_byte(b, i + 1, b'@').map_or(b.len(), |e| e + 1);
                }
                Kind::Asset
            }
            b'<' => {
                i = find_byte(b, i + 1, b'>').map_or(b.len(), |e| e + 1);
                Kind::PathRef
            }
            b'0'..=b'9' => {
                i = number_end(b, i);
                Kind::Number
            }
            // `.5` is a number unless the dot is glued to a name (`attr.timeSamples`, `a.5`).
            b'.' if b.get(i + 1).is_some_and(u8::is_ascii_digit)
                && !matches!(self.last, Some(Kind::Ident | Kind::Number)) =>
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
            c if c.is_ascii() => {
                i += 1;
                Kind::Punct
            }
            _ => {
                // One multi-byte character.
                i += self.text[i..].chars().next().map_or(1, char::len_utf8);
                Kind::Punct
            }
        };
        // A string or escape may step past the end: the token ends with the text.
        let end = i.min(b.len());
        self.at = end;
        self.last = Some(kind);
        Some(Token { kind, span: start..end })
    }
}

fn find_byte(b: &[u8], from: usize, needle: u8) -> Option<usize> {
    b.get(from..)?.iter().position(|&c| c == needle).map(|p| p + from)
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
    // Nearly every number of a large layer is already spelled so: tell with one pass over its
    // bytes before splitting it (the split cost a tenth of preparing a mesh-heavy layer).
    if !needs_digit_by_dot(n.as_bytes()) {
        return None;
    }
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

/// Whether a number token has a `.` without a digit on one side of it.
fn needs_digit_by_dot(n: &[u8]) -> bool {
    let Some(dot) = n.iter().position(|&c| c == b'.') else { return false };
    let digit_at = |i: Option<usize>| i.and_then(|i| n.get(i)).is_some_and(u8::is_ascii_digit);
    !(digit_at(dot.checked_sub(1)) && digit_at(Some(dot + 1)))
}

/// Whether an identifier can start a construct [`fix_token`] rewrites (a list op, a legacy
/// type name, `asset`): only those need the tokens after it.
fn may_need_rewrite(word: &str) -> bool {
    word == "asset" || LIST_OPS.contains(&word) || TYPE_ALIASES.iter().any(|(alias, _)| *alias == word)
}

/// A replacement for one token: (its byte span, new text).
type Edit = (Range<usize>, String);

/// Rewrites the constructs listed in the module docs; borrows `text` when nothing changes, so a
/// layer that needs no rewrite costs one lexing pass and no allocation. (The resolver uses
/// [`prepare`], which also checks the structure.)
#[cfg(test)]
pub(crate) fn normalize(text: &str) -> Cow<'_, str> {
    let mut edits: Vec<Edit> = Vec::new();
    let mut tokens = Lexer::new(text);
    while let Some(t) = tokens.next_significant() {
        fix_token(text, &t, &tokens, &mut edits);
    }
    apply(text, edits)
}

/// A text layer as [`prepare`] hands it to the crate.
pub(crate) struct PreparedLayer<'a> {
    /// The text, normalized; borrowed when nothing needed a rewrite.
    pub text: Cow<'a, str>,
    /// Every asset path the layer spells (`@...@`, inside the delimiters), in order: the
    /// resolver prefetches the layers among them.
    pub asset_paths: Vec<&'a str>,
}

/// A text layer as the crate is given it: `structural_problem` and `normalize` in one
/// lexing pass (run one after the other they cost half as much as the crate's own parse),
/// with the asset paths it names; `Err` is `structural_problem`'s.
pub(crate) fn prepare(text: &str) -> Result<PreparedLayer<'_>, String> {
    prepare_with(text, Lexing::NumericRuns)
}

/// How [`prepare_with`] lexes.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Lexing {
    /// Every token through the general lexer (the reference the fast path is tested against).
    #[cfg(test)]
    General,
    /// Runs of plain numbers through [`numeric_run::skip`], the rest through the general lexer.
    NumericRuns,
}

fn prepare_with(text: &str, lexing: Lexing) -> Result<PreparedLayer<'_>, String> {
    let mut edits: Vec<Edit> = Vec::new();
    let mut asset_paths = Vec::new();
    let mut structure = Structure::new(text);
    let mut tokens = Lexer::new(text);
    loop {
        if lexing == Lexing::NumericRuns {
            numeric_run::skip(&mut tokens, &mut structure);
        }
        let Some(t) = tokens.next_significant() else { break };
        structure.check(&t, &tokens)?;
        fix_token(text, &t, &tokens, &mut edits);
        if t.kind == Kind::Asset {
            let raw = &text[t.span];
            let at = if raw.starts_with("@@@") { 3 } else { 1 };
            if let Some(inner) = raw.get(at..raw.len().saturating_sub(at)).filter(|p| !p.is_empty()) {
                asset_paths.push(inner);
            }
        }
    }
    Ok(PreparedLayer { text: apply(text, edits), asset_paths })
}

/// Records the edit significant token `t` needs, `tokens` standing just after it.
fn fix_token(text: &str, t: &Token, tokens: &Lexer<'_>, edits: &mut Vec<Edit>) {
    let src = |t: &Token| &text[t.span.clone()];
    let is_punct =
        |t: &Option<Token>, c: &str| t.as_ref().is_some_and(|t| t.kind == Kind::Punct && src(t) == c);
    match t.kind {
        Kind::Number => {
            if let Some(fixed) = fix_number(src(t)) {
                edits.push((t.span.clone(), fixed));
            }
        }
        // Most identifiers are names and types the crate reads as they are; looking ahead for
        // the rest only avoids lexing three tokens twice per identifier.
        Kind::Ident if may_need_rewrite(src(t)) => {
            let mut ahead = tokens.clone();
            let next = [ahead.next_significant(), ahead.next_significant(), ahead.next_significant()];
            let word = src(t);
            let list_op_key = next[0].as_ref().filter(|k| LIST_OP_METADATA.contains(&src(k)));
            if let (true, Some(key), true) = (LIST_OPS.contains(&word), list_op_key, is_punct(&next[1], "="))
            {
                edits.push((key.span.clone(), list_op_field(src(key), word)));
                edits.push((t.span.clone(), String::new()));
                return;
            }
            // Type position: `TYPE name` or `TYPE[] name`.
            let array = is_punct(&next[0], "[") && is_punct(&next[1], "]");
            let name = if array { &next[2] } else { &next[0] };
            if !name.as_ref().is_some_and(|n| n.kind == Kind::Ident) {
                return;
            }
            if let Some((_, modern)) = TYPE_ALIASES.iter().find(|(alias, _)| *alias == word) {
                edits.push((t.span.clone(), (*modern).to_string()));
            }
            if word == "asset" {
                let mut value = tokens.clone();
                for _ in 0..if array { 3 } else { 1 } {
                    value.next_significant();
                }
                asset_value(value, array, text, edits);
            }
        }
        _ => {}
    }
}

/// `text` with `edits` applied; borrowed when there are none.
fn apply(text: &str, mut edits: Vec<Edit>) -> Cow<'_, str> {
    if edits.is_empty() {
        return Cow::Borrowed(text);
    }
    // An asset value's edits are pushed when its type is met, before the numbers that precede it.
    edits.sort_by_key(|(span, _)| span.start);
    edits.dedup_by_key(|(span, _)| span.start);
    let mut out = String::with_capacity(text.len() + edits.len());
    let mut copied = 0;
    for (span, with) in &edits {
        out.push_str(&text[copied..span.start]);
        out.push_str(with);
        copied = span.end;
    }
    out.push_str(&text[copied..]);
    Cow::Owned(out)
}

/// Rewrites the value of an `asset`/`asset[]` attribute, `tokens` standing just after its name:
/// strings become asset paths, except in scalar time samples where asset paths become strings.
fn asset_value(mut tokens: Lexer<'_>, array: bool, text: &str, edits: &mut Vec<Edit>) {
    let src = |t: &Option<Token>| t.as_ref().map_or("", |t| &text[t.span.clone()]);
    let mut t = tokens.next_significant();
    let time_samples = src(&t) == "." && {
        let mut ahead = tokens.clone();
        src(&ahead.next_significant()) == "timeSamples"
    };
    if src(&t) == "." {
        tokens.next_significant();
        t = tokens.next_significant();
    }
    if src(&t) != "=" {
        return;
    }
    // The value: one token, or a bracketed group up to its matching close.
    let mut depth = 0usize;
    let to_string = time_samples && !array;
    while let Some(token) = tokens.next_significant() {
        let raw = &text[token.span.clone()];
        match token.kind {
            Kind::Punct if matches!(raw, "[" | "{" | "(") => depth += 1,
            Kind::Punct if matches!(raw, "]" | "}" | ")") => depth = depth.saturating_sub(1),
            Kind::Str if !to_string => {
                if let Some(path) = string_as_asset(raw) {
                    edits.push((token.span, path));
                }
            }
            Kind::Asset if to_string => {
                if let Some(string) = asset_as_string(raw) {
                    edits.push((token.span, string));
                }
            }
            _ => {}
        }
        if depth == 0 {
            return;
        }
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
#[cfg(test)]
pub(crate) fn structural_problem(text: &str) -> Option<String> {
    let mut structure = Structure::new(text);
    let mut tokens = Lexer::new(text);
    while let Some(t) = tokens.next_significant() {
        if let Err(problem) = structure.check(&t, &tokens) {
            return Some(problem);
        }
    }
    None
}

/// What the structural check tracks from one significant token to the next.
struct Structure<'a> {
    text: &'a str,
    /// The two significant tokens before the current one, nearest first.
    before: (&'a str, &'a str),
    depth: usize,
    /// The attribute declaration being read, and the typed value whose tuples are being counted.
    declaration: tuple_arity::Declaration<'a>,
    shape: Option<tuple_arity::ValueShape<'a>>,
}

impl<'a> Structure<'a> {
    fn new(text: &'a str) -> Self {
        Structure { text, before: ("", ""), depth: 0, declaration: Default::default(), shape: None }
    }

    /// Feeds significant token `here` to the tuple-dimension check ([`tuple_arity`]).
    fn check_tuples(&mut self, here: &'a str) -> Result<(), String> {
        use tuple_arity::ValueToken;
        if let Some(shape) = &mut self.shape {
            let token = match here {
                "(" | "[" | "{" => ValueToken::Open { paren: here == "(" },
                ")" | "]" | "}" => ValueToken::Close { paren: here == ")" },
                "," => ValueToken::Comma,
                _ => ValueToken::Other,
            };
            if !shape.take(token)? {
                self.shape = None;
            }
        }
        // Only a capitalised word can be a legacy alias (`Vec3f`).
        let modern = |t: &'a str| -> &'a str {
            if !t.starts_with(|c: char| c.is_ascii_uppercase()) {
                return t;
            }
            TYPE_ALIASES.iter().find(|(alias, _)| *alias == t).map_or(t, |(_, name)| name)
        };
        let (declaration, shape) = self.declaration.step(here, modern);
        self.declaration = declaration;
        if shape.is_some() {
            self.shape = shape;
        }
        Ok(())
    }

    /// Checks significant token `t`, `tokens` standing just after it.
    fn check(&mut self, t: &Token, tokens: &Lexer<'a>) -> Result<(), String> {
        use super::path_syntax::{check_element, Element};
        let text = self.text;
        let at = |offset: usize| {
            let before = &text[..offset];
            let line = before.matches('\n').count() + 1;
            let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
            format!("line {line}, column {column}")
        };
        let shown = |s: &str| -> String { s.chars().take(60).collect::<String>().escape_debug().collect() };
        let here = &text[t.span.clone()];
        let (before, before2) = self.before;
        match t.kind {
            Kind::PathRef => {
                // An unterminated `<` runs to the end of the text; the crate reports it.
                if let Some(inner) = here.strip_prefix('<').and_then(|s| s.strip_suffix('>')) {
                    if let Err(problem) = super::path_syntax::check(inner) {
                        return Err(format!(
                            "{}: path <{}> is malformed: {problem}",
                            at(t.span.start),
                            shown(inner)
                        ));
                    }
                }
            }
            // A quoted name that becomes a path element: a prim's (`def Xform "name" {`), a
            // variant set's (`variantSet "name" =`) or a variant's (`"name" {` inside one).
            Kind::Str => {
                if let Some(inner) = unquote(here) {
                    let next = tokens.clone().next_significant().map_or("", |n| &text[n.span]);
                    let opens = matches!(next, "{" | "(");
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
                            return Err(format!(
                                "{}: {what} \"{}\" is malformed: {problem}",
                                at(t.span.start),
                                shown(inner)
                            ));
                        }
                    }
                } else if here.ends_with('\n') {
                    // Sdf's grammar (and usd-core) end a one-quote string at the line; the crate
                    // reads on, so a prim name could swallow lines of braces (found by the fuzzer).
                    return Err(format!("{}: string not closed on its line", at(t.span.start)));
                }
            }
            Kind::Punct if matches!(here, "{" | "[" | "(") => {
                self.depth += 1;
                if self.depth > MAX_NESTING {
                    return Err(format!("{}: nested deeper than {MAX_NESTING} levels", at(t.span.start)));
                }
            }
            Kind::Punct if matches!(here, "}" | "]" | ")") => self.depth = self.depth.saturating_sub(1),
            _ => {}
        }
        self.check_tuples(here).map_err(|problem| format!("{}: {problem}", at(t.span.start)))?;
        self.before = (here, before);
        Ok(())
    }
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
    fn one_pass_preparation_agrees_with_the_separate_passes() {
        let texts = [
            "#usda 1.0\ndef \"A\" (\n    prepend references = @./b.usda@\n)\n{\n    Vec3f[] extent = [(-.5, 0, 0), (.5, 1, 1.)]\n    asset f = \"x.png\"\n    asset g.timeSamples = { 1: @y.png@ }\n}\n",
            "#usda 1.0\ndef PointInstancer \"P\" (\n    append inactiveIds = [1]\n)\n{\n    rel r = </P/Q>\n}\n",
            "#usda 1.0\ndef \"A\" {\n    float a = 0.5\n}\n",
            "def Xform \"}Root\" (\n)\n{\n}\n",
            "rel r = </A/B \"q>\n",
        ];
        for text in texts {
            match prepare(text) {
                Ok(layer) => {
                    assert_eq!(structural_problem(text), None, "{text}");
                    assert_eq!(layer.text, normalize(text), "{text}");
                    let borrowed = matches!(layer.text, Cow::Borrowed(_));
                    assert_eq!(borrowed, matches!(normalize(text), Cow::Borrowed(_)), "{text}");
                }
                Err(problem) => assert_eq!(Some(problem), structural_problem(text), "{text}"),
            }
        }
        let layer = prepare(texts[0]).unwrap();
        assert_eq!(layer.asset_paths, ["./b.usda", "y.png"]);
        assert_eq!(prepare("asset a = @@@x@y.usda@@@\n").unwrap().asset_paths, ["x@y.usda"]);
    }

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
