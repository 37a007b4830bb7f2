//! Albedo stage on imported files: the sRGB → linear conversion of a known texture end to end
//! (PNG → OBJ/MTL import → cube map), and watertight coverage on the shared real models.

use glam::DVec3;
use spherebake_bake::{bake_albedo, render_albedo_cubemaps, AlbedoSettings};
use spherebake_geom::winding::WindingNumber;
use spherebake_sh::CubeFace;

use spherebake_testkit::oracle::srgb8_to_linear;

#[test]
fn srgb_texture_arrives_linear() {
    // A 4×4 sRGB PNG on the quad z = 1 (x, y ∈ [−1, 1]); with the centre at the origin and 4×4
    // faces, +Z texel (i, j) looks at texture texel (i, j)'s centre (OBJ vt v is up: vt = ((x+1)/2,
    // (y+1)/2), so image row 0 is at y = +1, the top, which the +Z face's row 0 also sees).
    let dir = tempfile::tempdir().unwrap();
    let n = 4u32;
    let values: [u8; 8] = [0, 10, 60, 128, 188, 200, 240, 255];
    let px = |x: u32, y: u32, c: u32| values[((x + 2 * y + 3 * c) % 8) as usize];
    let img = image::RgbImage::from_fn(n, n, |x, y| image::Rgb([px(x, y, 0), px(x, y, 1), px(x, y, 2)]));
    img.save(dir.path().join("tex.png")).unwrap();
    std::fs::write(dir.path().join("quad.mtl"), "newmtl m\nKd 1 1 1\nmap_Kd tex.png\n").unwrap();
    std::fs::write(
        dir.path().join("quad.obj"),
        "mtllib quad.mtl\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl m\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n",
    )
    .unwrap();
    let imported = spherebake_io::load_mesh(&dir.path().join("quad.obj")).unwrap();
    let mesh = imported.mesh;
    assert_eq!(mesh.textures.len(), 1);
    let flip = vec![false; mesh.triangles.len()];
    let s = AlbedoSettings { cubemap_size: n as usize, ..Default::default() };
    let (maps, stats) = render_albedo_cubemaps(&mesh, &flip, &[[0.0, 0.0, 0.0, 1.0]], &s).unwrap();
    assert_eq!(stats.texels_rule1, u64::from(n * n));
    let m = &maps[0];
    let nn = n as usize;
    for j in 0..nn {
        for i in 0..nn {
            let got = m.texels_linear[(CubeFace::PosZ.index() * nn + j) * nn + i];
            for (c, g) in got.iter().enumerate() {
                let want = srgb8_to_linear(px(i as u32, j as u32, c as u32));
                assert!((f64::from(*g) - want).abs() < 2e-6, "texel ({i}, {j}) channel {c}: {g} vs {want}");
            }
        }
    }
}

#[test]
fn closed_models_are_covered_from_an_interior_point() {
    // For a closed mesh and a single sphere whose centre is inside, every direction leaves the
    // object through a back-facing surface of the (only) segment: every texel is rule 1 and none
    // is empty. A hole in the rasteriser (shared edges, UV seams, face borders) would show up
    // as a rule-3 or empty texel.
    for (file, candidates) in [
        ("obj/spot/spot.obj", vec![DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.0, 0.2, 0.1)]),
        ("gltf/CesiumMan.glb", vec![DVec3::new(0.0, 1.0, 0.02), DVec3::new(0.0, 1.2, 0.0), DVec3::new(0.0, 0.9, 0.0)]),
    ] {
        let Some(path) = spherebake_testkit::shared_model(file) else { continue };
        let mesh = spherebake_io::load_mesh(&path).unwrap().mesh;
        let wn = WindingNumber::new(&mesh.positions, &mesh.triangles);
        let flip = spherebake_geom::orient::outward_orientation(&mesh.positions, &mesh.triangles, &wn).flip;
        let Some(c) = candidates.into_iter().find(|c| wn.eval_exact(*c) > 0.9) else {
            panic!("{file}: no candidate interior point");
        };
        for n in [16, 48] {
            let s = AlbedoSettings { cubemap_size: n, ..Default::default() };
            let sphere = [c.x as f32, c.y as f32, c.z as f32, 0.05];
            let (sh, stats) = bake_albedo(&mesh, &flip, &[sphere], &s).unwrap();
            assert_eq!(stats.texels_rule1, (6 * n * n) as u64, "{file} n {n}: {stats:?}");
            // The DC term is √(4π) × the solid-angle mean of linear albedo, which lies in [0, 1].
            let mean = sh.coefficients[0].map(|v| f64::from(v) / (4.0 * std::f64::consts::PI).sqrt());
            assert!(mean.iter().all(|&m| m > 0.0 && m <= 1.0), "{file}: mean colour {mean:?}");
        }
    }
}

/// OBJ vertex colours reach the albedo: a cube whose every vertex is red (`v x y z 1 0 0`)
/// bakes the albedo of the same cube with `Kd 1 0 0`, whose DC term is red: √(4π) · (1, 0, 0)
/// seen from the centre, every texel the cube's colour (the colours were dropped: white). A
/// half-grey sRGB colour (0.5) bakes as `Kd` ((0.5 + 0.055) / 1.055)^2.4, its linear value.
#[test]
fn obj_vertex_colours_bake_as_the_same_kd() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let corners = [[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1], [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]];
    let quads = "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    let cube = |colour: &str| -> String {
        corners.iter().map(|c| format!("v {} {} {}{colour}\n", c[0], c[1], c[2])).collect::<String>() + quads
    };
    let bake = |name: &str, obj: String, mtl: Option<&str>| {
        if let Some(kd) = mtl {
            std::fs::write(d.join(format!("{name}.mtl")), format!("newmtl m\nKd {kd}\n")).unwrap();
        }
        std::fs::write(d.join(format!("{name}.obj")), obj).unwrap();
        let mesh = spherebake_io::load_mesh(&d.join(format!("{name}.obj"))).unwrap().mesh;
        let flip = vec![false; mesh.triangles.len()];
        let s = AlbedoSettings { cubemap_size: 8, ..Default::default() };
        bake_albedo(&mesh, &flip, &[[0.0, 0.0, 0.0, 2.0]], &s).unwrap().0.coefficients
    };
    let dc = (4.0 * std::f64::consts::PI).sqrt();
    let half = ((0.5f64 + 0.055) / 1.055).powf(2.4);
    for (name, colour, kd, want) in [
        ("red", " 1 0 0", "1 0 0", [1.0, 0.0, 0.0]),
        ("grey", " 0.5 0.5 0.5", "0.214041140 0.214041140 0.214041140", [half; 3]),
    ] {
        let coloured = bake(&format!("{name}_v"), cube(colour), None);
        let kd_obj = format!("mtllib {name}_kd.mtl\nusemtl m\n{}", cube(""));
        let by_kd = bake(&format!("{name}_kd"), kd_obj, Some(kd));
        for (k, w) in want.iter().enumerate() {
            let got = f64::from(coloured[0][k]);
            assert!((got - w * dc).abs() < 1e-5, "{name}: DC channel {k}: {got} vs {}", w * dc);
        }
        for (i, (a, b)) in coloured.iter().zip(&by_kd).enumerate() {
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() < 1e-6, "{name}: coefficient {i} channel {k}: {} vs Kd {}", a[k], b[k]);
            }
        }
    }
}
