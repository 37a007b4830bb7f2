//! Generalized winding number: exact values and fast-vs-exact accuracy.

mod voxel_support;

use glam::{DVec3, Vec3};
use spherebake_geom::winding::WindingNumber;
use spherebake_testkit::shared_model;
use voxel_support::{cuboid, icosphere, load_obj, Rng};

#[test]
fn cube_inside_is_one_outside_zero() {
    let (v, f) = cuboid(Vec3::ZERO, Vec3::ONE);
    let w = WindingNumber::new(&v, &f);
    let mut rng = Rng::new(3);
    for _ in 0..200 {
        let p = rng.dvec3(0.01, 0.99);
        assert!((w.eval_exact(p) - 1.0).abs() < 1e-12, "{p}");
        assert!((w.eval(p) - 1.0).abs() < 1e-12, "{p}"); // 12 triangles: always exact
        let q = rng.dvec3(1.01, 3.0) * if rng.f64() < 0.5 { 1.0 } else { -1.0 };
        assert!(w.eval_exact(q).abs() < 1e-12, "{q}");
    }
    // Invalid triangles (index out of range, NaN corner) are ignored.
    let mut bad_v = v.clone();
    bad_v.push(Vec3::new(f32::NAN, 0.0, 0.0));
    let mut bad_f = f.clone();
    bad_f.push([0, 1, 99]);
    bad_f.push([0, 1, 8]);
    let wb = WindingNumber::new(&bad_v, &bad_f);
    for p in [DVec3::splat(0.5), DVec3::splat(2.0), DVec3::ZERO] {
        assert_eq!(wb.eval_exact(p), w.eval_exact(p));
        assert_eq!(wb.eval(p), w.eval(p));
    }
    assert_eq!(WindingNumber::new(&[], &[]).eval(DVec3::ZERO), 0.0);
    // Reversed faces: −1 inside.
    let flipped: Vec<[u32; 3]> = f.iter().map(|t| [t[0], t[2], t[1]]).collect();
    let wf = WindingNumber::new(&v, &flipped);
    assert!((wf.eval_exact(DVec3::splat(0.5)) + 1.0).abs() < 1e-12);
}

#[test]
fn open_hemisphere_has_fractional_values() {
    // Remove the lower half of an icosphere: at the centre the remaining cap covers about half
    // of the sphere of directions, w ≈ 0.5 (exact fraction = enclosed solid angle / 4π).
    let (v, f) = icosphere(3, Vec3::ZERO, 1.0);
    let upper: Vec<[u32; 3]> =
        f.iter().copied().filter(|t| t.iter().map(|&i| v[i as usize].z).sum::<f32>() > 0.0).collect();
    let w = WindingNumber::new(&v, &upper);
    let c = w.eval_exact(DVec3::ZERO);
    assert!((c - 0.5).abs() < 0.05, "{c}");
    assert!((w.eval(DVec3::ZERO) - c).abs() < 5e-3);
    // Far away: ~0.
    assert!(w.eval_exact(DVec3::new(0.0, 0.0, 50.0)).abs() < 1e-3);
}

/// Max |fast − exact| over points inside, outside and near the surface.
fn max_error(v: &[Vec3], f: &[[u32; 3]], points: &[DVec3]) -> (f64, f64) {
    let w = WindingNumber::new(v, f);
    let mut max = 0.0f64;
    let mut sum = 0.0;
    for &p in points {
        let e = (w.eval(p) - w.eval_exact(p)).abs();
        max = max.max(e);
        sum += e;
    }
    (max, sum / points.len() as f64)
}

#[test]
fn fast_matches_exact_on_icosphere() {
    let (v, f) = icosphere(5, Vec3::new(0.1, 0.2, 0.3), 1.0); // 20480 triangles
    let mut rng = Rng::new(8);
    let c = DVec3::new(0.1, 0.2, 0.3);
    let mut pts = Vec::new();
    for _ in 0..300 {
        let dir = rng.dvec3(-1.0, 1.0).normalize_or(DVec3::X);
        // Inside, outside, and within 1% of the surface on both sides.
        for r in [rng.range(0.0, 0.95), rng.range(1.05, 3.0), rng.range(0.99, 1.01)] {
            pts.push(c + dir * r);
        }
    }
    let (max, mean) = max_error(&v, &f, &pts);
    println!("icosphere 20480 tris: max |fast - exact| = {max:.2e}, mean = {mean:.2e}");
    assert!(max < 6e-3, "max error {max}");
    assert!(mean < 2e-3, "mean error {mean}");
    let w = WindingNumber::new(&v, &f);
    for p in &pts[..60] {
        let d = (*p - c).length();
        let want = if d < 0.97 {
            1.0
        } else if d > 1.03 {
            0.0
        } else {
            continue;
        };
        assert!((w.eval(*p) - want).abs() < 6e-3, "{p}: {}", w.eval(*p));
    }
}

#[test]
fn fast_matches_exact_on_bunny() {
    let Some(path) = shared_model("obj/stanford-bunny.obj") else { return };
    let (v, f) = load_obj(&path);
    let (lo, hi) = v.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), p| (a.min(*p), b.max(*p)));
    let mut rng = Rng::new(21);
    let mut pts: Vec<DVec3> = (0..150)
        .map(|_| {
            let t = rng.dvec3(-0.1, 1.1);
            lo.as_dvec3() + (hi - lo).as_dvec3() * t
        })
        .collect();
    // Points very near the surface: triangle centroids pushed off by 1e-4 (bbox ~0.15).
    for _ in 0..100 {
        let t = f[(rng.next_u64() % f.len() as u64) as usize].map(|i| v[i as usize].as_dvec3());
        let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
        let s = if rng.f64() < 0.5 { 1e-4 } else { -1e-4 };
        pts.push((t[0] + t[1] + t[2]) / 3.0 + n * s);
    }
    let w = WindingNumber::new(&v, &f);
    let t0 = std::time::Instant::now();
    let mut acc = 0.0;
    for k in 0..20 {
        for p in &pts {
            acc += w.eval(*p + DVec3::splat(k as f64 * 1e-4));
        }
    }
    println!("bunny: {:.2} us per fast eval ({acc:.1})", t0.elapsed().as_secs_f64() * 1e6 / (20 * pts.len()) as f64);
    let (max, mean) = max_error(&v, &f, &pts);
    println!("bunny 69451 tris: max |fast - exact| = {max:.2e}, mean = {mean:.2e}");
    assert!(max < 6e-3, "max error {max}");
    assert!(mean < 2e-3, "mean error {mean}");
}
