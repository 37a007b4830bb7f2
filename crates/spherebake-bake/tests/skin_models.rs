//! Skinning stage on the real models of `../shared/models` (skips with a message when absent):
//! `--pose-margin auto` keeps every vertex of the model's own animations covered at every time
//! (checked by brute force on every mesh vertex, skinned by `anim::skin_vertices`, at the keys
//! and at 199 times between per animation), models without skin give no skin section, the
//! remainder never has to be dropped.

use glam::{DMat4, DVec3, Mat4, Vec3};
use spherebake_bake::skin::{animation_joint_matrices, pose_centre};
use spherebake_bake::{bake_skin, grow_for_animations, PoseMargin, SkinSettings};
use spherebake_geom::{anim, Mesh};

fn model(name: &str) -> Option<Mesh> {
    let p = spherebake_testkit::shared_model(&format!("gltf/{name}"))?;
    Some(spherebake_io::load_mesh(&p).expect("model loads").mesh)
}

/// Spheres at every 7th welded vertex pulled 10% towards the centroid, radius 6% of the diagonal:
/// not bounding, so the margin has work to do.
fn spheres(m: &Mesh) -> Vec<[f32; 4]> {
    let w = &m.welded_positions;
    let c = w.iter().copied().sum::<Vec3>() / w.len() as f32;
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in w {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let r = (hi - lo).length() * 0.06;
    w.iter().step_by(7).map(|p| *p + (c - *p) * 0.1).map(|p| [p.x, p.y, p.z, r]).collect()
}

#[test]
fn pose_margin_covers_every_animation_time() {
    for name in ["CesiumMan.glb", "Fox.glb"] {
        let Some(m) = model(name) else { return };
        let s = spheres(&m);
        let settings = SkinSettings { bones_per_sphere: 4, pose_margin: PoseMargin::Auto, ..Default::default() };
        let (terms, bones, stats) = bake_skin(&m, &s, &settings).unwrap().unwrap();
        assert_eq!(bones.len(), m.skin.as_ref().unwrap().skeleton.bones.len());
        assert_eq!(stats.remainder_dropped, 0);
        assert!(stats.closed);
        let r = grow_for_animations(&m, &s, &terms, &settings).unwrap();
        assert!(r.coverage_min_before < 1.0 && r.grown_count > 0, "{name}: the margin had work to do");
        assert!(r.capped_animations == 0 && r.unbounded_frames == 0, "{name}: {r:?}");
        let sk = m.skin.as_ref().unwrap();
        let mut frames = vec![(None, 0.0f32)];
        for (a, an) in sk.skeleton.animations.iter().enumerate() {
            let mut keys: Vec<f32> = an.channels.iter().flat_map(|c| c.times.clone()).collect();
            let t0 = keys.iter().copied().fold(f32::INFINITY, f32::min);
            let t1 = keys.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            keys.sort_by(f32::total_cmp);
            keys.dedup();
            frames.extend(keys.into_iter().map(|t| (Some(a), t)));
            frames.extend((0..199).map(|i| (Some(a), t0 + (t1 - t0) * (i as f32 + 0.381_966) / 199.0)));
        }
        for (a, t) in frames {
            let j = animation_joint_matrices(&sk.skeleton, a, t);
            let jd: Vec<DMat4> = j.iter().map(Mat4::as_dmat4).collect();
            let centres: Vec<DVec3> = (0..s.len()).map(|i| pose_centre(terms.of(i), &jd)).collect();
            for v in anim::skin_vertices(sk, &j) {
                let v = v.as_dvec3();
                let ok = centres.iter().zip(&r.spheres).any(|(c, sp)| c.distance(v) <= f64::from(sp[3]));
                assert!(ok, "{name} animation {a:?} t={t}: vertex {v} uncovered");
            }
        }
        eprintln!(
            "{name}: coverage before {:.4}, grown {} of {}, E {:?} -> {:?}",
            r.coverage_min_before,
            r.grown_count,
            s.len(),
            r.outside_ratio_before,
            r.outside_ratio_after
        );
    }
}

#[test]
fn static_models_have_no_skin_section() {
    let Some(m) = model("Duck.glb") else { return };
    assert!(bake_skin(&m, &spheres(&m), &SkinSettings::default()).unwrap().is_none());
}
