//! Albedo cube maps and their SH projection (issue 7), against independently derived answers:
//! the math reference §4 (constant function on a cube map), brute-force quadrature of the
//! sphere of directions, texel-exact texture lookups derived from the glTF sampler rules, and a
//! brute-force ray caster for the sample-point rules of §8.

use glam::{DVec3, Vec3};
use spherebake_bake::{
    bake_albedo, project_cubemaps, render_albedo_cubemaps, segment_triangles, AlbedoSettings, CubeMap,
};
use spherebake_geom::{Material, Mesh, Texture, TextureRef, UvTransform, WrapMode};
use spherebake_sh::{coeff_count, eval_sh_f64, sh_index, CubeFace};
use std::f64::consts::PI;

/// Cube [−1, 1]³ (scaled and shifted) as 12 CCW-outward triangles, one material per face
/// (+X, −X, +Y, −Y, +Z, −Z), with 4 vertices per face.
fn cube_mesh(face_colours: [[f32; 3]; 6]) -> Mesh {
    let mut m = Mesh::default();
    // Each face: outward axis n, and two tangents (u, v) with u × v = n.
    let faces: [(Vec3, Vec3, Vec3); 6] = [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (Vec3::NEG_X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (Vec3::NEG_Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (Vec3::NEG_Z, Vec3::Y, Vec3::X),
    ];
    for (f, (n, u, v)) in faces.iter().enumerate() {
        assert!((u.cross(*v) - *n).length() < 1e-6);
        let base = m.positions.len() as u32;
        for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            m.positions.push(*n + *u * a + *v * b);
            m.normals.push(*n);
        }
        m.triangles.push([base, base + 1, base + 2]);
        m.triangles.push([base, base + 2, base + 3]);
        m.triangle_materials.extend([f as u32, f as u32]);
        let c = face_colours[f];
        m.materials.push(Material { base_color_factor_linear: [c[0], c[1], c[2], 1.0], ..Default::default() });
    }
    m.rebuild_weld();
    m
}

/// Unit icosphere subdivided `levels` times (CCW outward), one white material.
fn icosphere(levels: usize) -> Mesh {
    let (p, tris) = spherebake_geom::sphere::icosphere(levels);
    let p: Vec<Vec3> = p.into_iter().map(Vec3::from).collect();
    let mut m = Mesh {
        normals: p.clone(),
        positions: p,
        triangle_materials: vec![0; tris.len()],
        triangles: tris,
        materials: vec![Material::default()],
        ..Default::default()
    };
    m.rebuild_weld();
    m
}

fn settings(order: usize, n: usize) -> AlbedoSettings {
    AlbedoSettings { sh_order: order, cubemap_size: n, ..Default::default() }
}

/// Brute-force SH projection of f over the sphere: midpoint rule in (z, φ), `nz`×`2nz` points
/// (equal areas 4π/(2nz²)).
fn brute_project(order: usize, nz: usize, f: impl Fn(DVec3) -> [f64; 3]) -> Vec<[f64; 3]> {
    let nc = coeff_count(order);
    let mut acc = vec![[0.0f64; 3]; nc];
    let mut y = vec![0.0; nc];
    let nphi = 2 * nz;
    let w = 4.0 * PI / (nz * nphi) as f64;
    for a in 0..nz {
        let z = -1.0 + (a as f64 + 0.5) * 2.0 / nz as f64;
        let r = (1.0 - z * z).sqrt();
        for b in 0..nphi {
            let phi = (b as f64 + 0.5) * 2.0 * PI / nphi as f64;
            let d = DVec3::new(r * phi.cos(), r * phi.sin(), z);
            let v = f(d);
            if v == [0.0; 3] {
                continue;
            }
            eval_sh_f64(order, d.to_array(), &mut y).unwrap();
            for (s, yi) in acc.iter_mut().zip(&y) {
                for c in 0..3 {
                    s[c] += w * yi * v[c];
                }
            }
        }
    }
    acc
}

#[test]
fn one_colour_closed_mesh_projects_like_a_constant() {
    // Math reference §4: a constant c on the cube map projects to DC = c·√(4π); at order 8 its
    // only errors are in y_40, y_44, y_60, y_64 (cubic symmetry) with the tabulated values;
    // every other coefficient is 0 (< 1e-13 in f64, here f32 rounding).
    let factor = [0.5f32, 1.0, 0.8];
    let vertex = [0.6f32, 0.4, 1.0];
    let c: Vec<f64> = (0..3).map(|k| f64::from(factor[k]) * f64::from(vertex[k])).collect();
    let table: [(usize, [f64; 4]); 2] = [
        (8, [-0.02639446064, -0.02230739071, 0.002399887675, -0.006349505962]),
        (32, [-0.001634501724, -0.001381406086, 0.0001414665501, -0.0003742853105]),
    ];
    let err_index = [sh_index(4, 0), sh_index(4, 4), sh_index(6, 0), sh_index(6, 4)];
    for (mesh_name, mut mesh, centres) in [
        (
            "cube",
            cube_mesh([[factor[0], factor[1], factor[2]]; 6]),
            vec![[0.0, 0.0, 0.0], [0.2, 0.1, -0.05], [-0.9, 0.85, 0.7]],
        ),
        ("icosphere", icosphere(3), vec![[0.0, 0.0, 0.0], [0.3, -0.2, 0.45]]),
    ] {
        if mesh_name == "icosphere" {
            mesh.materials[0].base_color_factor_linear = [factor[0], factor[1], factor[2], 1.0];
        }
        mesh.colors_linear = vec![[vertex[0], vertex[1], vertex[2], 1.0]; mesh.positions.len()];
        let flip = vec![false; mesh.triangles.len()];
        for centre in centres {
            for (n, e) in table {
                let (sh, stats) =
                    bake_albedo(&mesh, &flip, &[[centre[0], centre[1], centre[2], 2.0]], &settings(8, n)).unwrap();
                assert_eq!(
                    stats.texels_rule1,
                    (6 * n * n) as u64,
                    "{mesh_name} {centre:?} n {n}: every texel sees the mesh"
                );
                for (i, got) in sh.coefficients.iter().enumerate() {
                    for k in 0..3 {
                        let expect = if i == 0 {
                            c[k] * (4.0 * PI).sqrt()
                        } else {
                            err_index.iter().position(|&j| j == i).map_or(0.0, |p| c[k] * e[p])
                        };
                        let g = f64::from(got[k]);
                        assert!(
                            (g - expect).abs() < 2e-6,
                            "{mesh_name} {centre:?} n {n} coefficient {i} channel {k}: {g} vs {expect}"
                        );
                    }
                }
            }
        }
    }
}

/// Colour of the cube face through which the ray from `c` along `d` leaves [−1, 1]³.
fn exit_face_colour(c: DVec3, d: DVec3, colours: &[[f32; 3]; 6]) -> [f64; 3] {
    let mut best = (f64::INFINITY, 0usize);
    for axis in 0..3 {
        let (ci, di) = (c[axis], d[axis]);
        if di > 0.0 {
            let t = (1.0 - ci) / di;
            if t < best.0 {
                best = (t, 2 * axis);
            }
        } else if di < 0.0 {
            let t = (-1.0 - ci) / di;
            if t < best.0 {
                best = (t, 2 * axis + 1);
            }
        }
    }
    colours[best.1].map(f64::from)
}

#[test]
fn six_coloured_faces_match_brute_force_projection() {
    let colours =
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 0.0], [0.0, 1.0, 1.0], [1.0, 0.0, 1.0]];
    let mesh = cube_mesh(colours);
    let flip = vec![false; mesh.triangles.len()];
    let order = 4;
    for centre in [DVec3::ZERO, DVec3::new(0.3, -0.2, 0.1)] {
        let reference = brute_project(order, 1500, |d| exit_face_colour(centre, d, &colours));
        let sphere = [centre.x as f32, centre.y as f32, centre.z as f32, 2.5];
        let mut errs = Vec::new();
        for n in [16, 64] {
            let (sh, _) = bake_albedo(&mesh, &flip, &[sphere], &settings(order, n)).unwrap();
            let err = sh
                .coefficients
                .iter()
                .zip(&reference)
                .flat_map(|(g, r)| (0..3).map(move |k| (f64::from(g[k]) - r[k]).abs()))
                .fold(0.0, f64::max);
            errs.push(err);
        }
        // The cube map is a texel-centre quadrature of a piecewise-constant function: a texel cut
        // by a colour edge errs by up to Ω·|Δf|·max|y|; the number of cut texels grows like n
        // and Ω falls like 1/n², so the error falls like 1/n (measured: 0.025 at n = 16, 0.0079
        // at n = 64 for the tilted centre). With the centre at the cube's centre the colour edges
        // lie on texel boundaries and only the smooth §4 error remains (measured 8.5e-4, 7e-5).
        assert!(errs[1] < 0.01, "centre {centre}: max coefficient error at n 64 = {}", errs[1]);
        assert!(errs[1] < 0.5 * errs[0], "centre {centre}: error does not fall like 1/n: {errs:?}");
    }
}

