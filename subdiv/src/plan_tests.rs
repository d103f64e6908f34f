//! Planned triangle counts against the tessellators' output, face by face, on cages that exercise
//! every rule that changes a count: holes, `interpolateBoundary = none` (smooth and bilinear),
//! n-gons at level 0 and above, loop triangles, creases, face-varying seams, uneven edge rates.

use crate::tests::{creased_edge_cube, cube, cube_with_uv_seams, CUBE_POINTS};
use crate::*;

/// A cage with owned arrays, borrowed as a [`Cage`] on demand.
struct Owned {
    name: &'static str,
    points: Vec<[f32; 3]>,
    counts: Vec<i32>,
    indices: Vec<i32>,
    holes: Vec<i32>,
    options: Options,
    uv: Option<(Vec<i32>, usize)>,
}

impl Owned {
    fn topology(&self, base: Cage<'_>) -> Topology {
        let channels: Vec<FaceVaryingChannel<'_>> = self
            .uv
            .iter()
            .map(|(indices, value_count)| FaceVaryingChannel { indices, value_count: *value_count })
            .collect();
        Topology::new(&Cage {
            face_vertex_counts: &self.counts,
            face_vertex_indices: &self.indices,
            vertex_count: self.points.len(),
            options: self.options,
            hole_indices: &self.holes,
            face_varying: &channels,
            ..base
        })
        .unwrap()
    }
}

/// An `nx` × `ny` grid of quads in the plane z = 0 (x fastest).
fn grid(nx: i32, ny: i32) -> (Vec<[f32; 3]>, Vec<i32>, Vec<i32>) {
    let points =
        (0..(nx + 1) * (ny + 1)).map(|i| [(i % (nx + 1)) as f32, (i / (nx + 1)) as f32, 0.0]).collect();
    let mut indices = Vec::new();
    for y in 0..ny {
        for x in 0..nx {
            let v = y * (nx + 1) + x;
            indices.extend([v, v + 1, v + nx + 2, v + nx + 1]);
        }
    }
    (points, vec![4; (nx * ny) as usize], indices)
}

/// A pentagon, a triangle and a quad around a shared vertex, with a curved lift.
fn mixed() -> (Vec<[f32; 3]>, Vec<i32>, Vec<i32>) {
    let points = vec![
        [0.0, 0.0, 0.3],
        [1.0, 0.0, 0.0],
        [1.5, 1.0, 0.0],
        [0.5, 1.5, 0.1],
        [-0.5, 1.0, 0.0],
        [0.5, -1.0, 0.2],
        [-1.0, -0.5, 0.0],
        [-1.2, 0.4, 0.1],
    ];
    (points, vec![5, 3, 4], vec![0, 1, 2, 3, 4, 0, 5, 1, 0, 4, 7, 6])
}

