//! UsdGeom implicit surfaces: Cube, Sphere, Cylinder, Cone, Capsule and Plane, tessellated into
//! triangle meshes in the prim's local space.
//!
//! Once tessellated, a shape is a [`LocalMesh`] and goes through the same path as a polygon Mesh
//! prim ([`Reader::push_mesh`]): the walk's transform, visibility and purpose, instancing and
//! geometry sharing, material binding via [`Reader::gprim_material`] (with the displayColor /
//! displayOpacity fallback material). Shapes have no authored topology, so only constant primvars
//! apply (the first value of each primvar a bound material reads).
//!
//! # Tessellation rule
//!
//! A fixed count, the same for every shape and camera: [`SEGMENTS`] = 32 segments around the
//! spine, [`RINGS`] = 16 rings from pole to pole of a sphere (8 per capsule hemisphere). Camera
//! driven dicing (as for subdivision surfaces) would need the shapes queued until the camera is
//! known; at 32 × 16 a sphere's area is within 0.8 % of 4πr² and its silhouette within 0.5 % of
//! its radius, which is what the conformance listings compare, and the Sphere and Cube (the
//! shapes drawn before this module) keep their tessellations, so their images stay byte for byte. Triangle counts:
//!
//! | shape    | triangles                              | count |
//! |----------|----------------------------------------|-------|
//! | Cube     | 6 faces × 2                            | 12    |
//! | Sphere   | 2·S·R − 2·S (poles are fans)           | 960   |
//! | Cylinder | side 2·S, caps 2 × S (centre fans)     | 128   |
//! | Cone     | side S (one apex vertex per segment), base S | 64 |
//! | Capsule  | 2·S·R − 2·S hemispheres, 2·S band      | 1024  |
//! | Plane    | 2                                      | 2     |
//!
//! Every triangle winds counter-clockwise seen from outside (the Plane: seen from +axis), which
//! the renderer's front-face and glass code relies on. Normals are smooth where the surface is
//! (sphere, capsule, cylinder and cone sides; the cone apex has one vertex per segment carrying
//! that segment's mid normal) and split at creases (cube edges, cylinder and cone cap rims).
//!
//! Shapes with a spine (`axis`) are built along Z and rotated onto X or Y by a cyclic axis
//! permutation, which has determinant +1 and so keeps the winding. The Sphere keeps the Y-up
//! parametrisation it always had (it is symmetric; only its UVs depend on it).
//!
//! Schema fallbacks (checked against usd-core 26.11 and the UsdGeom schema docs): Cube size 2; Sphere radius 1; Cylinder and
//! Cone radius 1, height 2, axis Z; Capsule radius 0.5, height 1 (the spine between the two
//! hemispheres), axis Z; Plane width 2, length 2, axis Z, and — unlike every other gprim —
//! `doubleSided` true. A size, radius, height, width or length that is negative, NaN or infinite,
//! or an `axis` other than X, Y, Z, skips the prim with a warning naming the attribute.

use std::f64::consts::{PI, TAU};

use glam::{DVec3, Vec2};

use super::mesh::LocalMesh;
use super::{fallback, Inherited, Reader, UsdError};
use crate::scene::{MeshPrimvar, PrimvarLayout};

/// Segments around the spine of every round shape.
pub(super) const SEGMENTS: usize = 32;
/// Rings from pole to pole of a sphere; a capsule's hemispheres get half each.
pub(super) const RINGS: usize = 16;

/// The prim types this module reads.
pub(super) const TYPES: &[&str] = &["Cube", "Sphere", "Cylinder", "Cone", "Capsule", "Plane"];

/// A shape's spine, as its `axis` token.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    /// Maps a point built with its spine along Z onto this axis (a cyclic permutation: no mirror).
    fn place(self, p: DVec3) -> DVec3 {
        match self {
            Axis::Z => p,
            Axis::X => DVec3::new(p.z, p.x, p.y),
            Axis::Y => DVec3::new(p.y, p.z, p.x),
        }
    }
}