/// A square quad z = 1, x, y ∈ [−1, 1] (CCW seen from +z, outward normal +z), UV (U, V) given
/// per corner, with one material using `tex`.
fn quad_mesh(uv_of: impl Fn(f32, f32) -> [f32; 2], tex: Texture, tref: TextureRef, factor: [f32; 4]) -> Mesh {
    let corners = [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    let mut m = Mesh {
        positions: corners.iter().map(|&(x, y)| Vec3::new(x, y, 1.0)).collect(),
        normals: vec![Vec3::Z; 4],
        uvs: vec![corners.iter().map(|&(x, y)| uv_of(x, y)).collect()],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        triangle_materials: vec![0, 0],
        materials: vec![Material {
            base_color_factor_linear: factor,
            base_color_texture: Some(tref),
            ..Default::default()
        }],
        textures: vec![tex],
        ..Default::default()
    };
    m.rebuild_weld();
    m
}

/// A w×h texture whose texel (x, y) has a distinct colour.
fn pattern(w: u32, h: u32) -> Texture {
    let texels = (0..h)
        .flat_map(|y| {
            (0..w).map(move |x| [x as f32 / w as f32, y as f32 / h as f32, ((x * 7 + y * 3) % 5) as f32 / 5.0, 1.0])
        })
        .collect();
    Texture { name: "pattern".into(), width: w, height: h, texels_linear: texels }
}

fn tref(wrap: WrapMode, transform: UvTransform) -> TextureRef {
    TextureRef { texture: 0, uv_set: 0, wrap_s: wrap, wrap_t: wrap, mag_filter: Default::default(), transform }
}

fn face_texel(map: &CubeMap, face: CubeFace, i: usize, j: usize) -> [f32; 3] {
    let n = map.face_size;
    map.texels_linear[(face.index() * n + j) * n + i]
}

/// Asserts the +Z face (or, through the centre, the −Z face) shows `expect(i, j)` and every
/// other texel is 0.
fn check_quad(map: &CubeMap, face: CubeFace, expect: impl Fn(usize, usize) -> [f32; 3], what: &str) {
    let n = map.face_size;
    for f in CubeFace::ALL {
        for j in 0..n {
            for i in 0..n {
                let got = face_texel(map, f, i, j);
                let want = if f == face { expect(i, j) } else { [0.0; 3] };
                for k in 0..3 {
                    assert!((got[k] - want[k]).abs() < 2e-5, "{what}: face {f:?} texel ({i}, {j}) {got:?} vs {want:?}");
                }
            }
        }
    }
}

#[test]
fn textured_quad_shows_its_texels() {
    // With the sphere centre at the origin, texel (i, j) of the +Z face looks along (u, −v, 1),
    // u = 2(i+½)/n − 1, v = 2(j+½)/n − 1, and hits the quad at (x, y) = (u, −v). With
    // U = (x+1)/2 and V = (1−y)/2 this is UV = ((i+½)/n, (j+½)/n): texel (i, j)'s centre of an
    // n×n texture, so bilinear filtering returns that texel exactly. The cube-map texel's
    // footprint on the quad, (2/n)², is exactly one texture texel: level 0.
    let n = 16usize;
    let tex = pattern(n as u32, n as u32);
    let texel = |x: usize, y: usize| {
        let t = tex.texels_linear[y * n + x];
        [t[0], t[1], t[2]]
    };
    let factor = [0.5f32, 0.8, 1.0, 1.0];
    let vcol = [0.9f32, 0.5, 0.25];
    let mut mesh = quad_mesh(
        |x, y| [(x + 1.0) / 2.0, (1.0 - y) / 2.0],
        tex.clone(),
        tref(WrapMode::ClampToEdge, UvTransform::default()),
        factor,
    );
    mesh.colors_linear = vec![[vcol[0], vcol[1], vcol[2], 1.0]; 4];
    let sphere = [[0.0f32, 0.0, 0.0, 1.0]];
    let s = settings(4, n);

    // Back-facing from the centre (normal +z, seen along +z): rule 1 on the +Z face.
    let (maps, stats) = render_albedo_cubemaps(&mesh, &[false, false], &sphere, &s).unwrap();
    let prod = |t: [f32; 3]| [t[0] * factor[0] * vcol[0], t[1] * factor[1] * vcol[1], t[2] * factor[2] * vcol[2]];
    check_quad(&maps[0], CubeFace::PosZ, |i, j| prod(texel(i, j)), "rule 1");
    assert_eq!(stats.texels_rule1, (n * n) as u64);
    assert_eq!(stats.texels_rule2 + stats.texels_rule3, 0);

    // Flipped: the quad faces the centre, so rule 3 shows it through the centre on the −Z face:
    // direction (−u, −v, −1) sees the point (u, v, 1), i.e. UV ((i+½)/n, 1 − (j+½)/n): texel
    // (i, n−1−j).
    let (maps, stats) = render_albedo_cubemaps(&mesh, &[true, true], &sphere, &s).unwrap();
    check_quad(&maps[0], CubeFace::NegZ, |i, j| prod(texel(i, n - 1 - j)), "rule 3");
    assert_eq!(stats.texels_rule3, (n * n) as u64);

    // The SH of the rule-1 map equals a brute-force projection of the hit texel's colour (the
    // remaining difference is the cube map's texel-centre quadrature, about 1e-3 at n = 16).
    let (maps, _) = render_albedo_cubemaps(&mesh, &[false, false], &sphere, &s).unwrap();
    let sh = project_cubemaps(&maps, 4).unwrap();
    let reference = brute_project(4, 1200, |d| {
        if d.z <= 0.0 || d.x.abs() > d.z || d.y.abs() > d.z {
            return [0.0; 3];
        }
        let (x, y) = (d.x / d.z, d.y / d.z);
        let (u, v) = ((x + 1.0) / 2.0, (1.0 - y) / 2.0);
        let (ti, tj) = (((u * n as f64) as usize).min(n - 1), ((v * n as f64) as usize).min(n - 1));
        prod(texel(ti, tj)).map(f64::from)
    });
    for (i, (g, r)) in sh.coefficients.iter().zip(&reference).enumerate() {
        for k in 0..3 {
            assert!((f64::from(g[k]) - r[k]).abs() < 0.01, "coefficient {i}: {g:?} vs {r:?}");
        }
    }
}

#[test]
fn wrap_modes_and_texture_transform() {
    let n = 16usize;
    let h = n / 2;
    let small = pattern(h as u32, h as u32);
    let st = |x: usize, y: usize| {
        let t = small.texels_linear[y * h + x];
        [t[0], t[1], t[2]]
    };
    let sphere = [[0.0f32, 0.0, 0.0, 1.0]];
    let s = settings(2, n);
    let flip = [false, false];
    let white = [1.0f32; 4];

    // Repeat: UV = (x+1, 1−y) spans [0, 2]²; texel coordinate U·(n/2) − ½ = i: texel i mod n/2.
    let mesh =
        quad_mesh(|x, y| [x + 1.0, 1.0 - y], small.clone(), tref(WrapMode::Repeat, UvTransform::default()), white);
    let (maps, _) = render_albedo_cubemaps(&mesh, &flip, &sphere, &s).unwrap();
    check_quad(&maps[0], CubeFace::PosZ, |i, j| st(i % h, j % h), "repeat");

    // Mirrored repeat: UV = (x, −y) spans [−1, 1]²; texel coordinate i − n/2, mirrored below 0:
    // index n/2 − 1 − i for i < n/2, else i − n/2.
    let mirror = |i: usize| if i < h { h - 1 - i } else { i - h };
    let mesh = quad_mesh(|x, y| [x, -y], small.clone(), tref(WrapMode::MirroredRepeat, UvTransform::default()), white);
    let (maps, _) = render_albedo_cubemaps(&mesh, &flip, &sphere, &s).unwrap();
    check_quad(&maps[0], CubeFace::PosZ, |i, j| st(mirror(i), mirror(j)), "mirrored repeat");

    // KHR_texture_transform: UV (x+1, 1−y) with scale ½ is the plain [0, 1] mapping of a full
    // n×n texture; rotation 90° with offset (0, 1) maps (U, V) to (V, 1 − U), so texel (i, j)
    // shows texture texel (j, n−1−i).
    let big = pattern(n as u32, n as u32);
    let bt = |x: usize, y: usize| {
        let t = big.texels_linear[y * n + x];
        [t[0], t[1], t[2]]
    };
    let half = UvTransform { scale: [0.5, 0.5], ..Default::default() };
    let mesh = quad_mesh(|x, y| [x + 1.0, 1.0 - y], big.clone(), tref(WrapMode::ClampToEdge, half), white);
    let (maps, _) = render_albedo_cubemaps(&mesh, &flip, &sphere, &s).unwrap();
    check_quad(&maps[0], CubeFace::PosZ, bt, "scale");
    let rot = UvTransform { offset: [0.0, 1.0], rotation_rad: std::f32::consts::FRAC_PI_2, scale: [1.0, 1.0] };
    let mesh =
        quad_mesh(|x, y| [(x + 1.0) / 2.0, (1.0 - y) / 2.0], big.clone(), tref(WrapMode::ClampToEdge, rot), white);
    let (maps, _) = render_albedo_cubemaps(&mesh, &flip, &sphere, &s).unwrap();
    check_quad(&maps[0], CubeFace::PosZ, |i, j| bt(j, n - 1 - i), "rotation");
}

#[test]
fn far_texture_is_filtered_to_its_mean() {
    // A 256×256 random binary texture seen from far away: each cube-map texel covers thousands
    // of texture texels, so the mip level is high and every covered texel shows (nearly) the
    // mean ½. Without filtering (level 0, bilinear) the texels alias to values far from ½.
    let w = 256u32;
    // Random black/white texels (a hash of x, y): the mean over any large block is near ½.
    let bit =
        |x: u32, y: u32| (x.wrapping_mul(0x9E37_79B9) ^ y.wrapping_mul(0x85EB_CA6B)).wrapping_mul(0xC2B2_AE35) >> 31;
    let texels: Vec<[f32; 4]> = (0..w).flat_map(|y| (0..w).map(move |x| [bit(x, y) as f32; 4])).collect();
    let mean = texels.iter().map(|t| f64::from(t[0])).sum::<f64>() / texels.len() as f64;
    assert!((mean - 0.5).abs() < 0.01, "{mean}");
    let tex = Texture { name: "checker".into(), width: w, height: w, texels_linear: texels };
    let mesh = quad_mesh(
        |x, y| [(x + 1.0) / 2.0, (1.0 - y) / 2.0],
        tex,
        tref(WrapMode::Repeat, UvTransform::default()),
        [1.0; 4],
    );
    // The quad at z = 1 seen from (0, 0, −3): 4 units away, it spans about ±14° → a few texels of
    // a 16² face, each covering tens of texture texels.
    let sphere = [[0.13f32, 0.07, -3.0, 1.0]];
    for (lod, want_close) in
        [(spherebake_bake::TextureLod::Footprint, true), (spherebake_bake::TextureLod::Base, false)]
    {
        let s = AlbedoSettings { sh_order: 1, cubemap_size: 16, texture_lod: lod, ..Default::default() };
        let (maps, _) = render_albedo_cubemaps(&mesh, &[false, false], &sphere, &s).unwrap();
        let lit: Vec<f32> = maps[0].texels_linear.iter().filter(|t| t[0] != 0.0 || t[1] != 0.0).map(|t| t[0]).collect();
        assert!(!lit.is_empty());
        let worst = lit.iter().map(|v| (v - 0.5).abs()).fold(0.0f32, f32::max);
        if want_close {
            assert!(worst < 0.05, "footprint lod: worst |texel − ½| = {worst} over {lit:?}");
        } else {
            assert!(worst > 0.2, "base level should alias: {lit:?}");
        }
    }
}

/// The cube [−1, 1]³ with a colour of its own per triangle (so a cube map says which triangle
/// each texel took), outward, with its `flip` flags.
fn cube_of_triangle_colours() -> (Mesh, Vec<bool>) {
    let mut mesh = cube_mesh([[0.0; 3]; 6]);
    mesh.materials = (0..12)
        .map(|t| Material { base_color_factor_linear: [(t + 1) as f32 / 12.0, 0.5, 1.0, 1.0], ..Default::default() })
        .collect();
    mesh.triangle_materials = (0..12).collect();
    (mesh, vec![false; 12])
}

#[test]
fn sample_rules_match_a_brute_force_ray_caster() {
    // Math reference §8's example: cube [−1,1]³, S0 = ((0.2, 0.1, −0.05), 1) inside, S1 =
    // ((0.2, 0.1, 1.6), 1) outside. Equal radii: P_1 = {z > 0.775}, so a triangle is rendered for
    // S1 iff its highest corner has z > 0.775 and for S0 iff its lowest corner has z < 0.775;
    // a texel takes a hit only where the hit point itself lies in the segment (P_0: z < 0.775),
    // as §8 defines the segment by points, not triangles. Every triangle gets its own colour, so
    // the cube map says which triangle was chosen.
    let (mesh, flip) = cube_of_triangle_colours();
    let spheres = [[0.2f32, 0.1, -0.05, 1.0], [0.2, 0.1, 1.6, 1.0]];
    let seg = segment_triangles(&mesh, &spheres).unwrap();
    let tris: Vec<[DVec3; 3]> = (0..12).map(|t| mesh.triangle(t).map(|p| p.as_dvec3())).collect();
    let expect_seg: Vec<Vec<u32>> = vec![
        (0..12).filter(|&t| tris[t as usize].iter().any(|p| p.z < 0.775)).collect(),
        (0..12).filter(|&t| tris[t as usize].iter().any(|p| p.z > 0.775)).collect(),
    ];
    assert_eq!(seg, expect_seg);

    let n = 24;
    let (maps, stats) = render_albedo_cubemaps(&mesh, &flip, &spheres, &settings(1, n)).unwrap();
    let mut compared = 0;
    for (s, map) in maps.iter().enumerate() {
        let c = DVec3::new(f64::from(spheres[s][0]), f64::from(spheres[s][1]), f64::from(spheres[s][2]));
        for (texel, got) in map.texels_linear.iter().enumerate() {
            let face = CubeFace::from_index(texel / (n * n)).unwrap();
            let (j, i) = ((texel / n) % n, texel % n);
            let d = DVec3::from_array(spherebake_sh::cube_texel_direction(face, i, j, n));
            // All hits of the ray c + t·dir (t > 0) as (t, triangle, back-facing), and whether
            // any hit is within 1e-7 of a triangle edge (ambiguous: skipped).
            let hits = |dir: DVec3| {
                let mut out = Vec::new();
                let mut near_edge = false;
                for (t, [a, b, cc]) in tris.iter().enumerate() {
                    let nrm = (*b - *a).cross(*cc - *a);
                    let den = nrm.dot(dir);
                    if den == 0.0 {
                        continue;
                    }
                    let dist = nrm.dot(*a - c) / den;
                    if dist <= 0.0 {
                        continue;
                    }
                    let p = c + dir * dist;
                    let area = nrm.length();
                    let w = [(*b - p).cross(*cc - p), (*cc - p).cross(*a - p), (*a - p).cross(*b - p)]
                        .map(|x| x.dot(nrm) / (area * area));
                    if w.iter().all(|&x| x >= -1e-7) {
                        // On a triangle edge, or on the segment boundary z = 0.775: ambiguous.
                        near_edge |= w.iter().any(|&x| x.abs() < 1e-7) || (p.z - 0.775).abs() < 1e-7;
                        out.push((dist, t, den > 0.0, p.z));
                    }
                }
                (out, near_edge)
            };
            let (fwd, e1) = hits(d);
            let (bwd, e2) = hits(-d);
            if e1 || e2 {
                continue;
            }
            let mine = |h: &(f64, usize, bool, f64)| if s == 0 { h.3 < 0.775 } else { h.3 > 0.775 };
            let colour = |t: usize| mesh.materials[t].base_color_factor_linear;
            let back: Vec<_> = fwd.iter().filter(|h| h.2).collect();
            let want = if let Some(h) = back.iter().filter(|h| mine(h)).max_by(|a, b| a.0.total_cmp(&b.0)) {
                colour(h.1)
            } else if !back.is_empty() {
                [0.0; 4]
            } else if let Some(h) = bwd.iter().filter(|h| !h.2 && mine(h)).min_by(|a, b| a.0.total_cmp(&b.0)) {
                colour(h.1)
            } else {
                [0.0; 4]
            };
            for k in 0..3 {
                assert!((got[k] - want[k]).abs() < 1e-6, "sphere {s} texel {texel} dir {d}: {got:?} vs {want:?}");
            }
            compared += 1;
        }
    }
    assert!(compared > 2 * 6 * n * n * 9 / 10, "too many ambiguous texels: compared {compared}");
    // S0 is inside: every direction has a back-facing hit (rules 1 or 2 only).
    assert_eq!(
        stats.texels_rule1 + stats.texels_rule2 + stats.texels_rule3 + stats.texels_empty,
        (2 * 6 * n * n) as u64
    );
}

#[test]
fn a_triangle_shared_by_two_segments_shows_each_sphere_only_its_own_part() {
    // A white square y = 0, |x|, |z| ≤ 10, facing down (outward −Y), as two triangles whose
    // diagonal crosses x = 0; spheres of equal radius above it at x = ∓1: the segments split at
    // the plane x = 0, so both triangles are rendered for both spheres. Seen from S0 = (−1, 1, 0)
    // the square is back-facing below the horizon; rule 1 holds only where the point seen has
    // x < 0, the rest is rule 2 (0, uncovered texels not filled here), and nothing lies above.
    // Mean of the map = Ω / 4π, Ω the solid angle of the half x ∈ [−10, 0]: a rectangle seen from
    // h = 1 above a point of it is four corner rectangles a × b, each atan(ab / (h √(h² + a² + b²))).
    let mut mesh = Mesh::default();
    for (x, z) in [(-10.0, -10.0), (10.0, -10.0), (10.0, 10.0), (-10.0, 10.0)] {
        mesh.positions.push(Vec3::new(x, 0.0, z));
        mesh.normals.push(Vec3::NEG_Y);
    }
    mesh.triangles = vec![[0, 1, 2], [0, 2, 3]];
    mesh.triangle_materials = vec![0, 0];
    mesh.materials = vec![Material::default()];
    mesh.rebuild_weld();
    let spheres = [[-1.0f32, 1.0, 0.0, 1.5], [1.0, 1.0, 0.0, 1.5]];
    assert_eq!(segment_triangles(&mesh, &spheres).unwrap(), vec![vec![0, 1], vec![0, 1]]);
    let corner = |a: f64, b: f64| (a * b / (1.0 + a * a + b * b).sqrt()).atan();
    // Own half: 1 and 9 either side of the foot along x, 10 either side along z.
    let own = 2.0 * (corner(1.0, 10.0) + corner(9.0, 10.0));
    // The whole square (what drawing whole triangles gives): 9 and 11 along x.
    let whole = 2.0 * (corner(11.0, 10.0) + corner(9.0, 10.0));
    assert!(whole > 1.25 * own, "the check separates the two ({own} vs {whole})");
    let y0 = 0.5 / PI.sqrt();
    let s = AlbedoSettings { fill_uncovered: false, ..settings(2, 64) };
    let (sh, stats) = bake_albedo(&mesh, &[false, false], &spheres, &s).unwrap();
    assert_eq!(stats.shared_triangles, 2);
    for k in 0..2 {
        let mean = f64::from(sh.coefficients[k * 4][0]) * y0;
        let want = own / (4.0 * PI);
        // Texel-centre sampling of the edge x = 0 at 64² faces (measured 0.03 % and 0.4 % off):
        // within 1 %, where drawing the whole square gives 30 % more.
        assert!(
            (mean - want).abs() < 0.01 * want,
            "sphere {k}: mean {mean}, own half {want}, whole {}",
            whole / (4.0 * PI)
        );
        // The map leans towards the sphere's own half: −x for S0, +x for S1 (y_{1,1} = −√(3/4π) x
        // with the Condon–Shortley phase, so the coefficient's sign is the opposite).
        let x = f64::from(sh.coefficients[k * 4 + 3][0]);
        assert!(if k == 0 { x > 0.0 } else { x < 0.0 }, "sphere {k}: x coefficient {x}");
    }
}

#[test]
fn segment_assignment_is_conservative() {
    // Dense sampling of each triangle: the nearest sphere (|p − c|/r) of every sample point must
    // have the triangle in its list.
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    let mut rnd = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f32 / (1u64 << 53) as f32
    };
    let spheres: Vec<[f32; 4]> =
        (0..12).map(|_| [rnd() * 4.0 - 2.0, rnd() * 4.0 - 2.0, rnd() * 4.0 - 2.0, 0.3 + rnd() * 1.5]).collect();
    let mut mesh = Mesh::default();
    for t in 0..300 {
        let c = Vec3::new(rnd() * 4.0 - 2.0, rnd() * 4.0 - 2.0, rnd() * 4.0 - 2.0);
        let s = [0.05, 0.5, 2.0][t % 3];
        for _ in 0..3 {
            mesh.positions.push(c + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * s);
        }
        mesh.triangles.push([3 * t as u32, 3 * t as u32 + 1, 3 * t as u32 + 2]);
    }
    let seg = segment_triangles(&mesh, &spheres).unwrap();
    let mut shared = 0;
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = tri.map(|v| mesh.positions[v as usize].as_dvec3());
        let m = 60;
        let mut owners = std::collections::BTreeSet::new();
        for (_, _, p) in spherebake_geom::triangle::triangle_grid(a, b, c, m) {
            let (mut best, mut arg) = (f64::INFINITY, 0);
            for (k, s) in spheres.iter().enumerate() {
                let d = (p - DVec3::new(f64::from(s[0]), f64::from(s[1]), f64::from(s[2]))).length() / f64::from(s[3]);
                if d < best {
                    (best, arg) = (d, k);
                }
            }
            owners.insert(arg);
        }
        for o in &owners {
            assert!(seg[*o].contains(&(t as u32)), "triangle {t} has points in segment {o} but is not rendered for it");
        }
        shared += usize::from(owners.len() > 1);
    }
    assert!(shared > 20, "the random set should exercise shared triangles ({shared})");
}

