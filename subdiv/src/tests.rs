//! Geometry tests through the whole pipeline (cage → refiner → limit → triangles), on cages whose
//! answers are known analytically.

use crate::limit::{cross, dot, length, sub};
use crate::*;

/// Cube [-1, 1]³, faces wound counter-clockwise seen from outside.
pub(crate) const CUBE_POINTS: [[f32; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];
pub(crate) const CUBE_COUNTS: [i32; 6] = [4; 6];
pub(crate) const CUBE_INDICES: [i32; 24] =
    [0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7];

pub(crate) fn cube() -> Cage<'static> {
    Cage {
        face_vertex_counts: &CUBE_COUNTS,
        face_vertex_indices: &CUBE_INDICES,
        vertex_count: 8,
        ..Default::default()
    }
}

/// [`cube`] with edge 0–1 infinitely creased and its ends made corners: the limit curve of that edge
/// is the straight cage edge.
pub(crate) fn creased_edge_cube() -> Cage<'static> {
    Cage {
        crease_indices: &[0, 1],
        crease_lengths: &[2],
        crease_sharpnesses: &[10.0],
        corner_indices: &[0, 1],
        corner_sharpnesses: &[10.0, 10.0],
        ..cube()
    }
}

pub(crate) fn refine(cage: &Cage<'_>, level: u32) -> Refiner {
    Refiner::new(&Topology::new(cage).unwrap(), level).unwrap()
}

pub(crate) fn f64x3(p: [f32; 3]) -> [f64; 3] {
    p.map(f64::from)
}

pub(crate) fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    length(sub(a, b))
}

/// Distance from `p` to the infinite line through `a` and `b`.
pub(crate) fn distance_to_line(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let ab = sub(b, a);
    length(cross(sub(p, a), ab)) / length(ab)
}

#[test]
fn cube_triangle_count_grows_four_times_per_level() {
    for level in 0..=4u32 {
        let refiner = refine(&cube(), level);
        let faces = refiner.faces(None).unwrap();
        assert_eq!(faces.counts.len(), 6 * 4usize.pow(level));
        assert!(faces.counts.iter().all(|&n| n == 4));
        let mesh = tessellate(&refiner, &CUBE_POINTS, None).unwrap();
        assert_eq!(mesh.triangles.len(), 2 * 6 * 4usize.pow(level));
        for face in 0..6 {
            let n = mesh.coarse_face.iter().filter(|&&f| f == face).count();
            assert_eq!(n, 2 * 4usize.pow(level), "triangles from cage face {face}");
        }
        // A closed cube: V - E + F = 2 with E = 3F/2 for triangles.
        assert_eq!(mesh.positions.len() as i64 - mesh.triangles.len() as i64 / 2, 2);
    }
}

#[test]
fn infinitely_sharp_crease_with_corner_ends_stays_on_the_cage_edge() {
    // Edge 0–1 creased; its ends made corners, so the crease curve interpolates them and is the
    // straight segment. Without the crease the edge curve bulges inward.
    let a = f64x3(CUBE_POINTS[0]);
    let b = f64x3(CUBE_POINTS[1]);
    let on_edge = |mesh: &Tessellation| -> usize {
        mesh.positions.iter().filter(|&&p| distance_to_line(f64x3(p), a, b) < 1e-5).count()
    };
    for level in 1..=4u32 {
        let creased = creased_edge_cube();
        let refiner = refine(&creased, level);
        assert_eq!(flipped_tangent_fraction(&refiner, &CUBE_POINTS), 0.0, "crease and corner vertices");
        let mesh = tessellate(&refiner, &CUBE_POINTS, None).unwrap();
        assert_eq!(on_edge(&mesh), (1 << level) + 1, "level {level}");
        // The points on the line lie between the cage corners, not beyond.
        for p in mesh.positions.iter().map(|&p| f64x3(p)) {
            if distance_to_line(p, a, b) < 1e-5 {
                assert!(p[0] >= -1.0 - 1e-6 && p[0] <= 1.0 + 1e-6);
            }
        }

        let corners_only = Cage { corner_indices: &[0, 1], corner_sharpnesses: &[10.0, 10.0], ..cube() };
        let mesh = tessellate(&refine(&corners_only, level), &CUBE_POINTS, None).unwrap();
        assert_eq!(on_edge(&mesh), 2, "level {level}: only the corners without the crease");
    }
}

