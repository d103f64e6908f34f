//! Material programs run eight hits of one material at a time: the op list is interpreted once per
//! group over a register file of `[f32; 8]` columns (MoonRay's shaders over SIMD lanes). The scalar
//! reference is [`Shading::evaluate`]: each lane performs its IEEE operations in the same order, so
//! every lane's [`ShadingInputs`] equal the scalar ones bit for bit (the test checks it on random hits
//! for every filter).
//!
//! Per op: `CONST` broadcasts; `PRIMVAR_UV` selects per lane between the hit's uv footprint and the
//! fallback; `TRANSFORM_2D` is lane arithmetic (value and both footprint derivatives); `PRIMVAR` gathers
//! (each lane's triangle finds its own primvar record); `TEXTURE` hands the eight coordinates and
//! footprints to [`texture::sample_lanes_with`] (one texture per op, so the format is resolved once),
//! then applies scale and bias in lanes — a UDIM op picks a tile per lane, so it looks each lane up
//! alone; `MATH` runs [`blob::math`] per lane (a few flops: not worth a lane twin, and equal by
//! construction); `OUTPUT` writes the swizzled register into each lane's inputs.
//!
//! Register traffic (callgrind, shading-heavy 120×80, 8 spp, 1 thread: 11,443 groups, one texture op
//! each, ≈ 1,260 instructions a group outside the lookup): a second mask marking the registers that
//! hold derivatives, so texture, constant and primvar ops would store 128 bytes instead of 256, was
//! tried and left out — the render went from 603.70 M to 603.78 M instructions.
//!
//! What did cut it (same settings; the bench programs are `PRIMVAR_UV`, `TEXTURE` and two
//! `OUTPUT`s): `OUTPUT` matched the shading input and the swizzle per lane (through
//! `ShadingInputs::set`); it now resolves both once per op and writes each lane's field
//! (`output_lanes`, ≈ 70 instructions an op). `PRIMVAR_UV` read a transposed copy of the group's
//! footprints built up front; it now writes its register in place from the hits. Outside the
//! lookup: 14.6 M → 9.4 M (≈ 1,275 → 825 a group). With the cheaper lookups
//! (`texture/src/sample/lanes.rs`), `evaluate_lanes` inclusive 33.4 M → 19.1 M, whole render
//! 527.0 M → 512.6 M.

// Lane loops index several columns by the same lane number.
#![allow(clippy::needless_range_loop)]

use crate::shading::{reg, wrap, Shading, ShadingInputs, UvFootprint};
use blob::{op_kind, ShaderOp, MAX_REGISTERS, NONE};
use lanekit::LANES;
use texture::{Filter, LookupLanes, Touch};

use lanekit::Lanes;

const REGISTERS: usize = MAX_REGISTERS as usize;
const NO_DERIVATIVE: [Lanes; 2] = [[0.0; LANES]; 2];

static ZERO_VALUE: [Lanes; 4] = [[0.0; LANES]; 4];

/// The register file of eight programs: values and the footprint derivatives of their `xy`. Kept by
/// the worker and reused: a mask of the registers the current program wrote stands in for zeroing the
/// 4 KiB file per group (an unwritten register reads as zero, as in the scalar evaluator).
#[derive(Clone, Debug, Default)]
#[repr(C, align(32))]
pub struct RegisterLanes {
    value: [[Lanes; 4]; REGISTERS],
    dx: [[Lanes; 2]; REGISTERS],
    dy: [[Lanes; 2]; REGISTERS],
    written: u32,
}

impl RegisterLanes {
    #[inline]
    fn set(&mut self, r: u32, value: [Lanes; 4], dx: [Lanes; 2], dy: [Lanes; 2]) {
        let r = reg(r);
        self.written |= 1 << r;
        self.value[r] = value;
        self.dx[r] = dx;
        self.dy[r] = dy;
    }

    /// Register `r` to write whole, in place (value and both derivatives).
    #[inline]
    fn slot(&mut self, r: u32) -> (&mut [Lanes; 4], &mut [Lanes; 2], &mut [Lanes; 2]) {
        let r = reg(r);
        self.written |= 1 << r;
        (&mut self.value[r], &mut self.dx[r], &mut self.dy[r])
    }

