//! Per-face (Bfr) tessellation: watertightness, agreement with the uniform limit, and the
//! features the uniform tests pin (creases, corners, holes, boundaries, seams), on cages with
//! known answers.

use std::collections::{HashMap, HashSet};

use crate::limit::dot;
use crate::tests::{
    assert_unit_normals, creased_edge_cube, cube, cube_with_uv_seams, dist, distance_to_line, f64x3, refine,
    CUBE_POINTS,
};
use crate::*;

fn adaptive(cage: &Cage<'_>) -> AdaptiveRefiner {
    AdaptiveRefiner::new(&Topology::new(cage).unwrap()).unwrap()
}

/// Edge rates that differ from edge to edge (1 to 8, not powers of two).
fn varied_rates(refiner: &AdaptiveRefiner) -> Vec<u32> {
    (0..refiner.edges().len()).map(|e| [1, 2, 3, 5, 8, 4, 7, 6][e % 8]).collect()
}

/// Undirected edges keyed by `key(vertex)`, with the triangles using them in each direction.
fn edge_uses<K: Copy + Ord + std::hash::Hash>(
    triangles: &[[u32; 3]],
    key: impl Fn(u32) -> K,
) -> HashMap<(K, K), (u32, u32)> {
    let mut uses: HashMap<(K, K), (u32, u32)> = HashMap::new();
    for t in triangles {
        for i in 0..3 {
            let (a, b) = (key(t[i]), key(t[(i + 1) % 3]));
            let entry = uses.entry((a.min(b), a.max(b))).or_default();
            if a < b {
                entry.0 += 1;
            } else {
                entry.1 += 1;
            }
        }
    }
    uses
}

fn position_bits(p: [f32; 3]) -> [u32; 3] {
    p.map(f32::to_bits)
}

#[test]
fn cube_with_varying_edge_rates_is_watertight() {
    let refiner = adaptive(&cube());
    assert_eq!(refiner.edges().len(), 12);
    let rates = varied_rates(&refiner);
    let mesh = refiner.tessellate(&CUBE_POINTS, None, &rates, false).unwrap().mesh;
    assert!(mesh.refined_vertex.is_empty());

    // Every edge is used by exactly two triangles, once in each direction (consistent winding).
    let uses = edge_uses(&mesh.triangles, |v| v);
    for (edge, &(forward, backward)) in &uses {
        assert_eq!((forward, backward), (1, 1), "edge {edge:?}");
    }
    // A closed surface of genus 0.
    let (v, e, f) = (mesh.positions.len() as i64, uses.len() as i64, mesh.triangles.len() as i64);
    assert_eq!(v - e + f, 2);
    // Shared points are shared, not re-evaluated: no two vertices at the same position.
    let distinct: HashSet<[u32; 3]> = mesh.positions.iter().map(|&p| position_bits(p)).collect();
    assert_eq!(distinct.len(), mesh.positions.len());
    // The cage edges are split as asked: the boundary of cage face f has Σ rates points.
    for face in 0..6u32 {
        let (_, edges) = refiner.face(face as usize);
        let tris: Vec<[u32; 3]> = mesh
            .triangles
            .iter()
            .zip(&mesh.coarse_face)
            .filter(|(_, &c)| c == face)
            .map(|(t, _)| *t)
            .collect();
        let boundary = edge_uses(&tris, |v| v).values().filter(|&&(a, b)| a + b == 1).count();
        let expected: u32 = edges.iter().map(|&e| rates[e as usize]).sum();
        assert_eq!(boundary as u32, expected, "face {face}");
    }
    assert!(mesh.triangles.len() as u64 <= refiner.triangle_estimate(&rates));
    assert_unit_normals(&mesh);
    for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
        assert!(dot(f64x3(*p), f64x3(*n)) > 0.0, "normal points inward at {p:?}");
    }
}