#[test]
fn crease_sharpness_per_edge_and_per_chain_agree() {
    // A chain 0-1-2 with one sharpness, and the same chain with one sharpness per edge.
    let per_chain =
        Cage { crease_indices: &[0, 1, 2], crease_lengths: &[3], crease_sharpnesses: &[2.5], ..cube() };
    let per_edge = Cage { crease_sharpnesses: &[2.5, 2.5], ..per_chain };
    let a = tessellate(&refine(&per_chain, 3), &CUBE_POINTS, None).unwrap();
    let b = tessellate(&refine(&per_edge, 3), &CUBE_POINTS, None).unwrap();
    assert_eq!(a, b);
    let smooth = tessellate(&refine(&cube(), 3), &CUBE_POINTS, None).unwrap();
    assert_ne!(a.positions, smooth.positions);
}

#[test]
fn sharp_corner_stays_at_its_cage_vertex() {
    let cage = Cage { corner_indices: &[6], corner_sharpnesses: &[10.0], ..cube() };
    for level in 0..=4u32 {
        let refiner = refine(&cage, level);
        let limit = refiner.limit(&CUBE_POINTS).unwrap();
        // Children of vertices come first at every level, so vertex 6 keeps its index.
        assert!(dist(limit.positions[6], f64x3(CUBE_POINTS[6])) < 1e-6, "level {level}");
        assert!(dist(limit.positions[0], f64x3(CUBE_POINTS[0])) > 0.1);
    }
}

#[test]
fn holes_leave_no_faces() {
    let cage = Cage { hole_indices: &[2], ..cube() };
    for level in 0..=3u32 {
        let mesh = tessellate(&refine(&cage, level), &CUBE_POINTS, None).unwrap();
        assert_eq!(mesh.triangles.len(), 2 * 6 * 4usize.pow(level) - 2 * 4usize.pow(level));
        assert!(!mesh.coarse_face.contains(&2));
    }
}

#[test]
fn boundary_none_drops_faces_touching_the_boundary() {
    // 3×3 grid of quads; with interpolateBoundary = none only the centre face (4) is surface.
    let points: Vec<[f32; 3]> = (0..16).map(|i| [(i % 4) as f32, (i / 4) as f32, 0.0]).collect();
    let mut indices = Vec::new();
    for y in 0..3 {
        for x in 0..3 {
            let v = y * 4 + x;
            indices.extend([v, v + 1, v + 5, v + 4]);
        }
    }
    let counts = [4; 9];
    let mut cage = Cage {
        face_vertex_counts: &counts,
        face_vertex_indices: &indices,
        vertex_count: 16,
        ..Default::default()
    };
    cage.options.boundary = BoundaryInterpolation::None;
    let mesh = tessellate(&refine(&cage, 2), &points, None).unwrap();
    assert_eq!(mesh.triangles.len(), 2 * 16);
    assert!(mesh.coarse_face.iter().all(|&f| f == 4));

    cage.options.boundary = BoundaryInterpolation::EdgeAndCorner;
    let refiner = refine(&cage, 2);
    assert_eq!(flipped_tangent_fraction(&refiner, &points), 0.0, "boundary vertices");
    let mesh = tessellate(&refiner, &points, None).unwrap();
    assert_eq!(mesh.triangles.len(), 2 * 9 * 16);
    // A flat cage stays flat, with normals along +z (faces wound counter-clockwise).
    assert!(mesh.positions.iter().all(|p| p[2].abs() < 1e-6));
    assert!(mesh.normals.iter().all(|n| (n[2] - 1.0).abs() < 1e-5));
}

/// Per-face UV islands, face `f` on [2f, 2f + 1] × [0, 1]: every cage edge is a UV seam, and
/// the two sides of a seam never share a UV value by accident.
pub(crate) fn cube_with_uv_seams() -> (Vec<i32>, Vec<[f32; 2]>) {
    let indices: Vec<i32> = (0..24).collect();
    let square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let values: Vec<[f32; 2]> = (0..6).flat_map(|f| square.map(|[u, v]| [u + 2.0 * f as f32, v])).collect();
    (indices, values)
}

