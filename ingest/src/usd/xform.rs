//! UsdGeomXformable: the xformOp stack of one prim → its local transform.
//!
//! USD composes row vectors (`world = local * parent`); glam uses column vectors, so every matrix
//! here is the transpose of USD's. For `xformOpOrder = [A, B, C]` the local matrix is `A * B * C`
//! (the first op is outermost, the last is applied to the points first).

use glam::{DMat4, DQuat, DVec3};

use super::stage::{Stage, Value};
use super::UsdError;

/// Result of reading a prim's op stack.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LocalXform {
    /// `parent_from_local`, or `world_from_local` when `resets` is set.
    pub matrix: DMat4,
    /// `!resetXformStack!` was the first op: ignore the parent transform.
    pub resets: bool,
}

/// Reads `xformOpOrder` and the ops it names. Unknown op types and ops without a value are
/// reported through `warn` and skipped (treated as identity).
pub(crate) fn read_local(
    stage: &Stage,
    prim: &str,
    warn: &mut dyn FnMut(String),
) -> Result<LocalXform, UsdError> {
    read_local_at(stage, prim, stage.time(), warn)
}

/// [`read_local`] with every op evaluated at time code `time` (each op's value interpolated as USD
/// interpolates it, then the ops composed: UsdGeomXformable::GetLocalTransformation at `time`).
pub(crate) fn read_local_at(
    stage: &Stage,
    prim: &str,
    time: f64,
    warn: &mut dyn FnMut(String),
) -> Result<LocalXform, UsdError> {
    let mut local = LocalXform { matrix: DMat4::IDENTITY, resets: false };
    let order = match stage.attr(prim, "xformOpOrder")? {
        Some(Value::StrArray(order)) => order,
        _ => return Ok(local),
    };
    for entry in &order {
        if entry == "!resetXformStack!" {
            // Only meaningful as the first op; USD ignores everything before it otherwise.
            local = LocalXform { matrix: DMat4::IDENTITY, resets: true };
            continue;
        }
        let (inverted, name) = match entry.strip_prefix("!invert!") {
            Some(name) => (true, name),
            None => (false, entry.as_str()),
        };
        let Some(kind) = name.strip_prefix("xformOp:").map(|rest| rest.split(':').next().unwrap_or(rest))
        else {
            warn(format!("xformOpOrder entry {entry} is not an xformOp; ignored"));
            continue;
        };
        let Some(value) = stage.attr_at(prim, name, time)? else {
            warn(format!("xformOp {name} is in xformOpOrder but has no value; ignored"));
            continue;
        };
        let Some(mut m) = op_matrix(kind, &value) else {
            warn(format!("xformOp {name} of type {kind} could not be read; ignored"));
            continue;
        };
        if kind == "transform" && m.row(3) != glam::DVec4::W {
            // USD's fourth column (our fourth row) makes the matrix projective. Points go through it
            // with the homogeneous divide, as usd-core's GfMatrix4d::Transform does; normals and
            // lights only see its affine part.
            warn(format!(
                "xformOp {name} is projective (last column {:?}); points are divided through",
                m.row(3)
            ));
        }
        if inverted {
            m = m.inverse();
        }
        local.matrix *= m;
    }
    Ok(local)
}

/// The matrix (column-vector convention) of one op of type `kind` (`translate`, `rotateXYZ`, ...).
pub(crate) fn op_matrix(kind: &str, value: &Value) -> Option<DMat4> {
    let vec3 = |v: &Value| v.as_tuple::<3>().map(DVec3::from_array);
    match kind {
        "translate" => Some(DMat4::from_translation(vec3(value)?)),
        "scale" => match value {
            Value::Scalar(s) => Some(DMat4::from_scale(DVec3::splat(*s))),
            _ => Some(DMat4::from_scale(vec3(value)?)),
        },
        "rotateX" | "rotateY" | "rotateZ" => {
            let angle = value.as_f64()?;
            Some(axis_rotation(kind.as_bytes()[6], angle))
        }
        "orient" => match value {
            Value::Quat([x, y, z, w]) => Some(DMat4::from_quat(DQuat::from_xyzw(*x, *y, *z, *w).normalize())),
            _ => None,
        },
        "transform" => match value {
            // USD's row-major, row-vector matrix read as columns is its transpose: exactly glam's.
            Value::Matrix(m) => Some(DMat4::from_cols_array(m)),
            _ => None,
        },
        _ => {
            // rotateABC: rotate about A first, then B, then C → R_C * R_B * R_A.
            let axes = kind.strip_prefix("rotate")?.as_bytes();
            if axes.len() != 3 {
                return None;
            }
            let angles = vec3(value)?;
            let mut m = DMat4::IDENTITY;
            for &axis in axes {
                let angle = match axis {
                    b'X' => angles.x,
                    b'Y' => angles.y,
                    b'Z' => angles.z,
                    _ => return None,
                };
                m = axis_rotation(axis, angle) * m;
            }
            Some(m)
        }
    }
}

fn axis_rotation(axis: u8, degrees: f64) -> DMat4 {
    let r = degrees.to_radians();
    match axis {
        b'X' => DMat4::from_rotation_x(r),
        b'Y' => DMat4::from_rotation_y(r),
        _ => DMat4::from_rotation_z(r),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotate_xyz_is_x_first() {
        let m = op_matrix("rotateXYZ", &Value::Tuple(vec![90.0, 0.0, 90.0])).unwrap();
        // X by 90 takes +Y to +Z; Z by 90 then leaves +Z. Y axis → +Z.
        let y = m.transform_vector3(DVec3::Y);
        assert!((y - DVec3::Z).length() < 1e-12, "{y}");
        // +X: X-rotation leaves it, Z by 90 takes it to +Y.
        let x = m.transform_vector3(DVec3::X);
        assert!((x - DVec3::Y).length() < 1e-12, "{x}");
    }

    #[test]
    fn transform_op_translation_in_last_row() {
        let mut m = [0.0; 16];
        m[0] = 1.0;
        m[5] = 1.0;
        m[10] = 1.0;
        m[15] = 1.0;
        m[12] = 1.0;
        m[13] = 2.0;
        m[14] = 3.0;
        let mat = op_matrix("transform", &Value::Matrix(m)).unwrap();
        assert_eq!(mat.transform_point3(DVec3::ZERO), DVec3::new(1.0, 2.0, 3.0));
    }
}
