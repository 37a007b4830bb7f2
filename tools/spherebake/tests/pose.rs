//! Posing end to end: skin terms baked by `spherebake_bake::bake_skin`, stored in a `.sphb`,
//! loaded and posed by the runtime crate (f32), against MVC of the linear-blend-skinned mesh
//! (`anim::skin_vertices`, f64). Then the `spherebake pose` command. Tests that use
//! `../shared/models` say so and skip when it is absent.

use spherebake_bake::{bake_skin, SkinSettings};
use spherebake_format::{SphbFile, Sphere};
use spherebake_geom::glam::{DMat4, DQuat, DVec3, Mat4, Quat, Vec3};
use spherebake_geom::{anim, mvc, Mesh};
use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn diag(m: &Mesh) -> f64 {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in &m.welded_positions {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    f64::from((hi - lo).length())
}

/// Sphere centres: means of random welded-vertex triples (inside, outside or on the surface:
/// MVC is defined everywhere on a closed mesh), radius 1% of the diagonal.
fn centres(m: &Mesh, n: usize) -> Vec<[f32; 4]> {
    let mut rng = Rng(7);
    let w = &m.welded_positions;
    let r = (diag(m) * 0.01) as f32;
    (0..n)
        .map(|_| {
            let mut c = Vec3::ZERO;
            for _ in 0..3 {
                c += w[((rng.next() * w.len() as f64) as usize).min(w.len() - 1)];
            }
            let c = c / 3.0;
            [c.x, c.y, c.z, r]
        })
        .collect()
}

fn proxy(m: &Mesh, s: &[[f32; 4]], k: usize) -> spherebake_runtime::Proxy {
    let (terms, bones, _) =
        bake_skin(m, s, &SkinSettings { bones_per_sphere: k, ..Default::default() }).unwrap().unwrap();
    let file = SphbFile {
        spheres: s.iter().map(|v| Sphere { center: [v[0], v[1], v[2]], radius: v[3] }).collect(),
        skin: Some(terms),
        bones: Some(bones),
        ..SphbFile::default()
    };
    spherebake_runtime::load(&spherebake_format::write(&file)).expect("valid file")
}

fn random_pose(m: &Mesh, rng: &mut Rng, scale: f32) -> Vec<Mat4> {
    let skel = &m.skin.as_ref().unwrap().skeleton;
    let mut locals = anim::sample_local(skel, None, 0.0);
    for l in &mut locals {
        let axis = Vec3::new(rng.next() as f32 - 0.5, rng.next() as f32 - 0.5, rng.next() as f32 - 0.5).normalize();
        l.1 = Quat::from_axis_angle(axis, (rng.next() * 0.8) as f32) * l.1;
        l.0 += Vec3::new(rng.next() as f32 - 0.5, rng.next() as f32 - 0.5, rng.next() as f32 - 0.5) * scale;
    }
    anim::joint_matrices(skel, &anim::world_matrices(skel, &locals))
}

fn pose(p: &spherebake_runtime::Proxy, joints: &[Mat4]) -> Vec<DVec3> {
    let cols: Vec<[f32; 16]> = joints.iter().map(|m| m.to_cols_array()).collect();
    let mut out = vec![Sphere::default(); p.sphere_count()];
    spherebake_runtime::pose(p, &cols, &mut out).unwrap();
    out.iter().map(|s| Vec3::from(s.center).as_dvec3()).collect()
}

/// The three properties of the issue on one model.
fn check_model(m: &Mesh, n: usize, poses: usize) {
    let d = diag(m);
    let s = centres(m, n);
    let bones = m.skin.as_ref().unwrap().skeleton.bones.len();
    let all = proxy(m, &s, bones.min(64));
    let k4 = proxy(m, &s, 4);
    let skel = &m.skin.as_ref().unwrap().skeleton;
    let rest = anim::joint_matrices(skel, &anim::world_matrices(skel, &anim::sample_local(skel, None, 0.0)));
    // 1. Bind (rest) pose reproduces the rest centres.
    for p in [&all, &k4] {
        for (c, e) in pose(p, &rest).iter().zip(&s) {
            let e = DVec3::new(e[0].into(), e[1].into(), e[2].into());
            assert!((*c - e).length() <= 1e-6 * d, "rest: {c} vs {e} (diag {d})");
        }
    }
    // 2. A rigid transform of all joints moves the centres rigidly.
    let g = DMat4::from_rotation_translation(
        DQuat::from_axis_angle(DVec3::new(-0.4, 1.0, 0.3).normalize(), 0.9),
        DVec3::new(0.3, -0.2, 0.5) * d,
    );
    let moved: Vec<Mat4> = rest.iter().map(|j| (g * j.as_dmat4()).as_mat4()).collect();
    for p in [&all, &k4] {
        for (c, e) in pose(p, &moved).iter().zip(&s) {
            let e = g.transform_point3(DVec3::new(e[0].into(), e[1].into(), e[2].into()));
            assert!((*c - e).length() <= 1e-6 * d, "rigid: {c} vs {e}");
        }
    }
    // 3. All bones kept: posed centre = MVC (welded rest mesh) applied to the skinned vertices.
    let wp: Vec<DVec3> = m.welded_positions.iter().map(|p| p.as_dvec3()).collect();
    let wt = m.welded_triangles();
    let mut rep = vec![0usize; wp.len()];
    for (v, &w) in m.weld.iter().enumerate().rev() {
        rep[w as usize] = v;
    }
    let lambdas: Vec<Vec<f64>> = s
        .iter()
        .map(|c| {
            mvc::mean_value_coordinates(DVec3::new(c[0].into(), c[1].into(), c[2].into()), &wp, &wt).unwrap().weights
        })
        .collect();
    let mut rng = Rng(99);
    let mut worst = 0.0f64;
    for _ in 0..poses {
        let joints = random_pose(m, &mut rng, (0.1 * d) as f32);
        let skinned = anim::skin_vertices(m.skin.as_ref().unwrap(), &joints);
        for (c, l) in pose(&all, &joints).iter().zip(&lambdas) {
            let e: DVec3 = l.iter().enumerate().map(|(w, x)| skinned[rep[w]].as_dvec3() * *x).sum();
            worst = worst.max((*c - e).length() / d);
        }
    }
    eprintln!("all bones vs MVC of skinned vertices: max error {worst:.3e} × diagonal");
    assert!(worst <= 1e-6, "{worst}");
}

fn load(p: &Path) -> Mesh {
    spherebake_io::load_mesh(p).unwrap().mesh
}

#[test]
fn fixture_arm() {
    check_model(&load(&repo().join("fixtures/skinned-arm.gltf")), 40, 10);
}

#[test]
fn shared_skinned_models() {
    for name in ["RiggedSimple.glb", "RiggedFigure.glb", "CesiumMan.glb", "Fox.glb"] {
        let Some(p) = spherebake_testkit::shared_model(&format!("gltf/{name}")) else { return };
        eprintln!("{name}");
        check_model(&load(&p), 48, 5);
    }
}

// ---- the CLI ----

fn write_sphb(dir: &Path, m: &Mesh, s: &[[f32; 4]], k: usize) -> PathBuf {
    let p = proxy(m, s, k);
    let out = dir.join("arm.sphb");
    std::fs::write(&out, p.to_bytes()).unwrap();
    out
}

#[test]
fn cli_pose_json_matches_mvc_of_the_skinned_arm() {
    let dir = tempfile::tempdir().unwrap();
    let model = repo().join("fixtures/skinned-arm.gltf");
    let m = load(&model);
    let s = centres(&m, 12);
    let file = write_sphb(dir.path(), &m, &s, 64);
    let o = Command::new(env!("CARGO_BIN_EXE_spherebake"))
        .args(["pose", file.to_str().unwrap(), "--model", model.to_str().unwrap(), "--animation", "bend"])
        .args(["--time", "0.75", "--json"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let spheres = doc["spheres"].as_array().unwrap();
    assert_eq!(spheres.len(), s.len());
    // Independent: sample the animation, skin, apply MVC.
    let skel = &m.skin.as_ref().unwrap().skeleton;
    let joints = anim::joint_matrices(skel, &anim::world_matrices(skel, &anim::sample_local(skel, Some(0), 0.75)));
    let skinned = anim::skin_vertices(m.skin.as_ref().unwrap(), &joints);
    let wp: Vec<DVec3> = m.welded_positions.iter().map(|p| p.as_dvec3()).collect();
    let mut rep = vec![0usize; wp.len()];
    for (v, &w) in m.weld.iter().enumerate().rev() {
        rep[w as usize] = v;
    }
    let d = diag(&m);
    let mut balls = Vec::new();
    for (js, c) in spheres.iter().zip(&s) {
        let l =
            mvc::mean_value_coordinates(DVec3::new(c[0].into(), c[1].into(), c[2].into()), &wp, &m.welded_triangles())
                .unwrap()
                .weights;
        let e: DVec3 = l.iter().enumerate().map(|(w, x)| skinned[rep[w]].as_dvec3() * *x).sum();
        let got: Vec<f64> = js["center"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        assert!((DVec3::from_slice(&got) - e).length() <= 1e-6 * d);
        assert_eq!(js["radius"].as_f64().unwrap(), f64::from(c[3]));
        balls.push((e, f64::from(c[3])));
    }
    // Coverage: share of the posed welded vertices inside the union (tiny spheres: few).
    let inside = rep
        .iter()
        .filter(|&&v| {
            let p = skinned[v].as_dvec3();
            balls.iter().any(|(c, r)| p.distance(*c) <= *r)
        })
        .count();
    let expected = inside as f64 / rep.len() as f64;
    assert!((doc["coverage"].as_f64().unwrap() - expected).abs() < 1e-9 + 1.0 / rep.len() as f64 * 0.5);
    assert_eq!(doc["animation"], "bend");
}

#[test]
fn cli_pose_text_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    let model = repo().join("fixtures/skinned-arm.gltf");
    let m = load(&model);
    // One big sphere around everything: coverage 1 in every pose.
    let file = write_sphb(dir.path(), &m, &[[0.0, 1.0, 0.0, 3.0]], 4);
    let run = |extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_spherebake"))
            .args(["pose", file.to_str().unwrap(), "--model", model.to_str().unwrap()])
            .args(extra)
            .output()
            .unwrap()
    };
    let o = run(&["--time", "1"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("animation \"bend\""), "{text}");
    assert!(text.contains("coverage  1.000000"), "{text}");
    let o = run(&["--time", "1", "--animation", "wave"]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("wave") && err.contains("skinned-arm.gltf"), "{err}");
    let o = run(&["--animation", "bend"]);
    assert_eq!(o.status.code(), Some(2), "missing --time is a usage error");
}
