//! Sphere hierarchy over a sphere set (Ren et al. 2006 §6.3, "Construction and Animation").
//!
//! The fitted spheres are the leaves. Levels are built bottom-up: Lloyd clustering of the
//! level's spheres by centre distance (k-means++ start from `seed`), each cluster's parent the
//! *exact* minimal ball enclosing its child spheres (where the paper runs Powell on the centre),
//! the cluster count per level chosen so that the average branching ratio is
//! [`HierarchySettings::branching`]; the last level is a single root.
//!
//! **Storage.** Parents are stored in f32 and still contain their children when those stored
//! values are evaluated exactly: the centre is the f32 lattice point near the exact centre (of
//! 5³) that needs the smallest radius, and the radius is rounded up. Children are the stored (f32) values of the
//! level below, so containment holds level by level.
//!
//! **Node order.** Nodes are listed level by level from the leaves up; the root is the last node,
//! and every child node has a smaller index than its parent (so a forward pass is a bottom-up
//! refit). A node holds either child nodes or leaves, never both.
//!
//! Determinism: randomness from [`SplitMix64`] seeded by (seed, level); parallel work collects in
//! order, so the result does not depend on the rayon thread count.

use crate::baselines::kmeanspp_seeds;
use crate::rng::SplitMix64;
use glam::DVec3;
use rayon::prelude::*;
use spherebake_format::quant::{next_down_f32, next_up_f32, round_up_f32};
use spherebake_format::{Hierarchy, HierarchyNode, NodeLists};
use spherebake_geom::sphere::{min_enclosing_ball_of_balls, tangent_balls};

/// Hierarchy build settings.
#[derive(Clone, Debug, PartialEq)]
pub struct HierarchySettings {
    /// Target average branching ratio: children per parent, averaged over all parents
    /// (default 4, range 2..=16; Ren 2006 uses 4).
    pub branching: f64,
    /// Seed of the k-means++ starts (default 1).
    pub seed: u64,
}

impl Default for HierarchySettings {
    fn default() -> Self {
        Self { branching: 4.0, seed: 1 }
    }
}

/// Why a hierarchy could not be built.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum HierarchyError {
    /// No leaf spheres.
    #[error("no leaf spheres to build a hierarchy over")]
    NoLeaves,
    /// A leaf has a non-finite centre or radius, or a negative radius.
    #[error("leaf sphere {index} is invalid: centre and radius must be finite, radius ≥ 0 (got {value:?})")]
    InvalidLeaf {
        /// Index into the leaves.
        index: usize,
        /// The offending (x, y, z, radius).
        value: [f32; 4],
    },
    /// `branching` is outside 2..=16 (or not finite).
    #[error("branching = {value} is out of range (expected 2..=16)")]
    InvalidBranching {
        /// The given value.
        value: f64,
    },
    /// More leaves than u32 indices can address.
    #[error("{count} leaves is more than the format's u32 indices can address")]
    TooManyLeaves {
        /// Leaf count.
        count: usize,
    },
}

/// Measured shape and quality of a hierarchy.
#[derive(Clone, Debug, PartialEq)]
pub struct HierarchyStats {
    /// Number of node levels: 1 + the largest depth of a node below the root (leaves not counted).
    pub levels: usize,
    /// Average number of children (nodes + leaves) per node.
    pub mean_branching: f64,
    /// Mean over nodes of radius / radius of the minimal ball enclosing its children
    /// ([`brute_force_min_ball_of_balls`]); 1 is perfectly tight.
    pub tightness_mean: f64,
    /// Maximum of that ratio.
    pub tightness_max: f64,
}

/// A ball in f64, model units.
use crate::Ball;

fn leaf_ball(s: &[f32; 4]) -> Ball {
    (DVec3::new(f64::from(s[0]), f64::from(s[1]), f64::from(s[2])), f64::from(s[3]))
}

fn node_ball(n: &HierarchyNode) -> Ball {
    (DVec3::new(f64::from(n.center[0]), f64::from(n.center[1]), f64::from(n.center[2])), f64::from(n.radius))
}

