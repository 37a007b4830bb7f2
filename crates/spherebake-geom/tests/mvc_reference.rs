//! Mean value coordinates and bone folding against the math reference §7 (values computed there
//! by adaptive quadrature of the integral definition, independently of this code).

use glam::{DMat4, DQuat, DVec3};
use spherebake_geom::mvc::{
    fold_into_bones, largest_terms, mean_value_coordinates, pose_terms, truncate_terms, BoneTerm, MvcLocation, SkinRow,
};

fn cube() -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let (p, t) = spherebake_testkit::mesh::unit_cube();
    (p.into_iter().map(DVec3::from).collect(), t)
}

fn check(x: DVec3, expected: &[f64], raw_sum: Option<f64>, tol: f64) {
    let (p, t) = cube();
    let m = mean_value_coordinates(x, &p, &t).unwrap();
    for (i, (a, e)) in m.weights.iter().zip(expected).enumerate() {
        assert!((a - e).abs() <= tol, "x={x} λ{i} = {a}, expected {e}");
    }
    if let Some(s) = raw_sum {
        assert!((m.raw_sum - s).abs() <= 1e-7, "raw sum {} vs {s}", m.raw_sum);
    }
}

#[test]
fn cube_table_centre() {
    let (a, b) = (0.180981293, 0.106339569);
    // The table gives 9 digits: tolerance at its last digit.
    check(DVec3::splat(0.5), &[a, b, b, b, b, b, b, a], Some(41.78014807), 2e-9);
}

#[test]
fn cube_table_off_centre() {
    let e = [
        0.4458904945,
        0.04288559918,
        0.06765345318,
        0.04357045315,
        0.1413384729,
        0.0698854334,
        0.1451175794,
        0.04365851427,
    ];
    check(DVec3::new(0.2, 0.3, 0.4), &e, Some(58.22403315), 1e-10);
}

#[test]
fn linear_precision_and_partition_of_unity_inside_and_outside() {
    let (p, t) = cube();
    let mut s = 0x1234_5678_u64;
    let mut rnd = || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    for i in 0..200 {
        // Inside, then a shell outside.
        let x = if i < 100 {
            DVec3::new(0.05 + 0.9 * rnd(), 0.05 + 0.9 * rnd(), 0.05 + 0.9 * rnd())
        } else {
            DVec3::new(-1.0 + 3.0 * rnd(), -1.0 + 3.0 * rnd(), 1.5 + rnd())
        };
        let m = mean_value_coordinates(x, &p, &t).unwrap();
        let sum: f64 = m.weights.iter().sum();
        assert!((sum - 1.0).abs() < 1e-12);
        // Outside, weights of both signs cancel: a few more ulps.
        let tol = if i < 100 { 1e-12 } else { 1e-10 };
        assert!(m.linear_residual < tol, "x={x} residual {}", m.linear_residual);
        let direct: DVec3 = p.iter().zip(&m.weights).map(|(v, l)| *v * *l).sum();
        assert!((direct - x).length() < tol);
        if i < 100 {
            assert!(m.weights.iter().all(|&l| l > 0.0), "convex mesh, inside: positive weights");
        }
    }
}

#[test]
fn on_face_and_vertex() {
    check(DVec3::new(0.25, 0.5, 0.0), &[0.5, 0.0, 0.25, 0.25, 0.0, 0.0, 0.0, 0.0], None, 1e-12);
    let (p, t) = cube();
    let m = mean_value_coordinates(DVec3::new(1.0, 1.0, 0.0), &p, &t).unwrap();
    assert_eq!(m.location, MvcLocation::OnVertex { vertex: 3 });
    assert_eq!(m.weights, vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0]);
}

#[test]
fn near_face_limits() {
    let (p, t) = cube();
    let limit = [0.4, 0.0, 0.3, 0.3, 0.0, 0.0, 0.0, 0.0];
    for (delta, max_dev) in [(1e-2, 0.007259), (1e-3, 0.0007268)] {
        let x = DVec3::new(0.3, 0.6, delta);
        let m = mean_value_coordinates(x, &p, &t).unwrap();
        let dev = m.weights.iter().zip(limit).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!((dev - max_dev).abs() < 1e-8 * 10.0 + 5e-7, "δ={delta}: max dev {dev} vs {max_dev}");
        assert!(m.linear_residual < 1e-11);
        assert_eq!(m.location, MvcLocation::OffSurface);
    }
    for delta in [1e-6, 1e-9] {
        let m = mean_value_coordinates(DVec3::new(0.3, 0.6, delta), &p, &t).unwrap();
        assert!(matches!(m.location, MvcLocation::OnTriangle { .. }), "δ={delta}");
        let dev = m.weights.iter().zip(limit).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(dev < 1e-11, "δ={delta}: {dev}");
    }
}