impl Reader<'_> {
    /// Tessellates an implicit shape (one of [`TYPES`]) and adds it as a mesh.
    pub(super) fn read_shape(&mut self, path: &str, ty: &str, state: &Inherited) -> Result<(), UsdError> {
        let Some(mut out) = self.tessellate(path, ty)? else { return Ok(()) };
        let material = self.gprim_material(path)?;
        out.triangle_materials = vec![material; out.triangles.len()];
        // Whatever the primvar's interpolation, a shape has one value of it: there is no
        // authored topology to index.
        out.primvars = self
            .program_primvars(path, &[material], None)?
            .into_iter()
            .map(|p| MeshPrimvar {
                values: vec![p.primvar.get(0, 0, 0)],
                layout: PrimvarLayout::Constant,
                ..p.empty()
            })
            .collect();
        let double_sided_fallback =
            if ty == "Plane" { fallback::PLANE_DOUBLE_SIDED } else { fallback::DOUBLE_SIDED };
        out.double_sided = self.bool(path, "doubleSided")?.unwrap_or(double_sided_fallback);
        self.push_mesh(path, out, state);
        Ok(())
    }

    /// The shape's local mesh, or `None` (with a warning) when an attribute is out of its domain.
    fn tessellate(&mut self, path: &str, ty: &str) -> Result<Option<LocalMesh>, UsdError> {
        let Some(shape) = self.shape_parameters(path, ty)? else { return Ok(None) };
        Ok(Some(match shape {
            Shape::Cube { size } => cube(size),
            Shape::Sphere { radius } => sphere(radius, SEGMENTS, RINGS),
            Shape::Cylinder { radius, height, axis } => cylinder(radius, height, axis),
            Shape::Cone { radius, height, axis } => cone(radius, height, axis),
            Shape::Capsule { radius, height, axis } => capsule(radius, height, axis),
            Shape::Plane { width, length, axis } => plane(width, length, axis),
        }))
    }

    fn shape_parameters(&mut self, path: &str, ty: &str) -> Result<Option<Shape>, UsdError> {
        use fallback::*;
        let shape = match ty {
            "Cube" => Shape::Cube { size: self.extent_attr(path, ty, "size", CUBE_SIZE)? },
            "Sphere" => Shape::Sphere { radius: self.extent_attr(path, ty, "radius", SPHERE_SHAPE_RADIUS)? },
            "Cylinder" => Shape::Cylinder {
                radius: self.extent_attr(path, ty, "radius", CYLINDER_RADIUS)?,
                height: self.extent_attr(path, ty, "height", CYLINDER_HEIGHT)?,
                axis: self.axis(path, ty)?,
            },
            "Cone" => Shape::Cone {
                radius: self.extent_attr(path, ty, "radius", CONE_RADIUS)?,
                height: self.extent_attr(path, ty, "height", CONE_HEIGHT)?,
                axis: self.axis(path, ty)?,
            },
            "Capsule" => Shape::Capsule {
                radius: self.extent_attr(path, ty, "radius", CAPSULE_RADIUS)?,
                height: self.extent_attr(path, ty, "height", CAPSULE_HEIGHT)?,
                axis: self.axis(path, ty)?,
            },
            _ => Shape::Plane {
                width: self.extent_attr(path, ty, "width", PLANE_WIDTH)?,
                length: self.extent_attr(path, ty, "length", PLANE_LENGTH)?,
                axis: self.axis(path, ty)?,
            },
        };
        Ok(shape.valid().then_some(shape))
    }

    /// A size-like attribute: its value or `fallback`; NaN (with a warning) when it is negative
    /// or not finite, which [`Shape::valid`] then refuses.
    fn extent_attr(&mut self, path: &str, ty: &str, attr: &str, fallback: f64) -> Result<f64, UsdError> {
        let value = self.f64(path, attr)?.unwrap_or(fallback);
        if value.is_finite() && value >= 0.0 {
            return Ok(value);
        }
        self.warn(path, format!("{attr} {value} is negative or not finite; {ty} skipped"));
        Ok(f64::NAN)
    }

    /// The `axis` token; `None` (with a warning) for anything but X, Y, Z.
    fn axis(&mut self, path: &str, ty: &str) -> Result<Option<Axis>, UsdError> {
        let token = self.token(path, "axis")?;
        Ok(match token.as_deref().unwrap_or(fallback::SHAPE_AXIS) {
            "X" => Some(Axis::X),
            "Y" => Some(Axis::Y),
            "Z" => Some(Axis::Z),
            other => {
                self.warn(path, format!("axis \"{other}\" is not X, Y or Z; {ty} skipped"));
                None
            }
        })
    }
}

