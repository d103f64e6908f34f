//! Mip pyramid construction in linear `f32`, before any quantisation.
//!
//! Each level halves each side with `floor(n / 2)` (never below 1), so level `l` is `max(1, n >> l)` and a
//! lookup can derive every level's size from level 0. Downsampling is separable:
//! - even `n`: a 2-tap box;
//! - odd `n = 2m + 1`: a 3-tap filter whose weights are the exact overlap of each output texel's footprint
//!   (`n / m` source texels wide) with the three source texels it covers: `(m - i, m, i + 1) / n`. Every
//!   source texel then contributes `m / n` in total, so the level's mean is preserved exactly — a plain
//!   2×2 box on odd sizes would drop the last row/column and shift the image by a quarter texel.
//! - `n = 1`: copied.
//!
//! Filtering in linear space matters for sRGB textures: averaging encoded values darkens high-contrast
//! detail (a black/white checker would average to sRGB 0.5 = linear 0.21 instead of 0.5). Each level is
//! filtered from the previous `f32` level, not from its quantised bytes, so rounding does not accumulate.

/// An image in linear `f32`, channels interleaved, rows in storage order.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearImage {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Channels per texel, 1..=4.
    pub channels: u32,
    /// `width * height * channels` values.
    pub data: Vec<f32>,
}

/// Source indices and weights of output texel `i` when reducing a line of `n` texels.
#[inline]
fn taps(n: u32, i: u32) -> [(u32, f32); 3] {
    if n == 1 {
        [(0, 1.0), (0, 0.0), (0, 0.0)]
    } else if n.is_multiple_of(2) {
        [(2 * i, 0.5), (2 * i + 1, 0.5), (2 * i + 1, 0.0)]
    } else {
        let m = (n / 2) as f32;
        let d = n as f32;
        let fi = i as f32;
        [(2 * i, (m - fi) / d), (2 * i + 1, m / d), (2 * i + 2, (fi + 1.0) / d)]
    }
}

/// Next level of `img`: each side `max(1, n / 2)`.
pub fn downsample(img: &LinearImage) -> LinearImage {
    let c = img.channels as usize;
    let (w, h) = (img.width, img.height);
    let (w2, h2) = ((w / 2).max(1), (h / 2).max(1));

    // Horizontal pass: w × h → w2 × h.
    let mut tmp = vec![0.0f32; w2 as usize * h as usize * c];
    for y in 0..h as usize {
        let src = &img.data[y * w as usize * c..][..w as usize * c];
        let dst = &mut tmp[y * w2 as usize * c..][..w2 as usize * c];
        for x in 0..w2 {
            for (sx, wt) in taps(w, x) {
                for ch in 0..c {
                    dst[x as usize * c + ch] += wt * src[sx as usize * c + ch];
                }
            }
        }
    }

    // Vertical pass: w2 × h → w2 × h2, whole rows at a time.
    let row = w2 as usize * c;
    let mut out = vec![0.0f32; row * h2 as usize];
    for y in 0..h2 {
        let dst = &mut out[y as usize * row..][..row];
        for (sy, wt) in taps(h, y) {
            let src = &tmp[sy as usize * row..][..row];
            for (d, s) in dst.iter_mut().zip(src) {
                *d += wt * s;
            }
        }
    }
    LinearImage { width: w2, height: h2, channels: img.channels, data: out }
}

/// Number of levels from `width × height` down to 1×1.
pub fn mip_count(width: u32, height: u32) -> u32 {
    32 - width.max(height).max(1).leading_zeros()
}

/// The full chain, level 0 first.
pub fn build_pyramid(level0: LinearImage) -> Vec<LinearImage> {
    let count = mip_count(level0.width, level0.height);
    let mut levels = Vec::with_capacity(count as usize);
    levels.push(level0);
    while levels.len() < count as usize {
        let next = downsample(levels.last().expect("level 0 pushed above"));
        levels.push(next);
    }
    levels
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker(w: u32, h: u32) -> LinearImage {
        let data = (0..h).flat_map(|y| (0..w).map(move |x| ((x + y) % 2) as f32)).collect();
        LinearImage { width: w, height: h, channels: 1, data }
    }

    fn mean(img: &LinearImage) -> f64 {
        img.data.iter().map(|&v| v as f64).sum::<f64>() / img.data.len() as f64
    }

    #[test]
    fn chain_sizes() {
        let sizes: Vec<_> = build_pyramid(checker(100, 60)).iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, [(100, 60), (50, 30), (25, 15), (12, 7), (6, 3), (3, 1), (1, 1)]);
        assert_eq!(mip_count(256, 256), 9);
        assert_eq!(mip_count(37, 1), 6);
        assert_eq!(mip_count(1, 1), 1);
    }

    /// The 1×1 level of a checker is its mean: 0.5 for even sizes, 1110/2220 for 37×60 etc.
    #[test]
    fn mean_is_preserved_to_1x1() {
        for (w, h) in [(256, 256), (100, 60), (37, 1), (37, 61), (3, 3)] {
            let img = checker(w, h);
            let m = mean(&img);
            let top = build_pyramid(img).pop().unwrap();
            assert_eq!((top.width, top.height), (1, 1));
            assert!((top.data[0] as f64 - m).abs() < 1e-6, "{w}x{h}: {} vs {m}", top.data[0]);
        }
    }

    #[test]
    fn odd_taps_sum_to_one() {
        for n in [3u32, 5, 37, 101] {
            for i in 0..n / 2 {
                let s: f32 = taps(n, i).iter().map(|t| t.1).sum();
                assert!((s - 1.0).abs() < 1e-6);
            }
        }
    }
}
