//! The blob format: round trip, and every corruption is an error, never a panic.

use blob::*;
use proptest::prelude::*;

fn sample_scene() -> SceneData {
    let mut s = SceneData::default();
    let name = s.add_string("/World/Tri");
    s.positions = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    s.normals = vec![[0.0, 0.0, 1.0]; 3];
    s.uvs = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
    s.triangles = vec![Triangle { vertices: [0, 1, 2], mesh: 0 }];
    s.triangle_materials = vec![0];
    s.meshes = vec![Mesh {
        name,
        first_triangle: 0,
        triangle_count: 1,
        first_vertex: 0,
        vertex_count: 3,
        flags: MESH_HAS_NORMALS | MESH_HAS_UVS,
        light_set: 0,
    }];
    let mname = s.add_string("/Looks/M");
    s.materials = vec![Material {
        name: mname,
        diffuse_color: [0.5; 3],
        program_start: 0,
        program_len: 3,
        ..Material::default()
    }];
    // A 2×2 grey texture with its 1×1 level, a one-tile UDIM set over it, and a program reading it.
    let mut level_offsets = [0u64; MAX_MIP_LEVELS];
    level_offsets[1] = 64;
    s.texture_records = vec![TextureRecord {
        width: 2,
        height: 2,
        channels: 1,
        format: 0,
        mip_count: 2,
        tile_log2: 2,
        byte_len: 65,
        level_offsets,
        ..TextureRecord::default()
    }];
    s.texels = vec![7; 65];
    s.udim_sets = vec![UdimSet { first_tile: 0, u_count: 1, v_count: 1, reserved: 0 }];
    s.udim_tiles = vec![0];
    s.shader_ops = vec![
        ShaderOp { kind: op_kind::PRIMVAR_UV, dst: 0, ..ShaderOp::default() },
        ShaderOp {
            kind: op_kind::TEXTURE,
            dst: 1,
            src: 0,
            texture: 0,
            flags: OP_UDIM | op_wrap_flags(2, 3),
            params: [[1.0; 4], [0.0; 4], [0.0, 0.0, 0.0, 1.0]],
            ..ShaderOp::default()
        },
        ShaderOp {
            kind: op_kind::OUTPUT,
            dst: shading_input::DIFFUSE_COLOR,
            src: 1,
            flags: 0b11_10_01_00,
            ..ShaderOp::default()
        },
    ];
    // Two primvars of the triangle: a per-vertex colour and a constant float.
    let pname = s.add_string("displayColor");
    let fname = s.add_string("weight");
    s.primvars = vec![
        PrimvarRecord {
            name: pname,
            name_id: 0,
            mesh: 0,
            interpolation: primvar_interpolation::VERTEX,
            components: 3,
            first_value: 0,
            value_count: 3,
        },
        PrimvarRecord {
            name: fname,
            name_id: 1,
            mesh: 0,
            interpolation: primvar_interpolation::CONSTANT,
            components: 1,
            first_value: 3,
            value_count: 1,
        },
    ];
    s.primvar_values = vec![[1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0], [0.5; 4]];
    let lname = s.add_string("/Light");
    s.lights = vec![Light { name: lname, kind: light_kind::DOME, radiance: [1.0; 3], ..Light::default() }];
    let cname = s.add_string("/Cam");
    s.cameras = vec![Camera { name: cname, focal_length: 50.0, ..Camera::default() }];
    s.emissive_triangles = vec![];
    let mut node = BvhNode { children: [child_ref::EMPTY; BVH_WIDTH], ..BvhNode::default() };
    for axis in 0..3 {
        node.bounds[axis] = [f32::INFINITY; BVH_WIDTH];
        node.bounds[3 + axis] = [f32::NEG_INFINITY; BVH_WIDTH];
        node.bounds[axis][0] = 0.0;
        node.bounds[3 + axis][0] = if axis == 2 { 0.0 } else { 1.0 };
    }
    node.children[0] = child_ref::leaf(0, 1).unwrap();
    s.bvh_nodes = vec![node];
    let mut block = TriangleBlock::default();
    for (corner, p) in s.positions.iter().enumerate() {
        for (axis, &x) in p.iter().enumerate() {
            block.vertices[corner][axis] = [x; BLOCK_WIDTH];
        }
    }
    s.bvh_blocks = vec![block];
    s.info = SceneInfo {
        bounds_min: [0.0; 3],
        bounds_max: [1.0, 1.0, 0.0],
        default_camera: 0,
        dome_light: 0,
        gprim_count: 1,
        ..SceneInfo::default()
    };
    s
}

fn parse(bytes: &[u8]) -> Result<(), BlobError> {
    SceneView::parse(&AlignedBytes::copy_from(bytes)).map(|_| ())
}

#[test]
fn round_trip_preserves_every_section() {
    let scene = sample_scene();
    let bytes = AlignedBytes::copy_from(&scene.encode());
    let view = SceneView::parse(&bytes).unwrap();
    assert_eq!(*view.info, scene.info);
    assert_eq!(view.positions, &scene.positions[..]);
    assert_eq!(view.normals, &scene.normals[..]);
    assert_eq!(view.uvs, &scene.uvs[..]);
    assert_eq!(view.triangles, &scene.triangles[..]);
    assert_eq!(view.meshes, &scene.meshes[..]);
    assert_eq!(view.materials, &scene.materials[..]);
    assert_eq!(view.lights, &scene.lights[..]);
    assert_eq!(view.cameras, &scene.cameras[..]);
    assert_eq!(view.bvh_nodes, &scene.bvh_nodes[..]);
    assert_eq!(view.bvh_blocks, &scene.bvh_blocks[..]);
    assert_eq!(view.texture_records, &scene.texture_records[..]);
    assert_eq!(view.udim_sets, &scene.udim_sets[..]);
    assert_eq!(view.udim_tiles, &scene.udim_tiles[..]);
    assert_eq!(view.texels, &scene.texels[..]);
    assert_eq!(view.shader_ops, &scene.shader_ops[..]);
    assert_eq!(view.primvars, &scene.primvars[..]);
    assert_eq!(view.primvar_values, &scene.primvar_values[..]);
    assert_eq!(view.string(view.primvars[0].name), "displayColor");
    assert_eq!(view.string(view.meshes[0].name), "/World/Tri");
    assert_eq!(view.string(view.cameras[0].name), "/Cam");
}

