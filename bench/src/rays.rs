//! `bench rays`: the same rays through our BVH and through Embree, in one run.
//!
//! Primary rays go through pixel centres of the blob's camera; incoherent rays start at area-uniform
//! points on the triangles (offset along the geometric normal) with cosine-distributed directions, as a
//! diffuse bounce would. Both ray sets, the triangles and our hits are written to a folder so that
//! `embree_rays.py` traces exactly the same rays and reports agreement as well as speed.

use anyhow::Context;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use render::accel::Accel;
use std::path::Path;
use std::time::Instant;

/// A named set of rays (origins and unit directions).
pub struct RaySet {
    pub name: &'static str,
    pub origins: Vec<Vec3>,
    pub directions: Vec<Vec3>,
}

/// Pinhole rays through the centres of a `res × res` grid on the default camera (or a framing camera).
pub fn primary_rays(view: &blob::SceneView, res: u32) -> RaySet {
    let camera = match view.cameras.get(view.info.default_camera as usize).or(view.cameras.first()) {
        Some(c) => render::camera::Camera::from_blob(c, res, res),
        None => render::camera::Camera::framing(
            Vec3::from(view.info.bounds_min),
            Vec3::from(view.info.bounds_max),
            view.info.up_axis == blob::UP_AXIS_Z,
            res,
            res,
        ),
    };
    let mut set = RaySet { name: "primary", origins: Vec::new(), directions: Vec::new() };
    for y in 0..res {
        for x in 0..res {
            let (o, d) = camera.generate_ray((x as f32 + 0.5) / res as f32, (y as f32 + 0.5) / res as f32);
            set.origins.push(o);
            set.directions.push(d);
        }
    }
    set
}

/// `count` cosine-distributed rays leaving area-uniform points of the scene's triangles.
pub fn incoherent_rays(view: &blob::SceneView, count: usize, seed: u64) -> RaySet {
    let corners = |t: &blob::Triangle| t.vertices.map(|v| Vec3::from(view.positions[v as usize]));
    let mut cdf = Vec::with_capacity(view.triangles.len());
    let mut total = 0.0f64;
    for t in view.triangles {
        let [a, b, c] = corners(t);
        total += 0.5 * (b - a).cross(c - a).length() as f64;
        cdf.push(total);
    }
    let scale = (Vec3::from(view.info.bounds_max) - Vec3::from(view.info.bounds_min)).length().max(1.0);
    let mut rng = rand::rngs::SmallRng::seed_from_u64(seed);
    let mut set = RaySet { name: "incoherent", origins: Vec::new(), directions: Vec::new() };
    while set.origins.len() < count && total > 0.0 {
        let pick = rng.random::<f64>() * total;
        let index = cdf.partition_point(|&c| c < pick).min(cdf.len() - 1);
        let [a, b, c] = corners(&view.triangles[index]);
        let n = (b - a).cross(c - a).normalize_or_zero();
        if n == Vec3::ZERO {
            continue;
        }
        let (mut u, mut v) = (rng.random::<f32>(), rng.random::<f32>());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        let p = a + u * (b - a) + v * (c - a);
        let (r1, r2) = (rng.random::<f32>(), rng.random::<f32>());
        let (r, phi) = (r1.sqrt(), std::f32::consts::TAU * r2);
        let (t, bt) = n.any_orthonormal_pair();
        // Both sides are surfaces a path can leave from; pick the side at random.
        let n = if rng.random::<bool>() { n } else { -n };
        let d = (r * phi.cos() * t + r * phi.sin() * bt + (1.0 - r1).max(0.0).sqrt() * n).normalize();
        set.origins.push(p + 1e-5 * scale * n);
        set.directions.push(d);
    }
    set
}

/// Our closest hits for a ray set: (triangle or −1, distance) per ray.
pub fn trace(accel: &Accel, set: &RaySet) -> (Vec<i32>, Vec<f32>) {
    let mut prims = Vec::with_capacity(set.origins.len());
    let mut dists = Vec::with_capacity(set.origins.len());
    for (o, d) in set.origins.iter().zip(&set.directions) {
        match accel.closest_hit(*o, *d, f32::INFINITY) {
            Some(h) => {
                prims.push(h.triangle as i32);
                dists.push(h.t);
            }
            None => {
                prims.push(-1);
                dists.push(f32::INFINITY);
            }
        }
    }
    (prims, dists)
}

/// Best-of-`repeat` throughput in Mrays/s of closest-hit queries on `threads` threads.
pub fn measure(accel: &Accel, set: &RaySet, threads: usize, repeat: usize) -> anyhow::Result<f64> {
    use rayon::prelude::*;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
    let mut best = f64::INFINITY;
    for _ in 0..repeat {
        let start = Instant::now();
        let hits: usize = pool.install(|| {
            set.origins
                .par_chunks(4096)
                .zip(set.directions.par_chunks(4096))
                .map(|(os, ds)| {
                    os.iter()
                        .zip(ds)
                        .filter(|(o, d)| accel.closest_hit(**o, **d, f32::INFINITY).is_some())
                        .count()
                })
                .sum()
        });
        std::hint::black_box(hits);
        best = best.min(start.elapsed().as_secs_f64());
    }
    Ok(set.origins.len() as f64 / best / 1e6)
}

fn write_f32(path: &Path, values: impl IntoIterator<Item = f32>) -> anyhow::Result<()> {
    let bytes: Vec<u8> = values.into_iter().flat_map(f32::to_le_bytes).collect();
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))
}

fn write_i32(path: &Path, values: impl IntoIterator<Item = i32>) -> anyhow::Result<()> {
    let bytes: Vec<u8> = values.into_iter().flat_map(i32::to_le_bytes).collect();
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))
}

/// Writes the triangles for Embree (one vertex triple per triangle, so indices are 0..3m).
pub fn write_triangles(view: &blob::SceneView, dir: &Path) -> anyhow::Result<()> {
    let verts = view.triangles.iter().flat_map(|t| t.vertices).flat_map(|v| view.positions[v as usize]);
    write_f32(&dir.join("vertices.f32"), verts)?;
    write_i32(&dir.join("faces.i32"), 0..(3 * view.triangles.len()) as i32)
}

/// Writes a ray set and our hits for it.
pub fn write_set(dir: &Path, set: &RaySet, prims: &[i32], dists: &[f32]) -> anyhow::Result<()> {
    write_f32(&dir.join(format!("{}.origins.f32", set.name)), set.origins.iter().flat_map(|v| v.to_array()))?;
    write_f32(
        &dir.join(format!("{}.directions.f32", set.name)),
        set.directions.iter().flat_map(|v| v.to_array()),
    )?;
    write_i32(&dir.join(format!("{}.ours_prim.i32", set.name)), prims.iter().copied())?;
    write_f32(&dir.join(format!("{}.ours_t.f32", set.name)), dists.iter().copied())
}
