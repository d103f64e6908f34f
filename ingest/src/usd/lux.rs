//! UsdLux lights, UsdGeomCamera and UsdRenderSettings.

use std::path::PathBuf;

use glam::Vec3;
use openusd::ar;

use super::collection::{ExpansionRule, Membership};
use super::stage::Value;
use super::{fallback, Inherited, Reader, UsdError};
use crate::dicing::DEFAULT_WIDTH;
use crate::scene::{Camera, Light, LightKind, LightSet, SceneTexture, TextureData};

/// A light's two UsdLuxLightAPI collections: which gprims it lights (`collection:lightLink`) and
/// which gprims block its shadow rays (`collection:shadowLink`). Both fall back to
/// `includeRoot = true` (UsdLux's schema), so an unauthored light links everything.
#[derive(Clone, Debug)]
pub(super) struct LightLinks {
    light: Membership,
    shadow: Membership,
}

/// Largest image side ingest dices for (a RenderSettings resolution, or the image a camera's
/// apertures imply): render's per-axis limit.
pub(crate) const MAX_RESOLUTION_SIDE: u32 = 65_535;
/// Most image pixels ingest dices for: 2^28, a 16k × 16k frame. Subdivision dicing budgets
/// triangles per pixel and curves are split per pixel, so an unbounded resolution is an
/// unbounded tessellation (1 × 2147483647 grew ingest's memory without bound).
pub(crate) const MAX_RESOLUTION_PIXELS: u64 = 1 << 28;

