//! Start for the variational fit: a greedy set cover of the surface samples by dilated inner
//! balls (centre at an interior lattice point p, radius ρ(p) + t where ρ(p) is the distance to
//! the nearest surface sample), with the dilation t bisected so the cover needs at most k
//! balls. Random choices enter through the seeded tie order, so `seed` still varies the start.
//!
//! Cost follows the sphere count: samples and candidates are capped by [`sample_cap`] (125
//! per sphere, 256..=8000; strided or spatially even, [`Thinning`]), each doubling of the
//! dilation queries every candidate's ball once and keeps it sorted by distance, and the
//! bisection steps take prefixes of those lists.

use glam::DVec3;
use rayon::prelude::*;
use std::collections::BinaryHeap;

/// Cap on surface samples and on interior candidates used by the start.
const MAX_SAMPLES: usize = 8000;

struct Grid {
    origin: DVec3,
    h: f64,
    /// Sorted (cell key, point index).
    entries: Vec<((i64, i64, i64), u32)>,
    /// Each entry's z key and point, in the entries' order (a column's scan reads these).
    z: Vec<i64>,
    p: Vec<DVec3>,
    /// Where each (x, y) column of cells starts in `entries`, when the columns are few enough
    /// to list densely (see [`Columns`]); else each row is found by binary search.
    columns: Option<Columns>,
}

/// Dense index of the grid's (x, y) columns: column (x, y) holds
/// `entries[start[i]..start[i + 1]]` with i = (y − y0) + ny (x − x0) (the entries' order). A row then costs one
/// lookup instead of a binary search over every entry (the start's ball queries walk up to
/// (2r/h)² rows: 28 % of a cube bake's samples went to those searches).
struct Columns {
    x0: i64,
    y0: i64,
    nx: usize,
    ny: usize,
    start: Vec<u32>,
}

/// Columns of [`Columns`] at most, per entry (plus a constant): beyond, rows are searched.
const COLUMNS_PER_ENTRY: usize = 64;

