//! Frame sequences: frame ranges (`A-B[xStep]`) and file-name patterns with a frame field (`#`
//! runs, `%04d`), shared by `ingest --frames`, `render --frames` and the farm script (through
//! `render frames`), so that every tool numbers and names frames the same way.
//!
//! ```
//! use blob::sequence::{FramePattern, FrameRange};
//! let range: FrameRange = "1-5x2".parse().unwrap();
//! assert_eq!(range.frames(), vec![1, 3, 5]);
//! let pattern = FramePattern::new("shot.####.blob");
//! assert_eq!(pattern.path(3), std::path::PathBuf::from("shot.0003.blob"));
//! // A pattern without a frame field names one file: a range of several frames is refused.
//! assert!(blob::sequence::frame_paths(&FramePattern::new("shot.blob"), &range).is_err());
//! ```
//!
//! Padding follows Houdini and Nuke: a run of `#` pads the frame number with zeros to the run's
//! length (`#` alone is unpadded), `%0Nd` to N digits, `%d` not at all; a negative frame keeps
//! its sign inside the width, as `printf` does (`%04d` of −3 is `-003`). A longer number is never
//! cut (`##` of 123 is `123`).

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

/// Most frames one range may hold (a typo like `1-10000000` is refused, not expanded).
pub const MAX_FRAMES: usize = 1_000_000;

/// An inclusive range of integer frames with a positive step: `A-B[xStep]`, or one frame `N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameRange {
    /// First frame.
    pub first: i64,
    /// Last frame asked for (the last frame rendered is the last `first + k·step` not past it).
    pub last: i64,
    /// Step between frames, at least 1.
    pub step: i64,
}

/// What is wrong with a frame range or pattern.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum SequenceError {
    /// The text is not `A-B[xStep]` or `N`.
    Syntax {
        /// The range as given.
        range: String,
        /// What was expected.
        why: String,
    },
    /// The last frame is before the first.
    Backwards {
        /// The range as given.
        range: String,
    },
    /// The step is zero or negative.
    Step {
        /// The range as given.
        range: String,
    },
    /// More than [`MAX_FRAMES`] frames.
    TooMany {
        /// The range as given.
        range: String,
        /// How many frames it holds.
        count: u64,
    },
    /// A pattern with no frame field for a range of several frames: every frame would be written
    /// to (or read from) the same file.
    NoFrameField {
        /// The pattern.
        pattern: String,
        /// Frames in the range.
        count: usize,
    },
    /// A pattern with more than one frame field.
    SeveralFrameFields {
        /// The pattern.
        pattern: String,
    },
}

impl fmt::Display for SequenceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SequenceError::Syntax { range, why } => write!(f, "frame range {range:?}: {why}"),
            SequenceError::Backwards { range } => {
                write!(f, "frame range {range:?}: the last frame is before the first")
            }
            SequenceError::Step { range } => write!(f, "frame range {range:?}: the step must be at least 1"),
            SequenceError::TooMany { range, count } => {
                write!(f, "frame range {range:?} holds {count} frames, more than {MAX_FRAMES}")
            }
            SequenceError::NoFrameField { pattern, count } => write!(
                f,
                "{pattern:?} has no frame field (`#`, `####` or `%04d`) for a range of {count} frames: every frame would be the same file"
            ),
            SequenceError::SeveralFrameFields { pattern } => {
                write!(f, "{pattern:?} has more than one frame field (`#` runs, `%0Nd`); give exactly one")
            }
        }
    }
}

impl std::error::Error for SequenceError {}

impl FrameRange {
    /// The frames, first to last.
    pub fn frames(&self) -> Vec<i64> {
        (self.first..=self.last).step_by(self.step as usize).collect()
    }

    /// How many frames the range holds.
    pub fn len(&self) -> usize {
        ((self.last - self.first) / self.step + 1) as usize
    }

    /// Never true: a range holds at least its first frame.
    pub fn is_empty(&self) -> bool {
        false
    }
}

impl FromStr for FrameRange {
    type Err = SequenceError;

