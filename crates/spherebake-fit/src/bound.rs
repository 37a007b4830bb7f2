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
//!    build each sphere's power cell within its inflated ball (a box clipped by the bisector
//!    planes of the spheres whose inflated balls meet it), take the cell vertices of power in
//!    (0, P], and where such a v is uncovered and inside T (the one inside rule,
//!    `spherebake_geom::voxel::VoxelGrid::contains`: the voxel solid far from the surface,
//!    |w| ≥ ½ of the triangles near it, whatever their winding), grow the cheapest sphere over v; repeat until
//!    no such vertex remains. Degenerate vertices (five or more spheres of equal power) are
//!    found like any other.

use crate::ballgrid::BallGrid;
use glam::DVec3;
use rayon::prelude::*;
use spherebake_format::quant::next_up_f32;

/// A stored sphere: centre xyz and radius, f32, model space.
pub type Sphere32 = [f32; 4];

const MARGIN: f64 = 1.0 - 1e-12;

#[inline]
pub fn contains(s: &Sphere32, p: DVec3) -> bool {
    let c = DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64);
    let r = s[3] as f64;
    p.distance_squared(c) <= r * r * MARGIN
}

/// Smallest f32 radius ≥ current with which `s` contains every point in `ps`.
fn grow(s: &mut Sphere32, ps: &[DVec3]) {
    let c = DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64);
    let need = ps.iter().map(|p| p.distance(c)).fold(0.0f64, f64::max);
    let mut r = (need as f32).max(s[3]);
    while !ps.iter().all(|p| p.distance_squared(c) <= (r as f64) * (r as f64) * MARGIN) {
        r = next_up_f32(r);
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

/// The spheres as the bounding pass grows them, with a [`BallGrid`] so that "is this piece
/// covered" and "which sphere grows least" ask the nearby spheres only; answers are those of the
/// full scan (same sphere, ties to the lower index). Each sphere is listed with reach
/// 1.25 r + δ and, once it outgrows that, returned by every query.
struct Live {
    grid: BallGrid,
    reach: Vec<f64>,
    /// Least growth weight (> 0; else every `cheapest` scans all spheres).
    w_min: f64,
    /// First search radius of `cheapest`: the median reach.
    q0: f64,
    cand: Vec<u32>,
}

impl Live {
    fn new(spheres: &[Sphere32], weights: &[f64], delta: f64) -> Self {
        let reach: Vec<f64> = spheres.iter().map(|s| 1.25 * s[3] as f64 + delta.max(0.0)).collect();
        let balls: Vec<(DVec3, f64)> = to_balls(spheres).into_iter().zip(&reach).map(|(b, r)| (b.0, *r)).collect();
        let mut sorted: Vec<f64> = reach.iter().copied().filter(|r| r.is_finite()).collect();
        sorted.sort_by(f64::total_cmp);
        let q0 = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
        let w_min = (0..spheres.len()).map(|i| weights.get(i).copied().unwrap_or(1.0)).fold(f64::INFINITY, f64::min);
        Self { grid: BallGrid::new(&balls), reach, w_min, q0, cand: Vec::new() }
    }

    fn covered(&mut self, spheres: &[Sphere32], ps: &[DVec3]) -> bool {
        self.grid.at(ps[0], &mut self.cand);
        self.cand.iter().any(|&j| ps.iter().all(|p| contains(&spheres[j as usize], *p)))
    }

    /// [`cheapest`] over the spheres near `ps`: a sphere the grid does not list within q of
    /// ps[0] is farther than q + r from it, so its weighted growth exceeds w_min q³; the search
    /// radius widens until the best growth found is below that.
    fn cheapest(&mut self, spheres: &[Sphere32], ps: &[DVec3], weights: &[f64]) -> usize {
        let x0 = ps[0];
        let span = ps.iter().map(|p| p.distance(x0)).fold(0.0, f64::max);
        let mut q = 2.0 * span + self.q0;
        if self.w_min > 0.0 && self.w_min.is_finite() {
            for _ in 0..8 {
                if !(q.is_finite() && q > 0.0) {
                    break;
                }
                self.grid.near(x0, q, &mut self.cand);
                let mut best = (f64::INFINITY, usize::MAX);
                for &j in &self.cand {
                    let j = j as usize;
                    let g = growth_cost(&spheres[j], ps) * weights.get(j).copied().unwrap_or(1.0);
                    if g < best.0 {
                        best = (g, j);
                    }
                }
                let bound = self.w_min * q * q * q * (1.0 - 1e-9);
                if best.1 != usize::MAX && best.0 < bound {
                    return best.1;
                }
                q = (2.0 * q).max((best.0 / self.w_min).cbrt() * (1.0 + 1e-6));
            }
        }
        cheapest(spheres, ps, weights)
    }

    /// Sphere `i` grew: keep it findable.
    fn grew(&mut self, spheres: &[Sphere32], i: usize) {
        let r = spheres[i][3] as f64;
        if r.is_nan() || r > self.reach[i] {
            self.grid.list_everywhere(i as u32);
        }
    }
}

fn to_balls(s: &[Sphere32]) -> Vec<(DVec3, f64)> {
    s.iter().map(|x| (DVec3::new(x[0] as f64, x[1] as f64, x[2] as f64), x[3] as f64)).collect()
}

fn cover_piece(
    spheres: &mut [Sphere32],
    live: &mut Live,
    t: [DVec3; 3],
    depth: u32,
    rep: &mut BoundReport,
    weights: &[f64],
) {
    if live.covered(spheres, &t) {
        return;
    }
    let i = live.cheapest(spheres, &t, weights);
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
                cover_piece(spheres, live, piece, depth + 1, rep, weights);
            }
            return;
        }
        let m01 = (t[0] + t[1]) * 0.5;
        let m12 = (t[1] + t[2]) * 0.5;
        let m20 = (t[2] + t[0]) * 0.5;
        for piece in [[t[0], m01, m20], [m01, t[1], m12], [m20, m12, t[2]], [m01, m12, m20]] {
            cover_piece(spheres, live, piece, depth + 2, rep, weights);
        }
        return;
    }
    grow(&mut spheres[i], &t);
    live.grew(spheres, i);
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
    // Rule 1. The pre-filters ask only the spheres a grid lists at a corner (a sphere holding
    // the piece holds that corner), so they cost O(triangles + points), not × spheres.
    let grid = BallGrid::new(&to_balls(&out));
    let uncovered: Vec<u32> = {
        let o = &out;
        input
            .triangles
            .par_iter()
            .enumerate()
            .map_init(Vec::new, |cand, (i, t)| {
                let t = corners(t);
                grid.at(t[0], cand);
                (!cand.iter().any(|&j| t.iter().all(|p| contains(&o[j as usize], *p)))).then_some(i as u32)
            })
            .flatten()
            .collect()
    };
    let mut live = Live::new(&out, input.weights, input.delta);
    for ti in uncovered {
        cover_piece(&mut out, &mut live, corners(&input.triangles[ti as usize]), 0, &mut rep, input.weights);
    }
    // Rule 2 (radii have grown: a new grid).
    let grid = BallGrid::new(&to_balls(&out));
    let uncovered: Vec<u32> = {
        let o = &out;
        input
            .interior
            .par_iter()
            .enumerate()
            .map_init(Vec::new, |cand, (i, p)| {
                grid.at(*p, cand);
                (!cand.iter().any(|&j| contains(&o[j as usize], *p))).then_some(i as u32)
            })
            .flatten()
            .collect()
    };
    for pi in uncovered {
        let p = [input.interior[pi as usize]];
        if live.covered(&out, &p) {
            continue;
        }
        let i = live.cheapest(&out, &p, input.weights);
        grow(&mut out[i], &p);
        live.grew(&out, i);
        rep.grown_points += 1;
    }
    // Rule 3.
    for _round in 0..64 {
        let found = pocket_vertices(&out, input, &mut rep);
        if found.is_empty() {
            break;
        }
        for (v, p) in found {
            if live.covered(&out, &[v]) {
                continue;
            }
            // Cover v with a little room (a quarter of its orthogonal radius) so the pocket
            // closes in few rounds.
            let i = live.cheapest(&out, &[v], input.weights);
            let c = DVec3::new(out[i][0] as f64, out[i][1] as f64, out[i][2] as f64);
            let dir = (v - c).normalize_or_zero();
            grow(&mut out[i], &[v, v + dir * 0.25 * p.sqrt()]);
            live.grew(&out, i);
            rep.pockets_closed += 1;
        }
    }
    (out, rep)
}

