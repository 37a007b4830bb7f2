//! Alpha-masked materials (glTF `alphaMode` `MASK`) in the albedo cube maps: where the base
//! colour's alpha is below the cutoff the surface is a hole, so the surface behind it shows.
//!
//! Scene (sphere centre at the origin, both quads in its segment, both back-facing from it, so
//! rule 1 takes the farther): an opaque blue quad z = 1 over x, y ∈ [−1, 1], and behind it a
//! card z = 2 over x, y ∈ [−2, 2] whose n × n texture is red with alpha 0 in its left half and
//! green with alpha 1 in its right half. Texel (i, j) of the +Z face looks along (u, −v, 1),
//! u = 2(i+½)/n − 1, and meets the card at x = 2u, i.e. texture column i at its centre (the
//! geometry of `albedo_bake.rs`' textured quad, twice as far and twice as large; the footprint
//! is one texture texel). So the expected face is known without a sampler: columns i < n/2 see
//! through the card (blue), the others green; unmasked, the left half is red.

use glam::Vec3;
use spherebake_bake::{render_albedo_cubemaps, AlbedoSettings, CubeMap, TextureLod};
use spherebake_geom::{Material, Mesh, Texture, TextureRef, UvTransform, WrapMode};
use spherebake_sh::CubeFace;

const N: usize = 16;
const RED: [f32; 3] = [1.0, 0.0, 0.0];
const GREEN: [f32; 3] = [0.0, 1.0, 0.0];
const BLUE: [f32; 3] = [0.0, 0.0, 1.0];

fn card_texture() -> Texture {
    card_texture_sized(N, N / 2)
}

/// An n × n card texture whose columns below `cut` are red with alpha 0, the rest green, opaque.
fn card_texture_sized(n: usize, cut: usize) -> Texture {
    let texels = (0..n)
        .flat_map(|_| (0..n).map(move |x| if x < cut { [1.0, 0.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0, 1.0] }))
        .collect();
    Texture { name: "card".into(), width: n as u32, height: n as u32, texels_linear: texels }
}

/// The two quads; the card's material has `cutoff` (None: opaque) and `factor`. With
/// `card_near` the card and the blue quad trade places (the card at z = 1).
fn scene_with(cutoff: Option<f32>, factor: [f32; 4], card_near: bool) -> Mesh {
    let corners = [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    let (blue_z, card_z) = if card_near { (2.0, 1.0) } else { (1.0, 2.0) };
    let mut positions: Vec<Vec3> = corners.iter().map(|&(x, y)| Vec3::new(x, y, 1.0) * blue_z).collect();
    positions.extend(corners.iter().map(|&(x, y)| Vec3::new(x, y, 1.0) * card_z));
    let uv: Vec<[f32; 2]> = corners.iter().map(|&(x, y)| [(x + 1.0) / 2.0, (1.0 - y) / 2.0]).collect();
    let tref = TextureRef {
        texture: 0,
        uv_set: 0,
        wrap_s: WrapMode::ClampToEdge,
        wrap_t: WrapMode::ClampToEdge,
        mag_filter: Default::default(),
        transform: UvTransform::default(),
    };
    let mut m = Mesh {
        positions,
        normals: vec![Vec3::Z; 8],
        uvs: vec![[uv.clone(), uv].concat()],
        triangles: vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]],
        triangle_materials: vec![0, 0, 1, 1],
        materials: vec![
            Material { base_color_factor_linear: [BLUE[0], BLUE[1], BLUE[2], 1.0], ..Default::default() },
            Material {
                base_color_factor_linear: factor,
                base_color_texture: Some(tref),
                alpha_mask_cutoff: cutoff,
                ..Default::default()
            },
        ],
        textures: vec![card_texture()],
        ..Default::default()
    };
    m.rebuild_weld();
    m
}

fn scene(cutoff: Option<f32>, factor: [f32; 4]) -> Mesh {
    scene_with(cutoff, factor, false)
}

fn pos_z(mesh: &Mesh, lod: TextureLod) -> CubeMap {
    let s = AlbedoSettings { sh_order: 2, cubemap_size: N, texture_lod: lod, ..Default::default() };
    let (maps, stats) = render_albedo_cubemaps(mesh, &[false; 4], &[[0.0, 0.0, 0.0, 3.0]], &s).unwrap();
    assert_eq!(stats.texels_rule1, (N * N) as u64, "both quads fill the +Z face");
    maps.into_iter().next().unwrap()
}

