//! Imports every model in `/work/shared/models` (found as `../shared/models` relative to the
//! repository root) and checks the topology report against every number of its README:
//! triangles, file / welded vertex counts, closed + boundary edges, volume, AABB, components,
//! consistent orientation, surface area, joint count, influences per vertex, texture size, and
//! the mesh-space volumes / boxes where the import keeps mesh-space data (skin bind positions).
//! Skips with a message when the directory is absent.
//!
//! Where the README's definition is not what `Mesh` stores, the test computes it from the import:
//! - *file vertices*: OBJ = number of `v` lines (tobj drops unused vertices and splits UV
//!   seams); glTF = Σ POSITION counts over the primitives of each distinct mesh
//!   ([`ImportedPart::file_vertex_count`], first instance only).
//! - *welded*: distinct bit-identical f32 positions (−0 ≠ +0, unlike `Mesh::rebuild_weld`, which
//!   merges ±0) among used vertices, primitives of a mesh pooled, each distinct mesh once, in
//!   mesh space (skin bind positions) or in the scene space of its first instance.
//! - *closed / boundary / components / oriented*: `TopologyReport` on the scene mesh with that
//!   strict (bit-identical) weld. Only the teapot differs between the two welds: it has `-0.0`
//!   coordinates (3325 / 420 boundary edges strict, 3241 / 160 with ±0 merged).

use std::collections::{BTreeMap, HashSet};
use std::path::Path;

use spherebake_geom::glam::Vec3;
use spherebake_geom::topology::TopologyReport;
use spherebake_geom::Mesh;
use spherebake_io::{load_mesh, Imported};
use spherebake_testkit::shared_models_dir;

/// A README number with the tolerance of its printed digits (half a unit in the last place).
fn printed(s: &str) -> (f64, f64) {
    let v: f64 = s.parse().unwrap();
    let decimals = s.split_once('.').map_or(0, |(_, f)| f.len()) as i32;
    (v, 0.5 * 10f64.powi(-decimals))
}

struct Row {
    path: &'static str,
    tris: usize,
    verts_file: usize,
    welded: usize,
    /// `Some(0)` closed, `Some(n)` open with n boundary edges.
    boundary: usize,
    /// Volume as printed; closed models are checked to 1e-5 relative, open ones to the printed digits.
    volume: &'static str,
    aabb: ([f64; 3], [f64; 3]),
    components: usize,
    area: &'static str,
    /// Joints and maximum influences per vertex.
    skin: Option<(usize, usize)>,
    /// Base colour texture sizes expected among the textures.
    textures: &'static [(u32, u32)],
}