/// Uncovered power vertices inside T with power ≤ P (rule 3), as (vertex, power).
///
/// Each sphere's power cell is built by clipping a box around it (half-size 1.01 √(r² + P),
/// so box corners and faces have power > P) with the bisector planes of the spheres whose
/// inflated balls meet its own (no other plane can cut the part of the cell with power ≤ P);
/// the cell's vertices with power in (0, P] are the candidates. Cost O(n · m · cell size) for m
/// neighbours per sphere, where enumerating 4-cliques of the inflated balls cost O(n · m³):
/// with 4096 spheres smaller than δ that was hours (issue 17). Degenerate vertices (five or
/// more spheres of equal power, four coplanar centres) are found too.
/// Centres, radii and the ball grid at the pocket search's reach √(r² + P), P = 2 r_max δ + δ² the largest power a
/// pocket vertex within δ of the surface can have.
struct PowerSet {
    c: Vec<DVec3>,
    r: Vec<f64>,
    rin: Vec<f64>,
    grid: BallGrid,
    pmax: f64,
}

impl PowerSet {
    fn new(s: &[Sphere32], delta: f64) -> PowerSet {
        let c: Vec<DVec3> = s.iter().map(|x| DVec3::new(x[0] as f64, x[1] as f64, x[2] as f64)).collect();
        let r: Vec<f64> = s.iter().map(|x| x[3] as f64).collect();
        let rmax = r.iter().cloned().fold(0.0, f64::max);
        let pmax = 2.0 * rmax * delta + delta * delta;
        let rin: Vec<f64> = r.iter().map(|x| (x * x + pmax).sqrt()).collect();
        let grid = BallGrid::new(&c.iter().copied().zip(rin.iter().copied()).collect::<Vec<_>>());
        PowerSet { c, r, rin, grid, pmax }
    }
}