impl Reader<'_> {
    /// A light input: `inputs:<name>` (current UsdLux) wins over plain `<name>` (pre-2021 assets).
    fn light_input(&self, path: &str, name: &str) -> Result<Option<Value>, UsdError> {
        match self.stage.attr(path, &format!("inputs:{name}"))? {
            Some(v) => Ok(Some(v)),
            None => self.stage.attr(path, name),
        }
    }

    fn light_f32(&self, path: &str, name: &str, fallback: f32) -> Result<f32, UsdError> {
        Ok(self.light_input(path, name)?.and_then(|v| v.as_f64()).map_or(fallback, |v| v as f32))
    }

    fn light_bool(&self, path: &str, name: &str, fallback: bool) -> Result<bool, UsdError> {
        Ok(self.light_input(path, name)?.and_then(|v| v.as_f64()).map_or(fallback, |v| v != 0.0))
    }

    fn light_has_texture(&self, path: &str) -> Result<bool, UsdError> {
        let file = self.light_input(path, "texture:file")?;
        Ok(file.as_ref().and_then(Value::as_str).is_some_and(|f| !f.is_empty()))
    }

    /// The baked lat-long map of a dome light's `texture:file`, or `None` (uniform colour): none
    /// authored, texture baking off (listing only), or, with a warning naming the prim and the file,
    /// a format other than `automatic`/`latlong`, a file that cannot be found or read. With the
    /// texture index comes the factor the light's radiance must carry (see [`fit_half_float_range`]).
    fn dome_texture(&mut self, path: &str) -> Result<Option<(u32, f32)>, UsdError> {
        let attr = if self.stage.attr(path, "inputs:texture:file")?.is_some() {
            "inputs:texture:file"
        } else {
            "texture:file"
        };
        let Some(asset) = self.stage.attr(path, attr)?.and_then(|v| v.as_str().map(str::to_string)) else {
            return Ok(None);
        };
        if asset.is_empty() || !self.bake_textures {
            return Ok(None);
        }
        let format = self.light_input(path, "texture:format")?;
        let format = format.as_ref().and_then(Value::as_str).unwrap_or("automatic");
        if !matches!(format, "automatic" | "latlong") {
            self.warn(
                path,
                format!("dome texture {asset:?}: texture:format {format:?} not supported yet (automatic and latlong are); using its uniform color"),
            );
            return Ok(None);
        }
        let layer = self.stage.authoring_layer(path, attr);
        let file = match super::texture_files::resolve_asset(&layer, &asset) {
            Ok(file) => file,
            Err(why) => {
                self.warn(path, format!("dome texture {asset:?}: {why}; using its uniform color"));
                return Ok(None);
            }
        };
        let color_space = texture::ColorSpace::Auto;
        if let Some(i) =
            self.scene.textures.iter().position(|t| t.path == file && t.color_space == color_space)
        {
            return Ok(Some((i as u32, 1.0)));
        }
        let options = texture::BakeOptions { color_space, ..texture::BakeOptions::default() };
        let bake = || {
            super::texture_files::decode_texture(&file, &self.texture_limits)
                .and_then(|mut src| {
                    let scale = fit_half_float_range(&mut src);
                    texture::bake(&src, &options).map(|baked| (baked, scale))
                })
                .map_err(|e| e.to_string())
        };
        // A sequence's later frames take the first frame's bake (see `bake_cache`).
        let baked = match self.bake_cache {
            Some(cache) => (*cache.dome(&file, bake)).clone(),
            None => bake(),
        };
        match baked {
            Ok((baked, scale)) => {
                // A scaled copy must not be found by a material reading the same file.
                let key =
                    if scale == 1.0 { file } else { PathBuf::from(format!("{}#/{scale}", file.display())) };
                self.scene.textures.push(SceneTexture {
                    path: key,
                    color_space,
                    data: TextureData::Image(baked),
                });
                Ok(Some((self.scene.textures.len() as u32 - 1, scale)))
            }
            Err(e) => {
                let packaged = file.to_str().is_some_and(ar::is_package_relative_path);
                let why = if file.exists() || packaged {
                    format!("cannot be read ({e})")
                } else {
                    "not found".into()
                };
                self.warn(path, format!("dome texture {} {why}; using its uniform color", file.display()));
                Ok(None)
            }
        }
    }

    /// Reads a DomeLight, DistantLight, SphereLight, RectLight or DiskLight.
    pub(super) fn read_light(&mut self, path: &str, ty: &str, state: &Inherited) -> Result<(), UsdError> {
        let intensity = self.light_f32(path, "intensity", fallback::LIGHT_INTENSITY)?;
        let exposure = self.light_f32(path, "exposure", fallback::LIGHT_EXPOSURE)?;
        let mut color = self
            .light_input(path, "color")?
            .and_then(|v| v.as_tuple::<3>())
            .map_or(Vec3::from_array(fallback::LIGHT_COLOR), |c| {
                Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32)
            });
        let normalize = self.light_bool(path, "normalize", fallback::LIGHT_NORMALIZE)?;
        let kind = match ty {
            "DistantLight" => {
                LightKind::Distant { angle_degrees: self.light_f32(path, "angle", fallback::DISTANT_ANGLE)? }
            }
            "SphereLight" => LightKind::Sphere {
                radius: self.light_f32(path, "radius", fallback::SPHERE_RADIUS)?,
                treat_as_point: self.light_bool(path, "treatAsPoint", fallback::SPHERE_TREAT_AS_POINT)?,
            },
            "RectLight" => {
                if self.light_has_texture(path)? {
                    self.warn(path, "textured rect light not supported yet; using its uniform color");
                }
                LightKind::Rect {
                    width: self.light_f32(path, "width", fallback::RECT_SIZE)?,
                    height: self.light_f32(path, "height", fallback::RECT_SIZE)?,
                }
            }
            "DiskLight" => LightKind::Disk { radius: self.light_f32(path, "radius", fallback::DISK_RADIUS)? },
            _ => match self.dome_texture(path)? {
                Some((texture, scale)) => {
                    color *= scale;
                    LightKind::TexturedDome { texture }
                }
                None => LightKind::Dome,
            },
        };
        let links = LightLinks {
            light: self.read_light_collection(path, "lightLink")?,
            shadow: self.read_light_collection(path, "shadowLink")?,
        };
        self.light_links.push(links);
        let group = self.light_group(path)?;
        self.scene.light_groups.push(group);
        if !self.light_camera_visible(path)? {
            self.scene.camera_hidden_lights.push(self.scene.lights.len());
        }
        self.scene.lights.push(Light {
            path: path.to_string(),
            kind,
            radiance: color * intensity * exposure.exp2(),
            normalize,
            world_from_light: state.world_from_local.as_mat4(),
        });
        Ok(())
    }

    /// Whether camera rays see light `path`. UsdLux has no such attribute; the renderer-specific
    /// spellings assets author are read, each only where authored (every light is visible by
    /// default, as in usd-core's Storm and in RenderMan):
    /// - Karma: `karma:light:renderlightgeo` (also as a primvar), "Render Light Geometry": 0 hides;
    /// - RenderMan: `primvars:ri:attributes:visibility:camera` (also `ri:visibility:camera`): 0 hides;
    /// - Arnold: `primvars:arnold:camera` (also `arnold:camera`), the camera-ray weight: 0 hides
    ///   (other weights are read as visible: the camera sees a light fully or not at all).
    ///
    /// The first authored one in that order decides.
    fn light_camera_visible(&self, path: &str) -> Result<bool, UsdError> {
        const SPELLINGS: [&str; 6] = [
            "karma:light:renderlightgeo",
            "primvars:karma:light:renderlightgeo",
            "primvars:ri:attributes:visibility:camera",
            "ri:visibility:camera",
            "primvars:arnold:camera",
            "arnold:camera",
        ];
        for name in SPELLINGS {
            if let Some(v) = self.f64(path, name)? {
                return Ok(v != 0.0);
            }
        }
        Ok(true)
    }

    /// A UsdLuxLightAPI collection of light `path` (`lightLink` or `shadowLink`), with the schema's
    /// fallbacks (`includeRoot = true`, `expandPrims`); see [`super::collection`] for what is read.
    fn read_light_collection(&mut self, path: &str, name: &str) -> Result<Membership, UsdError> {
        let prefix = format!("collection:{name}");
        let rule_attr = format!("{prefix}:expansionRule");
        let rule = match self.token(path, &rule_attr)? {
            None => ExpansionRule::ExpandPrims,
            Some(token) => ExpansionRule::from_token(&token).unwrap_or_else(|| {
                self.warn(path, format!("{rule_attr} {token:?} is not an expansion rule; using expandPrims"));
                ExpansionRule::ExpandPrims
            }),
        };
        let include_root = self.bool(path, &format!("{prefix}:includeRoot"))?.unwrap_or(true);
        let expression = format!("{prefix}:membershipExpression");
        if self.stage.attr(path, &expression)?.and_then(|v| v.as_str().map(str::is_empty)) == Some(false) {
            self.warn(
                path,
                format!("{expression} (path expressions) not supported yet; using includes and excludes"),
            );
        }
        let mut targets = |rel: &str| {
            let mut paths = self.stage.targets(path, &format!("{prefix}:{rel}"));
            paths.retain(|p| {
                let nested = p.contains(".collection:");
                if nested {
                    self.scene.warn(
                        path,
                        format!("{prefix}:{rel} target <{p}> is a collection (nested collections not supported yet); ignored"),
                    );
                }
                if !nested && self.stage.type_name(p) == "GeomSubset" {
                    self.scene.warn(
                        path,
                        format!("{prefix}:{rel} target <{p}> is a GeomSubset: linking of face subsets not supported yet (its gprim's own membership is used)"),
                    );
                }
                !nested
            });
            paths
        };
        let includes = targets("includes");
        let excludes = targets("excludes");
        Ok(Membership::new(rule, include_root, &includes, &excludes))
    }

    /// Gives every mesh its light set ([`crate::scene::Mesh::light_set`]) from the lights'
    /// collections, each distinct set once, set 0 being every light; leaves the scene without
    /// light sets when every light lights and is shadowed by every gprim (the common case: the
    /// blob and the image are then those of a scene without linking). Curves and points are lit
    /// by and shadow every light: a light whose collections leave one out gets a warning.
    pub(super) fn assign_light_sets(&mut self) {
        let links = std::mem::take(&mut self.light_links);
        if links.iter().all(|l| l.light.is_everything() && l.shadow.is_everything()) {
            return;
        }
        let lights = self.scene.lights.len();
        let mut sets = vec![LightSet::everything(lights)];
        let mut index: std::collections::HashMap<LightSet, u32> = [(sets[0].clone(), 0)].into();
        for mesh in &mut self.scene.meshes {
            let set = LightSet {
                lit_by: links.iter().map(|l| l.light.includes(&mesh.path)).collect(),
                shadows: links.iter().map(|l| l.shadow.includes(&mesh.path)).collect(),
            };
            mesh.light_set = *index.entry(set).or_insert_with_key(|set| {
                sets.push(set.clone());
                sets.len() as u32 - 1
            });
        }
        let mut warnings = Vec::new();
        for (light, l) in self.scene.lights.iter().zip(&links) {
            let left_out =
                self.scene.curves.iter().find(|c| !l.light.includes(&c.path) || !l.shadow.includes(&c.path));
            if let Some(curve) = left_out {
                warnings.push((
                    light.path.clone(),
                    format!(
                        "light linking of curves and points not supported yet: {} (and any other left out) is lit by and shadows this light",
                        curve.path
                    ),
                ));
            }
        }
        for (prim, message) in warnings {
            self.warn(&prim, message);
        }
        if sets.len() > 1 {
            self.scene.light_sets = sets;
        }
    }

    /// Refuses a default camera whose apertures, without a RenderSettings resolution, give an
    /// image above the resolution limits: the image is [`DEFAULT_WIDTH`] wide at the apertures'
    /// aspect, so a tall aperture (`verticalAperture = 192000` at 36 wide: 512 × 2.7 M pixels) made
    /// dicing and curve splitting grow without bound.
    pub(super) fn check_default_camera_image(&self) -> Result<(), UsdError> {
        let (None, Some(i)) = (self.scene.resolution, self.scene.default_camera) else { return Ok(()) };
        let camera = &self.scene.cameras[i];
        let [h_ap, v_ap] =
            [camera.horizontal_aperture, camera.vertical_aperture].map(|a| f64::from(a).max(1e-6));
        let height = (f64::from(DEFAULT_WIDTH) * v_ap / h_ap).round().max(1.0);
        let pixels = f64::from(DEFAULT_WIDTH) * height;
        if height > f64::from(MAX_RESOLUTION_SIDE) || pixels > MAX_RESOLUTION_PIXELS as f64 {
            return Err(self.invalid(
                &camera.path,
                "verticalAperture",
                format!(
                    "verticalAperture {v_ap} with horizontalAperture {h_ap} gives a {DEFAULT_WIDTH}x{height} image (no RenderSettings resolution), above the limit of {MAX_RESOLUTION_SIDE} per side"
                ),
            ));
        }
        Ok(())
    }

    /// Reads a Camera (cameras are kept whatever their visibility or purpose).
    pub(super) fn read_camera(&mut self, path: &str, state: &Inherited) -> Result<(), UsdError> {
        let f = |r: &Self, name: &str, fallback: f32| -> Result<f32, UsdError> {
            Ok(r.f64(path, name)?.map_or(fallback, |v| v as f32))
        };
        let clipping_range = self
            .stage
            .attr(path, "clippingRange")?
            .and_then(|v| v.as_tuple::<2>())
            .map_or(fallback::CLIPPING_RANGE, |r| [r[0] as f32, r[1] as f32]);
        let orthographic = self.token(path, "projection")?.as_deref() == Some("orthographic");
        let lens = self.read_lens(path, orthographic)?;
        let shutter = self.read_shutter(path)?;
        let camera = Camera {
            path: path.to_string(),
            world_from_camera: state.world_from_local.as_mat4(),
            orthographic,
            focal_length: f(self, "focalLength", fallback::FOCAL_LENGTH)?,
            horizontal_aperture: f(self, "horizontalAperture", fallback::HORIZONTAL_APERTURE)?,
            vertical_aperture: f(self, "verticalAperture", fallback::VERTICAL_APERTURE)?,
            horizontal_aperture_offset: f(self, "horizontalApertureOffset", 0.0)?,
            vertical_aperture_offset: f(self, "verticalApertureOffset", 0.0)?,
            clipping_range,
            lens,
            shutter,
            motion: None,
        };
        self.scene.cameras.push(camera);
        Ok(())
    }

    /// Applies the stage's RenderSettings: the one named by the `renderSettingsPrimPath` stage
    /// metadata, else the first RenderSettings prim in traversal order.
    pub(super) fn read_render_settings(&mut self) -> Result<(), UsdError> {
        let named =
            self.stage.metadata("renderSettingsPrimPath").and_then(|v| v.as_str().map(str::to_string));
        let settings = match named.filter(|n| !n.is_empty()) {
            Some(n) => n,
            None => match self.render_settings.first() {
                Some(s) => s.clone(),
                None => return Ok(()),
            },
        };
        let mut targeted = None;
        if let Some(camera) = self.stage.targets(&settings, "camera").into_iter().next() {
            match self.scene.cameras.iter().position(|c| c.path == camera) {
                Some(i) => {
                    self.scene.default_camera = Some(i);
                    targeted = Some(i);
                }
                None => {
                    self.warn(&settings, format!("camera {camera} is not a camera on the stage; ignored"))
                }
            }
        }
        // UsdRenderSettingsBase: "disable all motion blur by setting the shutter interval of the
        // targeted camera to [0, 0]" (every camera when the settings target none).
        if self.bool(&settings, "disableMotionBlur")? == Some(true) {
            for (i, camera) in self.scene.cameras.iter_mut().enumerate() {
                if targeted.is_none_or(|t| t == i) {
                    camera.shutter = [0.0; 2];
                }
            }
        }
        if let Some(res) = self.stage.attr(&settings, "resolution")?.and_then(|v| v.as_tuple::<2>()) {
            if res[0] >= 1.0 && res[1] >= 1.0 {
                let [w, h] = res;
                if w > f64::from(MAX_RESOLUTION_SIDE)
                    || h > f64::from(MAX_RESOLUTION_SIDE)
                    || w * h > MAX_RESOLUTION_PIXELS as f64
                {
                    return Err(self.invalid(
                        &settings,
                        "resolution",
                        format!("resolution {w}x{h} is above the limit of {MAX_RESOLUTION_SIDE} per side and {MAX_RESOLUTION_PIXELS} pixels (subdivision and curves are diced for it)"),
                    ));
                }
                self.scene.resolution = Some([res[0] as u32, res[1] as u32]);
            } else {
                self.warn(&settings, format!("resolution {res:?} is not positive; ignored"));
            }
        }
        if let Some(window) = self.stage.attr(&settings, "dataWindowNDC")? {
            self.read_data_window(&settings, &window);
        }
        self.read_render_products(&settings)
    }

    /// RenderSettings `dataWindowNDC`: kept when it is an upright rectangle within
    /// ±[`blob::tree::MAX_NDC`] that is not the whole frame; anything else is one warning and the whole
    /// frame.
    fn read_data_window(&mut self, settings: &str, value: &Value) {
        let Some(w) = value.as_tuple::<4>() else {
            self.warn(settings, format!("dataWindowNDC {value:?} is not a float4; ignored"));
            return;
        };
        let limit = f64::from(blob::tree::MAX_NDC);
        if !w.iter().all(|v| v.is_finite() && v.abs() <= limit) || w[0] >= w[2] || w[1] >= w[3] {
            self.warn(
                settings,
                format!("dataWindowNDC {w:?} is not an upright rectangle within ±{limit} (xmin, ymin, xmax, ymax); the whole frame is rendered"),
            );
            return;
        }
        if w != [0.0, 0.0, 1.0, 1.0] {
            self.scene.data_window_ndc = Some(w.map(|v| v as f32));
        }
    }
}

/// Scales a float image by a power of two so that its largest finite sample fits a half float (65504;
/// bakes store float sources as halves, which would turn a bright sun into infinity), and returns the
/// inverse factor for the light's radiance. Powers of two keep every sample's mantissa; only values
/// far below the largest lose precision, at less than 2⁻²⁴ of it.
fn fit_half_float_range(src: &mut texture::SourceImage) -> f32 {
    const HALF_MAX: f32 = 65504.0;
    let texture::Samples::F32(samples) = &mut src.samples else { return 1.0 };
    let largest = samples.iter().copied().filter(|v| v.is_finite()).fold(0.0f32, f32::max);
    if largest <= HALF_MAX {
        return 1.0;
    }
    let exponent = (largest / HALF_MAX).log2().ceil() as i32;
    let factor = 2.0f32.powi(exponent);
    samples.iter_mut().for_each(|v| *v /= factor);
    factor
}
