//! Measures the skinning stage on the skinned models of `../shared/models` (every animation,
//! 30 evenly spaced times each, plus the rest pose):
//! - centre error of the k = 4 truncation against all bones kept (mean / max, relative to the
//!   bounding-box diagonal);
//! - the share of skinned (welded) vertices inside the union of posed spheres, min over frames;
//! - `--pose-margin auto`: spheres grown, largest growth, and outside-volume ratio E before/after
//!   (on stderr: the margin's frames and its largest motion bound between them).
//!
//! Spheres: `spherebake_fit::fit` with default settings and `SPHERES` spheres (env, default 64).
//! Run: `cargo run --release -p spherebake-bake --example skin_measure`.

use glam::{DMat4, Mat4};
use spherebake_bake::skin::{
    animation_frames, animation_joint_matrices, pose_centre, posed_welded_vertices, union_coverage,
};
use spherebake_bake::{bake_skin, grow_for_animations, PoseMargin, SkinSettings};
use std::path::Path;

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/models/gltf");
    if !root.exists() {
        eprintln!("../shared/models not found; nothing to measure");
        return;
    }
    let n_spheres: usize = std::env::var("SPHERES").ok().and_then(|v| v.parse().ok()).unwrap_or(64);
    println!(
        "| model | bones | anims | frames | spheres | k=4 err mean | k=4 err max | dropped |b| max | coverage min (k=4) | coverage min (all) | grown | max growth (÷diag) | E before | E after | residual max |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for name in ["RiggedSimple.glb", "RiggedFigure.glb", "CesiumMan.glb", "Fox.glb"] {
        let path = root.join(name);
        let mesh = spherebake_io::load_mesh(&path).expect("model loads").mesh;
        let t0 = std::time::Instant::now();
        let fit = spherebake_fit::fit(
            &mesh.welded_positions,
            &mesh.welded_triangles(),
            &spherebake_fit::FitSettings { spheres: n_spheres, ..Default::default() },
            &|_| {},
        )
        .expect("fit");
        let fit_s = t0.elapsed().as_secs_f64();
        let spheres = fit.spheres.clone();
        let skel = &mesh.skin.as_ref().expect("skinned").skeleton;
        let bones = skel.bones.len();
        let s4 = SkinSettings { bones_per_sphere: 4, pose_margin: PoseMargin::Auto, ..Default::default() };
        let (t4, _, st4) = bake_skin(&mesh, &spheres, &s4).unwrap().unwrap();
        let (tall, _, _) = bake_skin(&mesh, &spheres, &SkinSettings { bones_per_sphere: bones, ..Default::default() })
            .unwrap()
            .unwrap();
        let mut frames: Vec<(Option<usize>, f32)> = vec![(None, 0.0)];
        frames.extend(animation_frames(skel, 30).into_iter().map(|(a, t)| (Some(a), t)));
        let diag = {
            let (mut lo, mut hi) = (glam::Vec3::splat(f32::INFINITY), glam::Vec3::splat(f32::NEG_INFINITY));
            for p in &mesh.welded_positions {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
            f64::from((hi - lo).length())
        };
        let (mut err_sum, mut err_max, mut err_n) = (0.0, 0.0f64, 0usize);
        // Centre-LBS with the same k = 4 (math reference §7 P'_k): Σ_K b̃_j D_j c, D_j = M_j(t) M_j(rest)⁻¹.
        let rest = spherebake_bake::skin::rest_joint_matrices(skel);
        let (mut lbs_sum, mut lbs_max) = (0.0, 0.0f64);
        let (mut cov4, mut cov_all) = (1.0f64, 1.0f64);
        for &(a, t) in &frames {
            let j = animation_joint_matrices(skel, a, t);
            let jd: Vec<DMat4> = j.iter().map(Mat4::as_dmat4).collect();
            let verts = posed_welded_vertices(&mesh, &j).unwrap();
            let mut b4 = Vec::new();
            let mut ball = Vec::new();
            for (i, s) in spheres.iter().enumerate() {
                let c4 = pose_centre(t4.of(i), &jd);
                let ca = pose_centre(tall.of(i), &jd);
                let e = (c4 - ca).length() / diag;
                err_sum += e;
                err_max = err_max.max(e);
                err_n += 1;
                let mut slots: Vec<_> =
                    tall.of(i).iter().filter(|e| e.bone != spherebake_format::UNUSED_BONE).collect();
                slots.sort_by(|a, b| b.b.abs().total_cmp(&a.b.abs()).then(a.bone.cmp(&b.bone)));
                slots.truncate(4);
                let bsum: f64 = slots.iter().map(|e| f64::from(e.b)).sum();
                let c = glam::DVec3::new(s[0].into(), s[1].into(), s[2].into());
                let lbs: glam::DVec3 = slots
                    .iter()
                    .map(|e| {
                        let j = e.bone as usize;
                        (jd[j] * rest[j].inverse()).transform_point3(c) * (f64::from(e.b) / bsum)
                    })
                    .sum();
                let el = (lbs - ca).length() / diag;
                lbs_sum += el;
                lbs_max = lbs_max.max(el);
                b4.push([c4.x, c4.y, c4.z, f64::from(s[3])]);
                ball.push([ca.x, ca.y, ca.z, f64::from(s[3])]);
            }
            cov4 = cov4.min(union_coverage(&verts, &b4));
            cov_all = cov_all.min(union_coverage(&verts, &ball));
        }
        let t1 = std::time::Instant::now();
        let m = grow_for_animations(&mesh, &spheres, &t4, &s4).unwrap();
        let margin_s = t1.elapsed().as_secs_f64();
        if let Ok(dir) = std::env::var("DUMP") {
            // For the oracle cross-check: the spheres (rest scene space) and an all-bones .sphb.
            let stem = name.trim_end_matches(".glb");
            let pts: Vec<String> = spheres
                .iter()
                .map(|s| format!("{{\"center\": [{:?}, {:?}, {:?}], \"radius\": {:?}}}", s[0], s[1], s[2], s[3]))
                .collect();
            let dir = Path::new(&dir);
            std::fs::write(dir.join(format!("{stem}.points.json")), format!("{{\"spheres\": [{}]}}", pts.join(", ")))
                .unwrap();
            let (_, bone_table, _) =
                bake_skin(&mesh, &spheres, &SkinSettings { bones_per_sphere: bones, ..Default::default() })
                    .unwrap()
                    .unwrap();
            let file = spherebake_format::SphbFile {
                spheres: spheres
                    .iter()
                    .map(|s| spherebake_format::Sphere {
                        center: [s[0], s[1], s[2]],
                        radius: s[3].max(f32::MIN_POSITIVE),
                    })
                    .collect(),
                skin: Some(tall.clone()),
                bones: Some(bone_table),
                ..Default::default()
            };
            std::fs::write(dir.join(format!("{stem}.sphb")), spherebake_format::write(&file)).unwrap();
        }
        println!(
            "| {name} | {bones} | {} | {} | {} | {:.2e} | {:.2e} | {:.3} | {:.4} | {:.4} | {} | {:.2e} | {:.4} | {:.4} | {:.1e} |",
            skel.animations.len(),
            frames.len(),
            spheres.len(),
            err_sum / err_n as f64,
            err_max,
            st4.dropped_weight_max,
            cov4,
            cov_all,
            m.grown_count,
            m.max_growth_relative,
            m.outside_ratio_before.unwrap_or(f64::NAN),
            m.outside_ratio_after.unwrap_or(f64::NAN),
            st4.linear_residual_max_relative,
        );
        eprintln!(
            "  {name}: fit {fit_s:.1} s, skin bake {:.3} s, closed {}, on-surface centres {}, remainder dropped {}; centre-LBS k=4 error mean {:.2e} max {:.2e} (÷diag); margin {:.3} s, {} frames, motion bound ≤ {:.2e} (÷diag)",
            st4.seconds, st4.closed, st4.centres_on_surface, st4.remainder_dropped, lbs_sum / err_n as f64, lbs_max,
            margin_s, m.frames, m.motion_bound_max_relative
        );
    }
}