#[test]
fn output_is_identical_for_any_thread_count() {
    let mut mesh = icosphere(3);
    let tex = pattern(64, 64);
    mesh.textures = vec![tex];
    mesh.materials[0].base_color_texture = Some(tref(WrapMode::Repeat, UvTransform::default()));
    mesh.uvs =
        vec![mesh.positions.iter().map(|p| [p.x.atan2(p.z) / std::f32::consts::TAU + 0.5, 0.5 - p.y * 0.5]).collect()];
    let flip = vec![false; mesh.triangles.len()];
    let spheres: Vec<[f32; 4]> =
        (0..9).map(|k| [0.3 * ((k % 3) as f32 - 1.0), 0.3 * ((k / 3) as f32 - 1.0), 0.1, 0.5]).collect();
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| bake_albedo(&mesh, &flip, &spheres, &settings(5, 24)).unwrap().0.coefficients)
    };
    let one = run(1);
    let bits = |v: &[[f32; 3]]| v.iter().flat_map(|c| c.map(f32::to_bits)).collect::<Vec<u32>>();
    assert_eq!(bits(&one), bits(&run(2)));
    assert_eq!(bits(&one), bits(&run(3)));
    assert!(one.iter().any(|c| c[0] != 0.0));
}

#[test]
fn invalid_input_is_reported() {
    let mesh = cube_mesh([[1.0; 3]; 6]);
    let flip = vec![false; 12];
    let ok = [[0.0f32, 0.0, 0.0, 1.0]];
    let e = bake_albedo(&mesh, &flip[..11], &ok, &settings(4, 8)).unwrap_err();
    assert!(matches!(e, spherebake_bake::AlbedoError::FlipLength { expected: 12, actual: 11 }), "{e}");
    let e = bake_albedo(&mesh, &flip, &ok, &settings(9, 8)).unwrap_err();
    assert!(matches!(e, spherebake_bake::AlbedoError::InvalidSetting { name: "sh_order", value: 9, .. }), "{e}");
    let e = bake_albedo(&mesh, &flip, &[[0.0, 0.0, 0.0, -1.0]], &settings(4, 8)).unwrap_err();
    assert!(matches!(e, spherebake_bake::AlbedoError::InvalidSphere { index: 0, .. }), "{e}");
    let mut bad = mesh.clone();
    bad.triangle_materials[3] = 40;
    let e = bake_albedo(&bad, &flip, &ok, &settings(4, 8)).unwrap_err();
    assert!(matches!(e, spherebake_bake::AlbedoError::MaterialOutOfRange { triangle: 3, material: 40, .. }), "{e}");
    let mut bad = mesh.clone();
    bad.triangles[5][1] = 1000;
    let e = bake_albedo(&bad, &flip, &ok, &settings(4, 8)).unwrap_err();
    assert!(matches!(e, spherebake_bake::AlbedoError::VertexOutOfRange { triangle: 5, index: 1000, .. }), "{e}");
    // No spheres: an empty, valid result.
    let (sh, _) = bake_albedo(&mesh, &flip, &[], &settings(4, 8)).unwrap();
    assert!(sh.coefficients.is_empty() && sh.order == 4);
}