#[test]
fn uv_seams_split_vertices_but_not_positions() {
    // Every cage edge is a UV seam: the mesh is cut into six UV islands, yet the positions on
    // either side of each seam are bit-identical, so the surface stays closed.
    let (uv_indices, uv_values) = cube_with_uv_seams();
    let channels = [FaceVaryingChannel { indices: &uv_indices, value_count: uv_values.len() }];
    let cage = Cage { face_varying: &channels, ..cube() };
    let refiner = adaptive(&cage);
    let rates = varied_rates(&refiner);
    let uv = AdaptiveUv::FaceVarying(UvSource { channel: 0, values: &uv_values });
    let mesh = refiner.tessellate(&CUBE_POINTS, Some(uv), &rates, false).unwrap().mesh;
    let uvs = mesh.uvs.as_ref().unwrap();

    let by_position = edge_uses(&mesh.triangles, |v| position_bits(mesh.positions[v as usize]));
    for (edge, &(forward, backward)) in &by_position {
        assert_eq!((forward, backward), (1, 1), "edge {edge:?}");
    }
    // By index, the seams are open: every cage edge's segments are used once per side.
    let by_index = edge_uses(&mesh.triangles, |v| v);
    let open = by_index.values().filter(|&&(a, b)| a + b == 1).count() as u32;
    assert_eq!(open, 2 * rates.iter().sum::<u32>());

    // Copies of a point: one per island it belongs to (3 at cube corners, 2 along edges), with
    // identical normals and UVs on their islands' borders.
    let mut copies: HashMap<[u32; 3], Vec<usize>> = HashMap::new();
    for (i, &p) in mesh.positions.iter().enumerate() {
        copies.entry(position_bits(p)).or_default().push(i);
    }
    let corners = copies.values().filter(|c| c.len() == 3).count();
    let edge_points = copies.values().filter(|c| c.len() == 2).count() as u32;
    assert_eq!(corners, 8);
    assert_eq!(edge_points, rates.iter().map(|r| r - 1).sum::<u32>());
    for c in copies.values().filter(|c| c.len() > 1) {
        for &i in c {
            assert_eq!(mesh.normals[i], mesh.normals[c[0]]);
            let [u, v] = uvs[i];
            let u = u - 2.0 * ((u + 1e-4) / 2.0).floor();
            assert!([u, v].iter().any(|&t| t.abs() < 1e-5 || (t - 1.0).abs() < 1e-5), "seam uv {:?}", uvs[i]);
        }
    }
}

/// A closed triangular prism: two triangles and three quads (Catmull–Clark splits the triangles
/// into quadrilateral sub-faces), with valence-3 corners.
const PRISM_POINTS: [[f32; 3]; 6] =
    [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.5, 1.5, 0.0], [0.0, 0.0, 2.5], [2.0, 0.0, 2.5], [0.5, 1.5, 2.5]];
const PRISM_COUNTS: [i32; 5] = [3, 3, 4, 4, 4];
const PRISM_INDICES: [i32; 18] = [0, 2, 1, 3, 4, 5, 0, 1, 4, 3, 1, 2, 5, 4, 2, 0, 3, 5];

/// Distance from each point of `points` to the nearest of `reference`.
fn nearest_distances(points: &[[f32; 3]], reference: &[[f64; 3]]) -> Vec<f64> {
    points
        .iter()
        .map(|&p| reference.iter().map(|&q| dist(f64x3(p), q)).fold(f64::INFINITY, f64::min))
        .collect()
}

