//! Stages 2 and 3 of the variational sphere-set fit (Ren et al. 2006 §6.2 after Wang et al.
//! 2006). Lloyd ([`run`]): from the inner-ball cover start, power assignment (each point to
//! the containing sphere it lies deepest in; [`cluster`], the paper's flood fill, only when the
//! cover start is empty), per-cluster Powell centre update, cluster teleportation when progress
//! stalls. Polish ([`polish`]): the same on the dense point set, with joint radius shrinking.
//! Energies here use the voxel proxy of [`crate::solid::Solid::ball_volume`]; the exact energy
//! is computed once on the final, exactly bounding result.

use crate::ballgrid::BallGrid;
use crate::cover;
use crate::descent::{cheapest_of_three_nearest, Growth};
use crate::points::{PointSet, Rep};
use crate::powell::powell;
use crate::rng::SplitMix64;
use crate::solid::Solid;
use glam::DVec3;
use rayon::prelude::*;
use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::f64::consts::PI;

#[derive(Clone, Copy)]
pub struct Ctx<'a> {
    pub solid: &'a Solid,
    pub pts: &'a PointSet,
    /// The dense point set the spheres must bound: every mesh vertex, edge midpoint and
    /// triangle centroid, and the clustering points. Assignment and centre updates work on it.
    pub all: &'a [Rep],
    pub powell_sweeps: usize,
}

#[derive(Clone)]
pub struct State {
    pub centres: Vec<DVec3>,
    pub radii: Vec<f64>,
    pub assign: Vec<u32>,
    pub outside: Vec<f64>,
    /// The centre each cluster's update started from (its Powell search's x₀): with the same
    /// members, an update from the same start gives the same result, which [`update`] reuses.
    pub start: Vec<DVec3>,
}

impl State {
    pub fn energy(&self) -> f64 {
        self.outside.iter().sum()
    }
}

/// Outside volume as a function of radius for a fixed centre, tabulated lazily.
struct Radial {
    c: DVec3,
    step: f64,
    vals: Vec<f64>,
}

impl Radial {
    fn get(&mut self, solid: &Solid, r: f64) -> f64 {
        let m = r / self.step;
        let i = m.floor() as usize;
        while self.vals.len() <= i + 1 {
            let rr = self.vals.len() as f64 * self.step;
            self.vals.push(solid.outside(self.c, rr));
        }
        let f = m - i as f64;
        self.vals[i] * (1.0 - f) + self.vals[i + 1] * f
    }
}

