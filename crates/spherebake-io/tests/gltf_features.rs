//! glTF features checked on variants of the repository fixtures and small built documents:
//! negative-determinant node transforms, strips / fans, sparse accessors, rigid meshes under
//! joints, the content hash, and no panics on mutated documents.

use std::path::{Path, PathBuf};

use spherebake_geom::anim::{joint_matrices, sample_local, skin_vertices, world_matrices};
use spherebake_geom::glam::Vec3;
use spherebake_geom::topology::TopologyReport;
use spherebake_io::{load_mesh, load_mesh_from_bytes, Fnv1a64};

fn fixture(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures").join(p)
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap()
}

#[test]
fn mirrored_node_keeps_triangles_outward() {
    let path = fixture("textured-cube/textured-cube.gltf");
    let json = read(&path).replace(r#""mesh": 0"#, r#""mesh": 0, "scale": [-1.0, 2.0, 1.0]"#);
    assert!(json.contains("scale"));
    // Same directory, so the external .bin and .png resolve.
    let imp = load_mesh_from_bytes(&path.with_file_name("mirrored.gltf"), json.as_bytes()).unwrap();
    let r = TopologyReport::compute(&imp.mesh);
    assert!(r.consistently_oriented);
    assert!((r.signed_volume - 2.0).abs() < 1e-9, "volume {} (|det| = 2, winding flipped back)", r.signed_volume);
    // Normals follow the mirror: the +X face's normal becomes −X.
    let i = imp.mesh.positions.iter().position(|p| p.x > 0.49).unwrap();
    assert!(imp
        .mesh
        .normals
        .iter()
        .zip(&imp.mesh.positions)
        .all(|(n, p)| n.x.abs() < 0.5 || n.x.signum() == p.x.signum()));
    assert!(imp.mesh.normals[i].is_normalized());
}

/// One quad (0,0)-(1,1) in z = 0 as 4 vertices, with `mode` and the given u16 indices.
fn quad_json(mode: u32, indices: &[u16]) -> String {
    let pos: [[f32; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]];
    let mut bin: Vec<u8> = pos.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    bin.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let encoded = b64(&bin);
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"mode":{mode}}}]}}],
"buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{encoded}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":{}}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
{{"bufferView":1,"componentType":5123,"count":{},"type":"SCALAR"}}]}}"#,
        bin.len(),
        indices.len() * 2,
        indices.len()
    )
}

/// A GLB holding `json` as its only chunk, padded to 4 bytes with `pad`.
fn glb(json: &[u8], pad: u8) -> Vec<u8> {
    let mut chunk = json.to_vec();
    while chunk.len() % 4 != 0 {
        chunk.push(pad);
    }
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend(((12 + 8 + chunk.len()) as u32).to_le_bytes());
    out.extend((chunk.len() as u32).to_le_bytes());
    out.extend(0x4E4F_534Au32.to_le_bytes());
    out.extend(chunk);
    out
}

/// What cgltf and gltfpack accept, read the same: a GLB whose JSON chunk is padded with NULs
/// (the spec says spaces), GLB bytes in a `.gltf` file and JSON text in a `.glb` file (read by
/// content), and an index accessor flagged `normalized` (the flag is ignored for indices).
#[test]
fn lenient_containers_and_normalized_indices_read_like_cgltf() {
    let json = quad_json(4, &[0, 1, 2, 2, 1, 3]);
    let plain = load_mesh_from_bytes(Path::new("mem/q.gltf"), json.as_bytes()).unwrap().mesh.triangles;
    assert_eq!(plain.len(), 2);
    // 3 bytes of padding at least: the JSON's length is made ≡ 1 (mod 4).
    let mut odd = json.clone();
    while odd.len() % 4 != 1 {
        odd.push(' ');
    }
    for pad in [b' ', 0u8] {
        let bytes = glb(odd.as_bytes(), pad);
        for name in ["mem/q.glb", "mem/q.gltf"] {
            let imp =
                load_mesh_from_bytes(Path::new(name), &bytes).unwrap_or_else(|e| panic!("{name}, pad {pad}: {e}"));
            assert_eq!(imp.mesh.triangles, plain, "{name}");
        }
    }
    let imp = load_mesh_from_bytes(Path::new("mem/q.glb"), json.as_bytes()).expect("JSON in a .glb");
    assert_eq!(imp.mesh.triangles, plain);
    let flagged = json.replace(
        r#""componentType":5123,"count":6,"type":"SCALAR""#,
        r#""componentType":5123,"normalized":true,"count":6,"type":"SCALAR""#,
    );
    assert!(flagged.contains("normalized"), "quad_json layout changed");
    let imp = load_mesh_from_bytes(Path::new("mem/q.gltf"), flagged.as_bytes()).unwrap();
    assert_eq!(imp.mesh.triangles, plain);
}

