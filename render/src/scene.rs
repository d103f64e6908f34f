//! A validated blob view plus what rendering derives from it once: the BVH wrapper, the light list,
//! the camera choice and the resolution.

use crate::accel::curves::CurveAccel;
use crate::accel::Accel;
use crate::camera::{default_height, Camera};
use crate::error::RenderError;
use crate::lights::lanes::LightTable;
use crate::lights::Lights;
use crate::shading::Shading;
use blob::SceneView;
use glam::Vec3;

/// Everything the integrator reads, borrowed from the mapped blob (no copies of scene data).
#[derive(Clone, Debug)]
pub struct Scene<'a> {
    /// The validated blob.
    pub view: SceneView<'a>,
    /// BVH queries.
    pub accel: Accel<'a>,
    /// Curve and point queries (their own BVH).
    pub curves: CurveAccel<'a>,
    /// Lights for sampling and MIS.
    pub lights: Lights<'a>,
    /// Material programs and textures.
    pub shading: Shading<'a>,
    /// The lights laid out for the wavefront's 8-lane sampling kernel, built on first use (the
    /// scalar integrator never pays for it).
    light_table: std::sync::OnceLock<LightTable>,
}

impl<'a> Scene<'a> {
    /// Prepares a validated view for rendering.
    pub fn new(view: SceneView<'a>) -> Self {
        Scene {
            accel: Accel::new(&view),
            curves: CurveAccel::new(&view),
            lights: Lights::new(&view),
            shading: Shading::new(&view),
            light_table: std::sync::OnceLock::new(),
            view,
        }
    }

    /// [`Lights::sample`]'s data in the wavefront light kernel's layout, built once per scene.
    pub(crate) fn light_table(&self) -> &LightTable {
        self.light_table.get_or_init(|| LightTable::new(&self.lights))
    }

    /// Index of the camera with prim path `path`, or the default camera when `path` is `None`
    /// (`Ok(None)`: the scene has no camera).
    pub fn camera_index(&self, path: Option<&str>) -> Result<Option<usize>, RenderError> {
        match path {
            Some(path) => {
                self.view.cameras.iter().position(|c| self.view.string(c.name) == path).map(Some).ok_or_else(
                    || RenderError::UnknownCamera {
                        path: path.to_string(),
                        available: self
                            .view
                            .cameras
                            .iter()
                            .map(|c| self.view.string(c.name).to_string())
                            .collect(),
                    },
                )
            }
            None => Ok(if self.view.info.default_camera != blob::NONE {
                Some(self.view.info.default_camera as usize)
            } else if !self.view.cameras.is_empty() {
                Some(0)
            } else {
                None
            }),
        }
    }

    /// Image size: `requested`, else the authored RenderSettings resolution, else 512 wide with the
    /// camera's aperture aspect.
    pub fn resolution(&self, requested: Option<[u32; 2]>, camera: Option<usize>) -> [u32; 2] {
        if let Some(r) = requested {
            return r;
        }
        let authored = self.view.info.resolution;
        if authored[0] > 0 && authored[1] > 0 {
            return authored;
        }
        [512, default_height(camera.map(|i| &self.view.cameras[i]), 512)]
    }

    /// Whether anything in the scene can light it: a UsdLux light, an emissive triangle, or a material
    /// (on curves or points) whose `emissiveColor` is non-zero or driven by its program. A scene
    /// without any renders black.
    pub fn has_light(&self) -> bool {
        let v = &self.view;
        let program_emits = |m: &blob::Material| {
            let ops = v.shader_ops.get(m.program_start as usize..).unwrap_or_default();
            ops.iter()
                .take(m.program_len as usize)
                .any(|op| op.kind == blob::op_kind::OUTPUT && op.dst == blob::shading_input::EMISSIVE_COLOR)
        };
        !v.lights.is_empty()
            || !v.emissive_triangles.is_empty()
            || v.materials.iter().any(|m| m.emissive_color != [0.0; 3] || program_emits(m))
    }

    /// The authored RenderSettings data window (NDC), if any ([`blob::SceneInfo::data_window_ndc`]).
    pub fn data_window_ndc(&self) -> Option<[f32; 4]> {
        let w = self.view.info.data_window_ndc;
        (w[0] != w[2] && w[1] != w[3]).then_some(w)
    }

    /// The camera for an image of `width × height`: the blob camera `index` (moving when it has
    /// keys), or one framing the bounds.
    pub fn camera(&self, index: Option<usize>, width: u32, height: u32) -> Camera {
        match index {
            Some(i) => {
                let c = &self.view.cameras[i];
                // Validated: a moving camera's key range is inside the motion keys section.
                let first = c.first_motion_key as usize;
                let keys = &self.view.instancing.motion_keys[first..first + c.motion_key_count as usize];
                Camera::from_blob(c, width, height).with_motion(keys)
            }
            None => Camera::framing(
                Vec3::from(self.view.info.bounds_min),
                Vec3::from(self.view.info.bounds_max),
                self.view.info.up_axis == blob::UP_AXIS_Z,
                width,
                height,
            ),
        }
    }
}