#[derive(PartialEq)]
struct Item {
    cost: f64,
    tie: f64,
    point: u32,
}
impl Eq for Item {}
impl Ord for Item {
    fn cmp(&self, o: &Self) -> Ordering {
        // Min-heap on (cost, point).
        o.cost.total_cmp(&self.cost).then(o.tie.total_cmp(&self.tie)).then(o.point.cmp(&self.point))
    }
}
impl PartialOrd for Item {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

/// Flood-fill clustering from the current centres: each point, in order of least error, joins
/// the cluster (among those of its already clustered neighbours) whose sphere — centre fixed,
/// radius extended to the point — grows least in outside volume (ties: nearer centre).
/// Keys are re-checked when popped (lazy priority queue). Returns assignment and radii.
pub fn cluster(ctx: &Ctx, centres: &[DVec3], init_radii: Option<&[f64]>) -> (Vec<u32>, Vec<f64>) {
    let pts = &ctx.pts.points;
    let n = pts.len();
    let k = centres.len();
    let mut assign = vec![u32::MAX; n];
    let r0: Vec<f64> = init_radii.map(|r| r.to_vec()).unwrap_or(vec![0.0; k]);
    let mut radii = r0.clone();
    let mut tables: Vec<Radial> = centres.iter().map(|&c| Radial { c, step: ctx.solid.h, vals: Vec::new() }).collect();
    let mut heap = BinaryHeap::new();
    let mut remaining = n;
    // Seeds: the nearest not-yet-seeded point to each centre.
    for (ci, &c) in centres.iter().enumerate() {
        let mut best = None;
        let mut bd = f64::INFINITY;
        for (i, p) in pts.iter().enumerate() {
            if assign[i] != u32::MAX {
                continue;
            }
            let d = p.distance_squared(c);
            if d < bd {
                bd = d;
                best = Some(i);
            }
        }
        if let Some(i) = best {
            assign[i] = ci as u32;
            radii[ci] = radii[ci].max(bd.sqrt());
            remaining -= 1;
        }
    }
    // (Δ outside volume, power w.r.t. the starting sphere, distance)
    let cost_of = |ci: usize, q: usize, radii: &[f64], tables: &mut [Radial]| -> (f64, f64, f64) {
        let d2 = pts[q].distance_squared(centres[ci]);
        let d = d2.sqrt();
        let tie = d2 - r0[ci] * r0[ci];
        if d <= radii[ci] {
            (0.0, tie, d)
        } else {
            let t = &mut tables[ci];
            ((t.get(ctx.solid, d) - t.get(ctx.solid, radii[ci])).max(0.0), tie, d)
        }
    };
    for i in 0..n {
        if assign[i] != u32::MAX {
            for &q in ctx.pts.neighbours(i) {
                if assign[q as usize] == u32::MAX {
                    let (c, tie, _) = cost_of(assign[i] as usize, q as usize, &radii, &mut tables);
                    heap.push(Item { cost: c, tie, point: q });
                }
            }
        }
    }
    let mut cands: Vec<u32> = Vec::with_capacity(16);
    loop {
        while let Some(it) = heap.pop() {
            let p = it.point as usize;
            if assign[p] != u32::MAX {
                continue;
            }
            cands.clear();
            for &q in ctx.pts.neighbours(p) {
                let a = assign[q as usize];
                if a != u32::MAX && !cands.contains(&a) {
                    cands.push(a);
                }
            }
            let mut best = (f64::INFINITY, f64::INFINITY, f64::INFINITY, u32::MAX);
            for &ci in &cands {
                let (c, tie, d) = cost_of(ci as usize, p, &radii, &mut tables);
                if (c, tie, d, ci) < best {
                    best = (c, tie, d, ci);
                }
            }
            if best.3 == u32::MAX {
                continue;
            }
            if (best.0, best.1) < (it.cost, it.tie) {
                heap.push(Item { cost: best.0, tie: best.1, point: it.point });
                continue;
            }
            let ci = best.3 as usize;
            assign[p] = best.3;
            remaining -= 1;
            if best.2 > radii[ci] {
                radii[ci] = best.2;
            }
            for &q in ctx.pts.neighbours(p) {
                if assign[q as usize] == u32::MAX {
                    let (c, tie, _) = cost_of(ci, q as usize, &radii, &mut tables);
                    heap.push(Item { cost: c, tie, point: q });
                }
            }
        }
        if remaining == 0 {
            break;
        }
        // Unreached components: attach the first unassigned point to the cheapest cluster.
        let p = assign.iter().position(|&a| a == u32::MAX).unwrap_or(0);
        let mut best = (f64::INFINITY, f64::INFINITY, f64::INFINITY, 0usize);
        for ci in 0..k {
            let (c, tie, d) = cost_of(ci, p, &radii, &mut tables);
            if (c, tie, d) < (best.0, best.1, best.2) {
                best = (c, tie, d, ci);
            }
        }
        assign[p] = best.3 as u32;
        remaining -= 1;
        radii[best.3] = radii[best.3].max(best.2);
        for &q in ctx.pts.neighbours(p) {
            if assign[q as usize] == u32::MAX {
                let (c, tie, _) = cost_of(best.3, q as usize, &radii, &mut tables);
                heap.push(Item { cost: c, tie, point: q });
            }
        }
    }
    (assign, radii)
}

/// Polish: a member within this factor × another sphere's radius of its centre is exempt from
/// its own sphere's centre update (all rounds but the last).
const EXEMPT_FACTOR: f64 = 1.01;

/// Power assignment: each point joins the containing sphere in which it lies deepest
/// (least power d² − r²), or else the sphere whose volume grows least to reach it. With the
/// spheres of the previous update every point is contained, so no cluster's bounding radius at
/// its old centre grows and the following centre update cannot increase E.
///
/// The containing spheres come from a [`BallGrid`] (the candidates of the point's cell, in
/// index order, so the choice is the full scan's); only a point no sphere contains scans them
/// all. Cost O(points × spheres per cell) instead of O(points × spheres).
pub fn power_assign(pts: &[Rep], centres: &[DVec3], radii: &[f64]) -> Vec<u32> {
    let balls: Vec<(DVec3, f64)> = centres.iter().copied().zip(radii.iter().copied()).collect();
    let grid = BallGrid::new(&balls);
    pts.par_iter()
        .map_init(Vec::new, |cand, p| {
            grid.at(p.p, cand);
            let mut best_in = (f64::INFINITY, u32::MAX);
            for &i in cand.iter() {
                let (c, r) = (centres[i as usize], radii[i as usize]);
                // A candidate whose power is certainly above 0 (not containing) or not below
                // the best so far cannot be chosen: skipped before the costlier `far`.
                let lb = power_lower_bound(p.p.distance_squared(c), r * r);
                if lb > 0.0 || lb >= best_in.0 {
                    continue;
                }
                let d2 = p.far(c).powi(2);
                let pw = d2 - r * r;
                if pw <= 0.0 && pw < best_in.0 {
                    best_in = (pw, i);
                }
            }
            if best_in.1 != u32::MAX {
                return best_in.1;
            }
            let mut best_out = (f64::INFINITY, u32::MAX);
            for (i, (c, r)) in centres.iter().zip(radii).enumerate() {
                let d2 = p.far(*c).powi(2);
                if d2 - r * r > 0.0 {
                    let g = d2 * d2.sqrt() - r * r * r;
                    if g < best_out.0 {
                        best_out = (g, i as u32);
                    }
                }
            }
            best_out.1
        })
        .collect()
}

/// Relative slack of [`power_lower_bound`]: far beyond the few roundings (each ≤ 2⁻⁵³
/// relative) that separate its value from the power [`power_assign`] computes.
const POWER_SLACK: f64 = 1e-12;

/// A lower bound of the power `far(c)² − r²` as [`power_assign`] computes it, from the squared
/// distance `d2` = |p − c|² of the representative's point and `r2` = r²: `far` is at least
/// |p − c| (a representative's samples include its point: exactly |p − c| for a point, the
/// bound of a disc or slab with s, t ≥ 0 at least that), so the computed power is at least
/// d2 − r2 up to a few roundings, which the relative slack and an absolute `f64::MIN_POSITIVE`
/// (roundings among subnormals) more than cover. A NaN never skips (comparisons false).
fn power_lower_bound(d2: f64, r2: f64) -> f64 {
    (d2 - r2) - (POWER_SLACK * (d2 + r2) + f64::MIN_POSITIVE)
}

/// Assignment for a point set the spheres do not yet cover: covered points as in
/// [`power_assign`]; uncovered points, farthest out first, each grow the sphere (of the three
/// nearest to reaching it) whose proxy outside volume grows least, radii updated as they go so
/// one growth serves many neighbouring points. Deterministic (sequential over the uncovered).
pub fn assign_grow(solid: &Solid, pts: &[Rep], centres: &[DVec3], radii: &[f64]) -> Vec<u32> {
    let mut assign = power_assign(pts, centres, radii);
    let mut r = radii.to_vec();
    let balls: Vec<(DVec3, f64)> = centres.iter().copied().zip(radii.iter().copied()).collect();
    let grid = BallGrid::new(&balls);
    let mut out: Vec<(f64, u32)> = pts
        .par_iter()
        .enumerate()
        .map_init(Vec::new, |cand, (i, p)| {
            // Covered (a candidate of its cell contains it): no gap; else the full scan.
            grid.at(p.p, cand);
            if cand.iter().any(|&j| p.far(centres[j as usize]) - radii[j as usize] <= 0.0) {
                return None;
            }
            let gap = centres.iter().zip(radii).map(|(c, rr)| p.far(*c) - rr).fold(f64::INFINITY, f64::min);
            (gap > 0.0).then_some((gap, i as u32))
        })
        .flatten()
        .collect();
    out.sort_unstable_by(crate::largest_first);
    for &(_, i) in &out {
        let p = &pts[i as usize];
        let gaps = centres.iter().enumerate().map(|(ci, c)| (ci, p.far(*c) - r[ci]));
        let cost = |ci: usize| solid.outside(centres[ci], p.far(centres[ci])) - solid.outside(centres[ci], r[ci]);
        match cheapest_of_three_nearest(gaps, cost) {
            Growth::Inside(ci) => assign[i as usize] = ci as u32,
            Growth::Grow(ci) => {
                r[ci] = p.far(centres[ci]);
                assign[i as usize] = ci as u32;
            }
            Growth::Nothing => {}
        }
    }
    assign
}

/// Per-cluster members, in point order.
pub fn members(assign: &[u32], k: usize) -> Vec<Vec<u32>> {
    let mut m = vec![Vec::new(); k];
    for (i, &a) in assign.iter().enumerate() {
        if (a as usize) < k {
            m[a as usize].push(i as u32);
        }
    }
    m
}

/// A member of a [`FarQuery`]: a conservative representative (Lloyd and the polish) or a
/// point (the descent, whose squared distances need no root).
pub(crate) trait FarMember: Copy {
    /// Distance from `c` (an upper bound for a representative; 1-Lipschitz in `c`).
    fn far_from(&self, c: DVec3) -> f64;
    /// Its square.
    fn far2(&self, c: DVec3) -> f64;
}

impl FarMember for Rep {
    fn far_from(&self, c: DVec3) -> f64 {
        self.far(c)
    }
    fn far2(&self, c: DVec3) -> f64 {
        self.far(c).powi(2)
    }
}

impl FarMember for DVec3 {
    fn far_from(&self, c: DVec3) -> f64 {
        self.distance(c)
    }
    fn far2(&self, c: DVec3) -> f64 {
        self.distance_squared(c)
    }
}

/// Buckets of a [`FarQuery`] at most (and about one per [`FAR_BUCKET_MEMBERS`] members); at
/// most 256, since [`FarQuery::rebucket`] keeps each member's bucket as a `u8`.
const FAR_BUCKETS: usize = 64;
const _: () = assert!(FAR_BUCKETS <= 256);
/// Members per bucket of a [`FarQuery`] aimed at.
const FAR_BUCKET_MEMBERS: usize = 8;
/// Relative slack of a [`FarQuery`]'s triangle bound d₀ + |c − c0|: computed in floating point
/// it can fall an ulp or two short of the distance it bounds (when c0 lies nearly on the line
/// from the member to c); a relative 10⁻¹² covers the few roundings of the three distances.
const FAR_BOUND_SLACK: f64 = 1.0 + 1e-12;

/// (distance, index) pairs in farthest-first order ([`crate::largest_first`]: ties to the lower
/// index, so the order is total and unique), sorted only as far as they are read. A radius transfer
/// ([`crate::descent`]'s and Lloyd's) hands over the farthest members one by one and stops
/// once the spheres that take them grow more than the shrinking one can lose: on the bunny
/// (`fast`) after 87 of 737 members on average. So instead of sorting them all, each read past
/// the sorted front selects the next chunk (as many as are sorted, at least an eighth of all
/// and at least [`FarthestFirst::FIRST`]) and sorts only it: the same entries at the same
/// places as a full sort, at O(n) per chunk plus the sort of what is read. The same files;
/// instructions of a whole bake (cachegrind, seed 1): the bunny −3.1 % (default) and −1.4 %
/// (`fast`), the unit cube −3.5 % and −1.4 % (chunks of a quarter: about the same; growing
/// from 32 alone: −0.7 % on the fast bunny).
pub(crate) struct FarthestFirst {
    /// Each entry as one integer ([`FarthestFirst::key`]) whose ascending order is the order,
    /// so the selections and sorts compare integers instead of calling
    /// [`crate::largest_first`] (whose `total_cmp` transforms both distances at every
    /// comparison): the same order, so the same entries at the same places; a fast bunny bake
    /// −0.5 % instructions.
    v: Vec<u128>,
    /// `v[..done]` holds the first `done` entries of the order, in order; the rest follow them
    /// in the order but not among themselves.
    done: usize,
}

impl FarthestFirst {
    /// The first chunk sorted.
    const FIRST: usize = 32;

