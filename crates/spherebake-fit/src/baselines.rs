//! The two baselines: k-means of surface points (each sphere the bounding sphere of its
//! cluster about the centroid) and adaptive-octree leaf-cube spheres (Ren et al. 2006 Fig. 4).
//! Both pass through the same exactness rules as the variational fit afterwards. The box
//! lattices here ([`lattices_at_most`]) are no baseline: with the octree stopped at most k
//! they are the candidates of the variational fit's lattice start; nor is [`split_start`],
//! the variational fit's third start.

use crate::rng::SplitMix64;
use crate::solid::Solid;
use crate::Ball;
use glam::DVec3;
use std::collections::BinaryHeap;

/// k-means++ seeding (Arthur & Vassilvitskii 2007), written once (the k-means baseline and the
/// hierarchy's clustering): the first of min(`k`, n) seeds is uniform over `pts`, each next is
/// drawn with probability proportional to D², its squared distance to the nearest seed so far
/// (uniform again when every D² is 0). Returns the seeds' indices in draw order; draws come
/// from `rng` only (one `below` for the first seed, one `next_f64` or `below` per further seed),
/// so the seeds follow the seed. A draw that the rounding of the running sum carries past the
/// last point takes the last point with D² > 0, so no point is drawn twice while unseeded
/// points remain at a distance. Cost O(n·k).
pub fn kmeanspp_seeds(pts: &[DVec3], k: usize, rng: &mut SplitMix64) -> Vec<usize> {
    let n = pts.len();
    let k = k.min(n);
    if k == 0 {
        return Vec::new();
    }
    let mut seeds = vec![rng.below(n as u64) as usize];
    let mut d2: Vec<f64> = pts.iter().map(|p| p.distance_squared(pts[seeds[0]])).collect();
    while seeds.len() < k {
        let total: f64 = d2.iter().sum();
        let pick = if total > 0.0 {
            let mut t = rng.next_f64() * total;
            let mut pick = (0..n).rev().find(|&i| d2[i] > 0.0).unwrap_or(n - 1);
            for (i, &w) in d2.iter().enumerate() {
                if t < w {
                    pick = i;
                    break;
                }
                t -= w;
            }
            pick
        } else {
            rng.below(n as u64) as usize
        };
        seeds.push(pick);
        let c = pts[pick];
        for (d, p) in d2.iter_mut().zip(pts) {
            *d = d.min(p.distance_squared(c));
        }
    }
    seeds
}

/// k-means (k-means++ seeding from `seed`, ≤ `iterations` Lloyd steps) of `pts`; each sphere is
/// centred at its cluster mean with radius reaching the farthest member.
pub fn kmeans(pts: &[DVec3], k: usize, seed: u64, iterations: usize) -> Vec<(DVec3, f64)> {
    if pts.is_empty() || k == 0 {
        return Vec::new();
    }
    let k = k.min(pts.len());
    let mut rng = SplitMix64::new(seed);
    let mut centres: Vec<DVec3> = kmeanspp_seeds(pts, k, &mut rng).into_iter().map(|i| pts[i]).collect();
    let mut assign = vec![0usize; pts.len()];
    for _ in 0..iterations {
        let mut changed = false;
        for (i, p) in pts.iter().enumerate() {
            let mut best = (f64::INFINITY, 0);
            for (ci, c) in centres.iter().enumerate() {
                let d = p.distance_squared(*c);
                if d < best.0 {
                    best = (d, ci);
                }
            }
            if assign[i] != best.1 {
                assign[i] = best.1;
                changed = true;
            }
        }
        let mut sum = vec![DVec3::ZERO; k];
        let mut cnt = vec![0usize; k];
        for (i, p) in pts.iter().enumerate() {
            sum[assign[i]] += *p;
            cnt[assign[i]] += 1;
        }
        for ci in 0..k {
            if cnt[ci] > 0 {
                centres[ci] = sum[ci] / cnt[ci] as f64;
            }
        }
        if !changed {
            break;
        }
    }
    let mut r = vec![0.0f64; k];
    let mut used = vec![false; k];
    for (i, p) in pts.iter().enumerate() {
        r[assign[i]] = r[assign[i]].max(p.distance(centres[assign[i]]));
        used[assign[i]] = true;
    }
    (0..k).filter(|&i| used[i]).map(|i| (centres[i], r[i])).collect()
}

