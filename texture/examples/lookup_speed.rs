//! Lookups per second for each filter on one core: `cargo run --release -p texture --example lookup_speed`.
//!
//! A measurement, not a test: random points over a 2048² texture with footprints from 1/4 texel to 64
//! texels (log-uniform) and anisotropy up to 1:16, so every path (magnification, level blends, the
//! anisotropic taps) is exercised. Random access is the worst case for the tile layout; a wavefront
//! integrator that sorts by `shading_sort_key` should do better.

use std::hint::black_box;
use std::time::Instant;

use texture::{
    bake, sample_with, shading_sort_key_saturating, BakeOptions, BytesRead, ColorSpace, Filter, Lookup,
    NoTouch, PageTouches, Samples, SourceImage, TextureSetBuilder, Wrap,
};

/// xorshift64*: enough randomness for coordinates, no dependency.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn lookups(n: usize, size: f32) -> Vec<Lookup> {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    (0..n)
        .map(|_| {
            let texels = 2f32.powf(rng.next() * 8.0 - 2.0); // 1/4 .. 64 texels
            let aniso = 1.0 + rng.next() * 15.0;
            let angle = rng.next() * std::f32::consts::TAU;
            let (s, c) = angle.sin_cos();
            let major = texels / size;
            let minor = major / aniso;
            Lookup {
                uv: [rng.next(), rng.next()],
                duv_dx: [c * major, s * major],
                duv_dy: [-s * minor, c * minor],
                filter: Filter::Moonray,
                wrap_s: Wrap::Repeat,
                wrap_t: Wrap::Repeat,
            }
        })
        .collect()
}

fn main() -> Result<(), texture::Error> {
    const SIZE: u32 = 2048;
    const N: usize = 1 << 21;
    let mut rng = Rng(7);
    let rgba8: Vec<u8> = (0..SIZE * SIZE * 4).map(|_| (rng.next() * 255.0) as u8).collect();
    let rgba16: Vec<u16> = rgba8.iter().map(|&b| b as u16 * 257).collect();
    let mut builder = TextureSetBuilder::new();
    let opts = BakeOptions { color_space: ColorSpace::Auto, ..Default::default() };
    let start = Instant::now();
    let srgb8 = SourceImage { width: SIZE, height: SIZE, channels: 4, samples: Samples::U8(rgba8) };
    let half = SourceImage { width: SIZE, height: SIZE, channels: 4, samples: Samples::U16(rgba16) };
    let textures = [
        ("rgba sRGB8", builder.add_baked(bake(&srgb8, &opts)?)),
        ("rgba f16", builder.add_baked(bake(&half, &opts)?)),
    ];
    println!("baked 2 × {SIZE}² RGBA textures in {:.2} s", start.elapsed().as_secs_f64());
    let set = builder.finish();
    let view = set.view()?;
    let queries = lookups(N, SIZE as f32);

    // The same queries ordered by the shading sort key (tile, level, Morton uv), as a wavefront
    // integrator would issue them.
    let mut sorted = queries.clone();
    let key = |q: &Lookup| {
        let level = texture::mip_level(view.texture(0).expect("added").record(), q.duv_dx, q.duv_dy);
        shading_sort_key_saturating(0, level.max(0.0) as u32, q.uv)
    };
    sorted.sort_by_cached_key(key);

    println!(
        "{:<11} {:<10} {:>14} {:>14} {:>15}",
        "texture", "filter", "random M/s", "sorted M/s", "bytes/lookup"
    );
    for (name, index) in textures {
        let tex = view.texture(index).expect("just added");
        for filter in Filter::ALL {
            let rate = |qs: &[Lookup]| {
                let start = Instant::now();
                let mut acc = [0.0f32; 4];
                for q in qs {
                    let c = sample_with(&tex, &Lookup { filter, ..*q }, &NoTouch);
                    acc = std::array::from_fn(|k| acc[k] + c[k]);
                }
                black_box(acc);
                qs.len() as f64 / start.elapsed().as_secs_f64() / 1e6
            };
            let (random, coherent) = (rate(&queries), rate(&sorted));
            // Separate pass for the byte count, so the timings are of the plain lookup.
            let read = BytesRead::default();
            for q in &queries[..N / 16] {
                black_box(sample_with(&tex, &Lookup { filter, ..*q }, &read));
            }
            let per_lookup = read.0.get() as f64 / (N / 16) as f64;
            println!("{name:<11} {filter:<10} {random:>14.2} {coherent:>14.2} {per_lookup:>15.1}");
        }
    }
    // Pages a small batch touches: what the page cache has to hold for it.
    let touches = PageTouches::new(set.texels.len());
    let tex = view.texture(textures[0].1).expect("just added");
    for q in &sorted[..4096] {
        black_box(sample_with(&tex, q, &touches));
    }
    println!(
        "first 4096 sorted moonray lookups on {}: {} KiB of {} KiB texel pages touched",
        textures[0].0,
        touches.touched_bytes() / 1024,
        tex.record().byte_len / 1024
    );
    Ok(())
}