#[test]
fn strips_and_fans_become_ccw_triangles() {
    // Strip 0,1,2,3 and fan 0,1,3,2 both cover the quad with two +Z-facing triangles.
    for (mode, idx) in [(5, [0u16, 1, 2, 3]), (6, [0, 1, 3, 2])] {
        let imp = load_mesh_from_bytes(Path::new("mem/q.gltf"), quad_json(mode, &idx).as_bytes()).unwrap();
        let m = &imp.mesh;
        assert_eq!(m.triangles.len(), 2, "mode {mode}");
        for t in 0..2 {
            let [a, b, c] = m.triangle(t);
            assert!((b - a).cross(c - a).z > 0.0, "mode {mode} triangle {t} faces +Z");
        }
        let r = TopologyReport::compute(m);
        assert_eq!((r.boundary_edge_count, r.surface_area), (4, 1.0), "mode {mode}");
    }
    // Lines are skipped with a warning; with nothing else the mesh is empty (an error that
    // says the model has only points / lines, and how many were skipped).
    let e = load_mesh_from_bytes(Path::new("mem/q.gltf"), quad_json(1, &[0, 1]).as_bytes()).unwrap_err();
    assert_eq!(
        e.to_string(),
        "mem/q.gltf: no triangles to import: the model has only POINTS / LINES primitives (1 skipped; only triangles are imported)"
    );
}

#[test]
fn sparse_accessor_overrides_base_values() {
    // Positions: base view of 3 vertices, sparse override of vertex 2 with (0, 5, 0).
    let mut bin: Vec<u8> =
        [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]].iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    bin.extend(2u16.to_le_bytes());
    bin.extend([0, 0]);
    bin.extend([0.0f32, 5.0, 0.0].iter().flat_map(|x| x.to_le_bytes()));
    let encoded = b64(&bin);
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
"buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{encoded}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":2}},{{"buffer":0,"byteOffset":40,"byteLength":12}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,5,0],
"sparse":{{"count":1,"indices":{{"bufferView":1,"componentType":5123}},"values":{{"bufferView":2}}}}}}]}}"#,
        bin.len()
    );
    let imp = load_mesh_from_bytes(Path::new("mem/s.gltf"), json.as_bytes()).unwrap();
    assert_eq!(imp.mesh.positions, vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, 5.0, 0.0)]);
}

#[test]
fn rigid_mesh_under_a_joint_follows_it_and_one_outside_stays() {
    let path = fixture("skinned-arm.gltf");
    let mut doc: serde_json::Value = serde_json::from_str(&read(&path)).unwrap();
    // Mesh 1: unskinned, reusing the arm's POSITION and index accessors. Node 4 ("hand", child of
    // the wrist, 0.5 up) and node 5 ("prop", a scene root at x = 3) instance it.
    let arm_prim = doc["meshes"][0]["primitives"][0].clone();
    let rigid = serde_json::json!({"name": "rigid", "primitives": [{
        "attributes": {"POSITION": arm_prim["attributes"]["POSITION"]}, "indices": arm_prim["indices"]}]});
    doc["meshes"].as_array_mut().unwrap().push(rigid);
    let nodes = doc["nodes"].as_array_mut().unwrap();
    assert_eq!(nodes[3]["name"], "wrist");
    nodes[3]["children"] = serde_json::json!([4]);
    nodes.push(serde_json::json!({"name": "hand", "mesh": 1, "translation": [0.0, 0.5, 0.0]}));
    nodes.push(serde_json::json!({"name": "prop", "mesh": 1, "translation": [3.0, 0.0, 0.0]}));
    doc["scenes"][0]["nodes"].as_array_mut().unwrap().push(5.into());
    let json = serde_json::to_string(&doc).unwrap();

    let imp = load_mesh_from_bytes(&path, json.as_bytes()).unwrap();
    let m = &imp.mesh;
    let skin = m.skin.as_ref().unwrap();
    assert_eq!(imp.parts.len(), 3);
    assert!(imp.warnings.iter().any(|w| w.0.contains("not under any joint")), "{:?}", imp.warnings);
    let hand = imp.parts.iter().find(|p| p.node == Some(4)).unwrap();
    let prop = imp.parts.iter().find(|p| p.node == Some(5)).unwrap();
    let wrist_bone = skin.skeleton.bones.iter().position(|b| b.name == "wrist").unwrap() as u32;
    for v in hand.vertices.clone() {
        let inf = skin.influences[v as usize];
        assert_eq!((inf.joints[0], inf.weights[0], inf.weights[1]), (wrist_bone, 1.0, 0.0));
    }
    for v in prop.vertices.clone() {
        assert!(skin.influences[v as usize].weights.iter().all(|&w| w == 0.0));
    }
    // Hand origin at wrist (0,2,0) + (0,0.5,0); its top cap centre (local (0,2,0)) is at (0,4.5,0).
    let top =
        hand.vertices.clone().find(|&v| m.positions[v as usize].distance(Vec3::new(0.0, 4.5, 0.0)) < 1e-6).unwrap();
    let pose = |t: f32| {
        let w = world_matrices(&skin.skeleton, &sample_local(&skin.skeleton, Some(0), t));
        skin_vertices(skin, &joint_matrices(&skin.skeleton, &w))
    };
    assert!(pose(0.0).iter().zip(&m.positions).all(|(a, b)| a.distance(*b) < 1e-5));
    // Elbow at 90° about Z: the point 3.5 above the elbow goes to (0,1,0) + R_z(90°)(0,3.5,0).
    let p = pose(1.0);
    assert!(p[top as usize].distance(Vec3::new(-3.5, 1.0, 0.0)) < 1e-5, "{}", p[top as usize]);
    for v in prop.vertices.clone() {
        assert_eq!(p[v as usize], m.positions[v as usize]);
    }
}