    /// `A-B`, `A-BxS` or `N`; `A` and `B` may be negative (`-10--2`, `-5-5`).
    fn from_str(text: &str) -> Result<Self, SequenceError> {
        let s = text.trim();
        let syntax = |why: &str| SequenceError::Syntax { range: text.to_string(), why: why.to_string() };
        let (span, step) = match s.split_once(['x', 'X']) {
            Some((span, step)) => (span, Some(step)),
            None => (s, None),
        };
        let number = |v: &str| -> Result<i64, SequenceError> {
            let v = v.trim();
            let digits = v.strip_prefix('-').unwrap_or(v);
            if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
                return Err(syntax("expected A-B, A-BxSTEP or N with integer frames"));
            }
            v.parse::<i64>().map_err(|_| syntax("a frame number is too large"))
        };
        // The separating `-` is the first one after the first character (which may be A's sign).
        let split = span.char_indices().skip(1).find(|&(_, c)| c == '-').map(|(i, _)| i);
        let (first, last) = match split {
            Some(i) => (number(&span[..i])?, number(&span[i + 1..])?),
            None => {
                let n = number(span)?;
                (n, n)
            }
        };
        let step = match step {
            Some(v) => {
                let v = v.trim();
                if v.starts_with('-') {
                    return Err(SequenceError::Step { range: text.to_string() });
                }
                number(v)?
            }
            None => 1,
        };
        if step < 1 {
            return Err(SequenceError::Step { range: text.to_string() });
        }
        if last < first {
            return Err(SequenceError::Backwards { range: text.to_string() });
        }
        let count = ((last as i128 - first as i128) / step as i128 + 1) as u64;
        if count > MAX_FRAMES as u64 {
            return Err(SequenceError::TooMany { range: text.to_string(), count });
        }
        Ok(FrameRange { first, last, step })
    }
}

impl fmt::Display for FrameRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.first == self.last, self.step) {
            (true, _) => write!(f, "{}", self.first),
            (false, 1) => write!(f, "{}-{}", self.first, self.last),
            (false, step) => write!(f, "{}-{}x{step}", self.first, self.last),
        }
    }
}

/// A file name with at most one frame field: a run of `#`, `%d` or `%0Nd`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FramePattern {
    text: String,
    /// Byte range of the field in `text` and its zero-padded width.
    field: Option<(std::ops::Range<usize>, usize)>,
    /// More than one field was found (refused by [`FramePattern::check`]).
    several: bool,
}

impl FramePattern {
    /// Reads the frame field of `pattern` (none is allowed: the pattern then names one file).
    pub fn new(pattern: impl Into<String>) -> Self {
        let text = pattern.into();
        let bytes = text.as_bytes();
        let mut fields = Vec::new();
        let mut i = 0;
        while i < bytes.len() {
            if bytes[i] == b'#' {
                let start = i;
                while i < bytes.len() && bytes[i] == b'#' {
                    i += 1;
                }
                let width = if i - start == 1 { 0 } else { i - start };
                fields.push((start..i, width));
                continue;
            }
            if bytes[i] == b'%' {
                // `%d`, `%Nd` or `%0Nd`.
                let mut j = i + 1;
                while j < bytes.len() && bytes[j].is_ascii_digit() {
                    j += 1;
                }
                if j < bytes.len() && bytes[j] == b'd' {
                    let width = text[i + 1..j].parse::<usize>().unwrap_or(0).min(32);
                    fields.push((i..j + 1, width));
                    i = j + 1;
                    continue;
                }
            }
            i += 1;
        }
        let several = fields.len() > 1;
        FramePattern { text, field: fields.into_iter().next(), several }
    }

    /// The pattern as given.
    pub fn as_str(&self) -> &str {
        &self.text
    }

    /// Whether the pattern has a frame field.
    pub fn has_frame_field(&self) -> bool {
        self.field.is_some()
    }

    /// The pattern is usable for `frames` frames: at most one field, and one when `frames > 1`.
    pub fn check(&self, frames: usize) -> Result<(), SequenceError> {
        if self.several {
            return Err(SequenceError::SeveralFrameFields { pattern: self.text.clone() });
        }
        if frames > 1 && self.field.is_none() {
            return Err(SequenceError::NoFrameField { pattern: self.text.clone(), count: frames });
        }
        Ok(())
    }

    /// The file of `frame` (the pattern itself when it has no frame field).
    pub fn path(&self, frame: i64) -> PathBuf {
        match &self.field {
            None => PathBuf::from(&self.text),
            Some((range, width)) => {
                let number = format!("{frame:0width$}");
                PathBuf::from(format!("{}{number}{}", &self.text[..range.start], &self.text[range.end..]))
            }
        }
    }
}