#[test]
fn face_varying_seams_stay_seams() {
    let (uv_indices, uv_values) = cube_with_uv_seams();
    let channels = [FaceVaryingChannel { indices: &uv_indices, value_count: uv_values.len() }];
    let cage = Cage { face_varying: &channels, ..cube() };
    for level in 1..=3u32 {
        let refiner = refine(&cage, level);
        let mesh =
            tessellate(&refiner, &CUBE_POINTS, Some(UvSource { channel: 0, values: &uv_values })).unwrap();
        let uvs = mesh.uvs.as_ref().unwrap();
        let side = (1usize << level) + 1;
        // Each face is its own UV island of side² vertices.
        assert_eq!(mesh.positions.len(), 6 * side * side);
        assert_eq!(mesh.triangles.len(), 2 * 6 * 4usize.pow(level));

        // Group output vertices by the refined vertex they sit on.
        let mut by_vertex = std::collections::HashMap::<u32, Vec<usize>>::new();
        for (i, &v) in mesh.refined_vertex.iter().enumerate() {
            by_vertex.entry(v).or_default().push(i);
        }
        let mut seam_vertices = 0;
        for copies in by_vertex.values().filter(|c| c.len() > 1) {
            seam_vertices += 1;
            // Same point, same normal …
            for &i in copies {
                assert_eq!(mesh.positions[i], mesh.positions[copies[0]]);
                assert_eq!(mesh.normals[i], mesh.normals[copies[0]]);
            }
            // … on the border of every island it belongs to, with distinct UVs.
            for &i in copies {
                let [u, v] = uvs[i];
                let u = u - 2.0 * ((u + 1e-4) / 2.0).floor();
                let on_border = [u, v].iter().any(|&t| t.abs() < 1e-5 || (t - 1.0).abs() < 1e-5);
                assert!(on_border, "seam uv {:?}", uvs[i]);
            }
            let distinct = copies.iter().any(|&i| {
                let (a, b) = (uvs[i], uvs[copies[0]]);
                (a[0] - b[0]).abs() + (a[1] - b[1]).abs() > 1e-3
            });
            assert!(
                distinct,
                "seam vertex with a single UV: {:?}",
                copies.iter().map(|&i| (uvs[i], mesh.positions[i])).collect::<Vec<_>>()
            );
        }
        // 12 edges with side-2 interior points, plus 8 corners.
        assert_eq!(seam_vertices, 12 * (side - 2) + 8);
        assert!(uvs
            .iter()
            .all(|&[u, v]| (-1e-6..=11.0 + 1e-6).contains(&u) && (-1e-6..=1.0 + 1e-6).contains(&v)));
    }
}

#[test]
fn cube_limit_points_lie_inside_the_cage_and_corners_match_the_limit_mask() {
    // Catmull–Clark limit of a valence-n vertex on quads: (n² v + 4 Σ edge neighbours +
    // Σ diagonal neighbours) / (n (n + 5)). For the corner (1,1,1) of [-1,1]³, n = 3:
    // per axis (9·1 + 4·(−1 + 1 + 1) + (−1 − 1 + 1)) / 24 = 12 / 24 = 1/2, i.e. ±1/4 for a cube
    // of side 1 (not 5/9: the cage corner moves halfway towards the centre).
    let expected = {
        let v = [1.0f64, 1.0, 1.0];
        let edges = [[-1.0, 1.0, 1.0], [1.0, -1.0, 1.0], [1.0, 1.0, -1.0]];
        let diagonals = [[-1.0, -1.0, 1.0], [-1.0, 1.0, -1.0], [1.0, -1.0, -1.0]];
        let n = 3.0;
        let mut p = v.map(|x| n * n * x);
        for e in edges {
            p = [p[0] + 4.0 * e[0], p[1] + 4.0 * e[1], p[2] + 4.0 * e[2]];
        }
        for d in diagonals {
            p = [p[0] + d[0], p[1] + d[1], p[2] + d[2]];
        }
        p.map(|x| x / (n * (n + 5.0)))
    };
    assert!(expected.iter().all(|&x| (x - 0.5).abs() < 1e-12));

    for level in 0..=4u32 {
        let limit = refine(&cube(), level).limit(&CUBE_POINTS).unwrap();
        assert!(dist(limit.positions[6], expected) < 1e-6, "level {level}: {:?}", limit.positions[6]);
        let max_abs = limit.positions.iter().flatten().fold(0.0f64, |m, &x| m.max(x.abs()));
        assert!(max_abs < 1.0, "level {level}: limit reaches {max_abs}");
    }
    // Brute force: a level-8 control point of the corner is within 1e-4 of the limit.
    let refined =
        refine(&cube(), 8).vertex_primvar(CUBE_POINTS.as_flattened(), 3, Evaluation::Refined).unwrap();
    let corner = [refined[18], refined[19], refined[20]].map(f64::from);
    eprintln!("cube corner: level-8 control point {:.3e} from the analytic limit", dist(corner, expected));
    assert!(dist(corner, expected) < 1e-4, "{corner:?}");
}

