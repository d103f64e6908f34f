//! Syntax of scene paths as authored in text layers (`</World/Cube.points>`).
//!
//! openusd's text parser takes anything between `<` and `>` as a path, and its path queries
//! (parent, prim path) assume a well-formed one: on some malformed paths (spaces, quotes, a `}`
//! with no `{`) the instancing code walks "ancestors" that never shorten and overflows the stack,
//! which aborts the process. Every path reference is therefore checked against Sdf's path
//! grammar before the crate parses the layer:
//!
//! ```text
//! path      = "" | "/" | prim-part [property] | property-only
//! prim-part = ["/"] element ("/" element)*        (or relative: "." | ".." ("/" "..")* ...)
//! element   = ".." | name variant* | variant+      (a name may follow a variant: A{v=x}B)
//! variant   = "{" name "=" [selection] "}"        selection: [A-Za-z0-9_|.-]+
//! property  = "." ns-name ("[" path "]")* ("." ns-name ("[" path "]")*)*
//! name      = identifier (letter or _ then letters, digits, _; letters may be non-ASCII)
//! ns-name   = name (":" name)*
//! ```

/// Checks one authored path (without its `<` `>`); the error says what is wrong.
pub(crate) fn check(path: &str) -> Result<(), String> {
    let mut p = Parser { s: path.as_bytes(), i: 0 };
    p.path(0)?;
    if p.i != p.s.len() {
        return Err(p.unexpected());
    }
    Ok(())
}

/// What one element of a path may be.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Element {
    /// A prim name: an identifier.
    Prim,
    /// A property name: identifiers joined by `:`.
    Property,
    /// A variant selection `{set=selection}`.
    Variant,
    /// A variant name as authored (`variantSet "v" = { "name" { ... } }`): letters, digits and
    /// `_|-.`, as the selection inside a variant element.
    VariantName,
}

/// Checks one path element (a prim or property name, a variant selection), as a crate file's
/// path tree or a text layer's prim definitions spell it.
pub(crate) fn check_element(text: &str, element: Element) -> Result<(), String> {
    let mut p = Parser { s: text.as_bytes(), i: 0 };
    match element {
        Element::Prim => p.name()?,
        Element::Property => p.namespaced_name()?,
        Element::Variant if p.peek() == Some(b'{') => p.variant()?,
        Element::Variant => return Err(format!("expected `{{`: {}", p.unexpected())),
        Element::VariantName => {
            p.selection();
            if p.i == 0 {
                return Err(format!("expected a variant name: {}", p.unexpected()));
            }
        }
    }
    if p.i != p.s.len() {
        return Err(p.unexpected());
    }
    Ok(())
}

/// Nesting of target paths (`.rel[/A.rel[/B]]`) allowed; real layers use one level.
const MAX_TARGET_DEPTH: u32 = 8;

struct Parser<'a> {
    s: &'a [u8],
    i: usize,
}

