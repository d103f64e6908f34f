//! Light linking and shadow linking: which lights light a shading point, and which blockers a
//! light's shadow rays ignore.
//!
//! Ingest resolves UsdLux's `collection:lightLink` and `collection:shadowLink` of every light into
//! one light set per gprim (the blob's `LightSets` section, [`blob::light_set_words`]): a *lit-by*
//! and a *shadows* bit mask over the blob's lights. A prototype's meshes carry the set of all its
//! instances (ingest gives differently linked instances prototypes of their own), so a hit's set
//! is always its triangle's mesh's.
//!
//! How the integrators honour it (both call these functions, so they stay equal bit for bit):
//! - next-event estimation selects and samples a light exactly as without linking, and drops the
//!   sample when the light does not light the shading point: the selection pdf is unchanged, so
//!   the estimator of the linked lights' contribution stays unbiased;
//! - emission found by a BSDF-sampled ray (area lights crossed, dome and distant lights on escape)
//!   counts only when its light lights the previous scattering vertex: the other half of the same
//!   MIS pair, dropped for the same pairs. Camera rays (no previous vertex) see every light;
//! - a shadow ray towards light `l` ignores every triangle whose set does not shadow `l`.
//!
//! Not linked (every light lights and is shadowed by everything): emissive triangles (they are
//! not UsdLux lights), and curves and points (their blob records carry no set; ingest warns).
//! Without a `LightSets` section nothing here runs: the images are those of a scene without
//! linking, byte for byte.

use blob::SceneView;

/// "No light set": a shading point every light lights (curves, points; the camera).
pub const UNLINKED: u32 = u32::MAX;

/// The light sets of a blob that has some.
#[derive(Clone, Debug)]
pub struct LightLinks<'a> {
    words: &'a [u32],
    /// Words of one mask (one bit per blob light).
    half: usize,
    /// The blob's lights (the selection list's entry after them, the emissive triangles, is never
    /// linked).
    lights: usize,
    triangles: &'a [blob::Triangle],
    meshes: &'a [blob::Mesh],
}

impl<'a> LightLinks<'a> {
    /// The light sets of `view`, or `None` when it has none (nothing is linked).
    pub fn new(view: &SceneView<'a>) -> Option<Self> {
        (view.light_set_count() > 0).then(|| LightLinks {
            words: view.light_sets,
            half: blob::light_set_words(view.lights.len()),
            lights: view.lights.len(),
            triangles: view.triangles,
            meshes: view.meshes,
        })
    }

    /// The light set of (top-level or prototype) `triangle`; [`UNLINKED`] for [`blob::NONE`] (a
    /// curve or point hit).
    #[inline]
    pub fn set_of(&self, triangle: u32) -> u32 {
        match self.triangles.get(triangle as usize) {
            Some(t) => self.meshes[t.mesh as usize].light_set,
            None => UNLINKED,
        }
    }

    /// Bit `light` of mask `half` (0: lit by, 1: shadows) of `set`.
    #[inline]
    fn bit(&self, set: u32, half: usize, light: usize) -> bool {
        if set == UNLINKED || light >= self.lights {
            return true;
        }
        let word = (set as usize * 2 + half) * self.half + light / 32;
        // Validated: every mesh's set is in range, so the word exists.
        (self.words[word] >> (light % 32)) & 1 != 0
    }

    /// Whether light `light` (an index into the selection list) lights points of light set `set`.
    #[inline]
    pub fn lights(&self, set: u32, light: usize) -> bool {
        self.bit(set, 0, light)
    }

    /// Whether gprims of light set `set` block the shadow rays of light `light`.
    #[inline]
    pub fn shadows(&self, set: u32, light: usize) -> bool {
        self.bit(set, 1, light)
    }
}

#[cfg(test)]
mod tests {
    use crate::testscene::{self, assert_close, camera_looking_down_z, card, dome, lambert};
    use crate::wavefront::equivalence_tests::both_integrators;
    use crate::{Image, RenderOptions};

