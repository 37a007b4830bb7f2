//! A textured material on a part without UVs, beside a part with them, through both importers:
//! the part without reads its base colour factor (the documented rule for textured triangles
//! without UVs), never the texel at UV (0, 0), which a zero-filled UV set used to give it.
//!
//! The texture is one colour except its top-left texel, so the expected values need no sampler:
//! the part with UVs reads the plain colour at its UV (0.75, 0.75), the texel at (0, 0) would be
//! a blend with the corner colour, and the part without must be the factor itself (white).

use spherebake_bake::{bake_albedo, AlbedoSettings, SurfaceAlbedo};
use std::path::Path;

/// sRGB 8-bit green (0, 255, 0) is linear (0, 1, 0) exactly; red likewise.
const PLAIN: [u8; 3] = [0, 255, 0];
const CORNER: [u8; 3] = [255, 0, 0];

fn write_texture(path: &Path) {
    let mut img = image::RgbImage::from_pixel(4, 4, image::Rgb(PLAIN));
    img.put_pixel(0, 0, image::Rgb(CORNER));
    img.save(path).unwrap();
}

/// Imports `model` and checks both parts: `with` (z = 0) reads green, `without` (z = 1) reads
/// the white factor, and the bake counts exactly the part without as textured without UVs.
fn check(model: &Path) {
    let imp = spherebake_io::load_mesh(model).unwrap_or_else(|e| panic!("{}: {e}", model.display()));
    let mesh = &imp.mesh;
    assert_eq!(mesh.triangles.len(), 2, "{}", model.display());
    assert!(mesh.materials.iter().any(|m| m.base_color_texture.is_some()), "the material keeps its texture");
    let surface = SurfaceAlbedo::new(mesh).unwrap();
    let z = |t: usize| mesh.positions[mesh.triangles[t][0] as usize].z;
    let with = (0..2).find(|&t| z(t) == 0.0).expect("the part with UVs");
    let without = (0..2).find(|&t| z(t) == 1.0).expect("the part without UVs");
    let third = [1.0 / 3.0; 3];
    let a = surface.albedo(with, third, 0.0);
    for (k, want) in [0.0, 1.0, 0.0].into_iter().enumerate() {
        assert!((a[k] - want).abs() < 1e-6, "{}: part with UVs {a:?}", model.display());
    }
    assert_eq!(surface.albedo(without, third, 0.0), [1.0; 3], "{}: part without UVs", model.display());
    // The bake's count (its warning "N textured triangles have no UVs") is the part without.
    let flip = vec![false; 2];
    let (_, stats) = bake_albedo(mesh, &flip, &[[0.5, 0.5, 0.5, 2.0]], &AlbedoSettings::default()).unwrap();
    assert_eq!(stats.textured_triangles_without_uvs, 1, "{}", model.display());
}

#[test]
fn an_obj_group_without_uvs_reads_its_base_colour_not_the_texel_at_zero() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_texture(&d.join("tex.png"));
    std::fs::write(d.join("m.mtl"), "newmtl tex\nKd 1 1 1\nmap_Kd tex.png\n").unwrap();
    // OBJ v runs bottom-up: vt (0.75, 0.25) is UV (0.75, 0.75) in the glTF convention.
    std::fs::write(
        d.join("m.obj"),
        "mtllib m.mtl\no with\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.75 0.25\nusemtl tex\nf 1/1 2/1 3/1\n\
         o without\nv 0 0 1\nv 1 0 1\nv 0 1 1\nusemtl tex\nf 4 5 6\n",
    )
    .unwrap();
    check(&d.join("m.obj"));
}

#[test]
fn a_gltf_primitive_without_uvs_reads_its_base_colour_not_the_texel_at_zero() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_texture(&d.join("tex.png"));
    // Buffer: positions of both triangles (2 × 3 × VEC3 f32), then three UVs (VEC2 f32).
    let mut bin: Vec<u8> = Vec::new();
    for p in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]] {
        bin.extend(p.iter().flat_map(|x| x.to_le_bytes()));
    }
    for _ in 0..3 {
        bin.extend([0.75f32, 0.75].iter().flat_map(|x| x.to_le_bytes()));
    }
    std::fs::write(d.join("m.bin"), &bin).unwrap();
    let json = r#"{
      "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
      "meshes": [{"primitives": [
        {"attributes": {"POSITION": 0, "TEXCOORD_0": 2}, "material": 0},
        {"attributes": {"POSITION": 1}, "material": 0}
      ]}],
      "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
      "textures": [{"source": 0}], "images": [{"uri": "tex.png"}],
      "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
        {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 1], "max": [1, 1, 1]},
        {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"}
      ],
      "bufferViews": [
        {"buffer": 0, "byteOffset": 0, "byteLength": 36},
        {"buffer": 0, "byteOffset": 36, "byteLength": 36},
        {"buffer": 0, "byteOffset": 72, "byteLength": 24}
      ],
      "buffers": [{"byteLength": 96, "uri": "m.bin"}]
    }"#;
    std::fs::write(d.join("m.gltf"), json).unwrap();
    check(&d.join("m.gltf"));
}