/// Builds the hierarchy over `leaves` (x, y, z, radius; model space).
///
/// Every leaf is in the leaf range of exactly one node; see the module docs for the node
/// order and the f32 containment guarantee.
///
/// # Errors
///
/// [`HierarchyError`] for empty input, an invalid leaf or an out-of-range setting.
pub fn build_hierarchy(leaves: &[[f32; 4]], settings: &HierarchySettings) -> Result<Hierarchy, HierarchyError> {
    let b = settings.branching;
    if !b.is_finite() || !(2.0..=16.0).contains(&b) {
        return Err(HierarchyError::InvalidBranching { value: b });
    }
    if leaves.is_empty() {
        return Err(HierarchyError::NoLeaves);
    }
    if u32::try_from(leaves.len()).is_err() {
        return Err(HierarchyError::TooManyLeaves { count: leaves.len() });
    }
    for (index, s) in leaves.iter().enumerate() {
        if !s.iter().all(|v| v.is_finite()) || s[3] < 0.0 {
            return Err(HierarchyError::InvalidLeaf { index, value: *s });
        }
    }
    let plan = plan_levels(leaves.len(), b);
    let mut nodes: Vec<NodeLists> = Vec::new();
    // Current level: balls (stored f32 values as f64) and their ids (leaf or node index).
    let mut level: Vec<Ball> = leaves.iter().map(leaf_ball).collect();
    let mut level_is_leaf = true;
    let mut level_first_id = 0u32;
    for (depth, &k) in plan.iter().enumerate() {
        let seed = settings.seed ^ (depth as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let assignment = lloyd(&level, k, seed);
        let mut members: Vec<Vec<u32>> = vec![Vec::new(); k];
        for (i, &c) in assignment.iter().enumerate() {
            members[c as usize].push(i as u32);
        }
        let parents: Vec<NodeLists> = members
            .par_iter()
            .map(|m| {
                let balls: Vec<Ball> = m.iter().map(|&i| level[i as usize]).collect();
                let (center, radius) = store_enclosing(&balls);
                let ids: Vec<u32> = m.iter().map(|&i| level_first_id + i).collect();
                let (children, leaf_children) = if level_is_leaf { (Vec::new(), ids) } else { (ids, Vec::new()) };
                NodeLists { center, radius, children, leaf_children }
            })
            .collect();
        level_first_id = nodes.len() as u32;
        level = parents.iter().map(|n| leaf_ball(&[n.center[0], n.center[1], n.center[2], n.radius])).collect();
        level_is_leaf = false;
        nodes.extend(parents);
    }
    let root = nodes.len().saturating_sub(1) as u32;
    Ok(Hierarchy::from_lists(root, nodes))
}

/// Node counts per level, bottom-up, ending with 1 (the root): repeated division by `b`
/// (rounded), or cut short by sending a level straight to the root, whichever gives the mean
/// branching closest to `b` (root fan-out at most 3b). One leaf → `[1]`.
fn plan_levels(leaf_count: usize, b: f64) -> Vec<usize> {
    let mut seq = Vec::new();
    let mut n = leaf_count;
    while n > 1 {
        let k = ((n as f64 / b).round() as usize).clamp(1, n - 1);
        seq.push(k);
        n = k;
    }
    if seq.is_empty() {
        return vec![1];
    }
    // Candidates: seq[..j] followed by the root, for every j whose level may feed the root.
    let mut best: Option<(f64, Vec<usize>)> = None;
    for j in 0..seq.len() {
        let fan_in = if j == 0 { leaf_count } else { seq[j - 1] };
        if j + 1 < seq.len() && fan_in as f64 > 3.0 * b {
            continue;
        }
        let mut cand: Vec<usize> = seq[..j].to_vec();
        cand.push(1);
        let internal: usize = cand.iter().sum();
        let mean = (leaf_count + internal - 1) as f64 / internal as f64;
        let err = (mean - b).abs();
        if best.as_ref().is_none_or(|(e, _)| err < *e - 1e-12) {
            best = Some((err, cand));
        }
    }
    best.map_or(seq, |(_, c)| c)
}

/// Lloyd clustering of `balls` into exactly `k` non-empty clusters by centre distance
/// (Ren 2006 §6.3): assign each ball to the nearest cluster centre, then move each centre to its
/// cluster's minimal enclosing ball centre; k-means++ start. Returns the assignment with the
/// smallest total enclosing radius seen.
fn lloyd(balls: &[Ball], k: usize, seed: u64) -> Vec<u32> {
    let n = balls.len();
    if k <= 1 || n <= 1 {
        return vec![0; n];
    }
    let k = k.min(n);
    let mut rng = SplitMix64::new(seed);
    // k-means++ seeding on the centres.
    let points: Vec<DVec3> = balls.iter().map(|b| b.0).collect();
    let mut centres: Vec<DVec3> = kmeanspp_seeds(&points, k, &mut rng).into_iter().map(|i| points[i]).collect();
    let mut best: Option<(f64, Vec<u32>)> = None;
    let mut previous: Vec<u32> = Vec::new();
    for _ in 0..40 {
        let mut assign: Vec<u32> = balls
            .par_iter()
            .map(|b| {
                let mut bi = 0u32;
                let mut bd = f64::INFINITY;
                for (j, c) in centres.iter().enumerate() {
                    let d = b.0.distance_squared(*c);
                    if d < bd {
                        bd = d;
                        bi = j as u32;
                    }
                }
                bi
            })
            .collect();
        fill_empty_clusters(balls, &centres, &mut assign, k);
        let mut members: Vec<Vec<Ball>> = vec![Vec::new(); k];
        for (i, &c) in assign.iter().enumerate() {
            members[c as usize].push(balls[i]);
        }
        let enclosing: Vec<Ball> = members.par_iter().map(|m| min_enclosing_ball_of_balls(m)).collect();
        let cost: f64 = enclosing.iter().map(|e| e.1).sum();
        if best.as_ref().is_none_or(|(c, _)| cost < *c) {
            best = Some((cost, assign.clone()));
        }
        if assign == previous {
            break;
        }
        centres = enclosing.iter().map(|e| e.0).collect();
        previous = assign;
    }
    best.map_or_else(|| vec![0; n], |(_, a)| a)
}

/// Gives every empty cluster one ball: the one sticking out farthest (centre distance + radius)
/// from its own cluster centre among clusters with at least two members (lowest index on ties).
fn fill_empty_clusters(balls: &[Ball], centres: &[DVec3], assign: &mut [u32], k: usize) {
    let mut counts = vec![0usize; k];
    for &a in assign.iter() {
        counts[a as usize] += 1;
    }
    for j in 0..k {
        if counts[j] > 0 {
            continue;
        }
        let mut pick: Option<(f64, usize)> = None;
        for (i, b) in balls.iter().enumerate() {
            let a = assign[i] as usize;
            if counts[a] < 2 {
                continue;
            }
            let s = b.0.distance(centres[a]) + b.1;
            if pick.is_none_or(|(ps, _)| s > ps) {
                pick = Some((s, i));
            }
        }
        let Some((_, i)) = pick else { return };
        counts[assign[i] as usize] -= 1;
        assign[i] = j as u32;
        counts[j] = 1;
    }
}

/// The f32 sphere to store for a parent of `balls` (f64 copies of stored f32 values): the exact
/// minimal enclosing ball, its centre moved to the f32 lattice point (within ±2 steps per axis of
/// the nearest) that needs the smallest radius, the radius rounded up so that |c − cᵢ| + rᵢ ≤ r
/// holds for the stored values (checked in f64 with a 4-ulp margin).
///
/// Moving the centre by δ costs about |δ·u| along the direction u of two opposite supports but
/// only |δ|²/2R across it, so searching 125 lattice points usually finds one far better than the
/// nearest; with 4 supports around the centre the cost is linear in every direction, and the
/// inflation stays of the order of the f32 spacing at |c|.
fn store_enclosing(balls: &[Ball]) -> ([f32; 3], f32) {
    let (c, _) = min_enclosing_ball_of_balls(balls);
    let axis = |v: f64| -> [f32; 5] {
        let m = v as f32;
        let (d1, u1) = (next_down_f32(m), next_up_f32(m));
        [next_down_f32(d1), d1, m, u1, next_up_f32(u1)]
    };
    let (ax, ay, az) = (axis(c.x), axis(c.y), axis(c.z));
    let mut best: Option<([f32; 3], f64)> = None;
    // Nearest first, so ties keep it.
    let order = [2usize, 1, 3, 0, 4];
    for &i in &order {
        for &j in &order {
            for &k in &order {
                let cc = [ax[i], ay[j], az[k]];
                let c64 = DVec3::new(f64::from(cc[0]), f64::from(cc[1]), f64::from(cc[2]));
                let need = balls.iter().map(|(bc, br)| bc.distance(c64) + br).fold(0.0, f64::max);
                if best.is_none_or(|(_, bn)| need < bn) {
                    best = Some((cc, need));
                }
            }
        }
    }
    let (center, need) = best.unwrap_or(([0.0; 3], 0.0));
    // f64 distance error is a few ulps; cover it before rounding up to f32.
    let need = need * (1.0 + 4.0 * f64::EPSILON);
    let radius = round_up_f32(need).max(f32::MIN_POSITIVE);
    (center, radius)
}

/// Measures `h` over `leaves`: levels, mean branching and parent tightness against
/// [`brute_force_min_ball_of_balls`] of each node's children (stored f32 values).
/// Out-of-range indices are skipped; a node without valid children counts as tightness 1.
pub fn hierarchy_stats(h: &Hierarchy, leaves: &[[f32; 4]]) -> HierarchyStats {
    let per_node: Vec<f64> = h
        .nodes
        .par_iter()
        .enumerate()
        .map(|(i, n)| {
            let mut balls: Vec<Ball> =
                h.children_of(i).iter().filter_map(|&c| h.nodes.get(c as usize)).map(node_ball).collect();
            balls.extend(h.leaves_of(i).iter().filter_map(|&l| leaves.get(l as usize)).map(leaf_ball));
            if balls.is_empty() {
                return 1.0;
            }
            let (_, r) = brute_force_min_ball_of_balls(&balls);
            if r > 0.0 {
                f64::from(n.radius) / r
            } else {
                1.0
            }
        })
        .collect();
    let count = per_node.len().max(1) as f64;
    let edges: usize = (0..h.nodes.len()).map(|i| h.children_of(i).len() + h.leaves_of(i).len()).sum();
    HierarchyStats {
        levels: depth_levels(h),
        mean_branching: edges as f64 / count,
        tightness_mean: per_node.iter().sum::<f64>() / count,
        tightness_max: per_node.iter().copied().fold(0.0, f64::max),
    }
}

/// 1 + the largest node depth below the root (iterative; a malformed graph stops at
/// `nodes.len()` levels).
fn depth_levels(h: &Hierarchy) -> usize {
    if h.nodes.get(h.root as usize).is_none() {
        return 0;
    }
    let mut frontier = vec![h.root];
    let mut levels = 0;
    while !frontier.is_empty() && levels < h.nodes.len() {
        levels += 1;
        frontier = frontier
            .iter()
            .flat_map(|&n| h.children_of(n as usize).iter().copied())
            .filter(|&c| (c as usize) < h.nodes.len())
            .collect();
    }
    levels
}

/// Reference minimal enclosing ball of balls by brute force: every subset of at most 4 balls,
/// every ball internally tangent to all of them with its centre in their affine hull
/// (|c − cⱼ| + rⱼ = R: a linear system in the affine coordinates plus one quadratic in R), the
/// smallest one that contains every ball (to 1e-10 · scale). O(n⁵); meant for n ≲ 40.
/// Empty input → (0, 0).
pub fn brute_force_min_ball_of_balls(balls: &[(DVec3, f64)]) -> (DVec3, f64) {
    let n = balls.len();
    if n == 0 {
        return (DVec3::ZERO, 0.0);
    }
    let scale = balls.iter().map(|(c, r)| c.abs().max_element() + r.abs()).fold(0.0, f64::max).max(1e-300);
    let tol = 1e-10 * scale;
    let mut best: Option<Ball> = None;
    let mut consider = |cand: Ball| {
        if !(cand.0.is_finite() && cand.1.is_finite()) {
            return;
        }
        if best.is_some_and(|b| cand.1 >= b.1) {
            return;
        }
        if balls.iter().all(|(c, r)| c.distance(cand.0) + r <= cand.1 + tol) {
            best = Some(cand);
        }
    };
    for a in 0..n {
        consider(balls[a]);
        for b in a + 1..n {
            for cand in tangent_balls(balls, &[a, b]) {
                consider(cand);
            }
            for c in b + 1..n {
                for cand in tangent_balls(balls, &[a, b, c]) {
                    consider(cand);
                }
                for d in c + 1..n {
                    for cand in tangent_balls(balls, &[a, b, c, d]) {
                        consider(cand);
                    }
                }
            }
        }
    }
    // Fallback (numerically hopeless input): a ball around the first centre.
    best.unwrap_or_else(|| {
        let c = balls[0].0;
        (c, balls.iter().map(|(bc, r)| bc.distance(c) + r).fold(0.0, f64::max))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(leaf_count: usize, b: f64, expected: &[usize]) {
        assert_eq!(plan_levels(leaf_count, b), expected, "{leaf_count} leaves, b = {b}");
    }

    #[test]
    fn level_plans() {
        // 256 leaves, b = 4: 64, 16, 4, 1 → 85 parents = 255 / 3 exactly (mean branching 4).
        check(256, 4.0, &[64, 16, 4, 1]);
        check(1, 4.0, &[1]);
        check(2, 4.0, &[1]);
        // 9 leaves: [2, 1] gives (9 + 2) / 3 = 3.67, [1] gives 9: the first is closer to 4.
        check(9, 4.0, &[2, 1]);
        check(64, 2.0, &[32, 16, 8, 4, 2, 1]);
    }

    #[test]
    fn brute_force_matches_pair_bound_and_welzl_table() {
        // Math reference §6: pair bound ((1,2,3),0.5) + ((2,0,3.5),1.2) → R = 1.995643924.
        let (c, r) =
            brute_force_min_ball_of_balls(&[(DVec3::new(1.0, 2.0, 3.0), 0.5), (DVec3::new(2.0, 0.0, 3.5), 1.2)]);
        assert!((r - 1.995643924).abs() < 1e-8);
        assert!((c - DVec3::new(1.652752523, 0.6944949537, 3.326376262)).length() < 1e-8);
        // Points (radius 0): the regular tetrahedron row → √3 at the origin.
        let pts = [(1.0, 1.0, 1.0), (1.0, -1.0, -1.0), (-1.0, 1.0, -1.0), (-1.0, -1.0, 1.0)];
        let balls: Vec<Ball> = pts.iter().map(|&(x, y, z)| (DVec3::new(x, y, z), 0.0)).collect();
        let (c, r) = brute_force_min_ball_of_balls(&balls);
        assert!(c.length() < 1e-9 && (r - 3f64.sqrt()).abs() < 1e-9);
        // The ten-point row.
        let balls: Vec<Ball> = (0..10)
            .map(|k| {
                let k = k as f64;
                (DVec3::new((1.3 * k + 0.2).sin(), (2.1 * k).cos(), (0.7 * k + 1.1).sin()), 0.0)
            })
            .collect();
        let (c, r) = brute_force_min_ball_of_balls(&balls);
        assert!((r - 1.419500959).abs() < 1e-9);
        assert!((c - DVec3::new(0.1985562219, 0.2119352056, 0.04492116698)).length() < 1e-9);
        // Balls: three equal balls (radius 0.5) with centres on a unit circle → R = 1.5.
        let balls: Vec<Ball> = (0..3)
            .map(|k| {
                let a = k as f64 * 2.0 * std::f64::consts::PI / 3.0;
                (DVec3::new(a.cos(), a.sin(), 2.0), 0.5)
            })
            .collect();
        let (c, r) = brute_force_min_ball_of_balls(&balls);
        assert!((r - 1.5).abs() < 1e-12 && (c - DVec3::new(0.0, 0.0, 2.0)).length() < 1e-12);
    }
}