/// Whether `v` (power `p` with respect to its defining spheres, one of radius `r_i`) is a genuine power-diagram
/// vertex: no sphere has lower power at v (with a rounding allowance) and none contains it. A sphere failing
/// either test has |v − c|² < r² + p ≤ r² + P (or contains v), so it is among the grid's candidates at v.
#[allow(clippy::too_many_arguments)]
fn genuine_power_vertex(
    grid: &BallGrid,
    s: &[Sphere32],
    c: &[DVec3],
    r: &[f64],
    r_i: f64,
    v: DVec3,
    p: f64,
    cand: &mut Vec<u32>,
) -> bool {
    let tol = 1e-9 * (p + r_i * r_i);
    grid.at(v, cand);
    cand.iter().all(|&x| {
        let x = x as usize;
        !contains(&s[x], v) && v.distance_squared(c[x]) - r[x] * r[x] >= p - tol
    })
}

fn pocket_vertices(s: &[Sphere32], input: &BoundInput, rep: &mut BoundReport) -> Vec<(DVec3, f64)> {
    let n = s.len();
    if n < 4 {
        return Vec::new();
    }
    let PowerSet { c, r, rin, grid, pmax } = PowerSet::new(s, input.delta);
    let cand: Vec<(DVec3, f64)> = (0..n)
        .into_par_iter()
        .flat_map_iter(|i| {
            let mut nb = Vec::new();
            grid.near(c[i], rin[i], &mut nb);
            let mut planes: Vec<(f64, DVec3, f64)> = Vec::with_capacity(nb.len());
            let mut empty = false;
            for &j in &nb {
                let j = j as usize;
                if j == i || c[i].distance(c[j]) >= rin[i] + rin[j] {
                    continue;
                }
                // power_i(x) ≤ power_j(x) ⇔ 2 e·y ≤ |e|² − r_j² + r_i², y = x − c_i, e = c_j − c_i.
                let e = c[j] - c[i];
                let rhs = e.length_squared() - r[j] * r[j] + r[i] * r[i];
                if e == DVec3::ZERO {
                    // Same centre: the larger sphere's cell is everything, the smaller's empty.
                    empty |= rhs < 0.0 || (rhs == 0.0 && j < i);
                    continue;
                }
                planes.push((e.length_squared(), 2.0 * e, rhs));
            }
            let mut found = Vec::new();
            if empty {
                return found;
            }
            planes.sort_by(|a, b| a.0.total_cmp(&b.0));
            let mut cell = ConvexCell::cube(1.01 * rin[i]);
            for (_, nrm, rhs) in &planes {
                cell.clip(*nrm, *rhs);
                if cell.faces.is_empty() {
                    return found;
                }
            }
            let mut cand = Vec::new();
            for y in cell.vertices() {
                let v = c[i] + y;
                let p = y.length_squared() - r[i] * r[i];
                if p <= 0.0 || p > pmax {
                    continue;
                }
                // Only genuine power-diagram vertices can be pocket maxima.
                if genuine_power_vertex(&grid, s, &c, &r, r[i], v, p, &mut cand) {
                    found.push((v, p));
                }
            }
            found
        })
        .collect();
    rep.pocket_candidates = cand.len();
    let inside: Vec<bool> = cand.par_iter().map(|(v, _)| (input.inside)(*v)).collect();
    cand.into_iter().zip(inside).filter(|x| x.1).map(|x| x.0).collect()
}

