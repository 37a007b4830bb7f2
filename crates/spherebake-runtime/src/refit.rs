//! Animation-time refit of the sphere hierarchy (Ren et al. 2006 §6.3): after the leaves (the
//! sphere set) have been posed, every parent is recomputed bottom-up by merging its children one
//! at a time with the sphere-pair bound (math reference §6).
//!
//! A [`HierarchyPlan`] is built once per hierarchy (it allocates and validates the tree, and
//! precomputes the refit schedule: nodes grouped by height so that independent merge chains run
//! side by side); [`refit`] and [`crate::cut::cut`] then use it without further checks of the
//! tree. [`refit`] does not allocate.
//!
//! Arithmetic is f64 inside (f32 in and out); every stored parent is rounded outwards (centre to
//! nearest, radius up, plus the centre's rounding distance), so the f32 parents contain the f32
//! children exactly when evaluated in exact arithmetic.

use crate::{Hierarchy, Sphere};
use alloc::vec;
use alloc::vec::Vec;
use core::fmt;
use spherebake_format::quant::round_up_f32;

/// Flag bit of a child reference in [`HierarchyPlan`]: set = leaf (sphere) index.
const LEAF_BIT: u32 = 1 << 31;

/// Nodes merged side by side by [`refit`]: one group holds up to this many nodes of the same
/// height, so their merge chains are independent and the processor overlaps them
/// (pose_timing, 85 nodes: refit 1.83 µs with 4, 2.3 µs with 2, 1.66 µs with 8, 1.74 µs with 16).
const LANES: usize = 8;

/// Padding in a refit group: as a node index never in range (a plan has fewer than 2³¹ nodes),
/// so it names no child sphere and no output node.
const PAD: u32 = !LEAF_BIT;

/// Why a hierarchy cannot be planned or a refit / cut call was given unusable slices.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum QueryError {
    /// The hierarchy has no nodes.
    Empty,
    /// `root` is not below the node count.
    RootOutOfRange {
        /// The root index.
        root: u32,
        /// Number of nodes.
        node_count: usize,
    },
    /// A node lists a child node index that is not below the node count.
    ChildOutOfRange {
        /// The listing node.
        node: u32,
        /// The bad child index.
        child: u32,
        /// Number of nodes.
        node_count: usize,
    },
    /// A node or leaf index does not fit in 31 bits.
    IndexTooLarge {
        /// The listing node.
        node: u32,
        /// The index.
        index: u32,
    },
    /// A node is reached twice from the root (the graph is not a tree).
    NodeReachedTwice {
        /// The node.
        node: u32,
    },
    /// A node is not reachable from the root.
    NodeUnreachable {
        /// The node.
        node: u32,
    },
    /// A node's child or leaf range runs past the end of the hierarchy's index array.
    RangeOutOfBounds {
        /// The node.
        node: u32,
    },
    /// A node has neither child nodes nor leaves.
    NodeEmpty {
        /// The node.
        node: u32,
    },
    /// A slice passed to a query has the wrong length.
    SliceLength {
        /// Which argument: `"posed_leaves"`, `"nodes_out"` or `"nodes"`.
        argument: &'static str,
        /// Required length (for leaves: at least this many).
        expected: usize,
        /// Given length.
        actual: usize,
    },
}

impl fmt::Display for QueryError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            QueryError::Empty => write!(f, "hierarchy has no nodes"),
            QueryError::RootOutOfRange { root, node_count } => {
                write!(f, "hierarchy root {root} is out of range (expected < {node_count})")
            }
            QueryError::ChildOutOfRange { node, child, node_count } => {
                write!(f, "node {node} lists child {child}, but there are {node_count} nodes")
            }
            QueryError::IndexTooLarge { node, index } => {
                write!(f, "node {node} lists index {index}, above the 31-bit limit")
            }
            QueryError::NodeReachedTwice { node } => write!(f, "node {node} is reached twice from the root"),
            QueryError::NodeUnreachable { node } => write!(f, "node {node} is not reachable from the root"),
            QueryError::NodeEmpty { node } => write!(f, "node {node} has no children and no leaves"),
            QueryError::RangeOutOfBounds { node } => {
                write!(f, "node {node} has a child or leaf range past the end of its index array")
            }
            QueryError::SliceLength { argument, expected, actual } => {
                write!(f, "{argument} has length {actual}, expected {expected}")
            }
        }
    }
}