/// Max distance between the refined control points and their limit points at `level`.
fn control_to_limit(level: u32) -> f64 {
    let refiner = refine(&cube(), level);
    let flat = CUBE_POINTS.as_flattened();
    let refined = refiner.vertex_primvar(flat, 3, Evaluation::Refined).unwrap();
    let limit = refiner.vertex_primvar(flat, 3, Evaluation::Limit).unwrap();
    refined
        .chunks_exact(3)
        .zip(limit.chunks_exact(3))
        .map(|(a, b)| {
            let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]].map(f64::from);
            length(d)
        })
        .fold(0.0, f64::max)
}

#[test]
fn refined_points_converge_to_the_limit_four_times_per_level() {
    let errors: Vec<f64> = (1..=6).map(control_to_limit).collect();
    let ratios: Vec<f64> = errors.windows(2).map(|w| w[0] / w[1]).collect();
    eprintln!("control-to-limit distance per level 1..=6: [{}]; ratios {ratios:.3?}", sci(&errors));
    for r in &ratios {
        assert!((3.5..=4.5).contains(r), "ratio {r}");
    }
}

#[test]
fn limit_points_do_not_depend_on_the_level_they_are_evaluated_at() {
    // Vertices that persist from level N to N+1 keep their index (children of vertices come
    // first) and, the limit masks being exact, their limit point.
    let mut max_diff = Vec::new();
    for level in 0..=4u32 {
        let coarse = refine(&cube(), level).limit(&CUBE_POINTS).unwrap();
        let fine = refine(&cube(), level + 1).limit(&CUBE_POINTS).unwrap();
        let d = coarse.positions.iter().zip(&fine.positions).map(|(&a, &b)| dist(a, b)).fold(0.0, f64::max);
        max_diff.push(d);
        assert!(d < 1e-6, "level {level}: {d}");
    }
    eprintln!("limit point drift level N → N+1, N = 0..=4: [{}]", sci(&max_diff));
}

/// Formats small distances for the test log.
fn sci(values: &[f64]) -> String {
    values.iter().map(|v| format!("{v:.3e}")).collect::<Vec<_>>().join(", ")
}

/// Catmull–Clark's subdominant eigenvalue at a valence-`n` vertex: how much the 1-ring shrinks
/// per level around it.
fn catmull_clark_subdominant(n: f64) -> f64 {
    let c = (std::f64::consts::TAU / n).cos();
    (5.0 + c + (std::f64::consts::PI / n).cos() * (2.0 * (9.0 + c)).sqrt()) / 16.0
}