/// Asserts every texel of column i of `face` is `want(i)`, skipping the columns within
/// `margin` of the mask's edge (where a filtered level blends both halves).
fn check_face(map: &CubeMap, face: CubeFace, want: impl Fn(usize) -> [f32; 3], margin: usize, what: &str) {
    let face = face.index();
    for j in 0..N {
        for i in (0..N).filter(|&i| i + margin < N / 2 || i >= N / 2 + margin) {
            let got = map.texels_linear[(face * N + j) * N + i];
            let w = want(i);
            for k in 0..3 {
                assert!((got[k] - w[k]).abs() < 1e-5, "{what}: texel ({i}, {j}) {got:?}, want {w:?}");
            }
        }
    }
}

fn check(map: &CubeMap, want: impl Fn(usize) -> [f32; 3], margin: usize, what: &str) {
    check_face(map, CubeFace::PosZ, want, margin, what)
}

#[test]
fn a_masked_cards_cut_out_shows_the_surface_behind_it() {
    let left_right = |left: [f32; 3]| move |i: usize| if i < N / 2 { left } else { GREEN };
    // Base level: every column exactly, the boundary too.
    let masked = scene(Some(0.5), [1.0; 4]);
    check(&pos_z(&masked, TextureLod::Base), left_right(BLUE), 0, "masked, base level");
    // The bake's footprint level: the same away from the mask's edge.
    check(&pos_z(&masked, TextureLod::Footprint), left_right(BLUE), 2, "masked, footprint level");
    // Opaque (and BLEND, which imports as opaque): the card's red shows.
    check(&pos_z(&scene(None, [1.0; 4]), TextureLod::Base), left_right(RED), 0, "opaque");
    // The cutoff compares alpha: at 0.0 nothing is a hole (alpha 0 is not below 0), so the
    // card takes every texel and the blue quad behind it shows nowhere.
    let all_card = pos_z(&scene(Some(0.0), [1.0; 4]), TextureLod::Base);
    assert!(all_card.texels_linear[CubeFace::PosZ.index() * N * N..][..N * N].iter().all(|t| t[2] == 0.0), "cutoff 0");
    // The factor's alpha multiplies: 0.4 × 1 < 0.5 makes the whole card a hole.
    check(&pos_z(&scene(Some(0.5), [1.0, 1.0, 1.0, 0.4]), TextureLod::Base), |_| BLUE, 0, "factor alpha 0.4");
    // ... and 0.6 × 1 ≥ 0.5 keeps the right half.
    check(&pos_z(&scene(Some(0.5), [1.0, 1.0, 1.0, 0.6]), TextureLod::Base), left_right(BLUE), 0, "factor 0.6");

    // Rule 3 (both quads face the centre, seen through it on the −Z face: the nearest wins),
    // the card now nearest: its cut-out shows the blue quad behind it. Texel (i, j) of −Z sees
    // the point (u, v, 1) (`albedo_bake.rs`), texture column i again.
    let s = AlbedoSettings { sh_order: 2, cubemap_size: N, texture_lod: TextureLod::Base, ..Default::default() };
    for (cutoff, left) in [(Some(0.5), BLUE), (None, RED)] {
        let mesh = scene_with(cutoff, [1.0; 4], true);
        let (maps, stats) = render_albedo_cubemaps(&mesh, &[true; 4], &[[0.0, 0.0, 0.0, 3.0]], &s).unwrap();
        assert_eq!(stats.texels_rule3, (N * N) as u64);
        check_face(&maps[0], CubeFace::NegZ, left_right(left), 0, "rule 3");
    }
}

/// The importer reads `alphaMode` and `alphaCutoff`: MASK keeps its cutoff (0.5 when absent),
/// OPAQUE and BLEND are opaque; an OBJ material is opaque.
#[test]
fn the_gltf_importer_reads_the_alpha_mode() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut bin: Vec<u8> = Vec::new();
    for p in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        bin.extend(p.iter().flat_map(|x| x.to_le_bytes()));
    }
    std::fs::write(d.join("m.bin"), &bin).unwrap();
    let prims: Vec<String> =
        (0..4).map(|i| format!(r#"{{"attributes": {{"POSITION": 0}}, "material": {i}}}"#)).collect();
    let json = format!(
        r#"{{
      "asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
      "meshes": [{{"primitives": [{}]}}],
      "materials": [
        {{"name": "mask", "alphaMode": "MASK", "alphaCutoff": 0.3}},
        {{"name": "mask default", "alphaMode": "MASK"}},
        {{"name": "blend", "alphaMode": "BLEND"}},
        {{"name": "opaque"}}
      ],
      "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}],
      "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
      "buffers": [{{"byteLength": 36, "uri": "m.bin"}}]
    }}"#,
        prims.join(", ")
    );
    std::fs::write(d.join("m.gltf"), json).unwrap();
    let imp = spherebake_io::load_mesh(&d.join("m.gltf")).unwrap();
    let cutoff = |name: &str| imp.mesh.materials.iter().find(|m| m.name == name).unwrap().alpha_mask_cutoff;
    assert_eq!(cutoff("mask"), Some(0.3));
    assert_eq!(cutoff("mask default"), Some(0.5));
    assert_eq!(cutoff("blend"), None);
    assert_eq!(cutoff("opaque"), None);
    // An unknown alpha mode is a validation error, not a panic.
    let bad = std::fs::read_to_string(d.join("m.gltf")).unwrap().replace("\"BLEND\"", "\"CUTOUT\"");
    std::fs::write(d.join("bad.gltf"), bad).unwrap();
    let Err(e) = spherebake_io::load_mesh(&d.join("bad.gltf")) else { panic!("an unknown alphaMode is refused") };
    assert!(e.to_string().contains("bad.gltf"), "{e}");
}

