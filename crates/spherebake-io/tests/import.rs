//! Importer behaviour on the repository fixtures, a few shared models (skipped when absent) and
//! small byte strings built here for every error case.

use std::path::{Path, PathBuf};

use spherebake_geom::glam::Vec3;
use spherebake_geom::topology::TopologyReport;
use spherebake_geom::{FilterMode, WrapMode};
use spherebake_io::{load_mesh, load_mesh_from_bytes, load_mesh_from_memory, ImportOptions, IoError};
use spherebake_testkit::shared_models_dir;

fn fixture(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures").join(p)
}

fn b64(data: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in data.chunks(3) {
        let n =
            (u32::from(c[0]) << 16) | (u32::from(*c.get(1).unwrap_or(&0)) << 8) | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            if k <= c.len() {
                s.push(A[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// A one-primitive glTF: positions (+ optional u16 indices) in one buffer, embedded as a data URI
/// (`bin_uri = None`) or referenced as GLB BIN (`Some("")`). `extra` is spliced into the root.
fn gltf_json(positions: &[[f32; 3]], indices: Option<&[u16]>, glb: bool, extra: &str) -> (String, Vec<u8>) {
    let mut bin: Vec<u8> = positions.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    let pos_len = bin.len();
    if let Some(ix) = indices {
        bin.extend(ix.iter().flat_map(|i| i.to_le_bytes()));
    }
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let uri =
        if glb { String::new() } else { format!(r#","uri":"data:application/octet-stream;base64,{}""#, b64(&bin)) };
    let (idx_attr, idx_view, idx_acc) = match indices {
        Some(ix) => (
            r#","indices":1"#.to_string(),
            format!(r#",{{"buffer":0,"byteOffset":{pos_len},"byteLength":{}}}"#, ix.len() * 2),
            format!(r#",{{"bufferView":1,"componentType":5123,"count":{},"type":"SCALAR"}}"#, ix.len()),
        ),
        None => Default::default(),
    };
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"name":"m","primitives":[{{"attributes":{{"POSITION":0}}{idx_attr}}}]}}],
"buffers":[{{"byteLength":{}{uri}}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{pos_len}}}{idx_view}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":{},"type":"VEC3"}}{idx_acc}]{extra}}}"#,
        bin.len(),
        positions.len()
    );
    (json, bin)
}

fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    let total = 12 + 8 + j.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(0x4E4F_534Au32.to_le_bytes());
    out.extend(&j);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(0x004E_4942u32.to_le_bytes());
    out.extend(bin);
    out
}

/// The error of an import that must fail (without printing the whole mesh when it does not).
fn refused(r: Result<spherebake_io::Imported, IoError>, why: &str) -> IoError {
    match r {
        Ok(_) => panic!("{why}: imported"),
        Err(e) => e,
    }
}

const TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

/// The triangle twice, as two primitives with materials 0 and 1 (`extra` defines them).
fn two_material_gltf(extra: &str) -> String {
    let (json, _) = gltf_json(&TRI, Some(&[0, 1, 2]), false, extra);
    json.replace(
        r#""indices":1}"#,
        r#""indices":1,"material":0},{"attributes":{"POSITION":0},"indices":1,"material":1}"#,
    )
}

#[test]
fn built_gltf_and_glb_import() {
    let (json, _) = gltf_json(&TRI, Some(&[0, 1, 2]), false, "");
    let imp = load_mesh_from_bytes(Path::new("mem/tri.gltf"), json.as_bytes()).unwrap();
    assert_eq!(imp.mesh.triangles, vec![[0, 1, 2]]);
    // No NORMAL: flat shading (§3.7.2.1), each triangle by its geometric normal.
    assert_eq!(imp.mesh.normals, vec![spherebake_geom::normals::NO_NORMAL; 3]);
    assert!(imp.mesh.skin.is_none());
    let (json, bin) = gltf_json(&TRI, None, true, "");
    let imp = load_mesh_from_bytes(Path::new("mem/tri.glb"), &glb(&json, &bin)).unwrap();
    assert_eq!(imp.mesh.triangles, vec![[0, 1, 2]]);
    assert_eq!(imp.mesh.positions[1], Vec3::X);
}

#[test]
fn textured_cube_fixture_external_bin_and_srgb_texels() {
    let imp = load_mesh(&fixture("textured-cube/textured-cube.gltf")).unwrap();
    let names: Vec<_> = imp.inputs.iter().map(|p| p.file_name().unwrap().to_str().unwrap().to_owned()).collect();
    assert_eq!(names, ["textured-cube.gltf", "textured-cube.bin", "textured-cube.png"]);
    assert!(imp.warnings.is_empty(), "{:?}", imp.warnings);
    let m = &imp.mesh;
    assert_eq!((m.positions.len(), m.triangles.len(), m.uvs.len(), m.uvs[0].len()), (24, 12, 1, 24));
    let r = TopologyReport::compute(m);
    assert!(r.closed && r.consistently_oriented && (r.signed_volume - 1.0).abs() < 1e-9, "{r:?}");
    let tr = m.materials[0].base_color_texture.as_ref().unwrap();
    assert_eq!(
        (tr.wrap_s, tr.wrap_t, tr.mag_filter, tr.uv_set),
        (WrapMode::Repeat, WrapMode::Repeat, FilterMode::Nearest, 0)
    );
    let t = &m.textures[tr.texture];
    assert_eq!((t.width, t.height), (4, 4));
    // Generator: texel (x, y) = [red, green, blue, grey 188][(x + 2y) % 4], row 0 = top.
    assert_eq!(t.texels_linear[0], [1.0, 0.0, 0.0, 1.0]);
    assert_eq!(t.texels_linear[1], [0.0, 1.0, 0.0, 1.0]);
    // (3, 0) = sRGB 188 → linear 0.50289 (sRGB EOTF tables); (1, 1) = index 3 as well.
    for i in [3, 5] {
        let g = t.texels_linear[i];
        assert!((g[0] - 0.502_886).abs() < 2e-5 && g[0] == g[1] && g[1] == g[2] && g[3] == 1.0, "{g:?}");
    }
    // (0, 1) = index 2: blue.
    assert_eq!(t.texels_linear[4], [0.0, 0.0, 1.0, 1.0]);
}

#[test]
fn capsule_obj_with_mtl() {
    let imp = load_mesh(&fixture("capsule.obj")).unwrap();
    assert_eq!(imp.inputs.len(), 2, "{:?}", imp.inputs);
    let m = &imp.mesh;
    // 32 cap triangles + 176 quads triangulated.
    assert_eq!(m.triangles.len(), 384);
    let r = TopologyReport::compute(m);
    assert_eq!(r.welded_vertex_count, 194);
    assert!(r.closed && r.consistently_oriented && r.component_count == 1);
    // Euler characteristic 2 (genus 0): V − E + F.
    assert_eq!(194 - r.edge_count as i64 + 384, 2);
    assert!(r.signed_volume > 0.0, "outward winding");
    // Inscribed polyhedron: below the analytic capsule volume π r² 2h + 4/3 π r³ = 1.309.
    let analytic = std::f64::consts::PI * 0.25 + 4.0 / 3.0 * std::f64::consts::PI * 0.125;
    assert!(r.signed_volume < analytic && r.signed_volume > 0.9 * analytic, "{}", r.signed_volume);
    assert_eq!(m.materials.len(), 1);
    assert_eq!(m.materials[0].base_color_factor_linear, [0.8, 0.3, 0.2, 1.0]);
    assert!(m.uvs.is_empty());
}

#[test]
fn obj_uv_flip_and_missing_mtl_and_texture_warn() {
    let dir = tempfile::tempdir().unwrap();
    let obj = "mtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.25 0.125\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
    std::fs::write(dir.path().join("a.obj"), obj).unwrap();
    let imp = load_mesh(&dir.path().join("a.obj")).unwrap();
    assert_eq!(imp.mesh.uvs[0][0], [0.25, 0.875], "v' = 1 − v");
    assert!(imp.warnings.iter().any(|w| w.0.contains("missing.mtl")), "{:?}", imp.warnings);
    // MTL present, its texture missing: a warning, Kd used.
    std::fs::write(dir.path().join("b.mtl"), "newmtl m\nKd 0.5 0.25 1\nmap_Kd nothere.png\n").unwrap();
    std::fs::write(dir.path().join("b.obj"), format!("mtllib b.mtl\nusemtl m\n{obj}")).unwrap();
    let imp = load_mesh(&dir.path().join("b.obj")).unwrap();
    assert!(imp.warnings.iter().any(|w| w.0.contains("nothere.png")), "{:?}", imp.warnings);
    let mat = &imp.mesh.materials[imp.mesh.triangle_materials[0] as usize];
    assert_eq!(mat.base_color_factor_linear, [0.5, 0.25, 1.0, 1.0]);
    assert!(mat.base_color_texture.is_none());
    // Only the library's warning when it is missing (not one per name it would define).
    let imp = load_mesh_from_bytes(Path::new("mem/a.obj"), format!("usemtl m\n{obj}").as_bytes()).unwrap();
    assert_eq!(imp.warnings.len(), 1, "{:?}", imp.warnings);
}

/// Duplicate triangles (either winding) are removed at import, for every command that reads
/// the model, and each part's triangle range is the part's kept triangles.
#[test]
fn duplicate_triangles_are_removed_at_import_and_parts_keep_their_triangles() {
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\no a\nf 1 2 3\nf 3 2 1\nf 2 3 1\nf 1 2 4\no b\nf 1 4 2\nf 1 3 4\nf 2 3 4\nf 4 3 2\n";
    let imp = load_mesh_from_bytes(Path::new("mem/x.obj"), obj.as_bytes()).unwrap();
    assert_eq!(imp.mesh.triangles.len(), 4, "{:?}", imp.mesh.triangles);
    assert!(imp.warnings.iter().any(|w| w.0.starts_with("4 duplicate triangles")), "{:?}", imp.warnings);
    let ranges: Vec<_> = imp.parts.iter().map(|p| p.triangles.clone()).collect();
    assert_eq!(ranges, vec![0..2, 2..4]);
    // A CR-only library with a short `Kd` is a parse warning, not a panic in tobj.
    let files = std::collections::BTreeMap::from([(PathBuf::from("mem/m.mtl"), b"newmtl red\rKd 1 0\r".to_vec())]);
    let imp = load_mesh_from_memory(
        Path::new("mem/x.obj"),
        b"mtllib m.mtl\nusemtl red\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        files,
        &ImportOptions::default(),
    )
    .unwrap();
    assert!(imp.warnings.iter().any(|w| w.0.contains("cannot parse material library")), "{:?}", imp.warnings);
}

/// A `usemtl` name no library defines gets the default material and one warning naming it,
/// with or without a library; names that are defined give none.
#[test]
fn obj_usemtl_names_no_library_defines_are_warned_about() {
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let mtl = b"newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n".to_vec();
    let load = |obj: String| {
        let files = std::collections::BTreeMap::from([(PathBuf::from("mem/m.mtl"), mtl.clone())]);
        load_mesh_from_memory(Path::new("mem/x.obj"), obj.as_bytes(), files, &ImportOptions::default()).unwrap()
    };
    // The copies of `tri` are duplicate triangles, warned about apart.
    let named = |imp: &spherebake_io::Imported| -> Vec<String> {
        imp.warnings.iter().map(|w| w.0.clone()).filter(|w| !w.contains("duplicate triangles")).collect()
    };
    let imp = load(format!("mtllib m.mtl\nusemtl red\n{tri}usemtl blue\n{tri}"));
    assert!(named(&imp).is_empty(), "{:?}", imp.warnings);
    // Of two libraries, one that does not parse is named (tobj drops its error when another
    // library reads), and its materials are not called undefined.
    let files = std::collections::BTreeMap::from([
        (PathBuf::from("mem/a.mtl"), b"newmtl red\nKd 1 0 0\n".to_vec()),
        (PathBuf::from("mem/b.mtl"), b"newmtl blue\nKd 0 0\n".to_vec()),
    ]);
    let obj = format!("mtllib a.mtl\nmtllib b.mtl\nusemtl red\n{tri}usemtl blue\n{tri}");
    let imp = load_mesh_from_memory(Path::new("mem/x.obj"), obj.as_bytes(), files, &ImportOptions::default()).unwrap();
    let w = named(&imp);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].contains("b.mtl: cannot parse material library"), "{w:?}");
    // A name used before its library is looked up in it too (as Blender does: it reads the
    // libraries after the OBJ): no warning, and the faces before and after are red.
    for obj in [
        format!("usemtl red\n{tri}mtllib m.mtl\nusemtl red\n{tri}"),
        format!("usemtl red\n{tri}usemtl blue\nv 0 0 1\nf 1 2 4\nmtllib m.mtl\n"),
    ] {
        let imp = load(obj.clone());
        assert!(named(&imp).is_empty(), "{obj:?}: {:?}", imp.warnings);
        let colour = |t: usize| imp.mesh.materials[imp.mesh.triangle_materials[t] as usize].base_color_factor_linear;
        assert_eq!(colour(0), [1.0, 0.0, 0.0, 1.0], "{obj:?}");
        let last = if obj.contains("blue") { [0.0, 0.0, 1.0, 1.0] } else { [1.0, 0.0, 0.0, 1.0] };
        assert_eq!(colour(imp.mesh.triangles.len() - 1), last, "{obj:?}");
        assert!(imp.mesh.materials.iter().all(|m| m.name != "default"), "{obj:?}");
    }
    let cases = [
        (format!("mtllib m.mtl\nusemtl Red\n{tri}"), "usemtl \"Red\": no material library defines it"),
        (format!("usemtl red\n{tri}"), "usemtl \"red\": no material library defines it"),
        // The first in the file is named.
        (format!("mtllib m.mtl\nusemtl x\n{tri}usemtl red\n{tri}usemtl w\n{tri}"), "usemtl \"x\" (and 1 more)"),
        // A name used before the libraries that no library defines.
        (format!("usemtl rot\n{tri}mtllib m.mtl\nusemtl blue\n{tri}"), "usemtl \"rot\": no material library"),
    ];
    for (obj, want) in cases {
        let imp = load(obj.clone());
        let w = named(&imp);
        assert_eq!(w.len(), 1, "{obj:?}: {:?}", imp.warnings);
        assert!(w[0].contains(want), "{obj:?}: {:?}", imp.warnings);
        assert!(imp.mesh.materials.iter().any(|m| m.name == "default"), "{obj:?}");
    }
}

#[test]
fn gltf_missing_or_bad_texture_warns_and_uses_factor() {
    let dir = tempfile::tempdir().unwrap();
    let extra = r#","materials":[{"pbrMetallicRoughness":{"baseColorFactor":[0.5,0.5,0.5,1],"baseColorTexture":{"index":0}}},{"pbrMetallicRoughness":{"baseColorTexture":{"index":1}}}],"textures":[{"source":0},{"source":1}],"images":[{"uri":"gone.png"},{"uri":"data:image/png;base64,AAAA"}]"#;
    let json = two_material_gltf(extra);
    let p = dir.path().join("t.gltf");
    std::fs::write(&p, json).unwrap();
    let imp = load_mesh(&p).unwrap();
    assert_eq!(imp.mesh.materials.len(), 2);
    assert!(imp.mesh.materials.iter().all(|m| m.base_color_texture.is_none()));
    assert_eq!(imp.mesh.materials[0].base_color_factor_linear, [0.5, 0.5, 0.5, 1.0]);
    assert!(imp.warnings.iter().any(|w| w.0.contains("gone.png")), "{:?}", imp.warnings);
    assert!(imp.warnings.iter().any(|w| w.0.contains("decode")), "{:?}", imp.warnings);
}

#[test]
fn error_cases_name_the_file() {
    let p = Path::new("mem/x.glb");
    let check = |bytes: &[u8], path: &Path, ok: &dyn Fn(&IoError) -> bool| {
        let e = load_mesh_from_bytes(path, bytes).unwrap_err();
        assert!(ok(&e), "unexpected error {e:?}");
        assert!(e.to_string().contains(path.to_str().unwrap()), "{e}");
    };
    // Missing file.
    let e = load_mesh(Path::new("/nonexistent/spherebake/missing.gltf")).unwrap_err();
    assert!(matches!(e, IoError::NotFound { .. }) && e.to_string().contains("missing.gltf"));
    // Wrong magic, truncated header, truncated chunk.
    check(b"GLTF\x02\0\0\0\x0c\0\0\0", p, &|e| matches!(e, IoError::WrongMagic { .. }));
    check(b"glTF\x02\0", p, &|e| matches!(e, IoError::Truncated { .. }));
    let (json, bin) = gltf_json(&TRI, None, true, "");
    let full = glb(&json, &bin);
    check(&full[..full.len() - 5], p, &|e| matches!(e, IoError::Truncated { .. }));
    let mut short = full.clone();
    let n = short.len() - 5;
    short[8..12].copy_from_slice(&(n as u32).to_le_bytes());
    short.truncate(n);
    check(&short, p, &|e| matches!(e, IoError::Truncated { what, .. } if what.contains("chunk")));
    let g = Path::new("mem/x.gltf");
    // Index out of range.
    let (json, _) = gltf_json(&TRI, Some(&[0, 1, 3]), false, "");
    check(json.as_bytes(), g, &|e| matches!(e, IoError::IndexOutOfRange { index: 3, vertex_count: 3, .. }));
    // NaN position, named by mesh, primitive and vertex.
    let (json, _) = gltf_json(&[[0.0; 3], [1.0, f32::NAN, 0.0], [0.0, 1.0, 0.0]], None, false, "");
    check(json.as_bytes(), g, &|e| matches!(e, IoError::NonFinitePosition { vertex: 1, primitive: 0, mesh: 0, .. }));
    // Empty mesh: a point primitive only (skipped with a warning), so no triangles.
    let (json, _) = gltf_json(&TRI, None, false, "");
    let json = json.replace(r#""attributes":{"POSITION":0}"#, r#""attributes":{"POSITION":0},"mode":0"#);
    check(json.as_bytes(), g, &|e| matches!(e, IoError::EmptyMesh { .. }));
    // Required extension we do not implement.
    let (json, _) = gltf_json(
        &TRI,
        None,
        false,
        r#","extensionsUsed":["KHR_draco_mesh_compression"],"extensionsRequired":["KHR_draco_mesh_compression"]"#,
    );
    check(
        json.as_bytes(),
        g,
        &|e| matches!(e, IoError::UnsupportedExtension { extension, .. } if extension == "KHR_draco_mesh_compression"),
    );
    // Bad JSON; schema violation (accessor index that does not exist).
    check(b"{\"asset\": ", g, &|e| matches!(e, IoError::Json { .. }));
    let (json, _) = gltf_json(&TRI, None, false, "");
    check(json.replace(r#""POSITION":0"#, r#""POSITION":7"#).as_bytes(), g, &|e| matches!(e, IoError::Invalid { .. }));
    // Accessor larger than its buffer view.
    let (json, _) = gltf_json(&TRI, None, false, "");
    check(json.replace(r#""count":3,"type":"VEC3""#, r#""count":4,"type":"VEC3""#).as_bytes(), g, &|e| {
        matches!(e, IoError::Accessor { accessor: 0, .. })
    });
    // Unknown file type; OBJ with a face past the vertex list.
    check(b"", Path::new("mem/x.fbx"), &|e| matches!(e, IoError::UnknownFileType { .. }));
    check(b"v 0 0 0\nv 1 0 0\nf 1 2 3\n", Path::new("mem/x.obj"), &|e| {
        matches!(e, IoError::Obj { .. } | IoError::IndexOutOfRange { .. })
    });
}

#[test]
fn arbitrary_bytes_never_panic() {
    // Mutations of a valid GLB: every outcome must be Ok or Err.
    let (json, bin) = gltf_json(&TRI, Some(&[0, 1, 2]), true, "");
    let base = glb(&json, &bin);
    let p = Path::new("mem/f.glb");
    for i in 0..base.len() {
        for v in [0u8, 0xff, b'9', b'"'] {
            let mut b = base.clone();
            b[i] = v;
            let _ = load_mesh_from_bytes(p, &b);
        }
        let _ = load_mesh_from_bytes(p, &base[..i]);
    }
}

#[test]
fn fox_is_non_indexed() {
    let Some(d) = shared_models_dir() else { return };
    let imp = load_mesh(&d.join("gltf/Fox.glb")).unwrap();
    assert_eq!(imp.parts.len(), 1);
    assert_eq!((imp.parts[0].file_vertex_count, imp.mesh.triangles.len()), (1728, 576));
    // Non-indexed: triangle t uses vertices 3t, 3t+1, 3t+2.
    assert!(imp
        .mesh
        .triangles
        .iter()
        .enumerate()
        .all(|(t, tri)| *tri == [3 * t as u32, 3 * t as u32 + 1, 3 * t as u32 + 2]));
    let skin = imp.mesh.skin.as_ref().unwrap();
    let names: Vec<&str> = skin.skeleton.animations.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["Survey", "Walk", "Run"]);
}

#[test]
fn texture_transform_values() {
    let Some(d) = shared_models_dir() else { return };
    let imp = load_mesh(&d.join("gltf/TextureTransformTest/TextureTransformTest.gltf")).unwrap();
    let by_name = |n: &str| {
        let m = imp.mesh.materials.iter().find(|m| m.name == n).unwrap();
        m.base_color_texture.clone().unwrap()
    };
    // Values from the file's KHR_texture_transform objects.
    assert_eq!(by_name("Offset U").transform.offset, [0.5, 0.0]);
    assert_eq!(by_name("Offset V").transform.offset, [0.0, 0.5]);
    assert_eq!(by_name("Offset UV").transform.offset, [0.5, 0.5]);
    // The file stores 0.39269908169872414 = π/8.
    assert!((by_name("Rotation").transform.rotation_rad - std::f32::consts::FRAC_PI_8).abs() < 1e-7);
    assert_eq!(by_name("Scale").transform.scale, [1.5, 1.5]);
    let all = by_name("All").transform;
    assert_eq!((all.offset, all.rotation_rad, all.scale), ([-0.2, -0.1], 0.3, [1.5, 1.5]));
    let c = by_name("Correct");
    assert_eq!((c.transform.offset, c.transform.scale), ([0.0, 0.0], [1.0, 1.0]));
    // Sampler 0: CLAMP_TO_EDGE both ways, LINEAR magnification.
    let o = by_name("Offset U");
    assert_eq!((o.wrap_s, o.wrap_t, o.mag_filter), (WrapMode::ClampToEdge, WrapMode::ClampToEdge, FilterMode::Linear));
    assert_eq!(imp.mesh.textures[o.texture].name, "UV.png");
}

#[test]
fn spot_obj_finds_its_texture_through_the_mtl() {
    let Some(d) = shared_models_dir() else { return };
    let imp = load_mesh(&d.join("obj/spot/spot.obj")).unwrap();
    assert!(imp.warnings.is_empty(), "{:?}", imp.warnings);
    let tr = imp.mesh.materials[0].base_color_texture.as_ref().unwrap();
    let t = &imp.mesh.textures[tr.texture];
    assert_eq!((t.name.as_str(), t.width, t.height), ("spot_texture.png", 1024, 1024));
    let names: Vec<_> = imp.inputs.iter().map(|p| p.file_name().unwrap().to_str().unwrap().to_owned()).collect();
    assert_eq!(names, ["spot.obj", "spot.mtl", "spot_texture.png"]);
    assert_eq!(imp.mesh.uvs.len(), 1);
    // The published spot_triangulated.obj has the same geometry and UVs but no material.
    let plain = load_mesh(&d.join("obj/spot/spot_triangulated.obj")).unwrap();
    assert_eq!(plain.mesh.positions, imp.mesh.positions);
    assert_eq!(plain.mesh.uvs, imp.mesh.uvs);
    assert!(plain.mesh.textures.is_empty());
    assert_ne!(plain.content_hash, imp.content_hash);
}

#[test]
fn box_vertex_colors_are_read() {
    let Some(d) = shared_models_dir() else { return };
    let imp = load_mesh(&d.join("gltf/BoxVertexColors.glb")).unwrap();
    assert_eq!(imp.mesh.colors_linear.len(), 24);
    assert!(imp.mesh.colors_linear.iter().any(|c| c[0] != c[1] || c[1] != c[2]), "coloured");
}

/// What the line check accepts, tobj reads the same way: a comment after data, a `\`-continued
/// line and bytes that are not UTF-8 (a Latin-1 comment or name) import as the plain file does,
/// where tobj alone failed with "color parse error", "face parse error" or "read error" and no
/// line; and tobj's own line errors are found by the check first, with the line.
#[test]
fn obj_files_read_as_checked_and_tobjs_errors_name_the_line() {
    let p = Path::new("mem/x.obj");
    let plain = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n".as_slice();
    let want = load_mesh_from_bytes(p, plain).unwrap();
    assert_eq!(want.mesh.triangles.len(), 4);
    let mut latin1 = b"# caf\xe9\no W\xfcrfel\n".to_vec();
    latin1.extend_from_slice(plain);
    // Classic Mac OS line ends (`\r` alone), and a mix of all three kinds.
    let cr: Vec<u8> = plain.iter().map(|&c| if c == b'\n' { b'\r' } else { c }).collect();
    let variants: [&[u8]; 12] = [
        &cr,
        b"v 0 0 0\r\nv 1 0 0\rv 0 1 0\nv 0 0 1\r\rf 1 3 2\r\nf 1 2 4\rf 1 4 3\nf 2 3 4",
        b"v 0 0 0 # origin\nv 1 0 0#x\nv 0 1 0\nv 0 0 1 # 1 2\nf 1 3 2 # base\nf 1 2 4\nf 1 4 3\nf 2 3 4#\n",
        b"v 0 0 \\\n0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 \\\n 3 \\\n 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
        b"v 0 0 0\r\nv 1 0 0 \\\r\n\r\nv 0 1 0\r\nv 0 0 1\r\nf 1 3 2\r\nf 1 2 4\r\nf 1 4 3\r\nf 2 3 4\r\n",
        &latin1,
        b"v 0 0 0 1\nv 2 0 0 2\nv 0 1 0\nvt 0 1 # uv\nvn 0 0 1 #n\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
        b"v 0 0 0 1 0 0\nv 1 0 0 0 1 0 # green\nv 0 1 0 0 0 1\nv 0 0 1 1 1 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
        // A line element is no surface (tobj made it a zero-area triangle, and the closed
        // tetrahedron non-manifold).
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nl 1 2 3\nf 1 2 4\nf 1 4 3\nf 2 3 4\nl 4 1\n",
        // Colours on some vertices only (tobj would misplace them: the others are given white),
        // and one that is not three numbers.
        b"v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0 0.5 x 1\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
        // A comment's or a name's `\\` continues nothing; a data line continued into the end.
        b"# exported from C:\\work\\\nv 0 0 0\no part \\\nv 1 0 0\nv 0 1 0\nv 0 0 1 # a \\\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 \\\n4 \\",
        // An empty vertex slot after the normal's.
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\nf 1//1/ 3//1 2//1\nf 1//1 2//1 4//1/\nf 1//1 4//1 3//1\nf 2//1 3//1 4//1\n",
    ];
    for (i, v) in variants.iter().enumerate() {
        let got = load_mesh_from_bytes(p, v).unwrap_or_else(|e| panic!("variant {i}: {e}"));
        // The same triangles over the same positions (a file with `vn` has no vertex split
        // at the tetrahedron's sharp edges, so the vertices are compared through the corners).
        let corners = |m: &spherebake_io::Mesh| -> Vec<[Vec3; 3]> {
            m.triangles.iter().map(|t| t.map(|v| m.positions[v as usize])).collect()
        };
        assert_eq!(corners(&got.mesh), corners(&want.mesh), "variant {i}");
    }
    let msg = |src: &str| match load_mesh_from_bytes(p, src.as_bytes()) {
        Err(IoError::Obj { message, .. }) => message,
        other => panic!("expected an OBJ line error for {src:?}, got {other:?}"),
    };
    let t = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    assert_eq!(msg(&format!("{t}v 1 1 1 0\n")), "line 5: vertex weight w is 0 (a weight must be finite and not 0)");
    assert_eq!(msg(&format!("{t}v 1 1 1 inf\n")), "line 5: vertex weight w is inf (a weight must be finite and not 0)");
    assert_eq!(msg(&format!("{t}v 1 1 1 w\n")), "line 5: vertex weight \"w\" is not a number");
    for (line, n) in [("v 1 1 1 1 1", 5), ("v 1 1 1 1 1 1 1", 7)] {
        assert_eq!(
            msg(&format!("{t}{line}\n")),
            format!("line 5: vertex with {n} values (expected x y z, x y z w or x y z r g b)")
        );
    }
    assert_eq!(msg(&format!("{t}f 1///1 2 3\n")), "line 5: face corner \"1///1\" has more than three indices");
    assert_eq!(msg(&format!("{t}usemtl  \n")), "line 5: usemtl without a material name");
    assert_eq!(msg(&format!("{t}mtllib\n")), "line 5: mtllib without a file name");
    assert_eq!(msg(&format!("{t}v 1e39 0 0\n")), "line 5: vertex position (1e39 0 0) is not finite in f32");
    assert_eq!(msg(&format!("{t}v 1 0 0 1e-40\n")), "line 5: vertex position (1 0 0) / 1e-40 is not finite in f32");
    // A byte-order mark is not part of the first keyword (the first vertex was lost).
    let mut bom = b"\xEF\xBB\xBF".to_vec();
    bom.extend_from_slice(t.as_bytes());
    let plain = load_mesh_from_bytes(p, t.as_bytes()).unwrap();
    assert_eq!(load_mesh_from_bytes(p, &bom).unwrap().mesh.positions, plain.mesh.positions);
    assert_eq!(msg(&format!("{t}vt 0 y\n")), "line 5: texture coordinate needs one or two numbers (u [v])");
    assert_eq!(msg(&format!("{t}vt\n")), "line 5: texture coordinate needs one or two numbers (u [v])");
    // Lines ended by `\r` alone are counted as an editor shows them (the file was one line).
    assert_eq!(
        msg(&format!("{}\r\nvt x\r", t.replace('\n', "\r"))),
        "line 6: texture coordinate needs one or two numbers (u [v])"
    );
    assert_eq!(msg(&format!("{t}vn 0 0 z\n")), "line 5: normal needs three numbers");
    assert_eq!(msg(&format!("{t}l\n")), "line 5: line element with no vertex");
    assert_eq!(msg(&format!("{t}l 1 7\n")), "line 5: vertex index 7 out of range (3 defined so far)");
}

/// Materials as the OBJ names them: after a comment line ending in `\\` (which continues
/// nothing), with `#` in the name, after a tab, in an MTL that is not UTF-8, and from a
/// library whose name holds `#` in a file tobj is given rewritten (a comment after data).
#[test]
fn obj_materials_are_found_by_their_names() {
    let red = |name: &[u8]| {
        let mut mtl = b"newmtl ".to_vec();
        mtl.extend_from_slice(name);
        mtl.extend_from_slice(b"\nKd 1 0 0\n");
        mtl
    };
    let mut red_cr = red(b"red");
    red_cr.iter_mut().for_each(|c| *c = if *c == b'\n' { b'\r' } else { *c });
    let cases: [(&[u8], &str, Vec<u8>); 9] = [
        // Classic Mac OS line ends, in the library and in the OBJ.
        (b"mtllib m.mtl\nusemtl red\n", "m", red_cr),
        (b"mtllib m.mtl\rusemtl red\r", "m", red(b"red")),
        (b"# exported from C:\\work\\\nmtllib m.mtl\nusemtl red\n", "m", red(b"red")),
        (b"mtllib m.mtl\n# C:\\work\\\nusemtl red\n", "m", red(b"red")),
        (b"mtllib m.mtl\nusemtl red#1\n", "m", red(b"red#1")),
        (b"mtllib m.mtl\nusemtl\tW\xfcrfel\n", "m", red(b"W\xfcrfel")),
        (b"mtllib m#1.mtl\nusemtl red#1\nv 9 9 9 # unused\n", "m#1", red(b"red#1")),
        (b"mtllib\tm.mtl\n usemtl  red\n", "m", red(b"red")),
        (b"\xEF\xBB\xBFmtllib m.mtl\nusemtl red\n", "m", red(b"red")),
    ];
    for (i, (head, lib, mtl)) in cases.into_iter().enumerate() {
        let mut obj = head.to_vec();
        obj.extend_from_slice(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n");
        let files = std::collections::BTreeMap::from([(PathBuf::from(format!("mem/{lib}.mtl")), mtl)]);
        let imp = load_mesh_from_memory(Path::new("mem/x.obj"), &obj, files, &ImportOptions::default())
            .unwrap_or_else(|e| panic!("case {i}: {e}"));
        assert_eq!(imp.mesh.materials.len(), 1, "case {i}");
        assert_eq!(
            imp.mesh.materials[0].base_color_factor_linear,
            [1.0, 0.0, 0.0, 1.0],
            "case {i}: {:?}",
            imp.warnings
        );
    }
}

#[test]
fn obj_line_errors_name_the_line_and_a_continued_line_by_its_first() {
    let p = Path::new("mem/x.obj");
    let msg = |src: &str| match load_mesh_from_bytes(p, src.as_bytes()) {
        Err(IoError::Obj { message, .. }) => message,
        other => panic!("expected an OBJ line error, got {other:?}"),
    };
    // A comment line is not read. The check joins a `\`-continued line and names it by its
    // first line.
    let ok = load_mesh_from_bytes(p, b"v 0 0 0\nv 1 0 0\nv 0 1 0\n# f 9 9\nf 1 2 3\n").unwrap();
    assert_eq!(ok.mesh.triangles.len(), 1);
    assert_eq!(msg("v 0 0 0\nv 1 0 0\n# f 1 2\nf 1 \\\n2\n"), "line 4: face with 2 vertices (a face needs at least 3)");
    assert_eq!(msg("v 0 0 0\nv 1 0 x\n"), "line 2: vertex needs three numbers");
    assert_eq!(
        msg("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 \\\n \\\n 4\n"),
        "line 5: vertex index 4 out of range (3 defined so far)"
    );
}

/// A texture wider than the largest side the bake reads is box-filtered down at decode, in
/// linear values, with a warning naming it; an image whose decoded size passes the decoder's
/// memory cap is refused (a warning, the base colour used) before it is inflated.
#[test]
fn large_textures_are_reduced_at_decode_and_oversized_ones_refused() {
    use spherebake_geom::texels::MAX_TEXTURE_SIDE;
    let dir = tempfile::tempdir().unwrap();
    let obj = "mtllib a.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
    std::fs::write(dir.path().join("a.obj"), obj).unwrap();
    std::fs::write(dir.path().join("a.mtl"), "newmtl m\nKd 0.5 0.5 0.5\nmap_Kd wide.png\n").unwrap();
    // (2 · side + 6) × 3 RGB8 texels with a pattern in x and y: two halvings to
    // (side / 2 + 1) × 1 (the third row is dropped, as the mip chain drops an odd last row).
    let (w, h) = (2 * MAX_TEXTURE_SIDE as u32 + 6, 3u32);
    let texel = |x: u32, y: u32| [(x * 7 % 256) as u8, (y * 90 + 20) as u8, ((x / 3 + y) * 11 % 256) as u8];
    let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb(texel(x, y)));
    img.save(dir.path().join("wide.png")).unwrap();
    let imp = load_mesh(&dir.path().join("a.obj")).unwrap();
    let t = &imp.mesh.textures[0];
    assert_eq!((t.width, t.height), (w / 4, 1));
    assert!(
        imp.warnings.iter().any(|w| w.0.contains("wide.png") && w.0.contains(&format!("{}×1", t.width))),
        "{:?}",
        imp.warnings
    );
    // Independent: the f64 mean of each 4 × 2 block of the sRGB EOTF of its texels.
    let eotf = spherebake_testkit::oracle::srgb8_to_linear;
    for x in 0..t.width {
        for ch in 0..3 {
            let mut s = 0.0;
            for yy in 0..2 {
                for xx in 4 * x..4 * x + 4 {
                    s += eotf(texel(xx, yy)[ch]);
                }
            }
            let got = f64::from(t.texels_linear[x as usize][ch]);
            assert!((got - s / 8.0).abs() < 1e-5, "texel {x} channel {ch}: {got} vs {}", s / 8.0);
        }
        assert_eq!(t.texels_linear[x as usize][3], 1.0);
    }
    // PNG headers of RGBA8 images with an empty image stream: a 40 000² one (6.4 GB
    // decoded) is refused by the cap before anything is inflated; a 16 384² one (1 GiB) passes
    // the cap (the image crate's default, 512 MiB, would refuse it) and fails on its data.
    let header_only = |side: u32| {
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        let mut chunk = |kind: &[u8; 4], data: &[u8]| {
            png.extend_from_slice(&(data.len() as u32).to_be_bytes());
            let body = [&kind[..], data].concat();
            png.extend_from_slice(&body);
            png.extend_from_slice(&crc32fast::hash(&body).to_be_bytes());
        };
        chunk(b"IHDR", &[&side.to_be_bytes()[..], &side.to_be_bytes(), &[8, 6, 0, 0, 0]].concat());
        chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]);
        chunk(b"IEND", &[]);
        std::fs::write(dir.path().join("wide.png"), &png).unwrap();
        let imp = load_mesh(&dir.path().join("a.obj")).unwrap();
        assert!(imp.mesh.textures.is_empty() && imp.mesh.materials[0].base_color_texture.is_none());
        let w = imp.warnings.iter().find(|w| w.0.contains("wide.png") && w.0.contains("cannot decode"));
        w.unwrap_or_else(|| panic!("{:?}", imp.warnings)).0.clone()
    };
    let refused = header_only(40_000);
    assert!(refused.contains("40000×40000 pixels would take more than the 1.25 GiB"), "{refused}");
    let admitted = header_only(16_384);
    assert!(!admitted.contains("limit") && !admitted.contains("GiB"), "{admitted}");
}

/// Each 8- and 16-bit layout (grey, grey + alpha, RGB, RGBA) decodes to the sRGB
/// EOTF of their values per channel (grey to all three), alpha as stored.
#[test]
fn every_pixel_layout_decodes_to_linear_rgba() {
    let eotf = spherebake_testkit::oracle::srgb_to_linear;
    let dir = tempfile::tempdir().unwrap();
    let obj = "mtllib a.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
    std::fs::write(dir.path().join("a.obj"), obj).unwrap();
    std::fs::write(dir.path().join("a.mtl"), "newmtl m\nmap_Kd t.png\n").unwrap();
    let (w, h) = (3u32, 2u32);
    let v = |x: u32, y: u32, c: u32| ((x * 70 + y * 40 + c * 25) % 256) as u8;
    // (image, expected linear RGBA of texel (x, y))
    type Expect = Box<dyn Fn(u32, u32) -> [f64; 4]>;
    let s = move |b: u8| eotf(f64::from(b) / 255.0);
    let cases: Vec<(image::DynamicImage, Expect)> = vec![
        (
            image::GrayImage::from_fn(w, h, |x, y| image::Luma([v(x, y, 0)])).into(),
            Box::new(move |x, y| [s(v(x, y, 0)), s(v(x, y, 0)), s(v(x, y, 0)), 1.0]),
        ),
        (
            image::GrayAlphaImage::from_fn(w, h, |x, y| image::LumaA([v(x, y, 0), v(x, y, 3)])).into(),
            Box::new(move |x, y| [s(v(x, y, 0)), s(v(x, y, 0)), s(v(x, y, 0)), f64::from(v(x, y, 3)) / 255.0]),
        ),
        (
            image::RgbImage::from_fn(w, h, |x, y| image::Rgb([v(x, y, 0), v(x, y, 1), v(x, y, 2)])).into(),
            Box::new(move |x, y| [s(v(x, y, 0)), s(v(x, y, 1)), s(v(x, y, 2)), 1.0]),
        ),
        (
            image::RgbaImage::from_fn(w, h, |x, y| image::Rgba([v(x, y, 0), v(x, y, 1), v(x, y, 2), v(x, y, 3)]))
                .into(),
            Box::new(move |x, y| [s(v(x, y, 0)), s(v(x, y, 1)), s(v(x, y, 2)), f64::from(v(x, y, 3)) / 255.0]),
        ),
        (
            image::ImageBuffer::<image::Rgb<u16>, _>::from_fn(w, h, |x, y| {
                image::Rgb([u16::from(v(x, y, 0)) * 257 + 3, u16::from(v(x, y, 1)) * 257, u16::from(v(x, y, 2)) * 257])
            })
            .into(),
            Box::new(move |x, y| {
                let c = |k: u32, add: f64| eotf((f64::from(v(x, y, k)) * 257.0 + add) / 65535.0);
                [c(0, 3.0), c(1, 0.0), c(2, 0.0), 1.0]
            }),
        ),
        (
            image::ImageBuffer::<image::Luma<u16>, _>::from_fn(w, h, |x, y| image::Luma([u16::from(v(x, y, 0)) * 255]))
                .into(),
            Box::new(move |x, y| {
                let l = eotf(f64::from(v(x, y, 0)) * 255.0 / 65535.0);
                [l, l, l, 1.0]
            }),
        ),
        (
            image::ImageBuffer::<image::LumaA<u16>, _>::from_fn(w, h, |x, y| {
                image::LumaA([u16::from(v(x, y, 0)) * 200, u16::from(v(x, y, 3)) * 256])
            })
            .into(),
            Box::new(move |x, y| {
                let l = eotf(f64::from(v(x, y, 0)) * 200.0 / 65535.0);
                [l, l, l, f64::from(v(x, y, 3)) * 256.0 / 65535.0]
            }),
        ),
        (
            image::ImageBuffer::<image::Rgba<u16>, _>::from_fn(w, h, |x, y| {
                image::Rgba([
                    u16::from(v(x, y, 0)) * 256,
                    u16::from(v(x, y, 1)) * 100,
                    u16::from(v(x, y, 2)) * 257,
                    u16::from(v(x, y, 3)) * 150,
                ])
            })
            .into(),
            Box::new(move |x, y| {
                let c = |k: u32, m: f64| f64::from(v(x, y, k)) * m / 65535.0;
                [eotf(c(0, 256.0)), eotf(c(1, 100.0)), eotf(c(2, 257.0)), c(3, 150.0)]
            }),
        ),
    ];
    for (i, (img, expect)) in cases.into_iter().enumerate() {
        img.save(dir.path().join("t.png")).unwrap();
        let imp = load_mesh(&dir.path().join("a.obj")).unwrap();
        let t = &imp.mesh.textures[0];
        assert_eq!((t.width, t.height), (w, h), "case {i}");
        for y in 0..h {
            for x in 0..w {
                let got = t.texels_linear[(y * w + x) as usize];
                let want = expect(x, y);
                for c in 0..4 {
                    assert!(
                        (f64::from(got[c]) - want[c]).abs() < 1e-6,
                        "case {i} ({x}, {y}) channel {c}: {got:?} vs {want:?}"
                    );
                }
            }
        }
    }
}

/// Morph targets at their default weights: the node's `weights` when present, else the mesh's,
/// else none. Every viewer shows base + Σ wᵢ·targetᵢ at rest, so that is the shape imported.
#[test]
fn morph_targets_are_applied_at_their_default_weights() {
    // Base triangle, then one target moving vertex 2 by (0, 0, 1) and another moving vertex 0
    // by (2, 0, 0).
    let mut bin: Vec<u8> = Vec::new();
    let targets = [[[0.0f32, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]], [[2.0, 0.0, 0.0], [0.0; 3], [0.0; 3]]];
    for p in TRI.iter().chain(targets.iter().flatten()) {
        bin.extend(p.iter().flat_map(|x| x.to_le_bytes()));
    }
    let doc = |node_weights: &str, mesh_weights: &str, target_count: usize| {
        format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0{node_weights}}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"targets":[{{"POSITION":1}},{{"POSITION":2}}]}}]{mesh_weights}}}],
