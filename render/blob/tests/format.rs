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
        reserved: 0,
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
            reserved: 0,
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