struct Node {
    centre: DVec3,
    half: f64,
    tris: Vec<u32>,
}

/// Adaptive octree over the bounding cube: split boundary leaves (those whose cube meets a
/// triangle's bounding box), largest first, until the leaves inside or on the boundary number
/// at least `k` (it can overshoot by up to 6). Spheres are the leaf cubes' circumspheres.
pub fn octree(positions: &[DVec3], triangles: &[[u32; 3]], solid: &Solid, k: usize) -> Vec<(DVec3, f64)> {
    octree_leaves(positions, triangles, solid, k, false)
}

/// [`octree`] stopped before the split that would pass `k`: at most `k` spheres (at least
/// `k − 6` when the tree can grow that far), every point of the surface and of the solid's
/// cells still inside one.
pub fn octree_at_most(positions: &[DVec3], triangles: &[[u32; 3]], solid: &Solid, k: usize) -> Vec<(DVec3, f64)> {
    octree_leaves(positions, triangles, solid, k, true)
}

fn octree_leaves(
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    solid: &Solid,
    k: usize,
    at_most: bool,
) -> Vec<(DVec3, f64)> {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let boxes: Vec<(DVec3, DVec3)> = triangles
        .iter()
        .map(|t| {
            let a = positions[t[0] as usize];
            let b = positions[t[1] as usize];
            let c = positions[t[2] as usize];
            let (l, h) = (a.min(b).min(c), a.max(b).max(c));
            lo = lo.min(l);
            hi = hi.max(h);
            (l, h)
        })
        .collect();
    if triangles.is_empty() {
        return Vec::new();
    }
    let root = Node {
        centre: (lo + hi) * 0.5,
        half: (hi - lo).max_element() * 0.5 * 1.0001,
        tris: (0..triangles.len() as u32).collect(),
    };
    let mut nodes = vec![root];
    let mut inside_leaves: Vec<usize> = Vec::new();
    // Max-heap on (half as ordered bits, reverse creation order).
    let mut heap: BinaryHeap<(u64, std::cmp::Reverse<usize>)> = BinaryHeap::new();
    heap.push((nodes[0].half.to_bits(), std::cmp::Reverse(0)));
    let mut count = 1usize;
    while count < k {
        let Some((_, std::cmp::Reverse(ni))) = heap.pop() else { break };
        count -= 1;
        let (c0, h0) = (nodes[ni].centre, nodes[ni].half);
        let tris = std::mem::take(&mut nodes[ni].tris);
        let h = h0 * 0.5;
        let mut children: Vec<(Node, bool)> = Vec::with_capacity(8);
        for oct in 0..8 {
            let off = DVec3::new(
                if oct & 1 != 0 { h } else { -h },
                if oct & 2 != 0 { h } else { -h },
                if oct & 4 != 0 { h } else { -h },
            );
            let c = c0 + off;
            let (bl, bh) = (c - DVec3::splat(h), c + DVec3::splat(h));
            let sub: Vec<u32> = tris
                .iter()
                .copied()
                .filter(|&t| {
                    let (l, u) = boxes[t as usize];
                    (l - bh).max_element() <= 0.0 && (bl - u).max_element() <= 0.0
                })
                .collect();
            if sub.is_empty() {
                if solid.is_solid_at(c) {
                    children.push((Node { centre: c, half: h, tris: sub }, true));
                }
            } else {
                children.push((Node { centre: c, half: h, tris: sub }, false));
            }
        }
        if at_most && count + children.len() > k {
            // This split would pass k: the node stays a leaf, and the tree is done (the other
            // leaves are as large or smaller, so their splits would pass k too or skew it).
            nodes[ni].tris = tris;
            heap.push((h0.to_bits(), std::cmp::Reverse(ni)));
            break;
        }
        for (node, inside) in children {
            nodes.push(node);
            if inside {
                inside_leaves.push(nodes.len() - 1);
            } else {
                heap.push((h.to_bits(), std::cmp::Reverse(nodes.len() - 1)));
            }
            count += 1;
        }
    }
    let mut leaves: Vec<usize> = heap.into_iter().map(|(_, std::cmp::Reverse(i))| i).collect();
    leaves.extend(inside_leaves);
    leaves.sort_unstable();
    leaves.iter().map(|&i| (nodes[i].centre, nodes[i].half * 3f64.sqrt())).collect()
}

