//! Shared helpers of the `samples_*` tests: analytic meshes, brute-force references.
#![allow(dead_code)]

use glam::{DVec3, Vec3};
use spherebake_bake::samples::{place_samples, SampleStats};
use spherebake_format::Samples;
use spherebake_geom::bvh::TriangleBvh;
use spherebake_geom::orient::outward_orientation;
use spherebake_geom::winding::WindingNumber;
use spherebake_geom::Mesh;

/// Axis-aligned box, 24 vertices (flat per-face normals), 12 outward counter-clockwise triangles.
pub fn box_mesh(min: Vec3, max: Vec3) -> Mesh {
    let mut m = Mesh::default();
    for a in 0..3 {
        let (u, v) = ((a + 1) % 3, (a + 2) % 3);
        for sign in [1.0f32, -1.0] {
            let mut n = Vec3::ZERO;
            n[a] = sign;
            let base = m.positions.len() as u32;
            for (cu, cv) in [(0, 0), (1, 0), (1, 1), (0, 1)] {
                let mut p = Vec3::ZERO;
                p[a] = if sign > 0.0 { max[a] } else { min[a] };
                p[u] = if cu == 0 { min[u] } else { max[u] };
                p[v] = if cv == 0 { min[v] } else { max[v] };
                m.positions.push(p);
                m.normals.push(n);
            }
            // e_u × e_v = e_a: (0,1,2),(0,2,3) is counter-clockwise seen from +a.
            if sign > 0.0 {
                m.triangles.push([base, base + 1, base + 2]);
                m.triangles.push([base, base + 2, base + 3]);
            } else {
                m.triangles.push([base, base + 2, base + 1]);
                m.triangles.push([base, base + 3, base + 2]);
            }
        }
    }
    finish(m)
}

/// Capsule around the segment (−half, 0, 0)–(half, 0, 0) with radius `r`: `seg` vertices around
/// the x axis, `rows` rows per hemispherical cap, analytic unit vertex normals, welded, outward.
pub fn capsule_mesh(half: f32, r: f32, seg: u32, rows: u32) -> Mesh {
    let mut m = Mesh::default();
    let push = |m: &mut Mesh, p: DVec3, axis: DVec3| {
        m.positions.push(p.as_vec3());
        m.normals.push((p - axis).normalize().as_vec3());
        (m.positions.len() - 1) as u32
    };
    let (h, rr) = (half as f64, r as f64);
    // Ring list from +x pole to −x pole: each ring = (x offset, polar angle from +x).
    let mut rings: Vec<(f64, f64)> = Vec::new();
    for k in 1..=rows {
        rings.push((h, std::f64::consts::FRAC_PI_2 * k as f64 / rows as f64));
    }
    for k in 0..rows {
        rings.push((-h, std::f64::consts::FRAC_PI_2 * (1.0 + k as f64 / rows as f64)));
    }
    let top = push(&mut m, DVec3::new(h + rr, 0.0, 0.0), DVec3::new(h, 0.0, 0.0));
    let mut ring_ids = Vec::new();
    for &(x0, th) in &rings {
        let ids: Vec<u32> = (0..seg)
            .map(|s| {
                let ph = std::f64::consts::TAU * s as f64 / seg as f64;
                let p = DVec3::new(x0 + rr * th.cos(), rr * th.sin() * ph.cos(), rr * th.sin() * ph.sin());
                push(&mut m, p, DVec3::new(x0, 0.0, 0.0))
            })
            .collect();
        ring_ids.push(ids);
    }
    let bottom = push(&mut m, DVec3::new(-h - rr, 0.0, 0.0), DVec3::new(-h, 0.0, 0.0));
    // Orientation: walking φ increases around +x (y→z); outward normal at the +x pole is +x.
    for s in 0..seg {
        let s1 = (s + 1) % seg;
        let first = &ring_ids[0];
        m.triangles.push([top, first[s as usize], first[s1 as usize]]);
        for w in ring_ids.windows(2) {
            let (a, b) = (&w[0], &w[1]);
            m.triangles.push([a[s as usize], b[s as usize], b[s1 as usize]]);
            m.triangles.push([a[s as usize], b[s1 as usize], a[s1 as usize]]);
        }
        let last = ring_ids.last().unwrap();
        m.triangles.push([bottom, last[s1 as usize], last[s as usize]]);
    }
    finish(m)
}

fn finish(mut m: Mesh) -> Mesh {
    m.triangle_materials = vec![0; m.triangles.len()];
    m.rebuild_weld();
    m
}

/// Signed volume Σ a·(b×c)/6 (positive for an outward closed mesh).
pub fn signed_volume(m: &Mesh) -> f64 {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize].as_dvec3());
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

/// The stage as the pipeline runs it: BVH on the unwelded mesh, orientation from the winding
/// number of the welded mesh, then the samples.
pub fn run(mesh: &Mesh, spheres: &[[f32; 4]]) -> (Samples, SampleStats, Vec<bool>) {
    let bvh = TriangleBvh::new(&mesh.positions, &mesh.triangles);
    let welded = mesh.welded_triangles();
    let w = WindingNumber::new(&mesh.welded_positions, &welded);
    let o = outward_orientation(&mesh.welded_positions, &welded, &w);
    let (s, st) = place_samples(mesh, &bvh, &o.flip, spheres);
    (s, st, o.flip)
}

