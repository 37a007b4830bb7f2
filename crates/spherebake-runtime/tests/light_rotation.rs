//! Soft deformation (§7.1): the polar rotation, the per-sphere rotations from the skin terms, and rigid-motion
//! invariance of the two light passes when the rotations are passed (and its failure when they are not).

#![allow(clippy::needless_range_loop)] // matrix index loops

mod common;

use spherebake_runtime::light::{
    light_spheres, polar_rotation, sphere_rotations, ClusterSpec, IndirectCluster, LightContext, Pass1Settings,
    PosedProxy, SphereLights, IDENTITY_ROTATION,
};
use spherebake_runtime::shadow::{eval_sh_f64, uniform_light, ExpMethod};
use spherebake_runtime::{
    pose, AlbedoSh, BoneRecord, Proxy, Samples, SkinEntry, SkinTerms, SphbFile, Sphere, UNUSED_BONE,
};
use std::f64::consts::PI;

use spherebake_testkit::rng::SplitMix64 as Rng;

type M3 = [f64; 9];

/// Column-major product.
fn mul(a: &M3, b: &M3) -> M3 {
    let mut o = [0.0; 9];
    for c in 0..3 {
        for r in 0..3 {
            o[3 * c + r] = (0..3).map(|k| a[3 * k + r] * b[3 * c + k]).sum();
        }
    }
    o
}

fn transpose(a: &M3) -> M3 {
    let mut o = [0.0; 9];
    for c in 0..3 {
        for r in 0..3 {
            o[3 * c + r] = a[3 * r + c];
        }
    }
    o
}

/// Rotation by `angle` about the unit `axis` (Rodrigues), column-major.
fn axis_angle(axis: [f64; 3], angle: f64) -> M3 {
    let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    let [x, y, z] = axis.map(|v| v / n);
    let (s, c) = angle.sin_cos();
    let t = 1.0 - c;
    // Row-major entries, then stored column-major.
    let rm = [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ];
    let mut o = [0.0; 9];
    for r in 0..3 {
        for col in 0..3 {
            o[3 * col + r] = rm[r][col];
        }
    }
    o
}

fn random_rotation(rng: &mut Rng) -> M3 {
    let axis = [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)];
    axis_angle(axis, rng.range(-PI, PI))
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

#[test]
fn polar_rotation_recovers_the_rotation_of_r_times_spd() {
    let mut rng = Rng::new(7);
    for k in 0..200 {
        let r = random_rotation(&mut rng);
        // S = U D Uᵀ, D in [0.2, 5] (condition up to 25).
        let u = random_rotation(&mut rng);
        let d = [rng.range(0.2, 5.0), rng.range(0.2, 5.0), rng.range(0.2, 5.0)];
        let dm = [d[0], 0.0, 0.0, 0.0, d[1], 0.0, 0.0, 0.0, d[2]];
        let s = mul(&mul(&u, &dm), &transpose(&u));
        let m = mul(&r, &s);
        let got = polar_rotation(&m).expect("det > 0");
        assert!(max_diff(&got, &r) < 1e-9, "case {k}: {got:?} vs {r:?}");
        // A rotation is its own polar factor; a uniformly scaled one too.
        let got = polar_rotation(&r.map(|v| 3.0 * v)).unwrap();
        assert!(max_diff(&got, &r) < 1e-9, "case {k}: scaled rotation");
        // Whatever the scale (a hierarchy node's Σ (r_j / r_N)² R_j over tiny leaves is tiny).
        for scale in [1e-75, 1e-8, 1e-3, 1e3, 1e70] {
            let got = polar_rotation(&r.map(|v| scale * v)).expect("det > 0");
            assert!(max_diff(&got, &r) < 1e-9, "case {k}: rotation scaled by {scale}: {got:?}");
        }
    }
    // Reflections (det < 0), singular and non-finite matrices have no rotation.
    let reflect = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0];
    assert!(polar_rotation(&reflect).is_none());
    assert!(polar_rotation(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0]).is_none());
    assert!(polar_rotation(&[f64::NAN; 9]).is_none());
}

fn to_m4(r: &M3, t: [f64; 3]) -> [f32; 16] {
    let mut m = [0.0f32; 16];
    for c in 0..3 {
        for row in 0..3 {
            m[4 * c + row] = r[3 * c + row] as f32;
        }
    }
    m[12] = t[0] as f32;
    m[13] = t[1] as f32;
    m[14] = t[2] as f32;
    m[15] = 1.0;
    m
}

fn identity4() -> [f32; 16] {
    to_m4(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0], [0.0; 3])
}