"buffers":[{{"byteLength":108,"uri":"data:application/octet-stream;base64,{}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":36}},{{"buffer":0,"byteOffset":72,"byteLength":36}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}},{{"bufferView":1,"componentType":5126,"count":{target_count},"type":"VEC3"}},{{"bufferView":2,"componentType":5126,"count":3,"type":"VEC3"}}]}}"#,
            b64(&bin)
        )
    };
    let positions =
        |json: String| load_mesh_from_bytes(Path::new("mem/morph.gltf"), json.as_bytes()).unwrap().mesh.positions;
    let base: Vec<Vec3> = TRI.iter().map(|p| Vec3::from(*p)).collect();
    let shifted = |w0: f32, w1: f32| -> Vec<Vec3> {
        let mut p = base.clone();
        p[2].z += w0;
        p[0].x += 2.0 * w1;
        p
    };
    assert_eq!(positions(doc("", "", 3)), base, "no weights: the base shape");
    assert_eq!(positions(doc("", r#","weights":[0,0]"#, 3)), base);
    assert_eq!(positions(doc("", r#","weights":[0.5,0]"#, 3)), shifted(0.5, 0.0), "the mesh's weights");
    assert_eq!(positions(doc("", r#","weights":[0.25,0.5]"#, 3)), shifted(0.25, 0.5), "both targets");
    assert_eq!(
        positions(doc(r#","weights":[1,0]"#, r#","weights":[0.5,0.5]"#, 3)),
        shifted(1.0, 0.0),
        "the node's weights override the mesh's"
    );
    // A target whose count differs from POSITION's is an error naming the file.
    let e = load_mesh_from_bytes(Path::new("mem/morph.gltf"), doc("", r#","weights":[1,0]"#, 2).as_bytes());
    let Err(e) = e else { panic!("a short morph target is refused") };
    assert!(e.to_string().contains("morph.gltf") && e.to_string().contains("morph target 0"), "{e}");
}

/// KHR_materials_pbrSpecularGlossiness (older exporters): its diffuse factor and texture are
/// the albedo, over the metallic-roughness fallback; listed as required it is accepted.
#[test]
fn specular_glossiness_diffuse_is_the_base_colour() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(fixture("textured-cube/textured-cube.png"), dir.path().join("tex.png")).unwrap();
    let extra = r#","extensionsUsed":["KHR_materials_pbrSpecularGlossiness"],"extensionsRequired":["KHR_materials_pbrSpecularGlossiness"],
"materials":[{"name":"sg","pbrMetallicRoughness":{"baseColorFactor":[1,0,0,1]},
  "extensions":{"KHR_materials_pbrSpecularGlossiness":{"diffuseFactor":[0,0.5,0,0.75],"diffuseTexture":{"index":0}}}},
 {"name":"mr","pbrMetallicRoughness":{"baseColorFactor":[1,0,0,1]}}],
"textures":[{"source":0}],"images":[{"uri":"tex.png"}]"#;
    let json = two_material_gltf(extra);
    let p = dir.path().join("sg.gltf");
    std::fs::write(&p, json).unwrap();
    let imp = load_mesh(&p).unwrap();
    let by_name = |n: &str| imp.mesh.materials.iter().find(|m| m.name == n).unwrap();
    let sg = by_name("sg");
    assert_eq!(sg.base_color_factor_linear, [0.0, 0.5, 0.0, 0.75]);
    let t = sg.base_color_texture.as_ref().expect("the diffuse texture");
    assert_eq!(imp.mesh.textures[t.texture].name, "tex.png");
    let mr = by_name("mr");
    assert_eq!(mr.base_color_factor_linear, [1.0, 0.0, 0.0, 1.0]);
    assert!(mr.base_color_texture.is_none());
}

/// An MTL `map_Kd` with options and a file name with spaces: the options are skipped by the
/// MTL specification's argument counts and the rest of the line is the name (it was the last
/// word, so "my tex.png" read "tex.png" and the texture was lost); `-s` becomes the transform.
#[test]
fn obj_map_kd_with_options_and_spaces_in_the_name() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(fixture("textured-cube/textured-cube.png"), d.join("my tex.png")).unwrap();
    std::fs::write(d.join("m.mtl"), "newmtl m\nKd 1 1 1\nmap_Kd -s 2 2 1 -clamp on my tex.png\n").unwrap();
    std::fs::write(d.join("m.obj"), "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl m\nf 1/1 2/1 3/1\n")
        .unwrap();
    let imp = load_mesh(&d.join("m.obj")).unwrap();
    assert!(imp.warnings.is_empty(), "{:?}", imp.warnings);
    let tr = imp.mesh.materials[0].base_color_texture.as_ref().expect("the texture named with a space");
    assert_eq!(imp.mesh.textures[tr.texture].name, "my tex.png");
    assert_eq!((tr.transform.scale, tr.transform.offset), ([2.0, 2.0], [0.0, -1.0]));
}

/// `vt u` with one component (the OBJ specification's `vt u [v] [w]`) is read with v = 0, as
/// Blender reads it (it was "texture coordinate needs two numbers"): UV (u, 1 − 0) after the
/// flip to the glTF convention; `vt u v w` keeps u v.
#[test]
fn obj_vt_with_one_component_has_v_zero() {
    let p = Path::new("mem/vt.obj");
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.25\nvt 0.5 0.75 0.125\nf 1/1 2/1 3/2\n";
    let imp = load_mesh_from_bytes(p, obj.as_bytes()).unwrap();
    assert!(imp.warnings.is_empty(), "{:?}", imp.warnings);
    assert_eq!(imp.mesh.uvs, vec![vec![[0.25, 1.0], [0.25, 1.0], [0.5, 0.25]]]);
    // A comment after it, and negative indices counting it.
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5 # u only\nf 1/-1 2/-1 3/-1\n";
    let imp = load_mesh_from_bytes(p, obj.as_bytes()).unwrap();
    assert_eq!(imp.mesh.uvs, vec![vec![[0.5, 1.0]; 3]]);
}

/// Faces that name normals in a file with no `vn` line are read without them, as Blender reads
/// them (its bug T98782), with one warning, and get the normals computed from the faces (those
/// of the same file without the normal indices); with a `vn` line, an index past it stays an
/// error.
#[test]
fn obj_normal_indices_in_a_file_without_normals_are_ignored() {
    let p = Path::new("mem/n.obj");
    let v = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n";
    let plain = load_mesh_from_bytes(p, format!("{v}f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n").as_bytes()).unwrap();
    let named = format!("{v}f 1//1 3//3 2//2\nf 1//1 2//2 4//4\nf 1//1 4//4 3//3\nf 2//-1 3//0 4//9\n");
    let imp = load_mesh_from_bytes(p, named.as_bytes()).unwrap();
    assert_eq!(imp.warnings.len(), 1, "{:?}", imp.warnings);
    assert!(imp.warnings[0].0.contains("defines no vn; the normal indices are ignored"), "{:?}", imp.warnings);
    assert_eq!(imp.mesh.triangles.len(), 4);
    // The normals computed on the faces: at each corner, those of the file without the indices.
    let corners = |m: &spherebake_io::Mesh| -> Vec<[(Vec3, Vec3); 3]> {
        m.triangles.iter().map(|t| t.map(|v| (m.positions[v as usize], m.normals[v as usize]))).collect()
    };
    assert_eq!(corners(&imp.mesh), corners(&plain.mesh));
    // The tetrahedron's faces meet at 90° or 54.7° at its corners... and 125°: each pair of
    // faces at the origin (normals −x, −y, −z) meets at 90°, past the crease angle, so each
    // corner there is its own face's normal.
    for t in &imp.mesh.triangles {
        let [a, b, c] = t.map(|v| imp.mesh.positions[v as usize]);
        let face = (b - a).cross(c - a).normalize();
        for &v in t {
            if imp.mesh.positions[v as usize] == Vec3::ZERO {
                assert!(
                    (imp.mesh.normals[v as usize] - face).length() < 1e-6,
                    "{:?} vs {face}",
                    imp.mesh.normals[v as usize]
                );
            }
        }
    }
    let e = load_mesh_from_bytes(p, format!("{v}vn 0 0 1\nf 1//1 3//1 2//2\n").as_bytes()).unwrap_err();
    assert!(e.to_string().contains("line 6: normal index 2 out of range (1 defined so far)"), "{e}");
    // A `vn` after the face counts too: the index was out of range where it was read.
    let e = load_mesh_from_bytes(p, format!("{v}f 1//1 3//1 2//1\nvn 0 0 1\n").as_bytes()).unwrap_err();
    assert!(e.to_string().contains("line 5: normal index 1 out of range (0 defined so far)"), "{e}");
}

/// An `mtllib` path written with Windows separators (`mtllib mats\m.mtl`) is found, as a
/// `map_Kd` path with them is (it was not, so the materials were the default).
#[test]
fn obj_mtllib_with_backslashes_is_found() {
    let files = std::collections::BTreeMap::from([
        (PathBuf::from("mem/mats/m.mtl"), b"newmtl red\nKd 1 0 0\n".to_vec()),
        (PathBuf::from("mem/mats/sub/n.mtl"), b"newmtl blue\nKd 0 0 1\n".to_vec()),
    ]);
    let obj = "mtllib mats\\m.mtl\nmtllib \"mats\\sub\\n.mtl\"\nusemtl red\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nusemtl blue\nv 0 0 1\nf 1 2 4\n";
    let imp = load_mesh_from_memory(Path::new("mem/x.obj"), obj.as_bytes(), files, &ImportOptions::default()).unwrap();
    assert!(imp.warnings.is_empty(), "{:?}", imp.warnings);
    let colour = |t: usize| imp.mesh.materials[imp.mesh.triangle_materials[t] as usize].base_color_factor_linear;
    assert_eq!((colour(0), colour(1)), ([1.0, 0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0]));
    let inputs: Vec<String> = imp.inputs.iter().map(|p| p.display().to_string()).collect();
    assert_eq!(inputs, ["mem/x.obj", "mem/mats/m.mtl", "mem/mats/sub/n.mtl"]);
}

/// An OBJ group whose faces mix `vt` and no `vt` keeps its UVs per corner: the corners without
/// one hold NO_UV, the others theirs (the whole group's UVs were dropped, so its textured faces
/// lost their texture), with a warning; a group with `vt` on every face keeps them, unwarned.
#[test]
fn obj_group_mixing_faces_with_and_without_vt_keeps_the_uvs_it_has() {
    let p = Path::new("mem/mix.obj");
    let mixed = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0.25 0.125\nvt 0.5 1\nf 1/1 2/2 3/1\nf 2 4 3\nf 1/2 4/2 2/2\n";
    let imp = load_mesh_from_bytes(p, mixed.as_bytes()).unwrap();
    // Vertices in the order of first use: 1/1 2/2 3/1, then 2 4 3 (no vt), then 1/2 4/2
    // and 2/2 again, which the third face (wound the other way: a normal 180° from the
    // first's) splits off as a copy with its UV; v flipped to 1 − v.
    assert_eq!(imp.mesh.positions.len(), 9);
    assert_eq!(imp.mesh.uvs.len(), 1);
    let uv = &imp.mesh.uvs[0];
    assert_eq!(&uv[..3], &[[0.25, 0.875], [0.5, 0.0], [0.25, 0.875]]);
    assert!(uv[3..6].iter().all(|u| u[0].is_nan() && u[1].is_nan()), "{uv:?}");
    assert_eq!(&uv[6..], &[[0.5, 0.0], [0.5, 0.0], [0.5, 0.0]]);
    assert_eq!(imp.mesh.triangles, vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]]);
    assert_eq!(imp.mesh.positions[8], imp.mesh.positions[1]);
    assert!(imp.warnings.iter().any(|w| w.0.contains("some faces have no texture coordinates")), "{:?}", imp.warnings);
    let all = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nf 1/1 2/1 3/1\nf 2/1 4/1 3/1\n";
    let imp = load_mesh_from_bytes(p, all.as_bytes()).unwrap();
    assert_eq!(imp.mesh.uvs.len(), 1);
    assert!(imp.warnings.is_empty(), "{:?}", imp.warnings);
}

/// Morph targets move the normals too: normalize(n + Σ wᵢ·Δnᵢ) (glTF §3.7.2.2). Two targets
/// share one NORMAL accessor (read once, weights summed: 0.25 + 0.25).
#[test]
fn morph_targets_move_the_normals_too() {
    let mut bin: Vec<u8> = Vec::new();
    let normals = [[0.0f32, 0.0, 1.0]; 3];
    let zero = [[0.0f32; 3]; 3];
    let dn = [[0.0f32, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
    for p in TRI.iter().chain(&normals).chain(&zero).chain(&dn) {
        bin.extend(p.iter().flat_map(|x| x.to_le_bytes()));
    }
    let view = |k: usize| format!(r#"{{"buffer":0,"byteOffset":{},"byteLength":36}}"#, 36 * k);
    let acc = |k: usize| format!(r#"{{"bufferView":{k},"componentType":5126,"count":3,"type":"VEC3"}}"#);
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1}},
  "targets":[{{"POSITION":2,"NORMAL":3}},{{"POSITION":2,"NORMAL":3}}]}}],"weights":[0.25,0.25]}}],
"buffers":[{{"byteLength":144,"uri":"data:application/octet-stream;base64,{}"}}],
"bufferViews":[{},{},{},{}],"accessors":[{},{},{},{}]}}"#,
        b64(&bin),
        view(0),
        view(1),
        view(2),
        view(3),
        acc(0),
        acc(1),
        acc(2),
        acc(3)
    );
    let imp = load_mesh_from_bytes(Path::new("mem/n.gltf"), json.as_bytes()).unwrap();
    let want = Vec3::new(0.5, 0.0, 1.0).normalize();
    assert!((imp.mesh.normals[2] - want).length() < 1e-6, "{:?}", imp.mesh.normals);
    assert_eq!(imp.mesh.normals[0], Vec3::Z);
    assert_eq!(imp.mesh.positions, TRI.iter().map(|p| Vec3::from(*p)).collect::<Vec<_>>());
}

/// A `map_Kd` with options but no file name warns and keeps Kd (it is not a path to refuse);
/// several groups mixing faces with and without `vt` give one warning naming the first.
#[test]
fn obj_map_kd_without_a_name_and_many_mixed_groups_warn_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("m.mtl"), "newmtl m\nKd 0.5 0.5 0.5\nmap_Kd -s 2 2\n").unwrap();
    let mut obj = String::from("mtllib m.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\n");
    for g in 0..3 {
        obj += &format!("o g{g}\nf 1/1 2/1 3/1\nf 2 4 3\n");
    }
    std::fs::write(d.join("m.obj"), obj).unwrap();
    let imp = load_mesh(&d.join("m.obj")).unwrap();
    assert!(imp.mesh.materials[0].base_color_texture.is_none());
    assert!(imp.warnings.iter().any(|w| w.0.contains("map_Kd names no file")), "{:?}", imp.warnings);
    let mixed: Vec<_> =
        imp.warnings.iter().filter(|w| w.0.contains("some faces have no texture coordinates")).collect();
    assert_eq!(mixed.len(), 1, "{:?}", imp.warnings);
    assert!(mixed[0].0.contains("\"g0\" (and 2 more)"), "{:?}", mixed[0]);
}

