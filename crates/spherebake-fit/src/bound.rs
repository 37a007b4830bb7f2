//! Makes a sphere set *exactly* bounding, after rounding to the f32 values that are stored.
//!
//! Rules (all containment tests use the stored f32 centre and radius widened to f64, with a
//! relative safety margin of 1e-12 on r², so rounding inside the test cannot flip a verdict):
//!
//! 1. **Surface.** Every triangle is partitioned into pieces (4-way midpoint splits where a
//!    triangle is large next to the sphere that would have to grow), each inside one sphere:
//!    a triangle piece lies in a ball iff its three corners do (convexity). An uncovered piece
//!    grows the sphere whose volume grows least, to the next f32 radius that passes the test.
//! 2. **Interior points.** Every interior lattice point (a lattice corner inside the solid)
//!    lies in some sphere, grown the same way.
//! 3. **No pockets.** A point x of the solid T outside the union U lies in a bounded component
//!    C of R³∖U inside T (C cannot meet ∂T ⊂ U). On the closure of C the power function
//!    f(x) = min_i (|x − c_i|² − r_i²) is 0 on ∂C and positive inside; it is strictly convex
//!    on each power cell, face and edge, so its maximum is at a power-diagram vertex v: the
//!    point with equal power p > 0 to four spheres. By rules 1–2 every point of T has a covered
//!    point within δ (lattice cell diagonal plus a solid-cell diagonal), so p ≤ P =
//!    2 r_max δ + δ², and v lies in all four "inflated" balls of radius √(r² + P). We
//!    enumerate all cliques of four pairwise-intersecting inflated balls, solve for v, and
//!    where v is uncovered and inside T (voxel solid far from the surface, generalised
//!    winding number ≥ ½ near it), grow the cheapest sphere over v; repeat until no such
//!    vertex remains. Degenerate vertices (four coplanar centres) are skipped.

use glam::DVec3;
use rayon::prelude::*;

/// A stored sphere: centre xyz and radius, f32, model space.
pub type Sphere32 = [f32; 4];

const MARGIN: f64 = 1.0 - 1e-12;

#[inline]
pub fn contains(s: &Sphere32, p: DVec3) -> bool {
    let c = DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64);
    let r = s[3] as f64;
    p.distance_squared(c) <= r * r * MARGIN
}

fn next_up(x: f32) -> f32 {
    if x <= 0.0 {
        f32::from_bits(1)
    } else {
        f32::from_bits(x.to_bits() + 1)
    }
}

/// Smallest f32 radius ≥ current with which `s` contains every point in `ps`.
fn grow(s: &mut Sphere32, ps: &[DVec3]) {
    let c = DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64);
    let need = ps.iter().map(|p| p.distance(c)).fold(0.0f64, f64::max);
    let mut r = (need as f32).max(s[3]);
    while !ps.iter().all(|p| p.distance_squared(c) <= (r as f64) * (r as f64) * MARGIN) {
        r = next_up(r);
    }
    s[3] = r;
}

fn growth_cost(s: &Sphere32, ps: &[DVec3]) -> f64 {
    let c = DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64);
    let need = ps.iter().map(|p| p.distance(c)).fold(0.0f64, f64::max);
    let r = s[3] as f64;
    if need <= r {
        0.0
    } else {
        need * need * need - r * r * r
    }
}

fn cheapest(spheres: &[Sphere32], ps: &[DVec3], weights: &[f64]) -> usize {
    let mut best = (f64::INFINITY, 0usize);
    for (i, s) in spheres.iter().enumerate() {
        let g = growth_cost(s, ps) * weights.get(i).copied().unwrap_or(1.0);
        if g < best.0 {
            best = (g, i);
        }
    }
    best.1
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BoundReport {
    /// Triangle pieces that needed a sphere to grow.
    pub grown_pieces: usize,
    /// Triangles that were split into pieces.
    pub split_triangles: usize,
    /// Interior points that needed a sphere to grow.
    pub grown_points: usize,
    /// Power-diagram pockets inside the solid that were closed.
    pub pockets_closed: usize,
    /// Candidate power vertices examined in the last pocket round.
    pub pocket_candidates: usize,
}

pub struct BoundInput<'a> {
    pub positions: &'a [DVec3],
    pub triangles: &'a [[u32; 3]],
    pub interior: &'a [DVec3],
    /// Covering distance δ of rule 3, model units.
    pub delta: f64,
    /// Inside test for T (rule 3).
    pub inside: &'a (dyn Fn(DVec3) -> bool + Sync),
    /// Per-sphere multiplier of the growth cost (volume added), e.g. the share of a thin shell
    /// around the sphere that lies outside T, so growth goes where it adds least outside
    /// volume. Empty: all 1.
    pub weights: &'a [f64],
}

