//! Motion blur's input: the shutter, and the transform motion of gprims, with a warning for every
//! authored motion that is not rendered.
//!
//! The shutter is the camera's `shutter:open` / `shutter:close` (time codes relative to the
//! frame, UsdGeomCamera; the fallback `0, 0` is instantaneous: no blur). A RenderSettings'
//! `disableMotionBlur` closes its camera's shutter, as UsdRenderSettingsBase defines it.
//!
//! Only when some camera opens its shutter (`shutter:close > shutter:open`) does the stage ask for
//! blur, and only then does this pass scan the stage, so a stage without a shutter pays nothing
//! for it and keeps its blob bytes. Then, for each gprim drawn in world space (not inside an
//! instance) whose prim or an ancestor has time-sampled xformOps, the keys are the shutter's open
//! and close, the frame itself (so a render at time 0 draws the frame's geometry exactly), and
//! every sample time those ops author inside the union of the cameras' shutters,
//! and each key is the prim's world transform there, evaluated as UsdGeomXformable does (each op's
//! value interpolated, then the ops composed). The renderer interpolates the key *matrices*
//! linearly between keys, not a decomposed translation-rotation-scale: exact for translation and
//! for anything sampled at every key, a chord (a slightly shrunken in-between) for a rotation
//! between two keys, and what lets a box over the keys bound the motion (`blob::instances`).
//! Each key is stored as `world_from_stored`, relative to the geometry's world position at the
//! frame, so a gprim whose keys all equal the frame's placement stays still.
//!
//! Cameras move the same way: a camera under time-sampled xformOps gets keys at the same times
//! (`scene::Camera::motion`), and each camera ray is placed at its time.
//!
//! Everything authored that still is not rendered gets one warning naming the prim and the
//! attribute: time-sampled xformOps of prims no moving gprim or camera consumed (lights, curves,
//! gprims inside instances), time-sampled `points`, and `velocities`, `accelerations`,
//! `angularVelocities`. A prim whose xformOps move some gprim is not reported even where the same
//! ops also move a light or curves below it (those are drawn at the frame).

use super::{xform, Reader, UsdError};
use crate::scene::{MotionKey, TransformMotion};
use glam::DMat4;
use std::collections::{HashMap, HashSet};

/// Attributes that author motion without time samples (UsdGeomPointBased, UsdGeomPointInstancer).
const MOTION_ATTRIBUTES: [&str; 3] = ["velocities", "accelerations", "angularVelocities"];

/// A motion's transform keys and the time-sampled xformOps they were taken from.
type KeysAndOps = (Vec<MotionKey>, Vec<String>);