/// `map_d` (MTL's dissolve texture) makes an OBJ material a cut-out: one cut-out texture per
/// (map_Kd, map_d) pair, shared by the materials naming both; a `map_d` that names no file or
/// cannot be read warns and leaves the material opaque; `-o`/`-s` differing from `map_Kd`'s warn.
#[test]
fn obj_map_d_makes_a_cut_out_and_its_failures_warn() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    image::RgbImage::from_fn(4, 2, |x, y| image::Rgb([(x * 60) as u8, (y * 100) as u8, 7]))
        .save(d.join("c.png"))
        .unwrap();
    image::GrayImage::from_fn(2, 2, |x, y| image::Luma([(x * 200 + y * 50) as u8])).save(d.join("m.png")).unwrap();
    let mtl = "newmtl a\nmap_Kd c.png\nmap_d m.png\n\
               newmtl b\nKd 0.5 0.5 0.5\nmap_Kd c.png\nmap_d m.png\n\
               newmtl nomask\nmap_Kd c.png\nmap_d missing.png\n\
               newmtl noname\nmap_d -imfchan l\n\
               newmtl shifted\nmap_Kd -o 0.25 0 c.png\nmap_d -o 0.5 0 m.png\n\
               newmtl same\nmap_Kd -o 0.25 0 c.png\nmap_d -o 0.25 0 m.png\n\
               newmtl maskonly\nKd 0.2 0.4 0.6\nmap_d -s 2 2 m.png\n";
    std::fs::write(d.join("m.mtl"), mtl).unwrap();
    let mut obj = String::from("mtllib m.mtl\nvt 0 0\nvt 1 0\nvt 0 1\n");
    for (i, m) in ["a", "b", "nomask", "noname", "shifted", "same", "maskonly"].into_iter().enumerate() {
        obj += &format!("g {m}\nusemtl {m}\nv 0 0 {i}\nv 1 0 {i}\nv 0 1 {i}\nf -3/1 -2/2 -1/3\n");
    }
    std::fs::write(d.join("m.obj"), obj).unwrap();
    let imp = load_mesh(&d.join("m.obj")).unwrap();
    let mat = |n: &str| imp.mesh.materials.iter().find(|m| m.name == n).unwrap();
    let tex = |n: &str| &imp.mesh.textures[mat(n).base_color_texture.as_ref().unwrap().texture];
    assert!(!imp.warnings.iter().any(|w| w.0.contains("\"same\"")), "{:?}", imp.warnings);
    let warned = |s: &str| imp.warnings.iter().any(|w| w.0.contains(s));
    // a and b share one cut-out texture: c.png's colour, its alpha the mask at the nearest texel
    // (mask column x / 2, row y), as stored (no sRGB curve).
    assert_eq!(mat("a").alpha_mask_cutoff, Some(0.5));
    assert_eq!(mat("a").base_color_texture, mat("b").base_color_texture);
    let eotf = spherebake_testkit::oracle::srgb_to_linear;
    let t = tex("a");
    assert_eq!((t.width, t.height), (4, 2));
    for y in 0..2u32 {
        for x in 0..4u32 {
            let got = t.texels_linear[(y * 4 + x) as usize];
            let want = [
                eotf(f64::from(x * 60) / 255.0),
                eotf(f64::from(y * 100) / 255.0),
                eotf(7.0 / 255.0),
                f64::from((x / 2) * 200 + y * 50) / 255.0,
            ];
            for c in 0..4 {
                assert!((f64::from(got[c]) - want[c]).abs() < 1e-6, "({x}, {y}) channel {c}: {got:?} vs {want:?}");
            }
        }
    }
    // Unreadable or unnamed masks: opaque, with c.png (or nothing) as before, and a warning.
    assert_eq!(mat("nomask").alpha_mask_cutoff, None);
    assert_eq!(tex("nomask").name, "c.png");
    assert!(warned("missing.png") && warned("no cut-out"), "{:?}", imp.warnings);
    assert_eq!(mat("noname").alpha_mask_cutoff, None);
    assert!(warned("map_d names no file"), "{:?}", imp.warnings);
    // Different -o: cut out, read through map_Kd's transform, warned.
    assert_eq!(mat("shifted").alpha_mask_cutoff, Some(0.5));
    let kd_offset = mat("shifted").base_color_texture.as_ref().unwrap().transform.offset;
    assert_eq!(kd_offset, [0.25, 0.0], "map_Kd's -o 0.25 (OBJ v up: the offset's v is 1 - s_v - o_v = 0)");
    // The same -o on both: no warning (the count below), the same transform.
    assert_eq!(mat("same").base_color_texture.as_ref().unwrap().transform.offset, [0.25, 0.0]);
    assert!(warned("map_d's -o / -s differ from map_Kd's"), "{:?}", imp.warnings);
    // A mask alone: white texels at the mask's size with its values as alpha, Kd the colour,
    // the mask's own -s as the transform.
    let m = mat("maskonly");
    assert_eq!((m.alpha_mask_cutoff, m.base_color_factor_linear), (Some(0.5), [0.2, 0.4, 0.6, 1.0]));
    assert_eq!(m.base_color_texture.as_ref().unwrap().transform.scale, [2.0, 2.0]);
    let t = tex("maskonly");
    assert_eq!((t.width, t.height), (2, 2));
    assert_eq!(t.texels_linear[3], [1.0, 1.0, 1.0, 250.0 / 255.0]);
    assert_eq!(imp.warnings.len(), 3, "{:?}", imp.warnings);
}