fn bone(name: &str) -> BoneRecord {
    BoneRecord { name: name.into(), parent: None, inverse_bind: identity4() }
}

use common::surface_samples as samples_of;

/// A skinned proxy: sphere i's slots are `weights[i]` (bone, b) with q = b · c_i (rest joint matrices are the
/// identity, so the rest pose gives c_i back), padded with unused slots; albedo `albedo[i]` (order² coefficients).
fn skinned(spheres: &[Sphere], weights: &[Vec<(u32, f32)>], bones: usize, albedo: &[Vec<[f32; 3]>]) -> Proxy {
    let k = weights.iter().map(Vec::len).max().unwrap();
    let mut entries = Vec::new();
    for (s, w) in spheres.iter().zip(weights) {
        for &(bone, b) in w {
            entries.push(SkinEntry { bone, q: s.center.map(|v| v * b), b });
        }
        for _ in w.len()..k {
            entries.push(SkinEntry { bone: UNUSED_BONE, q: [0.0; 3], b: 0.0 });
        }
    }
    let order = (albedo[0].len() as f64).sqrt() as u8;
    let file = SphbFile {
        spheres: spheres.to_vec(),
        samples: Some(Samples::from_per_sphere(spheres.iter().map(samples_of))),
        albedo_sh: Some(AlbedoSh { order, coefficients: albedo.concat(), ..AlbedoSh::default() }),
        skin: Some(SkinTerms { bones_per_sphere: k as u32, entries }),
        bones: Some((0..bones).map(|b| bone(&format!("b{b}"))).collect()),
        ..SphbFile::default()
    };
    Proxy::from_file(&file).expect("valid proxy")
}

fn grey(n: usize) -> Vec<Vec<[f32; 3]>> {
    (0..n)
        .map(|_| {
            let mut a = vec![[0.0f32; 3]; 4];
            a[0] = [1.0; 3];
            a
        })
        .collect()
}

fn m3_f32(r: &[f32; 9]) -> Vec<f64> {
    r.iter().map(|&v| f64::from(v)).collect()
}

#[test]
fn common_rigid_bone_motion_turns_every_sphere_by_it() {
    let spheres: Vec<Sphere> =
        (0..6).map(|i| Sphere { center: [i as f32 * 0.4 - 1.0, 0.5 + 0.1 * i as f32, 0.2], radius: 0.3 }).collect();
    let weights: Vec<Vec<(u32, f32)>> = vec![
        vec![(0, 1.0)],
        vec![(0, 0.5), (1, 0.5)],
        vec![(1, 0.2), (2, 0.8)],
        vec![(0, 0.3), (1, 0.3), (2, 0.4)],
        vec![(2, 1.0)],
        vec![(1, 0.9), (0, 0.1)],
    ];
    let proxy = skinned(&spheres, &weights, 3, &grey(6));
    let rest = vec![identity4(); 3];
    let mut rng = Rng::new(11);
    for _ in 0..20 {
        let q = random_rotation(&mut rng);
        let t = [rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(-2.0, 2.0)];
        let joints = vec![to_m4(&q, t); 3];
        let mut out = vec![IDENTITY_ROTATION; 6];
        sphere_rotations(&proxy, &joints, &rest, &mut out).unwrap();
        for (i, r) in out.iter().enumerate() {
            assert!(max_diff(&m3_f32(r), &q) < 2e-6, "sphere {i}: {r:?} vs {q:?}");
        }
        // The same motion after a non-trivial rest pose P: joints Q·P, rest P, rotation Q.
        let p = random_rotation(&mut rng);
        let qp = mul(&q, &p);
        let joints = vec![to_m4(&qp, t); 3];
        let rest_p = vec![to_m4(&p, [0.3, -0.2, 0.1]); 3];
        sphere_rotations(&proxy, &joints, &rest_p, &mut out).unwrap();
        for (i, r) in out.iter().enumerate() {
            assert!(max_diff(&m3_f32(r), &q) < 2e-6, "sphere {i}, rest pose P: {r:?} vs {q:?}");
        }
    }
}