/// A convex polytope as its faces (vertex loops), for power cells.
struct ConvexCell {
    faces: Vec<Vec<DVec3>>,
}

impl ConvexCell {
    /// The cube [−a, a]³.
    fn cube(a: f64) -> Self {
        let v = |i: usize| {
            DVec3::new(
                if i & 1 != 0 { a } else { -a },
                if i & 2 != 0 { a } else { -a },
                if i & 4 != 0 { a } else { -a },
            )
        };
        let quads = [[0, 2, 6, 4], [1, 5, 7, 3], [0, 4, 5, 1], [2, 3, 7, 6], [0, 1, 3, 2], [4, 6, 7, 5]];
        Self { faces: quads.iter().map(|q| q.iter().map(|&i| v(i)).collect()).collect() }
    }

    /// Keeps the part with n·x ≤ d. An edge cut by the plane gives the same point in both of
    /// its faces (computed from its endpoints in a fixed order), and the cut points close the
    /// new face, ordered by angle about their centroid (the section of a convex body is convex).
    fn clip(&mut self, n: DVec3, d: f64) {
        let inside = |x: DVec3| n.dot(x) <= d;
        if self.faces.iter().all(|f| f.iter().all(|&x| inside(x))) {
            return;
        }
        let cut = |a: DVec3, b: DVec3| -> DVec3 {
            let (a, b) = if a.to_array() < b.to_array() { (a, b) } else { (b, a) };
            let (fa, fb) = (n.dot(a) - d, n.dot(b) - d);
            let t = (fa / (fa - fb)).clamp(0.0, 1.0);
            a + (b - a) * t
        };
        let mut cap: Vec<DVec3> = Vec::new();
        let mut faces = Vec::with_capacity(self.faces.len() + 1);
        for f in &self.faces {
            let mut out = Vec::with_capacity(f.len() + 1);
            for k in 0..f.len() {
                let (a, b) = (f[k], f[(k + 1) % f.len()]);
                let (ia, ib) = (inside(a), inside(b));
                if ia {
                    out.push(a);
                }
                if ia != ib {
                    let x = cut(a, b);
                    out.push(x);
                    cap.push(x);
                }
            }
            if out.len() >= 3 {
                faces.push(out);
            }
        }
        cap.sort_by(|a, b| a.to_array().partial_cmp(&b.to_array()).unwrap_or(std::cmp::Ordering::Equal));
        cap.dedup();
        if cap.len() >= 3 && !faces.is_empty() {
            let o = cap.iter().copied().sum::<DVec3>() / cap.len() as f64;
            let nn = n.normalize();
            let u = nn.any_orthonormal_vector();
            let w = nn.cross(u);
            cap.sort_by(|a, b| {
                let (pa, pb) = (*a - o, *b - o);
                pa.dot(w).atan2(pa.dot(u)).total_cmp(&pb.dot(w).atan2(pb.dot(u)))
            });
            faces.push(cap);
        }
        self.faces = faces;
    }