impl core::error::Error for QueryError {}

/// A validated, flattened copy of a hierarchy's tree: per node its children (nodes and leaves)
/// in one array, and a bottom-up order (every child node before its parent).
#[derive(Clone, Debug, PartialEq)]
pub struct HierarchyPlan {
    /// Per node: range `[start, end)` into `refs`.
    ranges: Vec<(u32, u32)>,
    /// Child references: node index, or `LEAF_BIT | leaf index`. Per node: child nodes in
    /// listed order, then leaves in listed order (the merge order of [`refit`]).
    refs: Vec<u32>,
    /// Node indices, children before parents.
    bottom_up: Vec<u32>,
    /// The refit schedule: per group `(offset, steps)` into `lanes`; row `offset` holds the
    /// group's node indices, rows `offset + 1 ..= offset + steps` their child references, one
    /// merge step per row (the order of `refs`). Groups are sorted by node height (leaf-only
    /// nodes first), so every child node is refitted in an earlier group. Unused entries: [`PAD`].
    groups: Vec<(u32, u32)>,
    /// Rows of [`LANES`] node indices or child references, see `groups`.
    lanes: Vec<[u32; LANES]>,
    root: u32,
    /// 1 + the largest leaf index (0 without leaves).
    leaf_bound: usize,
}

impl HierarchyPlan {
    /// Validates `hierarchy` as a tree (root in range, every node reached exactly once, child
    /// indices in range, no empty node) and flattens it.
    ///
    /// # Errors
    ///
    /// The first violation found, as a [`QueryError`].
    pub fn new(hierarchy: &Hierarchy) -> Result<HierarchyPlan, QueryError> {
        let nodes = &hierarchy.nodes;
        let node_count = nodes.len();
        if node_count == 0 {
            return Err(QueryError::Empty);
        }
        // Node indices stay below 2^31: the leaf flag and `PAD` need the top bit.
        if hierarchy.root as usize >= node_count || node_count > PAD as usize {
            return Err(QueryError::RootOutOfRange { root: hierarchy.root, node_count });
        }
        let mut ranges = vec![(0u32, 0u32); node_count];
        let mut refs = Vec::new();
        let mut leaf_bound = 0usize;
        for (i, n) in nodes.iter().enumerate() {
            let node = i as u32;
            let (children, leaves) = (hierarchy.children_of(i), hierarchy.leaves_of(i));
            if children.len() != n.child_count as usize || leaves.len() != n.leaf_count as usize {
                return Err(QueryError::RangeOutOfBounds { node });
            }
            if children.is_empty() && leaves.is_empty() {
                return Err(QueryError::NodeEmpty { node });
            }
            let start = refs.len();
            for &c in children {
                if c as usize >= node_count {
                    return Err(QueryError::ChildOutOfRange { node, child: c, node_count });
                }
                refs.push(c);
            }
            for &l in leaves {
                if l & LEAF_BIT != 0 {
                    return Err(QueryError::IndexTooLarge { node, index: l });
                }
                leaf_bound = leaf_bound.max(l as usize + 1);
                refs.push(LEAF_BIT | l);
            }
            let end = u32::try_from(refs.len()).map_err(|_| QueryError::IndexTooLarge { node, index: u32::MAX })?;
            ranges[i] = (start as u32, end);
        }
        // Pre-order from the root; reversed it lists children before parents.
        let mut seen = vec![false; node_count];
        let mut pre = Vec::with_capacity(node_count);
        let mut stack = vec![hierarchy.root];
        while let Some(n) = stack.pop() {
            let seen_n = &mut seen[n as usize];
            if *seen_n {
                return Err(QueryError::NodeReachedTwice { node: n });
            }
            *seen_n = true;
            pre.push(n);
            let (s, e) = ranges[n as usize];
            stack.extend(refs[s as usize..e as usize].iter().rev().filter(|&&r| r & LEAF_BIT == 0));
        }
        if let Some(node) = seen.iter().position(|&s| !s) {
            return Err(QueryError::NodeUnreachable { node: node as u32 });
        }
        pre.reverse();
        let (groups, lanes) = schedule(&ranges, &refs, &pre);
        Ok(HierarchyPlan { ranges, refs, bottom_up: pre, groups, lanes, root: hierarchy.root, leaf_bound })
    }

