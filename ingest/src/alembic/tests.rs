//! Reads the archives of tests/assets/alembic (made from USD by its make_abc.py with Blender):
//! each schema's mapping, time samples, visibility and bad input.

use super::*;
use crate::dicing::SubdivOptions;
use glam::Vec3;

fn asset(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/assets/alembic").join(name)
}

fn at_level(level: u32) -> LoadOptions {
    LoadOptions {
        subdiv: SubdivOptions { forced_level: Some(level), ..SubdivOptions::default() },
        ..LoadOptions::default()
    }
}

fn bounds(points: impl Iterator<Item = Vec3>) -> (Vec3, Vec3) {
    points.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)))
}

#[test]
fn subd_goes_through_the_subdivision_path_with_its_crease() {
    for level in [1, 2, 3] {
        let scene = load(&asset("shapes.abc"), &at_level(level)).unwrap();
        let i = scene.meshes.iter().position(|m| m.path == "/World/Rig/Arm/Cage/Cage").expect("the SubD");
        assert_eq!(scene.subdivisions.len(), 1);
        assert_eq!((scene.subdivisions[0].mesh, scene.subdivisions[0].level), (i, level));
        // Six quads: 2·4^N triangles each.
        assert_eq!(scene.meshes[i].triangles.len(), 6 * 2 * 4usize.pow(level));
        assert_eq!(scene.subdivisions[0].topology.options().scheme, subdiv::Scheme::CatmullClark);
    }
    // The top face of the 2-unit cage (world y = 2 after /World/Rig's +1) is bounded by an
    // infinitely sharp crease loop, so it stays flat at the cage; the uncreased bottom shrinks
    // towards the centre (y = 0 for the cage).
    let scene = load(&asset("shapes.abc"), &at_level(4)).unwrap();
    let cage = scene.meshes.iter().find(|m| m.path == "/World/Rig/Arm/Cage/Cage").unwrap();
    let (lo, hi) = bounds(cage.positions.iter().copied());
    assert!((hi.y - 2.0).abs() < 1e-4, "creased top at {}", hi.y);
    assert!(lo.y > 0.1, "smooth bottom at {}", lo.y);
}

#[test]
fn curves_points_camera_and_visibility() {
    let scene = load(&asset("shapes.abc"), &at_level(0)).unwrap();
    // Three linear curves of 4, 3 and 5 points: 3 + 2 + 4 segments, 0.1 wide.
    let hair = scene.curves.iter().find(|c| c.path == "/World/Hair/Hair").expect("curves");
    assert_eq!((hair.curve_count, hair.segments.len()), (3, 9));
    assert!(hair.segments.iter().all(|s| (s.p[0].w - 0.05).abs() < 1e-6));
    // The first curve starts at USD (0, 0, 3) and ends at (0, 3, 3.5).
    assert!((hair.segments[0].p[0].truncate() - Vec3::new(0.0, 0.0, 3.0)).length() < 1e-5);
    assert!((hair.segments[2].p[3].truncate() - Vec3::new(0.0, 3.0, 3.5)).length() < 1e-5);
    // A clamped cubic NURBS of 5 points (Blender writes no knots; the clamped uniform vector is
    // two spans): two Bézier segments from (3, 0, 0) to (7, 0, 0).
    let arc = scene.curves.iter().find(|c| c.path == "/World/Arc/Arc").expect("NURBS curve");
    assert_eq!((arc.curve_count, arc.segments.len()), (1, 2));
    assert!((arc.segments[0].p[0].truncate() - Vec3::new(3.0, 0.0, 0.0)).length() < 1e-5);
    assert!((arc.segments[1].p[3].truncate() - Vec3::new(7.0, 0.0, 0.0)).length() < 1e-5);
    assert!(!scene.warnings.iter().any(|w| w.prim.starts_with("/World/Arc")), "{:?}", scene.warnings);
    // Five points along x at y = 3 (Blender writes the particle size 0.05 as the width).
    let dots = scene.curves.iter().find(|c| c.path == "/Dots/Dots").expect("points");
    assert_eq!(dots.spheres.len(), 5);
    for (i, s) in dots.spheres.iter().enumerate() {
        assert!((s.center - Vec3::new(i as f32 - 2.0, 3.0, 0.0)).length() < 1e-5, "{:?}", s.center);
        assert!((s.radius - 0.025).abs() < 1e-6);
    }
    // /World/Hidden has visible = 0: its particles are not drawn.
    assert!(scene.curves.iter().chain([]).all(|c| !c.path.starts_with("/World/Hidden")));
    assert!(scene.meshes.iter().all(|m| !m.path.starts_with("/World/Hidden")));
    // The camera at USD (0, 1.5, 14) looking down −Z with a 35/36 lens ratio.
    assert_eq!(scene.cameras.len(), 1);
    let cam = &scene.cameras[0];
    assert_eq!((cam.path.as_str(), scene.default_camera), ("/World/Camera/Camera", Some(0)));
    let eye = cam.world_from_camera.transform_point3(Vec3::ZERO);
    assert!((eye - Vec3::new(0.0, 1.5, 14.0)).length() < 1e-4, "{eye}");
    let forward = cam.world_from_camera.transform_vector3(-Vec3::Z);
    assert!((forward - -Vec3::Z).length() < 1e-5, "{forward}");
    assert!((cam.focal_length / cam.horizontal_aperture - 35.0 / 36.0).abs() < 1e-6);
    assert!((cam.vertical_aperture / cam.horizontal_aperture - 24.0 / 36.0).abs() < 1e-6);
    assert_eq!(cam.clipping_range, [0.1, 1000.0]);
    // Every mesh without face sets gets the default grey.
    let grey = scene.materials.iter().position(|m| m.path == "default grey").unwrap() as u32;
    let box_mesh = scene.meshes.iter().find(|m| m.path == "/World/Mover/Box/Box").unwrap();
    assert!(box_mesh.triangle_materials.iter().all(|&m| m == grey));
    assert_eq!(scene.materials[grey as usize].diffuse_color, Vec3::splat(0.18));
}

