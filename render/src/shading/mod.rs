//! Material programs: the UsdPreviewSurface inputs at one hit, evaluated from the blob's flat op list
//! with filtered texture lookups, without allocation.
//!
//! A material is its constants ([`blob::Material`]) plus an optional program ([`blob::ShaderOp`]s, see
//! [`blob::op_kind`]): straight-line code over [`blob::MAX_REGISTERS`] `vec4` registers that ends in
//! `OUTPUT` ops overriding constants. Next to each register the evaluator carries the pixel-footprint
//! derivatives of its `xy` (zero for constants, the hit's `duv/dx`, `duv/dy` for the texture
//! coordinates, transformed by `TRANSFORM_2D`), so a texture read through a UsdTransform2d picks its mip
//! level from the transformed footprint.
//!
//! `MATH` ops (MaterialX arithmetic, channel picks and normal maps; [`blob::math_op`]) apply
//! [`blob::math`], the one definition of each function, to their operand registers; the result
//! carries no footprint derivatives.
//!
//! `PRIMVAR` ops read the hit mesh's primvar from the blob's primvar tables and interpolate it with
//! the triangle's barycentrics ([`MeshPoint`]).
//!
//! The op kind is matched once per op; programs are a handful of ops, so a per-kind batch (one queue per
//! op kind) would not pay for itself in the scalar integrator. The wavefront integrator runs the same
//! programs eight hits at a time instead ([`crate::shading::lanes`], equal to
//! [`Shading::evaluate`] bit for bit).
//!
//! Programs that name registers 0..4 only (the usual uv reader → transform → texture chain) run on a
//! 4-register file: zeroing the 16-register file was a 512-byte `memset` call per evaluation and per
//! sort key. With the texture crate's inline `floor`/`round`, on the shading-heavy bench scene
//! (callgrind, 120×80, 8 spp, 1 thread) `Shading::evaluate` fell from 92.3 M to 80.4 M instructions
//! inclusive (−13 %) and `Shading::sort_key` from 32.5 M to 30.8 M (−5 %; what remains is mostly
//! the footprint's `sqrt`s and `log2`, the same as the lookup's, and the program's coordinate ops).
//! The key's level now comes from the exponent of the squared footprint ([`sort_level`]), with no
//! `sqrt` or `log2`: `Shading::sort_key` 30.8 M → 25.5 M instructions inclusive on shading-heavy
//! (whole render 635.4 M → 630.0 M, −0.8 %; tractor 383.4 M → 382.1 M, −0.35 %), images unchanged.
//! Reusing the key's level in the lookup instead was not done: the surface-side table it needs
//! would live in the wavefront's worker, and only kept surfaces (textured triangle hits) have one.

pub mod lanes;
pub mod sort_key;

use blob::{op_kind, shading_input, ShaderOp, MAX_REGISTERS, NONE};
use glam::Vec3;
use texture::{Filter, Lookup, TextureSetView, Touch, Wrap};

/// The triangle a hit is on and where inside it: what primvar reads interpolate with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshPoint {
    /// Index into the triangles section.
    pub triangle: u32,
    /// Barycentric weights of the triangle's second and third vertex (the first has `1 − b1 − b2`).
    pub b1: f32,
    /// See `b1`.
    pub b2: f32,
}

/// Where on a texture a hit is, and how large its pixel footprint is there.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UvFootprint {
    /// Texture coordinates at the hit (`(0, 0)` on a mesh without them).
    pub uv: [f32; 2],
    /// Change of `uv` across the footprint's first axis (one pixel).
    pub duv_dx: [f32; 2],
    /// Change of `uv` across the second axis.
    pub duv_dy: [f32; 2],
    /// The mesh has texture coordinates (otherwise primvar readers return their fallback).
    pub has_uv: bool,
    /// The triangle hit (`None` for curves and points: their primvar reads return the fallback).
    pub point: Option<MeshPoint>,
}

/// A blob record's input in render's type.
macro_rules! shading_input {
    (color, $v:expr) => {
        Vec3::from($v)
    };
    (float, $v:expr) => {
        $v
    };
    (flag, $v:expr) => {
        $v != 0
    };
}