#[test]
fn debug_cubemaps_are_written() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = cube_mesh([
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 1.0],
        [1.0, 0.0, 1.0],
    ]);
    let s = AlbedoSettings { debug_dir: Some(dir.path().join("dbg")), ..settings(4, 16) };
    // The small second sphere leaves the face centres below in the first sphere's segment.
    let (_, stats) = bake_albedo(&mesh, &[false; 12], &[[0.0, 0.0, 0.0, 1.0], [0.5, 0.5, 0.5, 0.25]], &s).unwrap();
    assert_eq!(stats.debug_files.len(), 2);
    let img = image::open(&stats.debug_files[0]).unwrap().to_rgb8();
    // Faces enlarged ×4 to 64 px: two crosses of 4×3 faces plus a gap of 16 px.
    assert_eq!((img.width(), img.height()), (8 * 64 + 16, 3 * 64));
    // Centre of the +X face in the left cross (column 2, row 1) is red (sRGB 255, 0, 0).
    assert_eq!(img.get_pixel(2 * 64 + 32, 64 + 32).0, [255, 0, 0]);
    // +Y face (column 1, row 0) is blue.
    assert_eq!(img.get_pixel(64 + 32, 32).0, [0, 0, 255]);
}

#[test]
fn hostile_values_do_not_panic_or_leak_nan() {
    // Non-finite and huge positions, UVs and colours: the stage must finish with finite output.
    let n = 8usize;
    let mut mesh = quad_mesh(
        |x, y| [x * 1e30, y * f32::MAX],
        pattern(4, 4),
        tref(WrapMode::Repeat, UvTransform::default()),
        [1.0; 4],
    );
    mesh.colors_linear = vec![[f32::NAN, 1.0, f32::INFINITY, 1.0]; 4];
    mesh.positions.push(Vec3::new(f32::NAN, 0.0, 1.0));
    mesh.positions.push(Vec3::new(1e30, -1e30, 1.0));
    mesh.colors_linear.extend([[1.0; 4]; 2]);
    mesh.uvs[0].extend([[f32::NAN, 0.0], [0.0, f32::INFINITY]]);
    mesh.triangles.push([0, 4, 5]);
    mesh.triangles.push([4, 4, 4]);
    mesh.triangle_materials.extend([0, 0]);
    let flip = vec![false; mesh.triangles.len()];
    for lod in [spherebake_bake::TextureLod::Footprint, spherebake_bake::TextureLod::Base] {
        let s = AlbedoSettings { sh_order: 3, cubemap_size: n, texture_lod: lod, ..Default::default() };
        let (sh, _) = bake_albedo(&mesh, &flip, &[[0.0, 0.0, 0.0, 1.0], [0.1, 0.0, 0.5, 0.0]], &s).unwrap();
        assert!(sh.coefficients.iter().flatten().all(|v| v.is_finite()), "{:?}", sh.coefficients);
    }
}