    /// Every vertex once (exact duplicates removed).
    fn vertices(&self) -> Vec<DVec3> {
        let mut v: Vec<DVec3> = self.faces.iter().flatten().copied().collect();
        v.sort_by(|a, b| a.to_array().partial_cmp(&b.to_array()).unwrap_or(std::cmp::Ordering::Equal));
        v.dedup();
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

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

    /// The former rule-3 search, kept as the oracle: every 4-clique of pairwise intersecting
    /// inflated balls, its power vertex, the same genuineness test. O(n · m³).
    fn clique_pocket_vertices(s: &[Sphere32], input: &BoundInput, rep: &mut BoundReport) -> Vec<(DVec3, f64)> {
        let n = s.len();
        if n < 4 {
            return Vec::new();
        }
        let PowerSet { c, r, rin, grid, pmax } = PowerSet::new(s, input.delta);
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
                let mut cand = Vec::new();
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
                            // Only genuine power-diagram vertices can be pocket maxima.
                            if genuine_power_vertex(&grid, s, &c, &r, r[i], v, p, &mut cand) {
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

    fn close(a: DVec3, b: DVec3) -> bool {
        a.distance(b) <= 1e-9 * (1.0 + a.length())
    }

    #[test]
    fn power_cells_find_the_same_pocket_vertices_as_the_clique_search() {
        let everywhere = |_: DVec3| true;
        let mut total = 0;
        for seed in 1..=6u64 {
            let mut rng = SplitMix64::new(seed);
            let n = 20 + 10 * seed as usize;
            let s: Vec<Sphere32> = (0..n)
                .map(|_| {
                    let c = [rng.next_f64(), rng.next_f64(), rng.next_f64()].map(|x| (x * 4.0) as f32);
                    [c[0], c[1], c[2], (0.3 + 0.5 * rng.next_f64()) as f32]
                })
                .collect();
            let input = BoundInput {
                positions: &[],
                triangles: &[],
                interior: &[],
                delta: 0.4,
                inside: &everywhere,
                weights: &[],
            };
            let mut rep = BoundReport::default();
            let want = clique_pocket_vertices(&s, &input, &mut rep);
            let got = pocket_vertices(&s, &input, &mut rep);
            assert!(!want.is_empty(), "seed {seed}: the configuration has pockets");
            for (v, p) in &want {
                let hit = got.iter().find(|(g, _)| close(*g, *v));
                assert!(hit.is_some(), "seed {seed}: vertex {v} (power {p}) missed");
                assert!((hit.unwrap().1 - p).abs() <= 1e-9 * (1.0 + p), "seed {seed}: power differs at {v}");
            }
            for (g, _) in &got {
                assert!(want.iter().any(|(v, _)| close(*g, *v)), "seed {seed}: {g} is not a power vertex");
            }
            total += want.len();
        }
        assert!(total > 50, "enough vertices compared ({total})");
    }

    #[test]
    fn a_pocket_between_spheres_on_cube_corners_is_found() {
        // Eight equal spheres on the corners of a cube (edge 2, radius 1.2 > 1 so neighbours
        // overlap, < √3 so the centre stays uncovered): the pocket's deepest point is the
        // centre, a vertex of equal power to all eight, where every quadruple of centres is
        // degenerate or cospherical.
        let s: Vec<Sphere32> = (0..8)
            .map(|i| [(i & 1) as f32 * 2.0, ((i >> 1) & 1) as f32 * 2.0, ((i >> 2) & 1) as f32 * 2.0, 1.2])
            .collect();
        let everywhere = |_: DVec3| true;
        let input =
            BoundInput { positions: &[], triangles: &[], interior: &[], delta: 0.6, inside: &everywhere, weights: &[] };
        let mut rep = BoundReport::default();
        let got = pocket_vertices(&s, &input, &mut rep);
        let centre = DVec3::ONE;
        let hit = got.iter().find(|(v, _)| v.distance(centre) < 1e-9).expect("centre found");
        assert!((hit.1 - (3.0 - 1.44)).abs() < 1e-5, "power {}", hit.1);
        // Nothing else: the cell of each sphere is a cube whose only vertex of positive power
        // within reach is the centre.
        assert!(got.iter().all(|(v, _)| v.distance(centre) < 1e-9), "{got:?}");
    }

    #[test]
    fn make_bounding_closes_the_corner_pocket() {
        let raw: Vec<(DVec3, f64)> = (0..8)
            .map(|i| (DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64) * 2.0, 1.2))
            .collect();
        let everywhere = |_: DVec3| true;
        let input =
            BoundInput { positions: &[], triangles: &[], interior: &[], delta: 0.6, inside: &everywhere, weights: &[] };
        let (out, rep) = make_bounding(&raw, &input);
        assert!(rep.pockets_closed >= 1);
        assert!(out.iter().any(|s| contains(s, DVec3::ONE)), "the centre is covered");
    }
}