macro_rules! shading_inputs {
    ($($field:ident: $kind:ident = $fallback:expr, $usd:literal;)*) => {
        /// The UsdPreviewSurface inputs at one shading point, after the program ran: the constants
        /// of [`blob::preview_surface_constants!`] and the tangent-space normal.
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct ShadingInputs {
            $(
                #[doc = concat!("`", $usd, "`.")]
                pub $field: blob::model_input_type!($kind, Vec3),
            )*
            /// Tangent-space `normal` when a program drives it (`None`: the interpolated normal).
            pub normal: Option<Vec3>,
        }

        impl ShadingInputs {
            /// The constants of a material (what a material without a program shades with).
            pub fn constant(m: &blob::Material) -> Self {
                ShadingInputs { $($field: shading_input!($kind, m.$field),)* normal: None }
            }
        }
    };
}
blob::preview_surface_constants!(shading_inputs);

impl ShadingInputs {
    /// UsdPreviewSurface opacity as a pass-through probability: `opacityThreshold > 0` makes it a
    /// cut-out (below the threshold fully transparent, else opaque).
    #[inline]
    pub fn effective_opacity(&self) -> f32 {
        if self.opacity_threshold > 0.0 {
            if self.opacity < self.opacity_threshold {
                0.0
            } else {
                1.0
            }
        } else {
            self.opacity.clamp(0.0, 1.0)
        }
    }

    /// The `1 − opacity` part of the surface is a refracting dielectric of index `ior`
    /// ([`crate::bsdf::dielectric`]) rather than a hole: the UsdPreviewSurface reading of `opacity`
    /// when it is not a cut-out (`opacityThreshold = 0`), for any `ior` but 1 (an interface of index 1
    /// neither reflects nor bends, so it stays the cheaper pass-through).
    #[inline]
    pub fn refracts(&self) -> bool {
        self.opacity_threshold <= 0.0 && self.ior != 1.0 && self.ior > 0.0 && self.ior.is_finite()
    }

    /// Binds `v` (an `OUTPUT` op's swizzled register) to shading input `input`.
    pub(crate) fn set(&mut self, input: u32, v: [f32; 4]) {
        Self::set_each(std::slice::from_mut(self), input, |_| [v[0], v[1], v[2]]);
    }

    /// Binds shading input `input` of every entry `k` of `inputs` to `value(k)`: a colour takes its
    /// three channels, a scalar the first. The one mapping from an input to its field, for the
    /// scalar program ([`Self::set`]) and the lanes (`material_lanes`), which call it once per op
    /// rather than once per lane. Inlined, so unused channels are never read.
    #[inline(always)]
    pub(crate) fn set_each(inputs: &mut [ShadingInputs], input: u32, value: impl Fn(usize) -> [f32; 3]) {
        #[inline(always)]
        fn each(inputs: &mut [ShadingInputs], f: impl Fn(&mut ShadingInputs, usize)) {
            for (k, lane) in inputs.iter_mut().enumerate() {
                f(lane, k);
            }
        }
        let rgb = |k: usize| Vec3::from_array(value(k));
        let x = |k: usize| value(k)[0];
        match input {
            shading_input::DIFFUSE_COLOR => each(inputs, |l, k| l.diffuse_color = rgb(k)),
            shading_input::EMISSIVE_COLOR => each(inputs, |l, k| l.emissive_color = rgb(k)),
            shading_input::SPECULAR_COLOR => each(inputs, |l, k| l.specular_color = rgb(k)),
            shading_input::ROUGHNESS => each(inputs, |l, k| l.roughness = x(k)),
            shading_input::METALLIC => each(inputs, |l, k| l.metallic = x(k)),
            shading_input::OPACITY => each(inputs, |l, k| l.opacity = x(k)),
            shading_input::NORMAL => each(inputs, |l, k| l.normal = Some(rgb(k))),
            shading_input::CLEARCOAT => each(inputs, |l, k| l.clearcoat = x(k)),
            shading_input::CLEARCOAT_ROUGHNESS => each(inputs, |l, k| l.clearcoat_roughness = x(k)),
            shading_input::IOR => each(inputs, |l, k| l.ior = x(k)),
            _ => {}
        }
    }
}

/// Per-material facts the integrator branches on, found once at load.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ProgramFlags {
    /// A program writes `opacity` (shadow rays must evaluate it per hit).
    pub textured_opacity: bool,
    /// A program writes `emissiveColor` (light samples must evaluate it per point).
    pub textured_emission: bool,
}

/// The materials, their programs and the texture tables of a validated blob.
#[derive(Clone, Debug)]
pub struct Shading<'a> {
    materials: &'a [blob::Material],
    ops: &'a [ShaderOp],
    primvars: Primvars<'a>,
    textures: TextureSetView<'a>,
    flags: Vec<ProgramFlags>,
    /// Per material: its program names registers below [`SMALL_FILE`] only.
    small_file: Vec<bool>,
    any_textured_opacity: bool,
}