    /// Number of nodes.
    #[must_use]
    pub fn node_count(&self) -> usize {
        self.ranges.len()
    }

    /// The root node index.
    #[must_use]
    pub fn root(&self) -> u32 {
        self.root
    }

    /// The fewest leaves a query needs: 1 + the largest leaf index.
    #[must_use]
    pub fn leaf_bound(&self) -> usize {
        self.leaf_bound
    }

    /// Node indices with every child node before its parent.
    #[must_use]
    pub fn bottom_up_order(&self) -> &[u32] {
        &self.bottom_up
    }

    /// Child references of `node` (empty when out of range).
    pub(crate) fn refs_of(&self, node: u32) -> impl Iterator<Item = ChildRef> + '_ {
        let (s, e) = self.ranges.get(node as usize).copied().unwrap_or((0, 0));
        self.refs.get(s as usize..e as usize).unwrap_or(&[]).iter().map(|&r| {
            if r & LEAF_BIT != 0 {
                ChildRef::Leaf(r & !LEAF_BIT)
            } else {
                ChildRef::Node(r)
            }
        })
    }
}

/// The refit schedule of a validated tree (`bottom_up` lists children before parents): nodes
/// sorted by height (0 = no child nodes), then by child count (fewest padded merge steps), then
/// by bottom-up position; cut into groups of [`LANES`] nodes of equal height.
fn schedule(ranges: &[(u32, u32)], refs: &[u32], bottom_up: &[u32]) -> (Vec<(u32, u32)>, Vec<[u32; LANES]>) {
    let children = |n: u32| {
        let (s, e) = ranges.get(n as usize).copied().unwrap_or((0, 0));
        refs.get(s as usize..e as usize).unwrap_or(&[])
    };
    let mut height = vec![0u32; ranges.len()];
    for &n in bottom_up {
        let h = children(n)
            .iter()
            .filter(|&&r| r & LEAF_BIT == 0)
            .map(|&c| height.get(c as usize).map_or(0, |h| h + 1))
            .max()
            .unwrap_or(0);
        if let Some(slot) = height.get_mut(n as usize) {
            *slot = h;
        }
    }
    let mut order: Vec<u32> = bottom_up.to_vec();
    // Stable: ties keep the bottom-up order, so the schedule is a function of the tree.
    order.sort_by_key(|&n| (height.get(n as usize).copied().unwrap_or(0), children(n).len()));
    let mut groups = Vec::new();
    let mut lanes = Vec::new();
    let mut rest = order.as_slice();
    while let Some(&first) = rest.first() {
        let h = height.get(first as usize).copied().unwrap_or(0);
        let same = rest.iter().take(LANES).take_while(|&&n| height.get(n as usize).copied().unwrap_or(0) == h).count();
        let (group, tail) = rest.split_at(same);
        rest = tail;
        let steps = group.iter().map(|&n| children(n).len()).max().unwrap_or(0);
        let mut row = [PAD; LANES];
        row[..group.len()].copy_from_slice(group);
        groups.push((lanes.len() as u32, steps as u32));
        lanes.push(row);
        for k in 0..steps {
            let mut row = [PAD; LANES];
            for (slot, &n) in row.iter_mut().zip(group) {
                *slot = children(n).get(k).copied().unwrap_or(PAD);
            }
            lanes.push(row);
        }
    }
    (groups, lanes)
}

/// A decoded child reference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ChildRef {
    Node(u32),
    Leaf(u32),
}

/// The hierarchy's stored (rest-pose) node spheres, indexed like `hierarchy.nodes`: the starting
/// point for [`crate::cut::cut`] without animation.
#[must_use]
pub fn rest_node_spheres(hierarchy: &Hierarchy) -> Vec<Sphere> {
    hierarchy.nodes.iter().map(|n| Sphere { center: n.center, radius: n.radius }).collect()
}