fn covered_piece(spheres: &[Sphere32], t: &[DVec3; 3]) -> bool {
    spheres.iter().any(|s| t.iter().all(|p| contains(s, *p)))
}

fn cover_piece(spheres: &mut [Sphere32], t: [DVec3; 3], depth: u32, rep: &mut BoundReport, weights: &[f64]) {
    if covered_piece(spheres, &t) {
        return;
    }
    let i = cheapest(spheres, &t, weights);
    let l = (t[1] - t[0]).length().max((t[2] - t[1]).length()).max((t[0] - t[2]).length());
    // Splitting is free (no sphere grows), so split down to pieces small next to the sphere
    // that would grow before growing anything.
    // `depth` counts half levels: a four-way split halves every edge (+2), a sliver bisection
    // halves one (+1), so both reach the same piece sizes.
    if depth < 20 && (depth < 10 || l > 0.02 * spheres[i][3] as f64) {
        if depth == 0 {
            rep.split_triangles += 1;
        }
        // A sliver (longest edge² over twice the area above 30) is bisected across its longest
        // edge: two pieces per level instead of four, so a fan of slivers costs pieces in
        // proportion to its length, not its length squared (issue 17). Other triangles split
        // into four as before.
        let area2 = (t[1] - t[0]).cross(t[2] - t[0]).length();
        if l * l > 30.0 * area2 {
            let e = [(t[1] - t[0]).length(), (t[2] - t[1]).length(), (t[0] - t[2]).length()];
            let k = if e[0] >= e[1] && e[0] >= e[2] {
                0
            } else if e[1] >= e[2] {
                1
            } else {
                2
            };
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let m = (a + b) * 0.5;
            for piece in [[a, m, c], [m, b, c]] {
                cover_piece(spheres, piece, depth + 1, rep, weights);
            }
            return;
        }
        let m01 = (t[0] + t[1]) * 0.5;
        let m12 = (t[1] + t[2]) * 0.5;
        let m20 = (t[2] + t[0]) * 0.5;
        for piece in [[t[0], m01, m20], [m01, t[1], m12], [m20, m12, t[2]], [m01, m12, m20]] {
            cover_piece(spheres, piece, depth + 2, rep, weights);
        }
        return;
    }
    grow(&mut spheres[i], &t);
    rep.grown_pieces += 1;
}

/// Rounds `spheres` (f64 centre, radius) to f32 and grows radii until rules 1–3 hold.
pub fn make_bounding(spheres: &[(DVec3, f64)], input: &BoundInput) -> (Vec<Sphere32>, BoundReport) {
    let mut out: Vec<Sphere32> =
        spheres.iter().map(|(c, r)| [c.x as f32, c.y as f32, c.z as f32, (*r as f32).max(0.0)]).collect();
    let mut rep = BoundReport::default();
    if out.is_empty() {
        return (out, rep);
    }
    let corners = |t: &[u32; 3]| -> [DVec3; 3] {
        [input.positions[t[0] as usize], input.positions[t[1] as usize], input.positions[t[2] as usize]]
    };
    // Rule 1.
    let uncovered: Vec<u32> = {
        let o = &out;
        input
            .triangles
            .par_iter()
            .enumerate()
            .filter(|(_, t)| !covered_piece(o, &corners(t)))
            .map(|(i, _)| i as u32)
            .collect()
    };
    for ti in uncovered {
        cover_piece(&mut out, corners(&input.triangles[ti as usize]), 0, &mut rep, input.weights);
    }
    // Rule 2.
    let uncovered: Vec<u32> = {
        let o = &out;
        input
            .interior
            .par_iter()
            .enumerate()
            .filter(|(_, p)| !o.iter().any(|s| contains(s, **p)))
            .map(|(i, _)| i as u32)
            .collect()
    };
    for pi in uncovered {
        let p = [input.interior[pi as usize]];
        if out.iter().any(|s| contains(s, p[0])) {
            continue;
        }
        let i = cheapest(&out, &p, input.weights);
        grow(&mut out[i], &p);
        rep.grown_points += 1;
    }
    // Rule 3.
    for _round in 0..64 {
        let found = pocket_vertices(&out, input, &mut rep);
        if found.is_empty() {
            break;
        }
        for (v, p) in found {
            if out.iter().any(|s| contains(s, v)) {
                continue;
            }
            // Cover v with a little room (a quarter of its orthogonal radius) so the pocket
            // closes in few rounds.
            let i = cheapest(&out, &[v], input.weights);
            let c = DVec3::new(out[i][0] as f64, out[i][1] as f64, out[i][2] as f64);
            let dir = (v - c).normalize_or_zero();
            grow(&mut out[i], &[v, v + dir * 0.25 * p.sqrt()]);
            rep.pockets_closed += 1;
        }
    }
    (out, rep)
}