#[rustfmt::skip]
fn rows() -> Vec<Row> {
    vec![
        Row { path: "gltf/CesiumMan.glb", tris: 4672, verts_file: 3273, welded: 2338, boundary: 0, volume: "0.05371328",
              aabb: ([-0.569137, -1.75046e-07, -0.131], [0.569137, 1.50655, 0.180954]), components: 1, area: "1.535581",
              skin: Some((19, 4)), textures: &[(1024, 1024)] },
        Row { path: "gltf/Fox.glb", tris: 576, verts_file: 1728, welded: 290, boundary: 0, volume: "66487.75",
              aabb: ([-12.5927, -0.121744, -88.095], [12.5927, 78.9072, 66.6249]), components: 1, area: "15070.77",
              skin: Some((24, 4)), textures: &[(1024, 1024)] },
        Row { path: "gltf/RiggedFigure.glb", tris: 256, verts_file: 370, welded: 130, boundary: 0, volume: "0.06071126",
              aabb: ([-0.589461, -2.31534e-07, -0.130918], [0.589461, 1.44992, 0.194978]), components: 1, area: "1.832229",
              skin: Some((19, 4)), textures: &[] },
        Row { path: "gltf/RiggedSimple.glb", tris: 188, verts_file: 160, welded: 96, boundary: 0, volume: "11.38286",
              aabb: ([-1.0, -4.57508, -1.0], [1.0, 4.57508, 1.0]), components: 1, area: "38.73955",
              skin: Some((2, 2)), textures: &[] },
        Row { path: "gltf/Duck.glb", tris: 4212, verts_file: 2399, welded: 2108, boundary: 0, volume: "1.195799",
              aabb: ([-0.692985, 0.0992937, -0.613282], [0.961799, 1.6397, 0.539252]), components: 1, area: "7.023517",
              skin: None, textures: &[(512, 512)] },
        Row { path: "gltf/Duck/Duck.gltf", tris: 4212, verts_file: 2399, welded: 2108, boundary: 0, volume: "1.195799",
              aabb: ([-0.692985, 0.0992937, -0.613282], [0.961799, 1.6397, 0.539252]), components: 1, area: "7.023517",
              skin: None, textures: &[(512, 512)] },
        Row { path: "gltf/BoxTextured.glb", tris: 12, verts_file: 24, welded: 8, boundary: 0, volume: "1",
              aabb: ([-0.5; 3], [0.5; 3]), components: 1, area: "6", skin: None, textures: &[(256, 256)] },
        Row { path: "gltf/BoxTextured/BoxTextured.gltf", tris: 12, verts_file: 24, welded: 8, boundary: 0, volume: "1",
              aabb: ([-0.5; 3], [0.5; 3]), components: 1, area: "6", skin: None, textures: &[(256, 256)] },
        Row { path: "gltf/BoxVertexColors.glb", tris: 12, verts_file: 24, welded: 8, boundary: 0, volume: "1",
              aabb: ([0.0; 3], [1.0; 3]), components: 1, area: "6", skin: None, textures: &[] },
        Row { path: "gltf/CesiumMilkTruck.glb", tris: 3624, verts_file: 3995, welded: 1452, boundary: 8, volume: "19.25",
              aabb: ([-1.396, 0.00145183, -2.43091], [1.396, 2.58437, 2.438]), components: 13, area: "64.81636",
              skin: None, textures: &[(2048, 2048)] },
        Row { path: "gltf/GlassHurricaneCandleHolder.glb", tris: 4126, verts_file: 2386, welded: 2072, boundary: 4,
              volume: "0.002465", aabb: ([-0.0951675, 0.0, -0.0951675], [0.0951675, 0.306576, 0.0951675]), components: 4,
              area: "0.3817133", skin: None, textures: &[(2048, 2048)] },
        Row { path: "gltf/TextureTransformTest/TextureTransformTest.gltf", tris: 24, verts_file: 36, welded: 36,
              boundary: 48, volume: "0.0003667", aabb: ([-1.6, -1.14127, 0.0], [1.6, 1.05, 0.01]), components: 12,
              area: "6.11", skin: None, textures: &[(256, 256), (128, 128), (128, 128), (128, 128), (128, 128)] },
        Row { path: "gltf/TwoSidedPlane/TwoSidedPlane.gltf", tris: 2, verts_file: 6, welded: 4, boundary: 4, volume: "0",
              aabb: ([-1.0, 0.0, -1.0], [1.0, 0.0, 1.0]), components: 1, area: "4", skin: None, textures: &[(256, 256)] },
        Row { path: "obj/stanford-bunny.obj", tris: 69451, verts_file: 35947, welded: 34834, boundary: 223,
              volume: "0.0007701", aabb: ([-0.09469, 0.032987, -0.061874], [0.061009, 0.187321, 0.0588]), components: 1,
              area: "0.05712879", skin: None, textures: &[] },
        Row { path: "obj/armadillo.obj", tris: 50000, verts_file: 25002, welded: 25002, boundary: 0, volume: "237843.1",
              aabb: ([-63.5005, -54.2017, -57.7042], [63.5176, 97.1075, 57.7187]), components: 1, area: "38167.15",
              skin: None, textures: &[] },
        Row { path: "obj/spot/spot.obj", tris: 5856, verts_file: 2930, welded: 2930, boundary: 0, volume: "0.7182588",
              aabb: ([-0.471552, -0.736784, -0.668909], [0.471552, 0.953646, 1.049]), components: 1, area: "5.709519",
              skin: None, textures: &[(1024, 1024)] },
        Row { path: "obj/spot/spot_triangulated.obj", tris: 5856, verts_file: 2930, welded: 2930, boundary: 0,
              volume: "0.7182588", aabb: ([-0.471552, -0.736784, -0.668909], [0.471552, 0.953646, 1.049]), components: 1,
              area: "5.709519", skin: None, textures: &[] },
        Row { path: "obj/teapot.obj", tris: 6320, verts_file: 3644, welded: 3325, boundary: 420, volume: "25.77",
              aabb: ([-3.0, 0.0, -2.0], [3.434, 3.15, 2.0]), components: 3, area: "52.66079", skin: None, textures: &[] },
    ]
}

fn bits(p: Vec3) -> [u32; 3] {
    p.to_array().map(f32::to_bits)
}

