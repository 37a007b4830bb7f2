//! Sphere primitives against math reference §6 and brute-force oracles.

mod voxel_support;

use glam::DVec3;
use spherebake_geom::sphere::*;
use std::f64::consts::PI;
use voxel_support::Rng;

fn close(got: f64, want: f64, tol: f64, what: &str) {
    assert!((got - want).abs() <= tol, "{what}: got {got}, want {want}");
}

#[test]
fn volumes_match_reference() {
    close(ball_volume(1.0), 4.188790205, 1e-9, "ball r=1");
    close(cap_volume(1.0, 0.5), 0.6544984695, 1e-10, "cap 1, 0.5");
    close(cap_volume(0.6, 0.1), 0.01780235837, 1e-10, "cap 0.6, 0.1");
    close(lens_volume(1.0, 1.0, 1.0), 5.0 * PI / 12.0, 1e-10, "lens 1,1,1");
    close(lens_volume(1.0, 0.5, 1.2), 0.08423395302, 1e-10, "lens 1,0.5,1.2");
    close(lens_volume(1.0, 0.5, 0.3), PI / 6.0, 1e-10, "lens contained");
    close(lens_volume(1.0, 0.5, 1.5), 0.0, 0.0, "lens touching");
    close(lens_volume(1.0, 0.5, 7.0), 0.0, 0.0, "lens disjoint");
    // Independent: lens = sum of the two caps cut by the radical plane.
    let (r1, r2, d) = (1.3f64, 0.9f64, 1.1f64);
    let x = (d * d + r1 * r1 - r2 * r2) / (2.0 * d);
    close(lens_volume(r1, r2, d), cap_volume(r1, r1 - x) + cap_volume(r2, r2 - (d - x)), 1e-12, "lens = caps");
    close(cap_volume(1.0, 2.0), ball_volume(1.0), 1e-12, "full cap");
}

#[test]
fn pair_bound_matches_reference() {
    let (c, r) = sphere_pair_bound(DVec3::ZERO, 1.0, DVec3::new(3.0, 0.0, 0.0), 0.5);
    assert!((c - DVec3::new(1.25, 0.0, 0.0)).length() < 1e-8);
    close(r, 2.25, 1e-8, "pair R");
    let (c, r) = sphere_pair_bound(DVec3::ZERO, 2.0, DVec3::new(0.5, 0.5, 0.0), 0.5);
    assert!(c.length() < 1e-12);
    close(r, 2.0, 1e-12, "contained");
    let (c, r) = sphere_pair_bound(DVec3::new(1.0, 2.0, 3.0), 0.5, DVec3::new(2.0, 0.0, 3.5), 1.2);
    close(r, 1.995643924, 1e-8, "pair R 3");
    assert!((c - DVec3::new(1.652752523, 0.6944949537, 3.326376262)).length() < 1e-8, "{c}");
}

/// Indices of points on the boundary of (c, r).
fn boundary(points: &[DVec3], c: DVec3, r: f64) -> Vec<usize> {
    (0..points.len()).filter(|&i| (points[i].distance(c) - r).abs() < 1e-9).collect()
}

