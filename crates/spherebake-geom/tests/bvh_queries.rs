//! TriangleBvh against brute force over all triangles.

mod voxel_support;

use glam::{DVec3, Vec3};
use spherebake_geom::bvh::{Hit, TriangleBvh};
use voxel_support::{icosphere, Rng};

/// Random soup: many small and some large triangles, a few degenerate ones.
fn soup(rng: &mut Rng, n: usize) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut v = Vec::new();
    let mut f = Vec::new();
    for i in 0..n {
        let c = rng.dvec3(-1.0, 1.0);
        let s = if i % 17 == 0 { 1.0 } else { 0.25 };
        let a = c + rng.dvec3(-s, s);
        let b = c + rng.dvec3(-s, s);
        let d = if i % 31 == 0 { a } else { c + rng.dvec3(-s, s) }; // some degenerate
        let base = v.len() as u32;
        v.extend([a, b, d].map(|p| p.as_vec3()));
        f.push([base, base + 1, base + 2]);
    }
    (v, f)
}

/// Brute force with a single-triangle BVH per triangle (same watertight test, no tree).
fn brute_hits(v: &[Vec3], f: &[[u32; 3]], o: Vec3, d: Vec3, t0: f32, t1: f32) -> Vec<Hit> {
    let mut all = Vec::new();
    let mut tmp = Vec::new();
    for (i, t) in f.iter().enumerate() {
        let single = TriangleBvh::new(v, std::slice::from_ref(t));
        single.ray_hits(o, d, t0, t1, &mut tmp);
        all.extend(tmp.iter().map(|h| Hit { triangle: i as u32, ..*h }));
    }
    all.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.triangle.cmp(&b.triangle)));
    all
}

#[test]
fn ray_hits_match_brute_force() {
    let mut rng = Rng::new(1);
    let (v, f) = soup(&mut rng, 600);
    let bvh = TriangleBvh::new(&v, &f);
    assert_eq!(bvh.triangle_count(), f.len());
    let mut hits = Vec::new();
    let mut total = 0;
    for r in 0..400 {
        let o = rng.dvec3(-2.0, 2.0).as_vec3();
        let mut d = (rng.dvec3(-1.0, 1.0).as_vec3()).normalize();
        if r % 10 == 0 {
            d = Vec3::new(0.0, 0.0, if r % 20 == 0 { 1.0 } else { -1.0 }); // axis-aligned
        }
        let (t0, t1) = if r % 3 == 0 { (0.5, 2.5) } else { (0.0, f32::INFINITY) };
        bvh.ray_hits(o, d, t0, t1, &mut hits);
        let want = brute_hits(&v, &f, o, d, t0, t1);
        assert_eq!(hits, want, "ray {r}");
        for h in &hits {
            assert!(h.t > t0 && h.t < t1);
            // Barycentrics reproduce the hit point.
            let [a, b, c] = f[h.triangle as usize].map(|i| v[i as usize]);
            let p = a * (1.0 - h.u - h.v) + b * h.u + c * h.v;
            assert!((p - (o + d * h.t)).length() < 1e-4, "ray {r}");
            assert!(h.u >= 0.0 && h.v >= 0.0 && h.u + h.v <= 1.0 + 1e-6);
        }
        // closest_hit = first of the sorted list.
        assert_eq!(bvh.closest_hit(o, d, t0, t1), want.first().copied(), "ray {r}");
        total += hits.len();
    }
    assert!(total > 200, "rays should hit something: {total}");
}