#[test]
fn adaptive_points_lie_on_the_uniform_limit_surface() {
    // Power-of-two rates put every tessellation point at a dyadic parameter, where the uniform
    // level-6 refinement has a vertex with its exact limit point: the two must coincide up to
    // Bfr's approximation of irregular patches (extraordinary vertices, triangles).
    let prism = Cage {
        face_vertex_counts: &PRISM_COUNTS,
        face_vertex_indices: &PRISM_INDICES,
        vertex_count: 6,
        ..Default::default()
    };
    for (name, cage, points) in [("cube", cube(), &CUBE_POINTS[..]), ("prism", prism, &PRISM_POINTS[..])] {
        let refiner = adaptive(&cage);
        let rates: Vec<u32> = (0..refiner.edges().len()).map(|e| [2, 4, 8, 16, 32][e % 5]).collect();
        let mesh = refiner.tessellate(points, None, &rates, false).unwrap().mesh;
        let uniform = refine(&cage, 6).limit(points).unwrap().positions;
        let size = {
            let (lo, hi) =
                uniform.iter().fold(([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]), |(lo, hi), p| {
                    (std::array::from_fn(|k| lo[k].min(p[k])), std::array::from_fn(|k| hi[k].max(p[k])))
                });
            dist(lo, hi)
        };
        let worst = nearest_distances(&mesh.positions, &uniform).into_iter().fold(0.0, f64::max);
        eprintln!(
            "{name}: {} points, worst distance to the level-6 limit {:.2e} of the size",
            mesh.positions.len(),
            worst / size
        );
        assert!(worst < 1e-3 * size, "{name}: {worst}");
        assert_unit_normals(&mesh);

        // Arbitrary parameters through `evaluate` agree with the tessellation's own points.
        let coords = refiner.tessellate(points, None, &rates, true).unwrap();
        let samples: Vec<(u32, [f64; 2])> = coords
            .corner_coords
            .iter()
            .zip(&coords.mesh.coarse_face)
            .map(|(c, &f)| (f, c[0].map(f64::from)))
            .collect();
        let evaluated = refiner.evaluate(points, &samples).unwrap();
        for ((t, e), _) in coords.mesh.triangles.iter().zip(&evaluated).zip(&samples) {
            assert!(dist(f64x3(coords.mesh.positions[t[0] as usize]), *e) < 1e-6);
        }
    }
}

#[test]
fn uniform_rates_match_uniform_levels_in_triangles() {
    // Rate 2^L on every edge gives the triangles of uniform level L, for quads, Catmull–Clark
    // triangles and loop triangles.
    let refiner = adaptive(&cube());
    for level in 0..=4u32 {
        let rates = vec![1 << level; 12];
        let mesh = refiner.tessellate(&CUBE_POINTS, None, &rates, false).unwrap().mesh;
        assert_eq!(mesh.triangles.len(), 2 * 6 * 4usize.pow(level));
        assert_eq!(refiner.triangle_estimate(&rates), mesh.triangles.len() as u64);
    }
    let prism = Cage {
        face_vertex_counts: &PRISM_COUNTS,
        face_vertex_indices: &PRISM_INDICES,
        vertex_count: 6,
        ..Default::default()
    };
    let refiner = adaptive(&prism);
    for level in 1..=3u32 {
        let rates = vec![1 << level; refiner.edges().len()];
        let mesh = refiner.tessellate(&PRISM_POINTS, None, &rates, false).unwrap().mesh;
        let uniform = tessellate(&refine(&prism, level), &PRISM_POINTS, None).unwrap();
        assert_eq!(mesh.triangles.len(), uniform.triangles.len(), "level {level}");
        assert_eq!(refiner.triangle_estimate(&rates), mesh.triangles.len() as u64);
    }
    let points = [[1.0f32, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]];
    let mut tetrahedron = Cage {
        face_vertex_counts: &[3; 4],
        face_vertex_indices: &[0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2],
        vertex_count: 4,
        ..Default::default()
    };
    tetrahedron.options.scheme = Scheme::Loop;
    let refiner = adaptive(&tetrahedron);
    let mesh = refiner.tessellate(&points, None, &[4; 6], false).unwrap().mesh;
    assert_eq!(mesh.triangles.len(), 4 * 16);
    for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
        assert!(dot(f64x3(*p), f64x3(*n)) > 0.0, "normal points inward");
    }
}

