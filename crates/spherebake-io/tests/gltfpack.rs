//! gltfpack output (`KHR_mesh_quantization`, `EXT_meshopt_compression`, `KHR_meshopt_compression`)
//! imports like its source: fixtures in `fixtures/gltfpack/` (how they were made:
//! `fixtures/README.md`) against the repository fixtures they were made from.
//!
//! Bounds are derived from gltfpack's defaults, not measured: positions are quantized to 14 bits
//! over the largest extent of the mesh box (`-vp 14`), so each coordinate is within half a step
//! `extent / (2^14 − 1)` of the source; texture coordinates to 12 bits over their range
//! (`-vt 12`); normals to 8 bits (`-vn 8`); colours to 8 bits (`-vc 8`); rotations to 12 bits
//! (`-ar 12`). The meshopt codecs are lossless, so `-c` must give bit-identical data to the
//! uncompressed quantized `.q.glb`; the `-cc` / `-cz` filters (octahedral normals, quaternion
//! rotations, YCoCg colours) are lossy only within the same bit budgets.

use std::path::{Path, PathBuf};

use spherebake_geom::glam::{Quat, Vec3};
use spherebake_geom::topology::TopologyReport;
use spherebake_geom::AnimPath;
use spherebake_io::{load_mesh, load_mesh_from_bytes, Imported, IoError};
use spherebake_testkit::shared_model;

fn fixture(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures").join(p)
}

fn load(p: &str) -> Imported {
    load_mesh(&fixture(p)).unwrap_or_else(|e| panic!("{p}: {e}"))
}

const ARM: [&str; 4] = [
    "gltfpack/skinned-arm.q.glb",
    "gltfpack/skinned-arm.c.glb",
    "gltfpack/skinned-arm.cc.glb",
    "gltfpack/skinned-arm.cz.glb",
];

/// Largest AABB extent of a mesh.
fn extent(m: &spherebake_geom::Mesh) -> f32 {
    let (lo, hi) = m.positions.iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    (hi - lo).max_element()
}

/// For every source vertex, some imported vertex lies within `pos_tol` whose normal is within
/// `angle_tol` radians; returns the largest position error seen.
fn every_vertex_found(src: &spherebake_geom::Mesh, got: &spherebake_geom::Mesh, pos_tol: f32, angle_tol: f32) -> f32 {
    let mut worst = 0.0f32;
    for (i, (p, n)) in src.positions.iter().zip(&src.normals).enumerate() {
        let best = got
            .positions
            .iter()
            .zip(&got.normals)
            .filter(|(_, gn)| gn.dot(*n) >= angle_tol.cos())
            .map(|(gp, _)| gp.distance(*p))
            .fold(f32::INFINITY, f32::min);
        assert!(best <= pos_tol, "source vertex {i} at {p}: nearest match {best} > {pos_tol}");
        worst = worst.max(best);
    }
    worst
}

#[test]
fn quantized_and_compressed_arm_match_the_source() {
    let src = load("skinned-arm.gltf");
    let sr = TopologyReport::compute(&src.mesh);
    let step = extent(&src.mesh) / 16383.0;
    // Half a step per axis, plus f32 rounding of the dequantization transform.
    let pos_tol = 0.5 * step * 3f32.sqrt() + 1e-6;
    // 8-bit normals: each component within 0.5/127 (plain) or one octahedral cell (filter),
    // well inside 0.02 rad.
    let angle_tol = 0.02;
    for f in ARM {
        let imp = load(f);
        assert!(imp.warnings.is_empty(), "{f}: {:?}", imp.warnings);
        let r = TopologyReport::compute(&imp.mesh);
        assert_eq!(r.triangle_count, sr.triangle_count, "{f}");
        assert_eq!(r.welded_vertex_count, sr.welded_vertex_count, "{f}");
        assert!(r.closed && r.consistently_oriented, "{f}: {r:?}");
        assert_eq!(r.component_count, sr.component_count, "{f}");
        // |ΔV| ≤ area × largest displacement.
        let dv = (r.signed_volume - sr.signed_volume).abs();
        assert!(dv <= sr.surface_area * f64::from(pos_tol), "{f}: volume {} vs {}", r.signed_volume, sr.signed_volume);
        let worst = every_vertex_found(&src.mesh, &imp.mesh, pos_tol, angle_tol);
        println!(
            "{f}: volume {} (source {}), worst position error {worst} (step {step})",
            r.signed_volume, sr.signed_volume
        );
        // Skin: same joints, every vertex still fully weighted.
        let skin = imp.mesh.skin.as_ref().expect("skinned");
        assert_eq!(skin.skeleton.bones.len(), 3, "{f}");
        for inf in &skin.influences {
            let w: f32 = inf.weights.iter().sum();
            assert!((w - 1.0).abs() < 0.02, "{f}: weights sum {w}");
        }
    }
}