#[test]
fn sections_are_64_byte_aligned_and_encoding_is_deterministic() {
    let bytes = sample_scene().encode();
    assert_eq!(bytes, sample_scene().encode());
    let header: Header = bytemuck::pod_read_unaligned(&bytes[..64]);
    for i in 0..header.section_count as usize {
        let entry: SectionEntry = bytemuck::pod_read_unaligned(&bytes[64 + 32 * i..96 + 32 * i]);
        assert_eq!(entry.offset % 64, 0);
    }
}

#[test]
fn texel_section_starts_on_a_page() {
    let bytes = sample_scene().encode();
    let header: Header = bytemuck::pod_read_unaligned(&bytes[..64]);
    let texels = (0..header.section_count as usize)
        .map(|i| bytemuck::pod_read_unaligned::<SectionEntry>(&bytes[64 + 32 * i..96 + 32 * i]))
        .find(|e| e.kind == SectionKind::TextureTexels as u32)
        .unwrap();
    assert_eq!(texels.offset % TEXEL_ALIGN as u64, 0);
    assert_eq!(texels.byte_len, 65);
}

#[test]
fn bad_texture_and_program_indices_are_rejected() {
    let rejects = |what: &str, edit: &dyn Fn(&mut SceneData), kind: SectionKind| {
        let mut scene = sample_scene();
        edit(&mut scene);
        match parse(&scene.encode()) {
            Err(BlobError::BadIndex { kind: k, .. }) if k == kind => {}
            other => panic!("{what}: {other:?}"),
        }
    };
    rejects(
        "level past the texels",
        &|s| s.texture_records[0].level_offsets[1] = 65,
        SectionKind::TextureRecords,
    );
    rejects("too many levels", &|s| s.texture_records[0].mip_count = 3, SectionKind::TextureRecords);
    rejects("unknown format", &|s| s.texture_records[0].format = 3, SectionKind::TextureRecords);
    rejects("huge width", &|s| s.texture_records[0].width = 1 << 20, SectionKind::TextureRecords);
    rejects("tile past the table", &|s| s.udim_sets[0].u_count = 2, SectionKind::UdimSets);
    rejects("tile names no texture", &|s| s.udim_tiles[0] = 1, SectionKind::UdimTiles);
    rejects("udim set out of range", &|s| s.shader_ops[1].texture = 1, SectionKind::ShaderOps);
    rejects(
        "texture out of range",
        &|s| {
            s.shader_ops[1].flags = 0;
            s.shader_ops[1].texture = 1;
        },
        SectionKind::ShaderOps,
    );
    rejects("register out of range", &|s| s.shader_ops[1].dst = MAX_REGISTERS, SectionKind::ShaderOps);
    rejects("source register out of range", &|s| s.shader_ops[2].src = 99, SectionKind::ShaderOps);
    rejects("unknown input", &|s| s.shader_ops[2].dst = shading_input::COUNT, SectionKind::ShaderOps);
    rejects("unknown op", &|s| s.shader_ops[0].kind = op_kind::COUNT, SectionKind::ShaderOps);
    let math = |s: &mut SceneData, src3: u32, function: u32| {
        s.shader_ops[0] = ShaderOp {
            kind: op_kind::MATH,
            dst: 1,
            src: 0,
            src2: 2,
            src3,
            flags: function,
            ..ShaderOp::default()
        };
    };
    rejects(
        "math operand out of range",
        &|s| math(s, MAX_REGISTERS, blob::math_op::MIX),
        SectionKind::ShaderOps,
    );
    rejects("unknown math function", &|s| math(s, 3, blob::math_op::COUNT), SectionKind::ShaderOps);
    let mut scene = sample_scene();
    math(&mut scene, 3, blob::math_op::MIX);
    assert!(parse(&scene.encode()).is_ok(), "a valid MATH op is accepted");
    rejects("program past the ops", &|s| s.materials[0].program_len = 4, SectionKind::Materials);
    // A missing texture is NONE, not an error.
    let mut scene = sample_scene();
    scene.shader_ops[1].texture = NONE;
    assert!(parse(&scene.encode()).is_ok());
}

#[test]
fn bad_primvars_are_rejected() {
    let rejects = |what: &str, edit: &dyn Fn(&mut SceneData)| {
        let mut scene = sample_scene();
        edit(&mut scene);
        match parse(&scene.encode()) {
            Err(BlobError::BadIndex { kind: SectionKind::Primvars, .. }) => {}
            other => panic!("{what}: {other:?}"),
        }
    };
    rejects("mesh out of range", &|s| s.primvars[1].mesh = 1);
    rejects("values past the section", &|s| s.primvars[1].first_value = 4);
    rejects("vertex count mismatch", &|s| s.primvars[0].value_count = 2);
    rejects("face-varying needs 3 per triangle", &|s| {
        s.primvars[0].interpolation = primvar_interpolation::FACE_VARYING;
        s.primvars[0].value_count = 1;
    });
    rejects("uniform needs 1 per triangle", &|s| {
        s.primvars[0].interpolation = primvar_interpolation::UNIFORM
    });
    rejects("unknown interpolation", &|s| s.primvars[0].interpolation = primvar_interpolation::COUNT);
    rejects("components", &|s| s.primvars[1].components = 5);
    rejects("not sorted", &|s| s.primvars.swap(0, 1));
    rejects("repeated key", &|s| s.primvars[1].name_id = 0);
    rejects("name past the strings", &|s| s.primvars[0].name.offset = 10_000);
    // A primvar op's source is a name key, not a register: any value parses (a lookup finds nothing).
    let mut scene = sample_scene();
    scene.shader_ops[0] = ShaderOp { kind: op_kind::PRIMVAR, dst: 0, src: 12345, ..ShaderOp::default() };
    assert!(parse(&scene.encode()).is_ok());
    scene.shader_ops[0].dst = MAX_REGISTERS;
    assert!(matches!(parse(&scene.encode()), Err(BlobError::BadIndex { kind: SectionKind::ShaderOps, .. })));
}

#[test]
fn wrong_version_is_reported_as_such() {
    let mut bytes = sample_scene().encode();
    bytes[8..12].copy_from_slice(&(FORMAT_VERSION + 1).to_le_bytes());
    // Re-seal the header so only the version is wrong.
    let mut header: Header = bytemuck::pod_read_unaligned(&bytes[..64]);
    header.seal();
    bytes[..64].copy_from_slice(bytemuck::bytes_of(&header));
    assert!(matches!(parse(&bytes), Err(BlobError::UnsupportedVersion { .. })));
}

