//! Shading sort keys for up to eight hits at once: [`Shading::sort_key`] in lanes.
//!
//! The scalar key interprets the material's program up to its first texture read (a register file
//! cleared per call, one `match` per op), then derives the mip level from the footprint and
//! interleaves the uv bits. Almost every textured material reads its first texture through the
//! hit's uv and at most a couple of UsdTransform2d ops, so that walk is done once per material
//! ([`KeyPlan`]), and the per-hit part runs in lanes: the transforms (per-lane selects on the
//! lane's transform count), [`crate::shading::sort_level`]'s exponent read-off and
//! [`texture::shading_sort_key_saturating`]'s quantisation and Morton interleave, with the same
//! IEEE operations in the same order, so every lane equals the scalar key (tested on random
//! footprints, infinities and NaNs included). A material whose first texture read does not depend
//! on the hit at all (its coordinates are constants: the tractor's materials) has one key, found
//! once. Materials whose first texture is a UDIM set read through the uv, or whose coordinates
//! come from a primvar, keep the scalar key.
//!
//! The quantisation is written so that it vectorises ([`morton`]), and groups on one material read
//! the plan once as loop-invariant scalars; measurements: `docs/perf.md#sort-key-lanes-shadingsortkeyrs`.

// Lane loops index several columns by the same lane number.
#![allow(clippy::needless_range_loop)]

use crate::shading::{reg, Shading, UvFootprint};
use blob::{op_kind, MAX_REGISTERS};
use lanekit::{Lanes, U32Lanes, LANES};
use texture::sort_key::{MAX_SORT_MIP, MIP_SHIFT};

/// UsdTransform2d ops a [`KeyPlan::Uv`] follows between the uv reader and the texture read.
const MAX_TRANSFORMS: usize = 2;

/// How the sort key of a hit on one material is found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum KeyPlan {
    /// By [`Shading::sort_key`], per hit.
    Scalar,
    /// This key for every hit: the first texture read's coordinates do not depend on the hit
    /// (constants, or the cleared register file), so neither do its tile and level (footprint 0).
    Constant(u32),
    /// In lanes: the first texture read (not a UDIM set) takes the hit's uv and footprint through
    /// the listed transforms.
    Uv(UvPlan),
}

/// The per-material part of a key computed in lanes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UvPlan {
    /// `[a, b, c, d, tx, ty]` of each transform in program order: `xy ↦ (a·x + b·y + tx,
    /// c·x + d·y + ty)`, footprints `(a·x + b·y, c·x + d·y)`.
    transforms: [[f32; 6]; MAX_TRANSFORMS],
    /// Transforms in use.
    count: u32,
    /// Level-0 width and height of the texture (its mip level), or 0 × 0 without a texture (level 0).
    width: f32,
    height: f32,
    has_texture: bool,
    /// The key of a hit on a mesh without uvs (the reader's fallback: one key per material).
    no_uv_key: u32,
}

/// Where a register's coordinates come from, as far as the key is concerned.
#[derive(Clone, Copy, Debug)]
enum Source {
    /// The hit's uv through the transforms at these op indices.
    Uv { transforms: [usize; MAX_TRANSFORMS], count: usize },
    /// Nothing the hit changes (constants, the cleared file, transforms of those): coordinates
    /// and footprint (zero) are the same for every hit.
    Constant,
    /// Anything else (primvars, more transforms than a plan follows).
    Varying,
}

/// The plan of every material of `shading`.
pub fn plans(shading: &Shading, materials: usize) -> Vec<KeyPlan> {
    (0..materials as u32).map(|m| plan(shading, m)).collect()
}