/// Every frame of `range` with its file from `pattern`, after [`FramePattern::check`].
pub fn frame_paths(pattern: &FramePattern, range: &FrameRange) -> Result<Vec<(i64, PathBuf)>, SequenceError> {
    pattern.check(range.len())?;
    Ok(range.frames().into_iter().map(|f| (f, pattern.path(f))).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn range(s: &str) -> Result<FrameRange, SequenceError> {
        s.parse()
    }

    #[test]
    fn ranges_parse_with_steps_signs_and_single_frames() {
        assert_eq!(range("1-24").unwrap().frames(), (1..=24).collect::<Vec<_>>());
        assert_eq!(range("1-10x3").unwrap().frames(), vec![1, 4, 7, 10]);
        assert_eq!(range("1-11x3").unwrap().frames(), vec![1, 4, 7, 10], "the last frame is not forced");
        assert_eq!(range("1-11x3").unwrap().len(), 4);
        assert_eq!(range("7").unwrap().frames(), vec![7]);
        assert_eq!(range("-3-1").unwrap().frames(), vec![-3, -2, -1, 0, 1]);
        assert_eq!(range("-5--3").unwrap().frames(), vec![-5, -4, -3]);
        assert_eq!(range(" 2-4X2 ").unwrap().frames(), vec![2, 4]);
        assert_eq!(range("1-10x3").unwrap().to_string(), "1-10x3");
        assert_eq!(range("3-3").unwrap().to_string(), "3");
    }

    #[test]
    fn bad_ranges_are_refused_with_what_is_wrong() {
        assert_eq!(range("10-1"), Err(SequenceError::Backwards { range: "10-1".into() }));
        assert_eq!(range("1-10x0"), Err(SequenceError::Step { range: "1-10x0".into() }));
        assert_eq!(range("1-10x-2"), Err(SequenceError::Step { range: "1-10x-2".into() }));
        for bad in ["", "a-b", "1-", "1.5-3", "1-3x", "1--", "x2", "1-2-3"] {
            let e = range(bad).unwrap_err();
            assert!(matches!(e, SequenceError::Syntax { .. }), "{bad:?}: {e:?}");
            assert!(e.to_string().contains("expected A-B"), "{bad:?}: {e}");
        }
        let e = range("1-99999999").unwrap_err();
        assert_eq!(e.to_string(), "frame range \"1-99999999\" holds 99999999 frames, more than 1000000");
        assert!(range("1-99999999999999999999").unwrap_err().to_string().contains("too large"));
        assert_eq!(
            range("10-1").unwrap_err().to_string(),
            "frame range \"10-1\": the last frame is before the first"
        );
    }

    #[test]
    fn patterns_pad_as_houdini_and_nuke_do() {
        let p = |s: &str, f: i64| FramePattern::new(s).path(f).to_string_lossy().into_owned();
        assert_eq!(p("out.#.blob", 7), "out.7.blob");
        assert_eq!(p("out.####.blob", 7), "out.0007.blob");
        assert_eq!(p("out.##.blob", 123), "out.123.blob", "never cut");
        assert_eq!(p("out.%04d.blob", 42), "out.0042.blob");
        assert_eq!(p("out.%d.blob", 42), "out.42.blob");
        assert_eq!(p("out.%4d.blob", 42), "out.0042.blob");
        assert_eq!(p("out.%04d.blob", -3), "out.-003.blob", "printf keeps the sign inside the width");
        assert_eq!(p("f#/beauty.exr", 12), "f12/beauty.exr", "the field may sit in a folder name");
        assert_eq!(p("plain.blob", 9), "plain.blob");
        assert_eq!(p("100%.blob", 9), "100%.blob", "a % that is no field stays");
    }

    #[test]
    fn patterns_need_one_field_for_several_frames() {
        let several = FramePattern::new("a.#.b.####.blob");
        assert_eq!(
            several.check(1).unwrap_err().to_string(),
            "\"a.#.b.####.blob\" has more than one frame field (`#` runs, `%0Nd`); give exactly one"
        );
        let plain = FramePattern::new("a.blob");
        assert!(plain.check(1).is_ok(), "one frame may go to a plain name");
        let e = frame_paths(&plain, &range("1-3").unwrap()).unwrap_err();
        assert_eq!(e, SequenceError::NoFrameField { pattern: "a.blob".into(), count: 3 });
        let paths = frame_paths(&FramePattern::new("s/%03d.blob"), &range("8-12x2").unwrap()).unwrap();
        let names: Vec<String> = paths.iter().map(|(f, p)| format!("{f}:{}", p.display())).collect();
        assert_eq!(names, ["8:s/008.blob", "10:s/010.blob", "12:s/012.blob"]);
    }
}