#[test]
fn welzl_table() {
    let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    let mut cube: Vec<DVec3> =
        (0..8).map(|i| v((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64)).collect();
    cube.push(v(0.5, 0.5, 0.5));
    let ten: Vec<DVec3> = (0..10)
        .map(|k| {
            let k = k as f64;
            v((1.3 * k + 0.2).sin(), (2.1 * k).cos(), (0.7 * k + 1.1).sin())
        })
        .collect();
    let cases: Vec<(Vec<DVec3>, DVec3, f64, Vec<usize>)> = vec![
        (vec![v(1., 0., 0.), v(-1., 0., 0.), v(0., 0.5, 0.), v(0., 0., 0.3)], v(0., 0., 0.), 1.0, vec![0, 1]),
        (
            vec![v(1., 1., 1.), v(1., -1., -1.), v(-1., 1., -1.), v(-1., -1., 1.)],
            v(0., 0., 0.),
            1.732050808,
            vec![0, 1, 2, 3],
        ),
        (vec![v(0., 0., 0.), v(4., 0., 0.), v(1., 3., 0.)], v(2., 1., 0.), 2.236067977, vec![0, 1, 2]),
        (vec![v(0., 0., 0.), v(4., 0., 0.), v(1., 1., 0.)], v(2., 0., 0.), 2.0, vec![0, 1]),
        (cube, v(0.5, 0.5, 0.5), 0.8660254038, (0..8).collect()),
        (ten, v(0.1985562219, 0.2119352056, 0.04492116698), 1.419500959, vec![1, 4, 6, 9]),
    ];
    for (points, center, radius, support) in cases {
        let (c, r) = min_enclosing_ball(&points);
        assert!((c - center).length() < 1e-9, "centre {c} vs {center}");
        close(r, radius, 1e-9, "radius");
        assert_eq!(boundary(&points, c, r), support);
        // Input order must not matter.
        let rev: Vec<DVec3> = points.iter().rev().copied().collect();
        let (c2, r2) = min_enclosing_ball(&rev);
        assert!((c2 - c).length() < 1e-9 && (r2 - r).abs() < 1e-9);
    }
}

/// Brute force: the smallest ball through 1–4 points (circumsphere in their affine hull) that
/// contains all points.
fn brute_min_ball(p: &[DVec3]) -> (DVec3, f64) {
    let n = p.len();
    let mut best = (DVec3::ZERO, f64::INFINITY);
    let mut consider = |c: DVec3| {
        let r = p.iter().map(|q| q.distance(c)).fold(0.0, f64::max);
        if r < best.1 {
            best = (c, r);
        }
    };
    for i in 0..n {
        consider(p[i]);
        for j in i + 1..n {
            consider((p[i] + p[j]) / 2.0);
            for k in j + 1..n {
                let (a, b) = (p[j] - p[i], p[k] - p[i]);
                let nrm = a.cross(b);
                if nrm.length_squared() > 1e-18 {
                    consider(
                        p[i] + (b.length_squared() * nrm.cross(a) + a.length_squared() * b.cross(nrm))
                            / (2.0 * nrm.length_squared()),
                    );
                }
                for l in k + 1..n {
                    // Circumsphere: 2(p_m − p_i)·c = |p_m|² − |p_i|².
                    let rows = [p[j] - p[i], p[k] - p[i], p[l] - p[i]];
                    let rhs = [
                        (p[j].length_squared() - p[i].length_squared()) / 2.0,
                        (p[k].length_squared() - p[i].length_squared()) / 2.0,
                        (p[l].length_squared() - p[i].length_squared()) / 2.0,
                    ];
                    let m = glam::DMat3::from_cols(rows[0], rows[1], rows[2]).transpose();
                    if m.determinant().abs() > 1e-12 {
                        consider(m.inverse() * DVec3::from(rhs));
                    }
                }
            }
        }
    }
    best
}

#[test]
fn welzl_matches_brute_force_on_random_sets() {
    let mut rng = Rng::new(7);
    for case in 0..300 {
        let n = 1 + (case % 12);
        let mut pts: Vec<DVec3> = (0..n).map(|_| rng.dvec3(-2.0, 2.0)).collect();
        if case % 5 == 0 && n > 2 {
            pts[1] = pts[0]; // duplicates
        }
        if case % 7 == 0 {
            for p in &mut pts {
                p.z = 0.25; // coplanar
            }
        }
        let (c, r) = min_enclosing_ball(&pts);
        let (bc, br) = brute_min_ball(&pts);
        assert!((r - br).abs() < 1e-9, "case {case}: {r} vs {br}");
        assert!((c - bc).length() < 1e-6, "case {case}: {c} vs {bc}");
        assert!(pts.iter().all(|p| p.distance(c) <= r));
    }
}

#[test]
fn welzl_many_cospherical_points() {
    // 5000 points on a sphere of radius 3 around (1, 2, 3) (Fibonacci lattice), duplicated.
    let center = DVec3::new(1.0, 2.0, 3.0);
    let mut pts = Vec::new();
    let n = 5000;
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let phi = i as f64 * PI * (3.0 - 5f64.sqrt());
        let s = (1.0 - z * z).sqrt();
        pts.push(center + 3.0 * DVec3::new(s * phi.cos(), s * phi.sin(), z));
    }
    pts.extend(pts.clone());
    let (c, r) = min_enclosing_ball(&pts);
    assert!((c - center).length() < 1e-6, "{c}");
    assert!((r - 3.0).abs() < 1e-6, "{r}");
}

fn fibonacci(n: usize) -> Vec<DVec3> {
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let phi = i as f64 * PI * (3.0 - 5f64.sqrt());
            let s = (1.0 - z * z).sqrt();
            DVec3::new(s * phi.cos(), s * phi.sin(), z)
        })
        .collect()
}

/// Distance from the origin to the convex hull of `u` (brute force over subsets of ≤ 4 vectors:
/// min-norm point of each affine hull, kept when its barycentric weights are ≥ 0).
fn hull_distance_to_origin(u: &[DVec3]) -> f64 {
    let n = u.len();
    let mut best = f64::INFINITY;
    for mask in 1u32..(1 << n) {
        let s: Vec<DVec3> = (0..n).filter(|&i| mask & (1 << i) != 0).map(|i| u[i]).collect();
        if s.len() > 4 {
            continue;
        }
        // Minimise |s0 + Σ μ_l (s_l − s0)|: normal equations.
        let k = s.len() - 1;
        let d: Vec<DVec3> = s[1..].iter().map(|x| *x - s[0]).collect();
        let mut mu = vec![0.0; k];
        if k > 0 {
            let mut m = glam::DMat3::IDENTITY;
            let mut rhs = DVec3::ZERO;
            for a in 0..k {
                for b in 0..k {
                    m.col_mut(b)[a] = d[a].dot(d[b]);
                }
                rhs[a] = -d[a].dot(s[0]);
            }
            if m.determinant().abs() < 1e-14 {
                continue;
            }
            let x = m.inverse() * rhs;
            for a in 0..k {
                mu[a] = x[a];
            }
        }
        let w0 = 1.0 - mu.iter().sum::<f64>();
        if w0 < -1e-9 || mu.iter().any(|&m| m < -1e-9) {
            continue;
        }
        let p = s[0] + d.iter().zip(&mu).map(|(dv, m)| *dv * *m).sum::<DVec3>();
        best = best.min(p.length());
    }
    best
}