#[test]
fn bad_indices_are_rejected_even_with_valid_checksums() {
    let mut scene = sample_scene();
    scene.triangles[0].vertices[2] = 7;
    assert!(matches!(parse(&scene.encode()), Err(BlobError::BadIndex { kind: SectionKind::Triangles, .. })));
    let mut scene = sample_scene();
    scene.triangle_materials[0] = 3;
    assert!(matches!(parse(&scene.encode()), Err(BlobError::BadIndex { .. })));
    let bvh_nodes_rejected = |scene: &SceneData| {
        matches!(parse(&scene.encode()), Err(BlobError::BadIndex { kind: SectionKind::BvhNodes, .. }))
    };
    let mut scene = sample_scene();
    scene.bvh_nodes[0].children[0] = child_ref::leaf(0, 2).unwrap();
    assert!(bvh_nodes_rejected(&scene), "leaf block range past the end");
    let mut scene = sample_scene();
    scene.bvh_nodes[0].children[3] = child_ref::leaf(2, 0).unwrap();
    assert!(bvh_nodes_rejected(&scene), "empty-looking leaf starting past the end");
    let mut scene = sample_scene();
    scene.bvh_nodes[0].children[1] = 0;
    assert!(bvh_nodes_rejected(&scene), "a node that is its own child (a cycle)");
    let mut scene = sample_scene();
    scene.bvh_nodes.push(scene.bvh_nodes[0]);
    scene.bvh_nodes[1].children[1] = 0;
    scene.bvh_nodes[0].children[1] = 1;
    assert!(bvh_nodes_rejected(&scene), "a child pointing back to its parent");
    let mut scene = sample_scene();
    scene.bvh_nodes[0].children[1] = 1;
    assert!(bvh_nodes_rejected(&scene), "child node index out of range");
    let mut scene = sample_scene();
    scene.bvh_blocks[0].triangles[3] = 1;
    assert!(matches!(
        parse(&scene.encode()),
        Err(BlobError::BadIndex { kind: SectionKind::BvhTriangleBlocks, .. })
    ));
    let mut scene = sample_scene();
    scene.meshes[0].name.len = 1000;
    assert!(matches!(parse(&scene.encode()), Err(BlobError::BadIndex { .. })));
}

#[test]
fn every_single_byte_flip_in_header_and_table_is_an_error() {
    let bytes = sample_scene().encode();
    let header: Header = bytemuck::pod_read_unaligned(&bytes[..64]);
    let table_end = 64 + 32 * header.section_count as usize;
    for i in 0..table_end {
        for flip in [0x01u8, 0x80, 0xff] {
            let mut corrupted = bytes.clone();
            corrupted[i] ^= flip;
            assert!(parse(&corrupted).is_err(), "flip {flip:#x} at byte {i} was accepted");
        }
    }
}

#[test]
fn every_truncation_is_an_error() {
    let bytes = sample_scene().encode();
    for len in 0..bytes.len() {
        assert!(parse(&bytes[..len]).is_err(), "truncation to {len} bytes was accepted");
    }
}

#[test]
fn every_single_byte_flip_anywhere_is_an_error() {
    let bytes = sample_scene().encode();
    for i in 0..bytes.len() {
        let mut corrupted = bytes.clone();
        corrupted[i] ^= 0x04;
        assert!(parse(&corrupted).is_err(), "flip at byte {i} of {} was accepted", bytes.len());
    }
}

/// The deferred path render takes (structure now, checksums later) reports, for every single-byte
/// corruption, exactly the error the eager parse does: at once when the structure is refused (a
/// checksum mismatch preferred), else from `verify`.
#[test]
fn deferred_checksums_report_every_corruption_as_the_eager_parse_does() {
    let bytes = sample_scene().encode();
    let (mut deferred_ok, mut structural) = (0, 0);
    for i in 0..bytes.len() {
        let mut corrupted = bytes.clone();
        corrupted[i] ^= 0x04;
        let aligned = AlignedBytes::copy_from(&corrupted);
        let eager = SceneView::parse(&aligned).map(|_| ()).unwrap_err();
        let deferred = match SceneView::parse_deferring_checksums(&aligned) {
            Ok((_, pending)) => {
                deferred_ok += 1;
                pending.verify(&aligned).unwrap_err()
            }
            Err(e) => {
                structural += 1;
                e
            }
        };
        assert_eq!(deferred, eager, "flip at byte {i}");
    }
    // Both paths are exercised: data flips pass the structure and fail only their checksum.
    assert!(deferred_ok > 0 && structural > 0, "{deferred_ok} deferred, {structural} structural");
    let aligned = AlignedBytes::copy_from(&bytes);
    let (_, pending) = SceneView::parse_deferring_checksums(&aligned).unwrap();
    assert_eq!(pending.verify(&aligned), Ok(()));
    let header: Header = bytemuck::pod_read_unaligned(&bytes[..64]);
    let table = &bytes[64..64 + 32 * header.section_count as usize];
    let section_bytes: u64 =
        table.chunks_exact(32).map(|e| bytemuck::pod_read_unaligned::<SectionEntry>(e).byte_len).sum();
    assert_eq!(pending.byte_len(), section_bytes);
    // A shorter second mapping (the file shrank) is a truncation, not a panic.
    assert!(matches!(pending.verify(&aligned[..aligned.len() / 2]), Err(BlobError::Truncated { .. })));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// Any byte anywhere changed to any value: an error (or, if the value is unchanged, a valid parse);
    /// never a panic.
    #[test]
    fn arbitrary_corruption_never_panics(pos in 0usize..4096, value in any::<u8>()) {
        let mut bytes = sample_scene().encode();
        let pos = pos % bytes.len();
        let changed = bytes[pos] != value;
        bytes[pos] = value;
        let result = parse(&bytes);
        prop_assert!(!changed || result.is_err(), "byte {} set to {:#x} was accepted", pos, value);
    }

    #[test]
    fn random_bytes_never_panic(data in proptest::collection::vec(any::<u8>(), 0..2048)) {
        let _ = parse(&data);
    }

    #[test]
    fn random_section_tables_never_panic(table in proptest::collection::vec(any::<u8>(), 0..512), count in 0u32..20) {
        // A header that passes its own checksum in front of arbitrary table bytes.
        let mut bytes = vec![0u8; 64];
        bytes.extend_from_slice(&table);
        let mut header = Header {
            magic: MAGIC,
            version: FORMAT_VERSION,
            section_count: count,
            file_size: bytes.len() as u64,
            ..Header::default()
        };
        let table_len = (32 * count as usize).min(table.len());
        header.table_checksum = checksum(&table[..table_len]);
        header.seal();
        bytes[..64].copy_from_slice(bytemuck::bytes_of(&header));
        let _ = parse(&bytes);
    }
}