#[test]
fn uncovered_directions_take_the_segment_mean_so_a_one_colour_segment_stays_one_colour() {
    // A one-colour unit sphere split between two spheres at x = ±0.5 (equal radii: each owns its
    // half). Half of each cube map is another segment's (rule 2). Filled with the segment's mean,
    // the map is the constant colour, so its SH is exact at every direction; left 0, the order-4
    // truncation of the step darkens the sphere's own directions near the split.
    let colour = [0.8f32, 0.6, 0.2];
    let mut mesh = icosphere(3);
    mesh.materials[0].base_color_factor_linear = [colour[0], colour[1], colour[2], 1.0];
    let flip = vec![false; mesh.triangles.len()];
    let spheres = [[0.5f32, 0.0, 0.0, 1.2], [-0.5, 0.0, 0.0, 1.2]];
    let worst = |fill: bool| -> f64 {
        let s = AlbedoSettings { fill_uncovered: fill, ..settings(4, 32) };
        let (sh, stats) = bake_albedo(&mesh, &flip, &spheres, &s).unwrap();
        if fill {
            // One colour: known from the segments alone (the other half is not drawn).
            assert_eq!(stats.one_colour_spheres, 2, "{stats:?}");
            assert!(stats.texels_unclassified > 0 && stats.texels_rule2 == 0, "{stats:?}");
        } else {
            assert!(stats.texels_rule2 > 0, "each sphere must see the other's half");
            assert_eq!(stats.one_colour_spheres, 0);
        }
        let nc = coeff_count(4);
        let mut y = vec![0.0; nc];
        let mut worst = 0.0f64;
        for (i, c) in spheres.iter().enumerate() {
            let centre = DVec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2]));
            for a in 0..40 {
                for b in 0..80 {
                    let z = -1.0 + (f64::from(a) + 0.5) / 20.0;
                    let phi = (f64::from(b) + 0.5) * PI / 40.0;
                    let r = (1.0 - z * z).sqrt();
                    let d = DVec3::new(z, r * phi.cos(), r * phi.sin());
                    // Where the ray from the centre leaves the unit sphere: |centre + t d| = 1.
                    let bq = centre.dot(d);
                    let t = -bq + (bq * bq - centre.length_squared() + 1.0).sqrt();
                    let p = centre + d * t;
                    // Only the sphere's own half, away from the split by one cube-map texel or so.
                    if p.x * centre.x.signum() < 0.05 {
                        continue;
                    }
                    eval_sh_f64(4, d.to_array(), &mut y).unwrap();
                    for (k, want) in colour.iter().enumerate() {
                        let v: f64 = (0..nc).map(|q| f64::from(sh.coefficients[i * nc + q][k]) * y[q]).sum();
                        worst = worst.max((v / f64::from(*want) - 1.0).abs());
                    }
                }
            }
        }
        worst
    };
    let (filled, zero) = (worst(true), worst(false));
    assert!(filled < 2e-3, "filled: worst relative colour error on the own half {filled}");
    assert!(zero > 0.1, "left 0, the split should darken the own half near it (worst {zero})");
}