/// The mesh with a strict weld: bit-identical f32 positions only (−0 ≠ +0).
fn strict_weld(mesh: &Mesh) -> Mesh {
    let mut m = mesh.clone();
    let mut ids: std::collections::HashMap<[u32; 3], u32> = Default::default();
    m.welded_positions.clear();
    m.weld = m
        .positions
        .iter()
        .map(|&p| {
            let next = ids.len() as u32;
            *ids.entry(bits(p)).or_insert_with(|| {
                m.welded_positions.push(p);
                next
            })
        })
        .collect();
    m
}

/// README "verts file" and "welded" from the import (see the module docs).
fn file_and_welded(path: &Path, imp: &Imported) -> (usize, usize) {
    if path.extension().is_some_and(|e| e == "obj") {
        let text = std::fs::read_to_string(path).unwrap();
        let v_lines = text.lines().filter(|l| l.starts_with("v ")).count();
        let used: HashSet<[u32; 3]> =
            imp.mesh.triangles.iter().flatten().map(|&v| bits(imp.mesh.positions[v as usize])).collect();
        return (v_lines, used.len());
    }
    // First instance (node) of each distinct glTF mesh.
    let mut first_node: BTreeMap<usize, Option<usize>> = BTreeMap::new();
    for p in &imp.parts {
        first_node.entry(p.source_mesh).or_insert(p.node);
    }
    let (mut file, mut welded) = (0, 0);
    for (&mesh, &node) in &first_node {
        let mut set = HashSet::new();
        for p in imp.parts.iter().filter(|p| p.source_mesh == mesh && p.node == node) {
            file += p.file_vertex_count;
            // Skinned files: every vertex has its raw (bind / mesh space) position in the skin.
            let skinned = imp.mesh.skin.as_ref();
            for t in p.triangles.start..p.triangles.end {
                for &v in &imp.mesh.triangles[t as usize] {
                    let pos = match skinned {
                        Some(s) => s.bind_positions[v as usize],
                        None => imp.mesh.positions[v as usize],
                    };
                    set.insert(bits(pos));
                }
            }
        }
        welded += set.len();
    }
    (file, welded)
}

#[test]
fn shared_models_match_readme() {
    let Some(dir) = shared_models_dir() else { return };
    let mut failures = Vec::new();
    for row in rows() {
        let path = dir.join(row.path);
        let imp = match load_mesh(&path) {
            Ok(i) => i,
            Err(e) => {
                failures.push(format!("{}: {e}", row.path));
                continue;
            }
        };
        let mut check = |what: &str, ok: bool, got: String| {
            if !ok {
                failures.push(format!("{}: {what}: got {got}", row.path));
            }
        };
        let m = &imp.mesh;
        let r = TopologyReport::compute(&strict_weld(m));
        check("triangles", r.triangle_count == row.tris, r.triangle_count.to_string());
        let (file, welded) = file_and_welded(&path, &imp);
        check("file vertices", file == row.verts_file, file.to_string());
        check("welded vertices", welded == row.welded, welded.to_string());
        check("boundary edges", r.boundary_edge_count == row.boundary, r.boundary_edge_count.to_string());
        check("non-manifold edges", r.non_manifold_edge_count == 0, r.non_manifold_edge_count.to_string());
        check("degenerate triangles", r.degenerate_triangle_count == 0, r.degenerate_triangle_count.to_string());
        check("closed", r.closed == (row.boundary == 0), r.closed.to_string());
        // README: every closed model is consistently oriented ("yes"), every open one "–".
        check(
            "consistently oriented",
            r.consistently_oriented == (row.boundary == 0),
            r.consistently_oriented.to_string(),
        );
        check("components", r.component_count == row.components, r.component_count.to_string());
        let (vol, vol_tol) = printed(row.volume);
        let vol_tol = if row.boundary == 0 {
            1e-5 * vol.abs()
        } else if vol == 0.0 {
            1e-12
        } else {
            vol_tol
        };
        check("volume", (r.signed_volume - vol).abs() <= vol_tol, r.signed_volume.to_string());
        let (area, _) = printed(row.area);
        check("surface area", (r.surface_area - area).abs() <= 1e-5 * area, r.surface_area.to_string());
        let (lo, hi) = r.aabb.unwrap();
        let (elo, ehi) = (Vec3::from(row.aabb.0.map(|x| x as f32)), Vec3::from(row.aabb.1.map(|x| x as f32)));
        let tol = 1e-5 * (ehi - elo).length();
        check(
            "aabb",
            (lo - elo).abs().max_element() <= tol && (hi - ehi).abs().max_element() <= tol,
            format!("{lo} {hi}"),
        );
        match (row.skin, &m.skin) {
            (Some((joints, max_infl)), Some(s)) => {
                check("joints", s.skeleton.bones.len() == joints, s.skeleton.bones.len().to_string());
                let most = s.influences.iter().map(|i| i.weights.iter().filter(|&&w| w > 0.0).count()).max().unwrap();
                check("influences", most <= max_infl, most.to_string());
                let sums_ok = s.influences.iter().all(|i| (i.weights.iter().sum::<f32>() - 1.0).abs() < 1e-5);
                check("weights sum to 1", sums_ok, String::new());
            }
            (None, None) => {}
            (want, got) => check("skin", false, format!("want {want:?}, got {}", got.is_some())),
        }
        let sizes: Vec<(u32, u32)> = m.textures.iter().map(|t| (t.width, t.height)).collect();
        check("textures", sizes == row.textures, format!("{sizes:?}"));
        for t in &m.textures {
            check("texels", t.texels_linear.len() == (t.width * t.height) as usize, t.name.clone());
        }
        check("normals", m.normals.len() == m.positions.len(), m.normals.len().to_string());
    }
    assert!(failures.is_empty(), "{} mismatches:\n{}", failures.len(), failures.join("\n"));
}

