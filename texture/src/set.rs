//! A scene's textures: built on the ingest side ([`TextureSetBuilder`]), read on the render side
//! ([`TextureSetView`]) from the same four flat tables.
//!
//! | table        | element             | meaning                                                  |
//! |--------------|---------------------|----------------------------------------------------------|
//! | `records`    | [`TextureRecord`]   | one per texture (a UDIM tile is a texture)               |
//! | `udim_sets`  | [`UdimSetRecord`]   | one per `<UDIM>` pattern                                  |
//! | `udim_tiles` | `u32`               | texture index per UDIM grid cell, or [`NONE`]             |
//! | `texels`     | `u8`                | every texture's levels; record offsets point in here     |
//!
//! Each texture starts on a 4 KiB boundary of the texel array, so if ingest places the array on a page
//! boundary in the blob, tiles share pages only with their own texture.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::bake::{bake, BakeOptions, BakedTexture};
use crate::decode::decode;
use crate::error::{Error, Warning};
use crate::float::floor;
use crate::format::{TexelFormat, Wrap};
use crate::record::{TextureRecord, UdimSetRecord, NONE};
use crate::sample::{sample_with, validate, Lookup, TextureView};
use crate::stats::{NoTouch, Touch};
use crate::udim::{expand, is_udim, tile_path};

/// Alignment of each texture's first byte in the texel array.
pub const TEXTURE_ALIGN: usize = 4096;

/// What a scene-level texture reference resolved to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TextureRef {
    /// An index into `records`.
    Texture(u32),
    /// An index into `udim_sets`.
    Udim(u32),
}

/// The finished tables, ready for ingest to copy into blob sections.
#[derive(Clone, Debug, Default)]
pub struct TextureSet {
    /// One per texture.
    pub records: Vec<TextureRecord>,
    /// One per UDIM pattern.
    pub udim_sets: Vec<UdimSetRecord>,
    /// UDIM grid cells → texture index or [`NONE`].
    pub udim_tiles: Vec<u32>,
    /// All texels.
    pub texels: Vec<u8>,
    /// Problems the bake survived, each reported once.
    pub warnings: Vec<Warning>,
}

impl TextureSet {
    /// The lookup view of these tables.
    pub fn view(&self) -> Result<TextureSetView<'_>, Error> {
        TextureSetView::new(&self.records, &self.udim_sets, &self.udim_tiles, &self.texels)
    }
}

/// Decodes and bakes texture files into a [`TextureSet`], once per (path, options).
#[derive(Debug, Default)]
pub struct TextureSetBuilder {
    set: TextureSet,
    cache: HashMap<(PathBuf, BakeOptions), TextureRef>,
}

impl TextureSetBuilder {
    /// An empty set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends a baked texture, rebasing its offsets into the shared texel array; returns its index.
    pub fn add_baked(&mut self, baked: BakedTexture) -> u32 {
        let texels = &mut self.set.texels;
        let base = texels.len().next_multiple_of(TEXTURE_ALIGN);
        texels.resize(base, 0);
        texels.extend_from_slice(&baked.texels);
        let mut record = baked.record;
        for offset in &mut record.level_offsets[..record.mip_count as usize] {
            *offset += base as u64;
        }
        self.set.records.push(record);
        (self.set.records.len() - 1) as u32
    }

    /// Decodes and bakes `path`, expanding `<UDIM>` patterns; a path seen before with the same options
    /// returns the earlier result.
    pub fn add_file(&mut self, path: &Path, options: &BakeOptions) -> Result<TextureRef, Error> {
        let key = (path.to_path_buf(), *options);
        if let Some(&found) = self.cache.get(&key) {
            return Ok(found);
        }
        let found = if is_udim(path) {
            TextureRef::Udim(self.add_udim(path, options)?)
        } else {
            TextureRef::Texture(self.add_baked(bake(&decode(path)?, options)?))
        };
        self.cache.insert(key, found);
        Ok(found)
    }

    /// Bakes every tile of a `<UDIM>` pattern and records the grid; holes get [`NONE`] and one
    /// [`Warning::MissingUdimTile`] each.
    fn add_udim(&mut self, pattern: &Path, options: &BakeOptions) -> Result<u32, Error> {
        let tiles = expand(pattern)?;
        let u_count = tiles.iter().map(|t| t.u).max().unwrap_or(0) + 1;
        let v_count = tiles.iter().map(|t| t.v).max().unwrap_or(0) + 1;
        let mut grid = vec![NONE; (u_count * v_count) as usize];
        for tile in &tiles {
            let baked = bake(&decode(&tile.path)?, options)?;
            grid[(tile.v * u_count + tile.u) as usize] = self.add_baked(baked);
        }
        for (cell, _) in grid.iter().enumerate().filter(|(_, &t)| t == NONE) {
            let number = 1001 + (cell as u32 % u_count) + 10 * (cell as u32 / u_count);
            self.set.warnings.push(Warning::MissingUdimTile {
                pattern: pattern.to_path_buf(),
                tile: number,
                path: tile_path(pattern, number),
            });
        }
        let first_tile = self.set.udim_tiles.len() as u32;
        self.set.udim_tiles.extend_from_slice(&grid);
        self.set.udim_sets.push(UdimSetRecord { first_tile, u_count, v_count, reserved: 0 });
        Ok((self.set.udim_sets.len() - 1) as u32)
    }