/// A texture finer than the cube map: 64² on a 16² face, so the footprint reads level 2, whose
/// texel i is the mean of texture columns 4i..4i+3, while a texel centre's level-0 lookup reads
/// columns 4i+1 and 4i+2 (halfway between them). Stripes: columns with x mod 4 in {1, 2} are
/// opaque green, the others cut out (red, alpha 0), cutoff 0.6. Level 0 finds alpha 1 at every
/// texel centre (no hole), level 2 would find 0.5 < 0.6 (all holes: blue); the α-weighted colour
/// is green where the plain level-2 mean would be (0.5, 0.5, 0). So every texel must be green.
#[test]
fn a_fine_masked_texture_is_tested_at_full_resolution_and_its_colour_alpha_weighted() {
    let n = 64;
    let texels = (0..n)
        .flat_map(|_| (0..n).map(|x| if matches!(x % 4, 1 | 2) { [0.0, 1.0, 0.0, 1.0] } else { [1.0, 0.0, 0.0, 0.0] }))
        .collect();
    let mut mesh = scene(Some(0.6), [1.0; 4]);
    mesh.textures = vec![Texture { name: "stripes".into(), width: n as u32, height: n as u32, texels_linear: texels }];
    check(&pos_z(&mesh, TextureLod::Footprint), |_| GREEN, 0, "stripes at the footprint level");
    // A coarse cut, aligned with level 2's texels: the cut-out quarter shows the blue behind.
    mesh.textures = vec![card_texture_sized(64, 16)];
    mesh.materials[1].alpha_mask_cutoff = Some(0.5);
    check(&pos_z(&mesh, TextureLod::Footprint), |i| if i < 4 { BLUE } else { GREEN }, 0, "a quarter cut out");
    // COLOR_0's alpha multiplies too: 0.2 on the card makes all of it a hole.
    let mut mesh = scene(Some(0.5), [1.0; 4]);
    mesh.colors_linear = (0..8).map(|v| if v < 4 { [1.0; 4] } else { [1.0, 1.0, 1.0, 0.2] }).collect();
    check(&pos_z(&mesh, TextureLod::Base), |_| BLUE, 0, "COLOR_0 alpha 0.2");
}

/// The scene of [`scene`] as an OBJ whose card material has a `map_d` (MTL's dissolve texture,
/// `dmap` its line after `map_d`) written by `write_maps` into the folder: imported, the card's
/// mask cuts it out like glTF's MASK at 0.5 (`d` × the map's value). The card's `map_Kd` is
/// `card.png`, red in its left half and green in its right, opaque RGB.
fn obj_scene(d_line: &str, dmap: &str, write_maps: impl Fn(&std::path::Path)) -> Mesh {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let card = image::RgbImage::from_fn(N as u32, N as u32, |x, _| {
        if (x as usize) < N / 2 {
            image::Rgb([255, 0, 0])
        } else {
            image::Rgb([0, 255, 0])
        }
    });
    card.save(d.join("card.png")).unwrap();
    write_maps(d);
    std::fs::write(
        d.join("m.mtl"),
        format!("newmtl blue\nKd 0 0 1\nnewmtl card\nKd 1 1 1\n{d_line}\nmap_Kd card.png\nmap_d {dmap}\n"),
    )
    .unwrap();
    // OBJ's v runs bottom-up: vt (x + 1)/2, (y + 1)/2 is the glTF scene's UV after the flip.
    let mut obj = String::from("mtllib m.mtl\n");
    for z in [1.0, 2.0] {
        for (x, y) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            obj += &format!("v {} {} {z}\n", x * z, y * z);
        }
    }
    for (x, y) in [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        obj += &format!("vt {} {}\n", (x + 1.0) / 2.0, (y + 1.0) / 2.0);
    }
    obj += "usemtl blue\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\nusemtl card\nf 5/1 6/2 7/3\nf 5/1 7/3 8/4\n";
    std::fs::write(d.join("m.obj"), obj).unwrap();
    let imp = spherebake_io::load_mesh(&d.join("m.obj")).unwrap_or_else(|e| panic!("{e}"));
    assert!(imp.warnings.is_empty(), "{:?}", imp.warnings);
    imp.mesh
}