/// Uncovered power vertices inside T with power ≤ P (rule 3), as (vertex, power).
fn pocket_vertices(s: &[Sphere32], input: &BoundInput, rep: &mut BoundReport) -> Vec<(DVec3, f64)> {
    let n = s.len();
    if n < 4 {
        return Vec::new();
    }
    let c: Vec<DVec3> = s.iter().map(|x| DVec3::new(x[0] as f64, x[1] as f64, x[2] as f64)).collect();
    let r: Vec<f64> = s.iter().map(|x| x[3] as f64).collect();
    let rmax = r.iter().cloned().fold(0.0, f64::max);
    let d = input.delta;
    let pmax = 2.0 * rmax * d + d * d;
    let rin: Vec<f64> = r.iter().map(|x| (x * x + pmax).sqrt()).collect();
    let words = n.div_ceil(64);
    let mut adj = vec![0u64; n * words];
    for i in 0..n {
        for j in 0..n {
            if i != j && c[i].distance(c[j]) < rin[i] + rin[j] {
                adj[i * words + j / 64] |= 1 << (j % 64);
            }
        }
    }
    let bits = |row: &[u64], lo: usize| -> Vec<usize> {
        let mut v = Vec::new();
        for (w, &word) in row.iter().enumerate() {
            let mut x = word;
            while x != 0 {
                let b = x.trailing_zeros() as usize;
                x &= x - 1;
                let idx = w * 64 + b;
                if idx > lo {
                    v.push(idx);
                }
            }
        }
        v
    };
    // Enumerate 4-cliques i < j < k < l in parallel over i (ordered collect).
    let cand: Vec<(DVec3, f64)> = (0..n)
        .into_par_iter()
        .flat_map_iter(|i| {
            let mut found = Vec::new();
            let ri = &adj[i * words..(i + 1) * words];
            for j in bits(ri, i) {
                let rij: Vec<u64> = (0..words).map(|w| ri[w] & adj[j * words + w]).collect();
                for k in bits(&rij, j) {
                    let rijk: Vec<u64> = (0..words).map(|w| rij[w] & adj[k * words + w]).collect();
                    for l in bits(&rijk, k) {
                        let Some(v) = power_vertex([c[i], c[j], c[k], c[l]], [r[i], r[j], r[k], r[l]]) else {
                            continue;
                        };
                        let p = v.distance_squared(c[i]) - r[i] * r[i];
                        if p <= 0.0 || p > pmax {
                            continue;
                        }
                        // Only genuine power-diagram vertices can be pocket maxima: no sphere
                        // may have lower power at v than the four defining ones (with a
                        // rounding allowance), and none may contain v.
                        let tol = 1e-9 * (p + r[i] * r[i]);
                        let genuine = s
                            .iter()
                            .zip(&c)
                            .zip(&r)
                            .all(|((x, cx), rx)| !contains(x, v) && v.distance_squared(*cx) - rx * rx >= p - tol);
                        if genuine {
                            found.push((v, p));
                        }
                    }
                }
            }
            found
        })
        .collect();
    rep.pocket_candidates = cand.len();
    let inside: Vec<bool> = cand.par_iter().map(|(v, _)| (input.inside)(*v)).collect();
    cand.into_iter().zip(inside).filter(|x| x.1).map(|x| x.0).collect()
}

fn power_vertex(c: [DVec3; 4], r: [f64; 4]) -> Option<DVec3> {
    let d1 = c[1] - c[0];
    let d2 = c[2] - c[0];
    let d3 = c[3] - c[0];
    let rhs = |d: DVec3, rr: f64| 0.5 * (d.length_squared() - rr * rr + r[0] * r[0]);
    let b = DVec3::new(rhs(d1, r[1]), rhs(d2, r[2]), rhs(d3, r[3]));
    let det = d1.dot(d2.cross(d3));
    let scale = d1.length() * d2.length() * d3.length();
    if det.abs() <= 1e-12 * scale || !det.is_finite() {
        return None;
    }
    // Rows d1, d2, d3: x = (b1 (d2×d3) + b2 (d3×d1) + b3 (d1×d2)) / det.
    let x = (d2.cross(d3) * b.x + d3.cross(d1) * b.y + d1.cross(d2) * b.z) / det;
    Some(c[0] + x)
}