    /// [`testscene::mean_where`] of a selection that must hold pixels.
    fn mean_where(image: &Image, keep: impl Fn(f32, f32) -> bool) -> f32 {
        let (mean, n) = testscene::mean_where(image, keep);
        assert!(n > 0, "no pixel selected");
        mean
    }
    use glam::{Mat4, Vec3};
    use scene_pack::{Light, LightKind, LightSet, Scene};
    use std::f32::consts::PI;

    fn distant(intensity: f32, angle_degrees: f32, world_from_light: Mat4) -> Light {
        Light {
            path: "/sun".into(),
            kind: LightKind::Distant { angle_degrees },
            radiance: Vec3::splat(intensity),
            normalize: true,
            world_from_light,
        }
    }

    /// Both integrators (asserted equal bit for bit), the image.
    fn render(scene: &Scene, spp: u32, max_depth: u32, what: &str) -> Image {
        let bytes = testscene::bytes(scene);
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let options = RenderOptions {
            spp,
            resolution: Some([16, 16]),
            threads: 2,
            max_depth,
            ..RenderOptions::default()
        };
        both_integrators(&view, &options, what).0
    }

    /// A Lambertian card (albedo 0.5) under a dome (radiance 1: E = π) and a normalized sun
    /// (E = 1, straight down) reads 0.5 · (π + 1) / π; left out of the dome's light link it reads
    /// the sun's L = albedo · E / π alone: the dome's light samples and the dome radiance its
    /// BSDF-sampled rays escape to both count for nothing.
    #[test]
    fn a_card_left_out_of_a_lights_link_is_lit_by_the_other_only() {
        let mut scene = Scene {
            meshes: vec![card(0.0, 3.0, 0)],
            materials: vec![lambert(0.5)],
            lights: vec![dome(1.0), distant(1.0, 0.53, Mat4::IDENTITY)],
            cameras: vec![camera_looking_down_z(Vec3::new(0.0, 0.0, 3.0), 50.0)],
            default_camera: Some(0),
            ..Scene::default()
        };
        let both = mean_where(&render(&scene, 256, 4, "card under dome + sun"), |_, _| true);
        assert_close("card under dome + sun", both, 0.5 * (PI + 1.0) / PI, 0.02);
        scene.light_sets =
            vec![LightSet::everything(2), LightSet { lit_by: vec![false, true], shadows: vec![true; 2] }];
        scene.meshes[0].light_set = 1;
        let image = render(&scene, 256, 4, "card linked to the sun only");
        assert_close("card linked to the sun only", mean_where(&image, |_, _| true), 0.5 / PI, 0.02);
        // Linked to neither: black, exactly.
        scene.light_sets[1].lit_by = vec![false, false];
        let image = render(&scene, 16, 4, "card linked to no light");
        assert!(image.beauty.iter().all(|p| p[..3] == [0.0; 3]), "an unlit card must be black");
    }

    /// Two delta suns 1 rad off the vertical cast a small card's shadow onto the middle of a
    /// ground card (albedo 0.5); direct light only (one bounce), so a lit ground pixel reads
    /// exactly albedo · E · cos 1 / π per sun. The blocker shadows both suns: the middle is black.
    /// Left out of sun A's shadow link it casts no shadow from A: the middle reads A's term, and
    /// still none of B's.
    #[test]
    fn a_blocker_left_out_of_a_lights_shadow_link_casts_no_shadow_from_it() {
        let sun = |e: f32| Light {
            kind: LightKind::Distant { angle_degrees: 0.0 },
            ..distant(e, 0.0, Mat4::from_rotation_x(1.0))
        };
        let mut blocker = card(0.5, 0.3, 0);
        blocker.path = "/blocker".into();
        blocker.positions.iter_mut().for_each(|p| p.y -= 0.5 * 1.0f32.tan());
        let mut scene = Scene {
            meshes: vec![card(0.0, 3.0, 0), blocker],
            materials: vec![lambert(0.5)],
            lights: vec![sun(1.0), sun(2.0)],
            cameras: vec![camera_looking_down_z(Vec3::new(0.0, 0.0, 3.0), 20.0)],
            default_camera: Some(0),
            ..Scene::default()
        };
        let middle = |fx: f32, fy: f32| fx.abs() < 0.12 && fy.abs() < 0.12;
        let open = |fx: f32, fy: f32| fx.abs() > 0.5 && fy > 0.3;
        let term = |e: f32| 0.5 * e * 1.0f32.cos() / PI;
        let image = render(&scene, 4, 1, "blocker shadowing both suns");
        assert_eq!(mean_where(&image, middle), 0.0, "the blocker's shadow is black");
        assert_close("ground outside the shadow", mean_where(&image, open), term(1.0) + term(2.0), 1e-4);
        scene.light_sets =
            vec![LightSet::everything(2), LightSet { lit_by: vec![true; 2], shadows: vec![false, true] }];
        scene.meshes[1].light_set = 1;
        let image = render(&scene, 4, 1, "blocker out of sun A's shadow link");
        assert_close("shadow of sun B only", mean_where(&image, middle), term(1.0), 1e-4);
        assert_close("ground outside the shadow", mean_where(&image, open), term(1.0) + term(2.0), 1e-4);
    }
}