#[test]
fn chordal_error_shrinks_four_times_per_level_away_from_extraordinary_vertices() {
    // Level-N limit quads against the level-(N+1) limit points at the same parameters: the child
    // of edge (j, j+1) against the edge's chord midpoint, the face child against the bilinear
    // centre. Quad f splits into children 4f..4f+3, each holding one corner of f. Errors are kept
    // apart for quads within a fixed distance of a cube corner (the valence-3 vertices, indices
    // 0..8 at every level): a fixed region, so that "away" means a fixed parametric distance.
    const NEAR: f64 = 0.3;
    let mut regular = Vec::new();
    let mut extraordinary = Vec::new();
    for level in 1..=6u32 {
        let (coarse_refiner, fine_refiner) = (refine(&cube(), level), refine(&cube(), level + 1));
        let coarse = coarse_refiner.limit(&CUBE_POINTS).unwrap().positions;
        let fine = fine_refiner.limit(&CUBE_POINTS).unwrap().positions;
        let coarse_faces = coarse_refiner.faces(None).unwrap();
        let fine_faces = fine_refiner.faces(None).unwrap();
        let (mut worst_regular, mut worst_extraordinary) = (0.0f64, 0.0f64);
        for (f, quad) in coarse_faces.vertices.chunks_exact(4).enumerate() {
            let p = |i: usize| coarse[quad[i % 4] as usize];
            let centre = (0..4)
                .fold([0.0; 3], |s, i| [s[0] + p(i)[0] / 4.0, s[1] + p(i)[1] / 4.0, s[2] + p(i)[2] / 4.0]);
            let mut worst = 0.0f64;
            for c in 4 * f..4 * f + 4 {
                let child = &fine_faces.vertices[4 * c..4 * c + 4];
                // The child holding corner j (vertex children keep their index) continues, with
                // the winding, along edge (j, j+1) to the face centre.
                let k = child.iter().position(|v| quad.contains(v)).expect("child keeps a corner");
                let j = quad.iter().position(|&v| v == child[k]).unwrap();
                let mid = [
                    (p(j)[0] + p(j + 1)[0]) / 2.0,
                    (p(j)[1] + p(j + 1)[1]) / 2.0,
                    (p(j)[2] + p(j + 1)[2]) / 2.0,
                ];
                worst = worst.max(dist(fine[child[(k + 1) % 4] as usize], mid));
                worst = worst.max(dist(fine[child[(k + 2) % 4] as usize], centre));
            }
            let near_corner =
                quad.iter().any(|&v| (0..8).any(|e| dist(coarse[v as usize], coarse[e]) < NEAR));
            if near_corner {
                worst_extraordinary = worst_extraordinary.max(worst);
            } else {
                worst_regular = worst_regular.max(worst);
            }
        }
        regular.push(worst_regular);
        extraordinary.push(worst_extraordinary);
    }
    let ratios = |e: &[f64]| -> Vec<f64> { e.windows(2).map(|w| w[0] / w[1]).collect() };
    let (regular_ratios, extraordinary_ratios) = (ratios(&regular), ratios(&extraordinary));
    eprintln!(
        "chordal error, quads ≥ {NEAR} from corners, levels 1..=6: [{}]; ratios {regular_ratios:.3?}",
        sci(&regular)
    );
    eprintln!(
        "chordal error, quads < {NEAR} from valence-3 corners: [{}]; ratios {extraordinary_ratios:.3?} (1/λ₃ = {:.3})",
        sci(&extraordinary),
        1.0 / catmull_clark_subdominant(3.0)
    );
    for r in &regular_ratios[1..] {
        assert!((3.5..=4.5).contains(r), "regular ratio {r}");
    }
    // Next to an extraordinary vertex the parameterisation shrinks by λ per level, and so does
    // the error at fixed parameters.
    let expected = 1.0 / catmull_clark_subdominant(3.0);
    assert!((extraordinary_ratios.last().unwrap() - expected).abs() < 0.05);
}

pub(crate) fn assert_unit_normals(mesh: &Tessellation) {
    for n in &mesh.normals {
        let n = f64x3(*n);
        assert!(n.iter().all(|x| x.is_finite()));
        assert!((length(n) - 1.0).abs() < 1e-5, "{n:?}");
    }
}

/// Fraction of refined vertices whose raw `du × dv` points against the faces around them.
fn flipped_tangent_fraction(refiner: &Refiner, points: &[[f32; 3]]) -> f64 {
    let limit = refiner.limit(points).unwrap();
    let faces = refiner.faces(None).unwrap();
    let mut sum = vec![[0.0f64; 3]; limit.positions.len()];
    let mut start = 0;
    for (f, &n) in faces.counts.iter().enumerate() {
        let v = &faces.vertices[start..start + n as usize];
        start += n as usize;
        if faces.is_hole[f] {
            continue;
        }
        let p = |i: usize| limit.positions[v[i] as usize];
        let fnrm = cross(sub(p(1), p(0)), sub(p(v.len() - 1), p(0)));
        for &i in v {
            let s = &mut sum[i as usize];
            *s = [s[0] + fnrm[0], s[1] + fnrm[1], s[2] + fnrm[2]];
        }
    }
    let (mut flipped, mut total) = (0, 0);
    for (v, s) in sum.iter().enumerate() {
        if let Some(n) = normal_from_tangents(limit.du[v], limit.dv[v]) {
            total += 1;
            if dot(n, *s) < 0.0 {
                flipped += 1;
            }
        }
    }
    flipped as f64 / total as f64
}