/// Recomputes every node sphere of the planned hierarchy from `posed_leaves` (the sphere set
/// after animation, model or world space — the output is in the same space), bottom-up: each
/// node is its first child, then the sphere-pair bound with each further child in turn (child
/// nodes in listed order, then leaves). Writes `nodes_out[i]` for node `i`.
///
/// The nodes are visited in the plan's schedule: groups of up to eight nodes of equal height
/// whose merge chains run side by side (the chains are latency-bound: square root, division).
/// Each node's result is that of merging its own children in the order above, so it does not
/// depend on the grouping.
///
/// Allocation-free; O(nodes + leaves + padding of groups with unequal child counts). Measured
/// (`benches/refit_cut.rs`, criterion median, median of 3 runs, 2-core machine at a load average
/// of about 2): 1.9 µs for 256 leaves and 85 nodes (branching 4), 5.1 µs one node at a time.
///
/// # Errors
///
/// [`QueryError::SliceLength`] when `posed_leaves` is shorter than [`HierarchyPlan::leaf_bound`]
/// or `nodes_out` is not [`HierarchyPlan::node_count`] long; nothing is written then.
pub fn refit(plan: &HierarchyPlan, posed_leaves: &[Sphere], nodes_out: &mut [Sphere]) -> Result<(), QueryError> {
    if posed_leaves.len() < plan.leaf_bound {
        return Err(QueryError::SliceLength {
            argument: "posed_leaves",
            expected: plan.leaf_bound,
            actual: posed_leaves.len(),
        });
    }
    if nodes_out.len() != plan.node_count() {
        return Err(QueryError::SliceLength {
            argument: "nodes_out",
            expected: plan.node_count(),
            actual: nodes_out.len(),
        });
    }
    for &(offset, steps) in &plan.groups {
        let rows = plan.lanes.get(offset as usize..=(offset + steps) as usize).unwrap_or(&[]);
        let Some((group, steps)) = rows.split_first() else { continue };
        // Every node has a child, so the first step sets every used lane.
        let mut acc = [Ball { c: [0.0; 3], r: f64::NAN }; LANES];
        for (k, step) in steps.iter().enumerate() {
            for (a, &r) in acc.iter_mut().zip(step) {
                // In range: the plan checked node indices, the length checks above the leaf
                // indices; `PAD` is out of range of both.
                let s = if r & LEAF_BIT != 0 {
                    posed_leaves.get((r & !LEAF_BIT) as usize)
                } else {
                    nodes_out.get(r as usize)
                };
                let Some(s) = s else { continue };
                let b = Ball::from_sphere(s);
                *a = if k == 0 { b } else { a.merge(b) };
            }
        }
        for (a, &n) in acc.iter().zip(group) {
            if let Some(out) = nodes_out.get_mut(n as usize) {
                *out = a.to_sphere_outward();
            }
        }
    }
    Ok(())
}

/// A ball in f64.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Ball {
    pub(crate) c: [f64; 3],
    pub(crate) r: f64,
}

impl Ball {
    pub(crate) fn from_sphere(s: &Sphere) -> Ball {
        Ball { c: [f64::from(s.center[0]), f64::from(s.center[1]), f64::from(s.center[2])], r: f64::from(s.radius) }
    }