/// A shape's parameters as read (NaN or a missing axis marks a refused attribute).
enum Shape {
    Cube { size: f64 },
    Sphere { radius: f64 },
    Cylinder { radius: f64, height: f64, axis: Option<Axis> },
    Cone { radius: f64, height: f64, axis: Option<Axis> },
    Capsule { radius: f64, height: f64, axis: Option<Axis> },
    Plane { width: f64, length: f64, axis: Option<Axis> },
}

impl Shape {
    /// Whether every parameter was accepted (the refusals have been warned about).
    fn valid(&self) -> bool {
        let (a, b, axis) = match *self {
            Shape::Cube { size } => (size, 0.0, Some(Axis::Z)),
            Shape::Sphere { radius } => (radius, 0.0, Some(Axis::Z)),
            Shape::Cylinder { radius, height, axis }
            | Shape::Cone { radius, height, axis }
            | Shape::Capsule { radius, height, axis } => (radius, height, axis),
            Shape::Plane { width, length, axis } => (width, length, axis),
        };
        !a.is_nan() && !b.is_nan() && axis.is_some()
    }
}

/// Unwraps an axis [`Shape::valid`] has checked.
fn spine(axis: Option<Axis>) -> Axis {
    axis.unwrap_or(Axis::Z)
}

/// One ring of a surface of revolution about Z: height, radius, and the outward normal's radial
/// and axial parts; `v` is the ring's texture coordinate.
#[derive(Clone, Copy)]
struct Ring {
    z: f64,
    radius: f64,
    normal_radial: f64,
    normal_z: f64,
    v: f32,
}

/// Appends the surface of revolution through `rings` (listed from +Z down to −Z) to `m`, with
/// smooth normals: [`SEGMENTS`] quads per band, each two triangles except where a ring of radius
/// zero (a pole or apex) makes one of them degenerate.
fn revolve(m: &mut LocalMesh, rings: &[Ring]) {
    let row = SEGMENTS as u32 + 1;
    let first = m.positions.len() as u32;
    for ring in rings {
        for s in 0..=SEGMENTS {
            let phi = TAU * s as f64 / SEGMENTS as f64;
            // A pole's vertices sit at the centre of their segment so the apex normal is the
            // segment's own, not the seam's.
            let phi_n = if ring.radius == 0.0 { TAU * (s as f64 + 0.5) / SEGMENTS as f64 } else { phi };
            m.positions.push(DVec3::new(ring.radius * phi.cos(), ring.radius * phi.sin(), ring.z));
            let n =
                DVec3::new(ring.normal_radial * phi_n.cos(), ring.normal_radial * phi_n.sin(), ring.normal_z);
            m.normals.push(n.try_normalize().unwrap_or(DVec3::Z));
            m.uvs.push(Vec2::new(s as f32 / SEGMENTS as f32, ring.v));
        }
    }
    for (r, pair) in rings.windows(2).enumerate() {
        let (upper, lower) = (first + r as u32 * row, first + (r as u32 + 1) * row);
        for s in 0..SEGMENTS as u32 {
            // Seen from outside, φ runs to the right and the band's upper ring is above: both
            // triangles below wind counter-clockwise.
            if pair[1].radius != 0.0 {
                m.triangles.push([lower + s, lower + s + 1, upper + s]);
            }
            if pair[0].radius != 0.0 {
                m.triangles.push([lower + s + 1, upper + s + 1, upper + s]);
            }
        }
    }
}