/// Registers of the small register file. Most programs (a texture read through a uv reader, maybe a
/// transform) use registers 0..4; zeroing the full 16-register file (512 bytes) was a `memset` call
/// per evaluation and per sort key (0.4 % of the scalar integrator's instructions and 0.5 % of the
/// wavefront's on the shading-heavy scene), while 4 registers zero in a few vector stores.
const SMALL_FILE: usize = 4;

/// One more than the largest register `program` names (0 for an empty program).
fn registers_used(program: &[ShaderOp]) -> u32 {
    let named = |op: &ShaderOp| match op.kind {
        op_kind::OUTPUT => op.src,
        op_kind::TEXTURE | op_kind::TRANSFORM_2D => op.src.max(op.dst),
        op_kind::MATH => op.dst.max(op.src).max(op.src2).max(op.src3),
        op_kind::CONST | op_kind::PRIMVAR_UV | op_kind::PRIMVAR => op.dst,
        _ => 0,
    };
    program.iter().map(|op| named(op).saturating_add(1)).max().unwrap_or(0)
}

/// Wrap code of a texture op (see [`blob::op_wrap_s`]).
pub(crate) fn wrap(code: u32) -> Wrap {
    match code {
        1 => Wrap::Mirror,
        2 => Wrap::Clamp,
        3 => Wrap::Black,
        _ => Wrap::Repeat,
    }
}

impl<'a> Shading<'a> {
    /// Wraps the validated view's materials, programs and textures.
    pub fn new(view: &blob::SceneView<'a>) -> Self {
        // The blob validated every record the way `TextureSetView::new` does (same checks, repeated in
        // the blob crate), so this cannot fail; an empty view would only make lookups return fallbacks.
        let textures =
            TextureSetView::new(view.texture_records, view.udim_sets, view.udim_tiles, view.texels)
                .unwrap_or_else(|_| TextureSetView::new(&[], &[], &[], &[]).expect("empty tables are valid"));
        let flags: Vec<ProgramFlags> = view
            .materials
            .iter()
            .map(|m| {
                let ops = &view.shader_ops[m.program_start as usize..][..m.program_len as usize];
                let writes = |input| ops.iter().any(|op| op.kind == op_kind::OUTPUT && op.dst == input);
                ProgramFlags {
                    textured_opacity: writes(shading_input::OPACITY),
                    textured_emission: writes(shading_input::EMISSIVE_COLOR),
                }
            })
            .collect();
        let any_textured_opacity = flags.iter().any(|f| f.textured_opacity);
        let small_file = view
            .materials
            .iter()
            .map(|m| {
                let ops = &view.shader_ops[m.program_start as usize..][..m.program_len as usize];
                registers_used(ops) as usize <= SMALL_FILE
            })
            .collect();
        let primvars = Primvars {
            records: view.primvars,
            values: view.primvar_values,
            triangles: view.triangles,
            meshes: view.meshes,
        };
        Shading {
            materials: view.materials,
            ops: view.shader_ops,
            primvars,
            textures,
            flags,
            small_file,
            any_textured_opacity,
        }
    }

