//! Motion the renderer does not draw yet, reported instead of dropped in silence.
//!
//! Motion blur is not rendered: every attribute is evaluated at the one time code of the ingest
//! (`--frame`, else `startTimeCode`) and the shutter is instantaneous. Whether that ignores anything
//! depends on the shutter: UsdGeomCamera's fallback `shutter:open = shutter:close = 0` asks for no
//! blur, so time-sampled transforms on such a stage are an animation evaluated at its frame, exactly
//! as authored. Only when some camera opens its shutter (`shutter:close > shutter:open`) does the
//! stage ask for blur; then the camera's shutter and every prim's authored motion — time-sampled
//! xformOps and points, `velocities`, `accelerations`, `angularVelocities` — get one warning each,
//! naming the prim and the attribute. The scan over the stage's prims runs only in that case, so a
//! stage without a shutter pays nothing for it.

use super::{Reader, UsdError};

/// Attributes that author motion without time samples (UsdGeomPointBased, UsdGeomPointInstancer).
const MOTION_ATTRIBUTES: [&str; 3] = ["velocities", "accelerations", "angularVelocities"];

impl Reader<'_> {
    /// Warns about each camera's open shutter and, if any is open, every prim's authored motion.
    pub(super) fn warn_ignored_motion(&mut self) -> Result<(), UsdError> {
        let mut open = false;
        let cameras: Vec<String> = self.scene.cameras.iter().map(|c| c.path.clone()).collect();
        for camera in &cameras {
            let shutter_open = self.f64(camera, "shutter:open")?.unwrap_or(0.0);
            let shutter_close = self.f64(camera, "shutter:close")?.unwrap_or(0.0);
            if shutter_close > shutter_open {
                self.warn(
                    camera,
                    format!(
                        "shutter:open {shutter_open} / shutter:close {shutter_close}: motion blur is not rendered (an instantaneous shutter at time {})",
                        self.stage.time()
                    ),
                );
                open = true;
            }
        }
        if !open {
            return Ok(());
        }
        let time = self.stage.time();
        for prim in self.prims.clone() {
            for name in self.stage.property_names(&prim) {
                let timed = name.starts_with("xformOp:") || name == "points";
                let samples = if timed { self.stage.time_sample_count(&prim, &name) } else { 0 };
                if samples > 1 {
                    self.warn(
                        &prim,
                        format!("{name} has {samples} time samples: motion blur is not rendered (evaluated at time {time})"),
                    );
                } else if MOTION_ATTRIBUTES.contains(&name.as_str()) {
                    self.warn(&prim, format!("{name} authored: motion blur is not rendered"));
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::Scene;
    use crate::usd::{load, LoadOptions};

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

    fn messages(scene: &Scene) -> Vec<(String, String)> {
        scene.warnings.iter().map(|w| (w.prim.clone(), w.message.clone())).collect()
    }

    #[test]
    fn an_open_shutter_warns_about_every_motion_it_does_not_blur() {
        let scene = load_text(&format!(
            r#"def Camera "Cam" {{
    double shutter:open = -0.25
    double shutter:close = 0.25
}}
{MOVING}"#
        ));
        let messages = messages(&scene);
        for expected in [
            ("/Cam", "shutter:open -0.25 / shutter:close 0.25: motion blur is not rendered (an instantaneous shutter at time 1)"),
            ("/Mover", "xformOp:translate has 2 time samples: motion blur is not rendered (evaluated at time 1)"),
            ("/Mover/Dust", "velocities authored: motion blur is not rendered"),
        ] {
            assert!(
                messages.iter().any(|(p, m)| p == expected.0 && m == expected.1),
                "missing {expected:?} in {messages:?}"
            );
        }
        assert_eq!(messages.len(), 3, "one warning per prim and attribute: {messages:?}");
    }

    #[test]
    fn a_closed_shutter_asks_for_no_blur_and_warns_nothing() {
        for camera in [
            r#"def Camera "Cam" {}"#,
            r#"def Camera "Cam" { double shutter:open = 0.5
double shutter:close = 0.5 }"#,
        ] {
            let scene = load_text(&format!("{camera}\n{MOVING}"));
            assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
        }
    }
}