#[test]
fn valence_three_cube_corners_have_outward_unit_normals() {
    for level in 0..=3u32 {
        let refiner = refine(&cube(), level);
        let mesh = tessellate(&refiner, &CUBE_POINTS, None).unwrap();
        assert_unit_normals(&mesh);
        // Convex and centred on the origin: every normal points away from the centre.
        for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
            assert!(dot(f64x3(*p), f64x3(*n)) > 0.0);
        }
        // The corner normal is the diagonal by symmetry.
        let corner = mesh.refined_vertex.iter().position(|&v| v == 6).unwrap();
        let expected = 1.0 / 3f64.sqrt();
        assert!(mesh.normals[corner].iter().all(|&x| (f64::from(x) - expected).abs() < 1e-5));
        assert_eq!(flipped_tangent_fraction(&refiner, &CUBE_POINTS), 0.0, "level {level}");
    }
}

#[test]
fn valence_five_vertex_has_a_finite_unit_normal() {
    // Five quads around vertex 0 (raised), spokes s_i = 1 + 2i and rims m_i = 2 + 2i.
    let mut points = vec![[0.0f32, 0.0, 0.5]];
    for i in 0..5 {
        let a = std::f32::consts::TAU * i as f32 / 5.0;
        let b = std::f32::consts::TAU * (i as f32 + 0.5) / 5.0;
        points.push([a.cos(), a.sin(), 0.0]);
        points.push([1.5 * b.cos(), 1.5 * b.sin(), 0.0]);
    }
    let mut indices = Vec::new();
    for i in 0..5 {
        let s = 1 + 2 * i;
        let m = 2 + 2 * i;
        let next = 1 + 2 * ((i + 1) % 5);
        indices.extend([0, s, m, next]);
    }
    let counts = [4; 5];
    let cage = Cage {
        face_vertex_counts: &counts,
        face_vertex_indices: &indices,
        vertex_count: 11,
        ..Default::default()
    };
    for level in 0..=3u32 {
        let refiner = refine(&cage, level);
        let mesh = tessellate(&refiner, &points, None).unwrap();
        assert_unit_normals(&mesh);
        let centre = mesh.refined_vertex.iter().position(|&v| v == 0).unwrap();
        let n = mesh.normals[centre];
        // Rotational symmetry: the normal is +z.
        assert!((n[2] - 1.0).abs() < 1e-5 && n[0].abs() < 1e-5, "level {level}: {n:?}");
        assert_eq!(flipped_tangent_fraction(&refiner, &points), 0.0, "level {level}");
    }
}

#[test]
fn loop_tetrahedron_quadruples_triangles() {
    let points = [[1.0f32, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]];
    let indices = [0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2];
    let counts = [3; 4];
    let mut cage = Cage {
        face_vertex_counts: &counts,
        face_vertex_indices: &indices,
        vertex_count: 4,
        ..Default::default()
    };
    cage.options.scheme = Scheme::Loop;
    for level in 0..=4u32 {
        let refiner = refine(&cage, level);
        let faces = refiner.faces(None).unwrap();
        assert!(faces.counts.iter().all(|&n| n == 3));
        let mesh = tessellate(&refiner, &points, None).unwrap();
        assert_eq!(mesh.triangles.len(), 4 * 4usize.pow(level));
        assert_unit_normals(&mesh);
        for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
            assert!(dot(f64x3(*p), f64x3(*n)) > 0.0, "normal points inward");
        }
    }
}

#[test]
fn bilinear_quad_stays_on_its_plane() {
    // A tilted, non-square quad in the plane x + 2y + 3z = 1.
    let plane = |x: f32, y: f32| [x, y, (1.0 - x - 2.0 * y) / 3.0];
    let points = [plane(0.0, 0.0), plane(2.0, 0.0), plane(2.5, 1.0), plane(-0.5, 1.5)];
    let mut cage = Cage {
        face_vertex_counts: &[4],
        face_vertex_indices: &[0, 1, 2, 3],
        vertex_count: 4,
        ..Default::default()
    };
    cage.options.scheme = Scheme::Bilinear;
    let expected_normal = [1.0, 2.0, 3.0].map(|x: f64| x / 14f64.sqrt());
    for level in 0..=4u32 {
        let mesh = tessellate(&refine(&cage, level), &points, None).unwrap();
        assert_eq!(mesh.triangles.len(), 2 * 4usize.pow(level));
        assert_eq!(mesh.positions.len(), ((1 << level) + 1) * ((1 << level) + 1));
        for p in &mesh.positions {
            assert!((p[0] + 2.0 * p[1] + 3.0 * p[2] - 1.0).abs() < 1e-5, "{p:?}");
        }
        for n in &mesh.normals {
            assert!(dist(f64x3(*n), expected_normal) < 1e-5, "{n:?}");
        }
    }
}