    pub(crate) fn new(v: impl IntoIterator<Item = (f64, u32)>) -> Self {
        Self { v: v.into_iter().map(Self::key).collect(), done: 0 }
    }

    /// (d, i) as an integer ordered as [`crate::largest_first`] orders the pairs: the bits of
    /// d mapped as `f64::total_cmp` maps them (negative values' magnitude bits flipped), then
    /// made unsigned (sign bit flipped) and complemented (largest first), above the index.
    fn key((d, i): (f64, u32)) -> u128 {
        let b = d.to_bits();
        let t = b ^ (((b as i64 >> 63) as u64) >> 1);
        (u128::from(!(t ^ (1 << 63))) << 32) | u128::from(i)
    }

    /// The pair of a [`FarthestFirst::key`] (the total_cmp mapping is its own inverse: it
    /// keeps the sign bit it depends on).
    fn pair(k: u128) -> (f64, u32) {
        let t = !((k >> 32) as u64) ^ (1 << 63);
        (f64::from_bits(t ^ (((t as i64 >> 63) as u64) >> 1)), k as u32)
    }

    pub(crate) fn len(&self) -> usize {
        self.v.len()
    }

    /// Entry `n` of the order (panics when n ≥ len, as indexing would).
    pub(crate) fn at(&mut self, n: usize) -> (f64, u32) {
        if n >= self.done {
            self.sort_through(n);
        }
        Self::pair(self.v[n])
    }

    /// The first `n` entries, in order.
    pub(crate) fn prefix(&mut self, n: usize) -> impl Iterator<Item = (f64, u32)> + '_ {
        if n > 0 {
            self.sort_through(n - 1);
        }
        self.v[..n].iter().map(|&k| Self::pair(k))
    }

    /// The entries after the first `n`, in no particular order.
    pub(crate) fn rest(&mut self, n: usize) -> impl Iterator<Item = (f64, u32)> + '_ {
        if n > 0 {
            self.sort_through(n - 1);
        }
        self.v[n..].iter().map(|&k| Self::pair(k))
    }

    fn sort_through(&mut self, n: usize) {
        while self.done <= n && self.done < self.v.len() {
            let chunk = self.done.max(Self::FIRST).max(self.v.len() / 8);
            let rest = &mut self.v[self.done..];
            if chunk + 1 < rest.len() {
                // rest[chunk] is then the entry of rank `chunk` among the rest, the `chunk`
                // before it those ranked before it.
                rest.select_nth_unstable(chunk);
                rest[..chunk].sort_unstable();
                self.done += chunk + 1;
            } else {
                rest.sort_unstable();
                self.done = self.v.len();
            }
        }
    }
}

/// Members grouped by their distance from a reference centre c0 into buckets of decreasing
/// distance (a counting sort, O(members); members in their given order within a bucket): the
/// farthest-member distance from any centre, exact, by a scan that stops at the first bucket
/// whose largest d₀ + |c − c0| (the triangle inequality) cannot beat the best so far, and
/// inside a bucket skips each member whose d₀ + |c − c0| cannot. The bound carries a relative
/// slack of [`FAR_BOUND_SLACK`], so a member is skipped only when its distance cannot beat the
/// best: the scans return exactly the brute-force maximum, whatever order they read the
/// members in (the scan before sorted them by d₀, about 4 % of a bunny bake, and had no
/// slack: it could miss the maximum by an ulp).
pub(crate) struct FarQuery<M> {
    c0: DVec3,
    /// (far distance from c0, member), grouped by bucket, the bucket of largest d₀ first.
    members: Vec<(f64, M)>,
    /// Per bucket: (end index in `members`, largest d₀ in it); empty buckets left out.
    buckets: Vec<(usize, f64)>,
}

impl<M: FarMember> FarQuery<M> {
    pub(crate) fn new(pts: &[M], mem: &[u32], c0: DVec3) -> Self {
        let mut q = Self { c0, members: Vec::new(), buckets: Vec::new() };
        q.rebucket(pts, mem, c0);
        q
    }

    /// The same query as [`FarQuery::new`] from `c0`, in place: its vectors are reused.
    ///
    /// The distances go to a buffer of their own (8 bytes a member) with the range folded into
    /// the same pass, and the members are written once, to their places: building the
    /// (distance, member) pairs first and moving them (32 bytes a point, twice) cost about as
    /// much as the distances.
    pub(crate) fn rebucket(&mut self, pts: &[M], mem: &[u32], c0: DVec3) {
        self.c0 = c0;
        self.members.clear();
        self.buckets.clear();
        let Some(&first) = mem.first() else {
            return;
        };
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        let far: Vec<f64> = mem
            .iter()
            .map(|&i| {
                let d = pts[i as usize].far_from(c0);
                (lo, hi) = (lo.min(d), hi.max(d));
                d
            })
            .collect();
        let nb = (far.len() / FAR_BUCKET_MEMBERS).clamp(1, FAR_BUCKETS);
        // Bucket 0 holds the largest distances. A width of 0 (one distance) or a non-finite
        // one puts every member in bucket 0; so does a NaN distance.
        let scale = if hi > lo && (hi - lo).is_finite() { nb as f64 / (hi - lo) } else { 0.0 };
        // Cast to u32 (nb ≤ FAR_BUCKETS fits): the same index as a cast to usize (both
        // saturate, NaN to 0) in about half the instructions.
        let bucket = |d: f64| (((hi - d) * scale) as u32).min(nb as u32 - 1) as u8;
        let mut count = [0usize; FAR_BUCKETS + 1];
        let mut top = [f64::NEG_INFINITY; FAR_BUCKETS];
        let of: Vec<u8> = far
            .iter()
            .map(|&d| {
                let b = bucket(d);
                count[b as usize + 1] += 1;
                top[b as usize] = top[b as usize].max(d);
                b
            })
            .collect();
        for b in 0..nb {
            count[b + 1] += count[b];
        }
        let mut next = count;
        self.members.resize(far.len(), (far[0], pts[first as usize]));
        for ((&d, &b), &i) in far.iter().zip(&of).zip(mem) {
            let at = &mut next[b as usize];
            self.members[*at] = (d, pts[i as usize]);
            *at += 1;
        }
        self.buckets.extend((0..nb).filter(|&b| count[b + 1] > count[b]).map(|b| (count[b + 1], top[b])));
    }

    /// The reference centre the members are bucketed by.
    pub(crate) fn centre(&self) -> DVec3 {
        self.c0
    }

    /// max |p − c| over the members (0 for none).
    pub(crate) fn max_dist(&self, c: DVec3) -> f64 {
        let shift = c.distance(self.c0);
        let mut best2 = 0.0f64;
        let mut start = 0;
        for &(end, top) in &self.buckets {
            let ub = (top + shift) * FAR_BOUND_SLACK;
            if ub * ub <= best2 {
                break;
            }
            for &(d0, p) in &self.members[start..end] {
                // Skipped only when the bound holds (a NaN bound is read).
                let ub = (d0 + shift) * FAR_BOUND_SLACK;
                if ub * ub <= best2 {
                    continue;
                }
                best2 = best2.max(p.far2(c));
            }
            start = end;
        }
        best2.sqrt()
    }
}