#[test]
fn a_one_colour_mesh_skips_the_coverage_pass_and_bakes_what_the_full_render_gives() {
    // The reference: every cube map rendered in full without the fill (`render_albedo_cubemaps`),
    // its uncovered (zero) texels set to its covered texels' colour when it has any, projected by
    // `project_cubemaps`. Spheres: the two halves of a unit sphere (rule 1 texels: the shortcut),
    // a small sphere whose centre lies outside the surface above it (its cap is seen through
    // the centre, rule 3 only: rendered in full), and one of radius 0 (no segment: all 0).
    let colour = [0.8f32, 0.6, 0.2];
    let spheres = [[0.5f32, 0.0, 0.0, 1.2], [-0.5, 0.0, 0.0, 1.2], [0.0, 0.0, 1.3, 0.45], [0.0, 0.2, 0.0, 0.0]];
    let reference = |mesh: &Mesh, flip: &[bool]| -> Vec<[f32; 3]> {
        let s = AlbedoSettings { fill_uncovered: false, ..settings(4, 16) };
        let (mut maps, _) = render_albedo_cubemaps(mesh, flip, &spheres, &s).unwrap();
        for m in &mut maps {
            if let Some(&c) = m.texels_linear.iter().find(|t| **t != [0.0; 3]) {
                for t in m.texels_linear.iter_mut().filter(|t| **t == [0.0; 3]) {
                    *t = c;
                }
            }
        }
        project_cubemaps(&maps, 4).unwrap().coefficients
    };
    let mut mesh = icosphere(3);
    mesh.materials[0].base_color_factor_linear = [colour[0], colour[1], colour[2], 1.0];
    // One colour also with a second material of the same factor and a constant COLOR_0.
    mesh.materials.push(mesh.materials[0].clone());
    for (t, m) in mesh.triangle_materials.iter_mut().enumerate() {
        *m = (t % 2) as u32;
    }
    mesh.colors_linear = vec![[0.5, 1.0, 0.25, 0.3]; mesh.positions.len()];
    let flip = vec![false; mesh.triangles.len()];
    let (sh, stats) = bake_albedo(&mesh, &flip, &spheres, &settings(4, 16)).unwrap();
    assert_eq!(stats.one_colour_spheres, 2, "{stats:?}");
    assert!(stats.texels_rule3 > 0, "the outside sphere is rendered in full: {stats:?}");
    let want = reference(&mesh, &flip);
    let nc = coeff_count(4);
    assert!(want[2 * nc][0] > 0.0 && want[3 * nc..].iter().flatten().all(|&v| v == 0.0));
    for (q, (a, b)) in sh.coefficients.iter().zip(&want).enumerate() {
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() <= 1e-6 * (1.0 + b[k].abs()), "coefficient {q}: {a:?} vs {b:?}");
        }
    }
    // Not one colour: a vertex colour differs, or a factor does; every sphere is rendered in full.
    let mut varied = mesh.clone();
    varied.colors_linear[0][1] = 0.9;
    let mut two = mesh.clone();
    two.materials[1].base_color_factor_linear[2] = 0.3;
    for m in [&varied, &two] {
        let (_, stats) = bake_albedo(m, &flip, &spheres, &settings(4, 16)).unwrap();
        assert_eq!((stats.one_colour_spheres, stats.texels_unclassified), (0, 0), "{stats:?}");
        assert!(stats.texels_rule2 > 0, "the coverage pass ran: {stats:?}");
    }
}