    /// The texture tables.
    pub fn textures(&self) -> &TextureSetView<'a> {
        &self.textures
    }

    /// Facts about material `material`'s program.
    #[inline]
    pub fn flags(&self, material: u32) -> ProgramFlags {
        self.flags[material as usize]
    }

    /// Some material's opacity comes from a program.
    pub fn any_textured_opacity(&self) -> bool {
        self.any_textured_opacity
    }

    /// The constants of material `material`.
    #[inline]
    pub(crate) fn material(&self, material: u32) -> &'a blob::Material {
        &self.materials[material as usize]
    }

    /// The op list of material `material` (empty without a program).
    pub(crate) fn program(&self, material: u32) -> &'a [ShaderOp] {
        let m = &self.materials[material as usize];
        // In range: validated by `SceneView::parse`.
        &self.ops[m.program_start as usize..][..m.program_len as usize]
    }

    /// The shading inputs of `material` at `at`, looking textures up with `filter` and reporting texel
    /// reads to `touch`.
    pub fn evaluate<T: Touch>(
        &self,
        material: u32,
        at: &UvFootprint,
        filter: Filter,
        touch: &T,
    ) -> ShadingInputs {
        let mut inputs = ShadingInputs::constant(&self.materials[material as usize]);
        let program = self.program(material);
        if program.is_empty() {
            return inputs;
        }
        if self.small_file[material as usize] {
            self.run::<SMALL_FILE, T>(program, at, filter, touch, &mut inputs);
        } else {
            self.run::<{ MAX_REGISTERS as usize }, T>(program, at, filter, touch, &mut inputs);
        }
        inputs
    }

    /// Runs `program` with an `N`-register file, writing its outputs into `inputs`.
    #[inline(always)]
    fn run<const N: usize, T: Touch>(
        &self,
        program: &[ShaderOp],
        at: &UvFootprint,
        filter: Filter,
        touch: &T,
        inputs: &mut ShadingInputs,
    ) {
        let mut regs = Registers::<N>::default();
        for op in program {
            match op.kind {
                op_kind::OUTPUT => inputs.set(op.dst, swizzle(regs.value[regs.index(op.src)], op.flags)),
                op_kind::TEXTURE => {
                    let (uv, dx, dy) = regs.coordinates(op.src);
                    let value = self.lookup(op, uv, dx, dy, filter, touch);
                    regs.set(op.dst, value, [0.0; 2], [0.0; 2]);
                }
                op_kind::PRIMVAR => regs.set(op.dst, self.primvars.read(op, at), [0.0; 2], [0.0; 2]),
                _ => regs.step(op, at),
            }
        }
    }

    /// A `PRIMVAR` op at `at` (see [`Primvars::read`]).
    #[inline]
    pub(crate) fn primvar(&self, op: &ShaderOp, at: &UvFootprint) -> [f32; 4] {
        self.primvars.read(op, at)
    }

    /// One UsdUVTexture op: filtered texel · scale + bias, or the fallback where there is no data.
    #[inline]
    pub(crate) fn lookup<T: Touch>(
        &self,
        op: &ShaderOp,
        uv: [f32; 2],
        duv_dx: [f32; 2],
        duv_dy: [f32; 2],
        filter: Filter,
        touch: &T,
    ) -> [f32; 4] {
        let [scale, bias, fallback] = op.params;
        let lookup = Lookup {
            uv,
            duv_dx,
            duv_dy,
            filter,
            wrap_s: wrap(blob::op_wrap_s(op.flags)),
            wrap_t: wrap(blob::op_wrap_t(op.flags)),
        };
        let texel = if op.texture == NONE {
            return fallback;
        } else if op.flags & blob::OP_UDIM != 0 {
            match self.textures.udim_tile(op.texture, uv) {
                Some((_, Some(_))) => self.textures.sample_udim_with(op.texture, &lookup, fallback, touch),
                _ => return fallback,
            }
        } else {
            match self.textures.texture(op.texture) {
                Some(tex) => texture::sample_with(&tex, &lookup, touch),
                None => return fallback,
            }
        };
        std::array::from_fn(|i| texel[i] * scale[i] + bias[i])
    }

    /// The shading sort key of a hit on `material` (see [`texture::shading_sort_key`]): UDIM tile,
    /// mip level and `uv` of the program's first texture lookup, so that queue entries sorted by it
    /// read neighbouring texel tiles. 0 for materials without textures. Costs the coordinate ops of
    /// the program, no texel reads.
    pub fn sort_key(&self, material: u32, at: &UvFootprint) -> u32 {
        let program = self.program(material);
        if self.small_file[material as usize] {
            self.key_of::<SMALL_FILE>(program, at)
        } else {
            self.key_of::<{ MAX_REGISTERS as usize }>(program, at)
        }
    }

    /// [`Self::sort_key`] with an `N`-register file.
    #[inline(always)]
    fn key_of<const N: usize>(&self, program: &[ShaderOp], at: &UvFootprint) -> u32 {
        let mut regs = Registers::<N>::default();
        for op in program {
            match op.kind {
                op_kind::OUTPUT => {}
                op_kind::TEXTURE => {
                    let (uv, dx, dy) = regs.coordinates(op.src);
                    let (tile, texture) = if op.flags & blob::OP_UDIM != 0 {
                        match self.textures.udim_tile(op.texture, uv) {
                            Some((tile, Some(t))) => (tile, t),
                            Some((tile, None)) => return texture::shading_sort_key_saturating(tile, 0, uv),
                            None => return 0,
                        }
                    } else {
                        (0, op.texture)
                    };
                    let level = self.textures.texture(texture).map_or(0, |t| sort_level(t.record(), dx, dy));
                    return texture::shading_sort_key_saturating(tile, level, uv);
                }
                op_kind::PRIMVAR => regs.set(op.dst, self.primvars.read(op, at), [0.0; 2], [0.0; 2]),
                _ => regs.step(op, at),
            }
        }
        0
    }
}