#[test]
fn content_hash_is_fnv_of_all_inputs_in_order() {
    let imp = load_mesh(&fixture("textured-cube/textured-cube.gltf")).unwrap();
    let mut h = Fnv1a64::new();
    for p in &imp.inputs {
        h.write(&std::fs::read(p).unwrap());
    }
    assert_eq!(h.finish(), imp.content_hash);
    assert_eq!(imp.inputs.len(), 3);
}

#[test]
fn mutated_documents_never_panic() {
    let p = fixture("skinned-arm.gltf");
    let text = read(&p);
    let bytes = text.as_bytes();
    // Every 5th byte replaced by a few structural characters, then every 97th prefix.
    for i in (0..bytes.len()).step_by(5) {
        for v in [b'9', b'-', b'"', b'0'] {
            let mut b = bytes.to_vec();
            b[i] = v;
            let _ = load_mesh_from_bytes(&p, &b);
        }
    }
    for n in (0..bytes.len()).step_by(97) {
        let _ = load_mesh_from_bytes(&p, &bytes[..n]);
    }
}

#[test]
fn texture_transform_texcoord_override_and_missing_set_warns() {
    let path = fixture("textured-cube/textured-cube.gltf");
    let json = read(&path).replace(
        r#""baseColorTexture": {
     "index": 0
    }"#,
        r#""baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform":
            {"texCoord": 1, "offset": [0.25, 0.5], "rotation": 1.5, "scale": [2.0, 3.0]}}}"#,
    );
    assert!(json.contains("KHR_texture_transform"), "fixture layout changed");
    let json = json.replacen(
        r#""asset": {"#,
        r#""extensionsUsed": ["KHR_texture_transform"], "extensionsRequired": ["KHR_texture_transform"], "asset": {"#,
        1,
    );
    let imp = load_mesh_from_bytes(&path.with_file_name("tt.gltf"), json.as_bytes()).unwrap();
    let t = imp.mesh.materials[0].base_color_texture.as_ref().unwrap();
    assert_eq!(t.uv_set, 1);
    assert_eq!((t.transform.offset, t.transform.rotation_rad, t.transform.scale), ([0.25, 0.5], 1.5, [2.0, 3.0]));
    assert!(imp.warnings.iter().any(|w| w.0.contains("TEXCOORD_1")), "{:?}", imp.warnings);
}