#[test]
fn closest_hit_ties_go_to_lowest_index() {
    // The same triangle three times (indices 1, 3, 4), plus farther ones.
    let v = vec![
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(-1.0, -1.0, 1.0),
        Vec3::new(1.0, -1.0, 1.0),
        Vec3::new(0.0, 1.0, 1.0),
    ];
    let near = [0, 1, 2];
    let far = [3, 4, 5];
    for order in [[far, near, far, near, near], [near, far, near, near, far]] {
        let f: Vec<[u32; 3]> = order.to_vec();
        let lowest_near = f.iter().position(|t| *t == near).unwrap() as u32;
        let bvh = TriangleBvh::new(&v, &f);
        let h = bvh.closest_hit(Vec3::new(0.0, 0.0, -5.0), Vec3::Z, 0.0, f32::INFINITY).unwrap();
        assert_eq!(h.triangle, lowest_near);
        assert_eq!(h.t, 5.0);
        // From above: the far copies win, lowest index among them.
        let h = bvh.closest_hit(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z, 0.0, f32::INFINITY).unwrap();
        assert_eq!(h.triangle, f.iter().position(|t| *t == far).unwrap() as u32);
        // A t range that excludes the near copies.
        let h = bvh.closest_hit(Vec3::new(0.0, 0.0, -5.0), Vec3::Z, 5.5, f32::INFINITY).unwrap();
        assert_eq!(h.t, 6.0);
        let mut hits = Vec::new();
        bvh.ray_hits(Vec3::new(0.0, 0.0, -5.0), Vec3::Z, 0.0, f32::INFINITY, &mut hits);
        let tris: Vec<u32> = hits.iter().map(|h| h.triangle).collect();
        let mut want: Vec<u32> = (0..5).filter(|&i| f[i as usize] == near).collect();
        want.extend((0..5).filter(|&i| f[i as usize] == far));
        assert_eq!(tris, want);
    }
}

#[test]
fn watertight_through_vertices_and_edges() {
    // Rays from the centre of a closed icosphere through every vertex and edge midpoint must hit.
    let (v, f) = icosphere(2, Vec3::new(0.3, -0.2, 0.1), 1.5);
    let bvh = TriangleBvh::new(&v, &f);
    let c = Vec3::new(0.3, -0.2, 0.1);
    let mut targets: Vec<Vec3> = v.clone();
    for t in &f {
        for e in 0..3 {
            targets.push((v[t[e] as usize] + v[t[(e + 1) % 3] as usize]) * 0.5);
        }
    }
    for p in targets {
        assert!(bvh.closest_hit(c, p - c, 0.0, f32::INFINITY).is_some(), "leaked through {p}");
    }
}

/// Exact squared distance from a point to a triangle (`spherebake_geom::triangle::closest_point_on_triangle`).
fn point_triangle_dist2(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    p.distance_squared(spherebake_geom::triangle::closest_point_on_triangle(p, &[a, b, c]))
}

#[test]
fn sphere_and_box_queries_match_brute_force() {
    let mut rng = Rng::new(5);
    let (v, f) = soup(&mut rng, 800);
    let bvh = TriangleBvh::new(&v, &f);
    let mut out = Vec::new();
    let bbox = |t: &[u32; 3]| {
        let p = t.map(|i| v[i as usize]);
        (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]))
    };
    for q in 0..300 {
        let c = rng.dvec3(-1.5, 1.5);
        let r = rng.range(0.0, 0.6) as f32;
        bvh.triangles_near_sphere(c.as_vec3(), r, &mut out);
        assert!(out.windows(2).all(|w| w[0] < w[1]), "sorted, unique");
        let cf = c.as_vec3().as_dvec3();
        for (i, t) in f.iter().enumerate() {
            let [a, b, cc] = t.map(|k| v[k as usize].as_dvec3());
            let touches = point_triangle_dist2(cf, a, b, cc) <= (r as f64).powi(2);
            if touches {
                assert!(out.binary_search(&(i as u32)).is_ok(), "query {q}: missing triangle {i}");
            }
            // Exactly the bounding-box criterion (away from round-off).
            let (mn, mx) = bbox(t);
            let d2 = (cf - cf.clamp(mn.as_dvec3(), mx.as_dvec3())).length_squared();
            let rr = (r as f64).powi(2);
            if d2 < rr * (1.0 - 1e-6) {
                assert!(out.binary_search(&(i as u32)).is_ok());
            } else if d2 > rr * (1.0 + 1e-6) {
                assert!(out.binary_search(&(i as u32)).is_err(), "query {q}: extra triangle {i}");
            }
        }
        let lo = rng.dvec3(-1.5, 1.0).as_vec3();
        let hi = lo + rng.dvec3(0.0, 0.8).as_vec3();
        bvh.triangles_in_aabb(lo, hi, &mut out);
        let want: Vec<u32> = (0..f.len() as u32)
            .filter(|&i| {
                let (mn, mx) = bbox(&f[i as usize]);
                mn.cmple(hi).all() && mx.cmpge(lo).all()
            })
            .collect();
        assert_eq!(out, want, "box query {q}");
    }
}

