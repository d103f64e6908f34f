//! Camera objects: the 16 doubles of `.core` (Alembic apertures are in centimetres, focal
//! length in millimetres; USD apertures are in the focal length's units, tenths of a scene
//! unit by convention, so apertures are multiplied by ten as usdAbc does).

use super::archive::Compound;
use super::translate::{finite, Translator};

/// `.core` fields.
const FOCAL_LENGTH: usize = 0;
const HORIZONTAL_APERTURE: usize = 1;
const HORIZONTAL_OFFSET: usize = 2;
const VERTICAL_APERTURE: usize = 3;
const VERTICAL_OFFSET: usize = 4;
const LENS_SQUEEZE: usize = 5;
const NEAR: usize = 14;
const FAR: usize = 15;

impl Translator {
    /// Writes the camera's lens and clipping range.
    pub(super) fn camera(&mut self, p: &Compound) -> Result<(), String> {
        let core = self.sampler.blended(p, ".core")?.ok_or(".core is missing")?;
        if core.len() != 16 {
            return Err(format!(".core has {} values, a camera has 16", core.len()));
        }
        finite(".core", &core)?;
        if (core[LENS_SQUEEZE] - 1.0).abs() > 1e-9 {
            self.warnings
                .push((self.current.clone(), format!("lens squeeze ratio {} ignored", core[LENS_SQUEEZE])));
        }
        let f = |v: f64| (v as f32).to_string();
        self.layer.attr("token projection", "\"perspective\"", None);
        self.layer.attr("float focalLength", &f(core[FOCAL_LENGTH]), None);
        self.layer.attr("float horizontalAperture", &f(core[HORIZONTAL_APERTURE] * 10.0), None);
        self.layer.attr("float verticalAperture", &f(core[VERTICAL_APERTURE] * 10.0), None);
        self.layer.attr("float horizontalApertureOffset", &f(core[HORIZONTAL_OFFSET] * 10.0), None);
        self.layer.attr("float verticalApertureOffset", &f(core[VERTICAL_OFFSET] * 10.0), None);
        self.layer.attr("float2 clippingRange", &format!("({}, {})", f(core[NEAR]), f(core[FAR])), None);
        Ok(())
    }
}