#[test]
fn level_zero_ngon_is_fanned_by_bilinear_and_refined_once_by_catmull_clark() {
    let points = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [1.5, 1.0, 0.0], [0.5, 1.5, 0.0], [-0.5, 1.0, 0.0]];
    let mut cage = Cage {
        face_vertex_counts: &[5],
        face_vertex_indices: &[0, 1, 2, 3, 4],
        vertex_count: 5,
        ..Default::default()
    };
    cage.options.scheme = Scheme::Bilinear;
    let mesh = tessellate(&refine(&cage, 0), &points, None).unwrap();
    assert_eq!(mesh.triangles.len(), 3);

    cage.options.scheme = Scheme::CatmullClark;
    let refiner = refine(&cage, 0);
    assert_eq!(refiner.level(), 1);
    let mesh = tessellate(&refiner, &points, None).unwrap();
    assert_eq!(mesh.triangles.len(), 2 * 5);
    assert_unit_normals(&mesh);
}

#[test]
fn vertex_primvars_refine_and_gather() {
    // A colour equal to the position refines exactly like the position.
    let refiner = refine(&cube(), 2);
    let mesh = tessellate(&refiner, &CUBE_POINTS, None).unwrap();
    let colour = refiner.vertex_primvar(CUBE_POINTS.as_flattened(), 3, Evaluation::Limit).unwrap();
    let gathered: Vec<[f32; 3]> = mesh.gather(&colour).unwrap();
    for (c, p) in gathered.iter().zip(&mesh.positions) {
        assert!(dist(f64x3(*c), f64x3(*p)) < 1e-6);
    }
    // Width 1 works too; a wrong length is an error.
    let scalar: Vec<f32> = (0..8).map(|i| i as f32).collect();
    assert_eq!(refiner.vertex_primvar(&scalar, 1, Evaluation::Refined).unwrap().len(), 98);
    assert!(refiner.vertex_primvar(&scalar[..7], 1, Evaluation::Refined).is_err());
    assert!(tessellate(&refiner, &CUBE_POINTS[..7], None).is_err());
}

#[test]
fn bad_topology_is_an_error_not_a_crash() {
    let bad = |cage: Cage<'_>| Topology::new(&cage).unwrap_err();
    assert!(matches!(
        bad(Cage {
            face_vertex_indices: &[0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 8],
            ..cube()
        }),
        Error::IndexOutOfRange { attribute: "faceVertexIndices", at: 23, index: 8, bound: 8 }
    ));
    assert!(matches!(
        bad(Cage {
            face_vertex_indices: &[0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, -1],
            ..cube()
        }),
        Error::IndexOutOfRange { index: -1, .. }
    ));
    assert!(matches!(
        bad(Cage { face_vertex_counts: &[4, 2], face_vertex_indices: &[0, 1, 2, 3, 0, 1], ..cube() }),
        Error::DegenerateFace { face: 1, count: 2 }
    ));
    assert_eq!(bad(Cage { face_vertex_counts: &[], face_vertex_indices: &[], ..cube() }), Error::NoFaces);
    assert!(matches!(
        bad(Cage { face_vertex_counts: &[4; 5], ..cube() }),
        Error::CountMismatch { sum: 20, len: 24 }
    ));
    assert!(matches!(
        bad(Cage { crease_indices: &[0, 6], crease_lengths: &[2], crease_sharpnesses: &[1.0], ..cube() }),
        Error::Invalid { attribute: "creaseIndices", .. }
    ));
    assert!(matches!(
        bad(Cage {
            crease_indices: &[0, 1],
            crease_lengths: &[2],
            crease_sharpnesses: &[1.0, 2.0, 3.0],
            ..cube()
        }),
        Error::Invalid { attribute: "creaseSharpnesses", .. }
    ));
    assert!(matches!(
        bad(Cage { hole_indices: &[6], ..cube() }),
        Error::IndexOutOfRange { attribute: "holeIndices", .. }
    ));
    assert!(matches!(
        bad(Cage { corner_indices: &[1], corner_sharpnesses: &[], ..cube() }),
        Error::Invalid { attribute: "cornerSharpnesses", .. }
    ));
    let mut loop_quads = cube();
    loop_quads.options.scheme = Scheme::Loop;
    assert!(matches!(bad(loop_quads), Error::Invalid { attribute: "faceVertexCounts", .. }));
    assert!(matches!(Refiner::new(&Topology::new(&cube()).unwrap(), 11), Err(Error::LevelTooHigh { .. })));
}

