//! Tuple dimensions of typed values: `double3 a = (1, 2)` is a syntax error to usd-core ("Tuple
//! dimensions error for attribute of type double3") but the crate reads it, so a short translate
//! or point would compose as something the author never wrote.
//!
//! [`Declaration`] follows the tokens of an attribute declaration (`type[]? name(.timeSamples)?
//! =`); at its `=` it hands over a [`ValueShape`], which counts the components of every tuple of
//! the value (an array's elements, each time sample's) until the value's first term is complete.
//! Both lexing paths feed the same calls (the numeric fast path too), so they agree on the error.

/// Components a value of type `name` (a modern USDA type name) has: `Some([])` for a numeric
/// scalar (no tuple allowed), `Some([n])` for a vector or quaternion, `Some([n, n])` for a matrix;
/// `None` for a type this check leaves alone (strings, tokens, assets, dictionaries, ...).
fn dimensions(name: &str) -> Option<&'static [usize]> {
    const SCALARS: &[&str] =
        &["bool", "uchar", "int", "uint", "int64", "uint64", "half", "float", "double", "timecode"];
    if SCALARS.contains(&name) {
        return Some(&[]);
    }
    match name {
        "matrix2d" => return Some(&[2, 2]),
        "matrix3d" => return Some(&[3, 3]),
        "matrix4d" | "frame4d" => return Some(&[4, 4]),
        "quatd" | "quatf" | "quath" => return Some(&[4]),
        _ => {}
    }
    // `<base><n><precision?>`: double3, int2, point3f, color4h, texCoord2d, ...
    let (base, rest) = name.split_at(name.find(|c: char| c.is_ascii_digit())?);
    let n = rest.as_bytes()[0] - b'0';
    let precision = &rest[1..];
    let plain = ["double", "float", "half", "int"].contains(&base) && precision.is_empty();
    let role = ["point", "normal", "vector", "color", "texCoord"].contains(&base)
        && ["d", "f", "h"].contains(&precision);
    let n_ok = match base {
        "point" | "normal" | "vector" => n == 3,
        "color" => matches!(n, 3 | 4),
        "texCoord" => matches!(n, 2 | 3),
        _ => matches!(n, 2..=4),
    };
    if !(plain || role) || !n_ok {
        return None;
    }
    Some(match n {
        2 => &[2],
        3 => &[3],
        _ => &[4],
    })
}

/// Where an attribute declaration stands, token by token.
#[derive(Clone, Copy, Debug, Default)]
pub(super) enum Declaration<'a> {
    #[default]
    None,
    /// A type name the check knows (`point3f`), perhaps followed by `[]`.
    Typed { type_name: &'a str, dims: &'static [usize], bracket: bool },
    /// The type and the attribute's name (`point3f[] points`, `double3 a.timeSamples`).
    Named { type_name: &'a str, dims: &'static [usize], dot: bool },
}

impl<'a> Declaration<'a> {
    /// The state after significant token `token`; a [`ValueShape`] when it is the `=` that starts
    /// a checked value. `modern` maps a legacy type alias to its modern name.
    pub(super) fn step(
        self,
        token: &'a str,
        modern: impl Fn(&'a str) -> &'a str,
    ) -> (Self, Option<ValueShape<'a>>) {
        use Declaration::*;
        let is_name = |t: &str| t.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_');
        let next = match self {
            Typed { type_name, dims, bracket: false } if token == "[" => {
                Typed { type_name, dims, bracket: true }
            }
            Typed { type_name, dims, bracket: true } if token == "]" => {
                Typed { type_name, dims, bracket: false }
            }
            Typed { type_name, dims, bracket: false } if is_name(token) => {
                Named { type_name, dims, dot: false }
            }
            Named { type_name, dims, dot: false } if token == "." => Named { type_name, dims, dot: true },
            Named { type_name, dims, dot: true } if token == "timeSamples" => {
                Named { type_name, dims, dot: false }
            }
            Named { type_name, dims, dot: false } if token == "=" => {
                return (None, Some(ValueShape { type_name, dims, levels: Vec::new() }));
            }
            _ => match dimensions(modern(token)) {
                Some(dims) => Typed { type_name: modern(token), dims, bracket: false },
                Option::None => None,
            },
        };
        (next, Option::None)
    }
}

/// One open bracket of a value being checked.
#[derive(Clone, Debug)]
struct Level {
    paren: bool,
    commas: usize,
    any: bool,
}

/// The tuples of one typed value, counted as its tokens pass.
#[derive(Clone, Debug)]
pub(super) struct ValueShape<'a> {
    type_name: &'a str,
    dims: &'static [usize],
    levels: Vec<Level>,
}

/// What a token of a value is to [`ValueShape`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum ValueToken {
    Open { paren: bool },
    Close { paren: bool },
    Comma,
    Other,
}