    /// The sphere-pair bound (math reference §6): the smallest ball containing both.
    pub(crate) fn merge(self, o: Ball) -> Ball {
        let dv = [o.c[0] - self.c[0], o.c[1] - self.c[1], o.c[2] - self.c[2]];
        let d2 = dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2];
        let dr = self.r - o.r;
        if dr >= 0.0 && d2 <= dr * dr {
            return self;
        }
        if dr <= 0.0 && d2 <= dr * dr {
            return o;
        }
        // An overestimate d' ≥ d still gives an enclosing ball (centre c1 + Δ (R' − r1)/d', radius
        // R' = (d' + r1 + r2)/2: its distances to c1 and c2 scale by d/d' ≤ 1), only (d' − d)/2 larger.
        let d = sqrt_upper(d2);
        if d.is_nan() || d <= 0.0 {
            // NaN input: propagate rather than divide by zero.
            return Ball { c: self.c, r: f64::NAN };
        }
        let r = 0.5 * (d + self.r + o.r);
        let t = (r - self.r) / d;
        Ball { c: [self.c[0] + dv[0] * t, self.c[1] + dv[1] * t, self.c[2] + dv[2] * t], r }
    }

    /// Rounds to f32 outwards: centre to nearest; radius + the centre's rounding distance
    /// (bounded by its L1 norm) + a few f64 ulps, rounded up.
    pub(crate) fn to_sphere_outward(self) -> Sphere {
        let center = [self.c[0] as f32, self.c[1] as f32, self.c[2] as f32];
        let shift: f64 = (0..3).map(|k| (f64::from(center[k]) - self.c[k]).abs()).sum();
        let mag = self.c.iter().fold(0.0f64, |m, v| m.max(v.abs())) + self.r.abs();
        let need = self.r + shift + 8.0 * f64::EPSILON * mag;
        Sphere { center, radius: round_up_f32(need) }
    }
}

/// An upper bound of √x, within 3 ulps: the correctly rounded square root (one `sqrtsd` on
/// x86-64, [`spherebake_sh::sqrt_f64`]) raised by 2ε, so it is never below the exact value. NaN, 0 and ∞ map to
/// themselves.
pub(crate) fn sqrt_upper(x: f64) -> f64 {
    spherebake_sh::sqrt_f64(x) * (1.0 + 2.0 * f64::EPSILON)
}