/// Independent segment test: argmin |p − c| / r over spheres, ties to the lowest index, f64.
pub fn argmin_segment(p: DVec3, spheres: &[[f32; 4]]) -> usize {
    let mut best = (0usize, f64::INFINITY);
    for (j, s) in spheres.iter().enumerate() {
        let c = DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64);
        let d = (p - c).length() / s[3] as f64;
        if d < best.1 {
            best = (j, d);
        }
    }
    best.0
}

/// Slab test against a box: `(t_enter, entry normal, t_exit, exit normal)` of the infinite line,
/// `None` when the line misses.
pub fn ray_box(o: DVec3, d: DVec3, min: DVec3, max: DVec3) -> Option<(f64, DVec3, f64, DVec3)> {
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    let (mut nlo, mut nhi) = (DVec3::ZERO, DVec3::ZERO);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < min[a] || o[a] > max[a] {
                return None;
            }
            continue;
        }
        let t0 = (min[a] - o[a]) / d[a];
        let t1 = (max[a] - o[a]) / d[a];
        let mut e = DVec3::ZERO;
        e[a] = 1.0;
        // Entering through the face the ray faces: normal opposite to d along a.
        let (tn, tf, nn, nf) = if t0 < t1 { (t0, t1, -e, e) } else { (t1, t0, e, -e) };
        if tn > lo {
            lo = tn;
            nlo = nn;
        }
        if tf < hi {
            hi = tf;
            nhi = nf;
        }
    }
    (lo < hi).then_some((lo, nlo, hi, nhi))
}

/// Expected outcome for one direction on a convex box (one back-side hit at most, one
/// front-side hit at most): rule and, for a sample, position and normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Expect {
    Sample { rule: u8, position: DVec3, normal: DVec3 },
    Rule2,
    Rule3Empty,
}

/// §8 rules for a convex box, from the slab test alone.
pub fn expect_box(i: usize, spheres: &[[f32; 4]], omega: DVec3, min: DVec3, max: DVec3) -> Expect {
    let s = spheres[i];
    let c = DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64);
    if let Some((_, _, t_exit, n_exit)) = ray_box(c, omega, min, max) {
        if t_exit > 0.0 {
            let p = c + t_exit * omega;
            return if argmin_segment(p, spheres) == i {
                Expect::Sample { rule: 1, position: p, normal: n_exit }
            } else {
                Expect::Rule2
            };
        }
    }
    // No back-side hit along +ω: the entry point along −ω, if any and in the segment.
    if let Some((t_enter, n_enter, _, _)) = ray_box(c, -omega, min, max) {
        if t_enter > 0.0 {
            let p = c - t_enter * omega;
            if argmin_segment(p, spheres) == i {
                return Expect::Sample { rule: 3, position: p, normal: n_enter };
            }
        }
    }
    Expect::Rule3Empty
}

/// Distance from `p` to triangle (a, b, c) (`spherebake_geom::triangle::closest_point_on_triangle`).
pub fn point_triangle_distance(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    p.distance(spherebake_geom::triangle::closest_point_on_triangle(p, &[a, b, c]))
}

/// Directions of §5 as f64 unit vectors, from the shared f32 table.
pub fn directions() -> Vec<DVec3> {
    spherebake_sh::GEODESIC_DIRECTIONS.iter().map(|d| Vec3::from_array(*d).as_dvec3()).collect()
}

/// A simple deterministic sphere set for real models: triangles grouped by centroid on a
/// k×k×k grid over the bounding box, each group's sphere centred at its corners' mean with the
/// radius reaching its farthest corner.
pub fn grid_spheres(mesh: &Mesh, k: u32) -> Vec<[f32; 4]> {
    let (lo, hi) = mesh.bounds().expect("triangles");
    let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
    let ext = (hi - lo).max(DVec3::splat(1e-9));
    let mut groups: std::collections::BTreeMap<u32, Vec<DVec3>> = Default::default();
    for t in 0..mesh.triangles.len() {
        let tri = mesh.triangle(t).map(|p| p.as_dvec3());
        let c = (tri[0] + tri[1] + tri[2]) / 3.0;
        let g = ((c - lo) / ext * k as f64).floor().clamp(DVec3::ZERO, DVec3::splat(k as f64 - 1.0));
        let key = (g.z as u32 * k + g.y as u32) * k + g.x as u32;
        groups.entry(key).or_default().extend(tri);
    }
    groups
        .values()
        .map(|pts| {
            let c = pts.iter().sum::<DVec3>() / pts.len() as f64;
            let r = pts.iter().map(|p| (*p - c).length()).fold(0.0, f64::max);
            [c.x as f32, c.y as f32, c.z as f32, (r * 1.0001 + 1e-6) as f32]
        })
        .collect()
}