impl FarQuery<DVec3> {
    /// `out[i]` = max |p − xs[i]| over point members for the 14 centres `xs` of a pattern
    /// step, in one scan, the same bits as [`FarQuery::max_dist`] at each: the scan stops once
    /// d₀ + max |xs[i] − c0| cannot beat the least of the 14 maxima (a bucket's largest d₀ at
    /// its start, each member's within it).
    ///
    /// The least of the maxima is taken at each bucket's start only, and members within the
    /// bucket are skipped against it: it only grows, so an older value is a weaker bound and
    /// still skips only members that cannot beat any maximum (the answer is the same bits).
    /// Measured on the fast bunny: 97 % of the members read are scanned even with the least
    /// taken after every member, whose 16-way running minimum cost a third of this scan;
    /// with [`least`] and 14 lanes instead of 16, the whole bake −1.7 % instructions.
    pub(crate) fn max_dists(&self, xs: &[DVec3; 14], out: &mut [f64; 14]) {
        let shift = xs.iter().map(|x| x.distance(self.c0)).fold(0.0, f64::max);
        // The centres by coordinate: the per-member loop is then plain lanes the compiler
        // vectorizes. Each squared distance is glam's `distance_squared`, (dx² + dy²) + dz²,
        // so the bits are those of `max_dist`.
        let lane = |f: fn(&DVec3) -> f64| -> [f64; 14] { std::array::from_fn(|i| f(&xs[i])) };
        let (ax, ay, az) = (lane(|v| v.x), lane(|v| v.y), lane(|v| v.z));
        let mut best = [0.0f64; 14];
        let mut start = 0;
        for &(end, top) in &self.buckets {
            let floor = least(&best);
            let ub = (top + shift) * FAR_BOUND_SLACK;
            if ub * ub <= floor {
                break;
            }
            for &(d0, p) in &self.members[start..end] {
                let ub = (d0 + shift) * FAR_BOUND_SLACK;
                if ub * ub <= floor {
                    continue;
                }
                // Plain comparisons: the values are finite, and they compile to max/min.
                for i in 0..14 {
                    let (dx, dy, dz) = (p.x - ax[i], p.y - ay[i], p.z - az[i]);
                    let v = dx * dx + dy * dy + dz * dz;
                    best[i] = if v > best[i] { v } else { best[i] };
                }
            }
            start = end;
        }
        for i in 0..14 {
            out[i] = best[i].sqrt();
        }
    }
}

/// The least of [`FarQuery::max_dists`]'s 14 maxima, by halving (lane-wise minima the compiler
/// vectorizes, where a running minimum is a chain of dependent scalar steps): 14 to 8 (entries
/// 0–7 against 6–13, the overlap harmless for a minimum), then 4, 2, 1. The maxima are never
/// NaN (they start at 0 and take only greater values), so the least is the same value in any
/// order of comparison.
fn least(v: &[f64; 14]) -> f64 {
    let half = |v: &[f64], out: &mut [f64]| {
        let n = out.len();
        for i in 0..n {
            out[i] = if v[i + v.len() - n] < v[i] { v[i + v.len() - n] } else { v[i] };
        }
    };
    let (mut a, mut b, mut c, mut d) = ([0.0f64; 8], [0.0f64; 4], [0.0f64; 2], [0.0f64; 1]);
    half(v, &mut a);
    half(&a, &mut b);
    half(&b, &mut c);
    half(&c, &mut d);
    d[0]
}

fn max_dist(pts: &[Rep], mem: &[u32], c: DVec3) -> f64 {
    let mut m = 0.0f64;
    for &i in mem {
        m = m.max(pts[i as usize].far(c));
    }
    m
}

/// Moves each centre (Powell) to minimise the proxy outside volume of the smallest sphere at
/// that centre bounding the cluster. Parallel over clusters, deterministic.
///
/// `memo`: an earlier update of the same run. A cluster with the same members that starts
/// from the same centre (bit for bit) as one of `memo`'s takes that cluster's result instead of
/// searching again: the search is a deterministic function of both, so the result is the same
/// bits. Once Lloyd settles, most clusters keep their members and most searches return their
/// start, so their next update starts where the last one did: at 64 spheres about half of the
/// bunny's and the capsule's updates are reused (Lloyd's stage 0.73 → 0.63 s on the bunny).
pub fn update(ctx: &Ctx, centres: &[DVec3], assign: &[u32], memo: Option<&State>) -> State {
    let k = centres.len();
    let mem = members(assign, k);
    let pts = ctx.all;
    let memo = memo.filter(|m| m.start.len() == k).map(|m| (m, members(&m.assign, k)));
    let res: Vec<(DVec3, f64, f64)> = (0..k)
        .into_par_iter()
        .map(|ci| {
            let m = &mem[ci];
            if m.is_empty() {
                return (centres[ci], 0.0, 0.0);
            }
            if let Some((st, old)) = &memo {
                if same_bits(st.start[ci], centres[ci]) && old[ci] == *m {
                    return (st.centres[ci], st.radii[ci], st.outside[ci]);
                }
            }
            let fq = FarQuery::new(pts, m, centres[ci]);
            let mut f = |x: [f64; 3]| {
                let c = DVec3::from_array(x);
                ctx.solid.outside(c, fq.max_dist(c))
            };
            let r0 = fq.max_dist(centres[ci]);
            let step = 0.25 * r0 + ctx.pts.h;
            let res = powell(&mut f, centres[ci].to_array(), step, ctx.powell_sweeps, 1e-3);
            let c = DVec3::from_array(res.x);
            (c, max_dist(pts, m, c), res.f)
        })
        .collect();
    State {
        centres: res.iter().map(|x| x.0).collect(),
        radii: res.iter().map(|x| x.1).collect(),
        assign: assign.to_vec(),
        outside: res.iter().map(|x| x.2).collect(),
        start: centres.to_vec(),
    }
}

fn lens(c1: DVec3, r1: f64, c2: DVec3, r2: f64) -> f64 {
    let d = c1.distance(c2);
    if d >= r1 + r2 {
        return 0.0;
    }
    if d <= (r1 - r2).abs() {
        let r = r1.min(r2);
        return 4.0 / 3.0 * PI * r * r * r;
    }
    PI * (r1 + r2 - d).powi(2) * (d * d + 2.0 * d * (r1 + r2) - 3.0 * (r1 - r2).powi(2)) / (12.0 * d)
}

/// Teleportation proposal: split the cluster of maximal outside volume at its farthest pair,
/// delete the cluster of maximal relative overlap. Returns the new centres or `None`.
pub fn teleport(ctx: &Ctx, st: &State, skip: usize) -> Option<(Vec<DVec3>, Vec<f64>)> {
    let k = st.centres.len();
    if k < 2 {
        return None;
    }
    let pts = ctx.all;
    let mem = members(&st.assign, k);
    let mut by_out: Vec<usize> = (0..k).filter(|&i| mem[i].len() >= 2).collect();
    by_out.sort_unstable_by(|&a, &b| st.outside[b].total_cmp(&st.outside[a]).then(a.cmp(&b)));
    let worst = *by_out.get(skip).or(by_out.first())?;
    let overlap = |j: usize| -> f64 {
        let vj = 4.0 / 3.0 * PI * st.radii[j].powi(3);
        if vj <= 0.0 {
            return f64::INFINITY;
        }
        (0..k).filter(|&l| l != j).map(|l| lens(st.centres[j], st.radii[j], st.centres[l], st.radii[l])).sum::<f64>()
            / vj
    };
    let del = (0..k).filter(|&j| j != worst).max_by(|&a, &b| overlap(a).total_cmp(&overlap(b)).then(b.cmp(&a)))?;
    let m = &mem[worst];
    let far = |from: DVec3| -> DVec3 {
        let mut best = pts[m[0] as usize].p;
        let mut bd = -1.0;
        for &i in m {
            let d = pts[i as usize].p.distance_squared(from);
            if d > bd {
                bd = d;
                best = pts[i as usize].p;
            }
        }
        best
    };
    let a = far(st.centres[worst]);
    let b = far(a);
    if a == b {
        return None;
    }
    let mut c = st.centres.clone();
    let mut r = st.radii.clone();
    // Seeds a quarter of the way in from the farthest pair, starting at radius 0: the other
    // spheres keep their radii, so only the orphaned points move.
    c[worst] = a + (b - a) * 0.25;
    c[del] = b + (a - b) * 0.25;
    r[worst] = 0.0;
    r[del] = 0.0;
    Some((c, r))
}