impl Grid {
    fn new(pts: &[DVec3], h: f64) -> Self {
        let mut origin = DVec3::splat(f64::INFINITY);
        for p in pts {
            origin = origin.min(*p);
        }
        let mut entries: Vec<_> =
            pts.iter().enumerate().map(|(i, p)| (Self::key_of(origin, h, *p), i as u32)).collect();
        entries.sort_unstable();
        let columns = Self::columns(&entries);
        let z = entries.iter().map(|e| e.0 .2).collect();
        let p = entries.iter().map(|e| pts[e.1 as usize]).collect();
        Self { origin, h, entries, z, p, columns }
    }
    fn columns(entries: &[((i64, i64, i64), u32)]) -> Option<Columns> {
        let (first, last) = (entries.first()?.0, entries.last()?.0);
        let (x0, x1) = (first.0, last.0);
        let (y0, y1) = entries.iter().fold((i64::MAX, i64::MIN), |(a, b), e| (a.min(e.0 .1), b.max(e.0 .1)));
        let nx = usize::try_from(x1.checked_sub(x0)?.checked_add(1)?).ok()?;
        let ny = usize::try_from(y1.checked_sub(y0)?.checked_add(1)?).ok()?;
        let n = nx.checked_mul(ny)?;
        if n > COLUMNS_PER_ENTRY * entries.len() + 4096 {
            return None;
        }
        let mut start = vec![0u32; n + 1];
        for e in entries {
            start[(e.0 .1 - y0) as usize + ny * (e.0 .0 - x0) as usize + 1] += 1;
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        Some(Columns { x0, y0, nx, ny, start })
    }
    fn key_of(o: DVec3, h: f64, p: DVec3) -> (i64, i64, i64) {
        let u = (p - o) / h;
        (u.x.floor() as i64, u.y.floor() as i64, u.z.floor() as i64)
    }
    /// Indices of points within `r` of `c` (appended to `out`; the order is not part of the
    /// contract). When the ball spans more grid rows than there are points (a large ball, or a
    /// spacing that is zero or not finite), every point is tested instead: the rows of a ball
    /// of radius r number about (2r/h)², unbounded as h → 0.
    fn within(&self, pts: &[DVec3], c: DVec3, r: f64, out: &mut Vec<u32>) {
        self.visit(pts, c, r, |_, i| out.push(i));
    }

    /// As [`Grid::within`], each point with its squared distance `pts[i].distance_squared(c)`.
    fn within_d2(&self, pts: &[DVec3], c: DVec3, r: f64, out: &mut Vec<(f64, u32)>) {
        self.visit(pts, c, r, |d2, i| out.push((d2, i)));
    }

    /// Calls `f(d², i)` for every point i with d² = |pts[i] − c|² ≤ r², `pts` being the points
    /// the grid was built from (the grid keeps a copy in its own order for the scans). Columns
    /// whose distance from c exceeds r (less [`CLIP_SLACK`] cells) are skipped; the points of
    /// the others are tested exactly, so the set is the brute-force one.
    #[inline(always)]
    fn visit(&self, pts: &[DVec3], c: DVec3, r: f64, mut f: impl FnMut(f64, u32)) {
        let r2 = r * r;
        let lo = Self::key_of(self.origin, self.h, c - DVec3::splat(r));
        let hi = Self::key_of(self.origin, self.h, c + DVec3::splat(r));
        let rows = (hi.0 as f64 - lo.0 as f64 + 1.0) * (hi.1 as f64 - lo.1 as f64 + 1.0);
        let searchable = self.h > 0.0 && self.h.is_finite() && r.is_finite() && rows <= self.entries.len() as f64;
        if !searchable {
            for (i, p) in pts.iter().enumerate() {
                let d2 = p.distance_squared(c);
                if d2 <= r2 {
                    f(d2, i as u32);
                }
            }
            return;
        }
        // The ball in cell units: a column (x, y) farther than the radius from the centre
        // holds no point of the ball (the slack covers the keys' rounding), so each x visits
        // only the y whose columns meet the ball's disc.
        let u = (c - self.origin) / self.h;
        let ru = r / self.h;
        let y_range = |x: i64| -> Option<(i64, i64)> {
            let gx = ((x as f64 - u.x).max(u.x - (x as f64 + 1.0)) - CLIP_SLACK).max(0.0);
            let w2 = ru * ru - gx * gx;
            if w2 < 0.0 {
                return None;
            }
            let w = w2.sqrt() + CLIP_SLACK;
            Some(((u.y - w).floor().max(lo.1 as f64) as i64, (u.y + w).floor().min(hi.1 as f64) as i64))
        };
        let mut scan = |s: usize, e: usize| {
            let a = s + self.z[s..e].partition_point(|&k| k < lo.2);
            for j in a..e {
                if self.z[j] > hi.2 {
                    break;
                }
                let d2 = self.p[j].distance_squared(c);
                if d2 <= r2 {
                    f(d2, self.entries[j].1);
                }
            }
        };
        if let Some(cols) = &self.columns {
            // Only the columns that exist; the others hold no point.
            let x_end = cols.x0 + cols.nx as i64 - 1;
            let y_end = cols.y0 + cols.ny as i64 - 1;
            for x in lo.0.max(cols.x0)..=hi.0.min(x_end) {
                let Some((ya, yb)) = y_range(x) else { continue };
                let base = cols.ny * (x - cols.x0) as usize;
                for y in ya.max(cols.y0)..=yb.min(y_end) {
                    let i = base + (y - cols.y0) as usize;
                    scan(cols.start[i] as usize, cols.start[i + 1] as usize);
                }
            }
            return;
        }
        for x in lo.0..=hi.0 {
            let Some((ya, yb)) = y_range(x) else { continue };
            for y in ya..=yb {
                let s = self.entries.partition_point(|e| (e.0 .0, e.0 .1) < (x, y));
                let e = s + self.entries[s..].partition_point(|e| (e.0 .0, e.0 .1) <= (x, y));
                scan(s, e);
            }
        }
    }
}

/// Cells by which [`Grid::visit`] shrinks a column's distance from the ball's centre before
/// skipping it: a point's key is ⌊(p − origin) / h⌋ rounded, so it can lie a
/// rounding outside its cell; 10⁻⁶ cells is far above that.
const CLIP_SLACK: f64 = 1e-6;

/// Doublings of the search radius in [`nearest_distance`] before it scans every point.
const MAX_DOUBLINGS: usize = 60;

/// Distance from `p` to the nearest of `pts` (not empty; ∞ if empty): balls of radius h, 2h,
/// 4h, … on the grid until one holds a point (then the nearest of those is the nearest of
/// all). Bounded: with a spacing that is zero or not finite, or after [`MAX_DOUBLINGS`], the
/// full scan answers.
fn nearest_distance(grid: &Grid, pts: &[DVec3], p: DVec3, h: f64) -> f64 {
    let scan = || pts.iter().map(|q| q.distance(p)).fold(f64::INFINITY, f64::min);
    if !(h > 0.0 && h.is_finite()) {
        return scan();
    }
    let mut r = h;
    let mut out = Vec::new();
    for _ in 0..MAX_DOUBLINGS {
        out.clear();
        grid.within(pts, p, r, &mut out);
        if !out.is_empty() {
            return out.iter().map(|&i| pts[i as usize].distance(p)).fold(f64::INFINITY, f64::min);
        }
        r *= 2.0;
        if !r.is_finite() {
            break;
        }
    }
    scan()
}

/// Greedy cover; returns chosen (candidate index) in pick order, or None if more than `limit`.
fn greedy(cover: &[&[u32]], n_samples: usize, limit: usize, order: &[u32]) -> Option<Vec<usize>> {
    let mut covered = vec![false; n_samples];
    let mut left = n_samples;
    let mut heap: BinaryHeap<(usize, u32, usize)> =
        cover.iter().enumerate().map(|(i, c)| (c.len(), order[i], i)).collect();
    let mut picks = Vec::new();
    while left > 0 {
        let (cnt, o, i) = heap.pop()?;
        let real = cover[i].iter().filter(|&&s| !covered[s as usize]).count();
        if real == 0 {
            continue;
        }
        if real < cnt {
            heap.push((real, o, i));
            continue;
        }
        for &s in cover[i] {
            if !covered[s as usize] {
                covered[s as usize] = true;
                left -= 1;
            }
        }
        picks.push(i);
        if picks.len() > limit {
            return None;
        }
    }
    Some(picks)
}

/// One candidate's samples within `rho + t_max`, nearest first: (squared distance, index).
/// Its cover at any dilation t ≤ t_max is a prefix, the samples with d² ≤ (rho + t)² — the
/// same test [`Grid::within`] applies, so the set is the one a fresh query would give.
/// [`Sorted::unsorted`] holds the same entries in query order: its whole list is the cover at
/// t_max (every entry passed that test), which is all a feasibility test at t_max reads.
struct Sorted {
    d2: Vec<f64>,
    idx: Vec<u32>,
}

impl Sorted {
    /// `buf` is scratch, reused across calls (a thread's queries share one): the query's
    /// entries are gathered there, so the two lists kept are allocated once at their exact
    /// length instead of a fresh list growing by doubling per query (about 170 000
    /// reallocations in a bunny bake at `fast`). The entries and their order are the query's.
    fn unsorted(grid: &Grid, pts: &[DVec3], c: DVec3, r: f64, buf: &mut Vec<(f64, u32)>) -> Self {
        buf.clear();
        grid.within_d2(pts, c, r, buf);
        Self { d2: buf.iter().map(|x| x.0).collect(), idx: buf.iter().map(|x| x.1).collect() }
    }
    #[cfg(test)]
    fn new(grid: &Grid, pts: &[DVec3], c: DVec3, r: f64) -> Self {
        let mut s = Self::unsorted(grid, pts, c, r, &mut Vec::new());
        s.sort();
        s
    }
    /// Nearest first (ties by index).
    fn sort(&mut self) {
        let mut v: Vec<(f64, u32)> = self.d2.iter().copied().zip(self.idx.iter().copied()).collect();
        v.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for (j, (d, i)) in v.into_iter().enumerate() {
            self.d2[j] = d;
            self.idx[j] = i;
        }
    }
    /// The cover at radius r (sorted lists only).
    fn within(&self, r: f64) -> &[u32] {
        let r2 = r * r;
        &self.idx[..self.d2.partition_point(|&d| d <= r2)]
    }
}

/// Surface samples (and interior candidates) the start uses for `k` spheres: about
/// [`SAMPLES_PER_SPHERE`] per sphere, at most [`MAX_SAMPLES`]. A start needs a few samples
/// per ball to place it; more only cost time (the covers hold up to candidates × samples
/// entries: 11 s for one sphere on a 12-triangle cube with the fixed cap).
pub fn sample_cap(k: usize) -> usize {
    k.saturating_mul(SAMPLES_PER_SPHERE).clamp(MIN_SAMPLES, MAX_SAMPLES)
}

/// Samples per sphere of [`sample_cap`]: 125 keeps the full [`MAX_SAMPLES`] from 64 spheres
/// on, so the start there is the one measured in `docs/benchmarks.md`.
const SAMPLES_PER_SPHERE: usize = 125;
/// Fewest samples of [`sample_cap`].
const MIN_SAMPLES: usize = 256;

/// How [`start`] holds a set larger than [`sample_cap`] to about the cap. The two give
/// different starts, and neither is better everywhere: Lloyd runs from both when a set is
/// capped ([`is_capped`]) and keeps the lower proxy E (see [`crate::lloyd::run_multi`]), or
/// from the even one alone when the plan says so ([`crate::FitPlan::both_thinnings`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Thinning {
    /// Every s-th point in the set's order, s = ⌈len / cap⌉: between half the cap and the cap.
    /// On a lattice whose rows are a multiple of s long every row keeps the same columns (the
    /// axis-aligned unit cube's 40 × 40 × 40 interior at s = 8: the candidates lie on 5 of the
    /// 40 x-planes, none within 0.2 of the face x = 1).
    Strided,
    /// Spatially even: the interior candidates keep the first point of each cube of edge
    /// h (len / cap)^⅓ ([`crate::points::keep_per_cell`]; cubes aligned half a spacing below
    /// the set's lowest corner, so lattice points never lie on a cube face), the surface
    /// samples (in their cell-key order) the points at indices ⌊i len / cap⌋ for i < cap.
    Even,
}