/// Three triangles sharing edge 0–1, and a face repeating a vertex, under every scheme: OpenSubdiv
/// may accept or reject them; either way the process survives and any mesh `refine` returns is
/// finite. Shared by the uniform and the adaptive refiner tests.
pub(crate) fn check_degenerate_cages(refine: impl Fn(&Cage, &[[f32; 3]]) -> Result<Tessellation>) {
    let points = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 1.0, 0.0], [0.5, -1.0, 0.0], [0.5, 0.0, 1.0]];
    let cases: [(&[i32], &[i32]); 2] =
        [(&[3, 3, 3], &[0, 1, 2, 1, 0, 3, 0, 1, 4]), (&[4, 3], &[0, 1, 1, 2, 0, 2, 3])];
    for (counts, indices) in cases {
        for scheme in [Scheme::CatmullClark, Scheme::Loop, Scheme::Bilinear] {
            let mut cage = Cage {
                face_vertex_counts: counts,
                face_vertex_indices: indices,
                vertex_count: 5,
                ..Default::default()
            };
            cage.options.scheme = scheme;
            let result = refine(&cage, &points);
            eprintln!(
                "{counts:?} {scheme:?}: {}",
                match &result {
                    Ok(m) => format!("ok, {} triangles", m.triangles.len()),
                    Err(e) => format!("error: {e}"),
                }
            );
            if let Ok(mesh) = result {
                assert!(mesh.positions.iter().flatten().all(|x| x.is_finite()));
                assert!(mesh.normals.iter().flatten().all(|x| x.is_finite()));
            }
        }
    }
}

#[test]
fn non_manifold_and_degenerate_faces_do_not_crash() {
    check_degenerate_cages(|cage, points| {
        Topology::new(cage).and_then(|t| Refiner::new(&t, 2)).and_then(|r| tessellate(&r, points, None))
    });
}

#[test]
fn usd_tokens_parse() {
    assert_eq!("catmullClark".parse::<Scheme>(), Ok(Scheme::CatmullClark));
    assert_eq!("edgeOnly".parse::<BoundaryInterpolation>(), Ok(BoundaryInterpolation::EdgeOnly));
    assert_eq!(
        "cornersPlus2".parse::<FaceVaryingInterpolation>(),
        Ok(FaceVaryingInterpolation::CornersPlus2)
    );
    assert_eq!("smooth".parse::<TriangleSubdivision>(), Ok(TriangleSubdivision::Smooth));
    assert!("none".parse::<Scheme>().is_err());
    assert_eq!(Options::default().face_varying, FaceVaryingInterpolation::CornersPlus1);
    assert_eq!(Options::default().boundary, BoundaryInterpolation::EdgeAndCorner);
}

#[test]
fn dicing_rate_levels() {
    assert_eq!(level_for_dicing_rate(100.0, 1.0, 10), 7); // log2 100 = 6.64
    assert_eq!(level_for_dicing_rate(4.0, 1.0, 10), 2);
    assert_eq!(level_for_dicing_rate(4.001, 1.0, 10), 3);
    assert_eq!(level_for_dicing_rate(1.0, 1.0, 10), 0);
    assert_eq!(level_for_dicing_rate(0.25, 1.0, 10), 0);
    assert_eq!(level_for_dicing_rate(1e6, 1.0, 6), 6);
    assert_eq!(level_for_dicing_rate(f32::NAN, 1.0, 6), 0);
    assert_eq!(level_for_dicing_rate(10.0, 0.0, 6), 6);
    let edge = Topology::new(&cube()).unwrap().longest_edge(&CUBE_POINTS).unwrap();
    assert_eq!(edge, 2.0);
}

#[test]
fn refiner_is_send_and_sync() {
    fn check<T: Send + Sync>() {}
    check::<Refiner>();
}