fn with_curves() -> SceneData {
    let mut s = sample_scene();
    let name = s.add_string("/Hair");
    let p = [[0.0, 0.0, 0.0, 0.1], [1.0, 0.0, 0.0, 0.1], [2.0, 0.0, 0.0, 0.1], [3.0, 0.0, 0.0, 0.1]];
    s.curves.groups = vec![CurveGroup {
        name,
        kind: curves::CURVE_TUBE,
        first: 0,
        count: 1,
        curve_count: 1,
        ..CurveGroup::default()
    }];
    s.curves.segments = vec![CurveSegment { p, group: 0, u: [0.0, 1.0], reserved: 0 }];
    s.curves.attributes = vec![CurveAttributes::default()];
    s.curves.bvh_nodes =
        vec![CwBvhNode { imask: 0, child_meta: [0b0010_0000, 0, 0, 0, 0, 0, 0, 0], ..CwBvhNode::default() }];
    s.curves.bvh_primitives = vec![0];
    s
}

#[test]
fn curve_sections_round_trip_and_are_validated() {
    let scene = with_curves();
    let bytes = AlignedBytes::copy_from(&scene.encode());
    let view = SceneView::parse(&bytes).unwrap();
    assert_eq!(view.curves.segments, &scene.curves.segments[..]);
    assert_eq!(view.curves.groups, &scene.curves.groups[..]);
    assert_eq!(view.string(view.curves.groups[0].name), "/Hair");
    let mut bad = with_curves();
    bad.curves.bvh_primitives[0] = 1;
    assert!(matches!(
        parse(&bad.encode()),
        Err(BlobError::BadIndex { kind: SectionKind::CurveBvhPrimitives, .. })
    ));
    let mut bad = with_curves();
    bad.curves.groups[0].count = 2;
    assert!(matches!(parse(&bad.encode()), Err(BlobError::BadIndex { kind: SectionKind::CurveGroups, .. })));
    let mut bad = with_curves();
    bad.curves.segments[0].p[2][3] = -1.0;
    assert!(matches!(
        parse(&bad.encode()),
        Err(BlobError::BadIndex { kind: SectionKind::CurveSegments, .. })
    ));
    let mut bad = with_curves();
    bad.curves.attributes.clear();
    assert!(matches!(
        parse(&bad.encode()),
        Err(BlobError::BadIndex { kind: SectionKind::CurveAttributes, .. })
    ));
}

/// The sample scene plus a one-triangle prototype (the same triangle, second mesh) placed by two
/// instances, with its own BVH and a top-level BVH over the instances.
fn with_instances() -> SceneData {
    let mut s = sample_scene();
    let name = s.add_string("/Proto/Tri");
    s.positions.extend_from_within(0..3);
    s.normals.extend_from_within(0..3);
    s.uvs.extend_from_within(0..3);
    s.triangles.push(Triangle { vertices: [3, 4, 5], mesh: 1 });
    s.triangle_materials.push(0);
    s.meshes.push(Mesh { name, first_triangle: 1, first_vertex: 3, ..s.meshes[0] });
    let mut node = s.bvh_nodes[0];
    let mut block = s.bvh_blocks[0];
    block.triangles = [1; BLOCK_WIDTH];
    s.instancing.prototype_nodes = vec![node];
    s.instancing.prototype_blocks = vec![block];
    s.instancing.prototypes = vec![Prototype {
        first_triangle: 1,
        triangle_count: 1,
        first_node: 0,
        node_count: 1,
        first_block: 0,
        block_count: 1,
        first_mesh: 1,
        mesh_count: 1,
        bounds_min: [0.0; 3],
        bounds_max: [1.0, 1.0, 0.0],
        reserved: [0; 2],
    }];
    let iname = s.add_string("/I0");
    let translate = |x: f32| [[1.0, 0.0, 0.0, x], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]];
    s.instancing.instances = (0..2)
        .map(|i| Instance {
            world_from_object: translate(2.0 * i as f32),
            object_from_world: translate(-2.0 * i as f32),
            prototype: 0,
            name: iname,
            motion: NONE,
        })
        .collect();
    node.children[0] = child_ref::leaf(0, 2).unwrap();
    s.instancing.bvh_nodes = vec![node];
    s.instancing.bvh_items = vec![0, 1];
    s
}

#[test]
fn instance_sections_round_trip() {
    let scene = with_instances();
    let bytes = AlignedBytes::copy_from(&scene.encode());
    let view = SceneView::parse(&bytes).unwrap();
    assert_eq!(view.instancing.instances, &scene.instancing.instances[..]);
    assert_eq!(view.instancing.prototypes, &scene.instancing.prototypes[..]);
    assert_eq!(view.instancing.bvh_items, &[0, 1]);
    assert_eq!(view.instancing.top_level_triangles(view.triangles.len()), 1);
    assert_eq!(std::mem::size_of::<Instance>(), 112);
    assert_eq!(std::mem::size_of::<Prototype>(), 64);
}