    /// Register `r`: value and derivatives, zero where the program has not written it.
    #[inline]
    fn get(&self, r: u32) -> (&[Lanes; 4], &[Lanes; 2], &[Lanes; 2]) {
        let r = reg(r);
        if self.written & (1 << r) != 0 {
            (&self.value[r], &self.dx[r], &self.dy[r])
        } else {
            (&ZERO_VALUE, &NO_DERIVATIVE, &NO_DERIVATIVE)
        }
    }
}

/// Writes the shading inputs of `material` at the first `min(at.len(), 8)` hits `at` into the same
/// lanes of `inputs` (lane `k` at `at[k]`; the other lanes are left as they were), looking textures
/// up with `filter` and reporting texel reads to `touch`. Lane `k` equals `shading.evaluate(material,
/// at[k], filter, touch)` exactly. `regs` is scratch.
///
/// Writes in place: returning the eight inputs (640 bytes) by value cost a `memcpy` call per group
/// (~100 instructions; callgrind, tractor 120×80, 8 spp: 1.1 M of the render's 392 M).
pub fn evaluate_lanes<T: Touch>(
    shading: &Shading,
    material: u32,
    at: &[&UvFootprint],
    filter: Filter,
    touch: &T,
    regs: &mut RegisterLanes,
    inputs: &mut [ShadingInputs; LANES],
) {
    let at = &at[..at.len().min(LANES)];
    let constant = ShadingInputs::constant(shading.material(material));
    for lane in &mut inputs[..at.len()] {
        *lane = constant;
    }
    let program = shading.program(material);
    if program.is_empty() {
        return;
    }
    regs.written = 0;
    for op in program {
        match op.kind {
            op_kind::OUTPUT => output_lanes(&mut inputs[..at.len()], regs.get(op.src).0, op),
            op_kind::TEXTURE => {
                let value = texture_lanes(shading, op, regs, at.len(), filter, touch);
                regs.set(op.dst, value, NO_DERIVATIVE, NO_DERIVATIVE);
            }
            op_kind::PRIMVAR => {
                let mut value = [[0.0; LANES]; 4];
                for (k, a) in at.iter().enumerate() {
                    let v = shading.primvar(op, a);
                    for c in 0..4 {
                        value[c][k] = v[c];
                    }
                }
                regs.set(op.dst, value, NO_DERIVATIVE, NO_DERIVATIVE);
            }
            op_kind::CONST => regs.set(op.dst, broadcast(op.params[0]), NO_DERIVATIVE, NO_DERIVATIVE),
            op_kind::PRIMVAR_UV => primvar_uv_lanes(regs, op, at),
            op_kind::TRANSFORM_2D => transform_lanes(regs, op),
            op_kind::MATH => math_lanes(regs, op),
            _ => {}
        }
    }
}

/// `MATH`: the scalar [`crate::shading::math`] per lane (one copy of each function, so the lanes
/// equal the scalar program by construction; the ops are a few flops, not worth a lane twin).
fn math_lanes(regs: &mut RegisterLanes, op: &ShaderOp) {
    let column = |r: u32, k: usize| {
        let v = regs.get(r).0;
        [v[0][k], v[1][k], v[2][k], v[3][k]]
    };
    let mut value = [[0.0; LANES]; 4];
    for k in 0..LANES {
        let v = crate::shading::math(op.flags, column(op.src, k), column(op.src2, k), column(op.src3, k));
        for c in 0..4 {
            value[c][k] = v[c];
        }
    }
    regs.set(op.dst, value, NO_DERIVATIVE, NO_DERIVATIVE);
}

fn broadcast(v: [f32; 4]) -> [Lanes; 4] {
    v.map(|c| [c; LANES])
}