#[test]
fn degenerate_triangles_do_not_change_the_answer() {
    let (mut p, mut t) = cube();
    let x = DVec3::new(0.2, 0.3, 0.4);
    let clean = mean_value_coordinates(x, &p, &t).unwrap();
    // A sliver with a repeated id, and a collinear triangle along the edge 0–1 (new vertex 8 at
    // its midpoint, referenced by nothing else).
    p.push(DVec3::new(0.5, 0.0, 0.0));
    t.push([0, 0, 1]);
    t.push([0, 8, 1]);
    let m = mean_value_coordinates(x, &p, &t).unwrap();
    // The repeated id is counted; the collinear one projects to a great-circle arc and drops out
    // through the in-plane test (s_i = 0).
    assert_eq!(m.degenerate_triangles, 1);
    for i in 0..8 {
        assert!((m.weights[i] - clean.weights[i]).abs() < 1e-14);
    }
    assert_eq!(m.weights[8], 0.0);
}

#[test]
fn bad_input_is_an_error() {
    let (p, mut t) = cube();
    assert!(mean_value_coordinates(DVec3::new(f64::NAN, 0.0, 0.0), &p, &t).is_err());
    t.push([0, 1, 99]);
    assert!(mean_value_coordinates(DVec3::splat(0.5), &p, &t).is_err());
}

// ---- folding example of §7 ----

fn rows() -> Vec<SkinRow> {
    let r = [
        [0.7, 0.1, 0.1, 0.1],
        [0.1, 0.7, 0.1, 0.1],
        [0.4, 0.0, 0.6, 0.0],
        [0.0, 0.4, 0.6, 0.0],
        [0.5, 0.0, 0.0, 0.5],
        [0.0, 0.5, 0.0, 0.5],
        [0.25, 0.25, 0.25, 0.25],
        [0.0, 0.3, 0.3, 0.4],
    ];
    r.iter()
        .map(|w| {
            let mut row: SkinRow = [(0, 0.0); 8];
            for j in 0..4 {
                row[j] = (j as u32, w[j]);
            }
            row
        })
        .collect()
}

fn about(axis: DVec3, angle_deg: f64, through: DVec3) -> DMat4 {
    DMat4::from_translation(through)
        * DMat4::from_quat(DQuat::from_axis_angle(axis, angle_deg.to_radians()))
        * DMat4::from_translation(-through)
}

fn bones() -> Vec<DMat4> {
    vec![
        DMat4::IDENTITY,
        about(DVec3::Z, 30.0, DVec3::X),
        DMat4::from_translation(DVec3::new(0.0, 0.2, 0.0)),
        about(DVec3::X, 45.0, DVec3::Z),
    ]
}

fn folded() -> (DVec3, Vec<BoneTerm>) {
    let (p, t) = cube();
    let x = DVec3::new(0.2, 0.3, 0.4);
    let m = mean_value_coordinates(x, &p, &t).unwrap();
    (x, fold_into_bones(&m.weights, &p, &rows(), 4))
}

/// Centre-LBS with kept set K and b renormalised over K (the reference's P'_k).
fn centre_lbs(terms: &[BoneTerm], keep: &[usize], x: DVec3, t: &[DMat4]) -> DVec3 {
    let s: f64 = keep.iter().map(|&j| terms[j].b).sum();
    keep.iter().map(|&j| t[j].transform_point3(x) * (terms[j].b / s)).sum()
}

fn close(a: DVec3, e: [f64; 3], tol: f64) {
    assert!((a - DVec3::from(e)).abs().max_element() <= tol, "{a} vs {e:?}");
}

