//! Surface tiles (`spherebake_runtime::tile`): the Voronoi cells of the 92 directions, Lambert's polygon irradiance
//! against an analytic rectangle formula and a brute-force hemisphere quadrature, and tiles of a plane seen from
//! just under it.

use spherebake_runtime::tile::{
    polygon_area, polygon_irradiance, sample_tile, scale_tile_to_area, voronoi_cells, SampleTile, CELL_MAX_CORNERS,
};
use spherebake_runtime::GEODESIC_DIRECTIONS;
use spherebake_testkit::oracle::triangle_solid_angle;
use std::f64::consts::PI;

fn dir(j: usize) -> [f64; 3] {
    let d = GEODESIC_DIRECTIONS[j].map(f64::from);
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    d.map(|v| v / l)
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

#[test]
fn voronoi_cells_are_the_geodesic_dual() {
    let cells = voronoi_cells();
    assert_eq!(cells.len(), 92);
    let pentagons = cells.iter().filter(|c| c.count == 5).count();
    let hexagons = cells.iter().filter(|c| c.count == 6).count();
    // A geodesic sphere's dual: 12 pentagons (the icosahedron's vertices, directions 0–11) and 80 hexagons.
    assert_eq!((pentagons, hexagons), (12, 80));
    assert!(cells[..12].iter().all(|c| c.count == 5));
    let mut total = 0.0;
    for (j, cell) in cells.iter().enumerate() {
        let d = dir(j);
        for k in 0..cell.count {
            let m = cell.corners[k];
            // Each corner is equidistant from ω_j and from at least two other directions, and no direction is
            // nearer to it (a Voronoi vertex).
            let own = dot(m, d);
            let ties = (0..92).filter(|&i| i != j && (dot(m, dir(i)) - own).abs() < 1e-9).count();
            assert!(ties >= 2, "direction {j} corner {k}: {ties} ties");
            assert!((0..92).all(|i| dot(m, dir(i)) <= own + 1e-9));
            // Counter-clockwise about ω_j, and convex.
            let next = cell.corners[(k + 1) % cell.count];
            assert!(dot(d, cross(m, next)) > 0.0, "direction {j}: corners not counter-clockwise");
            total += triangle_solid_angle(d, m, next);
        }
        assert!(cell.corners[cell.count..].iter().all(|c| *c == [0.0; 3]));
    }
    // The cells tile the sphere.
    assert!((total - 4.0 * PI).abs() < 1e-9, "cells cover {total} sr");
}

/// Projected solid angle of an a × b rectangle parallel to the receiver's plane at height h, the receiver under one
/// corner (the standard configuration factor, e.g. Howell's catalogue C-11, times π).
fn rectangle_corner(a: f64, b: f64, h: f64) -> f64 {
    let (x, y) = (a / h, b / h);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    0.5 * (x / sx * (y / sx).atan() + y / sy * (x / sy).atan())
}

#[test]
fn polygon_irradiance_matches_the_rectangle_formula() {
    let n = [0.0, 1.0, 0.0];
    for &(a, b, h) in &[(1.0, 1.0, 1.0), (0.3, 2.0, 0.5), (5.0, 0.1, 0.01), (1e3, 1e3, 1e-3)] {
        // Under a corner of the rectangle [0, a] × [0, b] at height h.
        let rect = [[0.0, h, 0.0], [a, h, 0.0], [a, h, b], [0.0, h, b]];
        let got = polygon_irradiance([0.0; 3], n, &rect);
        let want = rectangle_corner(a, b, h);
        assert!((got - want).abs() < 1e-9 * want.max(1.0), "a {a} b {b} h {h}: {got} vs {want}");
        // Under its centre: four corner rectangles; the winding does not matter.
        let centred: Vec<[f64; 3]> = rect.iter().rev().map(|c| [c[0] - 0.5 * a, c[1], c[2] - 0.5 * b]).collect();
        let got = polygon_irradiance([0.0; 3], n, &centred);
        let want = 4.0 * rectangle_corner(0.5 * a, 0.5 * b, h);
        assert!((got - want).abs() < 1e-9 * want.max(1.0), "centred a {a} b {b} h {h}: {got} vs {want}");
    }
    // A huge square just above the receiver fills its hemisphere: π.
    let big = [[-1e6, 1e-6, -1e6], [1e6, 1e-6, -1e6], [1e6, 1e-6, 1e6], [-1e6, 1e-6, 1e6]];
    assert!((polygon_irradiance([0.0; 3], n, &big) - PI).abs() < 1e-6);
    // Entirely below the horizon: nothing; degenerate input: nothing.
    let below = big.map(|c| [c[0], -1.0, c[2]]);
    assert_eq!(polygon_irradiance([0.0; 3], n, &below), 0.0);
    assert_eq!(polygon_irradiance([0.0; 3], n, &big[..2]), 0.0);
    assert_eq!(polygon_irradiance([f64::NAN; 3], n, &big), 0.0);
}

/// ∫ cos θ over the directions of the upper hemisphere of `n` = +Y whose ray from the origin crosses the convex
/// planar polygon, by a midpoint rule in (cos² θ, φ) (uniform in projected solid angle).
fn brute_force(poly: &[[f64; 3]]) -> f64 {
    let (nu, nphi) = (1500usize, 1500usize);
    let normal = cross([poly[1][0] - poly[0][0], poly[1][1] - poly[0][1], poly[1][2] - poly[0][2]], {
        let e = poly[2];
        [e[0] - poly[0][0], e[1] - poly[0][1], e[2] - poly[0][2]]
    });
    let mut hits = 0usize;
    for i in 0..nu {
        let u = (i as f64 + 0.5) / nu as f64; // sin² θ
        let (st, ct) = (u.sqrt(), (1.0 - u).sqrt());
        for k in 0..nphi {
            let phi = 2.0 * PI * (k as f64 + 0.5) / nphi as f64;
            let w = [st * phi.cos(), ct, st * phi.sin()];
            let den = dot(normal, w);
            if den.abs() < 1e-15 {
                continue;
            }
            let t = dot(normal, poly[0]) / den;
            if t <= 0.0 {
                continue;
            }
            let x = w.map(|v| v * t);
            // Inside the convex polygon: the same side of every edge.
            let mut sign = 0.0f64;
            let mut inside = true;
            for e in 0..poly.len() {
                let (a, b) = (poly[e], poly[(e + 1) % poly.len()]);
                let s = dot(
                    normal,
                    cross([b[0] - a[0], b[1] - a[1], b[2] - a[2]], [x[0] - a[0], x[1] - a[1], x[2] - a[2]]),
                );
                if sign == 0.0 {
                    sign = s.signum();
                } else if s * sign < 0.0 {
                    inside = false;
                    break;
                }
            }
            if inside {
                hits += 1;
            }
        }
    }
    PI * hits as f64 / (nu * nphi) as f64
}

#[test]
fn polygon_irradiance_matches_brute_force_across_the_horizon() {
    // Tilted hexagons that cross the receiver's horizon (clipped) or stand above it.
    let cases: [([f64; 3], [f64; 3], f64); 3] = [
        ([0.3, 0.2, 0.1], [0.6, 0.3, 0.74], 0.5),
        ([0.0, 0.6, 0.0], [0.1, -1.0, 0.05], 0.4),
        ([-0.5, 0.05, 0.4], [0.7, 0.7, 0.1], 0.3),
    ];
    for (centre, normal, radius) in cases {
        let l = dot(normal, normal).sqrt();
        let nn = normal.map(|v| v / l);
        let e1 = {
            let c = cross(nn, [0.0, 0.0, 1.0]);
            let cl = dot(c, c).sqrt();
            c.map(|v| v / cl)
        };
        let e2 = cross(nn, e1);
        let hex: Vec<[f64; 3]> = (0..6)
            .map(|k| {
                let a = PI / 3.0 * k as f64;
                [0, 1, 2].map(|q| centre[q] + radius * (a.cos() * e1[q] + a.sin() * e2[q]))
            })
            .collect();
        let got = polygon_irradiance([0.0; 3], [0.0, 1.0, 0.0], &hex);
        let want = brute_force(&hex);
        assert!(want > 0.01, "case {centre:?}: degenerate test");
        assert!((got - want).abs() < 3e-3 * want.max(0.1), "case {centre:?}: {got} vs brute force {want}");
    }
}

#[test]
fn tiles_of_a_plane_fill_the_view_from_just_under_it() {
    // A sphere centred at the origin over the plane y = −1 (outward normal −Y): every direction with ω_y < 0 has its
    // sample where its ray meets the plane. From just under the plane below the centre, the tiles cover the view
    // without gaps or overlaps where their corners lie on the plane; near the horizon the capped corners leave the
    // plane (measured: the sum is 1.003 π), so the sum is π within 1 %.
    let cells = voronoi_cells();
    let (centre, radius) = ([0.0; 3], 10.0);
    let receiver = [0.0, -1.0 - 1e-4, 0.0];
    let mut total = 0.0;
    for (j, cell) in cells.iter().enumerate() {
        let d = dir(j);
        if d[1] >= -1e-9 {
            continue;
        }
        let t = -1.0 / d[1];
        let x = d.map(|v| v * t);
        let mut tile = [[0.0; 3]; CELL_MAX_CORNERS];
        let k = sample_tile(cell, centre, radius, x, [0.0, -1.0, 0.0], &mut tile);
        assert!(tile[..k].iter().all(|c| (c[1] + 1.0).abs() < 1e-9 || (c[0] * c[0] + c[2] * c[2]).sqrt() > 1.0));
        total += polygon_irradiance(receiver, [0.0, 1.0, 0.0], &tile[..k]).max(0.0);
    }
    assert!(total <= PI * 1.01, "overlap: {total}");
    assert!(total > 0.99 * PI, "gaps: {total} of {PI}");
    // A sample on the centre or a non-finite one gives no tile.
    let mut tile = [[0.0; 3]; CELL_MAX_CORNERS];
    assert_eq!(sample_tile(&cells[0], centre, radius, centre, [0.0, 1.0, 0.0], &mut tile), 0);
    assert_eq!(sample_tile(&cells[0], centre, radius, [f64::NAN; 3], [0.0, 1.0, 0.0], &mut tile), 0);
}

#[test]
fn a_sample_tile_emits_on_its_front_side_and_saturates_near_its_plane() {
    use spherebake_runtime::tile::TILE_MIN_HEIGHT;
    let cells = voronoi_cells();
    // The sample straight below the centre of a unit sphere, on the plane y = −1 (outward normal −Y).
    let j = (0..92).min_by(|&a, &b| dir(a)[1].total_cmp(&dir(b)[1])).unwrap();
    let x = dir(j);
    let nrm = [0.0, -1.0, 0.0];
    let h_plane = -x[1]; // the plane through x, perpendicular to Y
    let at = |h: f64| {
        SampleTile { cell: &cells[j], radius: 1.0, x, normal: nrm, area: None }
            .irradiance([x[0], -(h_plane + h), x[2]], [0.0, 1.0, 0.0])
    };
    // Behind the plane (inside the object): nothing.
    assert_eq!(
        SampleTile { cell: &cells[j], radius: 1.0, x, normal: nrm, area: None }
            .irradiance([x[0], 0.0, x[2]], [0.0, 1.0, 0.0]),
        0.0
    );
    // Closer than h_min it is evaluated at h_min: the same value all the way to the plane.
    let h_min = TILE_MIN_HEIGHT * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
    let v = at(h_min);
    assert!(v > 0.1 && v < PI, "{v}");
    for h in [1e-9, 1e-3, 0.5 * h_min] {
        assert!((at(h) - v).abs() < 1e-12, "h {h}: {} vs {v}", at(h));
    }
    // Farther out it falls, as the tile covers less of the view; and at h ≥ h_min it is the tile's exact
    // polygon irradiance.
    assert!(at(2.0 * h_min) < v && at(4.0 * h_min) < at(2.0 * h_min));
    let mut tile = [[0.0; 3]; CELL_MAX_CORNERS];
    let k = sample_tile(&cells[j], [0.0; 3], 1.0, x, nrm, &mut tile);
    let p = [x[0], -(h_plane + 2.0 * h_min), x[2]];
    assert_eq!(at(2.0 * h_min), polygon_irradiance(p, [0.0, 1.0, 0.0], &tile[..k]));
    // Beside the tile (its foot point on the plane beyond every corner), near the plane's extension: not moved.
    let reach = tile[..k].iter().map(|c| ((c[0] - x[0]).powi(2) + (c[2] - x[2]).powi(2)).sqrt()).fold(0.0, f64::max);
    let beside = [x[0] + 1.5 * reach, -(h_plane + 1e-3), x[2]];
    let got =
        SampleTile { cell: &cells[j], radius: 1.0, x, normal: nrm, area: None }.irradiance(beside, [-1.0, 0.0, 0.0]);
    assert_eq!(got, polygon_irradiance(beside, [-1.0, 0.0, 0.0], &tile[..k]));
    assert!(got > 0.0);
}

#[test]
fn polygon_area_of_known_shapes() {
    // A unit square in a tilted plane, and a regular hexagon of side 0.3: 3√3/2 · s².
    let (u, v) = ([0.6, 0.8, 0.0], [0.0, 0.0, 1.0]);
    let sq: Vec<[f64; 3]> = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
        .iter()
        .map(|&(a, b)| [2.0 + a * u[0] + b * v[0], a * u[1] + b * v[1], a * u[2] + b * v[2] - 1.0])
        .collect();
    assert!((polygon_area(&sq) - 1.0).abs() < 1e-12);
    let hex: Vec<[f64; 3]> = (0..6)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / 6.0;
            [0.3 * a.cos(), 0.3 * a.sin(), 5.0]
        })
        .collect();
    assert!((polygon_area(&hex) - 1.5 * 3f64.sqrt() * 0.09).abs() < 1e-12);
    assert_eq!(polygon_area(&hex[..2]), 0.0);
}

