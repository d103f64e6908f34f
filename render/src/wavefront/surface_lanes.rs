//! Surface reconstruction for eight triangle hits at once: [`Scene::surface`] in lanes.
//!
//! Per lane, a gather loop reads the triangle's world-space vertices (instanced triangles moved by
//! their instance), its vertex normals and uvs; lane loops then interpolate the point, normal and uv,
//! build the geometric and shading normals and the ray-cone uv footprint with the scalar code's IEEE
//! operations in the same order (glam's `dot` is `(x·x' + y·y') + z·z'`, `cross` is
//! `y·z' − y'·z, …`, `try_normalize` multiplies by `1 / length` when that is finite and positive,
//! `Vec3 / f32` divides each component); every branch becomes a per-lane select. The two steps that
//! stay per lane are the instance's normal transform (applied to the interpolated normal) and the
//! head-on fallback axis `Frame::new(d).t`. The test checks every lane against [`Scene::surface`]
//! bit for bit on random hits, instanced, degenerate and uv-less triangles included.

// Lane loops index several columns by the same lane number.
#![allow(clippy::needless_range_loop)]

use super::lanes::LANES;
use crate::accel::Hit;
use crate::bsdf::Frame;
use crate::integrator::Surface;
use crate::scene::Scene;
use crate::shading::{MeshPoint, UvFootprint};
use glam::Vec3;

type Lanes = [f32; LANES];
type Lanes3 = [Lanes; 3];

#[inline(always)]
fn dot(a: &Lanes3, b: &Lanes3, k: usize) -> f32 {
    (a[0][k] * b[0][k]) + (a[1][k] * b[1][k]) + (a[2][k] * b[2][k])
}

#[inline(always)]
fn get(a: &Lanes3, k: usize) -> Vec3 {
    Vec3::new(a[0][k], a[1][k], a[2][k])
}

#[inline(always)]
fn put(a: &mut Lanes3, k: usize, v: Vec3) {
    a[0][k] = v.x;
    a[1][k] = v.y;
    a[2][k] = v.z;
}