/// `PRIMVAR_UV`: `(u, v, 0, 1)` and the footprint where the mesh has uvs, else the fallback (lanes
/// past the group's hits too), written in place from the hits: no transposed copy of the footprints.
fn primvar_uv_lanes(regs: &mut RegisterLanes, op: &ShaderOp, at: &[&UvFootprint]) {
    let fallback = op.params[0];
    let (value, dx, dy) = regs.slot(op.dst);
    for k in 0..LANES {
        let hit = at.get(k).filter(|a| a.has_uv);
        let (uv, duv_dx, duv_dy) =
            hit.map_or(([fallback[0], fallback[1]], [0.0; 2], [0.0; 2]), |a| (a.uv, a.duv_dx, a.duv_dy));
        let zw = if hit.is_some() { [0.0, 1.0] } else { [fallback[2], fallback[3]] };
        for c in 0..2 {
            value[c][k] = uv[c];
            value[c + 2][k] = zw[c];
            dx[c][k] = duv_dx[c];
            dy[c][k] = duv_dy[c];
        }
    }
}

/// `OUTPUT` for every lane of `inputs`: the swizzle and the shading input resolved once per op
/// (each lane through [`ShadingInputs::set`] matched both per lane: ≈ 250 instructions of a
/// group's ≈ 1,275 outside the lookup on shading-heavy), by [`ShadingInputs::set_each`], the
/// mapping `set` uses too.
fn output_lanes(inputs: &mut [ShadingInputs], v: &[Lanes; 4], op: &ShaderOp) {
    let column = |i: u32| &v[((op.flags >> (2 * i)) & 3) as usize];
    let (x, y, z) = (column(0), column(1), column(2));
    ShadingInputs::set_each(inputs, op.dst, |k| [x[k], y[k], z[k]]);
}

/// `TRANSFORM_2D`: `xy ← M xy + t` and `M` applied to both derivatives (`zw` carried over).
fn transform_lanes(regs: &mut RegisterLanes, op: &ShaderOp) {
    let [a, b, c, d] = op.params[0];
    let t = op.params[1];
    let (v, dx, dy) = regs.get(op.src);
    let m = |v: &[Lanes; 2]| {
        let mut out = NO_DERIVATIVE;
        for k in 0..LANES {
            out[0][k] = a * v[0][k] + b * v[1][k];
            out[1][k] = c * v[0][k] + d * v[1][k];
        }
        out
    };
    let p = m(&[v[0], v[1]]);
    let mut value = *v;
    for k in 0..LANES {
        value[0][k] = p[0][k] + t[0];
        value[1][k] = p[1][k] + t[1];
    }
    let (dx, dy) = (m(dx), m(dy));
    regs.set(op.dst, value, dx, dy);
}