/// Box lattices for a start of at most `k` spheres: the box `lo..hi` cut into a × b × c
/// equal cells, each cell that holds one of `points` (surface samples and interior lattice
/// points) giving its circumsphere, in cell order (x fastest). The lattices are the
/// near-cubic one (cells as close to cubes as whole counts allow) with the most cells that
/// keeps at most `k`, and its neighbours with −1..=+2 cells per axis that keep at most `k`
/// too (so the unit cube at 16 gets 2 × 2 × 3 and 2 × 2 × 4 besides 2 × 2 × 2, which the
/// octree cannot express). Empty lists for an empty or non-finite box. Cost O(points ×
/// (log k + 64)); at most 65 lattices of at most 64 k cells each.
pub fn lattices_at_most(lo: DVec3, hi: DVec3, points: &[DVec3], k: usize) -> Vec<Vec<(DVec3, f64)>> {
    let ext = hi - lo;
    let longest = ext.max_element();
    if k == 0 || !(longest > 0.0 && longest.is_finite()) || !lo.is_finite() || ext.min_element() < 0.0 {
        return Vec::new();
    }
    // Cells per axis of the near-cubic lattice with `n` cells along the longest axis.
    let near_cubic =
        |n: usize| -> [usize; 3] { [0, 1, 2].map(|a| ((n as f64 * ext[a] / longest).round() as usize).clamp(1, n)) };
    let cell_cap = k.saturating_mul(64);
    // Each point's place in the box per axis, (p − lo) / ext (0 on a flat axis), computed once:
    // a lattice of n cells along the axis puts it in cell ⌊u n⌋, the same product as
    // (p − lo) / ext × n, so the same cells.
    let unit: [Vec<f64>; 3] =
        [0, 1, 2].map(|a| points.iter().map(|p| if ext[a] > 0.0 { (p[a] - lo[a]) / ext[a] } else { 0.0 }).collect());
    // The points' cells along axis `a` in a lattice of `n` cells there; NaN and out-of-box
    // points clamp to the border cells.
    let cells_along = |a: usize, n: usize| -> Vec<u32> {
        unit[a]
            .iter()
            .map(|&u| {
                let t = u * n as f64;
                if t >= 0.0 {
                    (t as usize).min(n - 1) as u32
                } else {
                    0
                }
            })
            .collect()
    };
    // Lattice `d`'s cell count when at most the cap.
    let cells_of = |d: [usize; 3]| d[0].checked_mul(d[1])?.checked_mul(d[2]).filter(|&c| c <= cell_cap);
    // Which of `cells` cells of lattice `d` hold a point, from the points' cells along each axis.
    let occupied_from = |d: [usize; 3], cells: usize, along: [&[u32]; 3]| -> Vec<bool> {
        let mut occ = vec![false; cells];
        for ((&x, &y), &z) in along[0].iter().zip(along[1]).zip(along[2]) {
            occ[(z as usize * d[1] + y as usize) * d[0] + x as usize] = true;
        }
        occ
    };
    let occupied = |d: [usize; 3]| -> Option<Vec<bool>> {
        let cells = cells_of(d)?;
        let along = [0, 1, 2].map(|a| cells_along(a, d[a]));
        Some(occupied_from(d, cells, [&along[0], &along[1], &along[2]]))
    };
    let kept = |d: [usize; 3]| occupied(d).map_or(usize::MAX, |o| o.iter().filter(|&&x| x).count());
    // The largest n whose near-cubic lattice keeps at most k cells (binary search: the kept
    // count grows with n but for rounding, and the search only picks a base).
    let (mut lo_n, mut hi_n) = (1usize, k.max(1));
    if kept(near_cubic(1)) > k {
        return Vec::new();
    }
    while lo_n < hi_n {
        let mid = lo_n + (hi_n - lo_n).div_ceil(2);
        if kept(near_cubic(mid)) <= k {
            lo_n = mid;
        } else {
            hi_n = mid - 1;
        }
    }
    let base = near_cubic(lo_n);
    let mut dims: Vec<[usize; 3]> = Vec::new();
    for dx in -1i64..=2 {
        for dy in -1i64..=2 {
            for dz in -1i64..=2 {
                let d = [(base[0] as i64 + dx), (base[1] as i64 + dy), (base[2] as i64 + dz)];
                if d.iter().all(|&v| v >= 1) {
                    let d = d.map(|v| v as usize);
                    if !dims.contains(&d) {
                        dims.push(d);
                    }
                }
            }
        }
    }
    // The lattices share their cell counts per axis (four each): each axis's cells are
    // computed once per count.
    let mut along: [Vec<(usize, Vec<u32>)>; 3] = Default::default();
    let mut out = Vec::new();
    for d in dims {
        let Some(cells) = cells_of(d) else { continue };
        for (a, list) in along.iter_mut().enumerate() {
            if !list.iter().any(|(n, _)| *n == d[a]) {
                list.push((d[a], cells_along(a, d[a])));
            }
        }
        let get = |a: usize| along[a].iter().find(|(n, _)| *n == d[a]).map_or(&[][..], |(_, c)| c.as_slice());
        let occ = occupied_from(d, cells, [get(0), get(1), get(2)]);
        if occ.iter().filter(|&&x| x).count() > k {
            continue;
        }
        let size = DVec3::new(ext.x / d[0] as f64, ext.y / d[1] as f64, ext.z / d[2] as f64);
        let r = size.length() * 0.5;
        let mut sp = Vec::new();
        for (idx, _) in occ.iter().enumerate().filter(|(_, &o)| o) {
            let (i, j, l) = (idx % d[0], (idx / d[0]) % d[1], idx / (d[0] * d[1]));
            let c = lo + DVec3::new(i as f64 + 0.5, j as f64 + 0.5, l as f64 + 0.5) * size;
            sp.push((c, r));
        }
        out.push(sp);
    }
    out
}