/// Mesh space (README second table) for the skinned models: the skin's bind positions are the raw
/// POSITION data, so their volume and box must match without any transform.
#[test]
fn skinned_bind_positions_are_mesh_space() {
    let Some(dir) = shared_models_dir() else { return };
    #[rustfmt::skip]
    let cases = [
        ("gltf/CesiumMan.glb", 0.05371326, ([-0.131, -0.569137, 0.0], [0.180954, 0.569137, 1.50655])),
        ("gltf/Fox.glb", 66487.75, ([-12.5927, -0.121745, -88.095], [12.5927, 78.9072, 66.6249])),
        ("gltf/RiggedFigure.glb", 0.06071122, ([-0.589461, -0.194977, 0.0], [0.589461, 0.130918, 1.44992])),
        ("gltf/RiggedSimple.glb", 11.38286, ([-1.0, -1.0, -4.57508], [1.0, 1.0, 4.57508])),
    ];
    for (path, vol, (lo, hi)) in cases {
        let imp = load_mesh(&dir.join(path)).unwrap();
        let mut m = imp.mesh.clone();
        m.positions = imp.mesh.skin.as_ref().unwrap().bind_positions.clone();
        m.rebuild_weld();
        let r = TopologyReport::compute(&m);
        assert!((r.signed_volume - vol).abs() <= 1e-5 * vol, "{path}: {}", r.signed_volume);
        let (l, h) = r.aabb.unwrap();
        let (el, eh) = (Vec3::from(lo.map(|x: f64| x as f32)), Vec3::from(hi.map(|x: f64| x as f32)));
        let tol = 1e-5 * (eh - el).length();
        assert!((l - el).abs().max_element() <= tol && (h - eh).abs().max_element() <= tol, "{path}: {l} {h}");
    }
}

/// The Duck's node scales the mesh by 0.01: scene volume 1.195799 (first table) = mesh-space
/// volume 1195799 (second table) × 0.01³, and the mesh-space box × 0.01 is the scene box.
#[test]
fn duck_node_scale_applied() {
    let Some(dir) = shared_models_dir() else { return };
    for path in ["gltf/Duck.glb", "gltf/Duck/Duck.gltf"] {
        let imp = load_mesh(&dir.join(path)).unwrap();
        let r = TopologyReport::compute(&imp.mesh);
        assert!((r.signed_volume - 1195799.0 * 1e-6).abs() < 1e-5 * 1.195799, "{path}: {}", r.signed_volume);
        let (lo, hi) = r.aabb.unwrap();
        assert!((lo - Vec3::new(-0.692985, 0.0992937, -0.613282)).abs().max_element() < 1e-5, "{lo}");
        assert!((hi - Vec3::new(0.961799, 1.6397, 0.539252)).abs().max_element() < 1e-5, "{hi}");
    }
}

/// (path, instances, distinct meshes, triangles of the distinct meshes, volume as printed,
/// whether the volume is a closed one, AABB).
type MeshSpaceRow = (&'static str, usize, usize, usize, &'static str, bool, ([f64; 3], [f64; 3]));