/// Appends a flat disc of `radius` at height `z` facing `sign` (±1) along Z: a fan of
/// [`SEGMENTS`] triangles around a centre vertex, with its own (split) normals.
fn disc(m: &mut LocalMesh, radius: f64, z: f64, sign: f64) {
    let centre = m.positions.len() as u32;
    let normal = DVec3::new(0.0, 0.0, sign);
    m.positions.push(DVec3::new(0.0, 0.0, z));
    m.normals.push(normal);
    m.uvs.push(Vec2::splat(0.5));
    for s in 0..=SEGMENTS {
        let phi = TAU * s as f64 / SEGMENTS as f64;
        m.positions.push(DVec3::new(radius * phi.cos(), radius * phi.sin(), z));
        m.normals.push(normal);
        m.uvs.push(Vec2::new(0.5 + 0.5 * phi.cos() as f32, 0.5 + 0.5 * (sign * phi.sin()) as f32));
    }
    for s in 0..SEGMENTS as u32 {
        let (a, b) = (centre + 1 + s, centre + 2 + s);
        // φ increases counter-clockwise seen from +Z.
        m.triangles.push(if sign > 0.0 { [centre, a, b] } else { [centre, b, a] });
    }
}

/// Moves a mesh built along Z onto `axis`.
fn placed(mut m: LocalMesh, axis: Axis) -> LocalMesh {
    for p in m.positions.iter_mut().chain(m.normals.iter_mut()) {
        *p = axis.place(*p);
    }
    m
}

fn cylinder(radius: f64, height: f64, axis: Option<Axis>) -> LocalMesh {
    let h = height * 0.5;
    let mut m = LocalMesh::default();
    let side = |z: f64, v: f32| Ring { z, radius, normal_radial: 1.0, normal_z: 0.0, v };
    revolve(&mut m, &[side(h, 1.0), side(-h, 0.0)]);
    disc(&mut m, radius, h, 1.0);
    disc(&mut m, radius, -h, -1.0);
    placed(m, spine(axis))
}

/// The apex at +height/2 on the spine, the base at −height/2 (UsdGeomCone).
fn cone(radius: f64, height: f64, axis: Option<Axis>) -> LocalMesh {
    let h = height * 0.5;
    let mut m = LocalMesh::default();
    // The slant's outward normal is (height, radius) in (radial, axial).
    let ring = |z: f64, r: f64, v: f32| Ring { z, radius: r, normal_radial: height, normal_z: radius, v };
    revolve(&mut m, &[ring(h, 0.0, 1.0), ring(-h, radius, 0.0)]);
    disc(&mut m, radius, -h, -1.0);
    placed(m, spine(axis))
}

/// Two hemispheres of `radius` joined by a cylinder of `height` (the spine between their
/// centres, UsdGeomCapsule), all smooth.
fn capsule(radius: f64, height: f64, axis: Option<Axis>) -> LocalMesh {
    let h = height * 0.5;
    let total = (2.0 * radius + height).max(f64::MIN_POSITIVE);
    let ring = |k: usize, centre: f64| {
        let theta = PI * k as f64 / RINGS as f64;
        let (sin, cos) = theta.sin_cos();
        // A pole exactly at radius zero, so `revolve` fans it.
        let r = if k == 0 || k == RINGS { 0.0 } else { radius * sin };
        let z = centre + radius * cos;
        Ring { z, radius: r, normal_radial: sin, normal_z: cos, v: ((z + h + radius) / total) as f32 }
    };
    let rings: Vec<Ring> =
        (0..=RINGS / 2).map(|k| ring(k, h)).chain((RINGS / 2..=RINGS).map(|k| ring(k, -h))).collect();
    let mut m = LocalMesh::default();
    revolve(&mut m, &rings);
    placed(m, spine(axis))
}