#[test]
fn a_sphere_without_a_segment_renders_nothing_and_leaves_the_others_alone() {
    // The cube of the ray-caster test with its two spheres, plus a sphere of the least positive
    // radius at the centre (how a fit stores a sphere it left empty): its scaled distance to
    // every point is far the largest, so its segment holds no triangle. Rules 1 and 3 read only
    // the segment's triangles, so its map is 0; the other maps are the same bits as without it.
    let (mesh, flip) = cube_of_triangle_colours();
    let two = [[0.2f32, 0.1, -0.05, 1.0], [0.2, 0.1, 1.6, 1.0]];
    let three = [two[0], two[1], [0.0, 0.0, 0.0, f32::MIN_POSITIVE]];
    assert!(segment_triangles(&mesh, &three).unwrap()[2].is_empty());
    let n = 16;
    let (maps2, stats2) = render_albedo_cubemaps(&mesh, &flip, &two, &settings(1, n)).unwrap();
    let (maps3, stats3) = render_albedo_cubemaps(&mesh, &flip, &three, &settings(1, n)).unwrap();
    let bits = |m: &CubeMap| m.texels_linear.iter().flat_map(|t| t.map(f32::to_bits)).collect::<Vec<u32>>();
    for s in 0..2 {
        assert_eq!(bits(&maps3[s]), bits(&maps2[s]), "sphere {s}");
    }
    assert!(maps3[2].texels_linear.iter().all(|t| *t == [0.0; 3]));
    assert_eq!(stats3.texels_no_segment, (6 * n * n) as u64, "{stats3:?}");
    assert_eq!(
        (stats3.texels_rule1, stats3.texels_rule2, stats3.texels_rule3, stats3.texels_empty),
        (stats2.texels_rule1, stats2.texels_rule2, stats2.texels_rule3, stats2.texels_empty)
    );
}