/// The split start: `points` (surface samples and interior lattice points) cut by recursive
/// bisection into at most `k` cells, each cell's sphere the smallest ball around its points
/// ([`spherebake_geom::sphere::min_enclosing_ball`]), in the order the cells were made. The
/// cell whose ball is largest (the earliest on a tie) is cut next, at the middle of its points'
/// extent along the direction whose two balls hold the least volume together: x, y or z, and
/// with `oblique` also the cell's three principal axes
/// ([`spherebake_geom::sphere::principal_axes`]), which win only where strictly tighter (a
/// slab of a round rod shorter than it is wide is still cut across the rod: halving the disc
/// would not shrink its balls); a cell whose points all coincide is not cut. On a long round
/// part this is a chain of spheres along its axis (a 10 : 1 cylinder at 32 spheres: the balls
/// of 32 equal slabs), along an oblique axis too with `oblique`, which neither the cover start
/// nor the lattices of [`lattices_at_most`] (cells' circumspheres) give. Empty for no points
/// or `k` = 0. Cost O(points × depth) for the cuts (depth about log₂ k) and three pairs of
/// balls per cut (six with `oblique`, plus the covariance), expected O(the cell's points) each.
pub fn split_start(points: &[DVec3], k: usize, oblique: bool) -> Vec<(DVec3, f64)> {
    split_starts(points, k, oblique, |_, _| 0.0).0
}