/// The mip level a sort key carries for footprint `(duv_dx, duv_dy)` on texture `rec`: the nearest
/// integer to [`texture::mip_level`], 0 when magnifying (negative, `-inf` or NaN levels), saturating
/// at `u32::MAX` for an infinite one. Read off the exponent of twice the larger squared axis:
/// `round(log2 √q) = ⌊log2(2q) / 2⌋ = ⌊⌊log2 2q⌋ / 2⌋`, and `⌊log2 x⌋` of a normal float is its
/// exponent. The lookup's level (which needs the fraction) comes from `sqrt`s and `log2`; the key
/// needs neither: they were ~70 of the ~340 instructions of a [`Shading::sort_key`] (callgrind,
/// shading-heavy). Where `log2`'s rounding and the exponent disagree (within an ulp of a half-way
/// level) the key's level differs by one; that changes only the order hits are shaded in, never
/// a pixel.
#[inline]
pub(crate) fn sort_level(rec: &texture::TextureRecord, duv_dx: [f32; 2], duv_dy: [f32; 2]) -> u32 {
    let (w, h) = (rec.width as f32, rec.height as f32);
    let squared = |d: [f32; 2]| {
        let (x, y) = (d[0] * w, d[1] * h);
        x * x + y * y
    };
    let twice = 2.0 * squared(duv_dx).max(squared(duv_dy));
    if twice.is_nan() || twice < f32::MIN_POSITIVE {
        return 0; // NaN, zero or subnormal: magnifying
    }
    // ⌊log2⌋ of a normal float (an infinite one has the largest exponent, 128: saturates below).
    let exponent = ((twice.to_bits() >> 23) & 0xff) as i32 - 127;
    if exponent == 128 {
        return u32::MAX;
    }
    exponent.max(0) as u32 / 2
}

/// The primvar tables of a validated blob, with what a read needs to find the hit's values.
#[derive(Clone, Copy, Debug)]
struct Primvars<'a> {
    records: &'a [blob::PrimvarRecord],
    values: &'a [[f32; 4]],
    triangles: &'a [blob::Triangle],
    meshes: &'a [blob::Mesh],
}

impl Primvars<'_> {
    /// A `PRIMVAR` op at `at`: the mesh's primvar `op.src` interpolated with the barycentrics, or the
    /// op's fallback. Records are sorted by `(mesh, name_id)` (validated), so this is a binary search;
    /// value ranges were checked against the mesh's triangle and vertex counts by `SceneView::parse`.
    #[inline]
    fn read(&self, op: &ShaderOp, at: &UvFootprint) -> [f32; 4] {
        let fallback = op.params[0];
        let Some(point) = at.point else { return fallback };
        let Some(tri) = self.triangles.get(point.triangle as usize) else { return fallback };
        let key = (tri.mesh, op.src);
        let Ok(i) = self.records.binary_search_by(|r| (r.mesh, r.name_id).cmp(&key)) else { return fallback };
        let r = &self.records[i];
        let values = &self.values[r.first_value as usize..][..r.value_count as usize];
        let mesh = &self.meshes[tri.mesh as usize];
        // Ingest puts every triangle inside its mesh's range; the parse does not demand it, so check.
        let Some(local) =
            point.triangle.checked_sub(mesh.first_triangle).filter(|&l| l < mesh.triangle_count)
        else {
            return fallback;
        };
        let local = local as usize;
        let w = [1.0 - point.b1 - point.b2, point.b1, point.b2];
        let blend =
            |v: [[f32; 4]; 3]| std::array::from_fn(|k| v[0][k] * w[0] + v[1][k] * w[1] + v[2][k] * w[2]);
        match r.interpolation {
            blob::primvar_interpolation::CONSTANT => values[0],
            blob::primvar_interpolation::UNIFORM => values[local],
            blob::primvar_interpolation::VERTEX => {
                blend(tri.vertices.map(|v| values[(v - mesh.first_vertex) as usize]))
            }
            _ => blend([values[3 * local], values[3 * local + 1], values[3 * local + 2]]),
        }
    }
}

/// Register index, masked into range (validated at parse; the mask keeps the compiler from
/// inserting a bounds check).
#[inline(always)]
pub(crate) fn reg(r: u32) -> usize {
    const { assert!(MAX_REGISTERS.is_power_of_two()) };
    (r & (MAX_REGISTERS - 1)) as usize
}