/// Triangles as corner positions (f32 bits), each rotated to start at its smallest corner, sorted:
/// equal for meshes with the same geometry whatever their vertex and triangle order.
fn triangle_soup(m: &spherebake_geom::Mesh) -> Vec<[[u32; 3]; 3]> {
    let mut out: Vec<[[u32; 3]; 3]> = m
        .triangles
        .iter()
        .map(|t| {
            let c = t.map(|v| m.positions[v as usize].to_array().map(f32::to_bits));
            let k = (0..3).min_by_key(|&k| c[k]).unwrap();
            [c[k], c[(k + 1) % 3], c[(k + 2) % 3]]
        })
        .collect();
    out.sort_unstable();
    out
}

#[test]
fn meshopt_decoding_is_lossless_against_the_uncompressed_quantized_file() {
    let q = load("gltfpack/skinned-arm.q.glb");
    let qs = q.mesh.skin.as_ref().unwrap();
    // `-c`: same vertex order as the uncompressed file, so every decoded byte must match. The
    // index encoder may rotate a triangle's corners (keeping its orientation).
    let c = load("gltfpack/skinned-arm.c.glb");
    let rot = |t: &[u32; 3]| {
        let k = (0..3).min_by_key(|&k| t[k]).unwrap();
        [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
    };
    let (ct, qt): (Vec<_>, Vec<_>) =
        (c.mesh.triangles.iter().map(rot).collect(), q.mesh.triangles.iter().map(rot).collect());
    assert_eq!(ct, qt, "index codec");
    assert_eq!(c.mesh.positions, q.mesh.positions, "attribute codec: positions bit-identical");
    assert_eq!(c.mesh.normals, q.mesh.normals, "attribute codec: normals bit-identical");
    let cs = c.mesh.skin.as_ref().unwrap();
    assert_eq!(cs.influences, qs.influences, "joints and weights");
    assert_eq!(cs.skeleton.animations, qs.skeleton.animations, "animation keys");
    // `-cc` / `-cz` reorder vertices and triangles differently, but positions stay bit-identical:
    // the same triangles, corner for corner; normals pass the octahedral filter (8-bit
    // octahedral vs 8-bit plain: within 0.02 rad of each other).
    let soup = triangle_soup(&q.mesh);
    for f in &ARM[2..] {
        let c = load(f);
        assert_eq!(triangle_soup(&c.mesh), soup, "{f}");
        for (p, n) in c.mesh.positions.iter().zip(&c.mesh.normals) {
            let k = q.mesh.positions.iter().position(|x| x == p).unwrap();
            let ok = (k..q.mesh.positions.len())
                .filter(|&j| q.mesh.positions[j] == *p)
                .any(|j| q.mesh.normals[j].dot(*n) >= 0.02f32.cos());
            assert!(ok, "{f}: normal {n} at {p}");
        }
    }
}

#[test]
fn external_bin_with_a_uri_less_fallback_buffer() {
    let glb = load("gltfpack/skinned-arm.c.glb");
    let gltf = load("gltfpack/skinned-arm.c.gltf");
    assert_eq!(gltf.mesh.positions, glb.mesh.positions);
    assert_eq!(gltf.mesh.triangles, glb.mesh.triangles);
    assert_eq!(gltf.mesh.normals, glb.mesh.normals);
    // The compressed .bin is an input; the fallback buffer is never read.
    let names: Vec<String> =
        gltf.inputs.iter().map(|p| p.file_name().unwrap().to_string_lossy().into_owned()).collect();
    assert_eq!(names, ["skinned-arm.c.gltf", "skinned-arm.c.bin"]);
}

#[test]
fn animation_survives_resampling_quantization_and_the_quaternion_filter() {
    // Source: the elbow turns about +Z by 90°·t for t in [0, 1] (LINEAR = slerp between the
    // 0°, 45°, 90° keys, so the angle is exactly linear in t). gltfpack resamples at 30 Hz and
    // stores 12-bit rotations (≤ 1/2047 per component, ~5e-4); allow 2e-3 for its resampler.
    for f in ARM {
        let imp = load(f);
        let sk = &imp.mesh.skin.as_ref().unwrap().skeleton;
        assert_eq!(sk.animations.len(), 1, "{f}");
        let elbow = sk.nodes.iter().position(|n| n.name == "elbow").expect("elbow node");
        let ch = sk.animations[0]
            .channels
            .iter()
            .find(|c| c.node == elbow && c.path == AnimPath::Rotation)
            .unwrap_or_else(|| panic!("{f}: no elbow rotation"));
        assert!(ch.times.len() >= 3, "{f}");
        assert!(ch.times[0].abs() < 1e-6 && (ch.times.last().unwrap() - 1.0).abs() < 1e-6, "{f}: {:?}", ch.times);
        let mut worst = 0.0f32;
        for (t, q) in ch.times.iter().zip(ch.values.chunks_exact(4)) {
            let want = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2 * t);
            let got = Quat::from_xyzw(q[0], q[1], q[2], q[3]);
            let err = (got - want).length().min((got + want).length());
            worst = worst.max(err);
            assert!(err < 2e-3, "{f}: t {t}: {got:?} vs {want:?}");
        }
        println!("{f}: {} keys, worst quaternion error {worst}", ch.times.len());
    }
}