/// Optimality certificate for min_c max_j(|c − c_j| + r_j) (convex): 0 lies in the convex hull
/// of the unit vectors from the active centres to c.
fn assert_optimal(balls: &[(DVec3, f64)], c: DVec3, r: f64, what: &str) {
    let mut u = Vec::new();
    for (cj, rj) in balls {
        let d = c.distance(*cj);
        if d + rj >= r - 1e-7 * r.max(1.0) {
            if d < 1e-12 {
                return; // a ball centred at c is active: its subdifferential holds 0
            }
            u.push((c - *cj) / d);
        }
    }
    assert!(!u.is_empty() && u.len() <= 16, "{what}: {} active balls", u.len());
    let dist = hull_distance_to_origin(&u);
    assert!(dist < 1e-5, "{what}: not optimal, hull distance {dist}");
}

#[test]
fn enclosing_ball_of_balls_vs_sampling_and_optimality() {
    let mut rng = Rng::new(11);
    let dirs = fibonacci(3000);
    for case in 0..60 {
        let n = 1 + case % 9;
        let balls: Vec<(DVec3, f64)> = (0..n).map(|_| (rng.dvec3(-3.0, 3.0), rng.range(0.0, 1.5))).collect();
        let (c, r) = min_enclosing_ball_of_balls(&balls);
        // Containment of every input ball.
        for (cj, rj) in &balls {
            assert!(c.distance(*cj) + rj <= r, "case {case}: ball not contained");
        }
        // Lower bound: the minimal ball of points sampled on the sphere surfaces.
        let samples: Vec<DVec3> = balls.iter().flat_map(|(cj, rj)| dirs.iter().map(move |d| *cj + *d * *rj)).collect();
        let (_, rs) = min_enclosing_ball(&samples);
        let rmax = balls.iter().map(|b| b.1).fold(0.0, f64::max);
        assert!(r >= rs - 1e-9, "case {case}: {r} < sampled {rs}");
        assert!(r <= rs + 2e-3 * rmax + 1e-9, "case {case}: {r} vs sampled {rs}");
        // Optimality: the KKT certificate.
        assert_optimal(&balls, c, r, &format!("case {case}"));
    }
}

#[test]
fn enclosing_ball_of_balls_special_cases() {
    // One ball inside another.
    let (c, r) = min_enclosing_ball_of_balls(&[(DVec3::ZERO, 2.0), (DVec3::new(0.5, 0.0, 0.0), 1.0)]);
    assert!(c.length() < 1e-12 && (r - 2.0).abs() < 1e-12);
    // Two balls: the pair bound.
    let (c1, r1, c2, r2) = (DVec3::new(1.0, 2.0, 3.0), 0.5, DVec3::new(2.0, 0.0, 3.5), 1.2);
    let (c, r) = min_enclosing_ball_of_balls(&[(c1, r1), (c2, r2)]);
    let (pc, pr) = sphere_pair_bound(c1, r1, c2, r2);
    assert!((c - pc).length() < 1e-9 && (r - pr).abs() < 1e-9);
    // Zero radii reduce to points (Welzl table row 3).
    let pts = [DVec3::ZERO, DVec3::new(4.0, 0.0, 0.0), DVec3::new(1.0, 3.0, 0.0)];
    let (c, r) = min_enclosing_ball_of_balls(&pts.map(|p| (p, 0.0)));
    assert!((c - DVec3::new(2.0, 1.0, 0.0)).length() < 1e-9 && (r - 5f64.sqrt()).abs() < 1e-9);
    // Identical balls, repeated.
    let (c, r) = min_enclosing_ball_of_balls(&[(DVec3::ONE, 0.5); 6]);
    assert!((c - DVec3::ONE).length() < 1e-12 && (r - 0.5).abs() < 1e-12);
    // Empty.
    assert_eq!(min_enclosing_ball_of_balls(&[]), (DVec3::ZERO, 0.0));
    assert_eq!(min_enclosing_ball(&[]), (DVec3::ZERO, 0.0));
}

#[test]
fn enclosing_ball_of_many_balls() {
    // 2000 balls: result contains all and matches the optimiser.
    let mut rng = Rng::new(99);
    let balls: Vec<(DVec3, f64)> = (0..2000).map(|_| (rng.dvec3(-1.0, 1.0), rng.range(0.0, 0.2))).collect();
    let (c, r) = min_enclosing_ball_of_balls(&balls);
    assert!(balls.iter().all(|(cj, rj)| c.distance(*cj) + rj <= r));
    assert_optimal(&balls, c, r, "2000 balls");
}