/// [`split_start`]'s `k` cells, and the same cuts stopped at the count of least total `cost`
/// (summed over the cells' balls; the latest count on a tie, so a cost of 0 gives the `k`
/// cells twice): the cells alive after that cut, in the order they were made. With the proxy
/// outside volume as the cost the second is the bisection's best count up to `k`: more
/// cells need not fit better (the balls of a round rod's slabs each reach out beside the
/// rod by about as much however thin the slab, so on a short rod halving slabs adds outside
/// volume). `cost` is called once per cell made.
pub fn split_starts(
    points: &[DVec3],
    k: usize,
    oblique: bool,
    mut cost: impl FnMut(DVec3, f64) -> f64,
) -> (Vec<Ball>, Vec<Ball>) {
    let pts: Vec<DVec3> = points.iter().copied().filter(|p| p.is_finite()).collect();
    if pts.is_empty() || k == 0 {
        return (Vec::new(), Vec::new());
    }
    let ball_of = |idx: &[u32]| spherebake_geom::sphere::min_enclosing_ball_of(idx.iter().map(|&i| pts[i as usize]));
    // A cell: its points' indices and their smallest ball.
    type Cell = (Vec<u32>, (DVec3, f64));
    let all: Vec<u32> = (0..pts.len() as u32).collect();
    let whole = ball_of(&all);
    let mut cells: Vec<Cell> = vec![(all, whole)];
    // Per cell: the cut it was cut at (usize::MAX: never) and its cost; the running total
    // cost, and the number of cuts after which it was least.
    let mut cut_at: Vec<usize> = vec![usize::MAX];
    let mut costs: Vec<f64> = vec![cost(whole.0, whole.1)];
    let mut total = costs[0];
    let (mut best_total, mut best_cuts) = (total, 0usize);
    // Max-heap on (radius as ordered bits, earliest cell first).
    let mut heap: BinaryHeap<(u64, std::cmp::Reverse<usize>)> = BinaryHeap::new();
    heap.push((cells[0].1 .1.to_bits(), std::cmp::Reverse(0)));
    // Cells alive: one more than the cuts made.
    let mut count = 1;
    while count < k {
        let Some((_, std::cmp::Reverse(ci))) = heap.pop() else { break };
        let idx = std::mem::take(&mut cells[ci].0);
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for &i in &idx {
            lo = lo.min(pts[i as usize]);
            hi = hi.max(pts[i as usize]);
        }
        // The cut (at the middle of the extent along x, y, z or one of the cell's principal
        // axes) whose two balls hold the least volume together; the earliest on a tie, so a
        // principal axis wins only where it is strictly tighter (an oblique part; a slab of
        // an oblique rod is cut across the rod by its least-spread axis).
        let members: Vec<DVec3> = if oblique { idx.iter().map(|&i| pts[i as usize]).collect() } else { Vec::new() };
        let principal = if oblique { spherebake_geom::sphere::principal_axes(&members) } else { None };
        let mut best: Option<(f64, [Cell; 2])> = None;
        for axis in 0..6 {
            let dir = match (axis, principal) {
                (0..=2, _) => DVec3::AXES[axis],
                // A principal axis within 0.08° of x, y or z (the eigenvectors of a box's
                // slab, up to rounding) would repeat that axis's cut, or tilt it by rounding.
                (_, Some(p)) if p[axis - 3].abs().max_element() < 1.0 - 1e-6 => p[axis - 3],
                _ => continue,
            };
            let (plo, phi) = if axis < 3 {
                (lo[axis], hi[axis])
            } else {
                members
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| (l.min(p.dot(dir)), h.max(p.dot(dir))))
            };
            let mid = 0.5 * (plo + phi);
            let key = |p: DVec3| if axis < 3 { p[axis] } else { p.dot(dir) };
            let (a, b): (Vec<u32>, Vec<u32>) = idx.iter().partition(|&&i| key(pts[i as usize]) < mid);
            if a.is_empty() || b.is_empty() {
                continue;
            }
            let (ba, bb) = (ball_of(&a), ball_of(&b));
            let volume = ba.1.powi(3) + bb.1.powi(3);
            if best.as_ref().is_none_or(|(v, _)| volume < *v) {
                best = Some((volume, [(a, ba), (b, bb)]));
            }
        }
        let Some((_, parts)) = best else {
            // Every point at one place (or each middle rounded onto an end): keep the cell whole.
            cells[ci].0 = idx;
            continue;
        };
        cut_at[ci] = count;
        total -= costs[ci];
        for (part, ball) in parts {
            let c = cost(ball.0, ball.1);
            total += c;
            heap.push((ball.1.to_bits(), std::cmp::Reverse(cells.len())));
            cells.push((part, ball));
            cut_at.push(usize::MAX);
            costs.push(c);
        }
        if total <= best_total {
            (best_total, best_cuts) = (total, count);
        }
        count += 1;
    }
    // The cells alive after `n` cuts; cells are made two per cut, in order: cell j ≥ 1 by
    // cut ⌈j / 2⌉.
    let alive = |n: usize| -> Vec<Ball> {
        cells
            .iter()
            .enumerate()
            .filter(|&(j, _)| j.div_ceil(2) <= n && cut_at[j] > n)
            .map(|(_, (_, ball))| *ball)
            .collect()
    };
    (alive(count - 1), alive(best_cuts))
}

#[cfg(test)]
mod kmeanspp_tests {
    use super::*;