fn cages() -> Vec<(Owned, Cage<'static>)> {
    let mut out = Vec::new();
    let plain = |name, points: Vec<[f32; 3]>, counts, indices, options| Owned {
        name,
        points,
        counts,
        indices,
        holes: Vec::new(),
        options,
        uv: None,
    };
    let cube_owned = |name| {
        plain(name, CUBE_POINTS.to_vec(), vec![4; 6], cube().face_vertex_indices.to_vec(), Options::default())
    };
    out.push((cube_owned("cube"), cube()));
    out.push((cube_owned("creased cube"), creased_edge_cube()));
    out.push((Owned { holes: vec![2, 5], ..cube_owned("cube with holes") }, cube()));
    let (uv_indices, uv_values) = cube_with_uv_seams();
    out.push((Owned { uv: Some((uv_indices, uv_values.len())), ..cube_owned("cube with seams") }, cube()));
    for (scheme, boundary, name) in [
        (Scheme::CatmullClark, BoundaryInterpolation::None, "grid, boundary none"),
        (Scheme::Bilinear, BoundaryInterpolation::None, "bilinear grid, boundary none"),
        (Scheme::CatmullClark, BoundaryInterpolation::EdgeOnly, "grid, edge only"),
    ] {
        let (points, counts, indices) = grid(4, 3);
        let options = Options { scheme, boundary, ..Options::default() };
        out.push((
            Owned { holes: vec![6], ..plain(name, points, counts, indices, options) },
            Cage::default(),
        ));
    }
    for (scheme, boundary, name) in [
        (Scheme::CatmullClark, BoundaryInterpolation::EdgeAndCorner, "n-gons"),
        (Scheme::Bilinear, BoundaryInterpolation::EdgeAndCorner, "bilinear n-gons"),
        (Scheme::CatmullClark, BoundaryInterpolation::None, "n-gons, boundary none"),
    ] {
        let (points, counts, indices) = mixed();
        let options = Options { scheme, boundary, ..Options::default() };
        out.push((plain(name, points, counts, indices, options), Cage::default()));
    }
    let tetrahedron = vec![[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]];
    let loop_options = Options { scheme: Scheme::Loop, ..Options::default() };
    out.push((
        Owned {
            holes: vec![3],
            ..plain(
                "loop tetrahedron",
                tetrahedron,
                vec![3; 4],
                vec![0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2],
                loop_options,
            )
        },
        Cage::default(),
    ));
    out
}

/// Triangles per cage face of a tessellation.
fn histogram(coarse_face: &[u32], faces: usize) -> Vec<u64> {
    let mut out = vec![0u64; faces];
    coarse_face.iter().for_each(|&f| out[f as usize] += 1);
    out
}

#[test]
fn uniform_plan_counts_what_uniform_tessellation_makes_per_face() {
    for (owned, base) in cages() {
        let topology = owned.topology(base);
        for level in 0..=3 {
            let plan = UniformPlan::new(&topology, level).unwrap();
            let refiner = Refiner::new(&topology, level).unwrap();
            assert_eq!(plan.level, refiner.level(), "{} at {level}", owned.name);
            let mesh = tessellate(&refiner, &owned.points, None).unwrap();
            let made = histogram(&mesh.coarse_face, topology.face_count());
            assert_eq!(plan.face_triangles, made, "{} at level {level}", owned.name);
        }
    }
}

#[test]
fn adaptive_plan_counts_what_per_edge_tessellation_makes_per_face() {
    for (owned, base) in cages() {
        let topology = owned.topology(base);
        let refiner = AdaptiveRefiner::new(&topology).unwrap();
        let edges = refiner.edges().len();
        let rate_sets: [Vec<u32>; 4] = [
            vec![1; edges],
            vec![4; edges],
            (0..edges).map(|e| [1, 2, 3, 5, 8, 4, 7, 6][e % 8]).collect(),
            (0..edges).map(|e| [16, 1, 9, 2][e % 4]).collect(),
        ];
        for rates in &rate_sets {
            let planned = refiner.planned_face_triangles(rates).unwrap();
            let mesh = refiner.tessellate(&owned.points, None, rates, false).unwrap().mesh;
            let made = histogram(&mesh.coarse_face, topology.face_count());
            assert_eq!(planned, made, "{} at rates {rates:?}", owned.name);
            assert!(planned.iter().sum::<u64>() > 0 || owned.name.contains("none"), "{}", owned.name);
        }
    }
}

#[test]
fn plans_refuse_what_the_tessellators_refuse() {
    let topology = Topology::new(&cube()).unwrap();
    let refiner = AdaptiveRefiner::new(&topology).unwrap();
    assert!(refiner.planned_face_triangles(&[1; 3]).is_err(), "one rate per edge");
    assert!(refiner.planned_face_triangles(&[0; 12]).is_err(), "rates start at 1");
    let too_fine = Refiner::highest_level(&topology) + 1;
    assert!(matches!(UniformPlan::new(&topology, too_fine), Err(Error::LevelTooHigh { .. })));
}