#[test]
fn corrupted_instance_records_are_rejected_with_valid_checksums() {
    let rejects = |what: &str, edit: &dyn Fn(&mut SceneData), kind: SectionKind, message: &str| {
        let mut scene = with_instances();
        edit(&mut scene);
        // `encode` recomputes every checksum: only validation can catch these.
        match parse(&scene.encode()) {
            Err(e @ BlobError::BadIndex { kind: k, .. }) if k == kind => {
                assert!(e.to_string().contains(message), "{what}: {e}");
            }
            other => panic!("{what}: {other:?}"),
        }
    };
    use SectionKind as K;
    rejects(
        "bad prototype index",
        &|s| s.instancing.instances[1].prototype = 1,
        K::Instances,
        "prototype index out of range",
    );
    rejects(
        "NaN transform",
        &|s| s.instancing.instances[0].world_from_object[1][2] = f32::NAN,
        K::Instances,
        "non-finite transform",
    );
    rejects(
        "infinite inverse",
        &|s| s.instancing.instances[1].object_from_world[0][3] = f32::INFINITY,
        K::Instances,
        "non-finite",
    );
    rejects(
        "inverse that is not",
        &|s| s.instancing.instances[1].object_from_world[0][3] = 5.0,
        K::Instances,
        "not the inverse",
    );
    rejects("instance name", &|s| s.instancing.instances[0].name.len = 999, K::Instances, "name");
    rejects(
        "item out of range",
        &|s| s.instancing.bvh_items[1] = 2,
        K::InstanceBvhItems,
        "instance index out of range",
    );
    rejects(
        "top leaf past the items",
        &|s| s.instancing.bvh_nodes[0].children[0] = child_ref::leaf(1, 2).unwrap(),
        K::InstanceBvhNodes,
        "leaf item range",
    );
    rejects(
        "top child cycle",
        &|s| s.instancing.bvh_nodes[0].children[1] = 0,
        K::InstanceBvhNodes,
        "child node index",
    );
    rejects("no top-level BVH", &|s| s.instancing.bvh_nodes.clear(), K::InstanceBvhNodes, "required");
    rejects(
        "prototype block leaves its prototype",
        &|s| s.instancing.prototype_blocks[0].triangles[2] = 0,
        K::PrototypeBvhBlocks,
        "outside its prototype",
    );
    rejects(
        "prototype leaf past the blocks",
        &|s| s.instancing.prototype_nodes[0].children[0] = child_ref::leaf(0, 2).unwrap(),
        K::PrototypeBvhNodes,
        "leaf blocks outside",
    );
    rejects(
        "prototype node range",
        &|s| s.instancing.prototypes[0].node_count = 2,
        K::Prototypes,
        "node range",
    );
    rejects(
        "prototype past the triangles",
        &|s| s.instancing.prototypes[0].triangle_count = 2,
        K::Prototypes,
        "outside the triangles section",
    );
    rejects(
        "overlapping prototypes",
        &|s| s.instancing.prototypes.push(s.instancing.prototypes[0]),
        K::Prototypes,
        "contiguous",
    );
    rejects(
        "prototype mesh range",
        &|s| s.instancing.prototypes[0].mesh_count = 2,
        K::Prototypes,
        "mesh range",
    );
    rejects(
        "world BVH reaches a prototype triangle",
        &|s| s.bvh_blocks[0].triangles[1] = 1,
        K::BvhTriangleBlocks,
        "prototype",
    );
    rejects(
        "emitter inside a prototype",
        &|s| s.emissive_triangles = vec![EmissiveTriangle { triangle: 1, area: 0.5, cdf: 1.0, pmf: 1.0 }],
        K::EmissiveTriangles,
        "",
    );
}

// Crafted blobs: every checksum is right (`encode` and `reseal` recompute them), so only structural
// validation stands between these and render. Each pins a hang, panic or blow-up found by an
// adversarial run (issue 20).

/// The error text of parsing `scene`, which must be a `BadIndex` of `kind`.
fn crafted_error(scene: &SceneData, kind: SectionKind) -> String {
    match parse(&scene.encode()) {
        Err(e @ BlobError::BadIndex { kind: k, .. }) if k == kind => e.to_string(),
        other => panic!("expected a {kind:?} error, got {other:?}"),
    }
}

/// Makes `slot` of `node` an internal child `child` with the bounds of slot 0.
fn link(node: &mut BvhNode, slot: usize, child: u32) {
    for k in 0..6 {
        node.bounds[k][slot] = node.bounds[k][0];
    }
    node.children[slot] = child;
}

/// `n` world BVH nodes of the sample scene: node 0 links to 1..n as `edges` says, every node keeps the
/// sample's one leaf in slot 0.
fn world_bvh(n: usize, edges: &[(usize, usize, u32)]) -> SceneData {
    let mut s = sample_scene();
    s.bvh_nodes = vec![s.bvh_nodes[0]; n];
    for &(parent, slot, child) in edges {
        link(&mut s.bvh_nodes[parent], slot, child);
    }
    s
}

#[test]
fn bvh_dags_orphans_and_deep_chains_are_rejected() {
    use SectionKind as K;
    assert!(parse(&world_bvh(3, &[(0, 1, 1), (0, 2, 2)]).encode()).is_ok(), "a tree");
    // Node 2 under both 0 and 1: a DAG, exponential to traverse when repeated.
    let dag = world_bvh(3, &[(0, 1, 1), (0, 2, 2), (1, 1, 2)]);
    assert_eq!(
        crafted_error(&dag, K::BvhNodes),
        "section BvhNodes record 1: child node shared with another parent (the BVH must be a tree)"
    );
    let orphan = world_bvh(3, &[(0, 1, 1)]);
    assert!(crafted_error(&orphan, K::BvhNodes).contains("record 2: node not reachable from the root"));
    let chain = |n: usize| world_bvh(n, &(0..n - 1).map(|i| (i, 1, i as u32 + 1)).collect::<Vec<_>>());
    assert!(parse(&chain(tree::MAX_BVH_DEPTH as usize).encode()).is_ok());
    assert_eq!(
        crafted_error(&chain(tree::MAX_BVH_DEPTH as usize + 1), K::BvhNodes),
        format!(
            "section BvhNodes record {}: BVH deeper than the traversal stack allows",
            tree::MAX_BVH_DEPTH - 1
        )
    );
    let mut self_child = sample_scene();
    link(&mut self_child.bvh_nodes[0], 1, 0);
    assert!(crafted_error(&self_child, K::BvhNodes).contains("child node index not after the parent"));

    // The same rules hold in the top-level and the prototype BVHs.
    let mut s = with_instances();
    s.instancing.bvh_nodes = vec![s.instancing.bvh_nodes[0]; 3];
    link(&mut s.instancing.bvh_nodes[0], 1, 1);
    link(&mut s.instancing.bvh_nodes[0], 2, 2);
    link(&mut s.instancing.bvh_nodes[1], 1, 2);
    assert!(
        crafted_error(&s, K::InstanceBvhNodes).contains("record 1: child node shared with another parent")
    );
    let mut s = with_instances();
    s.instancing.prototype_nodes = vec![s.instancing.prototype_nodes[0]; 3];
    s.instancing.prototypes[0].node_count = 3;
    link(&mut s.instancing.prototype_nodes[0], 1, 1);
    link(&mut s.instancing.prototype_nodes[0], 2, 2);
    link(&mut s.instancing.prototype_nodes[1], 1, 2);
    assert!(
        crafted_error(&s, K::PrototypeBvhNodes).contains("record 1: child node shared with another parent")
    );
}