impl Reader<'_> {
    /// The shutter of camera `path`: `[open, close]`, or closed at 0 (with a warning) when the
    /// authored interval is not finite, ordered and within ±[`blob::MAX_SHUTTER`].
    pub(super) fn read_shutter(&mut self, path: &str) -> Result<[f32; 2], UsdError> {
        let open = self.f64(path, "shutter:open")?.unwrap_or(0.0);
        let close = self.f64(path, "shutter:close")?.unwrap_or(0.0);
        let limit = f64::from(blob::MAX_SHUTTER);
        let ok = |t: f64| t.is_finite() && t.abs() <= limit;
        if !(ok(open) && ok(close) && open <= close) {
            self.warn(
                path,
                format!("shutter:open {open} / shutter:close {close} is not an interval within ±{limit} time codes; the shutter is closed (no motion blur)"),
            );
            return Ok([0.0; 2]);
        }
        Ok([open as f32, close as f32])
    }

    /// Gives moving gprims their transform motion over the cameras' shutters and warns about every
    /// authored motion that is not rendered (see the module docs). Runs after subdivision surfaces
    /// are diced, so the diced meshes carry the motion of their prims.
    pub(super) fn read_motion(&mut self) -> Result<(), UsdError> {
        let open: Vec<[f32; 2]> =
            self.scene.cameras.iter().map(|c| c.shutter).filter(|[o, c]| c > o).collect();
        if open.is_empty() {
            return Ok(());
        }
        let lo = open.iter().map(|s| s[0]).fold(f32::INFINITY, f32::min);
        let hi = open.iter().map(|s| s[1]).fold(f32::NEG_INFINITY, f32::max);
        let frame = self.stage.time();
        // Per prim: its time-sampled xformOps (computed once, shared by every gprim below it).
        let mut timed_ops: HashMap<String, Vec<String>> = HashMap::new();
        let mut consumed: HashSet<String> = HashSet::new();
        let shutter = Shutter { lo, hi, frame };
        for m in 0..self.scene.meshes.len() {
            let mesh = &self.scene.meshes[m];
            if mesh.instance_index().is_some() || mesh.triangle_count() == 0 {
                continue;
            }
            let path = mesh.path.clone();
            let Some((keys, moving_prims)) = self.transform_keys(&path, &shutter, &mut timed_ops)? else {
                continue;
            };
            consumed.extend(moving_prims);
            if still(&keys) {
                continue;
            }
            let mesh = &self.scene.meshes[m];
            if mesh.triangle_materials.iter().any(|&t| crate::pack::emits(&self.scene.materials[t as usize]))
            {
                self.warn(
                    &path,
                    "time-sampled xformOps on this mesh or its ancestors: an emissive mesh is drawn at the frame (light sampling is world-space), its motion is not rendered",
                );
                continue;
            }
            self.scene.meshes[m].motion = Some(TransformMotion { keys });
        }
        for c in 0..self.scene.cameras.len() {
            let path = self.scene.cameras[c].path.clone();
            let Some((keys, moving_prims)) = self.transform_keys(&path, &shutter, &mut timed_ops)? else {
                continue;
            };
            consumed.extend(moving_prims);
            if !still(&keys) {
                self.scene.cameras[c].motion = Some(TransformMotion { keys });
            }
        }
        self.warn_ignored_motion(&consumed);
        Ok(())
    }

    /// The transform keys of the prim at `path` over `shutter`, and the prims of its chain whose
    /// xformOps are time-sampled; `None` when none are (or, with a warning, when they author more
    /// samples inside the shutter than a motion may have keys). Keys at the shutter's open and close,
    /// the frame itself (exactly the identity, so time 0 draws the stored placement bit for bit) and
    /// every sample time of those ops inside the shutter, each `world_from_stored`: the world
    /// transform there relative to the frame's.
    fn transform_keys(
        &mut self,
        path: &str,
        shutter: &Shutter,
        timed_ops: &mut HashMap<String, Vec<String>>,
    ) -> Result<Option<KeysAndOps>, UsdError> {
        let Shutter { lo, hi, frame } = *shutter;
        let chain = ancestors_and_self(path);
        // The frame is always a key, so time 0 (a closed shutter, `--no-motion-blur`) draws the
        // stored geometry exactly, whatever the shutter.
        let (lo, hi) = (lo.min(0.0), hi.max(0.0));
        let mut times = vec![f64::from(lo), 0.0, f64::from(hi)];
        let mut moving_prims = Vec::new();
        for prim in &chain {
            let ops = timed_ops.entry(prim.clone()).or_insert_with(|| {
                self.stage
                    .property_names(prim)
                    .into_iter()
                    .filter(|n| n.starts_with("xformOp:") && self.stage.time_sample_count(prim, n) > 1)
                    .collect()
            });
            for op in ops.iter() {
                let inside =
                    self.stage.sample_times_in(prim, op, frame + f64::from(lo), frame + f64::from(hi));
                times.extend(inside.into_iter().map(|t| t - frame));
            }
            if !ops.is_empty() {
                moving_prims.push(prim.clone());
            }
        }
        if moving_prims.is_empty() {
            return Ok(None);
        }
        times.sort_by(f64::total_cmp);
        // Keys closer than f32 can tell apart would not be strictly increasing in the blob.
        times.dedup_by(|a, b| (*a as f32) == (*b as f32));
        if times.len() > blob::MAX_MOTION_KEYS as usize {
            self.warn(
                path,
                format!(
                    "{} transform samples inside the shutter, more than {}: motion blur is not rendered",
                    times.len(),
                    blob::MAX_MOTION_KEYS
                ),
            );
            return Ok(None);
        }
        let stored = self.world_at(&chain, frame)?;
        let stored_inverse = stored.inverse();
        let mut keys = Vec::with_capacity(times.len());
        for &t in &times {
            // At the frame the stored geometry is where it is: exactly the identity.
            let world_from_stored =
                if t == 0.0 { DMat4::IDENTITY } else { self.world_at(&chain, frame + t)? * stored_inverse };
            keys.push(MotionKey { time: t as f32, world_from_stored });
        }
        Ok(Some((keys, moving_prims)))
    }

    /// The world transform of the last prim of `chain` (root first) at time code `time`, relative
    /// to the scene's world origin as the stored geometry is (`crate::usd::origin`).
    fn world_at(&mut self, chain: &[String], time: f64) -> Result<DMat4, UsdError> {
        let mut world = self.root_from_world;
        for prim in chain {
            // The walk already reported unreadable ops at the frame; other times repeat them.
            let local = xform::read_local_at(self.stage, prim, time, &mut |_| {})?;
            world = if local.resets { self.root_from_world * local.matrix } else { world * local.matrix };
        }
        Ok(world)
    }

    /// One warning per authored motion the renderer does not draw; the xformOps of `consumed`
    /// prims move gprims and are not reported.
    fn warn_ignored_motion(&mut self, consumed: &HashSet<String>) {
        let time = self.stage.time();
        for prim in self.prims.clone() {
            for name in self.stage.property_names(&prim) {
                let xform_op = name.starts_with("xformOp:");
                if xform_op && consumed.contains(&prim) {
                    continue;
                }
                let timed = xform_op || name == "points";
                let samples = if timed { self.stage.time_sample_count(&prim, &name) } else { 0 };
                if samples > 1 {
                    let what = if xform_op {
                        "this motion is not rendered (only meshes outside instances and cameras move)"
                    } else {
                        "deformation motion blur is not rendered"
                    };
                    self.warn(
                        &prim,
                        format!("{name} has {samples} time samples: {what} (evaluated at time {time})"),
                    );
                } else if MOTION_ATTRIBUTES.contains(&name.as_str()) {
                    self.warn(&prim, format!("{name} authored: motion blur is not rendered"));
                }
            }
        }
    }
}