/// A `MATH` op's function of its operand values: [`blob::math`], the one definition (the lanes
/// run it per lane, so they equal the scalar program by construction).
pub(crate) use blob::math;

/// `OUTPUT`'s swizzle: four 2-bit channel selectors, lowest first.
#[inline]
pub(crate) fn swizzle(v: [f32; 4], flags: u32) -> [f32; 4] {
    std::array::from_fn(|i| v[((flags >> (2 * i)) & 3) as usize])
}

/// The register file: values and the footprint derivatives of their `xy`; `N` registers (a power of
/// two, [`SMALL_FILE`] or [`MAX_REGISTERS`]), chosen per material from the registers its program names.
struct Registers<const N: usize> {
    value: [[f32; 4]; N],
    dx: [[f32; 2]; N],
    dy: [[f32; 2]; N],
}

impl<const N: usize> Default for Registers<N> {
    #[inline(always)]
    fn default() -> Self {
        Registers { value: [[0.0; 4]; N], dx: [[0.0; 2]; N], dy: [[0.0; 2]; N] }
    }
}

impl<const N: usize> Registers<N> {
    /// Register `r`'s slot: `r` itself, since the file was chosen to hold every register the
    /// program names (the mask keeps the compiler from inserting a bounds check).
    #[inline(always)]
    fn index(&self, r: u32) -> usize {
        const { assert!(N.is_power_of_two() && N <= MAX_REGISTERS as usize) };
        reg(r) & (N - 1)
    }

    #[inline]
    fn set(&mut self, r: u32, value: [f32; 4], dx: [f32; 2], dy: [f32; 2]) {
        let r = self.index(r);
        self.value[r] = value;
        self.dx[r] = dx;
        self.dy[r] = dy;
    }

    #[inline]
    fn coordinates(&self, r: u32) -> ([f32; 2], [f32; 2], [f32; 2]) {
        let r = self.index(r);
        ([self.value[r][0], self.value[r][1]], self.dx[r], self.dy[r])
    }