/// map_d's mask replaces the colour texture's alpha (MTL's dissolve is d × the map, not the
/// diffuse texture's own alpha): with map_Kd and map_d naming one RGBA file (Blender's
/// export), the stored alpha comes through once, not squared. A mask larger than map_Kd keeps
/// its resolution: the cut-out takes the larger size, the colour repeated at its nearest texel.
#[test]
fn obj_map_d_replaces_the_alpha_and_keeps_the_larger_size() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let alphas = [0u8, 128, 160, 255];
    image::RgbaImage::from_fn(4, 1, |x, _| image::Rgba([10, 20, 30, alphas[x as usize]]))
        .save(d.join("leaf.png"))
        .unwrap();
    image::RgbImage::from_fn(1, 1, |_, _| image::Rgb([255, 0, 0])).save(d.join("red.png")).unwrap();
    image::GrayImage::from_fn(16, 2, |x, _| image::Luma([if x < 8 { 0 } else { 255 }]))
        .save(d.join("fine.png"))
        .unwrap();
    image::RgbImage::from_fn(2, 1, |x, _| image::Rgb(if x == 0 { [255, 0, 0] } else { [0, 0, 255] }))
        .save(d.join("two.png"))
        .unwrap();
    image::GrayImage::from_fn(4, 2, |x, y| image::Luma([(x * 80 + y * 10) as u8])).save(d.join("four.png")).unwrap();
    let mtl = "newmtl leaf\nmap_Kd leaf.png\nmap_d leaf.png\nnewmtl flat\nmap_Kd red.png\nmap_d fine.png\n\
               newmtl wide\nmap_Kd two.png\nmap_d four.png\n";
    std::fs::write(d.join("m.mtl"), mtl).unwrap();
    let mut obj = String::from("mtllib m.mtl\nvt 0 0\nvt 1 0\nvt 0 1\n");
    for (i, m) in ["leaf", "flat", "wide"].into_iter().enumerate() {
        obj += &format!("usemtl {m}\nv 0 0 {i}\nv 1 0 {i}\nv 0 1 {i}\nf -3/1 -2/2 -1/3\n");
    }
    std::fs::write(d.join("m.obj"), obj).unwrap();
    let imp = load_mesh(&d.join("m.obj")).unwrap();
    assert!(imp.warnings.is_empty(), "{:?}", imp.warnings);
    let tex = |n: &str| {
        let m = imp.mesh.materials.iter().find(|m| m.name == n).unwrap();
        &imp.mesh.textures[m.base_color_texture.as_ref().unwrap().texture]
    };
    let leaf = tex("leaf");
    for (x, &a) in alphas.iter().enumerate() {
        assert!(
            (leaf.texels_linear[x][3] - f32::from(a) / 255.0).abs() < 1e-6,
            "texel {x}: {:?}",
            leaf.texels_linear[x]
        );
    }
    let flat = tex("flat");
    assert_eq!((flat.width, flat.height), (16, 2));
    for (i, t) in flat.texels_linear.iter().enumerate() {
        let want_a = if i % 16 < 8 { 0.0 } else { 1.0 };
        assert_eq!(*t, [1.0, 0.0, 0.0, want_a], "texel {i}");
    }
    // A 2 × 1 colour under a 4 × 2 mask: 4 × 2, each colour texel over two columns (texel
    // centres 0.5 and 1.5 of 4 fall in colour texel 0, 2.5 and 3.5 in texel 1).
    let wide = tex("wide");
    assert_eq!((wide.width, wide.height), (4, 2));
    for y in 0..2usize {
        for x in 0..4usize {
            let rgb = if x < 2 { [1.0, 0.0, 0.0] } else { [0.0, 0.0, 1.0] };
            let a = (x * 80 + y * 10) as f32 / 255.0;
            let got = wide.texels_linear[y * 4 + x];
            assert_eq!(got[..3], rgb, "({x}, {y})");
            assert!((got[3] - a).abs() < 1e-6, "({x}, {y}) {got:?}");
        }
    }
}

