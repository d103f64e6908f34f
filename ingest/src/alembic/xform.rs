//! Xform objects: the operation stack (`.ops`, one byte per operation) and its channel values
//! (`.vals`) composed into one local matrix; `.inherits = false` resets the parent transform.

use glam::{DMat4, DVec3};

use super::archive::Compound;
use super::translate::{finite, Translator};
use super::usda::matrix;

/// Channels of an operation: its type is the high nibble of the op byte.
fn channels(op: u8) -> Result<usize, String> {
    Ok(match op >> 4 {
        0 | 1 => 3, // scale, translate
        2 => 4,     // rotate: axis, angle in degrees
        3 => 16,    // matrix
        4..=6 => 1, // rotateX/Y/Z in degrees
        t => return Err(format!("unknown xform operation type {t}")),
    })
}

/// The local matrix (column vectors) of `ops` with channel values `vals`: the first operation
/// is outermost, as in USD's `xformOpOrder`.
pub(super) fn compose(ops: &[u8], vals: &[f64]) -> Result<DMat4, String> {
    let needed: usize = ops.iter().map(|&op| channels(op)).sum::<Result<_, _>>()?;
    if needed != vals.len() {
        return Err(format!(".ops need {needed} channel values but .vals has {}", vals.len()));
    }
    let mut m = DMat4::IDENTITY;
    let mut v = vals;
    for &op in ops {
        let n = channels(op)?;
        let (c, rest) = v.split_at(n);
        v = rest;
        let rotate = |axis: DVec3, degrees: f64| {
            let axis = axis.try_normalize().ok_or("rotation about a zero axis")?;
            Ok::<_, String>(DMat4::from_axis_angle(axis, degrees.to_radians()))
        };
        let op = match op >> 4 {
            0 => DMat4::from_scale(DVec3::new(c[0], c[1], c[2])),
            1 => DMat4::from_translation(DVec3::new(c[0], c[1], c[2])),
            2 => rotate(DVec3::new(c[0], c[1], c[2]), c[3])?,
            // Imath is row-major with row vectors: its rows are glam's columns.
            3 => DMat4::from_cols_array(c.try_into().expect("16 channels")),
            4 => rotate(DVec3::X, c[0])?,
            5 => rotate(DVec3::Y, c[0])?,
            _ => rotate(DVec3::Z, c[0])?,
        };
        m *= op;
    }
    Ok(m)
}

impl Translator {
    /// Writes the Xform's local transform.
    pub(super) fn xform(&mut self, p: &Compound) -> Result<(), String> {
        let ops = self.sampler.held(p, ".ops")?.unwrap_or_default();
        let vals = self.sampler.blended(p, ".vals")?.unwrap_or_default();
        finite(".vals", &vals)?;
        let ops: Vec<u8> = ops.into_iter().map(|o| o as u8).collect();
        let local = compose(&ops, &vals)?;
        let inherits = self.sampler.held(p, ".inherits")?.is_none_or(|v| v.first() != Some(&0.0));
        // USD rows (row vectors) are glam's columns.
        let c = local.to_cols_array_2d();
        self.layer.attr("matrix4d xformOp:transform", &matrix(&c), None);
        let order = if inherits {
            "[\"xformOp:transform\"]"
        } else {
            "[\"!resetXformStack!\", \"xformOp:transform\"]"
        };
        self.layer.attr("uniform token[] xformOpOrder", order, None);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn operations_compose_outermost_first() {
        // translate (1, 2, 3), then rotateY 90°, then scale 2: x̂ → scale → (2,0,0) → rotate →
        // (0,0,−2) → translate → (1, 2, 1).
        let ops = [0x10, 0x50, 0x00];
        let vals = [1.0, 2.0, 3.0, 90.0, 2.0, 2.0, 2.0];
        let m = compose(&ops, &vals).unwrap();
        let p = m.transform_point3(DVec3::X);
        assert!((p - DVec3::new(1.0, 2.0, 1.0)).length() < 1e-12, "{p}");
        // A matrix op in Imath layout: translation in the last row.
        let mut t = [0.0; 16];
        (t[0], t[5], t[10], t[15], t[12], t[13], t[14]) = (1.0, 1.0, 1.0, 1.0, 4.0, 5.0, 6.0);
        let m = compose(&[0x30], &t).unwrap();
        assert_eq!(m.transform_point3(DVec3::ZERO), DVec3::new(4.0, 5.0, 6.0));
        assert!(compose(&[0x30], &t[..15]).unwrap_err().contains("need 16"));
        assert!(compose(&[0x70], &[]).is_err());
        assert_eq!(compose(&[], &[]).unwrap(), DMat4::IDENTITY);
    }
}
