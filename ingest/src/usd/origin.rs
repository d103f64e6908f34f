//! The blob's origin in the stage's world space: ingest stores positions camera-relative.
//!
//! f32 positions are spaced 2⁻²³·|p| apart, and every ray-origin offset grows with that spacing:
//! at 1e5 units from the stage origin a unit sphere's contact shadow detaches and its lower half
//! shadows itself, at 1e7 it renders as a cube. What the pixels resolve finely is what lies near
//! the camera, so every world-space transform starts from `translate(−origin)` (in f64, before
//! anything becomes f32), with the origin near the render camera: geometry around the camera keeps
//! the precision it would have at the stage origin wherever the shot is placed. This is the
//! camera-relative rendering production renderers use; `SceneInfo::world_origin` records the
//! shift so that world-space outputs can add it back.
//!
//! The origin is the camera's position rounded to a multiple of [`GRID`]: a stage whose camera
//! lies within `GRID / 2` of its origin (per axis) is not moved, so its blob stays the bytes it was;
//! any other camera ends within `GRID / 2` of the blob's origin, where positions are spaced at most
//! 2⁻¹⁸ ≈ 3.8e-6 units apart. Multiples of [`GRID`] are exact in f32 and f64 up to 2³⁴ units.
//!
//! The camera is the one the stage's RenderSettings names, else the first Camera prim in
//! traversal order (the default camera's rule, [`crate::usd`]'s `finish`). Picking a different
//! camera would not be wrong, only less precise: the shift is exact, every position moves by it.
//! A stage without a camera keeps its origin (render frames it from its bounds).

use glam::{DMat4, DVec3};

use super::stage::Stage;
use super::xform;

/// The grid the origin snaps to (scene units).
pub(crate) const GRID: f64 = 64.0;

/// The world origin for a stage whose traversal region is `prims` (pre-order).
pub(crate) fn camera_origin(stage: &Stage, prims: &[String]) -> DVec3 {
    let Some(camera) = render_camera(stage, prims) else { return DVec3::ZERO };
    let position = world_from_local(stage, &camera).transform_point3(DVec3::ZERO);
    if !position.is_finite() {
        return DVec3::ZERO;
    }
    (position / GRID).round() * GRID
}

/// The camera RenderSettings names (through `renderSettingsPrimPath`, else the first
/// RenderSettings prim), else the first Camera prim.
fn render_camera(stage: &Stage, prims: &[String]) -> Option<String> {
    let named = stage.metadata("renderSettingsPrimPath").and_then(|v| v.as_str().map(str::to_string));
    let settings = named
        .filter(|n| !n.is_empty())
        .or_else(|| prims.iter().find(|p| stage.type_name(p) == "RenderSettings").cloned());
    let named_camera = settings
        .and_then(|s| stage.targets(&s, "camera").into_iter().next())
        .filter(|c| stage.type_name(c) == "Camera");
    named_camera.or_else(|| prims.iter().find(|p| stage.type_name(p) == "Camera").cloned())
}

/// `world_from_local` of `prim` from its ancestors' op stacks, as the traversal composes it.
/// An op that cannot be read counts as identity here; the traversal warns about it.
fn world_from_local(stage: &Stage, prim: &str) -> DMat4 {
    let mut world = DMat4::IDENTITY;
    let mut path = String::new();
    for name in prim.split('/').filter(|s| !s.is_empty()) {
        path.push('/');
        path.push_str(name);
        let Ok(local) = xform::read_local(stage, &path, &mut |_| {}) else { return world };
        world = if local.resets { local.matrix } else { world * local.matrix };
    }
    world
}

/// A warning when positions near the default camera are spaced more than [`MAX_SPACING_PIXELS`]
/// of a pixel apart at the nearest geometry (the camera's distance to the meshes' bounds, at
/// least its near clip): there, surfaces facet and ray offsets show. Camera-relative storage keeps
/// the camera within 32 units of the blob's origin, so only shots very close to their subject
/// (macro distances of a few thousandths of a unit) can meet it. An estimate: the nearest box may
/// hold geometry out of view.
pub(crate) fn precision_warning(scene: &crate::scene::Scene, width: u32) -> Option<(String, String)> {
    let camera = &scene.cameras[scene.default_camera?];
    let (mut lo, mut hi) = (glam::Vec3::splat(f32::INFINITY), glam::Vec3::splat(f32::NEG_INFINITY));
    for mesh in &scene.meshes {
        let [a, b] = mesh.world_bounds();
        (lo, hi) = (lo.min(a), hi.max(b));
    }
    if !(lo.cmple(hi).all() && lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let eye = camera.world_from_camera.w_axis.truncate();
    let distance = (eye.clamp(lo, hi) - eye).length().max(camera.clipping_range[0].max(0.0));
    // Coordinates of the nearest geometry are about |eye| + distance per axis.
    let magnitude = eye.abs().max_element() + distance;
    let spacing = f64::from(magnitude).max(f64::MIN_POSITIVE).log2().floor().exp2() * f64::from(f32::EPSILON);
    let view_width = if camera.orthographic {
        0.1 * f64::from(camera.horizontal_aperture)
    } else {
        f64::from(distance) * f64::from(camera.horizontal_aperture) / f64::from(camera.focal_length)
    };
    let pixel = view_width / f64::from(width.max(1));
    let pixels = spacing / pixel;
    (pixel > 0.0 && pixels > MAX_SPACING_PIXELS).then(|| {
        (
            camera.path.clone(),
            format!(
                "f32 positions {distance:.3e} units from this camera are spaced {spacing:.2e} apart, {pixels:.2} of a pixel at {width} pixels wide: expect faceting and self-shadowing there (model the subject larger, in smaller units)"
            ),
        )
    })
}

/// Position spacing, in pixels at the nearest geometry, beyond which [`precision_warning`] warns.
pub(crate) const MAX_SPACING_PIXELS: f64 = 0.25;