/// The plan of `material`: the walk [`Shading::sort_key`] makes over its program, with registers
/// tracked by where their coordinates come from (register `r` is slot `reg(r)` in either file).
fn plan(shading: &Shading, material: u32) -> KeyPlan {
    let program = shading.program(material);
    let mut regs = [Source::Constant; MAX_REGISTERS as usize];
    for (i, op) in program.iter().enumerate() {
        match op.kind {
            op_kind::TEXTURE => {
                let (transforms, count) = match regs[reg(op.src)] {
                    // The UDIM tile too is the same for every hit.
                    Source::Constant => {
                        return KeyPlan::Constant(shading.sort_key(material, &UvFootprint::default()))
                    }
                    Source::Uv { transforms, count } if op.flags & blob::OP_UDIM == 0 => (transforms, count),
                    _ => return KeyPlan::Scalar,
                };
                let mut plan = UvPlan { count: count as u32, ..UvPlan::default() };
                for (j, &at) in transforms[..count].iter().enumerate() {
                    let [a, b, c, d] = program[at].params[0];
                    let t = program[at].params[1];
                    plan.transforms[j] = [a, b, c, d, t[0], t[1]];
                }
                if let Some(t) = shading.textures().texture(op.texture) {
                    let rec = t.record();
                    (plan.width, plan.height, plan.has_texture) = (rec.width as f32, rec.height as f32, true);
                }
                plan.no_uv_key = shading.sort_key(material, &UvFootprint::default());
                return KeyPlan::Uv(plan);
            }
            // A MaterialX arithmetic result (say texture coordinates times a primvar) is followed
            // by the scalar key, which runs the op.
            op_kind::PRIMVAR | op_kind::MATH => regs[reg(op.dst)] = Source::Varying,
            op_kind::CONST => regs[reg(op.dst)] = Source::Constant,
            op_kind::PRIMVAR_UV => {
                regs[reg(op.dst)] = Source::Uv { transforms: [0; MAX_TRANSFORMS], count: 0 };
            }
            op_kind::TRANSFORM_2D => {
                regs[reg(op.dst)] = match regs[reg(op.src)] {
                    Source::Uv { mut transforms, count } if count < MAX_TRANSFORMS => {
                        transforms[count] = i;
                        Source::Uv { transforms, count: count + 1 }
                    }
                    Source::Constant => Source::Constant,
                    _ => Source::Varying,
                };
            }
            // `OUTPUT` and the value ops leave the coordinates alone (`Registers::step`).
            _ => {}
        }
    }
    KeyPlan::Scalar
}

/// Up to eight hits' key inputs: material and uv footprint per lane.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct KeyInputs {
    material: U32Lanes,
    uv: [Lanes; 2],
    duv_dx: [Lanes; 2],
    duv_dy: [Lanes; 2],
    has_uv: U32Lanes,
    len: usize,
}

impl KeyInputs {
    /// Adds a hit on `material` at `at` (lane `self.len()`).
    #[inline]
    pub fn push(&mut self, material: u32, at: &UvFootprint) {
        let k = self.len;
        self.material[k] = material;
        (self.uv[0][k], self.uv[1][k]) = (at.uv[0], at.uv[1]);
        (self.duv_dx[0][k], self.duv_dx[1][k]) = (at.duv_dx[0], at.duv_dx[1]);
        (self.duv_dy[0][k], self.duv_dy[1][k]) = (at.duv_dy[0], at.duv_dy[1]);
        self.has_uv[k] = at.has_uv as u32;
        self.len += 1;
    }

    /// Hits pushed.
    #[inline]
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when no hit was pushed.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Empties the group.
    #[cfg(test)]
    fn clear(&mut self) {
        self.len = 0;
    }
}

/// `keys[k] = shading.sort_key(material k, footprint k)` for the pushed lanes (`plans` from
/// [`plans`]). Lanes past `input.len()` get values nobody should read.
///
/// The sort-key pass meets hits in queue order, where runs of one material are common: a group on
/// one material reads its plan once (the lane loop then takes it as loop-invariant scalars), a
/// mixed group gathers each lane's plan into columns first.
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
pub fn keys(shading: &Shading, plans: &[KeyPlan], input: &KeyInputs, keys: &mut U32Lanes) {
    let first = input.material[0];
    if !input.material[..input.len].iter().all(|&m| m == first) {
        return gathered_keys(shading, plans, input, keys);
    }
    match &plans[first as usize] {
        KeyPlan::Uv(p) => lane_keys(input, keys, |k| LanePlan {
            transforms: p.transforms,
            count: p.count,
            width: p.width,
            height: p.height,
            has_texture: p.has_texture as u32,
            no_uv_key: p.no_uv_key,
            use_uv: input.has_uv[k],
        }),
        &KeyPlan::Constant(key) => *keys = [key; LANES],
        KeyPlan::Scalar => scalar_keys(shading, plans, input, keys),
    }
}

/// What lane `k`'s key takes from its material's plan.
#[derive(Clone, Copy)]
struct LanePlan {
    transforms: [[f32; 6]; MAX_TRANSFORMS],
    count: u32,
    width: f32,
    height: f32,
    has_texture: u32,
    /// The key where `use_uv` is 0.
    no_uv_key: u32,
    use_uv: u32,
}