#[test]
fn zero_block_leaves_must_be_the_empty_slot() {
    // A prototype leaf of 0 blocks far past the block array: traversal sliced `blocks[first..first]`.
    let mut s = with_instances();
    s.instancing.prototype_nodes[0].children[2] = child_ref::leaf(1000, 0).unwrap();
    assert_eq!(
        crafted_error(&s, SectionKind::PrototypeBvhNodes),
        "section PrototypeBvhNodes record 0: leaf with no blocks that is not the empty-slot encoding"
    );
    let mut s = sample_scene();
    s.bvh_nodes[0].children[1] = child_ref::leaf(0, 0).unwrap();
    assert_eq!(child_ref::leaf(0, 0), Some(child_ref::EMPTY), "block 0, count 0 is the empty slot");
    assert!(parse(&s.encode()).is_ok());
}

#[test]
fn curve_bvh_must_be_a_tree_with_one_rule_for_internal_children() {
    use SectionKind as K;
    let internal = |child_base_idx: u32| CwBvhNode {
        imask: 1 << 1,
        child_base_idx,
        child_meta: [0b0010_0000, tree::cw_internal_meta(1), 0, 0, 0, 0, 0, 0],
        ..CwBvhNode::default()
    };
    let leaf = with_curves().curves.bvh_nodes[0];
    let mut ok = with_curves();
    ok.curves.bvh_nodes = vec![internal(1), leaf];
    assert!(parse(&ok.encode()).is_ok());
    // A node whose children include itself hung render.
    let mut s = with_curves();
    s.curves.bvh_nodes = vec![internal(0), leaf];
    assert!(crafted_error(&s, K::CurveBvhNodes)
        .contains("record 0: child node index not after the parent or out of range"));
    // Internal by its meta byte, a leaf by imask: the traversal indexed past the nodes.
    let mut s = ok.clone();
    s.curves.bvh_nodes[0].imask = 0;
    assert!(crafted_error(&s, K::CurveBvhNodes).contains("imask and meta byte disagree"));
    let mut s = ok.clone();
    s.curves.bvh_nodes[0].child_meta[1] = tree::cw_internal_meta(3);
    assert!(crafted_error(&s, K::CurveBvhNodes).contains("does not name its own slot"));
    let mut s = with_curves();
    s.curves.bvh_nodes[0].child_meta[0] = 0b1010_0000;
    assert!(crafted_error(&s, K::CurveBvhNodes).contains("not unary"));
    let mut s = with_curves();
    s.curves.bvh_nodes[0].child_meta[0] = 0b0110_0000 | 23;
    assert!(crafted_error(&s, K::CurveBvhNodes).contains("spill past the node's 24 primitive bits"));
    // A chain deeper than obvhs' 32-entry stack.
    let deep = tree::MAX_CURVE_BVH_DEPTH as usize + 1;
    let mut s = with_curves();
    s.curves.bvh_nodes = (0..deep - 1).map(|i| internal(i as u32 + 1)).chain([leaf]).collect();
    assert!(crafted_error(&s, K::CurveBvhNodes).contains("deeper than the traversal stack"));
    s.curves.bvh_nodes = (0..deep - 2).map(|i| internal(i as u32 + 1)).chain([leaf]).collect();
    assert!(parse(&s.encode()).is_ok(), "32 levels traverse exactly");
}

#[test]
fn huge_or_non_finite_floats_and_resolutions_are_rejected() {
    use SectionKind as K;
    for bound in [1e38, f32::INFINITY, f32::NAN] {
        let mut s = sample_scene();
        s.info.bounds_max = [bound; 3];
        s.info.bounds_min = [-bound; 3];
        assert_eq!(
            crafted_error(&s, K::SceneInfo),
            "section SceneInfo record 0: scene bounds non-finite or beyond ±1e12 (and not the empty encoding)"
        );
    }
    let mut s = sample_scene();
    (s.info.bounds_min, s.info.bounds_max) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    assert!(parse(&s.encode()).is_ok(), "the empty scene's bounds");
    for window in [[0.5, 0.0, 0.25, 1.0], [0.0, 0.0, f32::NAN, 1.0], [0.0, 0.0, 17.0, 1.0]] {
        let mut s = sample_scene();
        s.info.data_window_ndc = window;
        assert_eq!(
            crafted_error(&s, K::SceneInfo),
            "section SceneInfo record 0: data window non-finite, beyond ±16 or inverted",
            "{window:?}"
        );
    }
    let mut s = sample_scene();
    s.info.data_window_ndc = [-0.5, 0.25, 1.5, 0.75];
    assert!(parse(&s.encode()).is_ok(), "an overscanning window");
    for origin in [f64::NAN, f64::INFINITY] {
        let mut s = sample_scene();
        s.info.world_origin = [1e7, origin, 0.0];
        assert_eq!(crafted_error(&s, K::SceneInfo), "section SceneInfo record 0: world origin not finite");
    }
    let mut s = sample_scene();
    s.info.world_origin = [1e7, -4_992.0, 64.0];
    assert!(parse(&s.encode()).is_ok(), "a camera-relative blob");
    for resolution in [[1, 2_147_483_647], [65_535, 65_535], [0, 5]] {
        let mut s = sample_scene();
        s.info.resolution = resolution;
        assert!(crafted_error(&s, K::SceneInfo).contains("resolution"), "{resolution:?}");
    }
    let mut s = sample_scene();
    s.info.resolution = [16_384, 16_384];
    assert!(parse(&s.encode()).is_ok());
    let mut s = sample_scene();
    s.positions[1][0] = 3e12;
    assert_eq!(crafted_error(&s, K::Positions), "section Positions record 1: non-finite or huge position");
    let mut s = sample_scene();
    s.bvh_blocks[0].vertices[1][0][2] = f32::NAN;
    assert!(crafted_error(&s, K::BvhTriangleBlocks).contains("non-finite or huge vertex"));
    let mut s = sample_scene();
    s.bvh_nodes[0].bounds[4][0] = f32::INFINITY;
    assert!(crafted_error(&s, K::BvhNodes).contains("non-finite or huge child bounds"));
    let mut s = sample_scene();
    s.cameras[0].world_from_camera[0][3] = f32::NAN;
    assert!(crafted_error(&s, K::Cameras).contains("non-finite or huge transform"));
    let mut s = sample_scene();
    s.lights[0].radiance[1] = f32::INFINITY;
    assert!(crafted_error(&s, K::Lights).contains("radiance"));
    let mut s = with_instances();
    s.instancing.instances[0].world_from_object[0][3] = 1e20;
    s.instancing.instances[0].object_from_world[0][3] = -1e20;
    assert!(crafted_error(&s, K::Instances).contains("beyond ±1e12"));
}

