//! Posing imported skins with `spherebake_geom::anim`: the rest pose reproduces the imported
//! positions, the fixture arm bends as its analytic joint chain says, and a CesiumMan vertex at
//! t = 0.5 s matches the independent oracle `/work/shared/tools/gltf_pose.py`.

use std::path::{Path, PathBuf};

use spherebake_geom::anim::{joint_matrices, sample_local, skin_vertices, world_matrices};
use spherebake_geom::glam::Vec3;
use spherebake_geom::Mesh;
use spherebake_io::load_mesh;
use spherebake_testkit::shared_models_dir;

fn fixture(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures").join(p)
}

fn pose(mesh: &Mesh, anim: Option<usize>, t: f32) -> Vec<Vec3> {
    let skin = mesh.skin.as_ref().expect("skinned");
    let w = world_matrices(&skin.skeleton, &sample_local(&skin.skeleton, anim, t));
    skin_vertices(skin, &joint_matrices(&skin.skeleton, &w))
}

fn max_dist(a: &[Vec3], b: &[Vec3]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| x.distance(*y)).fold(0.0, f32::max)
}

#[test]
fn rest_pose_reproduces_imported_positions() {
    let mut paths = vec![fixture("skinned-arm.gltf")];
    if let Some(d) = shared_models_dir() {
        for m in ["CesiumMan.glb", "Fox.glb", "RiggedFigure.glb", "RiggedSimple.glb"] {
            paths.push(d.join("gltf").join(m));
        }
    }
    for p in paths {
        let imp = load_mesh(&p).unwrap();
        let (lo, hi) = imp.mesh.bounds().unwrap();
        let d = max_dist(&pose(&imp.mesh, None, 0.0), &imp.mesh.positions);
        assert!(d <= 1e-5 * (hi - lo).length(), "{}: {d}", p.display());
    }
}

#[test]
fn arm_fixture_bends_at_the_elbow() {
    let imp = load_mesh(&fixture("skinned-arm.gltf")).unwrap();
    let m = &imp.mesh;
    let skin = m.skin.as_ref().unwrap();
    let names: Vec<&str> = skin.skeleton.bones.iter().map(|b| b.name.as_str()).collect();
    assert_eq!(names, ["shoulder", "elbow", "wrist"]);
    assert_eq!(skin.skeleton.bones.iter().map(|b| b.parent).collect::<Vec<_>>(), [None, Some(0), Some(1)]);
    // Data URI buffer: the .gltf is the only input.
    assert_eq!(imp.inputs.len(), 1);
    // Closed 12-gon prism, r = 0.25, h = 2: volume (12/2)·r²·sin 30°·h = 3·r²·h = 0.375.
    let r = spherebake_geom::topology::TopologyReport::compute(m);
    assert!(r.closed && r.consistently_oriented && (r.signed_volume - 0.375).abs() < 1e-6, "{r:?}");
    assert_eq!((r.triangle_count, r.welded_vertex_count), (216, 110));
    let find = |p: Vec3| m.positions.iter().position(|q| q.distance(p) < 1e-6).unwrap();
    let top = find(Vec3::new(0.0, 2.0, 0.0));
    let bottom = find(Vec3::new(0.0, 0.0, 0.0));
    let mid = find(Vec3::new(0.25, 1.0, 0.0)); // ring at y = 1: half shoulder, half elbow
    for (t, angle) in [
        (0.5f32, std::f32::consts::FRAC_PI_4),
        (1.0, std::f32::consts::FRAC_PI_2),
        (0.75, 3.0 * std::f32::consts::PI / 8.0),
    ] {
        let posed = pose(m, Some(0), t);
        let (s, c) = angle.sin_cos();
        // Wrist-weighted top centre: elbow (0,1,0) + R_z(angle)·(0,1,0).
        assert!(posed[top].distance(Vec3::new(-s, 1.0 + c, 0.0)) < 1e-5, "t={t}: {}", posed[top]);
        assert!(posed[bottom].distance(Vec3::ZERO) < 1e-6);
        // Half of the unmoved (0.25, 1, 0) plus half of elbow + R_z(angle)·(0.25, 0, 0).
        let e = 0.5 * Vec3::new(0.25, 1.0, 0.0) + 0.5 * Vec3::new(0.25 * c, 1.0 + 0.25 * s, 0.0);
        assert!(posed[mid].distance(e) < 1e-5, "t={t}: {} vs {e}", posed[mid]);
    }
}

#[test]
fn cesium_man_posed_vertices_match_gltf_pose_oracle() {
    let Some(d) = shared_models_dir() else { return };
    let imp = load_mesh(&d.join("gltf/CesiumMan.glb")).unwrap();
    // From `python /work/shared/tools/gltf_pose.py CesiumMan.glb --rest rest.json` and
    // `--pose pose.json --animation 0 --time 0.5` (numpy 2, run by hand), welded vertices
    // 0, 777, 1500, 2337: (rest position, posed position at t = 0.5 s).
    #[rustfmt::skip]
    let oracle: [([f64; 3], [f64; 3]); 4] = [
        ([0.04871460692537013, 0.9735750005071151, 0.09342923756800152],
         [0.016523175458197807, 0.9621821335949237, 0.10445386059807046]),
        ([-0.09886042560480615, 1.4147202969013608, -0.13100002653305898],
         [-0.1053106168064336, 1.422200534971282, -0.07788196907204081]),
        ([0.3187938591663613, 0.9927793954616727, 0.008170651847602855],
         [0.11293504452100955, 0.8690670193667905, -0.09609190151393007]),
        ([0.09140806587466098, -1.1144094051610613e-07, 0.1463500025626635],
         [0.08282914229008546, 0.11169552817611372, 0.07023370621716596]),
    ];
    let posed = pose(&imp.mesh, Some(0), 0.5);
    for (rest, want) in oracle {
        let rest = Vec3::from(rest.map(|x| x as f32));
        let v = imp.mesh.positions.iter().position(|p| p.distance(rest) < 1e-6).expect("rest vertex found");
        let want = Vec3::from(want.map(|x| x as f32));
        assert!(posed[v].distance(want) < 2e-6, "vertex {v}: {} vs {want}", posed[v]);
    }
}