#[test]
fn two_bones_about_one_axis_give_the_weighted_mean_angle() {
    // w R(α) + (1 − w) R(β) about one axis is a rotation about it by φ = atan2(w sin α + (1 − w) sin β,
    // w cos α + (1 − w) cos β) times a symmetric positive factor (scale ρ across the axis, 1 along it): its polar
    // rotation is R(φ).
    let spheres = [Sphere { center: [0.0, 1.0, 0.0], radius: 0.5 }, Sphere { center: [1.0, 1.0, 0.0], radius: 0.4 }];
    let axis = [0.3, 1.0, -0.4];
    for (w, alpha, beta) in [(0.5f32, 0.2f64, 1.4f64), (0.25, -0.9, 0.6), (0.8, 2.5, -2.0)] {
        let weights = vec![vec![(0, w), (1, 1.0 - w)], vec![(1, 1.0)]];
        let proxy = skinned(&spheres, &weights, 2, &grey(2));
        let joints = [to_m4(&axis_angle(axis, alpha), [0.0; 3]), to_m4(&axis_angle(axis, beta), [1.0, 0.0, 0.0])];
        let mut out = vec![IDENTITY_ROTATION; 2];
        sphere_rotations(&proxy, &joints, &[identity4(), identity4()], &mut out).unwrap();
        let wf = f64::from(w);
        let phi = (wf * alpha.sin() + (1.0 - wf) * beta.sin()).atan2(wf * alpha.cos() + (1.0 - wf) * beta.cos());
        let want = axis_angle(axis, phi);
        assert!(max_diff(&m3_f32(&out[0]), &want) < 2e-6, "w {w}, α {alpha}, β {beta}: {:?} vs {want:?}", out[0]);
        assert!(max_diff(&m3_f32(&out[1]), &axis_angle(axis, beta)) < 2e-6);
    }
    // No skin: identity for every sphere.
    let plain = Proxy::from_file(&SphbFile { spheres: spheres.to_vec(), ..SphbFile::default() }).unwrap();
    let mut out = [[0.0f32; 9]; 2];
    sphere_rotations(&plain, &[], &[], &mut out).unwrap();
    assert_eq!(out, [IDENTITY_ROTATION; 2]);
}

/// Albedo of a sphere that is red towards +x and green towards −x: a(n) = (0.5 + 0.4 n_x, 0.5 − 0.4 n_x, 0.1), i.e.
/// DC 0.5 √(4π) (0.1 √(4π) in blue) and ±0.4 σ / √(3/(4π)) on y_{1,1} = σ √(3/(4π)) x (index 3; σ = ±1 by the
/// phase convention, read from the basis at +x).
fn red_green() -> Vec<[f32; 3]> {
    let dc = (4.0 * PI).sqrt() as f32;
    let mut y = [0.0f64; 16];
    eval_sh_f64(4, [1.0, 0.0, 0.0], &mut y).unwrap();
    let sigma = y[3].signum();
    assert!((y[3].abs() - (3.0 / (4.0 * PI)).sqrt()).abs() < 1e-12);
    let k = (0.4 * sigma / (3.0 / (4.0 * PI)).sqrt()) as f32;
    let mut a = vec![[0.0f32; 3]; 16];
    a[0] = [0.5 * dc, 0.5 * dc, 0.1 * dc];
    a[3] = [k, -k, 0.0];
    a
}

/// Pass 1 under a uniform full-sphere environment (rotation invariant) and pass 2 at `receivers`, for the proxy
/// posed by one bone with joint matrix `joint` (rest: identity); `rotations` passes `sphere_rotations` or not.
fn lit(proxy: &Proxy, joint: [f32; 16], rotations: bool, receivers: &[([f32; 3], [f32; 3])]) -> Vec<[f64; 3]> {
    let ctx = LightContext::new(4, ExpMethod::default()).unwrap();
    let mut env = vec![0.0; 16];
    uniform_light(4, &mut env);
    let mut leaves = proxy.spheres().to_vec();
    pose(proxy, &[joint], &mut leaves).unwrap();
    let mut rot = vec![IDENTITY_ROTATION; proxy.sphere_count()];
    sphere_rotations(proxy, &[joint], &[identity4()], &mut rot).unwrap();
    let posed = PosedProxy { leaves: &leaves, rotations: rotations.then_some(&rot[..]), ..PosedProxy::at_rest(proxy) };
    let mut lights = SphereLights::new();
    light_spheres(&ctx, &posed, &env, &[], &Pass1Settings::default(), &mut lights).unwrap();
    let sources = [(posed, &lights)];
    let mut cl = IndirectCluster::new();
    let mut counts = [0usize; 4];
    let out = receivers
        .iter()
        .map(|&(p, n)| {
            // Default θmax: the far receivers see the implicit root (its rotation: polar of Σ r² R_i).
            cl.build(&ctx, &sources, &ClusterSpec::new(p, 0.0, Some(n))).unwrap();
            counts[cl.light_count().min(3)] += 1;
            cl.irradiance(&ctx, &sources, p, n).unwrap()
        })
        .collect();
    assert!(counts[1] > 0 && counts[3] > 0, "both the root and the leaves are used: {counts:?}");
    out
}