impl Parser<'_> {
    fn peek(&self) -> Option<u8> {
        self.s.get(self.i).copied()
    }

    fn unexpected(&self) -> String {
        match std::str::from_utf8(&self.s[self.i..]).ok().and_then(|t| t.chars().next()) {
            Some(c) => format!("unexpected {c:?} at character {}", self.i),
            None => "unexpected end".to_string(),
        }
    }

    fn eat(&mut self, c: u8) -> bool {
        let hit = self.peek() == Some(c);
        if hit {
            self.i += 1;
        }
        hit
    }

    /// An identifier: a letter (ASCII or not) or `_`, then letters, digits and `_`.
    fn name(&mut self) -> Result<(), String> {
        let rest = std::str::from_utf8(&self.s[self.i..]).map_err(|_| "not UTF-8".to_string())?;
        let mut chars = rest.char_indices();
        match chars.next() {
            Some((_, c)) if c.is_alphabetic() || c == '_' => {}
            _ => return Err(format!("expected a name: {}", self.unexpected())),
        }
        let end = chars.find(|&(_, c)| !(c.is_alphanumeric() || c == '_')).map_or(rest.len(), |(i, _)| i);
        self.i += end;
        Ok(())
    }

    fn namespaced_name(&mut self) -> Result<(), String> {
        self.name()?;
        while self.eat(b':') {
            self.name()?;
        }
        Ok(())
    }

    /// `{set=selection}`, the `{` already seen.
    fn variant(&mut self) -> Result<(), String> {
        self.i += 1;
        self.name()?;
        if !self.eat(b'=') {
            return Err(format!("expected `=` in a variant selection: {}", self.unexpected()));
        }
        self.selection();
        if !self.eat(b'}') {
            return Err(format!("expected `}}` closing a variant selection: {}", self.unexpected()));
        }
        Ok(())
    }

    /// A variant selection's characters (possibly none).
    fn selection(&mut self) {
        while self.peek().is_some_and(|c| c.is_ascii_alphanumeric() || b"_|-.".contains(&c)) {
            self.i += 1;
        }
    }

    fn path(&mut self, depth: u32) -> Result<(), String> {
        if self.i == self.s.len() || self.peek() == Some(b']') {
            return Ok(()); // The empty path.
        }
        let absolute = self.eat(b'/');
        if absolute && matches!(self.peek(), None | Some(b']')) {
            return Ok(()); // The pseudo-root.
        }
        // Relative prefixes: `.` alone, or `..` segments.
        if !absolute && self.s[self.i..].starts_with(b"..") {
            while self.s[self.i..].starts_with(b"..") {
                self.i += 2;
                if !self.eat(b'/') {
                    return self.property_part(depth);
                }
            }
        } else if !absolute && self.peek() == Some(b'.') {
            // `.` alone, or a property of the anchor prim (`.attr`).
            if matches!(self.s.get(self.i + 1), None | Some(b']')) {
                self.i += 1;
                return Ok(());
            }
            return self.property_part(depth);
        }
        loop {
            // One prim element: a name with variant selections, a name may follow a selection.
            let mut any = false;
            loop {
                match self.peek() {
                    Some(b'{') => self.variant()?,
                    Some(c) if c == b'_' || c.is_ascii_alphabetic() || c >= 0x80 => self.name()?,
                    _ => break,
                }
                any = true;
            }
            if !any {
                return Err(format!("expected a prim name: {}", self.unexpected()));
            }
            if !self.eat(b'/') {
                break;
            }
        }
        self.property_part(depth)
    }

    /// Optional `.name[target]...` after the prim part.
    fn property_part(&mut self, depth: u32) -> Result<(), String> {
        while self.eat(b'.') {
            self.namespaced_name()?;
            while self.eat(b'[') {
                if depth >= MAX_TARGET_DEPTH {
                    return Err("target paths nest too deep".into());
                }
                self.path(depth + 1)?;
                if !self.eat(b']') {
                    return Err(format!("expected `]` closing a target path: {}", self.unexpected()));
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::{check, check_element, Element};

    #[test]
    fn elements_are_checked_by_kind() {
        check_element("Root", Element::Prim).unwrap();
        check_element("primvars:st", Element::Property).unwrap();
        check_element("{look=a-1}", Element::Variant).unwrap();
        check_element("1-a.b", Element::VariantName).unwrap();
        assert_eq!(
            check_element("}Root", Element::Prim).unwrap_err(),
            "expected a name: unexpected '}' at character 0"
        );
        assert_eq!(check_element("a/b", Element::Prim).unwrap_err(), "unexpected '/' at character 1");
        assert_eq!(check_element("a.b", Element::Property).unwrap_err(), "unexpected '.' at character 1");
        assert_eq!(
            check_element("{look=a", Element::Variant).unwrap_err(),
            "expected `}` closing a variant selection: unexpected end"
        );
        assert_eq!(check_element("a}", Element::VariantName).unwrap_err(), "unexpected '}' at character 1");
    }

    #[test]
    fn paths_usd_writes_are_accepted() {
        for path in [
            "",
            "/",
            ".",
            "/World",
            "/World/Cube.points",
            "/World/Looks/Red/Surface.outputs:surface",
            "/Root{look=a}",
            "/Root{look=a}Child/Mesh",
            "/A{v=}",
            "/A{v=x}{w=y-1.5|2}B",
            "../Shader.outputs:rgb",
            "../../A",
            "..",
            "Child",
            ".attr",
            "/A.rel[/B/C].attr",
            "/Über/Größe",
        ] {
            check(path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
        }
    }

    #[test]
    fn malformed_paths_are_refused() {
        for (path, problem) in [
            ("/World/Tri\"\n token x", "unexpected '\"' at character 10"),
            ("/World/ Tri", "expected a prim name: unexpected ' ' at character 7"),
            ("/World//Tri", "expected a prim name: unexpected '/' at character 7"),
            ("/World/Tri}", "unexpected '}' at character 10"),
            ("/World{v=a", "expected `}` closing a variant selection: unexpected end"),
            ("/World.a.", "expected a name: unexpected end"),
            ("/World.a[/B", "expected `]` closing a target path: unexpected end"),
            ("/1World", "expected a prim name: unexpected '1' at character 1"),
            ("/A/../B", "expected a prim name: unexpected '.' at character 3"),
        ] {
            assert_eq!(check(path).unwrap_err(), problem, "{path:?}");
        }
    }
}

/// `TEXT_CHECK_SURVEY=DIR cargo test --release -p ingest --lib path_syntax::survey -- --ignored
/// --nocapture` runs the text-layer checks on every text layer under DIR: any report there is
/// either a broken file or a false alarm to fix.
#[cfg(test)]
#[test]
#[ignore = "needs TEXT_CHECK_SURVEY=<folder of USD assets>"]
fn survey() {
    let mut stack = vec![std::path::PathBuf::from(std::env::var("TEXT_CHECK_SURVEY").unwrap())];
    let (mut files, mut problems) = (0, Vec::new());
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(dir).unwrap().flatten() {
            let path = entry.path();
            if path.is_dir() {
                stack.push(path);
                continue;
            }
            let Ok(text) = std::fs::read_to_string(&path) else { continue };
            if text.starts_with("#usda") {
                files += 1;
                if let Some(problem) = super::layer_fix::structural_problem(&text) {
                    problems.push(format!("{}: {problem}", path.display()));
                }
            }
        }
    }
    println!("{files} text layers, {} reported", problems.len());
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