impl ValueShape<'_> {
    /// Takes `token`; `Ok(false)` when the value is complete (the shape is done with), `Err` the
    /// problem of a tuple it closes.
    pub(super) fn take(&mut self, token: ValueToken) -> Result<bool, String> {
        match token {
            ValueToken::Open { paren } => {
                if let Some(top) = self.levels.last_mut() {
                    top.any = true;
                }
                self.levels.push(Level { paren, commas: 0, any: false });
            }
            ValueToken::Close { paren } => {
                self.closes_cleanly(paren)?;
                self.levels.pop();
                return Ok(!self.levels.is_empty());
            }
            ValueToken::Comma => {
                if let Some(top) = self.levels.last_mut() {
                    top.commas += 1;
                }
            }
            ValueToken::Other => match self.levels.last_mut() {
                Some(top) => top.any = true,
                // A scalar term (a number, `None`, a sign): the value is that term.
                None => return Ok(false),
            },
        }
        Ok(true)
    }

    /// Whether a closing bracket now would pass (the fast path asks before consuming one).
    pub(super) fn closes_cleanly(&self, paren: bool) -> Result<(), String> {
        let Some(top) = self.levels.last() else { return Ok(()) };
        if !(paren && top.paren) {
            return Ok(());
        }
        let nesting = self.levels.iter().filter(|l| l.paren).count();
        let components = if top.any { top.commas + 1 } else { 0 };
        let name = self.type_name;
        match self.dims.get(nesting - 1) {
            Some(&n) if n == components => Ok(()),
            Some(&n) => Err(format!(
                "a {name} {} takes {n} components, this tuple has {components} (usd-core: tuple dimensions error)",
                if nesting == 2 { "row" } else { "value" }
            )),
            None => Err(format!("a {name} value cannot hold a tuple here (usd-core: tuple dimensions error)")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::prepare;

    fn layer(statement: &str) -> String {
        format!("#usda 1.0\ndef Xform \"P\"\n{{\n    {statement}\n}}\n")
    }

    #[test]
    fn tuples_of_the_wrong_size_are_refused_as_usd_core_refuses_them() {
        // Each was checked against usd-core 26.11's Sdf.Layer.ImportFromString: all rejected.
        for (statement, problem) in [
            ("double3 a = (1, 2)", "line 4, column 22: a double3 value takes 3 components, this tuple has 2"),
            ("float2 a = (1, 2, 3)", "a float2 value takes 2 components, this tuple has 3"),
            ("point3f[] p = [(1, 2, 3), (1, 2)]", "a point3f value takes 3 components, this tuple has 2"),
            (
                "matrix4d m = ((1,0,0,0),(0,1,0,0),(0,0,1,0),(0,0,0))",
                "a matrix4d row takes 4 components, this tuple has 3",
            ),
            ("matrix2d m = ((1,0),(0,1),(0,0))", "a matrix2d value takes 2 components, this tuple has 3"),
            ("quatf q = (1, 0, 0)", "a quatf value takes 4 components, this tuple has 3"),
            ("double3 a.timeSamples = { 1: (1, 2, 3), 2: (1, 2) }", "a double3 value takes 3 components"),
            ("double a = (1, 2)", "a double value cannot hold a tuple here"),
            ("Vec3f v = (1, 2)", "a float3 value takes 3 components"),
            ("uniform color3f[] c = [(1, 1, 1), ()]", "a color3f value takes 3 components, this tuple has 0"),
        ] {
            let error = prepare(&layer(statement)).err().unwrap_or_else(|| panic!("accepted: {statement}"));
            assert!(error.contains(problem), "{statement}: {error}");
        }
    }

    #[test]
    fn well_formed_values_and_other_types_pass() {
        // Each is accepted by usd-core 26.11 too.
        for statement in [
            "double3 a = (1, 2, 3)",
            "point3f[] p = [(1, 2, 3), (-.5, 0, 1e3),]",
            "double3 a.timeSamples = { 1: (1, 2, 3), 2: None, }",
            "matrix4d m = ((1,0,0,0),(0,1,0,0),(0,0,1,0),(0,0,0,1))",
            "float a = 1 (\n        doc = \"metadata after a scalar is not a tuple\"\n    )",
            "double3 a = (1, 2, 3) (\n        customData = { double3 d = (4, 5, 6) }\n    )",
            "texCoord2f[] st = [(0, 0), (1, 0)]",
            "string s = \"(1, 2)\"",
            "float2 a.connect = </P.b>",
            "double3 a = None",
        ] {
            assert!(
                prepare(&layer(statement)).is_ok(),
                "{statement}: {:?}",
                prepare(&layer(statement)).err()
            );
        }
    }
}