#[test]
fn crease_and_corners_hold_at_any_edge_rate() {
    // Edge 0–1 creased with corner ends: its limit curve is the straight cage edge, so all
    // rate + 1 points of that edge lie on it; without the crease only the corners do.
    let (a, b) = (f64x3(CUBE_POINTS[0]), f64x3(CUBE_POINTS[1]));
    let creased = creased_edge_cube();
    let corners_only = Cage { corner_indices: &[0, 1], corner_sharpnesses: &[10.0, 10.0], ..cube() };
    for rate in [1u32, 3, 5, 16] {
        for (cage, expected) in [(creased, rate as usize + 1), (corners_only, 2)] {
            let refiner = adaptive(&cage);
            let mut rates = vec![3; 12];
            let edge = refiner.edges().iter().position(|&e| e == [0, 1] || e == [1, 0]).unwrap();
            rates[edge] = rate;
            let mesh = refiner.tessellate(&CUBE_POINTS, None, &rates, false).unwrap().mesh;
            let on_edge: Vec<[f64; 3]> = mesh
                .positions
                .iter()
                .map(|&p| f64x3(p))
                .filter(|&p| distance_to_line(p, a, b) < 1e-5)
                .collect();
            assert_eq!(on_edge.len(), expected, "rate {rate}");
            assert!(on_edge.iter().all(|p| p[0] >= -1.0 - 1e-6 && p[0] <= 1.0 + 1e-6));
            // The sharp corners stay at their cage vertices.
            for corner in [a, b] {
                assert!(mesh.positions.iter().any(|&p| dist(f64x3(p), corner) < 1e-6));
            }
        }
    }
}

#[test]
fn holes_and_boundary_none_produce_no_faces() {
    let cage = Cage { hole_indices: &[2], ..cube() };
    let refiner = adaptive(&cage);
    assert!(refiner.is_hole(2));
    let rates = varied_rates(&refiner);
    let mesh = refiner.tessellate(&CUBE_POINTS, None, &rates, false).unwrap().mesh;
    assert!(!mesh.coarse_face.contains(&2));
    assert!((0..6u32).filter(|&f| f != 2).all(|f| mesh.coarse_face.contains(&f)));
    // The hole's border is open: its edges are used once.
    let open: u32 = edge_uses(&mesh.triangles, |v| v).values().filter(|&&(a, b)| a + b == 1).count() as u32;
    let (_, edges) = refiner.face(2);
    assert_eq!(open, edges.iter().map(|&e| rates[e as usize]).sum::<u32>());

    // 3×3 grid with interpolateBoundary = none: only the centre face (4) has a surface.
    let points: Vec<[f32; 3]> = (0..16).map(|i| [(i % 4) as f32, (i / 4) as f32, 0.0]).collect();
    let mut indices = Vec::new();
    for y in 0..3 {
        for x in 0..3 {
            let v = y * 4 + x;
            indices.extend([v, v + 1, v + 5, v + 4]);
        }
    }
    let mut grid = Cage {
        face_vertex_counts: &[4; 9],
        face_vertex_indices: &indices,
        vertex_count: 16,
        ..Default::default()
    };
    grid.options.boundary = BoundaryInterpolation::None;
    let refiner = adaptive(&grid);
    let mesh = refiner.tessellate(&points, None, &vec![4; refiner.edges().len()], false).unwrap().mesh;
    assert_eq!(mesh.triangles.len(), 2 * 16);
    assert!(mesh.coarse_face.iter().all(|&f| f == 4));

    // With edgeAndCorner, the flat grid stays flat with +z normals, whatever the rates.
    grid.options.boundary = BoundaryInterpolation::EdgeAndCorner;
    let refiner = adaptive(&grid);
    let rates = varied_rates(&refiner);
    let mesh = refiner.tessellate(&points, None, &rates, false).unwrap().mesh;
    assert!(mesh.positions.iter().all(|p| p[2].abs() < 1e-6));
    assert!(mesh.normals.iter().all(|n| (n[2] - 1.0).abs() < 1e-5));
    // The boundary interpolates the cage boundary: the corner (3, 3) is a limit point.
    assert!(mesh.positions.iter().any(|&p| dist(f64x3(p), [3.0, 3.0, 0.0]) < 1e-6));
}

#[test]
fn vertex_uvs_are_evaluated_like_positions() {
    // A vertex primvar equal to (x, y) of the points has the limit (x, y) of the surface.
    let uv: Vec<[f32; 2]> = CUBE_POINTS.iter().map(|p| [p[0], p[1]]).collect();
    let refiner = adaptive(&cube());
    let rates = varied_rates(&refiner);
    let mesh = refiner.tessellate(&CUBE_POINTS, Some(AdaptiveUv::Vertex(&uv)), &rates, false).unwrap().mesh;
    let uvs = mesh.uvs.unwrap();
    assert_eq!(uvs.len(), mesh.positions.len());
    for (t, p) in uvs.iter().zip(&mesh.positions) {
        assert!((t[0] - p[0]).abs() < 1e-6 && (t[1] - p[1]).abs() < 1e-6, "{t:?} {p:?}");
    }
}

