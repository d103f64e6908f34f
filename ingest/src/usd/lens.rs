//! A UsdGeomCamera's thin lens: `fStop`, `focusDistance` and RenderMan's polygonal aperture.
//!
//! Units, as the UsdGeomCamera schema defines them ("Lens and Filmback Units"): `focalLength` and the
//! apertures are in tenths of a scene unit, `focusDistance` in scene units, `fStop` is a pure number.
//! Every one of them is therefore a length *in the stage's own units*: `metersPerUnit` does not enter
//! (a centimetre stage's `focalLength = 50` is a 50 mm lens, a metre stage authors the same lens as
//! 0.5), so nothing here converts through it. Render turns the fields into a thin lens of radius
//! `0.1 · focalLength / (2 · fStop)` scene units focused on the plane `focusDistance` in front.
//!
//! `fStop = 0` (USD's fallback) is a pinhole. A lens that cannot be built is a warning naming the prim
//! and attribute and renders as a pinhole: the image is still the one the stage would give without
//! depth of field, never an aborted ingest over one camera's lens.
//!
//! Polygonal apertures: the blade count and rotation HdPrman reads from a camera,
//! `ri:apertureNSides` (0 round, else ≥ 3 blades) and `ri:apertureAngle` (degrees). The other two
//! RenderMan shape controls, `ri:apertureRoundness` and `ri:apertureDensity`, are not modelled and
//! warn when authored away from their zero default.

use super::{Reader, UsdError};
use crate::scene::Lens;
use blob::{MAX_APERTURE_BLADES, MAX_F_STOP};