/// The surfaces at `hits` (at most eight), seen along `-wo[k]`, with the uv footprints of ray cones of
/// width `footprint[k]`: lane `k` is `scene.surface(&hits[k], wo[k], footprint[k])`.
#[multiversion::multiversion(targets("x86_64+avx+avx2+fma"))]
pub fn surfaces(scene: &Scene, hits: &[Hit], wo: &Lanes3, footprint: &Lanes) -> [Option<Surface>; LANES] {
    let view = &scene.view;
    let count = hits.len().min(LANES);
    // Gather.
    let (mut p0, mut p1, mut p2) = (Lanes3::default(), Lanes3::default(), Lanes3::default());
    let (mut n0, mut n1, mut n2) = (Lanes3::default(), Lanes3::default(), Lanes3::default());
    let (mut t0, mut t1, mut t2) = ([[0.0; LANES]; 2], [[0.0; LANES]; 2], [[0.0; LANES]; 2]);
    let (mut b1, mut b2) = ([0.0f32; LANES], [0.0f32; LANES]);
    let (mut has_normals, mut has_uvs) = ([false; LANES], [false; LANES]);
    for (k, hit) in hits.iter().enumerate().take(count) {
        let tri = &view.triangles[hit.triangle as usize];
        let [a, b, c] = scene.accel.hit_vertices(hit);
        put(&mut p0, k, a);
        put(&mut p1, k, b);
        put(&mut p2, k, c);
        (b1[k], b2[k]) = (hit.b1, hit.b2);
        let mesh = &view.meshes[tri.mesh as usize];
        has_normals[k] = mesh.flags & blob::MESH_HAS_NORMALS != 0;
        if has_normals[k] {
            let [a, b, c] = tri.vertices.map(|v| Vec3::from(view.normals[v as usize]));
            put(&mut n0, k, a);
            put(&mut n1, k, b);
            put(&mut n2, k, c);
        }
        has_uvs[k] = mesh.flags & blob::MESH_HAS_UVS != 0;
        if has_uvs[k] {
            let [a, b, c] = tri.vertices.map(|v| view.uvs[v as usize]);
            for i in 0..2 {
                (t0[i][k], t1[i][k], t2[i][k]) = (a[i], b[i], c[i]);
            }
        }
    }

    // Point, edges, geometric normal, interpolated normal.
    let (mut p, mut e1, mut e2, mut ng, mut n) =
        (Lanes3::default(), Lanes3::default(), Lanes3::default(), Lanes3::default(), Lanes3::default());
    let mut valid = [false; LANES];
    let mut b0 = [0.0f32; LANES];
    for k in 0..LANES {
        b0[k] = 1.0 - b1[k] - b2[k];
        for c in 0..3 {
            p[c][k] = p0[c][k] * b0[k] + p1[c][k] * b1[k] + p2[c][k] * b2[k];
            e1[c][k] = p1[c][k] - p0[c][k];
            e2[c][k] = p2[c][k] - p0[c][k];
            n[c][k] = n0[c][k] * b0[k] + n1[c][k] * b1[k] + n2[c][k] * b2[k];
        }
        let cross = [
            e1[1][k] * e2[2][k] - e2[1][k] * e1[2][k],
            e1[2][k] * e2[0][k] - e2[2][k] * e1[0][k],
            e1[0][k] * e2[1][k] - e2[0][k] * e1[1][k],
        ];
        let rcp = 1.0 / ((cross[0] * cross[0]) + (cross[1] * cross[1]) + (cross[2] * cross[2])).sqrt();
        valid[k] = rcp.is_finite() && rcp > 0.0;
        for c in 0..3 {
            ng[c][k] = cross[c] * rcp;
        }
        let flip = dot(&ng, wo, k) < 0.0;
        for c in 0..3 {
            ng[c][k] = if flip { -ng[c][k] } else { ng[c][k] };
        }
    }
    // The instance's normal transform acts on the interpolated normal.
    for (k, hit) in hits.iter().enumerate().take(count) {
        if has_normals[k] && hit.instance != blob::NONE {
            let world = scene.accel.normal_to_world(hit, get(&n, k));
            put(&mut n, k, world);
        }
    }
    let mut ns = Lanes3::default();
    for k in 0..LANES {
        let rcp = 1.0 / dot(&n, &n, k).sqrt();
        let normalized = rcp.is_finite() && rcp > 0.0;
        let mut s = [0.0f32; 3];
        for c in 0..3 {
            s[c] = n[c][k] * rcp;
        }
        let d = (s[0] * ng[0][k]) + (s[1] * ng[1][k]) + (s[2] * ng[2][k]);
        if d < 0.0 {
            s = s.map(|v| -v);
        }
        let facing = (s[0] * wo[0][k]) + (s[1] * wo[1][k]) + (s[2] * wo[2][k]);
        // NaN compares false: the scalar code keeps such a normal too.
        let faces_away = facing < 1e-4;
        let keep = has_normals[k] && normalized && !faces_away;
        for c in 0..3 {
            ns[c][k] = if keep { s[c] } else { ng[c][k] };
        }
    }

    // Texture coordinates, dp/du, dp/dv and the footprint.
    let (mut at, mut dpdu, mut dpdv) = ([[0.0f32; LANES]; 2], Lanes3::default(), Lanes3::default());
    let (mut d1, mut d2) = ([[0.0f32; LANES]; 2], [[0.0f32; LANES]; 2]);
    let mut axis1 = Lanes3::default();
    let mut head_on = [false; LANES];
    let d = wo.map(|c| c.map(|v| -v));
    for k in 0..LANES {
        for i in 0..2 {
            at[i][k] = t0[i][k] * b0[k] + t1[i][k] * b1[k] + t2[i][k] * b2[k];
            d1[i][k] = t1[i][k] - t0[i][k];
            d2[i][k] = t2[i][k] - t0[i][k];
        }
        let det = d1[0][k] * d2[1][k] - d1[1][k] * d2[0][k];
        let solvable = det != 0.0 && det.is_finite();
        for c in 0..3 {
            let u = (e1[c][k] * d2[1][k] - e2[c][k] * d1[1][k]) / det;
            let v = (e2[c][k] * d1[0][k] - e1[c][k] * d2[0][k]) / det;
            dpdu[c][k] = if solvable { u } else { 0.0 };
            dpdv[c][k] = if solvable { v } else { 0.0 };
        }
        let nd = dot(&ng, &d, k);
        let mut a = [0.0f32; 3];
        for c in 0..3 {
            a[c] = ng[c][k] - d[c][k] * nd;
        }
        let rcp = 1.0 / ((a[0] * a[0]) + (a[1] * a[1]) + (a[2] * a[2])).sqrt();
        head_on[k] = !(rcp.is_finite() && rcp > 0.0);
        for c in 0..3 {
            axis1[c][k] = a[c] * rcp;
        }
    }
    for k in 0..count {
        if head_on[k] && has_uvs[k] {
            put(&mut axis1, k, Frame::new(get(&d, k)).t);
        }
    }
    let (mut duv_dx, mut duv_dy) = ([[0.0f32; LANES]; 2], [[0.0f32; LANES]; 2]);
    for k in 0..LANES {
        let axis2 = [
            d[1][k] * axis1[2][k] - axis1[1][k] * d[2][k],
            d[2][k] * axis1[0][k] - axis1[2][k] * d[0][k],
            d[0][k] * axis1[1][k] - axis1[0][k] * d[1][k],
        ];
        let cos = dot(&ng, &d, k);
        let cos = if cos.abs() < 1e-4 { 1e-4f32.copysign(cos) } else { cos };
        let g11 = dot(&e1, &e1, k);
        let g12 = dot(&e1, &e2, k);
        let g22 = dot(&e2, &e2, k);
        let gram = g11 * g22 - g12 * g12;
        let footprint = footprint[k];
        let to_uv = |v: [f32; 3]| -> [f32; 2] {
            // on_plane: v − d (v·ng / cos).
            let s = ((v[0] * ng[0][k]) + (v[1] * ng[1][k]) + (v[2] * ng[2][k])) / cos;
            let w = [v[0] - d[0][k] * s, v[1] - d[1][k] * s, v[2] - d[2][k] * s];
            let r1 = (w[0] * e1[0][k]) + (w[1] * e1[1][k]) + (w[2] * e1[2][k]);
            let r2 = (w[0] * e2[0][k]) + (w[1] * e2[1][k]) + (w[2] * e2[2][k]);
            let a = (r1 * g22 - r2 * g12) / gram;
            let b = (r2 * g11 - r1 * g12) / gram;
            let uv = [d1[0][k] * a + d2[0][k] * b, d1[1][k] * a + d2[1][k] * b];
            if gram <= 0.0 {
                [0.0; 2]
            } else {
                uv
            }
        };
        let x = to_uv([axis1[0][k] * footprint, axis1[1][k] * footprint, axis1[2][k] * footprint]);
        let y = to_uv([axis2[0] * footprint, axis2[1] * footprint, axis2[2] * footprint]);
        for i in 0..2 {
            duv_dx[i][k] = x[i];
            duv_dy[i][k] = y[i];
        }
    }

    std::array::from_fn(|k| {
        if k >= count || !valid[k] {
            return None;
        }
        let hit = &hits[k];
        let mut uv = if has_uvs[k] {
            UvFootprint {
                uv: [at[0][k], at[1][k]],
                duv_dx: [duv_dx[0][k], duv_dx[1][k]],
                duv_dy: [duv_dy[0][k], duv_dy[1][k]],
                has_uv: true,
                point: None,
            }
        } else {
            UvFootprint::default()
        };
        uv.point = Some(MeshPoint { triangle: hit.triangle, b1: hit.b1, b2: hit.b2 });
        let (dpdu, dpdv) = if has_uvs[k] { (get(&dpdu, k), get(&dpdv, k)) } else { (Vec3::ZERO, Vec3::ZERO) };
        Some(Surface::on_triangle(
            get(&p, k),
            get(&ng, k),
            get(&ns, k),
            view.triangle_materials[hit.triangle as usize],
            uv,
            dpdu,
            dpdv,
            hit.triangle,
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testscene::{self, Rng};
    use glam::Mat4;

    fn bits(v: Vec3) -> [u32; 3] {
        v.to_array().map(|c| if c.is_nan() { u32::MAX } else { c.to_bits() })
    }

    fn key(s: &Surface) -> Vec<u32> {
        let f = |v: f32| if v.is_nan() { u32::MAX } else { v.to_bits() };
        let mut out = Vec::new();
        for v in [s.p, s.ng, s.ns, s.dpdu, s.dpdv] {
            out.extend(bits(v));
        }
        out.extend(s.uv.uv.map(f));
        out.extend(s.uv.duv_dx.map(f));
        out.extend(s.uv.duv_dy.map(f));
        out.push(s.uv.has_uv as u32);
        out.push(s.material);
        out.push(s.triangle);
        let point = s.uv.point.expect("triangle hits carry their point");
        out.extend([point.triangle, f(point.b1), f(point.b2)]);
        out
    }

    #[test]
    fn lanes_equal_scalar_surfaces() {
        // Spheres with normals and uvs (degenerate triangles at the poles), a card without uvs,
        // instanced spheres (normals through the instance transform), a tilted random soup.
        let mut scene = testscene::instanced_spheres(6, 5);
        scene.meshes.push(testscene::sphere(Vec3::new(0.0, 0.0, -3.0), 1.0, 6, 9, 0, false));
        let mut card = testscene::card(-2.0, 1.5, 0);
        card.normals.clear();
        scene.meshes.push(card);
        let mut soup = testscene::random_triangles_mesh(40, 9);
        let tilt = Mat4::from_rotation_x(0.7);
        soup.positions.iter_mut().for_each(|p| *p = tilt.transform_point3(*p));
        scene.meshes.push(soup);
        if scene.materials.is_empty() {
            scene.materials.push(testscene::lambert(0.5));
        }
        let bytes = testscene::bytes(&scene);
        let view = blob::SceneView::parse(&bytes).expect("valid blob");
        let s = Scene::new(view);
        let triangles = view.triangles.len() as u32;
        let instances = view.instancing.instances.len() as u32;
        let mut rng = Rng(17);
        let (mut compared, mut degenerate, mut instanced) = (0, 0, 0);
        for round in 0..600 {
            let count = 1 + round % LANES;
            let mut hits = Vec::new();
            let (mut wo, mut footprint) = (Lanes3::default(), [0.0f32; LANES]);
            for k in 0..count {
                let (mut b1, mut b2) = (rng.next_f32(), rng.next_f32());
                if b1 + b2 > 1.0 {
                    (b1, b2) = (1.0 - b1, 1.0 - b2);
                }
                let instance = if instances > 0 && rng.next_f32() < 0.3 {
                    (rng.next_f32() * instances as f32) as u32
                } else {
                    blob::NONE
                };
                let triangle = if instance != blob::NONE {
                    let inst = &view.instancing.instances[instance as usize];
                    let proto = &view.instancing.prototypes[inst.prototype as usize];
                    proto.first_triangle + (rng.next_f32() * proto.triangle_count as f32) as u32
                } else {
                    (rng.next_f32() * triangles as f32) as u32
                };
                hits.push(Hit { t: 1.0, triangle, b1, b2, instance });
                // Now and then straight along an axis (head-on hits on the card: the fallback axis).
                let dir = if rng.next_f32() < 0.1 {
                    Vec3::new(0.0, 0.0, if rng.next_f32() < 0.5 { 1.0 } else { -1.0 })
                } else {
                    Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)).normalize()
                };
                put(&mut wo, k, dir);
                footprint[k] = rng.range(0.0, 0.05);
            }
            let got = surfaces(&s, &hits, &wo, &footprint);
            for (k, hit) in hits.iter().enumerate() {
                let want = s.surface(hit, get(&wo, k), footprint[k]);
                match (&got[k], &want) {
                    (Some(a), Some(b)) => assert_eq!(key(a), key(b), "lane {k}: {hit:?}"),
                    (None, None) => degenerate += 1,
                    _ => panic!("lane {k}: {hit:?}: lanes {}, scalar {}", got[k].is_some(), want.is_some()),
                }
                instanced += (hit.instance != blob::NONE) as u32;
                compared += 1;
            }
            assert!(got[count..].iter().all(Option::is_none));
        }
        assert!(compared > 2000 && degenerate > 0 && instanced > 100, "{compared} {degenerate} {instanced}");
    }
}
