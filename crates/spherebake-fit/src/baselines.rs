//! The two baselines: k-means of surface points (each sphere the bounding sphere of its
//! cluster about the centroid) and adaptive-octree leaf-cube spheres (Ren et al. 2006 Fig. 4).
//! Both pass through the same exactness rules as the variational fit afterwards.

use crate::rng::SplitMix64;
use crate::solid::Solid;
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
}