#[test]
fn bad_rates_and_samples_are_errors() {
    let refiner = adaptive(&cube());
    let tess = |rates: &[u32]| refiner.tessellate(&CUBE_POINTS, None, rates, false);
    assert!(matches!(tess(&[2; 11]), Err(Error::PrimvarSize { what: "edge rates", .. })));
    let mut rates = vec![2; 12];
    rates[3] = 0;
    assert!(matches!(tess(&rates), Err(Error::Invalid { attribute: "edge rates", .. })));
    rates[3] = MAX_RATE + 1;
    assert!(matches!(tess(&rates), Err(Error::Invalid { attribute: "edge rates", .. })));
    // 400 quads at the highest rate would be 400·2·2^20 = 839 M triangles, beyond the shim's
    // 32-bit corner indices: refused before any work.
    let points: Vec<[f32; 3]> = (0..21 * 21).map(|i| [(i % 21) as f32, (i / 21) as f32, 0.0]).collect();
    let indices: Vec<i32> = (0..20 * 20)
        .flat_map(|q| [q % 20 + 21 * (q / 20)])
        .flat_map(|v| [v, v + 1, v + 22, v + 21])
        .collect();
    let grid = adaptive(&Cage {
        face_vertex_counts: &[4; 400],
        face_vertex_indices: &indices,
        vertex_count: points.len(),
        ..Default::default()
    });
    let rates = vec![MAX_RATE; grid.edges().len()];
    assert_eq!(grid.triangle_estimate(&rates), (400 * 2) << 20);
    let err = grid.tessellate(&points, None, &rates, false).unwrap_err();
    assert!(matches!(err, Error::Invalid { attribute: "edge rates", .. }), "{err}");
    assert!(matches!(
        refiner.tessellate(&CUBE_POINTS[..7], None, &[2; 12], false),
        Err(Error::PrimvarSize { what: "points", .. })
    ));
    assert!(refiner.evaluate(&CUBE_POINTS, &[(6, [0.5, 0.5])]).is_err());
    // A hole has no surface to evaluate.
    let holed = adaptive(&Cage { hole_indices: &[1], ..cube() });
    let err = holed.evaluate(&CUBE_POINTS, &[(1, [0.5, 0.5])]).unwrap_err();
    assert!(matches!(err, Error::OpenSubdiv(ref m) if m.contains("face 1")), "{err}");
}

#[test]
fn non_manifold_and_degenerate_faces_do_not_crash_bfr() {
    crate::tests::check_degenerate_cages(|cage, points| {
        let refiner = Topology::new(cage).and_then(|t| AdaptiveRefiner::new(&t))?;
        let rates = vec![3; refiner.edges().len()];
        refiner.tessellate(points, None, &rates, false).map(|t| t.mesh)
    });
}

#[test]
fn dicing_rates_per_edge() {
    assert_eq!(rate_for_dicing_rate(100.0, 1.0, 1024), 100);
    assert_eq!(rate_for_dicing_rate(100.5, 1.0, 1024), 101);
    assert_eq!(rate_for_dicing_rate(100.0, 4.0, 1024), 25);
    assert_eq!(rate_for_dicing_rate(0.3, 1.0, 1024), 1);
    assert_eq!(rate_for_dicing_rate(1e9, 1.0, 32), 32);
    assert_eq!(rate_for_dicing_rate(f64::NAN, 1.0, 32), 1);
    assert_eq!(rate_for_dicing_rate(10.0, 0.0, 32), 32);
    assert_eq!(rate_for_dicing_rate(1e9, 1.0, u32::MAX), MAX_RATE);
    assert_eq!([1, 2, 3, 4, 5, 32, 33].map(level_for_rate), [0, 1, 2, 2, 3, 5, 6]);
}

#[test]
fn adaptive_refiner_is_send_and_sync() {
    fn check<T: Send + Sync>() {}
    check::<AdaptiveRefiner>();
}