/// README second table (glTF in mesh space: raw POSITION of each distinct mesh once, no
/// transform): recovered from the import as skin bind positions (skinned files) or as scene
/// positions mapped back through the inverse of the instancing node's world matrix.
#[test]
fn gltf_mesh_space_table() {
    let Some(dir) = shared_models_dir() else { return };
    // (path, instances, distinct meshes, triangles of the distinct meshes, volume as printed,
    //  whether the volume is a closed one, AABB)
    #[rustfmt::skip]
    let rows: [MeshSpaceRow; 11] = [
        ("gltf/CesiumMan.glb", 1, 1, 4672, "0.05371326", true, ([-0.131, -0.569137, 0.0], [0.180954, 0.569137, 1.50655])),
        ("gltf/Fox.glb", 1, 1, 576, "66487.75", true, ([-12.5927, -0.121745, -88.095], [12.5927, 78.9072, 66.6249])),
        ("gltf/RiggedFigure.glb", 1, 1, 256, "0.06071122", true, ([-0.589461, -0.194977, 0.0], [0.589461, 0.130918, 1.44992])),
        ("gltf/RiggedSimple.glb", 1, 1, 188, "11.38286", true, ([-1.0, -1.0, -4.57508], [1.0, 1.0, 4.57508])),
        ("gltf/Duck.glb", 1, 1, 4212, "1195799", true, ([-69.2985, 9.92937, -61.3282], [96.1799, 163.97, 53.9252])),
        ("gltf/Duck/Duck.gltf", 1, 1, 4212, "1195799", true, ([-69.2985, 9.92937, -61.3282], [96.1799, 163.97, 53.9252])),
        ("gltf/BoxTextured.glb", 1, 1, 12, "1", true, ([-0.5; 3], [0.5; 3])),
        ("gltf/BoxVertexColors.glb", 1, 1, 12, "1", true, ([0.0; 3], [1.0; 3])),
        ("gltf/CesiumMilkTruck.glb", 3, 2, 2856, "18.98", false, ([-2.43091, -1.396, -2.58437], [2.438, 1.396, 0.4278])),
        ("gltf/GlassHurricaneCandleHolder.glb", 2, 2, 4126, "0.002465", false,
         ([-0.0951675, -0.0951675, -0.306576], [0.0951675, 0.272126, 0.0707887])),
        ("gltf/TextureTransformTest/TextureTransformTest.gltf", 12, 9, 18, "0", false, ([-0.5, -0.5, 0.0], [0.5, 0.5, 0.0])),
    ];
    let mut failures = Vec::new();
    for (path, instances, distinct, tris, volume, closed, (elo, ehi)) in rows {
        let imp = load_mesh(&dir.join(path)).unwrap();
        let nodes: HashSet<Option<usize>> = imp.parts.iter().map(|p| p.node).collect();
        let mut first_node: BTreeMap<usize, Option<usize>> = BTreeMap::new();
        for p in &imp.parts {
            first_node.entry(p.source_mesh).or_insert(p.node);
        }
        let mut vol = 0.0f64;
        let mut n_tris = 0;
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for p in imp.parts.iter().filter(|p| first_node[&p.source_mesh] == p.node) {
            let back = p.node_world.inverse();
            let mesh_space = |v: u32| match &imp.mesh.skin {
                Some(s) => s.bind_positions[v as usize],
                None => back.transform_point3(imp.mesh.positions[v as usize]),
            };
            for t in p.triangles.start..p.triangles.end {
                let [a, b, c] = imp.mesh.triangles[t as usize].map(mesh_space);
                for q in [a, b, c] {
                    lo = lo.min(q);
                    hi = hi.max(q);
                }
                let [a, b, c] = [a, b, c].map(Vec3::as_dvec3);
                vol += a.dot(b.cross(c)) / 6.0;
                n_tris += 1;
            }
        }
        let (v, half_digit) = printed(volume);
        // A printed 0 (flat TextureTransformTest) only holds up to the f32 round trip through the inverse.
        let tol = if closed {
            1e-5 * v.abs()
        } else if v == 0.0 {
            1e-7
        } else {
            half_digit
        };
        let (elo, ehi) = (Vec3::from(elo.map(|x| x as f32)), Vec3::from(ehi.map(|x| x as f32)));
        let box_tol = 1e-5 * (ehi - elo).length();
        let got = (nodes.len(), first_node.len(), n_tris);
        if got != (instances, distinct, tris)
            || (vol - v).abs() > tol
            || (lo - elo).abs().max_element() > box_tol
            || (hi - ehi).abs().max_element() > box_tol
        {
            failures.push(format!("{path}: instances/distinct/tris {got:?}, volume {vol}, box {lo} {hi}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
