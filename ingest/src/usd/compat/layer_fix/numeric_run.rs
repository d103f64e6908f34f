//! The fast path of [`super::prepare`] through the bulk of a mesh-heavy layer: runs of numbers,
//! commas, parentheses, signs and white space (`[(0.25, -1, 3e-2), (4, 5, 6)]`).
//!
//! The general lexer hands out one [`super::Token`] at a time to the structural check and the
//! rewrite, about 17 ns a token; a 3 MB layer of points and indices has a million of them, and
//! the crate waits for its preparation before parsing it. This loop consumes the same tokens a
//! byte at a time. It takes only whole tokens that need no rewrite and whose only structural
//! effect is the nesting depth, and stops at the first token of any other kind (a number spelled
//! `.5`, `5.` or `1.e3`, a name, a string, a bracket, a comment, nesting past
//! [`super::MAX_NESTING`]), which the general lexer then reads from its first byte.

use super::tuple_arity::ValueToken;
use super::{Kind, Lexer, Structure, MAX_NESTING};

/// Consumes the run of plain numeric tokens at the lexer's position, updating what the
/// structural check tracks (the depth, the last two significant tokens) as the general path
/// would have; consumes nothing if the lexer does not stand at such a run.
pub(super) fn skip<'a>(tokens: &mut Lexer<'a>, structure: &mut Structure<'a>) {
    let text = tokens.text;
    let b = text.as_bytes();
    let start = tokens.at;
    let mut i = start;
    let mut last = tokens.last;
    let mut depth = structure.depth;
    // The last two significant tokens consumed, nearest first, and how many there were (up to 2).
    let (mut nearest, mut second) = (0..0, 0..0);
    let mut significant = 0;
    let digits_from = |mut j: usize| {
        while j < b.len() && b[j].is_ascii_digit() {
            j += 1;
        }
        j
    };
    while let Some(&c) = b.get(i) {
        let token = match c {
            b'0'..=b'9' => {
                // digits [. digits] [e [+-] digits], a digit on both sides of the dot: the
                // general lexer's number, spelled as the crate reads it.
                let mut j = digits_from(i);
                if b.get(j) == Some(&b'.') {
                    if !b.get(j + 1).is_some_and(u8::is_ascii_digit) {
                        break;
                    }
                    j = digits_from(j + 1);
                }
                if matches!(b.get(j), Some(b'e' | b'E')) {
                    let sign = usize::from(matches!(b.get(j + 1), Some(b'+' | b'-')));
                    if !b.get(j + 1 + sign).is_some_and(u8::is_ascii_digit) {
                        break;
                    }
                    j = digits_from(j + 1 + sign);
                }
                Some((Kind::Number, j))
            }
            b' ' | b'\t' | b'\r' | b'\n' => None,
            b',' | b'-' | b'+' | b')' => {
                if c == b')' {
                    // A tuple of the wrong size is the general path's to report, with its place.
                    if structure.shape.as_ref().is_some_and(|s| s.closes_cleanly(true).is_err()) {
                        break;
                    }
                    depth = depth.saturating_sub(1);
                }
                Some((Kind::Punct, i + 1))
            }
            b'(' if depth < MAX_NESTING => {
                depth += 1;
                Some((Kind::Punct, i + 1))
            }
            _ => break,
        };
        if let (Some(_), Some(shape)) = (token, structure.shape.as_mut()) {
            let value_token = match c {
                b'(' => ValueToken::Open { paren: true },
                b')' => ValueToken::Close { paren: true },
                b',' => ValueToken::Comma,
                _ => ValueToken::Other,
            };
            // Checked above: a closing parenthesis that reaches here closes cleanly.
            if !shape.take(value_token).unwrap_or(false) {
                structure.shape = None;
            }
        }
        if token.is_some() {
            structure.declaration = Default::default();
        }
        match token {
            Some((kind, end)) => {
                second = std::mem::replace(&mut nearest, i..end);
                significant = (significant + 1).min(2);
                last = Some(kind);
                i = end;
            }
            None => {
                last = Some(Kind::Space);
                i += 1;
            }
        }
    }
    if i == start {
        return;
    }
    tokens.at = i;
    tokens.last = last;
    structure.depth = depth;
    structure.before = match significant {
        0 => structure.before,
        1 => (&text[nearest], structure.before.0),
        _ => (&text[nearest], &text[second]),
    };
}

#[cfg(test)]
mod tests {
    use super::super::{prepare_with, Lexing};
    use super::*;

    /// Where [`skip`] leaves a lexer started at `from` in `text`.
    fn skipped_to(text: &str, from: usize) -> usize {
        let mut tokens = Lexer { text, at: from, last: Some(Kind::Punct) };
        let mut structure = Structure::new(text);
        skip(&mut tokens, &mut structure);
        tokens.at
    }

    #[test]
    fn a_run_of_plain_numbers_is_consumed_whole() {
        let points = "[(0.25, -1, 3e-2), (4, 5.5E+3, 6)]\n";
        assert_eq!(skipped_to(points, 1), points.find(']').unwrap());
        let indices = "[0, 1, 2,\n 3, 4]";
        assert_eq!(skipped_to(indices, 1), indices.find(']').unwrap());
    }

    #[test]
    fn a_token_the_general_lexer_must_see_is_left_from_its_first_byte() {
        for (text, stop) in [
            ("(1, .5)", "(1, ".len()),
            ("(1, 5.)", "(1, ".len()),
            ("(1, 1.e3)", "(1, ".len()),
            ("(1, 1e)", "(1, ".len()),
            ("(1, 2x)", "(1, 2".len()),
            ("(1, 2) # c", "(1, 2) ".len()),
            ("1, \"s\"", "1, ".len()),
        ] {
            assert_eq!(skipped_to(text, 0), stop, "{text}");
        }
    }

    /// `text` prepared along both paths gives the same text, asset paths and problem.
    fn agree(text: &str) {
        let along = |lexing| prepare_with(text, lexing).map(|l| (l.text.into_owned(), l.asset_paths));
        assert_eq!(along(Lexing::NumericRuns), along(Lexing::General), "{text:?}");
    }

    #[test]
    fn the_fast_path_prepares_as_the_general_lexer() {
        let deep = format!("#usda 1.0\nfloat3 a = {}1{}\n", "(".repeat(300), ")".repeat(300));
        for text in [
            "#usda 1.0\ndef Mesh \"M\" {\n point3f[] points = [(-.5, 0, 1.), (1e3, -2E-2, 0.5)]\n int[] i = [0,1,2]\n}\n",
            "def \"A\" {\n float a = 1 def \"B\" {}\n float2 b = (1, 2) over \"C\" ( doc = \"x\" ) {}\n}\n",
            "double d.timeSamples = { 1: 2.5, 2: .5 }\nasset f = \"x.png\"\nrel r = </A/B>\n",
            &deep,
        ] {
            agree(text);
        }
        // Random texts over the alphabet where the two paths part: digits, dots, exponents,
        // signs, brackets, names, strings, comments, asset and path delimiters.
        let alphabet = b"0123456789..eE+-(((),,  \n[]{}ax=\"#@<>";
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for _ in 0..20_000 {
            let len = (next() % 40) as usize;
            let text: String =
                (0..len).map(|_| alphabet[(next() % alphabet.len() as u64) as usize] as char).collect();
            agree(&text);
        }
    }
}