#[test]
fn rigidly_rotated_proxy_gives_the_rotated_answer_only_with_the_rotations() {
    let spheres = [
        Sphere { center: [0.0, 0.0, 0.0], radius: 1.0 },
        Sphere { center: [1.6, 0.3, -0.2], radius: 0.5 },
        Sphere { center: [-0.4, 1.3, 0.5], radius: 0.4 },
    ];
    let weights = vec![vec![(0, 1.0)]; 3];
    let albedo = vec![red_green(); 3];
    let proxy = skinned(&spheres, &weights, 1, &albedo);
    for (dir, want) in [([1.0f32, 0.0, 0.0], [0.9f32, 0.1, 0.1]), ([-1.0, 0.0, 0.0], [0.1, 0.9, 0.1])] {
        let got = proxy.albedo(0, dir).unwrap();
        assert!((0..3).all(|c| (got[c] - want[c]).abs() < 1e-5), "albedo towards {dir:?}: {got:?}");
    }
    // Receivers around the group, normals facing its centre (tilted by 0.3 rad), near (leaves) and far (the root).
    let mut receivers = Vec::new();
    for k in 0..24 {
        let a = k as f64 * 0.7;
        let e = (k as f64 * 0.37).sin() * 1.2;
        let dist = if k % 3 == 0 { 14.0 } else { 3.0 + 0.1 * k as f64 };
        let dir = [e.cos() * a.cos(), e.sin(), e.cos() * a.sin()];
        let p = dir.map(|v| v * dist);
        let tilt = [(a + 1.0).cos() * 0.3, 0.0, (a + 1.0).sin() * 0.3];
        let n = [-dir[0] + tilt[0], -dir[1] + tilt[1], -dir[2] + tilt[2]];
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        receivers.push((p.map(|v| v as f32), n.map(|v| (v / l) as f32)));
    }
    let rest = lit(&proxy, identity4(), true, &receivers);
    assert!(rest.iter().all(|e| e[0] > 0.0 && e[1] > 0.0), "every receiver is lit");
    // The red side (+x) lights the receivers at +x redder.
    for (e, (p, _)) in rest.iter().zip(&receivers) {
        if p[0] > 2.5 {
            assert!(e[0] > e[1], "receiver at {p:?}: {e:?}");
        } else if p[0] < -2.5 {
            assert!(e[0] < e[1], "receiver at {p:?}: {e:?}");
        }
    }
    let mut rng = Rng::new(5);
    for case in 0..4 {
        let q = if case == 0 { axis_angle([0.0, 1.0, 0.0], PI) } else { random_rotation(&mut rng) };
        let t = [rng.range(-3.0, 3.0), rng.range(-1.0, 1.0), rng.range(-3.0, 3.0)];
        let joint = to_m4(&q, t);
        let moved: Vec<([f32; 3], [f32; 3])> = receivers
            .iter()
            .map(|(p, n)| {
                let p = p.map(f64::from);
                let n = n.map(f64::from);
                let rp = [0, 1, 2].map(|r| (0..3).map(|c| q[3 * c + r] * p[c]).sum::<f64>() + t[r]);
                let rn = [0, 1, 2].map(|r| (0..3).map(|c| q[3 * c + r] * n[c]).sum::<f64>());
                (rp.map(|v| v as f32), rn.map(|v| v as f32))
            })
            .collect();
        let with = lit(&proxy, joint, true, &moved);
        let without = lit(&proxy, joint, false, &moved);
        let (mut worst_with, mut worst_without) = (0.0f64, 0.0f64);
        for k in 0..receivers.len() {
            let scale = rest[k].iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for c in 0..3 {
                worst_with = worst_with.max((with[k][c] - rest[k][c]).abs() / scale);
                worst_without = worst_without.max((without[k][c] - rest[k][c]).abs() / scale);
            }
        }
        println!("rotation {case}: worst relative change {worst_with:.2e} with rotations, {worst_without:.3} without");
        // f32 geometry (posed centres, receivers, rotations rounded to f32; f32 asin / rsqrt) moves values by ~1e-6.
        assert!(worst_with < 5e-5, "rotation {case}: {worst_with}");
        assert!(
            worst_without > 0.05,
            "rotation {case}: without the rotations the colours must stay put: {worst_without}"
        );
    }
}