/// `TEXTURE` for the first `count` lanes: filtered texel · scale + bias, or the fallback without data.
fn texture_lanes<T: Touch>(
    shading: &Shading,
    op: &ShaderOp,
    regs: &RegisterLanes,
    count: usize,
    filter: Filter,
    touch: &T,
) -> [Lanes; 4] {
    let [scale, bias, fallback] = op.params;
    if op.texture == NONE {
        return broadcast(fallback);
    }
    let (value, dx, dy) = regs.get(op.src);
    if op.flags & blob::OP_UDIM != 0 {
        // The tile (a texture of its own) depends on each lane's uv.
        let mut out = [[0.0; LANES]; 4];
        for k in 0..count {
            let v = shading.lookup(
                op,
                [value[0][k], value[1][k]],
                [dx[0][k], dx[1][k]],
                [dy[0][k], dy[1][k]],
                filter,
                touch,
            );
            for c in 0..4 {
                out[c][k] = v[c];
            }
        }
        return out;
    }
    let Some(tex) = shading.textures().texture(op.texture) else { return broadcast(fallback) };
    let q = LookupLanes {
        uv: [value[0], value[1]],
        duv_dx: *dx,
        duv_dy: *dy,
        filter,
        wrap_s: wrap(blob::op_wrap_s(op.flags)),
        wrap_t: wrap(blob::op_wrap_t(op.flags)),
    };
    let mut texel = texture::sample_lanes_with(&tex, &q, count, touch);
    for c in 0..4 {
        for k in 0..LANES {
            texel[c][k] = texel[c][k] * scale[c] + bias[c];
        }
    }
    texel
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testscene::{self, card, Rng};
    use glam::{Vec2, Vec3};
    use scene_pack::scene::{
        MeshPrimvar, PrimvarLayout, SceneTexture, ShaderNode, ShadingInput, TextureData,
    };
    use scene_pack::{Material, Scene};
    use texture::Wrap;

    fn image(seed: u32, w: u32, h: u32, channels: u32) -> texture::BakedTexture {
        let texels =
            (0..w * h * channels).map(|i| (crate::sampler::hash_u32(i ^ seed) >> 11) as u8).collect();
        let src =
            texture::SourceImage { width: w, height: h, channels, samples: texture::Samples::U8(texels) };
        texture::bake(&src, &texture::BakeOptions::default()).expect("valid image")
    }

    fn texture_node(dst: u32, src: u32, texture: Option<u32>, wrap_s: Wrap, wrap_t: Wrap) -> ShaderNode {
        ShaderNode::Texture {
            dst,
            src,
            texture,
            wrap_s,
            wrap_t,
            scale: [1.5, 0.5, 2.0, 1.0],
            bias: [0.1, -0.2, 0.0, 0.25],
            fallback: [0.3, 0.6, 0.9, 1.0],
        }
    }

    fn out(input: ShadingInput, src: u32, swizzle: [u8; 4]) -> ShaderNode {
        ShaderNode::Output { input, src, swizzle }
    }

    /// Materials covering every op kind: textures through a UsdTransform2d with every wrap, a UDIM set
    /// with a hole, a missing file, primvars of every interpolation, a normal map, constants.
    fn scene() -> Scene {
        use ShadingInput::*;
        let mut card0 = card(0.0, 1.0, 0);
        card0.uvs = vec![Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0), Vec2::new(2.0, 1.5), Vec2::new(0.0, 1.5)];
        let widen = |v: f32| [v, 0.5 * v, 1.0 - v, 1.0];
        card0.primvars = vec![
            MeshPrimvar {
                name: "vert".into(),
                layout: PrimvarLayout::PerVertex,
                components: 3,
                values: (0..4).map(|i| widen(0.2 * i as f32)).collect(),
            },
            MeshPrimvar {
                name: "tri".into(),
                layout: PrimvarLayout::PerTriangle,
                components: 3,
                values: vec![widen(0.7), widen(0.1)],
            },
            MeshPrimvar {
                name: "corner".into(),
                layout: PrimvarLayout::PerCorner,
                components: 3,
                values: (0..6).map(|i| widen(0.15 * i as f32)).collect(),
            },
            MeshPrimvar {
                name: "one".into(),
                layout: PrimvarLayout::Constant,
                components: 1,
                values: vec![widen(0.4)],
            },
        ];
        let mut card1 = card(-1.0, 2.0, 1);
        card1.positions.iter_mut().for_each(|p| *p += Vec3::new(0.3, 0.0, 0.0));
        let primvar =
            |dst, name: &str| ShaderNode::Primvar { dst, name: name.into(), fallback: [0.9, 0.8, 0.7, 0.6] };
        let transformed = |wrap_s, wrap_t| {
            vec![
                ShaderNode::PrimvarUv { dst: 0, fallback: [0.25, 0.75, 0.0, 1.0] },
                ShaderNode::Transform2d {
                    dst: 3,
                    src: 0,
                    rotation_degrees: 33.0,
                    scale: [1.7, -0.6],
                    translation: [0.2, -0.35],
                },
                texture_node(1, 3, Some(0), wrap_s, wrap_t),
                texture_node(2, 0, Some(1), Wrap::Repeat, Wrap::Black),
                out(DiffuseColor, 1, [0, 1, 2, 3]),
                out(Roughness, 2, [3; 4]),
                out(Metallic, 1, [1; 4]),
                out(Opacity, 2, [0; 4]),
                out(Normal, 2, [2, 1, 0, 3]),
            ]
        };
        let materials = vec![
            Material { program: transformed(Wrap::Mirror, Wrap::Clamp), ..Material::default() },
            Material { program: transformed(Wrap::Black, Wrap::Repeat), ..Material::default() },
            Material {
                program: vec![
                    ShaderNode::PrimvarUv { dst: 0, fallback: [0.0; 4] },
                    ShaderNode::Transform2d {
                        dst: 0,
                        src: 0,
                        rotation_degrees: 0.0,
                        scale: [1.0, 1.0],
                        translation: [0.6, 0.4],
                    },
                    texture_node(1, 0, Some(2), Wrap::Repeat, Wrap::Repeat),
                    texture_node(2, 0, None, Wrap::Repeat, Wrap::Repeat),
                    // Written here, read unwritten by the next material: the reused register file
                    // must not leak it.
                    ShaderNode::Const { dst: 6, value: [0.7; 4] },
                    out(DiffuseColor, 1, [0, 1, 2, 3]),
                    out(SpecularColor, 2, [0, 1, 2, 3]),
                ],
                ..Material::default()
            },
            Material {
                program: vec![
                    primvar(0, "vert"),
                    primvar(1, "tri"),
                    primvar(2, "corner"),
                    primvar(3, "one"),
                    primvar(4, "absent"),
                    ShaderNode::Const { dst: 5, value: [0.05, 0.15, 0.25, 0.35] },
                    out(DiffuseColor, 0, [0, 1, 2, 3]),
                    out(EmissiveColor, 1, [0, 1, 2, 3]),
                    out(SpecularColor, 2, [0, 1, 2, 3]),
                    out(Clearcoat, 3, [0; 4]),
                    out(ClearcoatRoughness, 4, [1; 4]),
                    out(Ior, 5, [3; 4]),
                    out(Roughness, 6, [0; 4]),
                ],
                ..Material::default()
            },
            Material { program: math_program(), ..Material::default() },
            testscene::lambert(0.5),
        ];
        Scene {
            meshes: vec![card0, card1],
            materials,
            textures: vec![
                SceneTexture {
                    path: "a".into(),
                    color_space: texture::ColorSpace::Auto,
                    data: TextureData::Image(image(1, 61, 37, 4)),
                },
                SceneTexture {
                    path: "b".into(),
                    color_space: texture::ColorSpace::Auto,
                    data: TextureData::Image(image(2, 16, 16, 2)),
                },
                SceneTexture {
                    path: "<UDIM>".into(),
                    color_space: texture::ColorSpace::Auto,
                    data: TextureData::Udim(vec![
                        (0, 0, image(3, 8, 8, 3)),
                        (1, 0, image(4, 32, 8, 1)),
                        (1, 1, image(5, 4, 4, 4)),
                    ]),
                },
            ],
            ..Scene::default()
        }
    }

    /// Every `MATH` function over a texture, a primvar and constants (negative, zero and
    /// fractional operands: `powf` and `/` meet NaN and infinities), each bound to an input.
    fn math_program() -> Vec<ShaderNode> {
        use scene_pack::scene::MathOp::*;
        use ShadingInput::*;
        let math = |dst, op, srcs| ShaderNode::Math { dst, op, srcs };
        let ops = [
            Add,
            Subtract,
            Multiply,
            Divide,
            Mix,
            Clamp,
            Power,
            Min,
            Max,
            Swizzle([2, 0, 3, 1]),
            NormalMap,
            OneMinus,
            Absolute,
        ];
        let mut program = vec![
            ShaderNode::PrimvarUv { dst: 0, fallback: [0.25, 0.75, 0.0, 1.0] },
            texture_node(1, 0, Some(0), Wrap::Repeat, Wrap::Repeat),
            ShaderNode::Primvar { dst: 2, name: "vert".into(), fallback: [0.9, -0.8, 0.0, 0.6] },
            ShaderNode::Const { dst: 3, value: [-0.5, 0.0, 2.5, 0.3] },
        ];
        let inputs = [DiffuseColor, EmissiveColor, SpecularColor, Roughness, Metallic, Opacity, Normal];
        for (i, op) in ops.into_iter().enumerate() {
            // Registers 4..16, the last op overwriting register 4 after it was read.
            let dst = 4 + (i as u32 % 12);
            let srcs = [[1, 2, 3], [2, 3, 1], [3, 1, 2]][i % 3];
            let srcs = if i >= 6 { [dst - 1, srcs[1], srcs[2]] } else { srcs };
            program.push(math(dst, op, srcs));
            program.push(out(inputs[i % inputs.len()], dst, [0, 1, 2, 3]));
        }
        program
    }

    fn footprint(rng: &mut Rng, triangles: u32) -> UvFootprint {
        let d = |rng: &mut Rng| (rng.next_f32() - 0.5) * 10f32.powf(rng.range(-4.0, 1.0));
        let (b1, b2) = (rng.next_f32(), rng.next_f32());
        let (b1, b2) = if b1 + b2 > 1.0 { (1.0 - b1, 1.0 - b2) } else { (b1, b2) };
        let special = |rng: &mut Rng, v: f32| if rng.next_f32() < 0.03 { f32::NAN } else { v };
        let (u, dxv) = (rng.range(-1.5, 3.0), d(rng));
        UvFootprint {
            uv: [special(rng, u), rng.range(-1.0, 2.5)],
            duv_dx: [d(rng), special(rng, dxv)],
            duv_dy: [d(rng), d(rng)],
            has_uv: rng.next_f32() < 0.9,
            point: (rng.next_f32() < 0.95).then(|| crate::shading::MeshPoint {
                triangle: (rng.next_f32() * triangles as f32) as u32,
                b1,
                b2,
            }),
        }
    }

    /// Compares bit patterns, every NaN alike (which NaN an operation returns is unspecified).
    fn bits(inputs: &ShadingInputs) -> Vec<u32> {
        let b = |v: f32| if v.is_nan() { u32::MAX } else { v.to_bits() };
        let mut out: Vec<u32> = [inputs.diffuse_color, inputs.emissive_color, inputs.specular_color]
            .iter()
            .flat_map(|v| v.to_array())
            .chain([
                inputs.roughness,
                inputs.metallic,
                inputs.ior,
                inputs.opacity,
                inputs.opacity_threshold,
                inputs.clearcoat,
                inputs.clearcoat_roughness,
            ])
            .map(b)
            .collect();
        out.push(inputs.use_specular_workflow as u32);
        out.extend(inputs.normal.map_or([u32::MAX - 1; 3], |n| n.to_array().map(b)));
        out
    }

    #[test]
    fn lanes_equal_scalar_programs() {
        let bytes = testscene::bytes(&scene());
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let shading = Shading::new(&view);
        let triangles = view.triangles.len() as u32;
        let mut rng = Rng(11);
        let mut compared = 0;
        let mut regs = RegisterLanes::default();
        // Reused across groups, as the wavefront does: every group must overwrite its lanes.
        let mut got = [ShadingInputs::constant(shading.material(0)); LANES];
        for filter in Filter::ALL {
            for material in 0..view.materials.len() as u32 {
                for round in 0..40 {
                    let count = 1 + round % LANES;
                    let hits: Vec<UvFootprint> = (0..count).map(|_| footprint(&mut rng, triangles)).collect();
                    let at: Vec<&UvFootprint> = hits.iter().collect();
                    evaluate_lanes(&shading, material, &at, filter, &texture::NoTouch, &mut regs, &mut got);
                    for (k, hit) in hits.iter().enumerate() {
                        let want = shading.evaluate(material, hit, filter, &texture::NoTouch);
                        assert_eq!(
                            bits(&got[k]),
                            bits(&want),
                            "{filter:?}, material {material}, lane {k}: {hit:?}"
                        );
                        compared += 1;
                    }
                }
            }
        }
        assert!(compared > 4000, "{compared}");
        // The programs above produce varied inputs (not all fallbacks).
        let hit = footprint(&mut Rng(3), triangles);
        let a = shading.evaluate(0, &hit, Filter::Moonray, &texture::NoTouch);
        let b =
            shading.evaluate(0, &UvFootprint { uv: [0.37, 0.61], ..hit }, Filter::Moonray, &texture::NoTouch);
        assert_ne!(a.diffuse_color, b.diffuse_color);
    }
}
