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
//! 4. **Shrink back.** The growth above is greedy (each piece grows the cheapest sphere at the
//!    time), so a sphere grown early may later be covered for by a neighbour's larger growth.
//!    Each grown sphere (at most [`SHRINK_MAX`], most weighted growth first) is set back to its
//!    radius before the pass; the triangle pieces and interior points in the shell between the
//!    two radii are covered again by rules 1–2 (it may grow back, or others grow); the step is
//!    kept only when the summed weighted volume Σ wᵢ rᵢ³ drops, else undone. Rule 3 then runs
//!    again. Measured in whole bakes (64 and 128 spheres, seeds 1–4): E −0.1 to −1.2 % on every
//!    seed (`docs/benchmarks.md`).

use crate::ballgrid::BallGrid;
use glam::DVec3;
use rayon::prelude::*;
use spherebake_format::quant::next_up_f32;
use spherebake_geom::triangle::closest_point_on_triangle;

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
    /// Spheres set back to a smaller radius by rule 4 (shrink back).
    pub shrunk: usize,
    /// Rule 4 steps whose sphere had grown further since its triangles and points at risk
    /// were listed, so they were searched again.
    pub rescanned: usize,
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
    /// At least every sphere's radius (+∞ when one is NaN): radii only grow between rebuilds,
    /// and rule 4's set-backs leave it an upper bound.
    r_max: f64,
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
        let r_max = spheres.iter().fold(0.0f64, |m, s| radius_bound(m, s[3]));
        Self { grid: BallGrid::new(&balls), reach, w_min, q0, r_max, cand: Vec::new() }
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
        self.r_max = radius_bound(self.r_max, spheres[i][3]);
        let r = spheres[i][3] as f64;
        if r.is_nan() || r > self.reach[i] {
            self.grid.list_everywhere(i as u32);
        }
    }
}

/// `m` raised to radius `r` (+∞ for a NaN radius).
fn radius_bound(m: f64, r: f32) -> f64 {
    if r.is_nan() {
        f64::INFINITY
    } else {
        m.max(r as f64)
    }
}

fn to_balls(s: &[Sphere32]) -> Vec<(DVec3, f64)> {
    s.iter().map(|x| (DVec3::new(x[0] as f64, x[1] as f64, x[2] as f64), x[3] as f64)).collect()
}

/// Which triangle pieces [`cover_piece`] looks at (rule 4).
type PieceFilter<'a> = dyn Fn(&[DVec3; 3]) -> bool + 'a;

/// Covers triangle piece `t` (rule 1). With `only`, pieces for which it is false are known to
/// be covered already and are skipped, with their sub-pieces (rule 4's shell).
fn cover_piece(
    spheres: &mut [Sphere32],
    live: &mut Live,
    t: [DVec3; 3],
    depth: u32,
    rep: &mut BoundReport,
    weights: &[f64],
    only: Option<&PieceFilter>,
) {
    if only.is_some_and(|f| !f(&t)) || live.covered(spheres, &t) {
        return;
    }
    let l = (t[1] - t[0]).length().max((t[2] - t[1]).length()).max((t[0] - t[2]).length());
    // Splitting is free (no sphere grows), so split down to pieces small next to the sphere
    // that would grow before growing anything.
    // `depth` counts half levels: a four-way split halves every edge (+2), a sliver bisection
    // halves one (+1), so both reach the same piece sizes. Below depth 10 a piece is always
    // split, so the growing sphere is only looked for from there (a search over the spheres
    // near a large piece is most of the pass's cost with thousands of spheres). Nor is it
    // looked for while the piece is longer than 0.02 × the largest radius: it is split
    // whichever sphere would grow (a thin rod's slivers: most pieces, and most of the pass).
    let grows = (depth >= 10 && l <= 0.02 * live.r_max).then(|| live.cheapest(spheres, &t, weights));
    if depth < 20 && grows.is_none_or(|i| l > 0.02 * spheres[i][3] as f64) {
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
                cover_piece(spheres, live, piece, depth + 1, rep, weights, only);
            }
            return;
        }
        let m01 = (t[0] + t[1]) * 0.5;
        let m12 = (t[1] + t[2]) * 0.5;
        let m20 = (t[2] + t[0]) * 0.5;
        for piece in [[t[0], m01, m20], [m01, t[1], m12], [m20, m12, t[2]], [m01, m12, m20]] {
            cover_piece(spheres, live, piece, depth + 2, rep, weights, only);
        }
        return;
    }
    let i = grows.unwrap_or_else(|| live.cheapest(spheres, &t, weights));
    grow(&mut spheres[i], &t);
    live.grew(spheres, i);
    rep.grown_pieces += 1;
}