/// Extensions listed in `extensionsUsed` that the importer does not read and that may change what
/// it should bake (hidden nodes, material variants, a vendor's unknown one) get one warning naming
/// each; implemented or harmless ones (material appearance, lights) none.
#[test]
fn unknown_used_extensions_are_named_in_one_warning() {
    let path = fixture("textured-cube/textured-cube.gltf");
    let with_used = |list: &str| {
        let json = read(&path).replacen(r#""asset": {"#, &format!(r#""extensionsUsed": [{list}], "asset": {{"#), 1);
        assert!(json.contains("extensionsUsed"), "fixture layout changed");
        load_mesh_from_bytes(&path.with_file_name("used.gltf"), json.as_bytes()).unwrap()
    };
    let named = |imp: &spherebake_io::Imported| -> Vec<String> {
        imp.warnings.iter().filter(|w| w.0.contains("not read:")).map(|w| w.0.clone()).collect()
    };
    let imp = with_used(
        r#""KHR_materials_emissive_strength", "KHR_node_visibility", "KHR_lights_punctual",
            "KHR_materials_variants", "VENDOR_thing", "KHR_node_visibility", "KHR_texture_transform""#,
    );
    let w = named(&imp);
    assert_eq!(w.len(), 1, "{:?}", imp.warnings);
    assert!(w[0].contains("not read: KHR_node_visibility, KHR_materials_variants, VENDOR_thing ("), "{}", w[0]);
    let imp = with_used(r#""KHR_materials_emissive_strength", "KHR_lights_punctual", "KHR_texture_transform""#);
    assert!(named(&imp).is_empty(), "{:?}", imp.warnings);
    // The same mesh either way: the warning is all that changes.
    assert_eq!(with_used(r#""VENDOR_thing""#).mesh.triangles, imp.mesh.triangles);
}

/// Colours outside [0, 1] (an albedo above 1 reflects more than it receives; glTF bounds
/// `baseColorFactor` to [0, 1], OBJ `Kd` is unchecked) are clamped with one warning: glTF
/// [5, −1, 1e30, 1] → [1, 0, 1, 1]; OBJ `Kd -5 1e30 nan` → [0, 1, 0]; in-range colours unchanged.
#[test]
fn out_of_range_colours_are_clamped_with_a_warning() {
    let path = fixture("textured-cube/textured-cube.gltf");
    let json = read(&path);
    let at = json.find(r#""baseColorFactor": ["#).expect("fixture has a base colour factor");
    let end = at + json[at..].find(']').unwrap() + 1;
    let patched = format!(r#"{}"baseColorFactor": [5, -1, 1e30, 1]{}"#, &json[..at], &json[end..]);
    let imp = load_mesh_from_bytes(&path.with_file_name("bcf.gltf"), patched.as_bytes()).unwrap();
    assert_eq!(imp.mesh.materials[0].base_color_factor_linear, [1.0, 0.0, 1.0, 1.0]);
    let clamped = |w: &[spherebake_io::Warning]| w.iter().filter(|w| w.0.contains("outside [0, 1] clamped")).count();
    assert_eq!(clamped(&imp.warnings), 1, "{:?}", imp.warnings);
    let plain = load_mesh_from_bytes(&path, json.as_bytes()).unwrap();
    assert_eq!(clamped(&plain.warnings), 0, "{:?}", plain.warnings);

    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("k.mtl"), "newmtl m\nKd -5 1e30 nan\n").unwrap();
    let obj = "mtllib k.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
    std::fs::write(dir.path().join("t.obj"), obj).unwrap();
    let imp = load_mesh(&dir.path().join("t.obj")).unwrap();
    assert_eq!(imp.mesh.materials[0].base_color_factor_linear[..3], [0.0, 1.0, 0.0]);
    assert_eq!(clamped(&imp.warnings), 1, "{:?}", imp.warnings);
}

#[test]
fn normalized_u8_vertex_colours_are_read_as_linear_values() {
    // COLOR_0 as normalized unsigned bytes, VEC4: 255 → 1.0, 51 → 0.2 (glTF: c / 255, no sRGB).
    let mut bin: Vec<u8> =
        [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]].iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    bin.extend([255, 51, 0, 255, 0, 255, 51, 102, 51, 51, 51, 0]);
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"COLOR_0":1}}}}]}}],
"buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":12}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
{{"bufferView":1,"componentType":5121,"normalized":true,"count":3,"type":"VEC4"}}]}}"#,
        bin.len(),
        b64(&bin)
    );
    let imp = load_mesh_from_bytes(Path::new("mem/c.gltf"), json.as_bytes()).unwrap();
    assert_eq!(imp.mesh.colors_linear, vec![[1.0, 0.2, 0.0, 1.0], [0.0, 1.0, 0.2, 0.4], [0.2, 0.2, 0.2, 0.0]]);
}

fn b64(data: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in data.chunks(3) {
        let n =
            (u32::from(c[0]) << 16) | (u32::from(*c.get(1).unwrap_or(&0)) << 8) | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            s.push(if k <= c.len() { A[(n >> (18 - 6 * k)) as usize & 63] as char } else { '=' });
        }
    }
    s
}