#[test]
fn textured_cube_uvs_through_the_dequantizing_texture_transform() {
    let src = load("textured-cube/textured-cube.gltf");
    let imp = load("gltfpack/textured-cube.cc.glb");
    assert!(imp.warnings.is_empty(), "{:?}", imp.warnings);
    let r = TopologyReport::compute(&imp.mesh);
    assert_eq!(r.triangle_count, 12);
    assert!(r.closed);
    let pos_tol = 0.5 * 1.0 / 16383.0 * 3f32.sqrt() + 1e-6;
    assert!((r.signed_volume - 1.0).abs() <= 6.0 * f64::from(pos_tol), "volume {}", r.signed_volume);
    // The texture itself is carried over unchanged.
    assert_eq!(imp.mesh.textures.len(), 1);
    assert_eq!(imp.mesh.textures[0].texels_linear, src.mesh.textures[0].texels_linear);
    let tex = imp.mesh.materials[0].base_color_texture.as_ref().expect("textured");
    let t = tex.transform;
    assert_eq!(t.rotation_rad, 0.0, "gltfpack dequantizes with offset and scale only");
    let uv_range = 1.0f32; // source UVs span [0, 1]
    let uv_tol = 0.5 * uv_range / 4095.0 + 1e-6;
    let uvs = &imp.mesh.uvs[tex.uv_set as usize];
    for (i, ((p, n), suv)) in src.mesh.positions.iter().zip(&src.mesh.normals).zip(&src.mesh.uvs[0]).enumerate() {
        let k = (0..imp.mesh.positions.len())
            .find(|&k| imp.mesh.positions[k].distance(*p) <= pos_tol && imp.mesh.normals[k].dot(*n) > 0.99)
            .unwrap_or_else(|| panic!("source vertex {i} not found"));
        let raw = uvs[k];
        let eff = [t.offset[0] + t.scale[0] * raw[0], t.offset[1] + t.scale[1] * raw[1]];
        assert!(
            (eff[0] - suv[0]).abs() <= uv_tol && (eff[1] - suv[1]).abs() <= uv_tol,
            "vertex {i}: {eff:?} vs {suv:?}"
        );
    }
}