/// The union of the open cameras' shutters around frame time code `frame`.
#[derive(Clone, Copy)]
struct Shutter {
    lo: f32,
    hi: f32,
    frame: f64,
}

/// Keys that all equal the identity: the prim's ops are time-sampled but it does not move.
fn still(keys: &[MotionKey]) -> bool {
    keys.windows(2).all(|w| w[0].world_from_stored == w[1].world_from_stored)
        && keys[0].world_from_stored.abs_diff_eq(DMat4::IDENTITY, 1e-12)
}

/// `/A`, `/A/B`, `/A/B/C` for `/A/B/C`.
fn ancestors_and_self(path: &str) -> Vec<String> {
    path.match_indices('/')
        .map(|(i, _)| i)
        .skip(1)
        .map(|i| path[..i].to_string())
        .chain(std::iter::once(path.to_string()))
        .filter(|p| !p.is_empty() && p != "/")
        .collect()
}

#[cfg(test)]
mod tests {
    use crate::scene::Scene;
    use crate::usd::{load, LoadOptions};
    use glam::{DMat4, DVec3};

    fn load_text(body: &str) -> Scene {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("motion.usda");
        std::fs::write(
            &root,
            format!("#usda 1.0\n(\n    startTimeCode = 1\n    endTimeCode = 2\n)\n\n{body}\n"),
        )
        .unwrap();
        load(&root, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
    }

    const MOVING: &str = r#"def Xform "Mover" {
    double3 xformOp:translate.timeSamples = { 1: (0, 0, 0), 2: (1, 0, 0) }
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Points "Dust" {
        point3f[] points = [(0, 0, 0), (1, 0, 0)]
        vector3f[] velocities = [(0, 1, 0), (0, 1, 0)]
        float[] widths = [0.1, 0.1]
    }
}
def Mesh "Still" {
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
}"#;

