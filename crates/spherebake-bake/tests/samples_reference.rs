//! Sample placement against the math reference §8 and analytic ray–box / ray–capsule answers.

mod samples_support;

use glam::{DVec3, Vec3};
use samples_support::*;
use spherebake_format::SamplePoint;

fn v(p: [f32; 3]) -> DVec3 {
    Vec3::from_array(p).as_dvec3()
}

/// Compares a stage's output for one sphere with the convex-box reference, direction by direction.
fn check_box(spheres: &[[f32; 4]], min: DVec3, max: DVec3, tol: f64) -> Vec<[u32; 4]> {
    let mesh = box_mesh(min.as_vec3(), max.as_vec3());
    let (samples, stats, flip) = run(&mesh, spheres);
    assert!(flip.iter().all(|f| !f), "the box is outward already");
    let dirs = directions();
    let mut tables = Vec::new();
    for i in 0..spheres.len() {
        let got: Vec<&SamplePoint> = samples.of(i).iter().collect();
        assert!(got.windows(2).all(|w| w[0].direction < w[1].direction), "strictly increasing directions");
        let mut counts = [0u32; 4];
        for (k, &omega) in dirs.iter().enumerate() {
            let e = expect_box(i, spheres, omega, min, max);
            let s = got.iter().find(|s| s.direction as usize == k);
            match e {
                Expect::Sample { rule, position, normal } => {
                    counts[if rule == 1 { 0 } else { 2 }] += 1;
                    let s = s.unwrap_or_else(|| panic!("sphere {i} direction {k}: expected rule {rule}, got nothing"));
                    assert_eq!(s.rule, rule, "sphere {i} direction {k}");
                    assert!(
                        (v(s.position) - position).length() < tol,
                        "sphere {i} dir {k}: {:?} vs {position}",
                        s.position
                    );
                    assert!((v(s.normal) - normal).length() < 1e-6, "sphere {i} dir {k}: {:?} vs {normal}", s.normal);
                }
                Expect::Rule2 => {
                    counts[1] += 1;
                    assert!(s.is_none(), "sphere {i} direction {k}: expected rule 2 (nothing), got {s:?}");
                }
                Expect::Rule3Empty => {
                    counts[3] += 1;
                    assert!(s.is_none(), "sphere {i} direction {k}: expected rule 3 nothing, got {s:?}");
                }
            }
        }
        let st = stats.per_sphere[i];
        assert_eq!([st.rule1, st.rule2_empty, st.rule3, st.rule3_empty], counts, "sphere {i} stats");
        tables.push(counts);
    }
    tables
}

/// Math reference §8: cube [−1,1]³, S0 inside, S1 with its centre outside.
#[test]
fn worked_example_rule_counts_and_samples() {
    let spheres = [[0.2, 0.1, -0.05, 1.0], [0.2, 0.1, 1.6, 1.0]];
    let tables = check_box(&spheres, DVec3::splat(-1.0), DVec3::splat(1.0), 1e-6);
    // The table of §8: rule 1, rule 2, rule 3 (sample), rule 3 (nothing).
    assert_eq!(tables, vec![[74, 18, 0, 0], [5, 18, 23, 46]]);

    let mesh = box_mesh(Vec3::splat(-1.0), Vec3::splat(1.0));
    let (samples, _, _) = run(&mesh, &spheres);
    let find = |i: usize, k: u8| samples.of(i).iter().find(|s| s.direction == k).copied();
    let close = |a: [f32; 3], b: [f64; 3]| (v(a) - DVec3::from_array(b)).length() < 1e-6;
    // (sphere, direction, rule, position, normal)
    type Case = (usize, u8, u8, [f64; 3], [f64; 3]);
    let cases: [Case; 5] = [
        (0, 0, 1, [-0.3562305899, 1.0, -0.05], [0.0, 1.0, 0.0]),
        (0, 9, 1, [1.0, 0.1, 0.444427191], [1.0, 0.0, 0.0]),
        (1, 10, 1, [-1.0, 0.1, 0.8583592135], [-1.0, 0.0, 0.0]),
        (1, 78, 1, [1.0, 0.9, 0.8], [1.0, 0.0, 0.0]),
        (1, 4, 3, [0.2, 0.4708203932, 1.0], [0.0, 0.0, 1.0]),
    ];
    for (i, k, rule, p, n) in cases {
        let s = find(i, k).unwrap_or_else(|| panic!("S{i} direction {k}: no sample"));
        assert_eq!(s.rule, rule, "S{i} direction {k}");
        assert!(close(s.position, p), "S{i} direction {k}: {:?} vs {p:?}", s.position);
        assert!(close(s.normal, n), "S{i} direction {k}: {:?} vs {n:?}", s.normal);
    }
    for (i, k) in [(0, 5), (1, 6), (1, 0)] {
        assert!(find(i, k).is_none(), "S{i} direction {k} must be empty");
    }
}

/// A sphere at the centre of a box: every direction is rule 1 at the analytic exit point
/// t = min_a h_a / |ω_a|, on the face of that axis.
#[test]
fn sphere_at_box_centre_all_92_analytic() {
    let centre = DVec3::new(0.3, -0.2, 0.1);
    let half = DVec3::new(1.5, 1.0, 0.6);
    let spheres = [[centre.x as f32, centre.y as f32, centre.z as f32, 0.5]];
    let (min, max) = (centre - half, centre + half);
    let tables = check_box(&spheres, min, max, 2e-6);
    assert_eq!(tables, vec![[92, 0, 0, 0]]);
    // And directly from the closed form, independent of the slab helper.
    let mesh = box_mesh(min.as_vec3(), max.as_vec3());
    let (samples, _, _) = run(&mesh, &spheres);
    let c = DVec3::new(spheres[0][0] as f64, spheres[0][1] as f64, spheres[0][2] as f64);
    for (k, omega) in directions().into_iter().enumerate() {
        let t = (0..3).map(|a| half[a] / omega[a].abs()).fold(f64::INFINITY, f64::min);
        let s = samples.of(0)[k];
        assert_eq!(s.direction as usize, k);
        assert!((v(s.position) - (c + t * omega)).length() < 2e-6, "direction {k}");
    }
}