/// The decoded textures of a model share `ImportOptions::max_texels` (here 200; by default
/// 4 × 4096²): over it, the largest is halved (box-filtered) as the textures are read, the
/// others keep their size, and one warning names it. Map_d cut-outs count too.
#[test]
fn the_textures_of_a_model_share_the_texel_budget() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let v = |x: u32, y: u32| ((x * 37 + y * 91) % 256) as u8;
    image::GrayImage::from_fn(16, 16, |x, y| image::Luma([v(x, y)])).save(d.join("big.png")).unwrap();
    image::GrayImage::from_fn(8, 8, |x, y| image::Luma([v(y, x)])).save(d.join("small.png")).unwrap();
    let opts = ImportOptions { max_texels: 200, ..Default::default() };
    // glTF: two materials, 256 + 64 texels > 200: big.png → 8×8.
    let extra = r#","materials":[{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}}},{"pbrMetallicRoughness":{"baseColorTexture":{"index":1}}}],"textures":[{"source":0},{"source":1}],"images":[{"uri":"big.png"},{"uri":"small.png"}]"#;
    std::fs::write(d.join("m.gltf"), two_material_gltf(extra)).unwrap();
    let imp = spherebake_io::load_mesh_with(&d.join("m.gltf"), &opts).unwrap();
    let sizes: Vec<(u32, u32)> = imp.mesh.textures.iter().map(|t| (t.width, t.height)).collect();
    assert_eq!(sizes, [(8, 8), (8, 8)]);
    let eotf = |b: u8| spherebake_testkit::oracle::srgb_to_linear(f64::from(b) / 255.0);
    for y in 0..8u32 {
        for x in 0..8u32 {
            let mean = (eotf(v(2 * x, 2 * y))
                + eotf(v(2 * x + 1, 2 * y))
                + eotf(v(2 * x, 2 * y + 1))
                + eotf(v(2 * x + 1, 2 * y + 1)))
                / 4.0;
            let got = imp.mesh.textures[0].texels_linear[(y * 8 + x) as usize];
            assert!((f64::from(got[0]) - mean).abs() < 1e-6, "({x}, {y}): {got:?} vs {mean}");
            let small = imp.mesh.textures[1].texels_linear[(y * 8 + x) as usize];
            assert!((f64::from(small[0]) - eotf(v(y, x))).abs() < 1e-6, "small.png untouched");
        }
    }
    let w: Vec<_> = imp.warnings.iter().filter(|w| w.0.contains("texels together")).collect();
    assert!(w.len() == 1 && w[0].0.contains("big.png 16×16 → 8×8"), "{:?}", imp.warnings);
    // OBJ: small.png (64) read only through its cut-out by big.png (16×16 = 256): small.png is
    // dropped (to 1×1, not counted), and the cut-out alone is over 200, so it is halved.
    std::fs::write(d.join("m.mtl"), "newmtl m\nmap_Kd small.png\nmap_d big.png\n").unwrap();
    std::fs::write(
        d.join("m.obj"),
        "mtllib m.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n",
    )
    .unwrap();
    let imp = spherebake_io::load_mesh_with(&d.join("m.obj"), &opts).unwrap();
    let sizes: Vec<(u32, u32)> = imp.mesh.textures.iter().map(|t| (t.width, t.height)).collect();
    assert_eq!(sizes, [(1, 1), (8, 8)], "{:?}", imp.warnings);
    assert!(imp.warnings.iter().any(|w| w.0.contains("cut out by big.png 16×16 → 8×8")), "{:?}", imp.warnings);
    // Read directly by a second material too, small.png counts (64 + 256 > 200 still halves
    // only the cut-out, the largest).
    std::fs::write(d.join("m.mtl"), "newmtl m\nmap_Kd small.png\nmap_d big.png\nnewmtl plain\nmap_Kd small.png\n")
        .unwrap();
    let obj = "mtllib m.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n\
               usemtl plain\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf 4/1 5/2 6/3\n";
    std::fs::write(d.join("m.obj"), obj).unwrap();
    let imp = spherebake_io::load_mesh_with(&d.join("m.obj"), &opts).unwrap();
    let used: Vec<(u32, u32)> = imp
        .mesh
        .materials
        .iter()
        .map(|m| &imp.mesh.textures[m.base_color_texture.as_ref().unwrap().texture])
        .map(|t| (t.width, t.height))
        .collect();
    assert_eq!(used, [(8, 8), (8, 8)], "the cut-out halved, small.png whole: {:?}", imp.warnings);
    // The default budget reads both whole.
    let imp = load_mesh(&d.join("m.obj")).unwrap();
    assert_eq!(imp.mesh.textures[1].width, 16);
}

/// A `map_d` outside the model's folder is refused like a `map_Kd` there: the import fails
/// naming the reference, and the file is not read; allowed with `allow_outside_paths`.
#[test]
fn an_obj_map_d_outside_the_folder_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (d, model) = (dir.path(), dir.path().join("model"));
    std::fs::create_dir(&model).unwrap();
    image::GrayImage::from_fn(2, 1, |x, _| image::Luma([(x * 255) as u8])).save(d.join("mask.png")).unwrap();
    std::fs::write(model.join("m.mtl"), "newmtl m\nmap_d ../mask.png\n").unwrap();
    let obj = "mtllib m.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
    std::fs::write(model.join("m.obj"), obj).unwrap();
    let Err(e) = load_mesh(&model.join("m.obj")) else { panic!("a map_d outside the folder is refused") };
    assert!(e.to_string().contains("\"../mask.png\" is outside the model's folder"), "{e}");
    let opts = ImportOptions { allow_outside_paths: true, ..Default::default() };
    let imp = spherebake_io::load_mesh_with(&model.join("m.obj"), &opts).unwrap();
    assert_eq!(imp.mesh.materials[0].alpha_mask_cutoff, Some(0.5));
}