#[test]
fn frames_pick_time_samples() {
    let x_of = |frame: Option<f64>| {
        let scene = load(&asset("animated.abc"), &LoadOptions { frame, ..at_level(0) }).unwrap();
        let m = scene.meshes.iter().find(|m| m.path == "/World/Mover/Box/Box").unwrap();
        bounds(m.positions.iter().copied()).0.x
    };
    let (first, one, ten) = (x_of(None), x_of(Some(1.0)), x_of(Some(10.0)));
    // The USD authored translate (0, 0, 0) at frame 1 and (4.5, 0, 0) at frame 10.
    assert!((first - -0.5).abs() < 1e-5 && first == one, "{first} {one}");
    assert!((ten - one - 4.5).abs() < 1e-5, "moved {}", ten - one);
    // Outside the samples the ends are held; between two samples they are blended.
    assert_eq!(x_of(Some(50.0)), ten);
    let (five, six, five_and_half) = (x_of(Some(5.0)), x_of(Some(6.0)), x_of(Some(5.5)));
    assert!(one < five && five < six && six < ten);
    assert!((five_and_half - (five + six) / 2.0).abs() < 1e-5);
}

#[test]
fn every_truncation_is_an_error_naming_the_file() {
    let full = std::fs::read(asset("shapes.abc")).unwrap();
    let dir = std::env::temp_dir().join(format!("ingest-abc-truncation-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("cut.abc");
    for len in 0..full.len() {
        std::fs::write(&path, &full[..len]).unwrap();
        let e = load(&path, &at_level(0)).expect_err("a truncated archive");
        assert!(e.to_string().starts_with(&path.display().to_string()), "{e}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn corrupt_bytes_are_errors_or_readings_never_panics() {
    let full = std::fs::read(asset("shapes.abc")).unwrap();
    let dir = std::env::temp_dir().join(format!("ingest-abc-corrupt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.abc");
    let mut errors = 0;
    // Every eleventh byte set to 0xff (a huge size, count, index or NaN wherever it lands); the
    // stride keeps the run short while landing in every structure of the archive.
    for i in (0..full.len()).step_by(11) {
        let mut bytes = full.clone();
        bytes[i] = 0xff;
        std::fs::write(&path, &bytes).unwrap();
        errors += usize::from(load(&path, &at_level(0)).is_err());
    }
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(errors > 0);
}

#[test]
fn bad_topology_names_the_object() {
    // Both meshes of shapes.abc share one stored .faceIndices sample (Alembic stores identical
    // samples once); an index past the 8 points breaks the polygon mesh, whose path is named.
    let mut bytes = std::fs::read(asset("shapes.abc")).unwrap();
    let pattern: Vec<u8> = [2i32, 3, 1, 0, 4, 5, 3, 2].iter().flat_map(|i| i.to_le_bytes()).collect();
    let at = bytes.windows(pattern.len()).position(|w| w == pattern).expect("the face indices");
    bytes[at..at + 4].copy_from_slice(&99i32.to_le_bytes());
    let dir = std::env::temp_dir().join(format!("ingest-abc-topology-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.abc");
    std::fs::write(&path, &bytes).unwrap();
    let e = load(&path, &at_level(0)).expect_err("index out of range");
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(e.object.as_deref(), Some("/World/Mover/Box/Box"), "{e}");
    assert!(e.message.contains("faceVertexIndices") && e.message.contains("99"), "{e}");
}

#[test]
fn not_an_archive() {
    let e = load(&asset("make_abc.py"), &LoadOptions::default()).unwrap_err();
    assert!(
        e.to_string().contains("make_abc.py: not a readable Alembic archive: not an Ogawa archive"),
        "{e}"
    );
    let e = load(&asset("missing.abc"), &LoadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("missing.abc: cannot read"), "{e}");
}

#[test]
fn a_cycle_of_groups_is_an_error_not_a_stack_overflow() {
    // Point /World/Rig/Arm's first child (Cage) at /World/Rig's own group.
    let mut bytes = std::fs::read(asset("shapes.abc")).unwrap();
    let mut archive = Archive::open(bytes.clone()).unwrap();
    let find = |archive: &mut Archive, parent: &archive::Object, name: &str| {
        let i = parent.children.iter().position(|c| c.name == name).unwrap();
        archive.child(parent, i).unwrap()
    };
    let top = archive.top().unwrap();
    let world = find(&mut archive, &top, "World");
    let rig = find(&mut archive, &world, "Rig");
    let arm = find(&mut archive, &rig, "Arm");
    let slot = (arm.offset() + 8 + 8) as usize;
    bytes[slot..slot + 8].copy_from_slice(&rig.offset().to_le_bytes());
    let dir = std::env::temp_dir().join(format!("ingest-abc-cycle-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("cycle.abc");
    std::fs::write(&path, &bytes).unwrap();
    let e = load(&path, &at_level(0)).expect_err("a cycle");
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(e.object.as_deref(), Some("/World/Rig/Arm/Cage"), "{e}");
    assert!(e.message.contains("cycle"), "{e}");
}