#[cfg(test)]
mod camera_visibility_tests {
    use crate::testscene::{self, camera_looking_down_z, card, lambert};
    use crate::wavefront::equivalence_tests::both_integrators;
    use crate::RenderOptions;
    use glam::{Mat4, Vec3};
    use scene_pack::{Light, LightKind, Scene};

    /// A bright sphere light between the camera and a ground card: visible, the middle pixels
    /// read its radiance; hidden from the camera (`LIGHT_CAMERA_HIDDEN`), they read the ground it
    /// lights, and every pixel the sphere does not cover keeps its bytes (the light still lights
    /// the scene the same way). Both integrators, equal bit for bit.
    #[test]
    fn a_light_hidden_from_the_camera_still_lights_the_scene() {
        let mut scene = Scene {
            meshes: vec![card(0.0, 3.0, 0)],
            materials: vec![lambert(0.5)],
            lights: vec![Light {
                path: "/bulb".into(),
                kind: LightKind::Sphere { radius: 0.2, treat_as_point: false },
                radiance: Vec3::splat(20.0),
                normalize: false,
                world_from_light: Mat4::from_translation(Vec3::new(0.0, 0.0, 1.0)),
            }],
            cameras: vec![camera_looking_down_z(Vec3::new(0.0, 0.0, 3.0), 20.0)],
            default_camera: Some(0),
            ..Scene::default()
        };
        let options =
            RenderOptions { spp: 16, resolution: Some([24, 24]), threads: 2, ..RenderOptions::default() };
        let render = |scene: &Scene, what: &str| {
            let bytes = testscene::bytes(scene);
            let view = blob::SceneView::parse(&bytes).expect("valid blob");
            both_integrators(&view, &options, what).0
        };
        let visible = render(&scene, "bulb seen by the camera");
        scene.camera_hidden_lights = vec![0];
        let hidden = render(&scene, "bulb hidden from the camera");
        // The sphere (radius 0.2 at distance 2, half-width tan 0.5) covers |f| < 0.2 of the frame.
        let (mut covered, mut kept) = (0, 0);
        for y in 0..24u32 {
            for x in 0..24u32 {
                let fx = (x as f32 + 0.5) / 12.0 - 1.0;
                let fy = 1.0 - (y as f32 + 0.5) / 12.0;
                let r = (fx * fx + fy * fy).sqrt();
                let (v, h) = (visible.rgb(x, y)[0], hidden.rgb(x, y)[0]);
                if r < 0.12 {
                    covered += 1;
                    assert!(v > 19.0, "pixel {x},{y} sees the bulb: {v}");
                    assert!(
                        h > 0.05 && h < 2.0,
                        "pixel {x},{y} sees the lit ground through the hidden bulb: {h}"
                    );
                } else if r > 0.3 {
                    kept += 1;
                    assert_eq!(v.to_bits(), h.to_bits(), "pixel {x},{y} away from the bulb");
                }
            }
        }
        assert!(covered >= 4 && kept > 300, "{covered} covered, {kept} kept");
    }
}