/// Writes `name`, an N × 1 RGBA image: `left` in the columns below N/2, `right` in the others.
fn halves(d: &std::path::Path, name: &str, left: [u8; 4], right: [u8; 4]) {
    let img =
        image::RgbaImage::from_fn(N as u32, 1, |x, _| image::Rgba(if (x as usize) < N / 2 { left } else { right }));
    img.save(d.join(name)).unwrap();
}

/// A grey mask image, `w` × 1: columns below w/2 black, the others white.
fn grey_mask(w: u32) -> image::GrayImage {
    image::GrayImage::from_fn(w, 1, |x, _| image::Luma([if x < w / 2 { 0 } else { 255 }]))
}

#[test]
fn an_obj_map_d_cuts_the_card_out() {
    let left_right = |left: [f32; 3]| move |i: usize| if i < N / 2 { left } else { GREEN };
    // A grey mask of the card's size (Sponza-style `map_d`): the left half shows the blue quad.
    let mesh = obj_scene("d 1", "mask.png", |d| grey_mask(N as u32).save(d.join("mask.png")).unwrap());
    let card = mesh.materials.iter().find(|m| m.name == "card").unwrap();
    assert_eq!(card.alpha_mask_cutoff, Some(0.5));
    assert!(mesh.materials.iter().find(|m| m.name == "blue").unwrap().alpha_mask_cutoff.is_none());
    check(&pos_z(&mesh, TextureLod::Base), left_right(BLUE), 0, "grey map_d");
    check(&pos_z(&mesh, TextureLod::Footprint), left_right(BLUE), 2, "grey map_d, footprint level");
    // A 2 × 1 mask is read at the nearest texel: the same halves.
    let mesh = obj_scene("d 1", "tiny mask.png", |d| grey_mask(2).save(d.join("tiny mask.png")).unwrap());
    check(&pos_z(&mesh, TextureLod::Base), left_right(BLUE), 0, "2 × 1 map_d");
    // `d` multiplies: 0.4 × 1 < 0.5 cuts out the whole card.
    let mesh = obj_scene("d 0.4", "mask.png", |d| grey_mask(N as u32).save(d.join("mask.png")).unwrap());
    check(&pos_z(&mesh, TextureLod::Base), |_| BLUE, 0, "d 0.4");
    // An RGBA map whose alpha is not opaque everywhere is read by its alpha (an exporter that
    // points map_d at the diffuse texture): alpha 0 on the right, so the right half is cut out
    // although its colour is white.
    let rgba = |d: &std::path::Path| halves(d, "rgba.png", [0, 0, 0, 255], [255, 255, 255, 0]);
    let mesh = obj_scene("d 1", "rgba.png", rgba);
    check(&pos_z(&mesh, TextureLod::Base), |i| if i < N / 2 { RED } else { BLUE }, 0, "RGBA map_d by alpha");
    // ... unless `-imfchan l` asks for its luminance: then the left half (black) is cut out.
    let mesh = obj_scene("d 1", "-imfchan l rgba.png", rgba);
    check(&pos_z(&mesh, TextureLod::Base), left_right(BLUE), 0, "RGBA map_d, -imfchan l");
    // An RGBA map that is opaque everywhere is read by its luminance; `-imfchan r` reads red.
    let opaque = |d: &std::path::Path| halves(d, "opaque.png", [255, 0, 0, 255], [255, 255, 255, 255]);
    // Luminance of the left half: 0.2126 < 0.5, cut out.
    check(&pos_z(&obj_scene("d 1", "opaque.png", opaque), TextureLod::Base), left_right(BLUE), 0, "opaque RGBA");
    // Its red channel is 1 everywhere: nothing is cut out.
    check(
        &pos_z(&obj_scene("d 1", "-imfchan r opaque.png", opaque), TextureLod::Base),
        left_right(RED),
        0,
        "-imfchan r",
    );
}
