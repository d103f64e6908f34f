//! What both integrators share about a path: its settings, the ray counts, the first-hit AOV record,
//! Russian roulette's start and the shadow-ray extent.

pub mod roulette;

use glam::Vec3;
use texture::Filter;

/// Bounces before Russian roulette starts.
pub const RR_START_BOUNCE: u32 = 3;
/// Null (pass-through) events allowed per path on top of `max_depth`, so stacks of transparent cards
/// cannot loop forever.
pub const MAX_NULL_EVENTS: u32 = 64;

/// How far a shadow ray from `origin` runs towards a light sample `distance` away from the shading
/// point `p`: the rest of the way, less a relative 1e-4 so it stops short of the light's own surface
/// (infinite for lights at infinity).
#[inline]
pub(crate) fn shadow_tmax(distance: f32, origin: Vec3, p: Vec3) -> f32 {
    if distance.is_finite() {
        (distance - (origin - p).length()) * (1.0 - 1e-4)
    } else {
        f32::INFINITY
    }
}

/// First-hit data for the AOVs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FirstHit {
    /// Diffuse albedo of the first scattering surface.
    pub albedo: Vec3,
    /// World-space shading normal there (facing the camera).
    pub normal: Vec3,
    /// Distance from the camera.
    pub depth: f32,
}

/// Result of one camera path.
#[derive(Clone, Copy, Debug, Default)]
pub struct PathResult {
    /// Radiance along the camera ray.
    pub radiance: Vec3,
    /// `Some` if the camera ray reached a surface.
    pub first_hit: Option<FirstHit>,
}

/// Ray counts, summed per tile.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    /// Camera rays.
    pub camera: u64,
    /// Closest-hit rays after the first (BSDF continuations and pass-throughs).
    pub bounce: u64,
    /// Any-hit shadow rays.
    pub shadow: u64,
}

impl RayCounts {
    /// All rays.
    pub fn total(&self) -> u64 {
        self.camera + self.bounce + self.shadow
    }
    /// Adds `other` into `self`.
    pub fn add(&mut self, other: &RayCounts) {
        self.camera += other.camera;
        self.bounce += other.bounce;
        self.shadow += other.shadow;
    }
}

/// Per-render settings the path reads.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PathSettings {
    /// Maximum number of bounces.
    pub max_depth: u32,
    /// Texture filter.
    pub filter: Filter,
    /// The shutter: every path's rays have the time [`crate::camera::Shutter::time`] gives its key.
    pub shutter: crate::camera::Shutter,
}

/// How much a bounce off a lobe of GGX α widens a ray cone, radians per unit α. A diffuse bounce
/// (α = 1) adds half a radian: indirect texture reads come from coarse levels, as in MoonRay, where the
/// footprint of a rough bounce is far larger than a pixel. Specular bounces (α → 0) keep the cone
/// (surface curvature is ignored).
pub const CONE_WIDEN_PER_ALPHA: f32 = 0.5;