impl Reader<'_> {
    /// The lens of camera `path` (a pinhole for an orthographic camera: it has no aperture to blur).
    pub(super) fn read_lens(&mut self, path: &str, orthographic: bool) -> Result<Lens, UsdError> {
        let Some(f_stop) = self.f64(path, "fStop")? else { return Ok(Lens::default()) };
        if f_stop == 0.0 {
            return Ok(Lens::default());
        }
        if !(f_stop > 0.0 && f_stop <= f64::from(MAX_F_STOP)) {
            self.warn(
                path,
                format!("fStop {f_stop} is not a positive f-number up to {MAX_F_STOP}; depth of field off"),
            );
            return Ok(Lens::default());
        }
        if orthographic {
            self.warn(
                path,
                format!("fStop {f_stop} ignored: an orthographic camera has no lens; it stays sharp"),
            );
            return Ok(Lens::default());
        }
        let focus_distance = self.f64(path, "focusDistance")?.unwrap_or(0.0);
        if !(focus_distance > 0.0 && focus_distance <= 1e12) {
            self.warn(
                path,
                format!(
                    "focusDistance {focus_distance} with fStop {f_stop}: the thin lens needs a positive, finite focus distance; depth of field off"
                ),
            );
            return Ok(Lens::default());
        }
        let mut lens =
            Lens { f_stop: f_stop as f32, focus_distance: focus_distance as f32, ..Lens::default() };
        let blades = self.f64(path, "ri:apertureNSides")?.unwrap_or(0.0);
        if blades != 0.0 {
            if blades.fract() == 0.0 && (3.0..=f64::from(MAX_APERTURE_BLADES)).contains(&blades) {
                lens.aperture_blades = blades as u32;
            } else {
                self.warn(
                    path,
                    format!("ri:apertureNSides {blades} is not 0 or a whole 3..={MAX_APERTURE_BLADES}; a round aperture is used"),
                );
            }
        }
        let angle = self.f64(path, "ri:apertureAngle")?.unwrap_or(0.0);
        if angle.abs() <= 360.0 {
            lens.aperture_rotation = angle as f32;
        } else {
            self.warn(path, format!("ri:apertureAngle {angle} is not within ±360 degrees; 0 is used"));
        }
        for ignored in ["ri:apertureRoundness", "ri:apertureDensity"] {
            if let Some(v) = self.f64(path, ignored)?.filter(|&v| v != 0.0) {
                self.warn(path, format!("{ignored} {v} ignored (straight blades, uniform density)"));
            }
        }
        Ok(lens)
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::{Lens, Scene};
    use crate::usd::{load, LoadOptions};

    fn load_cameras(cameras: &str) -> Scene {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("lens.usda");
        std::fs::write(&root, format!("#usda 1.0\n(\n    metersPerUnit = 0.01\n)\n\n{cameras}\n")).unwrap();
        load(&root, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
    }

    fn lens_of<'a>(scene: &'a Scene, path: &str) -> &'a Lens {
        &scene.cameras.iter().find(|c| c.path == path).unwrap_or_else(|| panic!("no camera {path}")).lens
    }

    /// The one warning on `prim`, which must name `needle`.
    fn warning<'a>(scene: &'a Scene, prim: &str) -> &'a str {
        let on: Vec<_> = scene.warnings.iter().filter(|w| w.prim == prim).collect();
        assert_eq!(on.len(), 1, "warnings on {prim}: {:?}", scene.warnings);
        &on[0].message
    }

    #[test]
    fn fstop_focus_distance_and_renderman_blades_are_read() {
        let scene = load_cameras(
            r#"def Camera "Pinhole" {}
def Camera "Lens" {
    float fStop = 2.8
    float focusDistance = 350
    float focalLength = 35
}
def Camera "Hexagon" {
    float fStop = 1.4
    float focusDistance = 12.5
    int ri:apertureNSides = 6
    float ri:apertureAngle = 15
}"#,
        );
        assert_eq!(*lens_of(&scene, "/Pinhole"), Lens::default(), "USD's fallback fStop 0 is a pinhole");
        // Units as authored: metersPerUnit 0.01 does not rescale focusDistance (scene units) or
        // focalLength (tenths of a scene unit: 35 mm on a centimetre stage).
        assert_eq!(
            *lens_of(&scene, "/Lens"),
            Lens { f_stop: 2.8, focus_distance: 350.0, aperture_blades: 0, aperture_rotation: 0.0 }
        );
        assert_eq!(scene.cameras[1].focal_length, 35.0);
        assert_eq!(
            *lens_of(&scene, "/Hexagon"),
            Lens { f_stop: 1.4, focus_distance: 12.5, aperture_blades: 6, aperture_rotation: 15.0 }
        );
        assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
        let data = crate::pack::pack_scene(&scene, &Default::default()).unwrap();
        let hexagon = &data.cameras[2];
        assert_eq!(
            (hexagon.f_stop, hexagon.focus_distance, hexagon.aperture_blades, hexagon.aperture_rotation),
            (1.4, 12.5, 6, 15.0)
        );
    }

    #[test]
    fn lenses_that_cannot_be_built_warn_naming_prim_and_attribute_and_render_sharp() {
        let scene = load_cameras(
            r#"def Camera "Negative" {
    float fStop = -2
    float focusDistance = 10
}
def Camera "NotANumber" {
    float fStop = nan
    float focusDistance = 10
}
def Camera "NoFocus" {
    float fStop = 2
}
def Camera "BehindTheLens" {
    float fStop = 2
    float focusDistance = -3
}
def Camera "Ortho" {
    token projection = "orthographic"
    float fStop = 2
    float focusDistance = 10
}
def Camera "TwoBlades" {
    float fStop = 4
    float focusDistance = 10
    int ri:apertureNSides = 2
    float ri:apertureAngle = 720
    float ri:apertureRoundness = 0.5
}"#,
        );
        for (prim, needle) in [
            ("/Negative", "fStop -2 is not a positive f-number up to 1000000; depth of field off"),
            ("/NotANumber", "fStop NaN is not a positive f-number"),
            ("/NoFocus", "focusDistance 0 with fStop 2: the thin lens needs a positive, finite focus distance; depth of field off"),
            ("/BehindTheLens", "focusDistance -3 with fStop 2"),
            ("/Ortho", "fStop 2 ignored: an orthographic camera has no lens; it stays sharp"),
        ] {
            let message = warning(&scene, prim);
            assert!(message.contains(needle), "{prim}: {message}");
            assert_eq!(*lens_of(&scene, prim), Lens::default(), "{prim} renders as a pinhole");
        }
        let messages: Vec<_> =
            scene.warnings.iter().filter(|w| w.prim == "/TwoBlades").map(|w| w.message.as_str()).collect();
        assert_eq!(
            messages,
            [
                "ri:apertureNSides 2 is not 0 or a whole 3..=64; a round aperture is used",
                "ri:apertureAngle 720 is not within ±360 degrees; 0 is used",
                "ri:apertureRoundness 0.5 ignored (straight blades, uniform density)",
            ]
        );
        assert_eq!(
            *lens_of(&scene, "/TwoBlades"),
            Lens { f_stop: 4.0, focus_distance: 10.0, aperture_blades: 0, aperture_rotation: 0.0 }
        );
    }
}
