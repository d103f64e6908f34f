//! Reads the archives of tests/assets/alembic (made by its make_abc.py with Blender).

use super::*;

fn asset(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/assets/alembic").join(name)
}

#[test]
fn shapes_translate() {
    let scene = load(&asset("shapes.abc"), &LoadOptions::default()).unwrap();
    for m in &scene.meshes {
        println!("{} {} tris", m.path, m.triangles.len());
    }
    for c in &scene.curves {
        println!("{} {:?} {} segs {} spheres", c.path, c.kind, c.segments.len(), c.spheres.len());
    }
    println!("{:?}", scene.cameras);
    println!("{:?}", scene.warnings);
}