/// One teleportation trial as recorded: E before, E of the trial, accepted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TeleportRecord {
    pub e_before: f64,
    pub e_trial: f64,
    pub accepted: bool,
}

pub struct LloydOutcome {
    pub state: State,
    pub history: Vec<TeleportRecord>,
    pub iterations: usize,
    pub teleports_accepted: usize,
    pub teleports_tried: usize,
}

/// How long [`run`] goes on (the Lloyd fields of [`crate::FitPlan`]).
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// Iterations at most, teleportation trials included.
    pub max_iterations: usize,
    /// Teleportation trials at most.
    pub teleports: usize,
    /// Teleportation stops after this many rejected trials in a row.
    pub teleport_max_fails: usize,
}

/// Runs the variational fit from `starts` seeded starts (seeds derived from `seed`) and keeps
/// the lowest proxy E (ties: the first). When the cover start thins its sets
/// ([`cover::is_capped`]), each seeded start runs twice, from the strided and from the even
/// thinning (two Lloyd runs at once), since neither start is better everywhere and Lloyd's
/// own proxy E ranks them: measured at 64 spheres (whole bakes, seeds 1–8 of the bunny, 1–4
/// of spot, 1–3 of the Duck) and at 128 (seeds 1–4 of the bunny), the run of lower Lloyd
/// proxy ended at the lower exact E in 17 of 19 runs; see `docs/benchmarks.md`. With
/// `both_thinnings` false (the `fast` plan, [`crate::FitPlan::both_thinnings`]) each seeded
/// start runs once, from the even thinning.
pub fn run_multi(ctx: &Ctx, k: usize, seed: u64, limits: Limits, starts: usize, both_thinnings: bool) -> LloydOutcome {
    let n_surface = ctx.pts.surface_count;
    // Within the cap both thinnings keep every point, so they give the same start.
    let both = both_thinnings && cover::is_capped(n_surface, ctx.pts.points.len() - n_surface, k);
    let mut best: Option<LloydOutcome> = None;
    for s in 0..starts.max(1) as u64 {
        let seed = seed ^ s.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let (a, b) = if both {
            let (a, b) = rayon::join(
                || run(ctx, k, seed, limits, cover::Thinning::Strided),
                || run(ctx, k, seed, limits, cover::Thinning::Even),
            );
            (a, Some(b))
        } else {
            (run(ctx, k, seed, limits, cover::Thinning::Even), None)
        };
        for o in std::iter::once(a).chain(b) {
            if best.as_ref().is_none_or(|b| o.state.energy() < b.state.energy()) {
                best = Some(o);
            }
        }
    }
    best.expect("at least one start")
}

/// Lloyd from the cover start with `k` spheres (see the module docs), until an iteration
/// gains < 0.5 % and teleportation ends (`limits`), or `limits.max_iterations`.
pub fn run(ctx: &Ctx, k: usize, seed: u64, limits: Limits, thinning: cover::Thinning) -> LloydOutcome {
    let Limits { max_iterations, teleports, teleport_max_fails } = limits;
    let pts = &ctx.pts.points;
    let mut rng = SplitMix64::new(seed);
    let k = k.min(pts.len()).max(1);
    let start =
        cover::start(&pts[..ctx.pts.surface_count], &pts[ctx.pts.surface_count..], k, ctx.pts.h, seed, thinning);
    let mut centres: Vec<DVec3> = start.iter().map(|x| x.0).collect();
    let mut radii0: Vec<f64> = start.iter().map(|x| x.1).collect();
    // New centres at random points not yet used: a bounded number of random draws, then the
    // first unused points in order. A point set with fewer distinct points than k (three equal
    // vertices, tiny far-apart triangles, a node scaled to 0) gives fewer centres instead of
    // looping forever; the caller reports the shortfall.
    let key = |p: DVec3| [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits(), (p.z + 0.0).to_bits()]; // -0 == 0
    let mut used: std::collections::BTreeSet<[u64; 3]> = centres.iter().map(|c| key(*c)).collect();
    let mut draws = 0usize;
    let mut scan = 0usize;
    while centres.len() < k {
        let i = if draws < 64 * k {
            draws += 1;
            rng.below(pts.len() as u64) as usize
        } else if scan < pts.len() {
            scan += 1;
            scan - 1
        } else {
            break;
        };
        if used.insert(key(pts[i])) {
            centres.push(pts[i]);
            radii0.push(0.0);
        }
    }
    let from_cover = !start.is_empty();
    // `memo`: the state the centres come from, whose unchanged clusters `update` reuses.
    let step = |centres: &[DVec3], radii: Option<&[f64]>, memo: Option<&State>| -> State {
        let assign = match radii {
            Some(r) => power_assign(ctx.all, centres, r),
            None => power_assign(ctx.all, centres, &cluster(ctx, centres, None).1),
        };
        update(ctx, centres, &assign, memo)
    };
    let mut st = if from_cover { step(&centres, Some(&radii0), None) } else { step(&centres, None, None) };
    let mut iterations = 1;
    let mut tried = 0;
    let mut accepted = 0;
    let mut fails = 0;
    let mut history = Vec::new();
    // The step from `st` when it was rejected (E not lower) and `st` has not changed since. A
    // step is a function of its start alone (centres and radii from `st`; the memo only spares
    // searches whose results are the same bits), so after a rejected teleportation the step
    // from the unchanged `st` would repeat this one bit for bit: it is taken instead.
    let mut rejected: Option<State> = None;
    while iterations < max_iterations {
        let next = match rejected.take() {
            Some(next) => next,
            None => {
                centres.clone_from(&st.centres);
                step(&centres, Some(&st.radii), Some(&st))
            }
        };
        iterations += 1;
        let (e0, e1) = (st.energy(), next.energy());
        if e1 < e0 {
            st = next;
        } else {
            rejected = Some(next);
        }
        if e1 < e0 * (1.0 - 5e-3) {
            continue;
        }
        // Converged: try teleportation.
        if tried >= teleports || fails >= teleport_max_fails {
            break;
        }
        // After a rejected teleportation, the next trial splits the next-worst cluster.
        let Some((tc, tr)) = teleport(ctx, &st, fails) else { break };
        tried += 1;
        let mut trial = step(&tc, Some(&tr), Some(&st));
        iterations += 1;
        for _ in 0..2 {
            if iterations >= max_iterations {
                break;
            }
            let t2 = step(&trial.centres, Some(&trial.radii), Some(&trial));
            iterations += 1;
            if t2.energy() < trial.energy() {
                trial = t2;
            } else {
                break;
            }
        }
        let ok = trial.energy() < st.energy();
        history.push(TeleportRecord { e_before: st.energy(), e_trial: trial.energy(), accepted: ok });
        if ok {
            st = trial;
            rejected = None;
            accepted += 1;
            fails = 0;
        } else {
            fails += 1;
        }
    }
    LloydOutcome { state: st, history, iterations, teleports_accepted: accepted, teleports_tried: tried }
}