/// Images with one source are decoded once, and a model's images decode at most
/// `ImportOptions::max_decoded_pixels` together (by their headers, before decoding): the
/// images past it are not decoded, their materials use the base colour factor, and one warning
/// names them. Before, a 118 KB glTF of 300 images pointing at one 4096² PNG decoded it 300
/// times (130 s, 2.6 GB); 300 distinct views of it now stop after 128 decodes.
#[test]
fn images_with_one_source_decode_once_and_a_model_decodes_a_bounded_number_of_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let png = |w: u32, h: u32| {
        let mut out = std::io::Cursor::new(Vec::new());
        image::RgbImage::from_fn(w, h, |x, y| image::Rgb([(x * 10) as u8, (y * 10) as u8, 7]))
            .write_to(&mut out, image::ImageFormat::Png)
            .unwrap();
        out.into_inner()
    };
    // A PNG header claiming 46 300² pixels (6.4 GB decoded), then a few bytes of IDAT.
    let huge = {
        use spherebake_testkit::png::chunk;
        let mut ihdr = 46_300u32.to_be_bytes().to_vec();
        ihdr.extend(46_300u32.to_be_bytes());
        ihdr.extend([8, 2, 0, 0, 0]);
        let mut p = b"\x89PNG\r\n\x1a\n".to_vec();
        p.extend(chunk(b"IHDR", &ihdr));
        p.extend(chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00]));
        p.extend(chunk(b"IEND", &[]));
        p
    };
    // A GLB: material i reads image i. Images 0 and 1 are buffer view 2 (a 16×16 PNG), image 2
    // is view 4 (the huge header), image 3 is view 5 (the same bytes as view 2, another view),
    // image 4 is view 3 (8×8).
    let images = [2, 2, 4, 5, 3].map(|v| format!(r#"{{"bufferView":{v},"mimeType":"image/png"}}"#)).join(",");
    let materials = (0..5)
        .map(|i| format!(r#"{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":{i}}}}}}}"#))
        .collect::<Vec<_>>()
        .join(",");
    let textures = (0..5).map(|i| format!(r#"{{"source":{i}}}"#)).collect::<Vec<_>>().join(",");
    let extra = format!(r#","materials":[{materials}],"textures":[{textures}],"images":[{images}]"#);
    let (json, mut bin) = gltf_json(&TRI, Some(&[0, 1, 2]), true, &extra);
    let old_len = bin.len();
    let mut views = String::new();
    let mut first = 0;
    for (k, p) in [png(16, 16), png(8, 8), huge].into_iter().enumerate() {
        if k == 0 {
            first = bin.len();
        }
        views += &format!(r#",{{"buffer":0,"byteOffset":{},"byteLength":{}}}"#, bin.len(), p.len());
        bin.extend(p);
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
    }
    let len16 = png(16, 16).len();
    views += &format!(r#",{{"buffer":0,"byteOffset":{first},"byteLength":{len16}}}"#);
    let prim = r#"{"attributes":{"POSITION":0},"indices":1"#;
    let prims = (0..5).map(|i| format!(r#"{prim},"material":{i}}}"#)).collect::<Vec<_>>().join(",");
    let json = json
        .replace(
            &format!(r#""buffers":[{{"byteLength":{old_len}}}]"#),
            &format!(r#""buffers":[{{"byteLength":{}}}]"#, bin.len()),
        )
        .replacen("}],\n\"accessors\"", &format!("}}{views}],\n\"accessors\""), 1)
        .replace(&format!("{prim}}}"), &prims);
    let bytes = glb(&json, &bin);
    std::fs::write(d.join("m.glb"), &bytes).unwrap();
    let texture_of = |imp: &spherebake_io::Imported| -> Vec<Option<(usize, u32, u32)>> {
        imp.mesh
            .materials
            .iter()
            .map(|m| {
                m.base_color_texture.as_ref().map(|t| {
                    let tex = &imp.mesh.textures[t.texture];
                    (t.texture, tex.width, tex.height)
                })
            })
            .collect()
    };
    let a = Some((0, 16, 16));
    let imp = load_mesh(&d.join("m.glb")).unwrap();
    assert_eq!(imp.mesh.textures.len(), 2, "the shared bytes decoded once: {:?}", imp.warnings);
    assert_eq!(texture_of(&imp), [a, a, None, a, Some((1, 8, 8))]);
    let decode_warnings = |imp: &spherebake_io::Imported| -> Vec<String> {
        imp.warnings.iter().filter(|w| w.0.contains("decode")).map(|w| w.0.clone()).collect()
    };
    let w = decode_warnings(&imp);
    assert!(w.len() == 1 && w[0].contains("46300×46300 pixels would take more than"), "{w:?}");
    // 320 pixels: exactly the two real images; the huge header is refused by the memory cap
    // before it is charged.
    let opts = ImportOptions { max_decoded_pixels: 320, ..Default::default() };
    let imp = spherebake_io::load_mesh_with(&d.join("m.glb"), &opts).unwrap();
    assert_eq!(texture_of(&imp), [a, a, None, a, Some((1, 8, 8))]);
    // 300 pixels: the 16×16 image (256) fits, the 8×8 one (64) would pass 300.
    let opts = ImportOptions { max_decoded_pixels: 300, ..Default::default() };
    let imp = spherebake_io::load_mesh_with(&d.join("m.glb"), &opts).unwrap();
    assert_eq!(texture_of(&imp), [a, a, None, a, None]);
    let w = decode_warnings(&imp);
    assert_eq!(w.len(), 2, "the memory cap's, and one for the budget: {w:?}");
    assert!(
        w[1].contains("decode more than 300 pixels, or 1073741824 encoded bytes, together; 1 not decoded")
            && w[1].ends_with(": image[4] (8×8)"),
        "{w:?}"
    );
    // The same file URI named by two images: read and decoded once.
    std::fs::write(d.join("a.png"), png(16, 16)).unwrap();
    let extra = r#","materials":[{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}}},{"pbrMetallicRoughness":{"baseColorTexture":{"index":1}}}],"textures":[{"source":0},{"source":1}],"images":[{"uri":"a.png"},{"uri":"a.png"}]"#;
    std::fs::write(d.join("m.gltf"), two_material_gltf(extra)).unwrap();
    let imp = load_mesh(&d.join("m.gltf")).unwrap();
    assert_eq!(texture_of(&imp), [a, a]);
    // OBJ: map_Kd and map_d count too; a.png (256) fits 300, then b.png's mask (64) does not.
    std::fs::write(d.join("a.png"), png(16, 16)).unwrap();
    std::fs::write(d.join("b.png"), png(8, 8)).unwrap();
    std::fs::write(d.join("m.mtl"), "newmtl one\nmap_Kd a.png\nnewmtl two\nmap_Kd a.png\nmap_d b.png\n").unwrap();
    let obj = "mtllib m.mtl\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl one\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/2 3/3\n\
               usemtl two\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf 4/1 5/2 6/3\n";
    std::fs::write(d.join("m.obj"), obj).unwrap();
    let opts = ImportOptions { max_decoded_pixels: 300, ..Default::default() };
    let imp = spherebake_io::load_mesh_with(&d.join("m.obj"), &opts).unwrap();
    let w: Vec<_> = imp.warnings.iter().filter(|w| w.0.contains("decode more than 300 pixels")).collect();
    assert!(w.len() == 1 && w[0].0.contains("b.png (8×8)"), "{:?}", imp.warnings);
    let two = imp.mesh.materials.iter().find(|m| m.name == "two").unwrap();
    assert!(two.alpha_mask_cutoff.is_none(), "no cut-out without its mask");
    let imp = load_mesh(&d.join("m.obj")).unwrap();
    let two = imp.mesh.materials.iter().find(|m| m.name == "two").unwrap();
    assert!(two.alpha_mask_cutoff.is_some(), "the default budget reads the mask: {:?}", imp.warnings);
}

/// glTF 2.0 makes an animation channel's `target.node` optional (KHR_animation_pointer targets
/// have none). Such a file was refused ("missing field `node`"); now those channels are skipped
/// with a warning and the channels with a node are read as before.
#[test]
fn animation_channels_without_a_node_are_skipped_not_refused() {
    let path = fixture("skinned-arm.gltf");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let before = load_mesh(&path).unwrap();
    let channels = json["animations"][0]["channels"].as_array_mut().unwrap();
    let kept = channels.len();
    // First a channel without a node, then a morph-weights one (skipped with a warning that
    // must name it by its index in the file, 1), then the file's own.
    channels.insert(0, serde_json::json!({"sampler": 0, "target": {"node": 2, "path": "weights"}}));
    channels.insert(
        0,
        serde_json::json!({
            "sampler": 0,
            "target": {"path": "pointer", "extensions": {"KHR_animation_pointer": {"pointer": "/nodes/2/rotation"}}}
        }),
    );
    let bytes = serde_json::to_vec(&json).unwrap();
    let r = load_mesh_from_bytes(&path, &bytes).expect("a channel without a node is valid glTF");
    let w: Vec<&str> = r.warnings.iter().map(|w| w.0.as_str()).collect();
    assert!(w.iter().any(|w| w.starts_with("1 animation channel(s) without a target node skipped")), "{w:?}");
    assert!(w.contains(&"animation 0 channel 1: morph target weights skipped"), "{w:?}");
    let anims = |m: &spherebake_io::Imported| m.mesh.skin.as_ref().expect("skinned").skeleton.animations.clone();
    let (a, b) = (anims(&r), anims(&before));
    assert_eq!(a.len(), 1);
    assert_eq!(a[0].channels.len(), kept);
    assert_eq!(a, b);
    assert_eq!(r.mesh.positions, before.mesh.positions);
}

/// The faces of an OBJ text as written (`v` positions, `f` corners: 1-based position indices,
/// the first number of each corner), read here apart from the importer.
fn obj_faces(obj: &str) -> Vec<Vec<[f64; 3]>> {
    let mut v: Vec<[f64; 3]> = Vec::new();
    let mut faces = Vec::new();
    for line in obj.lines() {
        let mut t = line.split_whitespace();
        match t.next() {
            Some("v") => v.push([0, 1, 2].map(|_| t.next().unwrap().parse().unwrap())),
            Some("f") => faces.push(
                t.map(|c| {
                    let i: i64 = c.split('/').next().unwrap().parse().unwrap();
                    v[if i < 0 { v.len() as i64 + i } else { i - 1 } as usize]
                })
                .collect::<Vec<_>>(),
            ),
            _ => {}
        }
    }
    faces
}

/// Newell's normal of a polygon: twice its vector area.
fn newell(p: &[[f64; 3]]) -> [f64; 3] {
    let mut n = [0.0; 3];
    for (i, a) in p.iter().enumerate() {
        let b = p[(i + 1) % p.len()];
        n[0] += (a[1] - b[1]) * (a[2] + b[2]);
        n[1] += (a[2] - b[2]) * (a[0] + b[0]);
        n[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    n
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Whether point q (in the plane of the axis-aligned polygon p, whose normal is along `axis`)
/// is strictly inside p, by the crossing rule in the other two coordinates.
fn inside(p: &[[f64; 3]], q: [f64; 3], axis: usize) -> bool {
    let (x, y) = ((axis + 1) % 3, (axis + 2) % 3);
    let mut odd = false;
    for (i, a) in p.iter().enumerate() {
        let b = p[(i + 1) % p.len()];
        if (a[y] > q[y]) != (b[y] > q[y]) && q[x] < a[x] + (q[y] - a[y]) / (b[y] - a[y]) * (b[x] - a[x]) {
            odd = !odd;
        }
    }
    odd
}

/// An OBJ face of four or more corners is triangulated in its own plane without covering area
/// outside it: each concave face (an L, a star, a dart) is split into triangles that face the
/// way its Newell normal does, lie inside it and add up to its area; a convex one gets the fan
/// from its first corner, as before. The expected values are the polygons' own (the L prism's
/// surface is 2 · 3 + 8 = 14, its volume 3), not the importer's.
#[test]
fn obj_polygons_are_triangulated_inside_their_outline() {
    // The L prism, its caps listed from a corner next to the notch ((2, 1)): the fan from there
    // covered the notch (area 16).
    let l_prism = "v 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 0 0 0\nv 2 0 0\n\
                   v 2 1 1\nv 1 1 1\nv 1 2 1\nv 0 2 1\nv 0 0 1\nv 2 0 1\n\
                   f 6 5 4 3 2 1\nf 7 8 9 10 11 12\nf 1 2 8 7\nf 2 3 9 8\nf 3 4 10 9\nf 4 5 11 10\nf 5 6 12 11\nf 6 1 7 12\n";
    // A five-pointed star (10 corners, in the plane x = 3), a dart whose reflex corner is the
    // second (its fan's first diagonal runs outside), a convex pentagon and a square.
    let mut star = String::new();
    for k in 0..10 {
        let a = std::f64::consts::FRAC_PI_2 + f64::from(k) * std::f64::consts::PI / 5.0 + 0.3;
        let r = if k % 2 == 0 { 1.0 } else { 0.4 };
        star.push_str(&format!("v 3 {} {}\n", r * a.cos(), r * a.sin()));
    }
    let others = format!(
        "{star}f -9 -8 -7 -6 -5 -4 -3 -2 -1 -10\n\
         v 0 0 5\nv 2 1 5\nv 4 0 5\nv 2 3 5\nf -4 -3 -2 -1\n\
         v 0 0 7\nv 2 -1 7\nv 3 1 7\nv 1 3 7\nv -1 1 7\nf -5 -4 -3 -2 -1\n\
         v 0 0 9\nv 1 0 9\nv 1 1 9\nv 0 1 9\nf -4 -3 -2 -1\n"
    );
    for (name, obj) in [("L prism", l_prism.to_string()), ("star, dart, pentagon, square", others)] {
        let imp = load_mesh_from_bytes(Path::new("mem/poly.obj"), obj.as_bytes()).unwrap();
        assert!(imp.warnings.is_empty(), "{name}: {:?}", imp.warnings);
        let m = &imp.mesh;
        let p = |i: u32| m.positions[i as usize].as_dvec3().to_array();
        let faces = obj_faces(&obj);
        assert_eq!(m.triangles.len(), faces.iter().map(|f| f.len() - 2).sum::<usize>(), "{name}");
        // Each face's triangles, in file order.
        let mut next = m.triangles.iter();
        for (k, face) in faces.iter().enumerate() {
            let normal = newell(face);
            let axis = (0..3).max_by(|&a, &b| normal[a].abs().total_cmp(&normal[b].abs())).unwrap();
            let want_area = dot(normal, normal).sqrt() / 2.0;
            let mut area = 0.0;
            let tris: Vec<[[f64; 3]; 3]> = next.by_ref().take(face.len() - 2).map(|t| t.map(p)).collect();
            for t in &tris {
                let x = cross(sub(t[1], t[0]), sub(t[2], t[0]));
                assert!(dot(x, normal) > 0.0, "{name}: face {k}: triangle {t:?} faces away from {normal:?}");
                area += dot(x, x).sqrt() / 2.0;
                let c = [0, 1, 2].map(|i| (t[0][i] + t[1][i] + t[2][i]) / 3.0);
                assert!(inside(face, c, axis), "{name}: face {k}: triangle {t:?} is outside the face");
            }
            assert!((area - want_area).abs() < 1e-6, "{name}: face {k}: area {area}, the polygon's {want_area}");
            // Convex faces: the fan from the first corner, corner for corner.
            let convex = (0..face.len()).all(|i| {
                let (a, b, c) = (face[i], face[(i + 1) % face.len()], face[(i + 2) % face.len()]);
                dot(cross(sub(b, a), sub(c, b)), normal) > 0.0
            });
            if convex {
                let fan: Vec<_> = (1..face.len() - 1).map(|i| [face[0], face[i], face[i + 1]]).collect();
                let got: Vec<_> = tris.iter().map(|t| t.map(|q| q.map(|x| x as f32 as f64))).collect();
                assert_eq!(got, fan, "{name}: face {k} is convex");
            }
        }
    }
    let imp = load_mesh_from_bytes(Path::new("mem/l.obj"), l_prism.as_bytes()).unwrap();
    let r = TopologyReport::compute(&imp.mesh);
    assert!(r.closed && r.consistently_oriented, "{r:?}");
    assert!((r.surface_area - 14.0).abs() < 1e-9, "{}", r.surface_area);
    assert!((r.signed_volume - 3.0).abs() < 1e-9, "{}", r.signed_volume);
}

/// Concave polygons the importer does not ear-clip (more corners than it clips, or none of
/// their corners an ear: self-intersecting) get the fan from their first corner, as before,
/// and one warning for the file says how many.
#[test]
fn obj_polygons_that_are_not_ear_clipped_get_the_fan_and_one_warning() {
    // A comb of 400 corners (concave) and a self-intersecting hexagon, twice each (in other
    // planes: copies of a face would be duplicate triangles), and a triangle.
    let mut obj = String::new();
    let n = 400;
    let comb = |z: u32| {
        let mut s = String::new();
        for k in 0..n {
            let a = f64::from(k) / f64::from(n) * std::f64::consts::TAU;
            let r = if k % 2 == 0 { 1.0 } else { 0.5 };
            s.push_str(&format!("v {} {} {z}\n", r * a.cos(), r * a.sin()));
        }
        let corners: Vec<String> = (1..=n).map(|i| format!("-{}", n + 1 - i)).collect();
        s + &format!("f {}\n", corners.join(" "))
    };
    let knot =
        |z: u32| format!("v 0 4 {z}\nv 4 1 {z}\nv 2 4 {z}\nv 2 0 {z}\nv 1 2 {z}\nv 6 3 {z}\nf -6 -5 -4 -3 -2 -1\n");
    obj.push_str(&format!("o comb\n{}o knot\n{}", comb(0), knot(1)));
    obj.push_str(&format!("v 0 0 2\nv 0 1 2\nv 1 0 2\nf -3 -2 -1\n{}{}", comb(3), knot(4)));
    let imp = load_mesh_from_bytes(Path::new("mem/hostile.obj"), obj.as_bytes()).unwrap();
    // The fans: every face's triangles, from its first corner.
    assert_eq!(imp.mesh.triangles.len(), 2 * (n as usize - 2) + 2 * 4 + 1);
    let w: Vec<&str> = imp.warnings.iter().map(|w| w.0.as_str()).collect();
    let fanned: Vec<&&str> = w.iter().filter(|w| w.contains("triangulated as a fan")).collect();
    assert_eq!(fanned.len(), 1, "{w:?}");
    assert!(fanned[0].starts_with("4 concave polygon(s) triangulated as a fan from the first corner"), "{w:?}");
    assert!(fanned[0].contains("(the first in object \"comb\"; 2 with more than 256 corners, 2 self-int"), "{w:?}");
    let first = imp.mesh.triangles[0].map(|i| imp.mesh.positions[i as usize]);
    assert_eq!(
        first,
        [0, 1, 2].map(|k| {
            let a = f64::from(k) / f64::from(n) * std::f64::consts::TAU;
            let r = if k % 2 == 0 { 1.0 } else { 0.5 };
            Vec3::new((r * a.cos()) as f32, (r * a.sin()) as f32, 0.0)
        })
    );
}

/// A 2×2 PNG of one colour (grey when `rgb` has one channel).
fn flat_png(rgb: &[u8]) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    let image: image::DynamicImage = match *rgb {
        [g] => image::GrayImage::from_pixel(2, 2, image::Luma([g])).into(),
        [r, g, b] => image::RgbImage::from_pixel(2, 2, image::Rgb([r, g, b])).into(),
        _ => unreachable!(),
    };
    image.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// Each material's texture paths (`map_Kd`, `map_d`) are relative to the folder of the MTL
/// file that defines it, whatever library is read last (`map_Kd tex.png` of t1/a.mtl read
/// t2/tex.png when t2/b.mtl came after), and still confined to the model's folder.
#[test]
fn obj_textures_resolve_against_the_folder_of_their_library() {
    let files = std::collections::BTreeMap::from([
        (PathBuf::from("mem/t1/a.mtl"), b"newmtl ma\nKd 1 1 1\nmap_Kd tex.png\nmap_d mask.png\n".to_vec()),
        (PathBuf::from("mem/t2/b.mtl"), b"newmtl mb\nKd 1 1 1\nmap_Kd tex.png\n".to_vec()),
        (PathBuf::from("mem/t1/tex.png"), flat_png(&[255, 0, 0])),
        (PathBuf::from("mem/t2/tex.png"), flat_png(&[0, 255, 0])),
        // Masks are data: grey 51 is 0.2, 204 is 0.8.
        (PathBuf::from("mem/t1/mask.png"), flat_png(&[51])),
        (PathBuf::from("mem/t2/mask.png"), flat_png(&[204])),
        (PathBuf::from("mem/tex.png"), flat_png(&[0, 0, 255])),
        (PathBuf::from("mem/mask.png"), flat_png(&[0])),
    ]);
    let geometry = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\n";
    let faces = "usemtl ma\nf 1/1 2/2 3/3\nusemtl mb\nf 1/1 4/2 2/3\n";
    // ma: t1's red with t1's mask 0.2 as alpha; mb: t2's green, opaque.
    let want = [("ma", [1.0, 0.0, 0.0, 0.2]), ("mb", [0.0, 1.0, 0.0, 1.0])];
    for libs in ["mtllib t1/a.mtl\nmtllib t2/b.mtl\n", "mtllib t2/b.mtl\nmtllib t1/a.mtl\n"] {
        let obj = format!("{libs}{geometry}{faces}");
        let imp =
            load_mesh_from_memory(Path::new("mem/x.obj"), obj.as_bytes(), files.clone(), &ImportOptions::default())
                .unwrap();
        assert!(imp.warnings.is_empty(), "{libs:?}: {:?}", imp.warnings);
        for (name, texel) in want {
            let m = imp.mesh.materials.iter().find(|m| m.name == name).unwrap();
            let t = &imp.mesh.textures[m.base_color_texture.as_ref().expect("a texture").texture];
            for got in &t.texels_linear {
                assert!(got.iter().zip(texel).all(|(g, w)| (g - w).abs() < 1e-6), "{libs:?}: {name}: {got:?}");
            }
        }
        let mut read: Vec<_> = imp.inputs.iter().map(|p| p.to_str().unwrap()).collect();
        read.sort_unstable();
        assert_eq!(
            read,
            ["mem/t1/a.mtl", "mem/t1/mask.png", "mem/t1/tex.png", "mem/t2/b.mtl", "mem/t2/tex.png", "mem/x.obj"]
        );
    }
    // `..` from a library's folder: inside the model's folder it is read, past it refused.
    let mut files = files;
    files.insert(PathBuf::from("mem/t1/a.mtl"), b"newmtl ma\nmap_Kd ../tex.png\n".to_vec());
    let obj = format!("mtllib t2/b.mtl\nmtllib t1/a.mtl\n{geometry}{faces}");
    let imp = load_mesh_from_memory(Path::new("mem/x.obj"), obj.as_bytes(), files.clone(), &ImportOptions::default())
        .unwrap();
    let m = imp.mesh.materials.iter().find(|m| m.name == "ma").unwrap();
    let t = &imp.mesh.textures[m.base_color_texture.as_ref().unwrap().texture];
    assert_eq!(t.texels_linear[0], [0.0, 0.0, 1.0, 1.0]);
    files.insert(PathBuf::from("mem/t1/a.mtl"), b"newmtl ma\nmap_Kd ../../tex.png\n".to_vec());
    files.insert(PathBuf::from("tex.png"), flat_png(&[0, 0, 255]));
    let e =
        load_mesh_from_memory(Path::new("mem/x.obj"), obj.as_bytes(), files, &ImportOptions::default()).unwrap_err();
    assert!(matches!(e, IoError::OutsideAsset { ref uri, .. } if uri == "../../tex.png"), "{e}");
}

/// One `mtllib` statement may name several libraries (`mtllib a.mtl b.mtl`, as the OBJ format
/// allows): each is read (it was looked up as one file "a.mtl b.mtl" and every material was
/// the default); a file whose name has spaces is still read whole when it exists, before any
/// library its words would name, and each name is still confined to the model's folder.
#[test]
fn obj_mtllib_names_several_libraries_or_one_with_spaces() {
    let kd = |name: &str, rgb: &str| format!("newmtl {name}\nKd {rgb}\n").into_bytes();
    let files = std::collections::BTreeMap::from([
        (PathBuf::from("mem/a.mtl"), kd("ma", "1 0 0")),
        (PathBuf::from("mem/b.mtl"), [kd("mb", "0 1 0"), kd("mc", "0 1 1")].concat()),
        (PathBuf::from("mem/c.mtl"), kd("mc", "0 0 1")),
        (PathBuf::from("mem/my lib.mtl"), kd("ma", "0.5 0.5 0.5")),
        (PathBuf::from("mem/my"), kd("ma", "0 0 0")),
        (PathBuf::from("mem/lib.mtl"), kd("ma", "0.25 0 0")),
    ]);
    let faces = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nusemtl ma\nf 1 2 3\nusemtl mb\nf 1 4 2\nusemtl mc\nf 1 3 4\n";
    let load = |head: &str, files: &std::collections::BTreeMap<PathBuf, Vec<u8>>| {
        let obj = format!("{head}\n{faces}");
        load_mesh_from_memory(Path::new("mem/x.obj"), obj.as_bytes(), files.clone(), &ImportOptions::default())
    };
    // (mtllib line, Kd of ma, mb, mc (None: the default material), libraries read, warnings)
    let d: Option<[f32; 3]> = None;
    let cases = [
        ("mtllib a.mtl b.mtl", [Some([1.0, 0.0, 0.0]), Some([0.0, 1.0, 0.0]), Some([0.0, 1.0, 1.0])], "a b", 0),
        // A later library's definition of a name wins, as with two mtllib lines; tabs separate.
        (
            "mtllib a.mtl\tb.mtl  c.mtl",
            [Some([1.0, 0.0, 0.0]), Some([0.0, 1.0, 0.0]), Some([0.0, 0.0, 1.0])],
            "a b c",
            0,
        ),
        // The file named with a space, not "my" and "lib.mtl".
        ("mtllib my lib.mtl", [Some([0.5, 0.5, 0.5]), d, d], "my lib", 1),
        (
            "mtllib b.mtl my lib.mtl",
            [Some([0.25, 0.0, 0.0]), Some([0.0, 1.0, 0.0]), Some([0.0, 1.0, 1.0])],
            "b my lib",
            0,
        ),
        // A library that is missing is said; the others' materials are read.
        ("mtllib a.mtl none.mtl", [Some([1.0, 0.0, 0.0]), d, d], "a", 1),
        // A name in double quotes is one file, its spaces kept, never split into words.
        ("mtllib \"my lib.mtl\"", [Some([0.5, 0.5, 0.5]), d, d], "my lib", 1),
        ("mtllib \"a.mtl\"", [Some([1.0, 0.0, 0.0]), d, d], "a", 1),
    ];
    for (head, want, libs, warnings) in cases {
        let imp = load(head, &files).unwrap_or_else(|e| panic!("{head:?}: {e}"));
        // Triangle k is face k, of ma, mb, mc.
        for (k, (name, want)) in ["ma", "mb", "mc"].into_iter().zip(want).enumerate() {
            let m = &imp.mesh.materials[imp.mesh.triangle_materials[k] as usize];
            match want {
                Some(rgb) => {
                    assert_eq!((m.name.as_str(), &m.base_color_factor_linear[..3]), (name, &rgb[..]), "{head:?}")
                }
                None => assert_eq!(m.name, "default", "{head:?}: {name}"),
            }
        }
        let read: Vec<String> = imp.inputs[1..]
            .iter()
            .map(|p| p.file_name().unwrap().to_str().unwrap().trim_end_matches(".mtl").to_string())
            .collect();
        assert_eq!(read.join(" "), libs, "{head:?}");
        assert_eq!(imp.warnings.len(), warnings, "{head:?}: {:?}", imp.warnings);
    }
    let imp = load("mtllib a.mtl none.mtl", &files).unwrap();
    assert!(imp.warnings[0].0.contains("\"none.mtl\" not found"), "{:?}", imp.warnings);
    // A quoted name that is missing is said as one name, without its quotes.
    let imp = load("mtllib \"none here.mtl\"", &files).unwrap();
    assert!(imp.warnings[0].0.contains("\"none here.mtl\" not found"), "{:?}", imp.warnings);
    assert_eq!(imp.warnings.len(), 1, "{:?}", imp.warnings);
    // Each name is confined to the model's folder.
    let e = load("mtllib a.mtl ../b.mtl", &files).unwrap_err();
    assert!(matches!(e, IoError::OutsideAsset { ref uri, .. } if uri == "../b.mtl"), "{e}");
    // On disk, as the README promises: a library named with spaces.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("my lib.mtl"), kd("ma", "0.5 0.5 0.5")).unwrap();
    std::fs::write(dir.path().join("m.obj"), format!("mtllib my lib.mtl\n{faces}")).unwrap();
    let imp = load_mesh(&dir.path().join("m.obj")).unwrap();
    assert_eq!(imp.mesh.materials[0].base_color_factor_linear, [0.5, 0.5, 0.5, 1.0]);
    assert_eq!(imp.inputs[1], dir.path().join("my lib.mtl"));
}

/// A quad cube given a second time in another group, each quad's corners reversed
/// (`f 1 3 4 2` then `f 2 4 3 1`) or rotated (`f 3 4 2 1`), imports as the single-sided cube:
/// triangulated from their own first corners the copies would take the other diagonal, so no
/// triangle would repeat (the reversed cube baked as an open sheet, E 53 at 8 spheres).
#[test]
fn obj_polygons_given_again_reversed_or_rotated_are_duplicates() {
    let quads = [[1, 3, 4, 2], [1, 2, 6, 5], [2, 4, 8, 6], [4, 3, 7, 8], [3, 1, 5, 7], [5, 6, 8, 7]];
    let mut one = String::new();
    for z in 0..2 {
        for y in 0..2 {
            for x in 0..2 {
                one += &format!("v {x} {y} {z}\n");
            }
        }
    }
    for q in &quads {
        one += &format!("f {} {} {} {}\n", q[0], q[1], q[2], q[3]);
    }
    // Triangles as sorted corner positions, each with its orientation (the normal's sign).
    let tris = |imp: &spherebake_io::Imported| {
        let p = &imp.mesh.positions;
        let mut v: Vec<([[i32; 3]; 3], [i32; 3])> = imp
            .mesh
            .triangles
            .iter()
            .map(|t| {
                let c = t.map(|i| p[i as usize]);
                let n = (c[1] - c[0]).cross(c[2] - c[0]);
                let mut k = c.map(|v| v.to_array().map(|x| x as i32));
                k.sort_unstable();
                (k, n.to_array().map(|x| x.signum() as i32 * (x != 0.0) as i32))
            })
            .collect();
        v.sort_unstable();
        v
    };
    let single = load_mesh_from_bytes(Path::new("mem/one.obj"), one.as_bytes()).unwrap();
    assert_eq!(single.mesh.triangles.len(), 12);
    for (name, copy) in [("reversed", [3, 2, 1, 0]), ("rotated", [1, 2, 3, 0])] {
        let mut obj = one.clone() + "o copy\n";
        for q in &quads {
            obj += &format!("f {} {} {} {}\n", q[copy[0]], q[copy[1]], q[copy[2]], q[copy[3]]);
        }
        let imp = load_mesh_from_bytes(Path::new("mem/two.obj"), obj.as_bytes()).unwrap();
        assert_eq!(tris(&imp), tris(&single), "{name}");
        assert!(imp.warnings.iter().any(|w| w.0.starts_with("12 duplicate triangles")), "{name}: {:?}", imp.warnings);
        let t = TopologyReport::compute(&imp.mesh);
        assert!(t.closed && t.consistently_oriented, "{name}: {t:?}");
    }
    // A double-sided quad beside the cube, its back reversed: one face per winding, so its kept
    // copy is surface only (the mirrored copy keeps the opposite winding) and the cube closed.
    let obj = one + "v 2 0 0\nv 3 0 0\nv 3 1 0\nv 2 1 0\nf 9 10 11 12\nf 12 11 10 9\n";
    let imp = load_mesh_from_bytes(Path::new("mem/fin.obj"), obj.as_bytes()).unwrap();
    assert_eq!((imp.mesh.triangles.len(), imp.mesh.surface_only.len()), (14, 2), "{:?}", imp.warnings);
    assert!(TopologyReport::compute(&imp.mesh).closed);
}

/// A material with `KHR_materials_transmission` (factor > 0) is warned about as baked opaque,
/// once, naming it; a factor of 0 (the extension's default) and the other material are not.
#[test]
fn transmissive_materials_are_named_as_baked_opaque() {
    let dir = tempfile::tempdir().unwrap();
    let glass = |factor: &str| {
        format!(
            r#","materials":[{{"name":"glass","extensions":{{"KHR_materials_transmission":{{{factor}}}}}}},{{"name":"body"}}],"extensionsUsed":["KHR_materials_transmission"]"#
        )
    };
    let load = |extra: String| {
        let p = dir.path().join("t.gltf");
        std::fs::write(&p, two_material_gltf(&extra)).unwrap();
        load_mesh(&p).unwrap()
    };
    let said = |imp: &spherebake_io::Imported| {
        imp.warnings
            .iter()
            .filter(|w| w.0.contains("KHR_materials_transmission"))
            .map(|w| w.0.clone())
            .collect::<Vec<_>>()
    };
    let imp = load(glass(r#""transmissionFactor":0.9"#));
    let w = said(&imp);
    assert_eq!(w.len(), 1, "{:?}", imp.warnings);
    assert!(w[0].starts_with("material \"glass\"") && w[0].contains("0.9") && w[0].contains("opaque"), "{w:?}");
    assert!(said(&load(glass(""))).is_empty());
    assert!(said(&load(glass(r#""transmissionFactor":0"#))).is_empty());
}

/// A scene's `nodes` is optional in glTF 2.0 (scene.schema.json). A file with a second, empty
/// scene was refused ("missing field `nodes`"); now the scene used imports as before, and when
/// the scene used is the empty one the error says so (not just "no triangles").
#[test]
fn a_scene_without_nodes_is_valid_and_named_when_it_is_the_one_used() {
    let (json, _) = gltf_json(&TRI, Some(&[0, 1, 2]), false, "");
    let two = json.replace(r#""scenes":[{"nodes":[0]}]"#, r#""scenes":[{"nodes":[0]},{"name":"empty"}]"#);
    assert_ne!(two, json, "gltf_json layout changed");
    let imp = load_mesh_from_bytes(Path::new("mem/s.gltf"), two.as_bytes()).expect("an unused empty scene is valid");
    assert_eq!(imp.mesh.triangles, vec![[0, 1, 2]]);
    assert_eq!(imp.mesh.positions, TRI.map(Vec3::from).to_vec());
    let used = two.replace(r#""scene":0"#, r#""scene":1"#);
    assert_ne!(used, two);
    let e = load_mesh_from_bytes(Path::new("mem/s.gltf"), used.as_bytes()).unwrap_err();
    assert!(
        matches!(e, IoError::EmptyMesh { reason: Some(ref r), .. } if r.contains("scene 1") && r.contains("no nodes")),
        "{e}"
    );
    assert!(e.to_string().starts_with("mem/s.gltf: "), "{e}");
}

/// A texture without `source` is valid since glTF 2.0.1 when an extension supplies the image
/// (MSFT_texture_dds here). It was refused ("textures[0].source: Missing data"); now it is a
/// texture that cannot be decoded: a warning naming it and the extension, and the material
/// keeps its base colour factor. The other material's PNG texture (image 0) is still read.
#[test]
fn a_texture_without_a_source_falls_back_to_the_base_colour_factor() {
    let png = b64(&flat_png(&[255, 0, 0]));
    let extra = format!(
        r#","extensionsUsed":["MSFT_texture_dds"],"materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[0.5,0.25,1,1],"baseColorTexture":{{"index":0}}}}}},{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":1}}}}}}],"textures":[{{"extensions":{{"MSFT_texture_dds":{{"source":1}}}}}},{{"source":0}}],"images":[{{"uri":"data:image/png;base64,{png}"}},{{"uri":"t.dds"}}]"#
    );
    let imp = load_mesh_from_bytes(Path::new("mem/t.gltf"), two_material_gltf(&extra).as_bytes())
        .expect("a texture without source is valid glTF 2.0.1");
    let m = &imp.mesh.materials;
    assert_eq!(m.len(), 2);
    assert!(m[0].base_color_texture.is_none());
    assert_eq!(m[0].base_color_factor_linear, [0.5, 0.25, 1.0, 1.0]);
    let w: Vec<&str> = imp.warnings.iter().map(|w| w.0.as_str()).collect();
    assert!(w.iter().any(|w| w.contains("texture 0 has no source image") && w.contains("MSFT_texture_dds")), "{w:?}");
    let t = m[1].base_color_texture.as_ref().expect("the PNG texture is read");
    // sRGB 255 → linear 1, 0 → 0.
    assert_eq!(imp.mesh.textures[t.texture].texels_linear[0][..3], [1.0, 0.0, 0.0]);
}

/// An accessor without a buffer view costs no input bytes whatever its count (zeros plus a
/// sparse block): a 794-byte file whose POSITION claimed 22 million of them, placed by six
/// nodes, took 10 GB and 38 s even with `--max-input-mb 1`. The vertices placed and the values
/// such accessors materialise are now held to the input budget (one per byte each): a file of
/// 2 nodes × 2997 vertices (5994 vertices, 2 × 8991 values) imports with a budget of 20000
/// bytes, and stops with an error naming the limit and `--max-input-mb` at 2000 (vertices,
/// before any is read) and at 10000 (values, at the second node).
#[test]
fn accessors_without_a_buffer_view_are_held_to_the_input_budget() {
    let mut bin = 1u32.to_le_bytes().to_vec();
    bin.extend([1.0f32, 2.0, 3.0].iter().flat_map(|x| x.to_le_bytes()));
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0,1]}}],"nodes":[{{"mesh":0}},{{"mesh":0,"translation":[5,0,0]}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
"buffers":[{{"byteLength":16,"uri":"data:application/octet-stream;base64,{}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":4}},{{"buffer":0,"byteOffset":4,"byteLength":12}}],
"accessors":[{{"componentType":5126,"count":2997,"type":"VEC3","sparse":{{"count":1,"indices":{{"bufferView":0,"componentType":5125}},"values":{{"bufferView":1}}}}}}]}}"#,
        b64(&bin)
    );
    assert!(json.len() < 2000);
    let load = |budget: u64| {
        let opts = ImportOptions { max_input_bytes: budget, ..Default::default() };
        spherebake_io::load_mesh_from_bytes_with(Path::new("mem/v.gltf"), json.as_bytes(), &opts)
    };
    let imp = load(20_000).expect("within the budget");
    let p = &imp.mesh.positions;
    assert_eq!(p.len(), 2 * 2997);
    assert_eq!((p[1], p[2997 + 1], p[2997 + 2]), (Vec3::new(1.0, 2.0, 3.0), Vec3::new(6.0, 2.0, 3.0), Vec3::X * 5.0));
    for budget in [2000, 10_000] {
        let e = refused(load(budget), "over the limit");
        let s = e.to_string();
        assert!(matches!(e, IoError::OverLimit { limit, .. } if limit == budget), "{s}");
        assert!(s.starts_with("mem/v.gltf: ") && s.contains("--max-input-mb"), "{s}");
    }
    let s = refused(load(2000), "over the limit").to_string();
    assert!(s.contains("2997 vertices") && s.contains("over the limit of 2000"), "{s}");
    let s = refused(load(10_000), "over the limit").to_string();
    assert!(s.contains("without a buffer view") && s.contains("17982"), "{s}");
    // With the default budget (1 GiB) such values are also held to 4096 per byte of the JSON
    // that declares them: the same file claiming 22 million vertices stops at once.
    let bomb = json.replace(r#""count":2997,"type":"VEC3","sparse""#, r#""count":22369620,"type":"VEC3","sparse""#);
    assert_ne!(bomb, json);
    let e = refused(spherebake_io::load_mesh_from_bytes(Path::new("mem/v.gltf"), bomb.as_bytes()), "over the limit");
    let s = e.to_string();
    let by_json = bomb.len() as u64 * 4096;
    assert!(matches!(e, IoError::OverJsonLimit { limit, .. } if limit == by_json), "{s}");
    assert!(s.contains("4096 per byte of its") && s.contains("does not raise it"), "{s}");
}

/// Skipped primitives are counted per kind, each once however often its mesh is placed: 1,000
/// nodes placing a mesh of 1,000 POINTS primitives printed 1,000,000 identical warnings. Empty
/// primitives (POSITION count 0) are left out before any placement, so they make no part (5,000
/// nodes × 5,000 of them took 7.7 s and 3 GB). Here 4 nodes place a mesh of one triangle, 3
/// POINTS and 2 empty primitives: 4 parts, 4 triangles, one warning for the 3 POINTS.
#[test]
fn skipped_and_empty_primitives_are_handled_once_per_mesh() {
    let (json, _) = gltf_json(&TRI, Some(&[0, 1, 2]), false, "");
    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["accessors"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({"bufferView":0,"componentType":5126,"count":0,"type":"VEC3"}));
    let prims = v["meshes"][0]["primitives"].as_array_mut().unwrap();
    for _ in 0..3 {
        prims.push(serde_json::json!({"attributes":{"POSITION":0},"mode":0}));
    }
    for _ in 0..2 {
        prims.push(serde_json::json!({"attributes":{"POSITION":2}}));
    }
    v["nodes"] = serde_json::json!([{"mesh":0},{"mesh":0,"translation":[2,0,0]},{"mesh":0,"translation":[4,0,0]},{"mesh":0,"translation":[6,0,0]}]);
    v["scenes"] = serde_json::json!([{"nodes":[0,1,2,3]}]);
    let imp = load_mesh_from_bytes(Path::new("mem/p.gltf"), &serde_json::to_vec(&v).unwrap()).unwrap();
    assert_eq!(imp.parts.len(), 4);
    assert!(imp.parts.iter().all(|p| p.primitive == 0 && p.triangles.len() == 1));
    assert_eq!(imp.mesh.triangles.len(), 4);
    let w: Vec<&str> = imp.warnings.iter().map(|w| w.0.as_str()).collect();
    assert_eq!(w, ["3 Points primitives skipped (only triangles are imported), the first mesh 0 (\"m\") primitive 1"]);
}

/// A node listing itself as a child is a cycle, and the error says so (it said "node has more
/// than one parent"); a node that two nodes list keeps that message.
#[test]
fn a_node_that_is_its_own_child_is_called_a_cycle() {
    let (json, _) = gltf_json(&TRI, Some(&[0, 1, 2]), false, "");
    let own = json.replace(r#""nodes":[{"mesh":0}]"#, r#""nodes":[{"mesh":0,"children":[0]}]"#);
    assert_ne!(own, json, "gltf_json layout changed");
    let e = refused(load_mesh_from_bytes(Path::new("mem/c.gltf"), own.as_bytes()), "a cycle");
    assert_eq!(e.to_string(), "mem/c.gltf: node 0: node is its own child (a cycle)");
    let two = json.replace(r#""nodes":[{"mesh":0}]"#, r#""nodes":[{"mesh":0},{"children":[0]},{"children":[0]}]"#);
    let e = refused(load_mesh_from_bytes(Path::new("mem/c.gltf"), two.as_bytes()), "two parents");
    assert_eq!(e.to_string(), "mem/c.gltf: node 0: node has more than one parent");
}

/// An image whose `uri` is empty names no file: a texture that cannot be read (a warning, the
/// base colour factor), not a refusal of the whole import as a path outside the model's folder.
#[test]
fn an_image_with_an_empty_uri_falls_back_to_the_base_colour_factor() {
    let dir = tempfile::tempdir().unwrap();
    let extra = r#","materials":[{"pbrMetallicRoughness":{"baseColorFactor":[0.25,0.5,0.75,1],"baseColorTexture":{"index":0}}},{}],"textures":[{"source":0}],"images":[{"uri":""}]"#;
    let p = dir.path().join("e.gltf");
    std::fs::write(&p, two_material_gltf(extra)).unwrap();
    let imp = load_mesh(&p).expect("an empty image uri is a texture that cannot be read");
    let m = &imp.mesh.materials[0];
    assert!(m.base_color_texture.is_none());
    assert_eq!(m.base_color_factor_linear, [0.25, 0.5, 0.75, 1.0]);
    let w: Vec<&str> = imp.warnings.iter().map(|w| w.0.as_str()).collect();
    assert!(
        w.contains(&"material \"material0\": image 0 has an empty uri (no file); using the base colour factor"),
        "{w:?}"
    );
    assert_eq!(imp.inputs, [p]);
}

/// A UTF-8 byte-order mark before the JSON is skipped (glTF 2.0 §3.2 and RFC 8259 §8.1 let a
/// reader ignore it), in a `.gltf` file and in JSON text named `.glb`: the same triangle as
/// without it. It was "invalid glTF JSON: expected value at line 1 column 1".
#[test]
fn a_byte_order_mark_before_the_json_is_skipped() {
    let (json, _) = gltf_json(&TRI, Some(&[0, 1, 2]), false, "");
    let mut bom = b"\xEF\xBB\xBF".to_vec();
    bom.extend(json.as_bytes());
    for name in ["mem/b.gltf", "mem/b.glb"] {
        let imp = load_mesh_from_bytes(Path::new(name), &bom).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(imp.mesh.triangles, vec![[0, 1, 2]], "{name}");
        assert_eq!(imp.mesh.positions, TRI.map(Vec3::from).to_vec(), "{name}");
    }
}

/// Every attribute of a primitive has POSITION's count (glTF §3.7.2.1 "MUST"). A NORMAL,
/// TEXCOORD_n or COLOR_0 that differs was dropped silently (the model baked without its
/// normals, texture or colours); now it is an error naming the attribute, both counts and the
/// file, as a JOINTS / WEIGHTS or morph-target mismatch already was. With the count right, the
/// same file imports.
#[test]
fn an_attribute_whose_count_differs_from_positions_is_an_error() {
    let (json, _) = gltf_json(&TRI, Some(&[0, 1, 2]), false, "");
    for (attr, ty, count) in
        [("NORMAL", "VEC3", 2), ("TEXCOORD_0", "VEC2", 4), ("COLOR_0", "VEC4", 1), ("NORMAL", "VEC3", 3)]
    {
        let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
        let accessors = v["accessors"].as_array_mut().unwrap();
        accessors.push(serde_json::json!({"bufferView":0,"componentType":5126,"count":count,"type":ty}));
        let ai = accessors.len() - 1;
        v["meshes"][0]["primitives"][0]["attributes"][attr] = ai.into();
        let r = load_mesh_from_bytes(Path::new("mem/a.gltf"), &serde_json::to_vec(&v).unwrap());
        if count == 3 {
            assert_eq!(r.expect("equal counts import").mesh.triangles, vec![[0, 1, 2]]);
            continue;
        }
        let e = refused(r, "a count mismatch");
        let want = format!(
            "mem/a.gltf: accessor {ai}: mesh 0 (\"m\") primitive 0: {attr} has {count} elements, POSITION 3 (the attributes of a primitive have one count, glTF §3.7.2.1)"
        );
        assert_eq!(e.to_string(), want);
    }
}

/// A `map_Kd` name in double quotes (`map_Kd "my red.png"`) is the file inside them, as an
/// `mtllib` name in quotes is (the quotes were kept, so the texture was not found).
#[test]
fn obj_map_kd_in_quotes_is_the_name_inside() {
    let files = std::collections::BTreeMap::from([
        (PathBuf::from("mem/m.mtl"), b"newmtl t\nmap_Kd -s 1 1 \"my red.png\"\n".to_vec()),
        (PathBuf::from("mem/my red.png"), flat_png(&[255, 0, 0])),
    ]);
    let obj = "mtllib m.mtl\nusemtl t\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5 0.5\nf 1/1 2/1 3/1\n";
    let imp = load_mesh_from_memory(Path::new("mem/x.obj"), obj.as_bytes(), files, &ImportOptions::default()).unwrap();
    assert!(imp.warnings.is_empty(), "{:?}", imp.warnings);
    let tr = imp.mesh.materials[0].base_color_texture.as_ref().expect("the texture in quotes");
    let t = &imp.mesh.textures[tr.texture];
    assert_eq!((t.name.as_str(), t.texels_linear[0]), ("my red.png", [1.0, 0.0, 0.0, 1.0]));
}

/// A `map_Kd` that is a Windows absolute path (`C:\Users\bob\tex\red.png`, a relative name on
/// other systems) and is not found is read by its file name next to the MTL, as Blender reads
/// it, with a warning naming both (the texture was lost); a POSIX absolute path is still
/// refused, and a Windows one whose file is not there either is a missing texture.
#[test]
fn obj_map_kd_windows_absolute_path_is_read_next_to_the_mtl() {
    let load = |map: &str| {
        let files = std::collections::BTreeMap::from([
            (PathBuf::from("mem/mats/m.mtl"), format!("newmtl t\nmap_Kd {map}\n").into_bytes()),
            (PathBuf::from("mem/mats/red.png"), flat_png(&[255, 0, 0])),
            (PathBuf::from("/tex/red.png"), flat_png(&[255, 0, 0])),
        ]);
        let obj = "mtllib mats/m.mtl\nusemtl t\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5 0.5\nf 1/1 2/1 3/1\n";
        load_mesh_from_memory(Path::new("mem/x.obj"), obj.as_bytes(), files, &ImportOptions::default())
    };
    for map in ["C:\\Users\\bob\\tex\\red.png", "d:/tex/red.png"] {
        let imp = load(map).unwrap();
        assert_eq!(imp.warnings.len(), 1, "{map}: {:?}", imp.warnings);
        let w = &imp.warnings[0].0;
        let written = format!("{map:?} not found (looked for mem/mats/{})", map.replace('\\', "/"));
        assert!(w.contains(&written) && w.contains("read mem/mats/red.png, its file name next to"), "{w}");
        let tr = imp.mesh.materials[0].base_color_texture.as_ref().expect("the texture next to the MTL");
        assert_eq!(imp.mesh.textures[tr.texture].texels_linear[0], [1.0, 0.0, 0.0, 1.0]);
        let inputs: Vec<String> = imp.inputs.iter().map(|p| p.display().to_string()).collect();
        assert_eq!(inputs, ["mem/x.obj", "mem/mats/m.mtl", "mem/mats/red.png"]);
        assert!(imp.missing.is_empty(), "{:?}", imp.missing);
    }
    let e = load("/tex/red.png").unwrap_err();
    assert!(matches!(e, IoError::OutsideAsset { .. }), "{e}");
    let imp = load("C:\\tex\\blue.png").unwrap();
    assert!(imp.mesh.materials[0].base_color_texture.is_none());
    assert!(imp.warnings.iter().any(|w| w.0.contains("not found")), "{:?}", imp.warnings);
    let missing: Vec<String> = imp.missing.iter().map(|p| p.display().to_string()).collect();
    assert_eq!(missing, ["mem/mats/C:/tex/blue.png", "mem/mats/blue.png"]);
}

/// OBJ vertex colours (`v x y z r g b`) are the mesh's vertex colours, read as sRGB and made
/// linear as Blender reads them (they were dropped): a vertex without one is white, one whose
/// values are not three numbers too, values outside [0, 1] are clamped with a warning, and a
/// weighted vertex (`v x y z w`) among coloured ones keeps its position x/w y/w z/w.
#[test]
fn obj_vertex_colours_are_read_as_srgb() {
    let p = Path::new("mem/c.obj");
    let obj = "v 0 0 0 1 0.5 0\nv 2 0 0 2\nv 0 1 0 0 0 1.5\nv 0 0 1 0.5 x 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
    let imp = load_mesh_from_bytes(p, obj.as_bytes()).unwrap();
    // Vertices in the order of first use: v1, v3, v2, v4, then the copies the tetrahedron's
    // sharp edges split off, each with its vertex's colour. sRGB 0.5 is
    // ((0.5 + 0.055) / 1.055)^2.4.
    let half = 0.214_041_14;
    let want = [[1.0, half, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0], [1.0; 4], [1.0; 4]];
    let at = [Vec3::ZERO, Vec3::new(0.0, 1.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0)];
    assert_eq!(imp.mesh.colors_linear.len(), imp.mesh.positions.len());
    for (got, p) in imp.mesh.colors_linear.iter().zip(&imp.mesh.positions) {
        let want = want[at.iter().position(|q| q == p).unwrap()];
        assert!(got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-6), "{:?}", imp.mesh.colors_linear);
    }
    assert_eq!(imp.mesh.positions[2], Vec3::new(1.0, 0.0, 0.0));
    assert_eq!(imp.warnings.len(), 1, "{:?}", imp.warnings);
    assert!(imp.warnings[0].0.contains("colours outside [0, 1] clamped: 0 material colour(s)"), "{:?}", imp.warnings);
    assert!(imp.warnings[0].0.contains("1 vertex colour(s)"), "{:?}", imp.warnings);
    // Every vertex coloured: no rewrite; no colour at all: none.
    let all = "v 0 0 0 0 0 0\nv 1 0 0 1 1 1\nv 0 1 0 0.5 0.5 0.5\nf 1 2 3\n";
    let imp = load_mesh_from_bytes(p, all.as_bytes()).unwrap();
    let grey = [half, half, half, 1.0];
    let close = |a: &[f32; 4], b: &[f32; 4]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6);
    assert_eq!(imp.mesh.colors_linear.len(), 3);
    assert!(imp.mesh.colors_linear.iter().zip([[0.0, 0.0, 0.0, 1.0], [1.0; 4], grey]).all(|(a, b)| close(a, &b)));
    let plain = load_mesh_from_bytes(p, b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    assert!(plain.mesh.colors_linear.is_empty());
}

/// A UTF-16 or binary OBJ is refused as not UTF-8 text, saying why (it was "no triangles to
/// import"); a Latin-1 byte in a comment of a file that has triangles still imports, and one
/// where the bytes that are not UTF-8 leave no triangle is named by its first such byte.
#[test]
fn obj_that_is_not_utf8_text_says_so() {
    let p = Path::new("mem/u.obj");
    let t = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let utf16 = |bom: bool, big: bool| -> Vec<u8> {
        let units = bom.then_some(0xFEFFu16).into_iter().chain(t.encode_utf16());
        units.flat_map(|u| if big { u.to_be_bytes() } else { u.to_le_bytes() }).collect()
    };
    let cases: [(Vec<u8>, &str); 4] = [
        (utf16(true, false), "mem/u.obj: is not UTF-8 text (it starts with a UTF-16 little-endian byte-order mark)"),
        (utf16(true, true), "mem/u.obj: is not UTF-8 text (it starts with a UTF-16 big-endian byte-order mark)"),
        (utf16(false, false), "mem/u.obj: is not UTF-8 text (a NUL byte at offset 1: UTF-16 or binary)"),
        (
            b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR".to_vec(),
            "mem/u.obj: is not UTF-8 text (a NUL byte at offset 8: UTF-16 or binary)",
        ),
    ];
    for (bytes, want) in cases {
        let e = load_mesh_from_bytes(p, &bytes).unwrap_err();
        assert_eq!(e.to_string(), want);
    }
    let mut latin1 = b"# caf\xe9\n".to_vec();
    latin1.extend_from_slice(t.as_bytes());
    assert_eq!(load_mesh_from_bytes(p, &latin1).unwrap().mesh.triangles.len(), 1);
    let e = load_mesh_from_bytes(p, b"# caf\xe9\nnothing of an OBJ\n").unwrap_err();
    assert_eq!(e.to_string(), "mem/u.obj: is not UTF-8 text (byte 0xe9 at offset 5 is not UTF-8)");
    // A point cloud with a Latin-1 comment is read: it has no faces, and says that.
    let e = load_mesh_from_bytes(p, b"# caf\xe9\nv 0 0 0\n").unwrap_err();
    assert!(matches!(e, IoError::EmptyMesh { .. }), "{e}");
    // UTF-8 text with no triangle is what it was.
    let e = load_mesh_from_bytes(p, b"# cafe\nv 0 0 0\n").unwrap_err();
    assert!(matches!(e, IoError::EmptyMesh { .. }), "{e}");
}

/// A short index accessor placed many times (here by `EXT_mesh_gpu_instancing` with 5000
/// instances from an accessor without a buffer view) is held to the triangle limit before the
/// instances are listed: 5000 × 1000 triangles from a file of under 2 KB. With a budget of
/// 10⁶ bytes (10⁶ triangles) it stops with an error naming triangles and `--max-input-mb`;
/// 500 instances (500 000 triangles) import.
#[test]
fn triangles_placed_many_times_are_held_to_the_input_budget() {
    let mut bin: Vec<u8> =
        [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0].iter().flat_map(|x| x.to_le_bytes()).collect();
    bin.extend(1u32.to_le_bytes());
    bin.extend([0.0f32; 3].iter().flat_map(|x| x.to_le_bytes()));
    bin.extend([0u8, 1, 2].repeat(1000));
    let json = |instances: usize| {
        format!(
            r#"{{"asset":{{"version":"2.0"}},"extensionsUsed":["EXT_mesh_gpu_instancing"],"scene":0,"scenes":[{{"nodes":[0]}}],
"nodes":[{{"mesh":0,"extensions":{{"EXT_mesh_gpu_instancing":{{"attributes":{{"TRANSLATION":2}}}}}}}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
"buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":52,"byteLength":3000}},{{"buffer":0,"byteOffset":36,"byteLength":4}},{{"buffer":0,"byteOffset":40,"byteLength":12}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},{{"bufferView":1,"componentType":5121,"count":3000,"type":"SCALAR"}},
{{"componentType":5126,"count":{instances},"type":"VEC3","sparse":{{"count":1,"indices":{{"bufferView":2,"componentType":5125}},"values":{{"bufferView":3}}}}}}]}}"#,
            bin.len(),
            b64(&bin)
        )
    };
    let opts = ImportOptions { max_input_bytes: 1_000_000, ..Default::default() };
    let load = |n: usize| spherebake_io::load_mesh_from_bytes_with(Path::new("mem/i.gltf"), json(n).as_bytes(), &opts);
    let e = refused(load(5000), "over the triangle limit");
    let s = e.to_string();
    assert!(matches!(e, IoError::OverLimit { limit: 1_000_000, .. }), "{s}");
    assert!(s.contains("5000000 triangles") && s.contains("--max-input-mb"), "{s}");
    let imp = load(500).expect("within the budget");
    // Every instance sits at the origin: 500 × 1000 copies of one triangle, one kept.
    assert_eq!(imp.mesh.triangles.len(), 1);
    assert!(imp.warnings.iter().any(|w| w.0.starts_with("499999 duplicate triangles")), "{:?}", imp.warnings);
}

/// An OBJ group whose faces mix `vn` and no `vn` gets all its normals from its faces, and says
/// so (the `vn` it gives were dropped silently); a group with `vn` on every face keeps them.
#[test]
fn obj_group_mixing_faces_with_and_without_vn_is_warned() {
    let p = Path::new("mem/tilt.obj");
    let v = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0.3 0.3 1\n";
    let mixed = load_mesh_from_bytes(p, format!("{v}f 1 2 4\nf 1//1 4//1 3//1\n").as_bytes()).unwrap();
    assert!(mixed.warnings.iter().any(|w| w.0.contains("some faces have no normals (vn)")), "{:?}", mixed.warnings);
    // Computed: the plane's normal, not the tilted vn.
    assert!(mixed.mesh.normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-6), "{:?}", mixed.mesh.normals);
    let all = load_mesh_from_bytes(p, format!("{v}f 1//1 2//1 4//1\nf 1//1 4//1 3//1\n").as_bytes()).unwrap();
    assert!(all.warnings.is_empty(), "{:?}", all.warnings);
    let tilted = Vec3::new(0.3, 0.3, 1.0).normalize();
    assert!(all.mesh.normals.iter().all(|n| (*n - tilted).length() < 1e-6), "{:?}", all.mesh.normals);
}

/// OBJ smoothing groups (`s`) decide the computed normals when the file has them: `s off` /
/// `s 0` faces are flat, faces of one group `s N` are smooth across every edge between them
/// whatever its angle, and not across to another group; without `s` lines the 60° crease
/// decides (a cube flat, a 16-sided prism smooth around its sides).
#[test]
fn obj_smoothing_groups_decide_the_computed_normals() {
    let p = Path::new("mem/s.obj");
    // The unit cube, outward quads.
    let v: String = (0..8).map(|i| format!("v {} {} {}\n", i & 1, (i >> 1) & 1, (i >> 2) & 1)).collect();
    let quads = [[1, 3, 4, 2], [5, 6, 8, 7], [1, 2, 6, 5], [3, 7, 8, 4], [1, 5, 7, 3], [2, 4, 8, 6]];
    let f: String = quads.iter().map(|q| format!("f {} {} {} {}\n", q[0], q[1], q[2], q[3])).collect();
    let normal_at = |imp: &spherebake_io::Imported, t: usize, k: usize| {
        let tri = imp.mesh.triangles[t];
        (imp.mesh.positions[tri[k] as usize], imp.mesh.normals[tri[k] as usize])
    };
    let face = |imp: &spherebake_io::Imported, t: usize| {
        let [a, b, c] = imp.mesh.triangles[t].map(|v| imp.mesh.positions[v as usize]);
        (b - a).cross(c - a).normalize()
    };
    // The area-weighted mean of the triangles `which` at position q (taken from the import's
    // triangles by construction, not by angle).
    let mean = |imp: &spherebake_io::Imported, q: Vec3, which: &dyn Fn(usize) -> bool| {
        let sum: Vec3 = (0..imp.mesh.triangles.len())
            .filter(|&t| which(t) && imp.mesh.triangles[t].iter().any(|&v| imp.mesh.positions[v as usize] == q))
            .map(|t| {
                let [a, b, c] = imp.mesh.triangles[t].map(|v| imp.mesh.positions[v as usize]);
                (b - a).cross(c - a)
            })
            .sum();
        sum.normalize()
    };
    // One group: each corner is the mean of every triangle there (leaning to the diagonal).
    let smooth = load_mesh_from_bytes(p, format!("{v}s 1\n{f}").as_bytes()).unwrap();
    for t in 0..smooth.mesh.triangles.len() {
        for k in 0..3 {
            let (q, n) = normal_at(&smooth, t, k);
            let want = mean(&smooth, q, &|_| true);
            assert!((n - want).length() < 1e-5, "corner {q}: {n} vs {want}");
            assert!(n.dot((q - Vec3::splat(0.5)).normalize()) > 0.9, "corner {q}: {n}");
        }
    }
    // Any number is a group: one past u32, one followed by a comment.
    for line in ["s 99999999999", "s 1#c"] {
        let same = load_mesh_from_bytes(p, format!("{v}{line}\n{f}").as_bytes()).unwrap();
        assert_eq!(same.mesh.normals, smooth.mesh.normals, "{line}");
    }
    // Faces wound the other way (an inconsistent file; the bake orients them later): each
    // corner keeps the smooth normal, turned to its own face's side, instead of opposite faces
    // cancelling. The side wall of an 8-sided prism (faces 45° apart), as triangles, every
    // third reversed; against the same triangles all wound outward.
    let ring: String = (0..16)
        .map(|i| {
            let a = (i % 8) as f32 * std::f32::consts::TAU / 8.0;
            format!("v {} {} {}\n", a.cos(), a.sin(), (i / 8) as f32)
        })
        .collect();
    let wall = |flip: bool| -> String {
        (0..8u32)
            .flat_map(|i| {
                let j = (i + 1) % 8;
                [[i + 1, j + 1, j + 9], [i + 1, j + 9, i + 9]]
            })
            .enumerate()
            .map(|(n, t)| if flip && n % 3 == 0 { [t[0], t[2], t[1]] } else { t })
            .map(|t| format!("f {} {} {}\n", t[0], t[1], t[2]))
            .collect()
    };
    let outward = load_mesh_from_bytes(p, format!("{ring}s 1\n{}", wall(false)).as_bytes()).unwrap();
    let mixed = load_mesh_from_bytes(p, format!("{ring}s 1\n{}", wall(true)).as_bytes()).unwrap();
    assert_eq!(mixed.mesh.triangles.len(), outward.mesh.triangles.len());
    for t in 0..mixed.mesh.triangles.len() {
        for k in 0..3 {
            let (q, n) = normal_at(&mixed, t, k);
            let want = mean(&outward, q, &|_| true);
            assert!(want.z.abs() < 1e-6 && want.dot(Vec3::new(q.x, q.y, 0.0)) > 0.0, "{want}");
            let side = if face(&mixed, t).dot(want) < 0.0 { -want } else { want };
            assert!((n - side).length() < 1e-5, "triangle {t} corner {q}: {n} vs {side}");
        }
    }
    // `s off`, `s 0`, and no `s` line (the crease): every corner its face's normal.
    for text in [format!("{v}s off\n{f}"), format!("{v}s 0\n{f}"), format!("{v}{f}")] {
        let flat = load_mesh_from_bytes(p, text.as_bytes()).unwrap();
        for t in 0..flat.mesh.triangles.len() {
            for k in 0..3 {
                let (q, n) = normal_at(&flat, t, k);
                assert!((n - face(&flat, t)).length() < 1e-5, "corner {q}: {n}");
            }
        }
    }
    // Two groups: the bottom and top faces (z = 0, z = 1) in group 2, the sides in group 1.
    // A side corner is the mean of the side triangles there (horizontal), a cap corner its
    // cap's normal.
    let caps: String = quads[..2].iter().map(|q| format!("f {} {} {} {}\n", q[0], q[1], q[2], q[3])).collect();
    let sides: String = quads[2..].iter().map(|q| format!("f {} {} {} {}\n", q[0], q[1], q[2], q[3])).collect();
    let two = load_mesh_from_bytes(p, format!("{v}s 2\n{caps}s 1\n{sides}").as_bytes()).unwrap();
    for t in 0..two.mesh.triangles.len() {
        for k in 0..3 {
            let (q, n) = normal_at(&two, t, k);
            let want = if t < 4 { face(&two, t) } else { mean(&two, q, &|o| o >= 4) };
            assert!(t < 4 || want.z.abs() < 1e-6, "a side corner is horizontal: {want}");
            assert!((n - want).length() < 1e-5, "triangle {t} corner {q}: {n} vs {want}");
        }
    }
}