/// [`keys`] for a group on several materials: each lane's plan gathered into columns.
#[inline(always)]
fn gathered_keys(shading: &Shading, plans: &[KeyPlan], input: &KeyInputs, keys: &mut U32Lanes) {
    // Lanes on a scalar plan are keyed after the lane loop.
    let mut t = [[[0.0f32; LANES]; 6]; MAX_TRANSFORMS];
    let (mut count, mut no_uv_key, mut use_uv) = ([0u32; LANES], [0u32; LANES], [0u32; LANES]);
    let (mut width, mut height, mut has_texture) = ([0.0f32; LANES], [0.0f32; LANES], [0u32; LANES]);
    let mut scalar = false;
    for k in 0..input.len {
        match &plans[input.material[k] as usize] {
            KeyPlan::Uv(p) => {
                for j in 0..MAX_TRANSFORMS {
                    for c in 0..6 {
                        t[j][c][k] = p.transforms[j][c];
                    }
                }
                (count[k], no_uv_key[k], use_uv[k]) = (p.count, p.no_uv_key, input.has_uv[k]);
                (width[k], height[k], has_texture[k]) = (p.width, p.height, p.has_texture as u32);
            }
            // `use_uv` 0: the lane takes `no_uv_key`.
            &KeyPlan::Constant(key) => (use_uv[k], no_uv_key[k]) = (0, key),
            KeyPlan::Scalar => scalar = true,
        }
    }
    lane_keys(input, keys, |k| LanePlan {
        // Spelled out: `array::map` here kept the lane loop from vectorising (+2.4 M instructions).
        transforms: [
            [t[0][0][k], t[0][1][k], t[0][2][k], t[0][3][k], t[0][4][k], t[0][5][k]],
            [t[1][0][k], t[1][1][k], t[1][2][k], t[1][3][k], t[1][4][k], t[1][5][k]],
        ],
        count: count[k],
        width: width[k],
        height: height[k],
        has_texture: has_texture[k],
        no_uv_key: no_uv_key[k],
        use_uv: use_uv[k],
    });
    if scalar {
        scalar_keys(shading, plans, input, keys);
    }
}

/// The lane loop: every lane's key from its uv footprint and `plan(lane)`.
#[inline(always)]
fn lane_keys(input: &KeyInputs, keys: &mut U32Lanes, plan: impl Fn(usize) -> LanePlan) {
    for k in 0..LANES {
        let LanePlan { transforms: t, count, width, height, has_texture, no_uv_key, use_uv } = plan(k);
        let (mut x, mut y) = (input.uv[0][k], input.uv[1][k]);
        let mut dx = [input.duv_dx[0][k], input.duv_dx[1][k]];
        let mut dy = [input.duv_dy[0][k], input.duv_dy[1][k]];
        for j in 0..MAX_TRANSFORMS {
            // `Registers::step`'s TRANSFORM_2D: `m(xy) + t`, `m(dx)`, `m(dy)`.
            let [a, b, c, d, tx, ty] = t[j];
            let m = |v: [f32; 2]| [a * v[0] + b * v[1], c * v[0] + d * v[1]];
            let p = m([x, y]);
            let on = (j as u32) < count;
            (x, y) = (if on { p[0] + tx } else { x }, if on { p[1] + ty } else { y });
            let (mx, my) = (m(dx), m(dy));
            dx = [if on { mx[0] } else { dx[0] }, if on { mx[1] } else { dx[1] }];
            dy = [if on { my[0] } else { dy[0] }, if on { my[1] } else { dy[1] }];
        }
        let level = if has_texture != 0 { sort_level(width, height, dx, dy) } else { 0 };
        let key = (level.min(MAX_SORT_MIP) << MIP_SHIFT) | morton(x, y);
        keys[k] = if use_uv != 0 { key } else { no_uv_key };
    }
}

/// `keys[k]` by [`Shading::sort_key`] for the pushed lanes on a scalar plan.
#[inline(never)]
fn scalar_keys(shading: &Shading, plans: &[KeyPlan], input: &KeyInputs, keys: &mut U32Lanes) {
    for k in 0..input.len {
        if plans[input.material[k] as usize] == KeyPlan::Scalar {
            let at = UvFootprint {
                uv: [input.uv[0][k], input.uv[1][k]],
                duv_dx: [input.duv_dx[0][k], input.duv_dx[1][k]],
                duv_dy: [input.duv_dy[0][k], input.duv_dy[1][k]],
                has_uv: input.has_uv[k] != 0,
                point: None,
            };
            keys[k] = shading.sort_key(input.material[k], &at);
        }
    }
}

