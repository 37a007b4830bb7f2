//! Exact ball ∩ mesh volume against the checkable values of the math reference §6
//! (`../shared/research/math-reference.md`, outside this repository; the values are copied here;
//! tolerance 1e-9, relative where stated).

use glam::DVec3;
use spherebake_geom::volume::*;
use std::f64::consts::PI;

fn cube() -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let (p, t) = spherebake_testkit::mesh::unit_cube();
    (p.into_iter().map(DVec3::from).collect(), t)
}

/// Closed outward boundary of a union of unit voxels: every voxel face not shared with another
/// voxel, as two triangles (`spherebake_testkit::mesh::voxel_union`, derived from the voxel list,
/// not from library code).
fn voxel_union(cells: &[[i32; 3]]) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let (p, t) = spherebake_testkit::mesh::voxel_union(cells, 1);
    (p.into_iter().map(|q| DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64)).collect(), t)
}

fn close_rel(a: f64, b: f64, tol: f64) {
    let scale = b.abs().max(1e-300);
    assert!(((a - b) / scale).abs() <= tol || (a - b).abs() <= 1e-12, "got {a}, expected {b}");
}

#[test]
fn single_triangle_rows() {
    let a = DVec3::X;
    let b = DVec3::Y;
    let c = DVec3::Z;
    let o = DVec3::ZERO;
    close_rel(triangle_ball_volume(o, 0.5, a, b, c), PI / 48.0, 1e-9);
    close_rel(triangle_ball_volume(o, 0.5, a, b, c), 0.06544984695, 1e-9);
    close_rel(triangle_ball_volume(o, 0.7, a, b, c), 0.1484452857, 1e-9);
    close_rel(triangle_ball_volume(o, 0.8, a, b, c), 0.1620466106, 1e-9);
    close_rel(triangle_ball_volume(o, 1.0, a, b, c), 1.0 / 6.0, 1e-9);
    // Reversing the winding negates.
    for r in [0.5, 0.7, 0.8, 1.0, 3.0] {
        let f = triangle_ball_volume(o, r, a, b, c);
        let g = triangle_ball_volume(o, r, a, c, b);
        assert!((f + g).abs() <= 1e-15 * f.abs().max(1.0), "r {r}: {f} vs {g}");
    }
}

#[test]
fn cube_rows() {
    let (p, t) = cube();
    let s3 = 3f64.sqrt();
    let rows = [
        ([0.5, 0.5, 0.5], 0.5, PI / 6.0, 0.0),
        ([0.5, 0.5, 0.5], 0.6, 0.797964534, 0.1068141502),
        ([0.5, 0.5, 0.5], 0.75, 0.9875901947, 0.779555673),
        ([0.5, 0.5, 0.5], s3 / 2.0, 1.0, 1.720699046),
        ([0.0, 0.0, 0.0], 0.5, 0.06544984695, 0.4581489286),
        ([0.9, 0.2, 0.5], 0.4, 0.1528358781, 0.115246695),
    ];
    for (c, r, inter, outside) in rows {
        let c = DVec3::from_array(c);
        let v = ball_mesh_intersection_volume(c, r, &p, &t);
        close_rel(v, inter, 1e-9);
        let o = ball_outside_volume(c, r, &p, &t);
        if outside == 0.0 {
            assert!(o.abs() < 1e-12, "{o}");
        } else {
            close_rel(o, outside, 1e-9);
        }
        // Reversed winding negates the intersection volume.
        let rev: Vec<[u32; 3]> = t.iter().map(|x| [x[0], x[2], x[1]]).collect();
        close_rel(-ball_mesh_intersection_volume(c, r, &p, &rev), v, 1e-12);
    }
    // Closed forms.
    let cap = |r: f64, h: f64| PI * h * h * (3.0 * r - h) / 3.0;
    let c = DVec3::splat(0.5);
    close_rel(ball_outside_volume(c, 0.6, &p, &t), 6.0 * cap(0.6, 0.1), 1e-9);
    close_rel(ball_outside_volume(c, s3 / 2.0, &p, &t), PI * s3 / 2.0 - 1.0, 1e-9);
    close_rel(ball_outside_volume(DVec3::ZERO, 0.5, &p, &t), 7.0 * PI / 48.0, 1e-9);
    close_rel(mesh_signed_volume(&p, &t), 1.0, 1e-15);
}

#[test]
fn l_shape_row() {
    let (p, t) = voxel_union(&[[0, 0, 0], [1, 0, 0], [0, 1, 0]]);
    assert_eq!(t.len(), 28);
    close_rel(mesh_signed_volume(&p, &t), 3.0, 1e-15);
    let c = DVec3::new(1.1, 1.1, 0.5);
    close_rel(ball_mesh_intersection_volume(c, 0.7, &p, &t), 0.8217593807, 1e-9);
    close_rel(ball_outside_volume(c, 0.7, &p, &t), 0.6149956596, 1e-9);
}