#[test]
fn a_tile_scaled_to_an_area_has_it_and_emits_in_proportion_far_away() {
    let cells = voronoi_cells();
    let j = 40;
    let w = dir(j);
    let x = w.map(|c| 0.8 * c);
    // A normal tilted away from the direction, so the tile is not a scaled cell.
    let t = [w[0] + 0.3, w[1] - 0.2, w[2] + 0.1];
    let l = dot(t, t).sqrt();
    let n = t.map(|c| c / l);
    let mut tile = [[0.0f64; 3]; CELL_MAX_CORNERS];
    let k = sample_tile(&cells[j], [0.0; 3], 1.0, x, n, &mut tile);
    let natural = polygon_area(&tile[..k]);
    for target in [0.2 * natural, 3.0 * natural, 0.0] {
        let mut scaled = tile;
        scale_tile_to_area(&mut scaled[..k], x, Some(target));
        assert!((polygon_area(&scaled[..k]) - target).abs() < 1e-12, "{target}");
        // Still in the tile's plane, about the sample.
        for c in &scaled[..k] {
            assert!(dot([c[0] - x[0], c[1] - x[1], c[2] - x[2]], n).abs() < 1e-12);
        }
    }
    // Far along the normal, a small tile's irradiance is A / d² (cosines 1): areas in proportion.
    let d = 200.0;
    let p = [x[0] + d * n[0], x[1] + d * n[1], x[2] + d * n[2]];
    let facing = n.map(|c| -c);
    let e1 = SampleTile { cell: &cells[j], radius: 1.0, x, normal: n, area: Some(natural) }.irradiance(p, facing);
    let e3 = SampleTile { cell: &cells[j], radius: 1.0, x, normal: n, area: Some(3.0 * natural) }.irradiance(p, facing);
    let none = SampleTile { cell: &cells[j], radius: 1.0, x, normal: n, area: None }.irradiance(p, facing);
    assert!((e1 / (natural / (d * d)) - 1.0).abs() < 1e-3, "{e1} vs {}", natural / (d * d));
    // 3 up to the tile's finite size seen from 200 (measured 3 − 4.5e-6).
    assert!((e3 / e1 - 3.0).abs() < 2e-5, "{}", e3 / e1);
    assert!((none / e1 - 1.0).abs() < 1e-12, "no area: the tile's own");
}

#[test]
fn cell_solid_angles_sum_to_the_sphere_and_match_a_lattice_count() {
    let cells = voronoi_cells();
    let omega: Vec<f64> =
        cells.iter().enumerate().map(|(j, c)| spherebake_runtime::tile::cell_solid_angle(c, j)).collect();
    let total: f64 = omega.iter().sum();
    assert!((total - 4.0 * PI).abs() < 1e-9, "{total}");
    // Independent: nearest-direction counts over a Fibonacci lattice of 200 000 equal-area points.
    let n = 200_000;
    let mut count = [0usize; 92];
    let golden = PI * (3.0 - 5f64.sqrt());
    for i in 0..n {
        let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
        let r = (1.0 - z * z).sqrt();
        let p = [r * (golden * i as f64).cos(), r * (golden * i as f64).sin(), z];
        let best = (0..92).max_by(|&a, &b| dot(p, dir(a)).total_cmp(&dot(p, dir(b)))).unwrap();
        count[best] += 1;
    }
    for j in 0..92 {
        let want = 4.0 * PI * count[j] as f64 / n as f64;
        assert!((omega[j] / want - 1.0).abs() < 0.01, "cell {j}: {} vs {want}", omega[j]);
    }
}