/// Final polish on the full point set (every mesh vertex, edge midpoint and triangle
/// centroid plus the clustering points): `rounds` of assignment, radius shrinking and Powell
/// centre update (members covered by another sphere exempt, except in the last round), so the
/// sphere set bounds the real vertices and the exactness pass only has to cover triangle
/// interiors.
pub fn polish(ctx: &Ctx, spheres: &[(DVec3, f64)], rounds: usize) -> Vec<(DVec3, f64)> {
    let all = ctx.all;
    let mut cur = spheres.to_vec();
    // Radius shrinking until a round finds no move (measured: bunny 64 E 0.315 → 0.305,
    // armadillo 64 0.558 → 0.546).
    let mut shrinking = true;
    for round in 0..rounds {
        let centres: Vec<DVec3> = cur.iter().map(|x| x.0).collect();
        let radii: Vec<f64> = cur.iter().map(|x| x.1).collect();
        let mut assign = assign_grow(ctx.solid, all, &centres, &radii);
        if shrinking {
            let mut rr = radii.clone();
            let mv = shrink(ctx.solid, all, &centres, &mut rr, &mut assign);
            shrinking = mv > 0;
        }
        let mut mem = members(&assign, cur.len());
        if round + 1 < rounds {
            // Every round but the last, a sphere's centre update ignores members already inside
            // another sphere (at its current centre and radius, scaled; the next round's
            // assignment restores full coverage, the last round bounds every member). Measured:
            // bunny 64 E 0.2935 → 0.2757, armadillo 64 0.5393 → 0.5108.
            let rr: Vec<f64> = (0..cur.len()).map(|i| max_dist(all, &mem[i], centres[i])).collect();
            // Members up to 1 % of a radius outside another sphere count as covered by it too
            // (measured at 64 spheres, factor 0.999 / 1.0 / 1.01 / 1.02: bunny E 0.2911 /
            // 0.2892 / 0.2757 / 0.3059, armadillo 0.5297 / 0.5276 / 0.5108 / 0.5059, spot
            // 0.2367 / 0.2373 / 0.2154 / 0.2253).
            let em = EXEMPT_FACTOR;
            let reach: Vec<(DVec3, f64)> = centres.iter().zip(&rr).map(|(c, r)| (*c, r * em)).collect();
            let grid = BallGrid::new(&reach);
            mem = mem
                .into_par_iter()
                .enumerate()
                .map_init(Vec::new, |cand, (i, m)| {
                    // Only spheres that can reach a member (|p − c_i| ≤ rr_i) matter.
                    grid.near(centres[i], rr[i], cand);
                    let near: Vec<usize> = cand
                        .iter()
                        .map(|&j| j as usize)
                        .filter(|&j| j != i && centres[i].distance(centres[j]) <= rr[i] + rr[j] * em)
                        .collect();
                    let kept: Vec<u32> = m
                        .iter()
                        .copied()
                        .filter(|&q| {
                            let p = &all[q as usize];
                            !near.iter().any(|&j| p.far(centres[j]) < rr[j] * em)
                        })
                        .collect();
                    if kept.is_empty() {
                        m
                    } else {
                        kept
                    }
                })
                .collect();
        }
        cur = (0..cur.len())
            .into_par_iter()
            .map(|ci| {
                let m = &mem[ci];
                if m.is_empty() {
                    return (cur[ci].0, 0.0);
                }
                let c0 = cur[ci].0;
                let fq = FarQuery::new(all, m, c0);
                let mut f = |x: [f64; 3]| {
                    let c = DVec3::from_array(x);
                    ctx.solid.outside(c, fq.max_dist(c))
                };
                let r0 = fq.max_dist(c0);
                let res = powell(&mut f, c0.to_array(), 0.1 * r0 + ctx.solid.h, ctx.powell_sweeps, 1e-4);
                let c = DVec3::from_array(res.x);
                (c, max_dist(all, m, c))
            })
            .collect();
    }
    cur
}

/// Whether two points are the same bits (a search from either runs alike; `==` would also
/// match −0 with +0).
fn same_bits(a: DVec3, b: DVec3) -> bool {
    a.to_array().map(f64::to_bits) == b.to_array().map(f64::to_bits)
}