/// Rounds `spheres` (f64 centre, radius) to f32 and grows radii until rules 1–3 hold.
pub fn make_bounding(spheres: &[(DVec3, f64)], input: &BoundInput) -> (Vec<Sphere32>, BoundReport) {
    let mut out: Vec<Sphere32> =
        spheres.iter().map(|(c, r)| [c.x as f32, c.y as f32, c.z as f32, (*r as f32).max(0.0)]).collect();
    // The rounded spheres before any growth: what rule 4 sets back to.
    let rounded = out.clone();
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
        cover_piece(&mut out, &mut live, corners(&input.triangles[ti as usize]), 0, &mut rep, input.weights, None);
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
    let mut memo = InsideMemo::default();
    close_pockets(&mut out, &mut live, input, &mut rep, &mut memo);
    // Rule 4, then rule 3 again on what it changed.
    if shrink_back(&mut out, &rounded, &mut live, input, &mut rep) > 0 {
        close_pockets(&mut out, &mut live, input, &mut rep, &mut memo);
    }
    (out, rep)
}

/// The inside test's answers by the bits of the point asked: a round of the pocket search
/// finds again the power vertices of every sphere that did not grow since the last round, at
/// the same bits, and the test (an exact winding number, O(T) on an open mesh) is a function
/// of the point alone, so an answer kept is the answer recomputed. Only looked up, never
/// iterated: the map's order cannot reach the result.
type InsideMemo = std::collections::HashMap<[u64; 3], bool>;

/// Rule 3: rounds of the pocket search, each uncovered pocket vertex covered by the cheapest
/// sphere (at most 64 rounds).
fn close_pockets(
    out: &mut [Sphere32],
    live: &mut Live,
    input: &BoundInput,
    rep: &mut BoundReport,
    memo: &mut InsideMemo,
) {
    for _round in 0..64 {
        let found = pocket_vertices(out, input, rep, memo);
        if found.is_empty() {
            break;
        }
        for (v, p) in found {
            if live.covered(out, &[v]) {
                continue;
            }
            // Cover v with a little room (a quarter of its orthogonal radius) so the pocket
            // closes in few rounds.
            let i = live.cheapest(out, &[v], input.weights);
            let c = DVec3::new(out[i][0] as f64, out[i][1] as f64, out[i][2] as f64);
            let dir = (v - c).normalize_or_zero();
            grow(&mut out[i], &[v, v + dir * 0.25 * p.sqrt()]);
            live.grew(out, i);
            rep.pockets_closed += 1;
        }
    }
}

/// Rule 4 sets back at most this many spheres, those of most weighted growth. Each costs the
/// re-cover of the surface pieces along its shell, down to the split depth; at 4096 spheres on
/// the unit cube all of them took 12 s (the whole pass before rule 4: 8 s). Every shared model
/// at 64–128 spheres has all its grown spheres set back.
const SHRINK_MAX: usize = 256;