/// A rectangle through the origin facing +`axis`: `width` along X (along Z for axis X), `length`
/// along Y (along Z for axis Y), per the UsdGeomPlane table.
fn plane(width: f64, length: f64, axis: Option<Axis>) -> LocalMesh {
    let axis = spine(axis);
    // In the Z-built frame (a, b, spine) that [`Axis::place`] maps: axis Z puts a on X and b on
    // Y; axis X puts a on Y and b on Z; axis Y puts a on Z and b on X.
    let (a, b) = match axis {
        Axis::Z => (width, length),
        Axis::X | Axis::Y => (length, width),
    };
    let mut m = LocalMesh::default();
    for (i, j) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        m.positions.push(DVec3::new(0.5 * a * i, 0.5 * b * j, 0.0));
        m.normals.push(DVec3::Z);
        m.uvs.push(Vec2::new((i as f32 + 1.0) * 0.5, (j as f32 + 1.0) * 0.5));
    }
    m.triangles = vec![[0, 1, 2], [0, 2, 3]];
    placed(m, axis)
}

/// A UV sphere of `radius` with per-vertex normals, `segments` around and `rings` from pole to pole.
fn sphere(radius: f64, segments: usize, rings: usize) -> LocalMesh {
    let mut m = LocalMesh::default();
    for r in 0..=rings {
        let theta = PI * r as f64 / rings as f64;
        for s in 0..=segments {
            let phi = TAU * s as f64 / segments as f64;
            // Y up (the sphere is symmetric; this was its first parametrisation and its images
            // depend on it).
            let n = DVec3::new(theta.sin() * phi.cos(), theta.cos(), -theta.sin() * phi.sin());
            m.positions.push(n * radius);
            m.normals.push(n);
            m.uvs.push(Vec2::new(s as f32 / segments as f32, 1.0 - r as f32 / rings as f32));
        }
    }
    let row = segments as u32 + 1;
    for r in 0..rings as u32 {
        for s in 0..segments as u32 {
            let (a, b) = (r * row + s, (r + 1) * row + s);
            if r != 0 {
                m.triangles.push([a, b, a + 1]);
            }
            if r + 1 != rings as u32 {
                m.triangles.push([a + 1, b, b + 1]);
            }
        }
    }
    m
}