    #[test]
    fn the_octree_at_most_k_stays_at_most_k_and_covers_the_surface() {
        // A unit cube (12 triangles) on a solid grid of 32 cells.
        let pos: Vec<DVec3> =
            (0..8).map(|i| DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, (i >> 2) as f64)).collect();
        let tris: Vec<[u32; 3]> = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        let h = 1.0 / 32.0;
        let cells: crate::solid::Bits = (0..32 * 32 * 32).map(|_| true).collect();
        let solid = Solid::from_cells(DVec3::ZERO, h, [32, 32, 32], cells);
        let mut rng = SplitMix64::new(5);
        for k in 1..=80 {
            let s = octree_at_most(&pos, &tris, &solid, k);
            let full = octree(&pos, &tris, &solid, k);
            assert!(s.len() <= k && !s.is_empty(), "k {k}: {}", s.len());
            // The unlimited octree reaches k with at most 6 more (one split adds ≤ 7).
            assert!(full.len() >= k && full.len() <= k + 6, "k {k}: {}", full.len());
            if k >= 8 {
                assert!(s.len() + 7 > k, "k {k}: only {} of at most {k}", s.len());
            }
            for _ in 0..200 {
                let t = tris[rng.below(12) as usize].map(|v| pos[v as usize]);
                let (mut a, mut b) = (rng.next_f64(), rng.next_f64());
                if a + b > 1.0 {
                    (a, b) = (1.0 - a, 1.0 - b);
                }
                let p = t[0] + (t[1] - t[0]) * a + (t[2] - t[0]) * b;
                assert!(s.iter().any(|(c, r)| p.distance(*c) <= *r * (1.0 + 1e-12)), "k {k}: {p} uncovered");
            }
        }
    }

    #[test]
    fn lattices_keep_at_most_k_cells_and_cover_their_points() {
        // Random points in the box [0, 2] × [0, 1] × [0, 1]; every cell of a lattice with a
        // point in it must hold a sphere whose ball contains that point, no lattice may keep
        // more than k, and the near-cubic base must be the largest such lattice.
        let mut rng = SplitMix64::new(11);
        let (lo, hi) = (DVec3::ZERO, DVec3::new(2.0, 1.0, 1.0));
        let pts: Vec<DVec3> =
            (0..4000).map(|_| DVec3::new(2.0 * rng.next_f64(), rng.next_f64(), rng.next_f64())).collect();
        for k in [1usize, 2, 7, 16, 64, 300] {
            let lats = lattices_at_most(lo, hi, &pts, k);
            assert!(!lats.is_empty(), "k {k}");
            for sp in &lats {
                assert!(!sp.is_empty() && sp.len() <= k, "k {k}: {} spheres", sp.len());
                for p in &pts {
                    assert!(sp.iter().any(|(c, r)| p.distance(*c) <= r * (1.0 + 1e-12)), "k {k}: {p} uncovered");
                }
                // Equal cells: one radius.
                assert!(sp.iter().all(|s| s.1 == sp[0].1));
            }
            // 4000 points fill every cell of these small lattices, so a lattice keeps a × b × c
            // cells: the near-cubic 2n × n × n with the largest n has 2n³ ≤ k.
            let n = (1..).take_while(|n: &usize| 2 * n * n * n <= k).last().unwrap_or(0);
            if n > 0 {
                let r = 3f64.sqrt() / (2.0 * n as f64); // cubic cells of edge 1/n
                assert!(lats.iter().any(|sp| sp.len() == 2 * n * n * n && (sp[0].1 - r).abs() < 1e-12), "k {k}");
            }
        }
        // The unit cube at 16: 2 × 2 × 3 cells of 1/2 × 1/2 × 1/3 (half-diagonal
        // √(1/4 + 1/4 + 1/9) / 2) are among the lattices.
        let cube: Vec<DVec3> = (0..4000).map(|_| DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64())).collect();
        let r223 = (0.25f64 + 0.25 + 1.0 / 9.0).sqrt() / 2.0;
        let lats = lattices_at_most(DVec3::ZERO, DVec3::ONE, &cube, 16);
        assert!(lats.iter().any(|sp| sp.len() == 12 && (sp[0].1 - r223).abs() < 1e-12));
        // Empty or non-finite boxes and k = 0 give nothing.
        assert!(lattices_at_most(DVec3::ZERO, DVec3::ONE, &cube, 0).is_empty());
        assert!(lattices_at_most(DVec3::ONE, DVec3::ONE, &cube, 16).is_empty());
        assert!(lattices_at_most(DVec3::ZERO, DVec3::splat(f64::NAN), &cube, 16).is_empty());
    }

    #[test]
    fn seeds_are_distinct_and_cover_separate_clusters() {
        // Two clusters of coincident points: once one is seeded its points have D² = 0, so the
        // second seed always comes from the other cluster.
        let mut pts = vec![DVec3::ZERO; 5];
        pts.extend(vec![DVec3::new(10.0, 0.0, 0.0); 7]);
        for seed in 0..200 {
            let s = kmeanspp_seeds(&pts, 2, &mut SplitMix64::new(seed));
            assert_eq!(s.len(), 2);
            assert_ne!(s[0] < 5, s[1] < 5, "seed {seed}: {s:?}");
        }
        // k = n on distinct points: every point once.
        let line: Vec<DVec3> = (0..9).map(|i| DVec3::new(i as f64, 0.0, 0.0)).collect();
        let mut s = kmeanspp_seeds(&line, 20, &mut SplitMix64::new(3));
        s.sort_unstable();
        assert_eq!(s, (0..9).collect::<Vec<_>>());
        assert!(kmeanspp_seeds(&line, 0, &mut SplitMix64::new(3)).is_empty());
        assert!(kmeanspp_seeds(&[], 4, &mut SplitMix64::new(3)).is_empty());
    }

    #[test]
    fn second_seed_follows_squared_distance() {
        // Points at x = 0, 1, 3: after the seed at 0, D² = (0, 1, 9), so 3 is drawn with
        // probability 9/10. 4000 runs, about a third start at 0: sd of the fraction ≈ 0.009.
        let pts = [DVec3::ZERO, DVec3::X, DVec3::new(3.0, 0.0, 0.0)];
        let (mut from_zero, mut far) = (0, 0);
        for seed in 0..4000 {
            let s = kmeanspp_seeds(&pts, 2, &mut SplitMix64::new(seed));
            if s[0] == 0 {
                from_zero += 1;
                far += usize::from(s[1] == 2);
            }
        }
        let f = far as f64 / from_zero as f64;
        assert!(from_zero > 1100 && (f - 0.9).abs() < 0.04, "{far} / {from_zero}");
    }

    /// Points on and inside a round rod (radius 0.5, length 10, along z): 32 cells are the 32
    /// equal slabs, each ball centred on the axis with radius √(0.5² + (10 / 64)²) (the slab's
    /// rim circles lie on it). Every point lies in its cell's ball. A unit cube's lattice at 8
    /// gives the octants.
    #[test]
    fn the_split_start_chains_a_rod_and_halves_a_cube() {
        let mut pts = Vec::new();
        for iz in 0..=640 {
            let z = 10.0 * iz as f64 / 640.0;
            for ia in 0..24 {
                let t = std::f64::consts::TAU * ia as f64 / 24.0;
                for r in [0.5, 0.25] {
                    pts.push(DVec3::new(r * t.cos(), r * t.sin(), z));
                }
            }
            pts.push(DVec3::new(0.0, 0.0, z));
        }
        let balls = split_start(&pts, 32, false);
        // The same with the principal axes: the same chain (x, y and z win their ties).
        assert_eq!(split_start(&pts, 32, true), balls);
        assert_eq!(balls.len(), 32);
        let want = (0.25f64 + (10.0f64 / 64.0).powi(2)).sqrt();
        let mut zs: Vec<f64> = balls.iter().map(|(c, _)| c.z).collect();
        zs.sort_by(f64::total_cmp);
        for (i, z) in zs.iter().enumerate() {
            assert!((z - (i as f64 + 0.5) * 10.0 / 32.0).abs() < 0.02, "slab {i} centred at {z}");
        }
        for (c, r) in &balls {
            assert!(c.x.abs() < 1e-6 && c.y.abs() < 1e-6, "off the axis: {c}");
            assert!((r - want).abs() < 0.01 * want, "radius {r}, a slab's ball {want}");
        }
        for p in &pts {
            assert!(balls.iter().any(|(c, r)| p.distance(*c) <= r * (1.0 + 1e-9)), "{p} in no ball");
        }
        // The same rod turned oblique (its axis along (1, 2, 2) / 3) and moved: cut across its
        // own axis (the points' principal axis), it is the same chain, where cuts along x, y
        // and z alone would slice it at a slant into larger balls.
        let rot = glam::DQuat::from_rotation_arc(DVec3::Z, DVec3::new(1.0, 2.0, 2.0) / 3.0);
        let shift = DVec3::new(3.0, -1.0, 0.5);
        let turned: Vec<DVec3> = pts.iter().map(|p| rot * *p + shift).collect();
        let balls = split_start(&turned, 32, true);
        assert_eq!(balls.len(), 32);
        let axis = DVec3::new(1.0, 2.0, 2.0) / 3.0;
        let mut along: Vec<f64> = balls.iter().map(|(c, _)| (*c - shift).dot(axis)).collect();
        along.sort_by(f64::total_cmp);
        for (i, t) in along.iter().enumerate() {
            assert!((t - (i as f64 + 0.5) * 10.0 / 32.0).abs() < 0.02, "oblique slab {i} centred at {t}");
        }
        for (c, r) in &balls {
            let off = (*c - shift) - axis * (*c - shift).dot(axis);
            assert!(off.length() < 0.01, "off the oblique axis by {}", off.length());
            assert!((r - want).abs() < 0.01 * want, "oblique radius {r}, a slab's ball {want}");
        }
        let cube: Vec<DVec3> =
            (0..1000).map(|i| DVec3::new((i % 10) as f64, (i / 10 % 10) as f64, (i / 100) as f64) / 9.0).collect();
        let oct = split_start(&cube, 8, true);
        assert_eq!(oct.len(), 8);
        for (c, r) in &oct {
            for a in 0..3 {
                assert!((c[a] - 0.5).abs() > 0.2, "not an octant: {c}");
            }
            // An octant's points fill a cube of side 4/9 (j / 9, j = 0..=4 or 5..=9).
            let want = 3f64.sqrt() * 2.0 / 9.0;
            assert!((r - want).abs() < 1e-9 * want, "radius {r}, the octant's ball {want}");
        }
        assert!(split_start(&[], 8, true).is_empty() && split_start(&cube, 0, true).is_empty());
        // Points that all coincide are one cell whatever k asks.
        assert_eq!(split_start(&[DVec3::ONE; 5], 4, true).len(), 1);
    }

    /// The best count of the split start against the brute force: the cuts do not depend on
    /// `k`, so `split_start(points, j)` is the sequence stopped after j − 1 cuts, and the
    /// returned cells must be those of the j ≤ k of least summed cost (the latest on a tie).
    /// The cost here is a ball's volume outside a round rod of radius 0.5 and length 2 along
    /// z, from a midpoint sum over the ball (an independent stand-in for the proxy). A cost of
    /// 0 gives the k cells twice.
    #[test]
    fn the_split_starts_best_count_is_the_least_total_cost_of_every_count() {
        let mut pts = Vec::new();
        for iz in 0..=64 {
            let z = -1.0 + 2.0 * iz as f64 / 64.0;
            for ia in 0..16 {
                let t = std::f64::consts::TAU * ia as f64 / 16.0;
                for r in [0.5, 0.25] {
                    pts.push(DVec3::new(r * t.cos(), r * t.sin(), z));
                }
            }
        }
        let outside = |c: DVec3, r: f64| {
            let n = 24;
            let step = 2.0 * r / n as f64;
            let mut v = 0.0;
            for i in 0..n {
                for j in 0..n {
                    for l in 0..n {
                        let q = c + DVec3::new(i as f64 + 0.5, j as f64 + 0.5, l as f64 + 0.5) * step - DVec3::splat(r);
                        let inside = q.x * q.x + q.y * q.y <= 0.25 && q.z.abs() <= 1.0;
                        if q.distance(c) <= r && !inside {
                            v += step.powi(3);
                        }
                    }
                }
            }
            v
        };
        for (k, oblique) in [(12, false), (24, true), (5, false)] {
            let (all, best) = split_starts(&pts, k, oblique, outside);
            assert_eq!(all, split_start(&pts, k, oblique));
            let totals: Vec<f64> = (1..=k)
                .map(|j| split_start(&pts, j, oblique).iter().map(|&(c, r)| outside(c, r)).sum::<f64>())
                .collect();
            let least = totals.iter().copied().fold(f64::INFINITY, f64::min);
            let j = totals.iter().rposition(|&t| t == least).unwrap() + 1;
            assert_eq!(best, split_start(&pts, j, oblique), "k {k}: totals {totals:?}");
            let (a0, b0) = split_starts(&pts, k, oblique, |_, _| 0.0);
            assert!(a0 == all && b0 == all);
            if k >= 12 {
                // The short rod's slabs: beyond a few, thinner slabs add outside volume.
                assert!(j < k && j >= 3, "best count {j} of {k}: {totals:?}");
            }
        }
    }
}