/// The thin-lens fields: a pinhole (f-stop 0), a lens with a focus plane, round or 3..=64 blades;
/// every bad value names the field.
#[test]
fn camera_lens_fields_are_validated() {
    use SectionKind as K;
    let lens = |f_stop: f32, focus_distance: f32, blades: u32, rotation: f32| {
        let mut s = sample_scene();
        let c = &mut s.cameras[0];
        (c.f_stop, c.focus_distance, c.aperture_blades, c.aperture_rotation) =
            (f_stop, focus_distance, blades, rotation);
        s
    };
    for ok in
        [lens(0.0, 0.0, 0, 0.0), lens(2.8, 5.0, 0, 0.0), lens(1.4, 0.5, 6, -30.0), lens(0.0, 3.0, 64, 360.0)]
    {
        let bytes = AlignedBytes::copy_from(&ok.encode());
        let view = SceneView::parse(&bytes).expect("valid lens");
        assert_eq!(view.cameras[0], ok.cameras[0]);
    }
    let cases = [
        (lens(-1.0, 5.0, 0, 0.0), "fStop not in [0, 1e6] (or NaN)"),
        (lens(f32::NAN, 5.0, 0, 0.0), "fStop not in [0, 1e6] (or NaN)"),
        (lens(2e6, 5.0, 0, 0.0), "fStop not in [0, 1e6] (or NaN)"),
        (lens(2.8, -5.0, 0, 0.0), "focusDistance negative, NaN or huge"),
        (lens(2.8, f32::INFINITY, 0, 0.0), "focusDistance negative, NaN or huge"),
        (lens(2.8, 0.0, 0, 0.0), "focusDistance 0 with a nonzero fStop (the thin lens needs a focus plane)"),
        (lens(2.8, 5.0, 2, 0.0), "aperture blades not 0 (round) or 3..=64"),
        (lens(2.8, 5.0, 65, 0.0), "aperture blades not 0 (round) or 3..=64"),
        (lens(2.8, 5.0, 5, f32::NAN), "aperture rotation not within ±360 degrees (or NaN)"),
        (lens(2.8, 5.0, 5, 400.0), "aperture rotation not within ±360 degrees (or NaN)"),
    ];
    for (scene, what) in cases {
        assert_eq!(crafted_error(&scene, K::Cameras), format!("section Cameras record 0: {what}"));
    }
}

/// The shutter interval: finite, bounded, open ≤ close (equal is an instantaneous shutter).
#[test]
fn camera_shutter_is_validated() {
    let shutter = |open: f32, close: f32| {
        let mut s = sample_scene();
        (s.cameras[0].shutter_open, s.cameras[0].shutter_close) = (open, close);
        s
    };
    for ok in [shutter(0.0, 0.0), shutter(-0.25, 0.25), shutter(0.5, 0.5)] {
        let bytes = AlignedBytes::copy_from(&ok.encode());
        assert_eq!(SceneView::parse(&bytes).expect("valid shutter").cameras[0], ok.cameras[0]);
    }
    for bad in [shutter(0.5, 0.25), shutter(f32::NAN, 0.0), shutter(0.0, f32::INFINITY), shutter(-2e4, 0.0)] {
        assert_eq!(
            crafted_error(&bad, SectionKind::Cameras),
            "section Cameras record 0: shutter open/close not finite within ±1e4 time codes with open <= close"
        );
    }
}

/// [`with_instances`] with instance 1 moving along x between two keys.
fn with_moving_instance() -> SceneData {
    let mut s = with_instances();
    let translate = |x: f32| [[1.0, 0.0, 0.0, x], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]];
    s.instancing.instances[1].motion = 0;
    s.instancing.motions = vec![InstanceMotion { first_key: 0, key_count: 2, reserved: [0; 2] }];
    s.instancing.motion_keys = vec![
        MotionKey { time: -0.25, reserved: [0; 3], world_from_object: translate(2.0) },
        MotionKey { time: 0.25, reserved: [0; 3], world_from_object: translate(3.0) },
    ];
    s
}

#[test]
fn motion_keys_round_trip_and_bad_keys_are_refused() {
    let scene = with_moving_instance();
    let bytes = AlignedBytes::copy_from(&scene.encode());
    let view = SceneView::parse(&bytes).expect("valid motion");
    assert_eq!(view.instancing.motions, &scene.instancing.motions[..]);
    assert_eq!(view.instancing.motion_keys, &scene.instancing.motion_keys[..]);
    assert_eq!((std::mem::size_of::<MotionKey>(), std::mem::size_of::<InstanceMotion>()), (64, 16));
    use SectionKind as K;
    let rejects = |edit: &dyn Fn(&mut SceneData), kind: SectionKind, expected: &str| {
        let mut s = with_moving_instance();
        edit(&mut s);
        assert_eq!(crafted_error(&s, kind), expected);
    };
    rejects(
        &|s| s.instancing.motion_keys[1].world_from_object[0][3] = f32::NAN,
        K::MotionKeys,
        "section MotionKeys record 1: key transform NaN, beyond ±1e12 or not invertible",
    );
    rejects(
        &|s| s.instancing.motion_keys[0].world_from_object[1][1] = 0.0,
        K::MotionKeys,
        "section MotionKeys record 0: key transform NaN, beyond ±1e12 or not invertible",
    );
    rejects(
        &|s| s.instancing.motion_keys[0].time = f32::NAN,
        K::MotionKeys,
        "section MotionKeys record 0: key time NaN, infinite, beyond ±1e4 time codes or not after the previous key",
    );
    rejects(
        &|s| s.instancing.motion_keys[1].time = -0.25,
        K::MotionKeys,
        "section MotionKeys record 1: key time NaN, infinite, beyond ±1e4 time codes or not after the previous key",
    );
    rejects(
        &|s| s.instancing.motions[0].key_count = 1_000_000,
        K::InstanceMotions,
        "section InstanceMotions record 0: key count not within 2..=256",
    );
    rejects(
        &|s| s.instancing.motions[0].key_count = 3,
        K::InstanceMotions,
        "section InstanceMotions record 0: key range outside the motion keys section",
    );
    rejects(
        &|s| s.instancing.motions[0].first_key = u32::MAX,
        K::InstanceMotions,
        "section InstanceMotions record 0: key range outside the motion keys section",
    );
    rejects(
        &|s| s.instancing.instances[0].motion = 1,
        K::Instances,
        "section Instances record 0: motion index out of range",
    );
}