    /// A triangle under an Xform translating +x by 1 per time code, and a rotation of 90° per time
    /// code on its parent, sampled at 1, 1.1 and 2.
    const SLIDING: &str = r#"def Xform "Rig" {
    float xformOp:rotateZ.timeSamples = { 1: 0.0, 1.1: 9.0, 2: 90.0 }
    uniform token[] xformOpOrder = ["xformOp:rotateZ"]
    def Xform "Slider" {
        double3 xformOp:translate.timeSamples = { 0: (-1, 0, 0), 2: (1, 0, 0) }
        uniform token[] xformOpOrder = ["xformOp:translate"]
        def Mesh "Tri" {
            uniform token subdivisionScheme = "none"
            int[] faceVertexCounts = [3]
            int[] faceVertexIndices = [0, 1, 2]
            point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
        }
    }
}"#;

    fn messages(scene: &Scene) -> Vec<(String, String)> {
        scene.warnings.iter().map(|w| (w.prim.clone(), w.message.clone())).collect()
    }

    fn camera(open: f64, close: f64) -> String {
        format!(
            "def Camera \"Cam\" {{\n    double shutter:open = {open}\n    double shutter:close = {close}\n}}"
        )
    }

    #[test]
    fn an_open_shutter_warns_about_every_motion_it_does_not_blur() {
        let scene = load_text(&format!("{}\n{MOVING}", camera(-0.25, 0.25)));
        assert_eq!(scene.cameras[0].shutter, [-0.25, 0.25]);
        let messages = messages(&scene);
        for expected in [
            ("/Mover", "xformOp:translate has 2 time samples: this motion is not rendered (only meshes outside instances and cameras move) (evaluated at time 1)"),
            ("/Mover/Dust", "velocities authored: motion blur is not rendered"),
        ] {
            assert!(
                messages.iter().any(|(p, m)| p == expected.0 && m == expected.1),
                "missing {expected:?} in {messages:?}"
            );
        }
        assert_eq!(messages.len(), 2, "one warning per prim and attribute: {messages:?}");
        assert!(scene.meshes.iter().all(|m| m.motion.is_none()), "the still mesh stays still");
    }

    #[test]
    fn a_closed_shutter_asks_for_no_blur_and_warns_nothing() {
        for camera in [
            r#"def Camera "Cam" {}"#.to_string(),
            camera(0.5, 0.5),
            format!("{}\ndef RenderSettings \"Settings\" {{\n    rel camera = </Cam>\n    uniform bool disableMotionBlur = 1\n}}", camera(-0.25, 0.25)),
        ] {
            let scene = load_text(&format!("{camera}\n{MOVING}\n{SLIDING}"));
            assert!(scene.warnings.is_empty(), "{camera}: {:?}", scene.warnings);
            assert!(scene.meshes.iter().all(|m| m.motion.is_none()), "{camera}");
            assert_eq!(scene.cameras[0].shutter[0], scene.cameras[0].shutter[1], "{camera}");
        }
    }

    #[test]
    fn a_shutter_that_is_not_an_interval_is_closed_with_a_warning() {
        let scene = load_text(&camera(0.5, -0.5));
        assert_eq!(scene.cameras[0].shutter, [0.0, 0.0]);
        assert_eq!(
            messages(&scene),
            [(
                "/Cam".to_string(),
                "shutter:open 0.5 / shutter:close -0.5 is not an interval within ±10000 time codes; the shutter is closed (no motion blur)".to_string()
            )]
        );
    }

    /// Keys at open, close and every sample time of the gprim's own and its ancestors' ops inside
    /// the shutter, each the world transform there relative to the frame's.
    #[test]
    fn transform_motion_keys_are_the_authored_times_inside_the_shutter() {
        let scene = load_text(&format!("{}\n{SLIDING}", camera(-0.5, 0.5)));
        let tri = scene.meshes.iter().find(|m| m.path == "/Rig/Slider/Tri").expect("the triangle");
        let motion = tri.motion.as_ref().expect("the triangle moves");
        let times: Vec<f32> = motion.keys.iter().map(|k| k.time).collect();
        // Frame 1: shutter [0.5, 1.5] holds the rotation samples 1 and 1.1 (the translation's
        // samples 0 and 2 are outside).
        assert_eq!(times, [-0.5, 0.0, 0.1, 0.5]);
        // World at time T: rotateZ(angle(T)) · translate(T − 1, 0, 0); the frame's is the identity.
        let world = |angle_degrees: f64, x: f64| {
            DMat4::from_rotation_z(angle_degrees.to_radians())
                * DMat4::from_translation(DVec3::new(x, 0.0, 0.0))
        };
        // Before the first rotation sample its value is held (0°); at 1.5 it is 9 + 81·(0.4/0.9).
        let expected =
            [world(0.0, -0.5), world(0.0, 0.0), world(9.0, 0.1), world(9.0 + 81.0 * 0.4 / 0.9, 0.5)];
        for (key, want) in motion.keys.iter().zip(expected) {
            assert!(key.world_from_stored.abs_diff_eq(want, 1e-9), "{key:?} against {want}");
        }
        assert!(
            !scene.warnings.iter().any(|w| w.prim.starts_with("/Rig")),
            "rendered motion is not warned about: {:?}",
            scene.warnings
        );
        // The stored geometry is the frame's: the triangle's own points.
        assert_eq!(tri.positions[1], glam::Vec3::X);
    }

    /// Far from the stage origin the keys move the camera-relative geometry: each is the stage
    /// key conjugated by the origin's translation, so a rotating mesh turns about its own pivot.
    #[test]
    fn transform_motion_keys_are_relative_to_the_world_origin() {
        let far_camera = camera(-0.5, 0.5).replace(
            "double shutter:close = 0.5",
            "double shutter:close = 0.5\n    double3 xformOp:translate = (1000, 0, 0)\n    uniform token[] xformOpOrder = [\"xformOp:translate\"]",
        );
        let scene = load_text(&format!("{far_camera}\n{SLIDING}"));
        assert_eq!(scene.world_origin, DVec3::new(1024.0, 0.0, 0.0));
        let tri = scene.meshes.iter().find(|m| m.path == "/Rig/Slider/Tri").expect("the triangle");
        let motion = tri.motion.as_ref().expect("the triangle moves");
        let shift = DMat4::from_translation(-scene.world_origin);
        let stage_key =
            DMat4::from_rotation_z(9.0f64.to_radians()) * DMat4::from_translation(DVec3::new(0.1, 0.0, 0.0));
        let want = shift * stage_key * shift.inverse();
        assert!(
            motion.keys[2].world_from_stored.abs_diff_eq(want, 1e-9),
            "{:?} against {want}",
            motion.keys[2]
        );
        assert_eq!(tri.positions[1], glam::Vec3::new(1.0 - 1024.0, 0.0, 0.0));
    }

    /// A camera under a translating Xform gets keys at the shutter's ends, the frame and the
    /// authored samples inside, each its world transform there relative to the frame's; its
    /// xformOps are not reported.
    #[test]
    fn camera_motion_keys_are_the_authored_times_inside_the_shutter() {
        let rig = format!(
            "def Xform \"Dolly\" {{\n    double3 xformOp:translate.timeSamples = {{ 1: (0, 0, 0), 1.2: (1, 0, 0), 2: (2, 0, 0) }}\n    uniform token[] xformOpOrder = [\"xformOp:translate\"]\n    {}\n}}",
            camera(-0.5, 0.5)
        );
        let scene = load_text(&rig);
        let cam = &scene.cameras[0];
        assert_eq!(cam.path, "/Dolly/Cam");
        let motion = cam.motion.as_ref().expect("the camera moves");
        let times: Vec<f32> = motion.keys.iter().map(|k| k.time).collect();
        assert_eq!(times, [-0.5, 0.0, 0.2, 0.5]);
        // x(T): held at 0 before frame 1, 5 per time code to 1.2, then 1.25 per time code.
        for (key, x) in motion.keys.iter().zip([0.0, 0.0, 1.0, 1.0 + 1.25 * 0.3]) {
            let want = DMat4::from_translation(DVec3::new(x, 0.0, 0.0));
            assert!(key.world_from_stored.abs_diff_eq(want, 1e-9), "{key:?} against {want}");
        }
        assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
        // A closed shutter asks for no keys.
        let scene = load_text(&rig.replace("shutter:close = 0.5", "shutter:close = -0.5"));
        assert!(scene.cameras[0].motion.is_none());
    }

    #[test]
    fn an_emissive_moving_mesh_stays_at_the_frame_with_a_warning() {
        let lamp = SLIDING.replace(
            "uniform token subdivisionScheme = \"none\"",
            "uniform token subdivisionScheme = \"none\"\n            rel material:binding = </Glow>",
        );
        let glow = r#"def Material "Glow" {
    token outputs:surface.connect = </Glow/Surface.outputs:surface>
    def Shader "Surface" {
        uniform token info:id = "UsdPreviewSurface"
        color3f inputs:emissiveColor = (5, 5, 5)
        token outputs:surface
    }
}"#;
        let scene = load_text(&format!("{}\n{lamp}\n{glow}", camera(-0.5, 0.5)));
        let tri = scene.meshes.iter().find(|m| m.path == "/Rig/Slider/Tri").expect("the triangle");
        assert!(tri.motion.is_none(), "light sources stay at the frame");
        assert_eq!(
            messages(&scene),
            [(
                "/Rig/Slider/Tri".to_string(),
                "time-sampled xformOps on this mesh or its ancestors: an emissive mesh is drawn at the frame (light sampling is world-space), its motion is not rendered".to_string()
            )]
        );
    }
}