#[test]
fn vertex_colours_through_the_color_filter() {
    let Some(src_path) = shared_model("gltf/BoxVertexColors.glb") else { return };
    let src = load_mesh(&src_path).unwrap();
    for f in ["gltfpack/BoxVertexColors.cc.glb", "gltfpack/BoxVertexColors.cz.glb"] {
        let imp = load(f);
        assert_eq!(imp.mesh.triangles.len(), 12);
        let r = TopologyReport::compute(&imp.mesh);
        assert!(r.closed && (r.signed_volume - 1.0).abs() < 1e-3, "{f}: {r:?}");
        // 8-bit colours: half a unit; the YCoCg filter (`-cz`) adds at most one more unit.
        let tol = 1.5 / 255.0;
        let pos_tol = 0.5 / 16383.0 * 3f32.sqrt() + 1e-6;
        for (i, (p, c)) in src.mesh.positions.iter().zip(&src.mesh.colors_linear).enumerate() {
            let ok = (0..imp.mesh.positions.len()).any(|k| {
                imp.mesh.positions[k].distance(*p) <= pos_tol
                    && imp.mesh.colors_linear[k].iter().zip(c).all(|(a, b)| (a - b).abs() <= tol)
            });
            assert!(ok, "{f}: source vertex {i} colour {c:?} not found");
        }
    }
}

#[test]
fn gpu_instancing_places_every_instance() {
    // Source: three placements of the unit cube (see fixtures/README.md). Tolerance: half a 14-bit
    // step of the unit cube, times the largest instance scale (2), plus the 12-bit rotation
    // (about 1e-3 rad at up to 1.6 from the instance origin), plus 16-bit exponential
    // translations/scales (2^-16 relative, at most 4 units): about 1.8e-3.
    // cubes.gltf shares ../textured-cube/textured-cube.bin, a file outside its folder: the
    // default import refuses it (issue 17), a trusted layout opts in.
    let e = load_mesh(&fixture("gltfpack/cubes.gltf")).unwrap_err();
    assert!(matches!(e, IoError::OutsideAsset { ref uri, .. } if uri == "../textured-cube/textured-cube.bin"), "{e}");
    let trusted = spherebake_io::ImportOptions { allow_outside_paths: true, ..Default::default() };
    let src = spherebake_io::load_mesh_with(&fixture("gltfpack/cubes.gltf"), &trusted).unwrap();
    let imp = load("gltfpack/cubes.mi.cc.glb");
    assert!(imp.warnings.is_empty(), "{:?}", imp.warnings);
    assert_eq!(imp.parts.len(), 3);
    let (sr, r) = (TopologyReport::compute(&src.mesh), TopologyReport::compute(&imp.mesh));
    assert_eq!((r.triangle_count, r.component_count), (36, 3));
    assert!(r.closed && r.consistently_oriented);
    assert!((sr.signed_volume - 3.0).abs() < 1e-6);
    let tol = 2e-3f32;
    assert!((r.signed_volume - 3.0).abs() < sr.surface_area * f64::from(tol), "volume {}", r.signed_volume);
    let worst = every_vertex_found(&src.mesh, &imp.mesh, tol, 0.02);
    println!("instancing: worst position error {worst}");
}

/// Splits a GLB into JSON text and BIN chunk.
fn split_glb(b: &[u8]) -> (String, Vec<u8>) {
    let u = |o: usize| u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]) as usize;
    let jl = u(12);
    let json = String::from_utf8(b[20..20 + jl].to_vec()).unwrap();
    let bl = u(20 + jl);
    (json, b[28 + jl..28 + jl + bl].to_vec())
}