#[test]
fn reseal_lets_byte_level_mutations_reach_structural_validation() {
    let scene = sample_scene();
    let mut bytes = scene.encode();
    let view_bytes = AlignedBytes::copy_from(&bytes);
    let view = SceneView::parse(&view_bytes).unwrap();
    // Point the root's slot 1 at the root itself, in the file's bytes.
    let node_offset = view.bvh_nodes.as_ptr() as usize - view_bytes.as_ptr() as usize;
    let slot1 = node_offset + std::mem::offset_of!(BvhNode, children) + 4;
    bytes[slot1..slot1 + 4].copy_from_slice(&0u32.to_le_bytes());
    assert!(matches!(parse(&bytes), Err(BlobError::SectionChecksum(SectionKind::BvhNodes))));
    blob::reseal(&mut bytes);
    let err = parse(&bytes).unwrap_err().to_string();
    assert_eq!(err, "section BvhNodes record 0: child node index not after the parent or out of range");
    // A truncation gets past the file-size check to the section bounds.
    let mut short = bytes[..bytes.len() - 64].to_vec();
    blob::reseal(&mut short);
    let header: Header = bytemuck::pod_read_unaligned(&short[..64]);
    assert_eq!(header.file_size, short.len() as u64);
    assert!(matches!(parse(&short), Err(BlobError::SectionBounds { .. })), "{:?}", parse(&short));
}

/// Light sets (format 8): a round trip, then each broken rule is its own error: a partial set, a
/// bit past the last light, a mesh's set out of range, a set index without any sets.
#[test]
fn light_sets_round_trip_and_are_validated() {
    let mut scene = sample_scene();
    // One light: one word per mask, two per set. Set 0 is everything; set 1 is shadows only.
    scene.light_sets = vec![1, 1, 0, 1];
    scene.meshes[0].light_set = 1;
    let bytes = AlignedBytes::copy_from(&scene.encode());
    let view = SceneView::parse(&bytes).unwrap();
    assert_eq!(view.light_sets, &[1, 1, 0, 1]);
    assert_eq!(view.light_set_count(), 2);
    assert_eq!(view.meshes[0].light_set, 1);

    let mut partial = scene.clone();
    partial.light_sets.push(1);
    let text = crafted_error(&partial, SectionKind::LightSets);
    assert!(text.contains("whole number of light sets"), "{text}");
    let mut past = scene.clone();
    past.light_sets[2] = 0b10;
    let text = crafted_error(&past, SectionKind::LightSets);
    assert!(text.contains("bit set past the last light"), "{text}");
    let mut out_of_range = scene.clone();
    out_of_range.meshes[0].light_set = 2;
    let text = crafted_error(&out_of_range, SectionKind::Meshes);
    assert!(text.contains("light set index out of range"), "{text}");
    let mut without_sets = scene.clone();
    without_sets.light_sets.clear();
    let text = crafted_error(&without_sets, SectionKind::Meshes);
    assert!(text.contains("light set index out of range"), "{text}");
    let mut no_lights = scene;
    no_lights.lights.clear();
    no_lights.info.dome_light = NONE;
    no_lights.meshes[0].light_set = 0;
    let text = crafted_error(&no_lights, SectionKind::LightSets);
    assert!(text.contains("whole number of light sets"), "{text}");
}

/// The OpenPBR constants of a material (format 12) are validated once at load: a coat of index
/// below 1, a NaN coat colour, a specular weight above 1 or a negative tint are each an error
/// naming the parameter and the record; the fallbacks (UsdPreviewSurface's look) load.
#[test]
fn openpbr_constants_out_of_range_are_rejected_at_load() {
    let fallback = Material::default();
    assert_eq!(
        (fallback.coat_color, fallback.coat_ior, fallback.specular_weight, fallback.specular_tint),
        ([1.0; 3], 1.5, 1.0, [1.0; 3])
    );
    assert!(parse(&sample_scene().encode()).is_ok());
    type Edit = fn(&mut Material);
    let edits: [(Edit, &str); 8] = [
        (|m| m.coat_ior = 0.5, "coat_ior not finite or outside [1, 10]"),
        (|m| m.coat_ior = f32::INFINITY, "coat_ior not finite or outside [1, 10]"),
        (|m| m.coat_color[1] = f32::NAN, "coat_color not finite or outside [0, 1]"),
        (|m| m.specular_weight = 1.5, "specular_weight not finite or outside [0, 1]"),
        (|m| m.specular_tint[2] = -0.25, "specular_color (specular_tint) not finite or outside [0, 1]"),
        (|m| m.fuzz_weight = 2.0, "fuzz_weight not finite or outside [0, 1]"),
        (|m| m.fuzz_color[0] = f32::NEG_INFINITY, "fuzz_color not finite or outside [0, 1]"),
        (|m| m.fuzz_roughness = f32::NAN, "fuzz_roughness not finite or outside [0, 1]"),
    ];
    for (edit, what) in edits {
        let mut scene = sample_scene();
        edit(&mut scene.materials[0]);
        assert_eq!(
            crafted_error(&scene, SectionKind::Materials),
            format!("section Materials record 0: {what}")
        );
    }
    // The ends of each range are valid.
    let mut scene = sample_scene();
    let m = &mut scene.materials[0];
    (m.coat_color, m.coat_ior, m.specular_weight, m.specular_tint) = ([0.0; 3], 10.0, 0.0, [0.0, 1.0, 0.0]);
    assert!(parse(&scene.encode()).is_ok());
}