#[test]
fn culled_sum_equals_full_sum() {
    let (p, t) = voxel_union(&[[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1], [2, 0, 0]]);
    let cases = [
        (DVec3::new(1.1, 1.1, 0.5), 0.7),
        (DVec3::new(0.5, 0.5, 0.5), 0.45),
        (DVec3::new(2.5, 0.5, 0.5), 0.3),
        (DVec3::new(1.4, 0.6, 0.9), 0.6),
        // Every corner of the row of three cubes along x is in this ball (their triangles take
        // the tetrahedron path of the culled sum), the cubes above it cross it.
        (DVec3::new(1.0, 0.5, 0.5), 1.3),
    ];
    let mut inside = 0;
    for (c, r) in cases {
        inside += t.iter().filter(|tri| tri.iter().all(|&v| p[v as usize].distance(c) <= r)).count();
        let full = ball_mesh_intersection_volume(c, r, &p, &t);
        // Near = triangles whose bounding box meets the ball's box (conservative).
        let near: Vec<u32> = (0..t.len() as u32)
            .filter(|&i| {
                let tri = t[i as usize];
                let lo = p[tri[0] as usize].min(p[tri[1] as usize]).min(p[tri[2] as usize]);
                let hi = p[tri[0] as usize].max(p[tri[1] as usize]).max(p[tri[2] as usize]);
                (lo - (c + r)).max_element() <= 0.0 && ((c - r) - hi).max_element() <= 0.0
            })
            .collect();
        assert!(near.len() < t.len());
        let w = winding_number_brute(c, &p, &t);
        assert!((w - w.round()).abs() < 1e-9);
        let culled = ball_mesh_intersection_volume_near(c, r, &p, &t, &near, w.round());
        close_rel(culled, full, 1e-11);
    }
    assert!(inside >= 8, "{inside} triangles inside a ball");
}

/// Seeded Monte Carlo on the real armadillo (closed): the exact intersection volume lies within
/// 5σ of the hit fraction of 4k points, where "inside T" is decided by the winding number.
#[test]
fn monte_carlo_armadillo() {
    let Some(path) = spherebake_testkit::shared_model("obj/armadillo.obj") else { return };
    let (p, t) = spherebake_testkit::mesh::load_obj::<f64>(&path);
    let p: Vec<DVec3> = p.into_iter().map(DVec3::from).collect();
    // A ball around the torso, partly outside the model.
    let c = DVec3::new(0.0, 10.0, 0.0);
    let r = 30.0;
    let exact = ball_mesh_intersection_volume(c, r, &p, &t);
    // Inside test: parity of +x ray crossings (the mesh is closed), counted by brute force.
    let inside = |q: DVec3| -> bool {
        let mut n = 0;
        for tri in &t {
            let a = p[tri[0] as usize] - q;
            let b = p[tri[1] as usize] - q;
            let cc = p[tri[2] as usize] - q;
            // Ray (s, 0, 0), s > 0: solve in the yz plane.
            let d1 = a.y * b.z - a.z * b.y;
            let d2 = b.y * cc.z - b.z * cc.y;
            let d3 = cc.y * a.z - cc.z * a.y;
            if (d1 > 0.0 && d2 > 0.0 && d3 > 0.0) || (d1 < 0.0 && d2 < 0.0 && d3 < 0.0) {
                let x = (d1 * cc.x + d2 * a.x + d3 * b.x) / (d1 + d2 + d3);
                if x > 0.0 {
                    n += 1;
                }
            }
        }
        n % 2 == 1
    };
    let mut rng = spherebake_geom::rng::SplitMix64::new(0x1234_5678_9abc_def0);
    let mut next = || rng.next_f64();
    let n = 4_000;
    let mut hits = 0usize;
    let mut drawn = 0usize;
    while drawn < n {
        let q = DVec3::new(next() * 2.0 - 1.0, next() * 2.0 - 1.0, next() * 2.0 - 1.0);
        if q.length_squared() > 1.0 {
            continue;
        }
        drawn += 1;
        if inside(c + q * r) {
            hits += 1;
        }
    }
    let f = hits as f64 / n as f64;
    let vb = ball_volume_f64(r);
    let sigma = vb * (f * (1.0 - f) / n as f64).sqrt();
    let mc = f * vb;
    assert!(exact > 0.05 * vb && exact < 0.95 * vb, "test ball should straddle the surface");
    assert!((exact - mc).abs() <= 5.0 * sigma, "exact {exact} vs MC {mc} ± {sigma}");
}