#[test]
fn fold_example_b_and_exact() {
    let (x, terms) = folded();
    let b: Vec<f64> = terms.iter().map(|t| t.b).collect();
    for (a, e) in b.iter().zip([0.4504219186, 0.176356816, 0.1649889023, 0.2082323631]) {
        assert!((a - e).abs() <= 1e-10, "b {a} vs {e}");
    }
    assert!((b.iter().sum::<f64>() - 1.0).abs() < 1e-14);
    let t = bones();
    let exact = pose_terms(&terms, &t);
    close(exact, [0.177431752, 0.3024341551, 0.452317819], 1e-9);
    // Independent: MVC of the linear-blend-skinned vertices.
    let (p, tris) = cube();
    let m = mean_value_coordinates(x, &p, &tris).unwrap();
    let skinned: DVec3 = p
        .iter()
        .zip(rows())
        .zip(&m.weights)
        .map(|((v, row), l)| row.iter().map(|&(j, s)| t[j as usize].transform_point3(*v) * s).sum::<DVec3>() * *l)
        .sum();
    assert!((skinned - exact).length() < 1e-14);
    let all = centre_lbs(&terms, &[0, 1, 2, 3], x, &t);
    assert!(((exact - all).length() - 0.03953445109).abs() <= 1e-10);
}

#[test]
fn fold_example_truncation() {
    let (x, terms) = folded();
    let t = bones();
    let exact = pose_terms(&terms, &t);
    let all = centre_lbs(&terms, &[0, 1, 2, 3], x, &t);
    let k2 = largest_terms(&terms, 2);
    assert_eq!(k2, vec![0, 3]);
    let p2 = centre_lbs(&terms, &k2, x, &t);
    close(p2, [0.2, 0.4063510212, 0.5226237577], 1e-9);
    assert!(((all - p2).length() - 0.09143094172).abs() <= 1e-10);
    assert!(((exact - p2).length() - 0.1274792763).abs() <= 1e-10);
    let k3 = largest_terms(&terms, 3);
    let p3 = centre_lbs(&terms, &k3, x, &t);
    assert!(((all - p3).length() - 0.03803781379).abs() <= 1e-10);

    // The stored truncation (exact terms of the kept bones + the remainder shared by b):
    // rest pose exact, common rigid motion exact, all bones = exact fold.
    let rest = vec![DMat4::IDENTITY; 4];
    for k in 1..=4 {
        let tr = truncate_terms(&terms, k, x, &rest);
        assert!(!tr.remainder_dropped);
        assert_eq!(tr.terms.len(), k);
        assert!((pose_terms(&tr.terms, &rest) - x).length() < 1e-14, "k={k}: rest");
        assert!((tr.terms.iter().map(|t| t.b).sum::<f64>() - 1.0).abs() < 1e-14);
        let g = about(DVec3::new(1.0, 2.0, 0.5).normalize(), 70.0, DVec3::new(0.3, -2.0, 1.0));
        let moved = pose_terms(&tr.terms, &vec![g; 4]);
        assert!((moved - g.transform_point3(x)).length() < 1e-13, "k={k}: rigid");
        let posed = pose_terms(&tr.terms, &t);
        let err = (posed - exact).length();
        eprintln!("k={k}: |exact - stored truncation| = {err:.10}");
        if k == 4 {
            assert!(err < 1e-14);
        }
        if k == 2 {
            // Keeping q of the kept bones beats centre-LBS here.
            assert!(err < (exact - p2).length());
        }
    }
}

#[test]
fn truncation_with_non_identity_rest_pose() {
    // Rest joint matrices differ per bone (bind space ≠ rest space): the rest centre is still exact.
    let (x_bind, terms_bind) = folded();
    let rest = bones();
    // The mesh at rest is the skinned cube; the centre is the MVC point of the bind cube, posed.
    let centre_rest = pose_terms(&terms_bind, &rest);
    for k in 1..=4 {
        let tr = truncate_terms(&terms_bind, k, centre_rest, &rest);
        assert!((pose_terms(&tr.terms, &rest) - centre_rest).length() < 1e-13, "k={k}");
        let g = DMat4::from_translation(DVec3::new(3.0, 0.0, -1.0)) * DMat4::from_rotation_y(1.1);
        let moved: Vec<DMat4> = rest.iter().map(|m| g * *m).collect();
        assert!((pose_terms(&tr.terms, &moved) - g.transform_point3(centre_rest)).length() < 1e-13);
    }
    let _ = x_bind;
}