/// Whether [`start`] thins a set of `surface` samples or `interior` candidates for `k` spheres
/// (only then do the two [`Thinning`]s differ).
pub fn is_capped(surface: usize, interior: usize, k: usize) -> bool {
    let cap = sample_cap(k);
    surface > cap || interior > cap
}

/// `v` held to about `cap` points by `thinning` (`dim`: 2 for surface samples, 3 for the
/// interior lattice); `v` itself when it is within the cap.
fn thin(v: &[DVec3], cap: usize, h: f64, dim: i32, thinning: Thinning) -> Vec<DVec3> {
    let cap = cap.max(1);
    if v.len() <= cap {
        return v.to_vec();
    }
    match thinning {
        Thinning::Strided => v.iter().step_by(v.len().div_ceil(cap)).copied().collect(),
        Thinning::Even if dim == 3 => {
            let lo = v.iter().fold(DVec3::splat(f64::INFINITY), |a, p| a.min(*p)) - DVec3::splat(0.5 * h);
            let cell = h * (v.len() as f64 / cap as f64).cbrt();
            let keep = crate::points::keep_per_cell(v, lo, cell, 1);
            v.iter().zip(keep).filter(|x| x.1).map(|x| *x.0).collect()
        }
        Thinning::Even => (0..cap).map(|i| v[i * v.len() / cap]).collect(),
    }
}