#[test]
fn invalid_input_never_panics() {
    let v = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(f32::NAN, 0.0, 0.0)];
    let f = vec![[0, 1, 2], [0, 1, 99], [0, 1, 3], [0, 0, 0]];
    let bvh = TriangleBvh::new(&v, &f);
    let mut hits = Vec::new();
    bvh.ray_hits(Vec3::new(0.2, 0.2, -1.0), Vec3::Z, 0.0, f32::INFINITY, &mut hits);
    assert_eq!(hits.iter().map(|h| h.triangle).collect::<Vec<_>>(), vec![0]);
    let mut out = Vec::new();
    bvh.triangles_in_aabb(Vec3::splat(-10.0), Vec3::splat(10.0), &mut out);
    assert_eq!(out, vec![0, 3]); // the degenerate one is kept (its box is a point), invalid ones are not
    assert!(bvh.closest_hit(Vec3::ZERO, Vec3::ZERO, 0.0, 1.0).is_none());
    assert!(bvh.closest_hit(Vec3::splat(f32::NAN), Vec3::Z, 0.0, 1.0).is_none());
    let empty = TriangleBvh::new(&[], &[]);
    assert!(empty.closest_hit(Vec3::ZERO, Vec3::Z, 0.0, 1.0).is_none());
    empty.triangles_near_sphere(Vec3::ZERO, 1.0, &mut out);
    assert!(out.is_empty());
}

#[test]
fn closest_hit_ties_after_f32_rounding() {
    // Triangle 0 lies one f32 ulp behind triangle 1; seen from z = −5 both hits round to t = 6.0
    // in f32, so the lower index (0, the farther one in f64) must win. Filler triangles, among
    // them more near-ties, put the candidates in different parts of the tree.
    let z_far = f32::from_bits(1.0f32.to_bits() + 1);
    let quad =
        |z: f32, dx: f32| vec![Vec3::new(-1.0 + dx, -1.0, z), Vec3::new(1.0 + dx, -1.0, z), Vec3::new(dx, 1.0, z)];
    for seed in 0..40 {
        let mut rng = Rng::new(seed);
        let mut v = quad(z_far, 0.05 * (seed % 10) as f32 - 0.2);
        let mut f = vec![[0, 1, 2]];
        for _ in 0..300 {
            let c = rng.dvec3(-3.0, 3.0).as_vec3();
            let base = v.len() as u32;
            v.extend([c, c + Vec3::new(0.1, 0.0, 0.0), c + Vec3::new(0.0, 0.1, 0.05)]);
            f.push([base, base + 1, base + 2]);
        }
        for k in 0..40 {
            let base = v.len() as u32;
            v.extend(quad(1.0, 0.02 * k as f32 - 0.4));
            f.push([base, base + 1, base + 2]);
        }
        let o = Vec3::new(0.01, 0.02, -5.0);
        let want = brute_hits(&v, &f, o, Vec3::Z, 0.0, f32::INFINITY);
        assert_eq!((want[0].t, want[0].triangle), (6.0, 0));
        let bvh = TriangleBvh::new(&v, &f);
        assert_eq!(bvh.closest_hit(o, Vec3::Z, 0.0, f32::INFINITY), Some(want[0]), "seed {seed}");
    }
}