    /// The coordinate ops (`CONST`, `PRIMVAR_UV`, `TRANSFORM_2D`).
    #[inline]
    fn step(&mut self, op: &ShaderOp, at: &UvFootprint) {
        match op.kind {
            op_kind::CONST => self.set(op.dst, op.params[0], [0.0; 2], [0.0; 2]),
            op_kind::PRIMVAR_UV => {
                if at.has_uv {
                    self.set(op.dst, [at.uv[0], at.uv[1], 0.0, 1.0], at.duv_dx, at.duv_dy);
                } else {
                    self.set(op.dst, op.params[0], [0.0; 2], [0.0; 2]);
                }
            }
            op_kind::MATH => {
                let v = |r| self.value[self.index(r)];
                self.set(op.dst, math(op.flags, v(op.src), v(op.src2), v(op.src3)), [0.0; 2], [0.0; 2]);
            }
            op_kind::TRANSFORM_2D => {
                let [a, b, c, d] = op.params[0];
                let t = op.params[1];
                let m = |v: [f32; 2]| [a * v[0] + b * v[1], c * v[0] + d * v[1]];
                let (xy, dx, dy) = self.coordinates(op.src);
                let v = self.value[self.index(op.src)];
                let p = m(xy);
                self.set(op.dst, [p[0] + t[0], p[1] + t[1], v[2], v[3]], m(dx), m(dy));
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The small register file is chosen only for programs it holds, and gives the same inputs and
    /// sort keys as the full file.
    #[test]
    fn small_register_file_equals_the_full_one() {
        use crate::testscene::{self, card, Rng};
        use scene_pack::scene::{SceneTexture, ShaderNode, ShadingInput, TextureData};
        let texels = (0..16 * 8 * 4).map(|i| (crate::sampler::hash_u32(i) >> 13) as u8).collect();
        let src =
            texture::SourceImage { width: 16, height: 8, channels: 4, samples: texture::Samples::U8(texels) };
        let baked = texture::bake(&src, &texture::BakeOptions::default()).expect("valid image");
        let mut small = ShaderNode::diffuse_texture_program(0, [0.5; 4]);
        small.insert(
            1,
            ShaderNode::Transform2d {
                dst: 3,
                src: 0,
                rotation_degrees: 20.0,
                scale: [1.5, 0.5],
                translation: [0.1, 0.2],
            },
        );
        if let ShaderNode::Texture { src, .. } = &mut small[2] {
            *src = 3;
        }
        small.push(ShaderNode::Output { input: ShadingInput::Roughness, src: 1, swizzle: [3; 4] });
        let mut large = small.clone();
        large.push(ShaderNode::Const { dst: 9, value: [0.25; 4] });
        large.push(ShaderNode::Output { input: ShadingInput::Metallic, src: 9, swizzle: [0; 4] });
        let scene = scene_pack::Scene {
            meshes: vec![card(0.0, 1.0, 0)],
            materials: vec![
                scene_pack::Material { program: small, ..scene_pack::Material::default() },
                scene_pack::Material { program: large, ..scene_pack::Material::default() },
            ],
            textures: vec![SceneTexture {
                path: "t".into(),
                color_space: texture::ColorSpace::Auto,
                data: TextureData::Image(baked),
            }],
            ..scene_pack::Scene::default()
        };
        let bytes = testscene::bytes(&scene);
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let shading = Shading::new(&view);
        assert_eq!(shading.small_file, [true, false]);
        let mut rng = Rng(5);
        for _ in 0..500 {
            let d = |rng: &mut Rng| (rng.next_f32() - 0.5) * 0.05;
            let at = UvFootprint {
                uv: [rng.range(-2.0, 3.0), rng.range(-2.0, 3.0)],
                duv_dx: [d(&mut rng), d(&mut rng)],
                duv_dy: [d(&mut rng), d(&mut rng)],
                has_uv: true,
                point: None,
            };
            for material in 0..2 {
                let program = shading.program(material);
                let mut full = ShadingInputs::constant(shading.material(material));
                shading.run::<{ MAX_REGISTERS as usize }, _>(
                    program,
                    &at,
                    Filter::Moonray,
                    &texture::NoTouch,
                    &mut full,
                );
                assert_eq!(shading.evaluate(material, &at, Filter::Moonray, &texture::NoTouch), full);
                let key = shading.key_of::<{ MAX_REGISTERS as usize }>(program, &at);
                assert_eq!(shading.sort_key(material, &at), key);
            }
        }
        // Material 1 reads metallic from register 9: the full file ran it.
        let at = UvFootprint { has_uv: true, ..Default::default() };
        assert_eq!(shading.evaluate(1, &at, Filter::Moonray, &texture::NoTouch).metallic, 0.25);
    }

    /// The sort key's level is `round(mip_level)` (0 when magnifying) except within float rounding
    /// of a half-way level, on footprints spanning magnification to the coarsest levels.
    #[test]
    fn sort_level_is_the_rounded_mip_level() {
        use crate::testscene::Rng;
        let rec = texture::TextureRecord { width: 1024, height: 256, ..bytemuck::Zeroable::zeroed() };
        let mut rng = Rng(9);
        let (mut compared, mut minified) = (0, 0);
        for _ in 0..100_000 {
            let scale = 2.0f32.powf(rng.range(-16.0, 2.0));
            let mut d = || (rng.next_f32() - 0.5) * scale;
            let (dx, dy) = ([d(), d()], [d(), d()]);
            let level = texture::mip_level(&rec, dx, dy);
            let want = texture::float::round(level) as u32;
            let got = sort_level(&rec, dx, dy);
            let near_half = (level - level.floor() - 0.5).abs() < 1e-5;
            assert!(got == want || near_half, "{dx:?} {dy:?}: level {level}, key level {got}, want {want}");
            compared += 1;
            minified += (want > 0) as u32;
        }
        assert!(compared == 100_000 && minified > 30_000, "{minified} minified");
        let at = |dx, dy| sort_level(&rec, dx, dy);
        assert_eq!(at([0.0; 2], [0.0; 2]), 0, "zero footprint");
        assert_eq!(at([f32::NAN, 0.0], [0.0; 2]), 0, "NaN");
        assert_eq!(at([f32::INFINITY, 0.0], [0.0; 2]), u32::MAX, "infinite");
        assert_eq!(at([1e-30, 0.0], [0.0; 2]), 0, "subnormal");
        // 4 texels across: level 2; √2·4 ≈ 5.66 texels: log2 = 2.5 → rounds up to 3 away from the edge.
        assert_eq!(at([4.0 / 1024.0, 0.0], [0.0; 2]), 2);
        assert_eq!(at([5.7 / 1024.0, 0.0], [0.0; 2]), 3);
        assert_eq!(at([5.6 / 1024.0, 0.0], [0.0; 2]), 2);
    }

    #[test]
    fn registers_used_counts_every_named_register() {
        let op = |kind, dst, src| ShaderOp { kind, dst, src, ..Default::default() };
        assert_eq!(registers_used(&[]), 0);
        assert_eq!(registers_used(&[op(op_kind::PRIMVAR_UV, 0, 0)]), 1);
        // PRIMVAR's src is a name key, OUTPUT's dst a shading input: neither is a register.
        assert_eq!(registers_used(&[op(op_kind::PRIMVAR, 2, 40), op(op_kind::OUTPUT, 30, 1)]), 3);
        assert_eq!(registers_used(&[op(op_kind::TRANSFORM_2D, 1, 7)]), 8);
        assert_eq!(registers_used(&[op(op_kind::TEXTURE, 5, 0)]), 6);
        let math = ShaderOp { kind: op_kind::MATH, dst: 1, src: 2, src2: 9, src3: 3, ..Default::default() };
        assert_eq!(registers_used(&[math]), 10);
    }

    #[test]
    fn math_functions_follow_the_materialx_definitions() {
        use blob::math_op as m;
        let (a, b, c) = ([0.25, 0.5, 0.75, 1.0], [2.0, -1.0, 0.5, 0.0], [0.5, 0.25, 1.0, 0.0]);
        let f = |op| math(op, a, b, c);
        assert_eq!(f(m::ADD), [2.25, -0.5, 1.25, 1.0]);
        assert_eq!(f(m::SUBTRACT), [-1.75, 1.5, 0.25, 1.0]);
        assert_eq!(f(m::MULTIPLY), [0.5, -0.5, 0.375, 0.0]);
        assert_eq!(f(m::DIVIDE), [0.125, -0.5, 1.5, f32::INFINITY]);
        // mix(fg = a, bg = b, mix = c): c = 1 is the foreground, c = 0 the background.
        assert_eq!(f(m::MIX), [1.125, -0.625, 0.75, 0.0]);
        // clamp(in = a, low = b, high = c).
        assert_eq!(f(m::CLAMP), [0.5, 0.25, 0.75, 0.0]);
        assert_eq!(f(m::POWER), [0.0625, 2.0, 0.75f32.powf(0.5), 1.0]);
        assert_eq!(f(m::MIN), [0.25, -1.0, 0.5, 0.0]);
        assert_eq!(f(m::MAX), [2.0, 0.5, 0.75, 1.0]);
        let zwxy = m::SWIZZLE | (0b01_00_11_10 << 8);
        assert_eq!(f(zwxy), [0.75, 1.0, 0.25, 0.5]);
        // normalmap: 2a - 1 = (-0.5, 0, 0.5, 1), x and y scaled by b.x = 2.
        assert_eq!(f(m::NORMAL_MAP), [-1.0, 0.0, 0.5, 1.0]);
        assert_eq!(f(m::ONE_MINUS), [0.75, 0.5, 0.25, 0.0]);
        assert_eq!(math(m::ABSOLUTE, b, a, c), [2.0, 1.0, 0.5, 0.0]);
    }

    #[test]
    fn swizzles_select_channels() {
        let v = [1.0, 2.0, 3.0, 4.0];
        assert_eq!(swizzle(v, 0b11_10_01_00), v);
        assert_eq!(swizzle(v, 0), [1.0; 4]);
        assert_eq!(swizzle(v, 0xff), [4.0; 4]);
    }

    #[test]
    fn transform2d_scales_rotates_translates_and_carries_derivatives() {
        let mut regs = Registers::<{ MAX_REGISTERS as usize }>::default();
        let at = UvFootprint {
            uv: [1.0, 0.0],
            duv_dx: [0.01, 0.0],
            duv_dy: [0.0, 0.01],
            has_uv: true,
            point: None,
        };
        regs.step(&ShaderOp { kind: op_kind::PRIMVAR_UV, dst: 0, ..Default::default() }, &at);
        // scale (2, 1), rotate 90°, translate (0.5, 0): (1, 0) → (2, 0) → (0, 2) → (0.5, 2).
        let (s, c) = (1.0f32, 0.0f32);
        let m = [c * 2.0, -s * 1.0, s * 2.0, c * 1.0];
        let op = ShaderOp {
            kind: op_kind::TRANSFORM_2D,
            dst: 1,
            src: 0,
            params: [m, [0.5, 0.0, 0.0, 0.0], [0.0; 4]],
            ..Default::default()
        };
        regs.step(&op, &at);
        let (uv, dx, dy) = regs.coordinates(1);
        assert_eq!(uv, [0.5, 2.0]);
        assert_eq!(dx, [0.0, 0.02]);
        assert_eq!(dy, [-0.01, 0.0]);
    }
}