/// [`crate::shading::sort_level`] for a `width × height` texture, branch-free.
#[inline(always)]
fn sort_level(width: f32, height: f32, duv_dx: [f32; 2], duv_dy: [f32; 2]) -> u32 {
    let squared = |d: [f32; 2]| {
        let (x, y) = (d[0] * width, d[1] * height);
        x * x + y * y
    };
    let twice = 2.0 * squared(duv_dx).max(squared(duv_dy));
    // No short circuit: both tests are lane compares.
    let magnifying = twice.is_nan() | (twice < f32::MIN_POSITIVE);
    let exponent = ((twice.to_bits() >> 23) & 0xff) as i32 - 127;
    let level = if exponent == 128 { u32::MAX } else { exponent.max(0) as u32 / 2 };
    if magnifying {
        0
    } else {
        level
    }
}

/// The Morton part of [`texture::shading_sort_key`]: each coordinate's fraction quantised to
/// 7 bits, u on the even bits, v on the odd ones.
///
/// Written so that it vectorises, with the scalar's results: `f32::floor` (one `vroundps`) equals
/// `texture::float::floor` on every input (NaN and infinities pass through both), and
/// `(f · 128) as u32).min(127)` equals truncating `f · 128` clamped to [0, 127] first (NaN to 0, as
/// the saturating cast does). The scalar forms compiled to a compare, a branch and a `cvttss2si`
/// per lane.
#[inline(always)]
fn morton(u: f32, v: f32) -> u32 {
    let q = |x: f32| {
        let scaled = (x - x.floor()) * 128.0;
        let clamped = if scaled >= 0.0 { scaled.min(127.0) } else { 0.0 };
        clamped as i32 as u32
    };
    spread7(q(u)) | (spread7(q(v)) << 1)
}