/// Joint radius shrinking (a local search on the assignment, monotone in the proxy E): for
/// each sphere, largest outside volume first, its farthest members are handed to neighbouring
/// spheres (each to the one it needs the least growth to reach), and the prefix of handed-over
/// points is kept that lowers the summed proxy outside volume the most (sphere shrinking to
/// its first kept member, receivers growing to their new farthest member). Returns the
/// number of accepted moves; `assign` and `radii` are updated in place, radii stay the exact
/// bounding radii of the clusters at the given centres.
pub fn shrink(solid: &Solid, pts: &[Rep], centres: &[DVec3], radii: &mut [f64], assign: &mut [u32]) -> usize {
    let k = centres.len();
    if k < 2 {
        return 0;
    }
    let mut mem = members(assign, k);
    for i in 0..k {
        radii[i] = max_dist(pts, &mem[i], centres[i]);
    }
    let mut outs: Vec<f64> = (0..k).into_par_iter().map(|i| solid.outside(centres[i], radii[i])).collect();
    let mut order: Vec<usize> = (0..k).collect();
    order.sort_unstable_by(|&a, &b| outs[b].total_cmp(&outs[a]).then(a.cmp(&b)));
    let step = 0.25 * solid.h;
    let mut moves = 0;
    let mut grid: Option<BallGrid> = None;
    let mut reach: Vec<f64> = Vec::new();
    let mut new_r = vec![0.0f64; k];
    let mut new_o = vec![0.0f64; k];
    let mut cand = Vec::new();
    for &i in &order {
        if mem[i].len() < 2 || radii[i] <= 0.0 {
            continue;
        }
        // Moves shrink one radius and grow others: the grid lists each sphere with reach
        // 1.5 (2 r + h) and is rebuilt only when a radius outgrows that (so a query still
        // returns a superset of the neighbours).
        if grid.is_none() || (0..k).any(|j| 1.5 * radii[j] > reach[j]) {
            reach = radii.iter().map(|r| 1.5 * (2.0 * r + solid.h)).collect();
            let balls: Vec<(DVec3, f64)> = centres.iter().copied().zip(reach.iter().copied()).collect();
            grid = Some(BallGrid::new(&balls));
        }
        let g = grid.as_ref().expect("built above");
        g.near(centres[i], 1.5 * radii[i] + solid.h, &mut cand);
        let nb: Vec<usize> = cand
            .iter()
            .map(|&j| j as usize)
            .filter(|&j| j != i && centres[i].distance(centres[j]) < 1.5 * (radii[i] + radii[j]) + solid.h)
            .collect();
        if nb.is_empty() {
            continue;
        }
        let mut sorted = FarthestFirst::new(mem[i].iter().map(|&q| (pts[q as usize].far(centres[i]), q)));
        for &j in &nb {
            new_r[j] = radii[j];
            new_o[j] = outs[j];
        }
        let o_i = outs[i];
        let mut grow_sum = 0.0; // Σ over receivers of (new_o − outs)
        let mut best = (0.0f64, 0usize); // (ΔE, dropped count)
        let mut target: Vec<u32> = Vec::new();
        let mut dirty: Vec<usize> = Vec::new();
        let mut checkpoint = sorted.at(0).0 - step;
        // Hand over at most half of the members (measured: allowing all gains < 1e-4 in E).
        let cap = sorted.len() / 2;
        for n in 0..cap {
            let p = &pts[sorted.at(n).1 as usize];
            let mut bj = (f64::INFINITY, usize::MAX);
            for &j in &nb {
                let g = p.far(centres[j]) - new_r[j];
                if g < bj.0 {
                    bj = (g, j);
                }
            }
            let j = bj.1;
            target.push(j as u32);
            if bj.0 > 0.0 {
                new_r[j] += bj.0;
                if !dirty.contains(&j) {
                    dirty.push(j);
                }
            }
            let r_next = sorted.at(n + 1).0;
            if r_next <= checkpoint || n + 1 == cap {
                checkpoint = r_next - step;
                for &j in &dirty {
                    let o = solid.outside(centres[j], new_r[j]);
                    grow_sum += o - new_o[j];
                    new_o[j] = o;
                }
                dirty.clear();
                let d = solid.outside(centres[i], r_next) - o_i + grow_sum;
                if d < best.0 {
                    best = (d, n + 1);
                }
                if grow_sum > o_i {
                    break;
                }
            }
        }
        if best.1 == 0 || best.0 > -1e-9 * o_i.max(1e-300) {
            continue;
        }
        // Apply the best prefix.
        let drop = best.1;
        for ((_, q), &j) in sorted.prefix(drop).zip(&target) {
            assign[q as usize] = j;
            mem[j as usize].push(q);
        }
        radii[i] = sorted.at(drop).0;
        let mut keep: Vec<u32> = sorted.rest(drop).map(|x| x.1).collect();
        keep.sort_unstable();
        mem[i] = keep;
        outs[i] = solid.outside(centres[i], radii[i]);
        for &j in &nb {
            if target[..drop].contains(&(j as u32)) {
                mem[j].sort_unstable();
                radii[j] = max_dist(pts, &mem[j], centres[j]);
                outs[j] = solid.outside(centres[j], radii[j]);
            }
        }
        moves += 1;
    }
    moves
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherebake_geom::voxel::Bits;

    /// Whatever is read and in whatever order, [`FarthestFirst`] gives the entries of a full
    /// sort (farthest first, ties by index) at the same places; `prefix` is the sort's prefix
    /// and `rest` the other entries. Distances on a coarse grid, so many tie.
    #[test]
    fn farthest_first_reads_as_a_full_sort() {
        let mut rng = crate::rng::SplitMix64::new(5);
        for &n in &[1usize, 2, 3, 31, 32, 33, 34, 64, 100, 257, 737, 2000] {
            // Distinct indices in a scrambled order.
            let v: Vec<(f64, u32)> = (0..n)
                .map(|i| ((rng.below(n as u64 / 3 + 1) as f64) * 0.25, (i as u32).wrapping_mul(2_654_435_761)))
                .collect();
            let mut full = v.clone();
            full.sort_by(|a, b| b.0.partial_cmp(&a.0).expect("finite").then(a.1.cmp(&b.1)));
            // In order, one at a time (a transfer's scan).
            let mut f = FarthestFirst::new(v.clone());
            assert_eq!(f.len(), n);
            for (k, want) in full.iter().enumerate() {
                assert_eq!(f.at(k), *want, "n {n}, entry {k} in order");
            }
            // Jumping ahead, then back, then a prefix and the rest as sets.
            for stop in [0, 1, n / 10, n / 2, n - 1].into_iter().filter(|&k| k < n) {
                let mut f = FarthestFirst::new(v.clone());
                let jump = (stop + n / 3).min(n - 1);
                assert_eq!(f.at(jump), full[jump], "n {n}, jump to {jump}");
                assert_eq!(f.at(stop), full[stop], "n {n}, back to {stop}");
                let mut f = FarthestFirst::new(v.clone());
                assert_eq!(f.prefix(stop).collect::<Vec<_>>(), &full[..stop], "n {n}, prefix {stop}");
                let mut rest: Vec<(f64, u32)> = f.rest(stop).collect();
                rest.sort_by(|a, b| b.0.partial_cmp(&a.0).expect("finite").then(a.1.cmp(&b.1)));
                assert_eq!(rest, full[stop..], "n {n}, rest after {stop}");
            }
        }
    }

    /// [`FarthestFirst::key`] orders pairs as [`crate::largest_first`] does and
    /// [`FarthestFirst::pair`] gives back the same bits, on every kind of f64 (both zeros,
    /// negatives, subnormals, infinities, NaNs of both signs) and on random bits.
    #[test]
    fn the_farthest_first_key_orders_as_largest_first() {
        let mut rng = SplitMix64::new(29);
        let mut ds = vec![0.0, -0.0, 1.0, -1.0, 0.25, -0.25, f64::MIN_POSITIVE, -f64::MIN_POSITIVE, 5e-324, -5e-324];
        ds.extend([f64::MAX, f64::MIN, f64::INFINITY, f64::NEG_INFINITY, f64::NAN, -f64::NAN]);
        ds.extend((0..200).map(|_| f64::from_bits(rng.next_u64())));
        ds.extend((0..200).map(|_| rng.next_f64() * 3.0));
        let pairs: Vec<(f64, u32)> =
            ds.iter().flat_map(|&d| [(d, 0u32), (d, 7), (d, u32::MAX), (d, rng.next_u64() as u32)]).collect();
        for a in &pairs {
            let back = FarthestFirst::pair(FarthestFirst::key(*a));
            assert_eq!((back.0.to_bits(), back.1), (a.0.to_bits(), a.1), "{a:?}");
            for b in &pairs {
                let want = crate::largest_first(a, b);
                assert_eq!(FarthestFirst::key(*a).cmp(&FarthestFirst::key(*b)), want, "{a:?} {b:?}");
            }
        }
    }

    /// [`FarQuery::new`]'s (and [`FarQuery::rebucket`]'s) buckets against a layout written
    /// apart (each member's bucket ⌊(hi − d₀) nb / (hi − lo)⌋ cast to usize and clamped,
    /// members stable within a bucket), on spread distances, distances that tie on bucket
    /// edges, and one distance for all.
    #[test]
    fn far_query_buckets_are_the_clamped_floor_layout() {
        let mut rng = SplitMix64::new(43);
        let c0 = DVec3::new(0.5, -1.0, 2.0);
        for case in 0..40 {
            let n = 1 + rng.below(900) as usize;
            let pts: Vec<DVec3> = (0..n)
                .map(|_| {
                    let d = DVec3::new(rng.next_f64() - 0.5, rng.next_f64() - 0.5, rng.next_f64() - 0.5);
                    let r = match case % 3 {
                        0 => 3.0 * rng.next_f64(),
                        1 => rng.below(5) as f64 * 0.5,
                        _ => 1.0,
                    };
                    c0 + d.normalize_or_zero() * r
                })
                .collect();
            let mem: Vec<u32> = (0..n as u32).rev().collect();
            let fq = FarQuery::new(&pts, &mem, c0);
            let d0: Vec<f64> = mem.iter().map(|&i| pts[i as usize].distance(c0)).collect();
            let (lo, hi) = d0.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| (l.min(x), h.max(x)));
            let nb = (n / FAR_BUCKET_MEMBERS).clamp(1, FAR_BUCKETS);
            let scale = if hi > lo && (hi - lo).is_finite() { nb as f64 / (hi - lo) } else { 0.0 };
            let of: Vec<usize> = d0.iter().map(|&d| (((hi - d) * scale) as usize).min(nb - 1)).collect();
            let mut want = Vec::new();
            let mut ends = Vec::new();
            for b in 0..nb {
                let inb: Vec<usize> = (0..n).filter(|&j| of[j] == b).collect();
                if !inb.is_empty() {
                    want.extend(inb.iter().map(|&j| (d0[j], mem[j])));
                    ends.push((want.len(), inb.iter().map(|&j| d0[j]).fold(f64::NEG_INFINITY, f64::max)));
                }
            }
            let got: Vec<(f64, u32)> = fq
                .members
                .iter()
                .map(|&(d, p)| (d, pts.iter().position(|q| q.to_array() == p.to_array()).unwrap() as u32))
                .collect();
            let want_pts: Vec<(f64, u32)> = want
                .iter()
                .map(|&(d, q)| (d, pts.iter().position(|x| x.to_array() == pts[q as usize].to_array()).unwrap() as u32))
                .collect();
            assert_eq!(got, want_pts, "case {case}");
            assert_eq!(fq.buckets, ends, "case {case}");
            // Rebucketing a query built from elsewhere for other members gives the same.
            let mut re = FarQuery::new(&pts, &mem[..n / 2], c0 + DVec3::X);
            re.rebucket(&pts, &mem, c0);
            assert_eq!((re.members, re.buckets), (fq.members, fq.buckets), "case {case}");
        }
    }

    /// [`least`] against a running minimum, on maxima drawn from a few values (so many tie
    /// and the least sits at every position) and on spread ones.
    #[test]
    fn least_is_the_running_minimum() {
        let mut rng = SplitMix64::new(17);
        for t in 0..2000 {
            let v: [f64; 14] =
                std::array::from_fn(|_| if t % 2 == 0 { rng.below(4) as f64 * 0.5 } else { rng.next_f64() * 1e3 });
            let want = v.iter().copied().fold(f64::INFINITY, f64::min);
            assert_eq!(least(&v).to_bits(), want.to_bits(), "{v:?}");
        }
    }

    /// A 20³-cell block with a 10³ bite out of one corner, and the cube mesh's points: an
    /// L-ish solid where clusters settle unevenly.
    fn setup() -> (Solid, PointSet) {
        let (n, h) = (20usize, 0.05);
        let mut bits = Bits::new(n * n * n);
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    if !(i >= 10 && j >= 10 && k >= 10) {
                        bits.set(i + n * (j + n * k));
                    }
                }
            }
        }
        let solid = Solid::from_cells(DVec3::ZERO, h, [n; 3], bits);
        let (p, tris) = spherebake_testkit::mesh::unit_cube();
        let pos: Vec<DVec3> = p.iter().map(|c| DVec3::from_array(*c)).collect();
        let pts = crate::points::build(&pos, &tris, &solid, DVec3::ZERO, DVec3::ONE, 0.1);
        (solid, pts)
    }

    /// A state's centres, radii and outside volumes, bit for bit.
    fn bits(s: &State) -> Vec<u64> {
        let v = s.centres.iter().flat_map(|c| c.to_array()).chain(s.radii.iter().copied());
        v.chain(s.outside.iter().copied()).map(f64::to_bits).collect()
    }

    /// With one thinning `run_multi` runs Lloyd from the even one; with both, it keeps the run
    /// of lower proxy E. The sets are capped here, so the two starts differ (else the test
    /// could not tell which one ran).
    #[test]
    fn run_multi_runs_the_even_thinning_alone_or_keeps_the_lower_of_both() {
        let (solid, pts) = setup();
        let ctx = Ctx { solid: &solid, pts: &pts, all: &pts.reps, powell_sweeps: 2 };
        let k = 2;
        assert!(cover::is_capped(pts.surface_count, pts.points.len() - pts.surface_count, k));
        let limits = Limits { max_iterations: 6, teleports: 1, teleport_max_fails: 2 };
        for seed in [3, 9] {
            let strided = run(&ctx, k, seed, limits, cover::Thinning::Strided);
            let even = run(&ctx, k, seed, limits, cover::Thinning::Even);
            assert_ne!(bits(&strided.state), bits(&even.state), "seed {seed}");
            assert_eq!(bits(&run_multi(&ctx, k, seed, limits, 1, false).state), bits(&even.state), "seed {seed}");
            let lower = if even.state.energy() < strided.state.energy() { &even } else { &strided };
            assert_eq!(bits(&run_multi(&ctx, k, seed, limits, 1, true).state), bits(&lower.state), "seed {seed}");
        }
    }

    /// [`power_assign`] (grid candidates, skipped by [`power_lower_bound`]) chooses as a full
    /// scan of every sphere with the plain formula does: the containing sphere of least power
    /// (ties to the lower index), else the one whose volume grows least. Points on and near
    /// sphere boundaries, at centres, spheres repeated (equal powers) and of radius 0, and
    /// representatives of points and of discs.
    #[test]
    fn power_assign_chooses_as_the_full_scan() {
        let reference = |pts: &[Rep], centres: &[DVec3], radii: &[f64]| -> Vec<u32> {
            pts.iter()
                .map(|p| {
                    let pw: Vec<f64> = centres.iter().zip(radii).map(|(c, r)| p.far(*c).powi(2) - r * r).collect();
                    let mut best = (f64::INFINITY, u32::MAX);
                    for (i, &w) in pw.iter().enumerate() {
                        if w <= 0.0 && w < best.0 {
                            best = (w, i as u32);
                        }
                    }
                    if best.1 != u32::MAX {
                        return best.1;
                    }
                    for (i, (c, r)) in centres.iter().zip(radii).enumerate() {
                        let d = p.far(*c);
                        if pw[i] > 0.0 && d * d * d - r * r * r < best.0 {
                            best = (d * d * d - r * r * r, i as u32);
                        }
                    }
                    best.1
                })
                .collect()
        };
        let mut rng = SplitMix64::new(71);
        let unit = |rng: &mut SplitMix64| {
            let v = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 2.0 - 1.0;
            if v.length_squared() > 1e-6 {
                v.normalize()
            } else {
                DVec3::X
            }
        };
        for round in 0..20 {
            let k = 1 + rng.below(60) as usize;
            let mut centres: Vec<DVec3> =
                (0..k).map(|_| DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64())).collect();
            let mut radii: Vec<f64> = (0..k).map(|_| 0.4 * rng.next_f64()).collect();
            // Repeated spheres (equal powers everywhere) and radius 0.
            for _ in 0..k / 4 {
                let (a, b) = (rng.below(k as u64) as usize, rng.below(k as u64) as usize);
                centres[b] = centres[a];
                radii[b] = radii[a];
            }
            radii[rng.below(k as u64) as usize] = 0.0;
            let mut pts = Vec::new();
            for _ in 0..3000 {
                let ci = rng.below(k as u64) as usize;
                let p = match rng.below(4) {
                    0 => DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 1.4 - 0.2,
                    1 => centres[ci] + unit(&mut rng) * radii[ci],
                    2 => centres[ci] + unit(&mut rng) * radii[ci] * (1.0 + 1e-15 * (rng.next_f64() - 0.5)),
                    _ => centres[ci],
                };
                let mut rep = Rep::point(p);
                if round % 2 == 1 && rng.below(2) == 0 {
                    rep = Rep { p, n: unit(&mut rng), s: 0.02 * rng.next_f64(), t: 0.01 * rng.next_f64() };
                }
                pts.push(rep);
            }
            assert_eq!(power_assign(&pts, &centres, &radii), reference(&pts, &centres, &radii), "round {round}");
        }
    }

    /// The memo returns what a fresh search returns, bit for bit, and only reuses a cluster
    /// whose start and members both match: each cluster's update from the previous state's
    /// centres (most clusters match, some do not) equals the update without a memo; a memo
    /// whose members differ (another assignment) or whose starts differ (moved centres) must
    /// not leak its results either.
    #[test]
    fn the_memo_gives_the_same_bits_as_searching_again() {
        let (solid, pts) = setup();
        let ctx = Ctx { solid: &solid, pts: &pts, all: &pts.reps, powell_sweeps: 2 };
        let k = 12;
        let mut rng = SplitMix64::new(5);
        let centres: Vec<DVec3> = (0..k).map(|_| pts.points[rng.below(pts.points.len() as u64) as usize]).collect();
        let radii = cluster(&ctx, &centres, None).1;
        let st = update(&ctx, &centres, &power_assign(ctx.all, &centres, &radii), None);
        let mut reused = 0;
        let mut s = st.clone();
        for _ in 0..6 {
            let assign = power_assign(ctx.all, &s.centres, &s.radii);
            let with = update(&ctx, &s.centres, &assign, Some(&s));
            let without = update(&ctx, &s.centres, &assign, None);
            assert_eq!(bits(&with), bits(&without));
            let old = members(&s.assign, k);
            let new = members(&assign, k);
            reused += (0..k)
                .filter(|&i| same_bits(s.start[i], s.centres[i]) && old[i] == new[i] && !new[i].is_empty())
                .count();
            s = with;
        }
        // The memo was exercised (else the comparison above proves nothing about it).
        assert!(reused > 0, "no cluster kept its start and members");
        // Same starts, other members: a different assignment (every point to its nearest
        // centre) must be searched again.
        let nearest = power_assign(ctx.all, &st.start, &vec![0.0; k]);
        assert_ne!(members(&nearest, k), members(&st.assign, k));
        let a = update(&ctx, &st.start, &nearest, Some(&st));
        let b = update(&ctx, &st.start, &nearest, None);
        assert_eq!(bits(&a), bits(&b));
        // Same members, other starts: every centre moved by a tenth of a cell.
        let moved: Vec<DVec3> = st.start.iter().map(|c| *c + DVec3::splat(0.005)).collect();
        let a = update(&ctx, &moved, &st.assign, Some(&st));
        let b = update(&ctx, &moved, &st.assign, None);
        assert_eq!(bits(&a), bits(&b));
    }
}
