//! The small closed sets a texture lookup is parameterised by: colour space, texel format, wrap, filter.

use std::fmt;
use std::str::FromStr;

/// UsdUVTexture `sourceColorSpace`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ColorSpace {
    /// sRGB for 8-bit sources, raw (linear) for 16-bit and float sources.
    #[default]
    Auto,
    /// The colour channels are sRGB-encoded whatever the bit depth; alpha is always linear.
    Srgb,
    /// The values are used as stored (normal maps, roughness, displacement).
    Raw,
}

impl FromStr for ColorSpace {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" | "" => Ok(ColorSpace::Auto),
            "sRGB" | "srgb" => Ok(ColorSpace::Srgb),
            "raw" => Ok(ColorSpace::Raw),
            other => Err(format!("unknown sourceColorSpace {other:?} (expected auto|sRGB|raw)")),
        }
    }
}

/// How texels are stored in the texel array; `TextureRecord::format` holds the discriminant.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum TexelFormat {
    /// One byte per channel, colour channels sRGB-encoded, alpha linear. Decoded through a 256-entry table.
    Srgb8 = 0,
    /// One byte per channel, linear (`raw` 8-bit sources such as normal maps).
    Unorm8 = 1,
    /// IEEE half float per channel, linear (16-bit and float sources).
    F16 = 2,
}

impl TexelFormat {
    /// Bytes per channel.
    pub const fn channel_bytes(self) -> u32 {
        match self {
            TexelFormat::Srgb8 | TexelFormat::Unorm8 => 1,
            TexelFormat::F16 => 2,
        }
    }

    /// The format with this discriminant, if any.
    pub const fn from_u32(v: u32) -> Option<Self> {
        match v {
            0 => Some(TexelFormat::Srgb8),
            1 => Some(TexelFormat::Unorm8),
            2 => Some(TexelFormat::F16),
            _ => None,
        }
    }
}

/// UsdUVTexture `wrapS` / `wrapT`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Wrap {
    /// Tile the texture.
    #[default]
    Repeat,
    /// Tile it, flipping every other copy.
    Mirror,
    /// Extend the edge texels.
    Clamp,
    /// Outside `[0, 1)` every texel is transparent black `(0, 0, 0, 0)`.
    Black,
}

impl FromStr for Wrap {
    type Err = String;
    /// `useMetadata` maps to [`Wrap::Repeat`]: none of the decoded formats carry wrap metadata that the
    /// bake keeps, and repeat is the UsdUVTexture fallback.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "repeat" | "useMetadata" => Ok(Wrap::Repeat),
            "mirror" => Ok(Wrap::Mirror),
            "clamp" => Ok(Wrap::Clamp),
            "black" => Ok(Wrap::Black),
            other => {
                Err(format!("unknown wrap mode {other:?} (expected repeat|mirror|clamp|black|useMetadata)"))
            }
        }
    }
}

/// Texture filter; see `sample` for what each does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Filter {
    /// MoonRay's default: nearest texel on the two mip levels around the footprint, blended linearly;
    /// bilinear on level 0 when magnifying.
    #[default]
    Moonray,
    /// Bilinear on the nearest mip level.
    Bilinear,
    /// Bilinear on both mip levels around the footprint, blended.
    Trilinear,
    /// Up to [`crate::MAX_ANISOTROPY`] trilinear taps along the footprint's major axis, level from the
    /// minor axis.
    Anisotropic,
    /// Elliptical weighted average (Heckbert 1989, as in pbrt-v3's `MIPMap::EWA`): a Gaussian over the
    /// ellipse the uv derivatives span, on the two levels around the minor axis (eccentricity clamped
    /// to [`crate::MAX_ANISOTROPY`]), blended.
    Ewa,
}

impl Filter {
    /// All filters, for benchmarks and tests.
    pub const ALL: [Filter; 5] =
        [Filter::Moonray, Filter::Bilinear, Filter::Trilinear, Filter::Anisotropic, Filter::Ewa];
}

impl FromStr for Filter {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "moonray" => Ok(Filter::Moonray),
            "bilinear" => Ok(Filter::Bilinear),
            "trilinear" => Ok(Filter::Trilinear),
            "anisotropic" => Ok(Filter::Anisotropic),
            "ewa" => Ok(Filter::Ewa),
            other => Err(format!(
                "unknown texture filter {other:?} (expected moonray|bilinear|trilinear|anisotropic|ewa)"
            )),
        }
    }
}

impl fmt::Display for Filter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // `pad` so that width/alignment flags (`{:<10}`) apply.
        f.pad(match self {
            Filter::Moonray => "moonray",
            Filter::Bilinear => "bilinear",
            Filter::Trilinear => "trilinear",
            Filter::Anisotropic => "anisotropic",
            Filter::Ewa => "ewa",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse() {
        assert_eq!("moonray".parse(), Ok(Filter::Moonray));
        assert_eq!("ewa".parse(), Ok(Filter::Ewa));
        assert_eq!("anisotropic".parse(), Ok(Filter::Anisotropic));
        for f in Filter::ALL {
            assert_eq!(f.to_string().parse(), Ok(f));
        }
        assert!("box".parse::<Filter>().is_err());
        assert_eq!("useMetadata".parse(), Ok(Wrap::Repeat));
        assert_eq!("sRGB".parse(), Ok(ColorSpace::Srgb));
    }
}