/// √x (correctly rounded, `libm`). Negative → NaN, NaN → NaN.
pub(crate) fn sqrt(x: f64) -> f64 {
    spherebake_sh::sqrt_f64(x)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    #[test]
    fn sqrt_upper_bounds_from_above() {
        let mut x = 1e-300f64;
        let mut k = 0u64;
        while x < 1e300 {
            // Sweep mantissas too: the first guess is worst at particular ones.
            let v = x * (1.0 + (k % 97) as f64 / 97.0);
            let e = std::primitive::f64::sqrt(v);
            let u = sqrt_upper(v);
            assert!(u >= e && u <= e * (1.0 + 2e-10), "{v}: {u} vs {e}");
            x *= 1.013;
            k += 1;
        }
        assert!(sqrt_upper(f64::NAN).is_nan());
        assert_eq!(sqrt_upper(0.0), 0.0);
    }

    #[test]
    fn sqrt_matches_std() {
        let mut x = 1e-320f64;
        while x < 1e300 {
            for m in [1.0, 1.37, 2.0, 3.999, 7.5] {
                let v = x * m;
                let e = std::primitive::f64::sqrt(v);
                assert!((sqrt(v) - e).abs() <= 2.0 * f64::EPSILON * e, "{v}: {} vs {e}", sqrt(v));
            }
            x *= 3.7;
        }
        assert_eq!(sqrt(0.0), 0.0);
        assert!(sqrt(-1.0).is_nan() && sqrt(f64::NAN).is_nan());
        assert_eq!(sqrt(f64::INFINITY), f64::INFINITY);
    }

    /// The plain refit, one node at a time in bottom-up order, each node's children merged in
    /// `refs` order: the schedule of [`refit`] must reproduce it bit for bit.
    fn refit_one_node_at_a_time(plan: &HierarchyPlan, leaves: &[Sphere], nodes: &mut [Sphere]) {
        for &n in plan.bottom_up_order() {
            let mut acc: Option<Ball> = None;
            for c in plan.refs_of(n) {
                let s = match c {
                    ChildRef::Node(i) => nodes[i as usize],
                    ChildRef::Leaf(i) => leaves[i as usize],
                };
                let b = Ball::from_sphere(&s);
                acc = Some(acc.map_or(b, |a| a.merge(b)));
            }
            nodes[n as usize] = acc.unwrap().to_sphere_outward();
        }
    }

    /// A random tree: groups of 1..=6 pool items (nodes or leaves, so heights and child counts
    /// mix) under new nodes, node indices in creation order reversed.
    fn random_hierarchy(seed: &mut u64, leaf_count: u32) -> Hierarchy {
        let mut next = |n: usize| {
            *seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            ((*seed >> 33) % n as u64) as usize
        };
        let mut pool: Vec<(bool, u32)> = (0..leaf_count).map(|l| (true, l)).collect();
        let mut nodes: Vec<crate::NodeLists> = Vec::new();
        while pool.len() != 1 || pool[0].0 {
            let take = (1 + next(6)).min(pool.len());
            let mut node = crate::NodeLists::default();
            for _ in 0..take {
                let (is_leaf, i) = pool.swap_remove(next(pool.len()));
                if is_leaf {
                    node.leaf_children.push(i);
                } else {
                    node.children.push(i);
                }
            }
            nodes.push(node);
            pool.push((false, nodes.len() as u32 - 1));
        }
        let m = nodes.len() as u32;
        for n in &mut nodes {
            n.children.iter_mut().for_each(|c| *c = m - 1 - *c);
        }
        nodes.reverse();
        Hierarchy::from_lists(0, nodes)
    }

    #[test]
    fn grouped_schedule_matches_one_node_at_a_time_bit_for_bit() {
        let mut seed = 3u64;
        for trial in 0..200u32 {
            let leaf_count = 1 + (trial * 37) % 300;
            let h = random_hierarchy(&mut seed, leaf_count);
            let plan = HierarchyPlan::new(&h).unwrap();
            // Every node appears once in the schedule, after the groups of its child nodes.
            let mut done = vec![false; plan.node_count()];
            for &(offset, steps) in &plan.groups {
                let rows = &plan.lanes[offset as usize..=(offset + steps) as usize];
                for r in rows[1..].iter().flatten().filter(|&&r| r & LEAF_BIT == 0 && r != PAD) {
                    assert!(done[*r as usize], "trial {trial}: child {r} scheduled after its parent");
                }
                for &n in rows[0].iter().filter(|&&n| n != PAD) {
                    assert!(!done[n as usize]);
                    done[n as usize] = true;
                }
            }
            assert!(done.iter().all(|&d| d));
            let leaves: Vec<Sphere> = (0..leaf_count)
                .map(|l| {
                    let f = |k: u32| ((l * 7919 + k * 104_729) % 1000) as f32 / 500.0 - 1.0;
                    Sphere { center: [f(1), f(2), f(3)], radius: 0.01 + 0.2 * (f(4) + 1.0) }
                })
                .collect();
            let mut want = rest_node_spheres(&h);
            refit_one_node_at_a_time(&plan, &leaves, &mut want);
            let mut got = rest_node_spheres(&h);
            refit(&plan, &leaves, &mut got).unwrap();
            let bits = |v: &[Sphere]| -> Vec<[u32; 4]> {
                v.iter().map(|s| [s.center[0], s.center[1], s.center[2], s.radius].map(f32::to_bits)).collect()
            };
            assert_eq!(bits(&got), bits(&want), "trial {trial}");
        }
    }

    fn check(a: Ball, b: Ball, c: [f64; 3], r: f64) {
        let m = a.merge(b);
        assert!((m.r - r).abs() < 1e-8, "{m:?}");
        assert!((0..3).all(|k| (m.c[k] - c[k]).abs() < 1e-8), "{m:?}");
    }

    #[test]
    fn pair_bound_checks_from_math_reference() {
        check(Ball { c: [0.0; 3], r: 1.0 }, Ball { c: [3.0, 0.0, 0.0], r: 0.5 }, [1.25, 0.0, 0.0], 2.25);
        check(Ball { c: [0.0; 3], r: 2.0 }, Ball { c: [0.5, 0.5, 0.0], r: 0.5 }, [0.0; 3], 2.0);
        check(
            Ball { c: [1.0, 2.0, 3.0], r: 0.5 },
            Ball { c: [2.0, 0.0, 3.5], r: 1.2 },
            [1.652752523, 0.6944949537, 3.326376262],
            1.995643924,
        );
    }
}
