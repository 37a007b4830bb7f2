//! The two baselines: k-means of surface points (each sphere the bounding sphere of its
//! cluster about the centroid) and adaptive-octree leaf-cube spheres (Ren et al. 2006 Fig. 4).
//! Both pass through the same exactness rules as the variational fit afterwards.

use crate::rng::SplitMix64;
use crate::solid::Solid;
use glam::DVec3;
use std::collections::BinaryHeap;

/// k-means (k-means++ seeding from `seed`, ≤ `iterations` Lloyd steps) of `pts`; each sphere is
/// centred at its cluster mean with radius reaching the farthest member.
pub fn kmeans(pts: &[DVec3], k: usize, seed: u64, iterations: usize) -> Vec<(DVec3, f64)> {
    if pts.is_empty() || k == 0 {
        return Vec::new();
    }
    let k = k.min(pts.len());
    let mut rng = SplitMix64::new(seed);
    let mut centres = vec![pts[rng.below(pts.len() as u64) as usize]];
    let mut d2: Vec<f64> = pts.iter().map(|p| p.distance_squared(centres[0])).collect();
    while centres.len() < k {
        let total: f64 = d2.iter().sum();
        let idx = if total > 0.0 {
            let mut t = rng.next_f64() * total;
            let mut pick = pts.len() - 1;
            for (i, &w) in d2.iter().enumerate() {
                if t < w {
                    pick = i;
                    break;
                }
                t -= w;
            }
            pick
        } else {
            rng.below(pts.len() as u64) as usize
        };
        centres.push(pts[idx]);
        for (i, p) in pts.iter().enumerate() {
            d2[i] = d2[i].min(p.distance_squared(pts[idx]));
        }
    }
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
                    nodes.push(Node { centre: c, half: h, tris: sub });
                    inside_leaves.push(nodes.len() - 1);
                    count += 1;
                }
            } else {
                nodes.push(Node { centre: c, half: h, tris: sub });
                heap.push((h.to_bits(), std::cmp::Reverse(nodes.len() - 1)));
                count += 1;
            }
        }
    }
    let mut leaves: Vec<usize> = heap.into_iter().map(|(_, std::cmp::Reverse(i))| i).collect();
    leaves.extend(inside_leaves);
    leaves.sort_unstable();
    leaves.iter().map(|&i| (nodes[i].centre, nodes[i].half * 3f64.sqrt())).collect()
}