/// Rule 4: each sphere grown beyond its radius in `rounded` (the spheres on entry to the pass;
/// centres never move), most weighted growth w (r³ − r₀³) first, is set back to it and the triangles and interior points that may
/// lose cover (those meeting the shell between the two radii) are covered again (rules 1–2: it
/// may grow back, or neighbours grow); the step is kept when Σ w r³ drops, else undone. Rules
/// 1–2 hold after every step. Cost: one parallel pass pairing triangles and points with the
/// grown spheres whose shell they meet (O(T + points) with the sphere grid), then per grown
/// sphere its pairs and an O(n) undo copy; a sphere that grew again since its pairs were
/// listed has them found again, the triangles through a grid of triangle balls (built once,
/// O(T)) and the interior points by a scan. Returns the spheres kept smaller.
fn shrink_back(
    out: &mut [Sphere32],
    rounded: &[Sphere32],
    live: &mut Live,
    input: &BoundInput,
    rep: &mut BoundReport,
) -> usize {
    let w = |j: usize| input.weights.get(j).copied().unwrap_or(1.0);
    let cube = |r: f32| (r as f64).powi(3);
    let before = |i: usize| rounded[i][3];
    let mut order: Vec<(f64, usize)> = (0..out.len())
        .filter(|&i| out[i][3] > before(i))
        .map(|i| (w(i) * (cube(out[i][3]) - cube(before(i))), i))
        .collect();
    if order.is_empty() {
        return 0;
    }
    order.sort_unstable_by(crate::largest_first);
    order.truncate(SHRINK_MAX);
    // The grid at today's radii: spheres that outgrew their first reach would otherwise be
    // returned by every query (with 4096 spheres on a cube, sorting those lists was most of
    // the time).
    *live = Live::new(out, input.weights, input.delta);
    let corners = |t: &[u32; 3]| -> [DVec3; 3] {
        [input.positions[t[0] as usize], input.positions[t[1] as usize], input.positions[t[2] as usize]]
    };
    // Centres stay; only radii change below.
    let centre = |i: usize| DVec3::new(rounded[i][0] as f64, rounded[i][1] as f64, rounded[i][2] as f64);
    // Whether triangle t, with sphere i at radius `old`, may lose cover when i is set back:
    // it is not inside the set-back ball and meets the old ball (else no piece of it was in
    // i). Both tests are pure, so their order is free: the three corner tests go first, as
    // they settle most of the pieces rule 4 re-covers (those inside the set-back ball) for
    // less than the closest point costs (the bunny at `fast`: 742 000 calls).
    let tri_at_risk = |i: usize, old: f64, t: &[DVec3; 3]| -> bool {
        let c = centre(i);
        !t.iter().all(|p| contains(&rounded[i], *p))
            && closest_point_on_triangle(c, t).distance_squared(c) <= old * old * (1.0 + 1e-9)
    };
    let point_at_risk = |i: usize, old: f64, p: DVec3| -> bool {
        p.distance_squared(centre(i)) <= old * old * (1.0 + 1e-9) && !contains(&rounded[i], p)
    };
    // Pairs (sphere, triangle) and (sphere, point) at risk at today's radii, found through a grid
    // of the grown spheres (the others listed nowhere).
    let grown: Vec<(DVec3, f64)> =
        (0..out.len()).map(|j| (centre(j), if out[j][3] > before(j) { out[j][3] as f64 } else { -1.0 })).collect();
    let sgrid = BallGrid::new(&grown);
    let mut tri_pairs: Vec<(u32, u32)> = input
        .triangles
        .par_iter()
        .enumerate()
        .map_init(Vec::new, |cand, (ti, t)| {
            let t = corners(t);
            let m = (t[0] + t[1] + t[2]) / 3.0;
            sgrid.near(m, t.iter().map(|q| q.distance(m)).fold(0.0, f64::max), cand);
            cand.iter()
                .filter(|&&j| tri_at_risk(j as usize, grown[j as usize].1, &t))
                .map(|&j| (j, ti as u32))
                .collect::<Vec<_>>()
        })
        .flatten()
        .collect();
    tri_pairs.sort_unstable();
    let mut point_pairs: Vec<(u32, u32)> = input
        .interior
        .par_iter()
        .enumerate()
        .map_init(Vec::new, |cand, (pi, p)| {
            sgrid.at(*p, cand);
            cand.iter()
                .filter(|&&j| point_at_risk(j as usize, grown[j as usize].1, *p))
                .map(|&j| (j, pi as u32))
                .collect::<Vec<_>>()
        })
        .flatten()
        .collect();
    point_pairs.sort_unstable();
    let of = |pairs: &[(u32, u32)], i: usize| -> Vec<u32> {
        let a = pairs.partition_point(|x| (x.0 as usize) < i);
        let b = pairs.partition_point(|x| (x.0 as usize) <= i);
        pairs[a..b].iter().map(|x| x.1).collect()
    };
    let mut undo = Vec::with_capacity(out.len());
    let mut scratch = BoundReport::default();
    let mut shrunk = 0;
    // The triangles as balls (centroid, farthest corner, padded for rounding) on a grid, built
    // when a sphere's pairs first go stale: a triangle that meets a ball meets it inside both
    // boxes, so `near` lists it (the bunny at `fast` re-scanned all 70 000 triangles for 25 of
    // its 64 spheres, 4 % of the bake).
    let mut tri_grid: Option<BallGrid> = None;
    let mut cand = Vec::new();
    for (_, i) in order {
        let old = out[i][3] as f64;
        // Sphere i grew further in an earlier step: its pairs are stale, find them again (the
        // triangles near its ball, every interior point).
        let (tris, pts): (Vec<u32>, Vec<u32>) = if old > grown[i].1 {
            rep.rescanned += 1;
            let grid = tri_grid.get_or_insert_with(|| {
                let balls: Vec<(DVec3, f64)> = input
                    .triangles
                    .par_iter()
                    .map(|t| {
                        let t = corners(t);
                        let m = (t[0] + t[1] + t[2]) / 3.0;
                        (m, t.iter().map(|q| q.distance(m)).fold(0.0, f64::max) * (1.0 + 1e-9))
                    })
                    .collect();
                BallGrid::new(&balls)
            });
            grid.near(centre(i), old, &mut cand);
            (
                cand.iter()
                    .copied()
                    .filter(|&ti| tri_at_risk(i, old, &corners(&input.triangles[ti as usize])))
                    .collect(),
                (0..input.interior.len() as u32)
                    .into_par_iter()
                    .filter(|&pi| point_at_risk(i, old, input.interior[pi as usize]))
                    .collect(),
            )
        } else {
            (of(&tri_pairs, i), of(&point_pairs, i))
        };
        undo.clear();
        undo.extend_from_slice(out);
        out[i][3] = before(i);
        // Pieces apart from the old ball or inside the set-back ball are covered: skipped.
        let at_risk = |t: &[DVec3; 3]| tri_at_risk(i, old, t);
        for ti in tris {
            cover_piece(
                out,
                live,
                corners(&input.triangles[ti as usize]),
                0,
                &mut scratch,
                input.weights,
                Some(&at_risk),
            );
        }
        for pi in pts {
            let p = [input.interior[pi as usize]];
            if live.covered(out, &p) {
                continue;
            }
            let j = live.cheapest(out, &p, input.weights);
            grow(&mut out[j], &p);
            live.grew(out, j);
        }
        let delta: f64 = (0..out.len())
            .filter(|&j| out[j][3] != undo[j][3])
            .map(|j| w(j) * (cube(out[j][3]) - cube(undo[j][3])))
            .sum();
        if delta < 0.0 {
            shrunk += 1;
        } else {
            out.copy_from_slice(&undo);
        }
    }
    rep.shrunk += shrunk;
    shrunk
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

fn pocket_vertices(
    s: &[Sphere32],
    input: &BoundInput,
    rep: &mut BoundReport,
    memo: &mut InsideMemo,
) -> Vec<(DVec3, f64)> {
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
    let bits = |v: DVec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
    let mut ask: Vec<DVec3> = cand.iter().map(|x| x.0).filter(|v| !memo.contains_key(&bits(*v))).collect();
    ask.sort_unstable_by_key(|v| bits(*v));
    ask.dedup_by_key(|v| bits(*v));
    let answers: Vec<bool> = ask.par_iter().map(|v| (input.inside)(*v)).collect();
    memo.extend(ask.iter().map(|v| bits(*v)).zip(answers));
    cand.into_iter().filter(|(v, _)| memo.get(&bits(*v)).copied().unwrap_or(false)).collect()
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
            let got = pocket_vertices(&s, &input, &mut rep, &mut InsideMemo::default());
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
        let got = pocket_vertices(&s, &input, &mut rep, &mut InsideMemo::default());
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

    #[test]
    fn the_pocket_search_asks_the_inside_test_once_per_point() {
        // A jittered 4 × 4 × 4 lattice of spheres too small to meet: pockets everywhere, closed
        // over several rounds, each round finding again the power vertices of the spheres that
        // did not grow. The inside test (here: inside the lattice's box) is asked once per
        // point, by its bits, and still decides: the covered spheres hold the box's centre.
        let mut rng = crate::rng::SplitMix64::new(5);
        let raw: Vec<(DVec3, f64)> = (0..64)
            .map(|i| {
                let g = DVec3::new((i % 4) as f64, ((i / 4) % 4) as f64, (i / 16) as f64);
                let j = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 0.1;
                (g + j, 0.62 + 0.05 * rng.next_f64())
            })
            .collect();
        let asked = std::sync::Mutex::new(Vec::new());
        let inside = |v: DVec3| {
            asked.lock().unwrap().push([v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]);
            v.cmpge(DVec3::ZERO).all() && v.cmple(DVec3::splat(3.1)).all()
        };
        let input =
            BoundInput { positions: &[], triangles: &[], interior: &[], delta: 0.3, inside: &inside, weights: &[] };
        let (out, rep) = make_bounding(&raw, &input);
        assert!(rep.pockets_closed >= 8, "{rep:?}");
        let mut asked = asked.into_inner().unwrap();
        let n = asked.len();
        asked.sort_unstable();
        asked.dedup();
        assert_eq!(asked.len(), n, "a point asked twice");
        assert!(out.iter().any(|s| contains(s, DVec3::splat(1.55))), "the box's centre is covered");
    }

    /// A tiny triangle at `p` (edge 0.01).
    fn speck(p: DVec3, pos: &mut Vec<DVec3>, tris: &mut Vec<[u32; 3]>) {
        let n = pos.len() as u32;
        pos.extend([p, p + DVec3::Y * 0.01, p + DVec3::Z * 0.01]);
        tris.push([n, n + 1, n + 2]);
    }

    #[test]
    fn a_sphere_grown_for_a_piece_that_a_later_growth_covers_is_set_back() {
        // A at the origin and B at x = 3, both r = 1. The speck X at x = 1.2 comes first: A
        // grows least (1.2³ − 1 = 0.73 against 1.8³ − 1 = 4.8). The speck Y at x = 4.9 then
        // grows B to 1.9 (A would need 4.9), and B now holds X (1.8 from it): A's growth
        // bought nothing, so rule 4 returns A to r = 1 exactly.
        let (mut pos, mut tris) = (Vec::new(), Vec::new());
        speck(DVec3::new(1.2, 0.0, 0.0), &mut pos, &mut tris);
        speck(DVec3::new(4.9, 0.0, 0.0), &mut pos, &mut tris);
        let nowhere = |_: DVec3| false;
        let input = BoundInput {
            positions: &pos,
            triangles: &tris,
            interior: &[],
            delta: 0.01,
            inside: &nowhere,
            weights: &[],
        };
        let raw = [(DVec3::ZERO, 1.0), (DVec3::new(3.0, 0.0, 0.0), 1.0)];
        let (out, rep) = make_bounding(&raw, &input);
        assert_eq!(out[0][3], 1.0, "A set back: {out:?}");
        assert!(out[1][3] >= 1.9 && out[1][3] < 1.9001, "B holds Y: {out:?}");
        assert_eq!(rep.shrunk, 1);
        for p in &pos {
            assert!(out.iter().any(|s| contains(s, *p)), "{p} covered");
        }
    }

    #[test]
    fn a_sphere_grown_again_before_its_set_back_still_leaves_every_piece_covered() {
        // Many small triangles among spheres that must grow a lot: set-backs make neighbours
        // grow again, so later steps find their lists stale and search the triangles near the
        // ball again (rule 4's second path). Every triangle stays covered.
        use crate::rng::SplitMix64;
        let (mut rescanned, mut shrunk) = (0, 0);
        for seed in 0..12u64 {
            let mut rng = SplitMix64::new(100 + seed);
            let mut pt = || DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 4.0;
            let (mut pos, mut tris) = (Vec::new(), Vec::new());
            for _ in 0..400 {
                let p = pt();
                speck(p, &mut pos, &mut tris);
            }
            let raw: Vec<(DVec3, f64)> = (0..10).map(|i| (pt(), 0.2 + 0.03 * i as f64)).collect();
            let weights: Vec<f64> = (0..10).map(|i| 1.0 - 0.08 * i as f64).collect();
            let nowhere = |_: DVec3| false;
            let input = BoundInput {
                positions: &pos,
                triangles: &tris,
                interior: &[],
                delta: 0.05,
                inside: &nowhere,
                weights: &weights,
            };
            let (out, rep) = make_bounding(&raw, &input);
            rescanned += rep.rescanned;
            shrunk += rep.shrunk;
            for p in &pos {
                assert!(out.iter().any(|s| contains(s, *p)), "seed {seed}: {p} uncovered");
            }
        }
        assert!(rescanned > 0 && shrunk > 0, "rescanned {rescanned}, shrunk {shrunk}");
    }

    #[test]
    fn after_the_shrink_back_every_triangle_and_interior_point_is_still_covered() {
        // Random spheres over random triangles and points in a box: dense barycentric samples
        // of every triangle and every interior point lie in some stored sphere.
        use crate::rng::SplitMix64;
        let mut shrunk = 0;
        for seed in 0..20u64 {
            let mut rng = SplitMix64::new(seed);
            let mut pt = || DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 4.0;
            let pos: Vec<DVec3> = (0..90).map(|_| pt()).collect();
            let tris: Vec<[u32; 3]> = (0..30).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
            let interior: Vec<DVec3> = (0..40).map(|_| pt()).collect();
            let raw: Vec<(DVec3, f64)> = (0..12).map(|i| (pt(), 0.3 + 0.05 * i as f64)).collect();
            let nowhere = |_: DVec3| false;
            let weights: Vec<f64> = (0..12).map(|i| 0.2 + 0.07 * i as f64).collect();
            let input = BoundInput {
                positions: &pos,
                triangles: &tris,
                interior: &interior,
                delta: 0.05,
                inside: &nowhere,
                weights: &weights,
            };
            let (out, rep) = make_bounding(&raw, &input);
            shrunk += rep.shrunk;
            for t in &tris {
                let [a, b, c] = t.map(|v| pos[v as usize]);
                for i in 0..=8 {
                    for j in 0..=8 - i {
                        let p = a + (b - a) * (i as f64 / 8.0) + (c - a) * (j as f64 / 8.0);
                        assert!(out.iter().any(|s| contains(s, p)), "seed {seed}: {p} uncovered");
                    }
                }
            }
            for p in &interior {
                assert!(out.iter().any(|s| contains(s, *p)), "seed {seed}: interior {p} uncovered");
            }
        }
        assert!(shrunk > 0, "the shrink back acted in some case");
    }
}