/// `texture::sort_key`'s `spread7`: the low 7 bits of `x` to the even bits 0, 2, .., 12.
#[inline(always)]
fn spread7(x: u32) -> u32 {
    let mut x = x & 0x7f;
    x = (x | (x << 4)) & 0x0f0f;
    x = (x | (x << 2)) & 0x3333;
    (x | (x << 1)) & 0x5555
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testscene::{self, card, Rng};
    use scene_pack::scene::{SceneTexture, ShaderNode, TextureData};

    /// Materials of every plan shape: uv → texture, uv → transform → texture, two transforms,
    /// three (scalar), a texture read from a constant (constant), one from a missing file (level 0),
    /// a transform chain in the high registers (the full register file), a chain whose texture
    /// reads the untransformed register while a transform writes another, a texture read from a
    /// primvar (scalar), and one from a register nothing wrote (constant).
    fn scene_bytes() -> blob::AlignedBytes {
        let texels = (0..64 * 16 * 4).map(|i| (crate::sampler::hash_u32(i) >> 13) as u8).collect();
        let src = texture::SourceImage {
            width: 64,
            height: 16,
            channels: 4,
            samples: texture::Samples::U8(texels),
        };
        let baked = texture::bake(&src, &texture::BakeOptions::default()).expect("valid image");
        let transform = |dst, src, deg: f32| ShaderNode::Transform2d {
            dst,
            src,
            rotation_degrees: deg,
            scale: [1.5, -0.5],
            translation: [0.1, -2.2],
        };
        let with = |extra: Vec<ShaderNode>, src: u32, texture: Option<u32>| {
            let mut program = ShaderNode::diffuse_texture_program(0, [0.5; 4]);
            if let ShaderNode::PrimvarUv { fallback, .. } = &mut program[0] {
                *fallback = [0.3, 0.7, 0.0, 1.0];
            }
            if let ShaderNode::Texture { src: s, texture: t, .. } = &mut program[1] {
                (*s, *t) = (src, texture);
            }
            for (i, node) in extra.into_iter().enumerate() {
                program.insert(1 + i, node);
            }
            program
        };
        let programs = vec![
            with(vec![], 0, Some(0)),
            with(vec![transform(3, 0, 20.0)], 3, Some(0)),
            with(vec![transform(2, 0, 20.0), transform(3, 2, -75.0)], 3, Some(0)),
            with(vec![transform(2, 0, 20.0), transform(3, 2, 5.0), transform(2, 3, 90.0)], 2, Some(0)),
            with(vec![ShaderNode::Const { dst: 2, value: [0.4, 0.6, 0.0, 1.0] }], 2, Some(0)),
            with(vec![transform(3, 0, 33.0)], 3, None),
            with(vec![transform(12, 0, 10.0), transform(9, 12, 45.0)], 9, Some(0)),
            with(vec![transform(3, 0, 10.0)], 0, Some(0)),
            with(
                vec![ShaderNode::Primvar { dst: 2, name: "st1".into(), fallback: [0.2, 0.9, 0.0, 1.0] }],
                2,
                Some(0),
            ),
            with(vec![transform(3, 2, 10.0)], 3, Some(0)),
            // Coordinates through a MaterialX multiply: the scalar key runs the op.
            with(
                vec![
                    ShaderNode::Const { dst: 4, value: [2.0, 3.0, 1.0, 1.0] },
                    ShaderNode::Math { dst: 2, op: scene_pack::scene::MathOp::Multiply, srcs: [0, 4, 4] },
                ],
                2,
                Some(0),
            ),
        ];
        let scene = scene_pack::Scene {
            meshes: vec![card(0.0, 1.0, 0)],
            materials: programs
                .into_iter()
                .map(|program| scene_pack::Material { program, ..scene_pack::Material::default() })
                .collect(),
            textures: vec![SceneTexture {
                path: "t".into(),
                color_space: texture::ColorSpace::Auto,
                data: TextureData::Image(baked),
            }],
            ..scene_pack::Scene::default()
        };
        testscene::bytes(&scene)
    }

    #[test]
    fn plans_follow_the_programs() {
        let bytes = scene_bytes();
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let shading = Shading::new(&view);
        let plans = plans(&shading, view.materials.len());
        let shape = |p: &KeyPlan| match p {
            KeyPlan::Uv(p) => Some((p.count, p.has_texture)),
            KeyPlan::Constant(_) => Some((9, true)),
            KeyPlan::Scalar => None,
        };
        let shapes: Vec<_> = plans.iter().map(shape).collect();
        assert_eq!(
            shapes,
            [
                Some((0, true)),
                Some((1, true)),
                Some((2, true)),
                None,
                Some((9, true)),
                Some((1, false)),
                Some((2, true)),
                Some((0, true)),
                None,
                Some((9, true)),
                None,
            ]
        );
    }

    /// Lanes equal [`Shading::sort_key`] on random footprints (tiny to huge, zero, infinite and NaN
    /// ones among them), uvs inside and far outside [0, 1), with and without uvs, 1 to 8 lanes.
    #[test]
    fn lanes_equal_scalar_keys() {
        let bytes = scene_bytes();
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let shading = Shading::new(&view);
        let plans = plans(&shading, view.materials.len());
        let materials = view.materials.len() as u32;
        let mut rng = Rng(23);
        let special = [0.0, -0.0, f32::INFINITY, f32::NAN, 1e30, 1e-40, -3.0];
        let value = |rng: &mut Rng, scale: f32| {
            if rng.next_f32() < 0.05 {
                special[(rng.next_f32() * special.len() as f32) as usize]
            } else {
                (rng.next_f32() - 0.5) * scale * 2.0f32.powf(rng.range(-12.0, 6.0))
            }
        };
        let mut input = KeyInputs::default();
        let (mut levels, mut compared) = ([0u32; 16], 0);
        let mut uniform_groups = 0;
        for round in 0..20_000 {
            input.clear();
            let mut want = Vec::new();
            // Every other round all lanes share one material (the uniform path), else each lane picks.
            let shared = (round / LANES).is_multiple_of(2);
            uniform_groups += shared as u32;
            let group_material = (rng.next_f32() * materials as f32) as u32;
            for _ in 0..1 + round % LANES {
                let own = (rng.next_f32() * materials as f32) as u32;
                let material = if shared { group_material } else { own };
                let at = UvFootprint {
                    uv: [value(&mut rng, 4.0), value(&mut rng, 4.0)],
                    duv_dx: [value(&mut rng, 0.1), value(&mut rng, 0.1)],
                    duv_dy: [value(&mut rng, 0.1), value(&mut rng, 0.1)],
                    has_uv: rng.next_f32() < 0.9,
                    point: None,
                };
                input.push(material, &at);
                want.push(shading.sort_key(material, &at));
            }
            let mut got = [0u32; LANES];
            keys(&shading, &plans, &input, &mut got);
            assert_eq!(got[..want.len()], want[..], "round {round}: {input:?}");
            for key in want {
                levels[((key >> MIP_SHIFT) & 15) as usize] += 1;
                compared += 1;
            }
        }
        eprintln!(
            "keys compared {compared} ({uniform_groups} groups on one material), by mip level {levels:?}"
        );
        assert!(uniform_groups > 5000, "{uniform_groups}");
        assert!(levels.iter().filter(|&&n| n > 100).count() >= 8, "{levels:?}");
    }
}