/// Returns up to `k` start spheres (centre, radius).
///
/// Cost: the candidates' covers are computed once per doubling of the dilation (sorted by
/// distance once the dilation is feasible), and each bisection step takes prefixes of the
/// last ones, so the queries cost O(candidates × covered samples) about twice, not once per
/// step; both sets are capped by [`sample_cap`], so the start's cost follows the sphere count.
pub fn start(
    surface_all: &[DVec3],
    interior_all: &[DVec3],
    k: usize,
    h: f64,
    seed: u64,
    thinning: Thinning,
) -> Vec<(DVec3, f64)> {
    if surface_all.is_empty() {
        return Vec::new();
    }
    // The start only needs to be roughly right: cap both sets.
    let n_cap = sample_cap(k);
    let surface = &thin(surface_all, n_cap, h, 2, thinning)[..];
    let interior = &thin(interior_all, n_cap, h, 3, thinning)[..];
    // The grid's cell: twice the thinned samples' spacing (about h √(thinning), the samples
    // lying on a surface), not h. The samples lie on a surface, so most columns a ball
    // crosses hold a few of them or none, and a query's cost is mostly its columns: at twice
    // the spacing a ball walks a quarter of them, each scanning about twice the cells
    // (bunny, `fast`: Lloyd with its two starts 0.29 → 0.24 s; at three spacings 0.26 s).
    // Queries are exact at any cell, so the start is the same.
    let cell = 2.0 * h * (surface_all.len() as f64 / surface.len().max(1) as f64).sqrt().max(1.0);
    let grid = Grid::new(surface, cell);
    // Candidates: interior points, then surface samples (ρ = 0) as a fallback.
    let cand: Vec<DVec3> = interior.iter().chain(surface.iter()).copied().collect();
    let rho: Vec<f64> = cand.par_iter().map(|p| nearest_distance(&grid, surface, *p, cell)).collect();
    let mut rng = crate::rng::SplitMix64::new(seed ^ 0x5EED_C0DE);
    let order: Vec<u32> = (0..cand.len()).map(|_| rng.next_u64() as u32).collect();
    // Each doubling's lists are sorted only once the dilation is feasible: the feasibility
    // test at the lists' own dilation reads every entry, in any order.
    let unsorted_at = |t: f64| -> Vec<Sorted> {
        cand.par_iter()
            .zip(rho.par_iter())
            .map_init(Vec::new, |buf, (p, r)| Sorted::unsorted(&grid, surface, *p, r + t, buf))
            .collect()
    };
    let greedy_at = |lists: &[Sorted], t: f64| -> Option<Vec<usize>> {
        let covers: Vec<&[u32]> = lists.iter().zip(&rho).map(|(l, r)| l.within(r + t)).collect();
        greedy(&covers, surface.len(), k, &order)
    };
    let mut lo_t = 0.0;
    let mut hi_t = h;
    // Grow hi_t until feasible.
    let mut best: Option<(f64, Vec<usize>, Vec<Sorted>)> = None;
    for _ in 0..40 {
        let mut lists = unsorted_at(hi_t);
        let whole: Vec<&[u32]> = lists.iter().map(|l| &l.idx[..]).collect();
        if let Some(p) = greedy(&whole, surface.len(), k, &order) {
            lists.par_iter_mut().for_each(Sorted::sort);
            best = Some((hi_t, p, lists));
            break;
        }
        lo_t = hi_t;
        hi_t *= 2.0;
    }
    let Some((mut t_best, mut picks, lists)) = best else { return Vec::new() };
    for _ in 0..7 {
        let mid = 0.5 * (lo_t + hi_t);
        match greedy_at(&lists, mid) {
            Some(p) => {
                hi_t = mid;
                t_best = mid;
                picks = p;
            }
            None => lo_t = mid,
        }
    }
    picks.iter().map(|&i| (cand[i], rho[i] + t_best)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_distance_ends_for_zero_and_non_finite_spacings() {
        // Before: the doubling search never ended at spacing 0 (r stays 0) or NaN (no ball
        // holds a point), and with a point far beyond the grid it looped (2r/h)² rows.
        let pts = vec![DVec3::new(1.0, 2.0, 3.0), DVec3::new(-4.0, 0.5, 2.0), DVec3::new(0.25, 0.0, -1.0)];
        let brute = |p: DVec3| pts.iter().map(|q| q.distance(p)).fold(f64::INFINITY, f64::min);
        for h in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e-300, 0.1, 1e300] {
            let grid = Grid::new(&pts, h);
            for p in [DVec3::ZERO, DVec3::new(1.0, 2.0, 3.0), DVec3::splat(1e12), DVec3::new(-3.0, 0.0, 2.0)] {
                let d = nearest_distance(&grid, &pts, p, h);
                assert_eq!(d, brute(p), "h {h}, p {p}");
            }
        }
        // The start itself ends on a point set whose spacing is 0 (one repeated point).
        let same = vec![DVec3::ONE; 4];
        let s = start(&same, &[], 2, 0.0, 1, Thinning::Strided);
        assert!(!s.is_empty() && s.len() <= 2, "{s:?}");
        assert!(s.iter().all(|(c, r)| c.distance(DVec3::ONE) <= *r + 1e-12), "{s:?}");
    }

    #[test]
    fn a_sorted_cover_gives_the_ball_at_every_smaller_radius() {
        let mut rng = crate::rng::SplitMix64::new(5);
        let pts: Vec<DVec3> = (0..400).map(|_| DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64())).collect();
        let grid = Grid::new(&pts, 0.07);
        let c = DVec3::new(0.3, 0.5, 0.45);
        let sorted = Sorted::new(&grid, &pts, c, 0.6);
        // Nearest first, ties (points at one distance: the centre's mirror images below) by
        // index, and the same (distance, index) pairs as the query found.
        let mut twins = pts.clone();
        twins.extend(pts.iter().map(|p| 2.0 * c - *p));
        let twin_grid = Grid::new(&twins, 0.07);
        let t = Sorted::new(&twin_grid, &twins, c, 0.6);
        // A scratch buffer left holding an entry from an earlier query: the list is the
        // query's alone.
        let mut want = Sorted::unsorted(&twin_grid, &twins, c, 0.6, &mut vec![(1.0, 7)]);
        let mut pairs: Vec<(f64, u32)> = want.d2.drain(..).zip(want.idx.drain(..)).collect();
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let got: Vec<(f64, u32)> = t.d2.iter().copied().zip(t.idx.iter().copied()).collect();
        assert_eq!(got, pairs);
        assert!(got.windows(2).any(|w| w[0].0 == w[1].0), "the test should hold ties");
        for r in [0.0, 0.05, 0.21, 0.37, 0.6] {
            let mut got = sorted.within(r).to_vec();
            got.sort_unstable();
            let want: Vec<u32> = (0..400u32).filter(|&i| pts[i as usize].distance_squared(c) <= r * r).collect();
            assert_eq!(got, want, "r {r}");
        }
    }

    #[test]
    fn the_start_uses_few_samples_for_few_spheres_and_covers_them() {
        assert_eq!(sample_cap(1), MIN_SAMPLES);
        assert_eq!(sample_cap(64), MAX_SAMPLES);
        assert_eq!(sample_cap(4096), MAX_SAMPLES);
        assert!(sample_cap(8) < sample_cap(16) && sample_cap(16) < sample_cap(32));
        // A 20 x 20 x 20 lattice's boundary as the surface, its inside as the candidates:
        // at most k balls, and every capped sample lies in one of them.
        let mut surface = Vec::new();
        let mut interior = Vec::new();
        for i in 0..20 {
            for j in 0..20 {
                for l in 0..20 {
                    let p = DVec3::new(i as f64, j as f64, l as f64) * 0.05;
                    if [i, j, l].iter().any(|&x| x == 0 || x == 19) {
                        surface.push(p);
                    } else {
                        interior.push(p);
                    }
                }
            }
        }
        for k in [1, 3, 16] {
            for t in [Thinning::Strided, Thinning::Even] {
                let balls = start(&surface, &interior, k, 0.05, 7, t);
                assert!(!balls.is_empty() && balls.len() <= k, "k {k}: {}", balls.len());
                let capped = thin(&surface, sample_cap(k), 0.05, 2, t);
                assert!(capped.len() <= sample_cap(k), "k {k} {t:?}: {}", capped.len());
                for p in &capped {
                    assert!(balls.iter().any(|(c, r)| c.distance(*p) <= *r * (1.0 + 1e-12)), "k {k}: {p} uncovered");
                }
            }
        }
    }

    #[test]
    fn the_even_thinning_spans_an_axis_aligned_lattice_and_keeps_about_the_cap() {
        let h = 0.025;
        let lattice = |n: usize| -> Vec<DVec3> {
            let mut v = Vec::new();
            for k in 0..n {
                for j in 0..n {
                    for i in 0..n {
                        v.push(DVec3::new(i as f64, j as f64, k as f64) * h);
                    }
                }
            }
            v
        };
        let planes = |v: &[DVec3]| -> Vec<i64> {
            let mut x: Vec<i64> = v.iter().map(|p| (p.x / h).round() as i64).collect();
            x.sort_unstable();
            x.dedup();
            x
        };
        // The unit cube's 40³ interior lattice at the cap of 64 spheres (8000): a stride of 8
        // keeps x-planes 0, 8, ..., 32 only; cubes of 2 spacings keep every other plane,
        // 20³ = 8000 points.
        let cube = lattice(40);
        let strided = thin(&cube, 8000, h, 3, Thinning::Strided);
        assert_eq!(planes(&strided), vec![0, 8, 16, 24, 32]);
        let even = thin(&cube, 8000, h, 3, Thinning::Even);
        assert_eq!(even.len(), 8000);
        assert_eq!(planes(&even), (0..20).map(|i| 2 * i).collect::<Vec<_>>());
        // A set just over the cap: the stride halves it (22³ = 10 648 → 5324); cubes of
        // 1.1 spacings hold 20 of the 22 lattice planes per axis, 20³ = 8000.
        let over = lattice(22);
        assert_eq!(thin(&over, 8000, h, 3, Thinning::Strided).len(), 5324);
        let even = thin(&over, 8000, h, 3, Thinning::Even);
        assert_eq!(even.len(), 8000);
        let xs = planes(&even);
        assert_eq!((xs[0], *xs.last().unwrap(), xs.len()), (0, 21, 20));
        // Surface samples: exactly the cap, in order, first and spread to the end.
        let surf = thin(&over, 8000, h, 2, Thinning::Even);
        assert_eq!(surf.len(), 8000);
        assert_eq!(surf[0], over[0]);
        assert!(surf.windows(2).all(|w| w[0] != w[1]));
        assert_eq!(surf[7999], over[7999 * over.len() / 8000]);
        // Within the cap both return the set itself.
        let small = lattice(10);
        for t in [Thinning::Strided, Thinning::Even] {
            assert_eq!(thin(&small, 8000, h, 3, t), small);
        }
    }

    #[test]
    fn within_keeps_points_exactly_on_the_ball_and_on_cell_faces() {
        // A lattice at the grid's own spacing: every point lies on a cell face, and balls
        // centred on lattice points with radii equal to lattice distances put points exactly on
        // the sphere (d² = r², kept), so a column skipped by a rounding would lose them.
        let h = 0.1;
        let pts: Vec<DVec3> =
            (0..8 * 8 * 8).map(|i| DVec3::new((i % 8) as f64, ((i / 8) % 8) as f64, (i / 64) as f64) * h).collect();
        let mut grid = Grid::new(&pts, h);
        for dense in [true, false] {
            if !dense {
                grid.columns = None;
            }
            for &c in &[pts[0], pts[3 + 8 * 4 + 64 * 2], pts[7 + 8 * 7 + 64 * 7], DVec3::new(0.35, 0.35, 0.35)] {
                for r2u in [1.0, 2.0, 3.0, 5.0, 9.0, 14.0] {
                    let r = f64::sqrt(r2u) * h;
                    let mut got = Vec::new();
                    grid.within_d2(&pts, c, r, &mut got);
                    got.sort_by_key(|x| x.1);
                    let want: Vec<(f64, u32)> = (0..pts.len() as u32)
                        .map(|i| (pts[i as usize].distance_squared(c), i))
                        .filter(|x| x.0 <= r * r)
                        .collect();
                    assert_eq!(got, want, "c {c}, r² {r2u} h², dense {dense}");
                }
            }
        }
    }

    #[test]
    fn within_finds_exactly_the_points_in_the_ball_on_either_path() {
        let mut rng = crate::rng::SplitMix64::new(11);
        let pts: Vec<DVec3> = (0..300).map(|_| DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64())).collect();
        let mut grid = Grid::new(&pts, 0.05);
        assert!(grid.columns.is_some());
        for dense in [true, false] {
            if !dense {
                grid.columns = None;
            }
            for r in [0.0, 0.03, 0.2, 0.9, 5.0] {
                for c in [DVec3::new(0.4, 0.6, 0.5), DVec3::new(-0.2, 1.1, 0.5), DVec3::splat(0.97)] {
                    let mut got = Vec::new();
                    grid.within(&pts, c, r, &mut got);
                    got.sort_unstable();
                    let want: Vec<u32> =
                        (0..300u32).filter(|&i| pts[i as usize].distance_squared(c) <= r * r).collect();
                    assert_eq!(got, want, "r {r}, c {c}, dense {dense}");
                }
            }
        }
    }
}