fn join_glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend(((28 + j.len() + bin.len()) as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(0x4E4F_534Au32.to_le_bytes());
    out.extend(&j);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(0x004E_4942u32.to_le_bytes());
    out.extend(bin);
    out
}

#[test]
fn malformed_compressed_views_give_named_errors_never_panics() {
    let bytes = std::fs::read(fixture("gltfpack/skinned-arm.cc.glb")).unwrap();
    let (json, bin) = split_glb(&bytes);
    let p = Path::new("mem/arm.glb");
    assert!(load_mesh_from_bytes(p, &join_glb(&json, &bin)).is_ok());
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let view0 = &v["bufferViews"][0]["extensions"]["EXT_meshopt_compression"];
    let len0 = view0["byteLength"].as_u64().unwrap();
    // A compressed byte range one byte short: the error names the view and the extension.
    let short = json.replacen(&format!("\"byteLength\":{len0}"), &format!("\"byteLength\":{}", len0 - 1), 1);
    assert_ne!(short, json);
    let e = load_mesh_from_bytes(p, &join_glb(&short, &bin)).unwrap_err();
    assert!(
        matches!(&e, IoError::CompressedView { view: 0, extension, .. } if extension == "EXT_meshopt_compression"),
        "{e}"
    );
    assert!(e.to_string().contains("buffer view 0") && e.to_string().contains("mem/arm.glb"), "{e}");
    // An unknown filter name.
    let bad = json.replacen("\"OCTAHEDRAL\"", "\"SPIRAL\"", 1);
    let e = load_mesh_from_bytes(p, &join_glb(&bad, &bin)).unwrap_err();
    assert!(matches!(&e, IoError::CompressedView { .. }) && e.to_string().contains("SPIRAL"), "{e}");
    // A view of the fallback buffer (which has no data) without the extension.
    let mut v2 = v.clone();
    v2["bufferViews"][0].as_object_mut().unwrap().remove("extensions");
    let e = load_mesh_from_bytes(p, &join_glb(&v2.to_string(), &bin)).unwrap_err();
    assert!(matches!(&e, IoError::Buffer { .. }) && e.to_string().contains("fallback"), "{e}");
    // Every byte of the compressed data replaced (codec v0 and v1 files): Ok or Err, never a
    // panic; many are caught by the stream structure checks.
    for f in ["gltfpack/skinned-arm.cc.glb", "gltfpack/skinned-arm.cz.glb"] {
        let (json, bin) = split_glb(&std::fs::read(fixture(f)).unwrap());
        let mut errors = 0;
        for i in 0..bin.len() {
            for x in [0x00u8, 0xff] {
                if bin[i] == x {
                    continue;
                }
                let mut b = bin.clone();
                b[i] = x;
                if load_mesh_from_bytes(p, &join_glb(&json, &b)).is_err() {
                    errors += 1;
                }
            }
        }
        println!("{f}: {errors} of {} single-byte corruptions rejected", 2 * bin.len());
        assert!(errors > 0);
    }
}

/// A one-triangle glTF with a base colour factor and `extra` spliced into the root JSON.
fn tri_gltf(extra: &str, texture: &str) -> String {
    let bin: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|x| x.to_le_bytes()).collect();
    let b64 = {
        const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        bin.chunks(3)
            .flat_map(|c| {
                let n = (u32::from(c[0]) << 16) | (u32::from(c[1]) << 8) | u32::from(c[2]);
                (0..4).map(move |k| A[(n >> (18 - 6 * k)) as usize & 63] as char)
            })
            .collect::<String>()
    };
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"material":0}}]}}],
"materials":[{{"name":"m","pbrMetallicRoughness":{{"baseColorFactor":[0.25,0.5,0.75,1]{texture}}}}}],
"buffers":[{{"byteLength":36,"uri":"data:application/octet-stream;base64,{b64}"}}],
"bufferViews":[{{"buffer":0,"byteLength":36}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}]{extra}}}"#
    )
}

#[test]
fn draco_is_a_named_error_and_basis_and_avif_textures_fall_back_with_a_warning() {
    let p = Path::new("mem/t.gltf");
    assert!(load_mesh_from_bytes(p, tri_gltf("", "").as_bytes()).is_ok());
    let draco = tri_gltf(
        r#","extensionsUsed":["KHR_draco_mesh_compression"],"extensionsRequired":["KHR_draco_mesh_compression"]"#,
        "",
    );
    let e = load_mesh_from_bytes(p, draco.as_bytes()).unwrap_err();
    assert!(matches!(&e, IoError::UnsupportedExtension { extension, .. } if extension == "KHR_draco_mesh_compression"));
    assert!(e.to_string().contains("KHR_draco_mesh_compression"), "{e}");
    for (ext, mime) in [("KHR_texture_basisu", "image/ktx2"), ("EXT_texture_avif", "image/avif")] {
        let json = tri_gltf(
            &format!(
                r#","extensionsUsed":["{ext}"],"extensionsRequired":["{ext}"],
"textures":[{{"extensions":{{"{ext}":{{"source":0}}}}}}],
"images":[{{"uri":"missing-on-purpose.bin","mimeType":"{mime}"}}]"#
            ),
            r#","baseColorTexture":{"index":0}"#,
        );
        let imp = load_mesh_from_bytes(p, json.as_bytes()).unwrap_or_else(|e| panic!("{ext}: {e}"));
        assert!(
            imp.warnings.iter().any(|w| w.0.contains(ext) && w.0.contains("base colour factor")),
            "{ext}: {:?}",
            imp.warnings
        );
        let m = &imp.mesh.materials[0];
        assert!(m.base_color_texture.is_none() && imp.mesh.textures.is_empty(), "{ext}");
        assert_eq!(m.base_color_factor_linear, [0.25, 0.5, 0.75, 1.0]);
        // The undecodable image is not read (not an input).
        assert_eq!(imp.inputs, vec![p.to_path_buf()]);
    }
}