    /// Warnings so far.
    pub fn warnings(&self) -> &[Warning] {
        &self.set.warnings
    }

    /// The tables built so far.
    pub fn set(&self) -> &TextureSet {
        &self.set
    }

    /// The finished tables.
    pub fn finish(self) -> TextureSet {
        self.set
    }
}

/// The four tables, validated once; every lookup after that works on these borrowed slices.
#[derive(Clone, Copy, Debug)]
pub struct TextureSetView<'a> {
    records: &'a [TextureRecord],
    udim_sets: &'a [UdimSetRecord],
    udim_tiles: &'a [u32],
    texels: &'a [u8],
}

impl<'a> TextureSetView<'a> {
    /// Checks every record against the texel array and every UDIM cell against the texture table.
    pub fn new(
        records: &'a [TextureRecord],
        udim_sets: &'a [UdimSetRecord],
        udim_tiles: &'a [u32],
        texels: &'a [u8],
    ) -> Result<Self, Error> {
        for (i, rec) in records.iter().enumerate() {
            validate(rec, texels.len(), i).map_err(|reason| Error::invalid("texture", i, reason))?;
        }
        for (i, set) in udim_sets.iter().enumerate() {
            let cells = set.u_count.checked_mul(set.v_count).filter(|_| (1..=10).contains(&set.u_count));
            let end = cells.and_then(|c| set.first_tile.checked_add(c));
            if end.is_none_or(|end| end as usize > udim_tiles.len()) {
                return Err(Error::invalid("udim set", i, "tile range runs past the tile table"));
            }
        }
        if let Some(i) = udim_tiles.iter().position(|&t| t != NONE && t as usize >= records.len()) {
            return Err(Error::invalid("udim tile", i, "texture index out of range"));
        }
        Ok(TextureSetView { records, udim_sets, udim_tiles, texels })
    }

    /// Texture `index`, or `None` if out of range.
    #[inline]
    pub fn texture(&self, index: u32) -> Option<TextureView<'a>> {
        let rec = self.records.get(index as usize)?;
        // Validated in `new`, so the format is known.
        let format = TexelFormat::from_u32(rec.format)?;
        Some(TextureView::trusted(rec, format, self.texels))
    }

    /// Number of textures.
    pub fn texture_count(&self) -> usize {
        self.records.len()
    }

    /// Size of the texel array, the denominator of "bytes touched".
    pub fn texel_bytes(&self) -> usize {
        self.texels.len()
    }

    /// The tile of UDIM set `set` under `uv`: `(tile index u + 10 v, texture index)`, with the texture
    /// `None` for a hole. `None` if `uv` is outside the set's grid or `set` is out of range.
    #[inline]
    pub fn udim_tile(&self, set: u32, uv: [f32; 2]) -> Option<(u32, Option<u32>)> {
        let rec = self.udim_sets.get(set as usize)?;
        let (fu, fv) = (floor(uv[0]), floor(uv[1]));
        // Rejects negatives, NaN (comparisons are false) and cells past the grid.
        if !(fu >= 0.0 && fv >= 0.0 && fu < rec.u_count as f32 && fv < rec.v_count as f32) {
            return None;
        }
        let (u, v) = (fu as u32, fv as u32);
        let texture = self.udim_tiles[(rec.first_tile + v * rec.u_count + u) as usize];
        Some((u + 10 * v, (texture != NONE).then_some(texture)))
    }

    /// Filtered lookup in UDIM set `set`: picks tile `(floor u, floor v)` and samples it at the fractional
    /// `uv`, clamped to the tile so filtering never blends across tiles (the lookup's wrap modes are
    /// ignored). Holes and cells outside the grid return `fallback`.
    #[inline]
    pub fn sample_udim(&self, set: u32, lookup: &Lookup, fallback: [f32; 4]) -> [f32; 4] {
        self.sample_udim_with(set, lookup, fallback, &NoTouch)
    }

    /// [`Self::sample_udim`], reporting texel reads to `touch`.
    pub fn sample_udim_with<T: Touch>(
        &self,
        set: u32,
        lookup: &Lookup,
        fallback: [f32; 4],
        touch: &T,
    ) -> [f32; 4] {
        let Some((_, Some(texture))) = self.udim_tile(set, lookup.uv) else {
            return fallback;
        };
        let Some(tex) = self.texture(texture) else {
            return fallback;
        };
        let local = Lookup {
            uv: [lookup.uv[0] - floor(lookup.uv[0]), lookup.uv[1] - floor(lookup.uv[1])],
            wrap_s: Wrap::Clamp,
            wrap_t: Wrap::Clamp,
            ..*lookup
        };
        sample_with(&tex, &local, touch)
    }
}