/// Two equal overlapping spheres in a capsule: directions whose exit point lies clearly on the
/// other sphere's side of the bisecting plane x = 0 are rule 2, the others rule 1 at the exit.
#[test]
fn capsule_two_spheres_rules_1_and_2() {
    let (half, r) = (1.0f64, 0.5f64);
    let mesh = capsule_mesh(half as f32, r as f32, 96, 24);
    let analytic_volume = std::f64::consts::PI * r * r * 2.0 * half + 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
    let vol = signed_volume(&mesh);
    assert!(vol > 0.0 && (vol / analytic_volume - 1.0).abs() < 0.01, "{vol} vs {analytic_volume}");
    let spheres = [[-0.5, 0.0, 0.0, 0.9], [0.5, 0.0, 0.0, 0.9]];
    let (samples, stats, flip) = run(&mesh, &spheres);
    assert!(flip.iter().all(|f| !f));
    // Exit point of the exact capsule from an inside point (convex: a single exit).
    let exit = |c: DVec3, w: DVec3| -> (DVec3, DVec3) {
        let rho = (w.y * w.y + w.z * w.z).sqrt();
        if rho > 0.0 {
            let t = r / rho; // c is on the axis
            let p = c + t * w;
            if p.x.abs() <= half {
                return (p, DVec3::new(0.0, p.y, p.z) / r);
            }
        }
        let e = DVec3::new(half * w.x.signum(), 0.0, 0.0);
        let oc = c - e;
        let b = oc.dot(w);
        let t = -b + (b * b - (oc.length_squared() - r * r)).sqrt();
        let p = c + t * w;
        (p, (p - e) / r)
    };
    let mut seen = [0u32; 2];
    for (i, sphere) in spheres.iter().enumerate() {
        let c = DVec3::new(sphere[0] as f64, 0.0, 0.0);
        for (k, w) in directions().into_iter().enumerate() {
            let (p, n) = exit(c, w);
            let s = samples.of(i).iter().find(|s| s.direction as usize == k);
            // Segment boundary is x = 0; tessellation moves the exit by < 1e-3.
            let own = if i == 0 { p.x < 0.0 } else { p.x > 0.0 };
            if p.x.abs() < 0.02 {
                continue;
            }
            if own {
                seen[0] += 1;
                let s = s.unwrap_or_else(|| panic!("sphere {i} dir {k}: expected rule 1"));
                assert_eq!(s.rule, 1);
                assert!((v(s.position) - p).length() < 5e-3, "sphere {i} dir {k}: {:?} vs {p}", s.position);
                assert!((v(s.normal) - n).length() < 1e-2, "sphere {i} dir {k}: {:?} vs {n}", s.normal);
            } else {
                seen[1] += 1;
                assert!(s.is_none(), "sphere {i} dir {k}: expected rule 2, got {s:?}");
            }
        }
        let st = stats.per_sphere[i];
        assert_eq!(st.rule3 + st.rule3_empty, 0, "centres inside: no rule 3");
        assert_eq!(st.total(), 92);
    }
    assert!(seen[0] > 50 && seen[1] > 20, "both rules exercised: {seen:?}");
}

/// A thin closed plate (a flat shell) with sphere centres above and below it, outside the solid:
/// upward rays from the upper centre miss, so rule 3 looks back down and finds the top face.
#[test]
fn centre_outside_thin_shell_uses_rule_3() {
    let (min, max) = (DVec3::new(-1.0, -1.0, 0.0), DVec3::new(1.0, 1.0, 0.05));
    let spheres = [[0.1, -0.2, 0.5, 0.6], [-0.3, 0.2, -0.4, 0.5]];
    let tables = check_box(&spheres, min, max, 2e-6);
    for t in &tables {
        assert!(t[2] > 10 && t[3] > 10, "rule 3 with and without a sample: {tables:?}");
        assert!(t[0] > 0, "{tables:?}");
    }
}

/// Radius-0 and non-finite spheres own no segment: they get no samples, are counted as skipped,
/// and the valid sphere gets what it gets alone.
#[test]
fn degenerate_spheres_are_skipped() {
    let mesh = box_mesh(Vec3::splat(-1.0), Vec3::splat(1.0));
    let alone = [[0.2, 0.1, -0.05, 1.0]];
    let with = [[0.5, 0.5, 0.5, 0.0], [0.2, 0.1, -0.05, 1.0], [f32::NAN, 0.0, 0.0, 1.0]];
    let (a, _, _) = run(&mesh, &alone);
    let (b, st, _) = run(&mesh, &with);
    assert_eq!(b.sphere_count(), 3);
    assert!(b.of(0).is_empty() && b.of(2).is_empty());
    assert_eq!(b.of(1), a.of(0));
    assert_eq!((st.per_sphere[0].skipped, st.per_sphere[2].skipped, st.per_sphere[1].skipped), (92, 92, 0));
    assert_eq!(st.per_sphere[1].rule1, 92);
}