/// A texture whose only image comes through EXT_texture_webp is decoded (a lossless WebP here,
/// so every texel is known): linear values from an independent sRGB EOTF, no image warning, and the
/// image is an input of the bake (its hash makes the output stale when it changes).
#[test]
fn webp_textures_are_decoded() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (3u32, 2u32);
    let rgba: Vec<u8> = (0..w * h).flat_map(|i| [(40 * i) as u8, 255 - (30 * i) as u8, 7, 255]).collect();
    let mut webp = Vec::new();
    image::codecs::webp::WebPEncoder::new_lossless(&mut webp)
        .encode(&rgba, w, h, image::ExtendedColorType::Rgba8)
        .unwrap();
    std::fs::write(dir.path().join("tex.webp"), &webp).unwrap();
    let ext = "EXT_texture_webp";
    let json = tri_gltf(
        &format!(
            r#","extensionsUsed":["{ext}"],"extensionsRequired":["{ext}"],
"textures":[{{"extensions":{{"{ext}":{{"source":0}}}}}}],
"images":[{{"uri":"tex.webp","mimeType":"image/webp"}}]"#
        ),
        r#","baseColorTexture":{"index":0}"#,
    );
    let p = dir.path().join("t.gltf");
    std::fs::write(&p, json).unwrap();
    let imp = load_mesh(&p).unwrap();
    // (The triangle has no UVs, which the importer warns about; nothing about the image.)
    assert!(
        !imp.warnings.iter().any(|w| w.0.contains("WebP") || w.0.contains("decode") || w.0.contains(ext)),
        "{:?}",
        imp.warnings
    );
    let tr = imp.mesh.materials[0].base_color_texture.as_ref().expect("the WebP texture");
    let t = &imp.mesh.textures[tr.texture];
    assert_eq!((t.width, t.height), (w, h));
    let eotf = spherebake_testkit::oracle::srgb8_to_linear;
    for (i, texel) in t.texels_linear.iter().enumerate() {
        for k in 0..3 {
            assert!((f64::from(texel[k]) - eotf(rgba[4 * i + k])).abs() < 1e-6, "texel {i}: {texel:?}");
        }
        assert_eq!(texel[3], 1.0);
    }
    assert!(imp.inputs.iter().any(|f| f.ends_with("tex.webp")), "{:?}", imp.inputs);
    // A texture offering Basis and WebP takes the WebP (it decodes), whatever the order.
    let both = tri_gltf(
        r#","extensionsUsed":["KHR_texture_basisu","EXT_texture_webp"],"extensionsRequired":["KHR_texture_basisu","EXT_texture_webp"],
"textures":[{"extensions":{"KHR_texture_basisu":{"source":1},"EXT_texture_webp":{"source":0}}}],
"images":[{"uri":"tex.webp","mimeType":"image/webp"},{"uri":"missing.ktx2","mimeType":"image/ktx2"}]"#,
        r#","baseColorTexture":{"index":0}"#,
    );
    std::fs::write(&p, both).unwrap();
    let imp = load_mesh(&p).unwrap();
    let tr = imp.mesh.materials[0].base_color_texture.as_ref().expect("the WebP of the two");
    assert_eq!(imp.mesh.textures[tr.texture].width, w);
}