/// An axis-aligned cube of edge `size` centred at the origin, flat-shaded.
fn cube(size: f64) -> LocalMesh {
    let mut m = LocalMesh::default();
    let h = size * 0.5;
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let mut n = DVec3::ZERO;
            n[axis] = sign;
            // t × b = n, so the quad below winds counter-clockwise seen from outside.
            let t = DVec3::AXES[(axis + 1) % 3];
            let b = n.cross(t);
            let base = m.positions.len() as u32;
            for (i, j) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                m.positions.push((n + t * i + b * j) * h);
                m.normals.push(n);
            }
            m.triangles.push([base, base + 1, base + 2]);
            m.triangles.push([base, base + 2, base + 3]);
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bounds(m: &LocalMesh) -> (DVec3, DVec3) {
        let lo = m.positions.iter().fold(DVec3::INFINITY, |a, &p| a.min(p));
        let hi = m.positions.iter().fold(DVec3::NEG_INFINITY, |a, &p| a.max(p));
        (lo, hi)
    }

    fn area(m: &LocalMesh) -> f64 {
        m.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }

    /// Every triangle faces away from `centre` and agrees with its vertex normals, which are unit.
    fn assert_outward(m: &LocalMesh, centre: DVec3) {
        assert_eq!(m.normals.len(), m.positions.len());
        assert_eq!(m.uvs.len(), m.positions.len());
        assert!(m.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-12));
        for &t in &m.triangles {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            let face = (b - a).cross(c - a);
            assert!(face.length() > 0.0, "degenerate triangle {t:?}");
            assert!(face.dot((a + b + c) / 3.0 - centre) > 0.0, "triangle {t:?} faces inwards");
            let shading: DVec3 = t.map(|i| m.normals[i as usize]).iter().sum();
            assert!(face.dot(shading) > 0.0, "triangle {t:?} winds against its normals");
        }
    }

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).abs().max_element() < 1e-12
    }

    #[test]
    fn triangle_counts_follow_the_rule() {
        let (s, r) = (SEGMENTS, RINGS);
        assert_eq!(cube(2.0).triangles.len(), 12);
        assert_eq!(sphere(1.0, s, r).triangles.len(), 2 * s * r - 2 * s);
        assert_eq!(sphere(1.0, s, r).triangles.len(), 960);
        assert_eq!(cylinder(1.0, 2.0, Some(Axis::Z)).triangles.len(), 128);
        assert_eq!(cone(1.0, 2.0, Some(Axis::Z)).triangles.len(), 64);
        assert_eq!(capsule(0.5, 1.0, Some(Axis::Z)).triangles.len(), 1024);
        assert_eq!(plane(2.0, 2.0, Some(Axis::Z)).triangles.len(), 2);
    }

    #[test]
    fn bounds_are_the_analytic_extents() {
        let (lo, hi) = bounds(&sphere(2.0, SEGMENTS, RINGS));
        // The poles and the equator's ring vertices on ±X, ±Z lie on the sphere exactly.
        assert!(close(lo, DVec3::splat(-2.0)) && close(hi, DVec3::splat(2.0)), "{lo} {hi}");

        let (lo, hi) = bounds(&cylinder(0.5, 3.0, Some(Axis::X)));
        assert!(close(lo, DVec3::new(-1.5, -0.5, -0.5)) && close(hi, DVec3::new(1.5, 0.5, 0.5)), "{lo} {hi}");
        let (lo, hi) = bounds(&cylinder(0.5, 3.0, Some(Axis::Y)));
        assert!(close(lo, DVec3::new(-0.5, -1.5, -0.5)) && close(hi, DVec3::new(0.5, 1.5, 0.5)), "{lo} {hi}");

        let (lo, hi) = bounds(&cone(1.0, 4.0, Some(Axis::Z)));
        assert!(close(lo, DVec3::new(-1.0, -1.0, -2.0)) && close(hi, DVec3::new(1.0, 1.0, 2.0)), "{lo} {hi}");
        let m = cone(1.0, 4.0, Some(Axis::Z));
        assert!(
            m.positions.iter().filter(|p| p.z == 2.0).all(|p| p.x == 0.0 && p.y == 0.0),
            "apex on the spine"
        );

        let (lo, hi) = bounds(&capsule(0.5, 1.0, Some(Axis::Y)));
        assert!(close(lo, DVec3::new(-0.5, -1.0, -0.5)) && close(hi, DVec3::new(0.5, 1.0, 0.5)), "{lo} {hi}");

        let (lo, hi) = bounds(&cube(3.0));
        assert!(close(lo, DVec3::splat(-1.5)) && close(hi, DVec3::splat(1.5)));

        // UsdGeomPlane: width on X (Z for axis X), length on Y (Z for axis Y).
        for (axis, extent) in [
            (Axis::Z, DVec3::new(1.0, 2.0, 0.0)),
            (Axis::X, DVec3::new(0.0, 2.0, 1.0)),
            (Axis::Y, DVec3::new(1.0, 0.0, 2.0)),
        ] {
            let (lo, hi) = bounds(&plane(2.0, 4.0, Some(axis)));
            assert!(close(lo, -extent) && close(hi, extent), "{axis:?}: {lo} {hi}");
        }
    }

    #[test]
    fn areas_match_the_analytic_surfaces() {
        let r = 2.0;
        let sphere_area = area(&sphere(r, SEGMENTS, RINGS));
        let exact = 4.0 * PI * r * r;
        assert!((sphere_area / exact - 1.0).abs() < 0.01, "sphere {sphere_area} vs {exact}");
        // An inscribed 32-gon has area ratio sin(2π/32)·32/(2π) = 0.99359 of its circle.
        let polygon = (TAU / SEGMENTS as f64).sin() * SEGMENTS as f64 / TAU;
        let (radius, height) = (0.5, 3.0);
        let cylinder_area = area(&cylinder(radius, height, Some(Axis::Z)));
        let exact = TAU * radius * height + 2.0 * PI * radius * radius;
        assert!((cylinder_area / exact - 1.0).abs() < 0.01, "cylinder {cylinder_area} vs {exact}");
        let cap = area(&{
            let mut m = LocalMesh::default();
            disc(&mut m, radius, 0.0, 1.0);
            m
        });
        assert!((cap - polygon * PI * radius * radius).abs() < 1e-12);
        let capsule_area = area(&capsule(radius, height, Some(Axis::Z)));
        let exact = 4.0 * PI * radius * radius + TAU * radius * height;
        assert!((capsule_area / exact - 1.0).abs() < 0.01, "capsule {capsule_area} vs {exact}");
        let cone_area = area(&cone(1.0, 2.0, Some(Axis::Z)));
        let exact = PI * 1.0 * (1.0f64 + 4.0).sqrt() + PI;
        assert!((cone_area / exact - 1.0).abs() < 0.01, "cone {cone_area} vs {exact}");
        assert!((area(&plane(2.0, 3.0, Some(Axis::X))) - 6.0).abs() < 1e-12);
    }

    #[test]
    fn convex_shapes_wind_outwards() {
        assert_outward(&sphere(1.5, SEGMENTS, RINGS), DVec3::ZERO);
        for axis in [Axis::X, Axis::Y, Axis::Z] {
            assert_outward(&cylinder(1.0, 2.0, Some(axis)), DVec3::ZERO);
            assert_outward(&capsule(0.5, 1.0, Some(axis)), DVec3::ZERO);
            assert_outward(&cone(1.0, 2.0, Some(axis)), DVec3::ZERO);
        }
        let m = cube(2.0);
        for t in &m.triangles {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            assert!((b - a).cross(c - a).dot((a + b + c) / 3.0) > 0.0);
        }
        for (axis, up) in [(Axis::X, DVec3::X), (Axis::Y, DVec3::Y), (Axis::Z, DVec3::Z)] {
            let m = plane(2.0, 2.0, Some(axis));
            for t in &m.triangles {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                assert!((b - a).cross(c - a).dot(up) > 0.0, "plane {axis:?} faces +axis");
            }
            assert!(m.normals.iter().all(|&n| n == up));
        }
    }

    #[test]
    fn normals_are_smooth_on_sides_and_split_at_rims() {
        let m = cylinder(1.0, 2.0, Some(Axis::Z));
        // Each rim point appears twice: once on the side (radial normal), once on the cap (±Z).
        let rim = DVec3::new(1.0, 0.0, 1.0);
        let normals: Vec<DVec3> =
            m.positions.iter().zip(&m.normals).filter(|(p, _)| close(**p, rim)).map(|(_, n)| *n).collect();
        assert!(normals.iter().any(|n| close(*n, DVec3::X)) && normals.iter().any(|n| close(*n, DVec3::Z)));
        // The capsule's band and hemispheres share normals where they meet: the surface is C1.
        let m = capsule(0.5, 1.0, Some(Axis::Z));
        for (p, n) in m.positions.iter().zip(&m.normals) {
            let centre = DVec3::new(0.0, 0.0, p.z.clamp(-0.5, 0.5));
            assert!(close(*n, (*p - centre).normalize()), "capsule normal {n} at {p}");
        }
        // The cone's slant normal leans towards the apex by atan(r / h); its base rim splits
        // between the slant and the base cap.
        let m = cone(1.0, 2.0, Some(Axis::Z));
        let rim = DVec3::new(1.0, 0.0, -1.0);
        let normals: Vec<DVec3> =
            m.positions.iter().zip(&m.normals).filter(|(p, _)| close(**p, rim)).map(|(_, n)| *n).collect();
        let slant = DVec3::new(2.0, 0.0, 1.0) / 5.0f64.sqrt();
        assert!(normals.iter().any(|n| close(*n, slant)), "{normals:?}");
        assert!(normals.iter().any(|n| close(*n, -DVec3::Z)), "{normals:?}");
    }
}
