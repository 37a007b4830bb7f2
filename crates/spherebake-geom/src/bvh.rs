//! Triangle BVH with watertight ray casts and box / ball overlap queries.
//!
//! The tree *topology* comes from obvhs 0.4 (PLOC builder, `fast_build` preset, built without
//! obvhs' `parallel` feature so the tree is the same on every run); above 32 768 triangles
//! they are first cut at the median into pieces built in parallel and joined (`SPLIT_ABOVE`),
//! the cut independent of the thread count. It is then copied into a flat node array of our
//! own with bounding boxes recomputed in f64 from the triangles' f32 corners and padded by a
//! tiny relative margin, so box tests are conservative.
//!
//! Ray/triangle intersection is the watertight test of Woop, Benthin and Wald (JCGT 2013),
//! evaluated in f64: a ray through a shared edge or vertex hits every triangle that touches it
//! (it never slips between two triangles). Results never depend on the tree's shape: `ray_hits`
//! sorts by (t, triangle), `closest_hit` breaks ties by the lowest triangle index, the box and
//! ball queries return ascending triangle indices.
//!
//! Input tolerance: triangles with an out-of-range vertex index or a non-finite coordinate are
//! left out of the tree (never hit, never returned); degenerate (zero-area) triangles are kept in
//! the tree but a ray never hits them (zero determinant). Nothing here panics on input data.
//!
//! Cost: build O(T log T) (69k triangles: ~30 ms CPU; 1.1 M: 1.1 s serial; the 1.1 M bunny's
//! whole orientation stage, this build included, 0.74–0.78 s wall in 64 pieces on two cores);
//! a ray, ball or box query visits O(log T) nodes plus the answer size. Memory ≈ 120 bytes
//! per triangle (f64 corners, ~0.8 nodes per triangle with up to 4 triangles per leaf).

use glam::{DVec3, Vec3};
use obvhs::{aabb::Aabb, bvh2::builder::build_bvh2, BvhBuildParams};
use spherebake_format::quant::next_up_f32;

/// One ray/triangle intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter: the hit point is `origin + t * dir` (units of `dir`'s length).
    pub t: f32,
    /// Index of the triangle in the input triangle list.
    pub triangle: u32,
    /// Barycentric coordinates: `p = (1 - u - v) a + u b + v c` for triangle `[a, b, c]`.
    pub u: f32,
    pub v: f32,
}

/// A hit in f64 with the sign of the crossing, used internally (voxelization).
#[derive(Clone, Copy, Debug)]
pub(crate) struct HitF64 {
    pub t: f64,
    pub triangle: u32,
    /// Weights of the three corners (sum 1).
    pub bary: [f64; 3],
    /// `sign(det)`: +1 when the ray leaves through the triangle's front side (dir · n > 0 for the
    /// counter-clockwise normal n = (b - a) × (c - a)), −1 when it enters.
    pub exiting: bool,
}

#[derive(Clone, Copy, Debug)]
pub(crate) struct Node {
    pub min: DVec3,
    pub max: DVec3,
    /// Inner node: index of the left child (right child = `left + 1`). Leaf: first entry in `prims`.
    pub first: u32,
    /// 0 for inner nodes, number of triangles for leaves.
    pub count: u32,
}

impl Node {
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// Bounding volume hierarchy over a triangle list (see the module docs).
#[derive(Clone, Debug, Default)]
pub struct TriangleBvh {
    /// Corners of every input triangle in f64 (zero for invalid triangles), indexed by triangle.
    pub(crate) tris: Vec<[DVec3; 3]>,
    /// Flat node array; node 0 is the root. Empty when no triangle is valid.
    pub(crate) nodes: Vec<Node>,
    /// Triangle indices referenced by leaves.
    pub(crate) prims: Vec<u32>,
}

/// The corners of `tri` when it is valid: every index in range, every corner finite.
fn valid_corners(positions: &[Vec3], tri: &[u32; 3]) -> Option<[Vec3; 3]> {
    match tri.map(|i| positions.get(i as usize).copied()) {
        [Some(a), Some(b), Some(c)] if a.is_finite() && b.is_finite() && c.is_finite() => Some([a, b, c]),
        _ => None,
    }
}

/// Above this many valid triangles [`TriangleBvh::new`] cuts them in two at the median centre
/// of their boxes along the longest axis of those centres' box and builds the halves in parallel
/// (rayon), each the same way, joined under a new root ([`join`]); obvhs' own parallel build is
/// not deterministic. The cut depends on the triangles only, never on the thread count, so
/// the tree is the same on every run; no query answer depends on its shape (module docs).
///
/// It also bounds obvhs' worst case. Each PLOC pass merges the nodes that are each other's
/// cheapest neighbour in Morton order, ties going to the right-hand one, so equal boxes equally
/// spaced along a line tie every choice and a pass merges about one pair: the build grows
/// with the square of the items. A row of 25 000 separate unit cubes (300 000 triangles) took
/// 20 s to build whole at the old bound of 2¹⁹; in pieces of at most 2¹⁵, 1.5 s (10 000 cubes:
/// 3.3 → 0.9 s). Every other input compared bakes to the same bytes (the bunny, in four
/// pieces; the armadillo; the 1.1 M bunny, in 64), at the same CPU time.
const SPLIT_ABOVE: usize = 1 << 15;

/// The topology (nodes with unset boxes, triangle ids in leaf order) of a tree over `items`
/// (triangle id, box): obvhs' build up to `split_above` items, else two halves by median
/// (ties by id) built in parallel and joined.
fn topology(items: &mut [(u32, Aabb)], split_above: usize) -> (Vec<Node>, Vec<u32>) {
    if items.len() > split_above.max(2) {
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        let centre = |b: &Aabb| (Vec3::from(b.min).as_dvec3() + Vec3::from(b.max).as_dvec3()) * 0.5;
        for (_, b) in items.iter() {
            let c = centre(b);
            (lo, hi) = (lo.min(c), hi.max(c));
        }
        let e = hi - lo;
        let axis = if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        };
        let mid = items.len() / 2;
        items.select_nth_unstable_by(mid, |a, b| centre(&a.1)[axis].total_cmp(&centre(&b.1)[axis]).then(a.0.cmp(&b.0)));
        let (l, r) = items.split_at_mut(mid);
        let (a, b) = rayon::join(|| topology(l, split_above), || topology(r, split_above));
        return join(a, b);
    }
    let mut nodes = Vec::new();
    let mut prims = Vec::with_capacity(items.len());
    if items.is_empty() {
        return (nodes, prims);
    }
    let aabbs: Vec<Aabb> = items.iter().map(|(_, b)| *b).collect();
    let mut params = BvhBuildParams::fast_build();
    params.max_prims_per_leaf = 4;
    // `build_bvh2` pairs `aabbs[i]` with primitive id `i`; map back through `items`.
    let b2 = build_bvh2(&aabbs, params, &mut std::time::Duration::default());
    if b2.nodes.is_empty() {
        return (nodes, prims);
    }
    // Copy the topology (iteratively, depth-first).
    nodes.push(Node { min: DVec3::ZERO, max: DVec3::ZERO, first: 0, count: 0 });
    let mut stack = vec![(0usize, 0usize)]; // (obvhs node, our node)
    while let Some((src, dst)) = stack.pop() {
        let n = &b2.nodes[src];
        if n.is_leaf() {
            let first = prims.len() as u32;
            for k in n.first_index..n.first_index + n.prim_count {
                prims.push(items[b2.primitive_indices[k as usize] as usize].0);
            }
            nodes[dst].first = first;
            nodes[dst].count = n.prim_count;
        } else {
            let left = nodes.len();
            nodes.push(Node { min: DVec3::ZERO, max: DVec3::ZERO, first: 0, count: 0 });
            nodes.push(Node { min: DVec3::ZERO, max: DVec3::ZERO, first: 0, count: 0 });
            nodes[dst].first = left as u32;
            stack.push((n.first_index as usize, left));
            stack.push((n.first_index as usize + 1, left + 1));
        }
    }
    (nodes, prims)
}

/// Two trees (nodes, triangle ids) as one: a new root 0 (box: the union of the two roots'),
/// `a`'s root at 1 and `b`'s at 2 (children stay adjacent and after their parent, which the
/// refits rely on), `a`'s other nodes from 3, then `b`'s; `b`'s leaves index its ids after
/// `a`'s. An empty tree gives the other unchanged.
fn join(a: (Vec<Node>, Vec<u32>), b: (Vec<Node>, Vec<u32>)) -> (Vec<Node>, Vec<u32>) {
    let ((na, mut pa), (nb, pb)) = (a, b);
    let off = pa.len() as u32;
    pa.extend(&pb);
    if na.is_empty() || nb.is_empty() {
        let (nodes, shift) = if na.is_empty() { (nb, off) } else { (na, 0) };
        let nodes =
            nodes.into_iter().map(|n| if n.is_leaf() { Node { first: n.first + shift, ..n } } else { n }).collect();
        return (nodes, pa);
    }
    let len_a = na.len() as u32;
    let at_a = |i: u32| if i == 0 { 1 } else { i + 2 };
    let at_b = |i: u32| if i == 0 { 2 } else { i + len_a + 1 };
    let moved = |n: &Node, at: &dyn Fn(u32) -> u32, prim_off: u32| {
        if n.is_leaf() {
            Node { first: n.first + prim_off, ..*n }
        } else {
            Node { first: at(n.first), ..*n }
        }
    };
    let (ra, rb) = (na[0], nb[0]);
    let mut nodes = Vec::with_capacity(na.len() + nb.len() + 1);
    nodes.push(Node { min: ra.min.min(rb.min), max: ra.max.max(rb.max), first: 1, count: 0 });
    nodes.push(moved(&ra, &at_a, 0));
    nodes.push(moved(&rb, &at_b, off));
    nodes.extend(na[1..].iter().map(|n| moved(n, &at_a, 0)));
    nodes.extend(nb[1..].iter().map(|n| moved(n, &at_b, off)));
    (nodes, pa)
}

fn pad_box(min: DVec3, max: DVec3) -> (DVec3, DVec3) {
    let scale = min.abs().max(max.abs()).max_element() + (max - min).max_element();
    let pad = DVec3::splat(scale * 1e-12 + f64::MIN_POSITIVE);
    (min - pad, max + pad)
}

impl TriangleBvh {
    /// Builds the tree. `positions` in model space; `triangles` index `positions`.
    pub fn new(positions: &[Vec3], triangles: &[[u32; 3]]) -> Self {
        Self::build(positions, triangles, SPLIT_ABOVE)
    }

    /// [`TriangleBvh::new`], the triangles cut at their median while more than `split_above`
    /// remain (see [`SPLIT_ABOVE`]).
    fn build(positions: &[Vec3], triangles: &[[u32; 3]], split_above: usize) -> Self {
        use rayon::prelude::*;
        // The f64 corners in parallel (an ordered collect); invalid triangles get zeros.
        let valid = |tri: &[u32; 3]| valid_corners(positions, tri);
        let tris: Vec<[DVec3; 3]> =
            triangles.par_iter().map(|tri| valid(tri).map_or([DVec3::ZERO; 3], |t| t.map(|p| p.as_dvec3()))).collect();
        let mut items: Vec<(u32, Aabb)> = triangles
            .iter()
            .enumerate()
            .filter_map(|(ti, tri)| {
                let [a, b, c] = valid(tri)?;
                Some((ti as u32, Aabb::new(a.min(b).min(c).into(), a.max(b).max(c).into())))
            })
            .collect();
        let (nodes, prims) = topology(&mut items, split_above);
        let mut bvh = TriangleBvh { tris, nodes, prims };
        if bvh.nodes.is_empty() {
            return bvh;
        }
        // Leaf boxes from their triangles (in parallel: each reads only its own), then the
        // inner nodes: children always have larger indices than their parent, so a reverse
        // pass refits them.
        let (tris, prims) = (&bvh.tris, &bvh.prims);
        bvh.nodes.par_iter_mut().filter(|n| n.is_leaf()).for_each(|n| {
            let mut min = DVec3::INFINITY;
            let mut max = DVec3::NEG_INFINITY;
            for &t in &prims[n.first as usize..(n.first + n.count) as usize] {
                for p in tris[t as usize] {
                    min = min.min(p);
                    max = max.max(p);
                }
            }
            (n.min, n.max) = pad_box(min, max);
        });
        for i in (0..bvh.nodes.len()).rev() {
            let n = bvh.nodes[i];
            if !n.is_leaf() {
                let l = bvh.nodes[n.first as usize];
                let r = bvh.nodes[n.first as usize + 1];
                (bvh.nodes[i].min, bvh.nodes[i].max) = (l.min.min(r.min), l.max.max(r.max));
            }
        }
        bvh
    }

    /// A tree over `triangles` that reuses `base`'s where it can, instead of building one (the
    /// build is serial: 0.6 s for the 1.1 M-triangle bunny). It can when the first
    /// `base.triangle_count()` triangles are `base`'s in the same order, each with the same
    /// three corners in any order (a rewound triangle has the same box): their tree is
    /// `base`'s, and the triangles after them (a hole filling's fans, say) get a tree of their
    /// own beside it under a new root. Otherwise (other corners, an invalid or all-zero
    /// triangle among the first) it is [`TriangleBvh::new`]. Either way every query answers as
    /// a new build's would, since no answer depends on the tree's shape (module docs); only
    /// sums over the tree (the winding number's far-field expansions) round in another order.
    /// Cost O(T) and a build over the added triangles only.
    pub fn reuse(base: &TriangleBvh, positions: &[Vec3], triangles: &[[u32; 3]]) -> Self {
        use rayon::prelude::*;
        let n0 = base.tris.len();
        if triangles.len() < n0 {
            return Self::new(positions, triangles);
        }
        let same =
            |old: &[DVec3; 3], tri: &[u32; 3]| match valid_corners(positions, tri).map(|t| t.map(|p| p.as_dvec3())) {
                Some(t) if t != [DVec3::ZERO; 3] => {
                    let (a, b, c) = (t[0], t[1], t[2]);
                    [[a, b, c], [b, c, a], [c, a, b], [a, c, b], [c, b, a], [b, a, c]].contains(old).then_some(t)
                }
                _ => None,
            };
        let first: Option<Vec<[DVec3; 3]>> =
            base.tris.par_iter().zip(&triangles[..n0]).map(|(old, tri)| same(old, tri)).collect();
        let Some(mut tris) = first else {
            return Self::new(positions, triangles);
        };
        let mut rest = Self::new(positions, &triangles[n0..]);
        tris.extend_from_slice(&rest.tris);
        rest.prims.iter_mut().for_each(|t| *t += n0 as u32);
        let (nodes, prims) = join((base.nodes.clone(), base.prims.clone()), (rest.nodes, rest.prims));
        TriangleBvh { tris, nodes, prims }
    }

    /// Number of input triangles (including invalid ones that are never hit).
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// All hits with `t_min < t < t_max` (f32 `t`), sorted by `t`, ties by triangle index.
    /// A ray through a shared edge or vertex reports every triangle touching it.
    pub fn ray_hits(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32, out: &mut Vec<Hit>) {
        out.clear();
        let (o, d) = (origin.as_dvec3(), dir.as_dvec3());
        self.traverse_ray(o, d, t_min as f64, t_max as f64, |h| {
            let t = h.t as f32;
            if t > t_min && t < t_max {
                out.push(Hit { t, triangle: h.triangle, u: h.bary[1] as f32, v: h.bary[2] as f32 });
            }
            None
        });
        out.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.triangle.cmp(&b.triangle)));
    }

    /// Closest hit with `t_min < t < t_max`; equal `t` goes to the lowest triangle index.
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Option<Hit> {
        let (o, d) = (origin.as_dvec3(), dir.as_dvec3());
        let mut best: Option<Hit> = None;
        self.traverse_ray(o, d, t_min as f64, t_max as f64, |h| {
            let t = h.t as f32;
            if t > t_min && t < t_max {
                let better = match best {
                    None => true,
                    Some(b) => t < b.t || (t == b.t && h.triangle < b.triangle),
                };
                if better {
                    best = Some(Hit { t, triangle: h.triangle, u: h.bary[1] as f32, v: h.bary[2] as f32 });
                    // Prune beyond every f64 t that still rounds to this f32 t (a tie there
                    // may belong to a lower triangle index in another node).
                    return Some(next_up_f32(t) as f64);
                }
            }
            None
        });
        best
    }

    /// Triangles whose bounding box intersects the closed ball (a conservative superset of the
    /// triangles that touch the ball), ascending.
    pub fn triangles_near_sphere(&self, center: Vec3, radius: f32, out: &mut Vec<u32>) {
        out.clear();
        let c = center.as_dvec3();
        let r = radius as f64;
        if r.is_nan() || r < 0.0 || !c.is_finite() {
            return;
        }
        let r2 = r * r * (1.0 + 1e-9);
        let ball_box = |min: DVec3, max: DVec3| {
            let q = c.clamp(min, max);
            (q - c).length_squared() <= r2
        };
        self.traverse_boxes(&ball_box, |t, tri| {
            let min = tri[0].min(tri[1]).min(tri[2]);
            let max = tri[0].max(tri[1]).max(tri[2]);
            if ball_box(min, max) {
                out.push(t);
            }
        });
        out.sort_unstable();
    }

    /// Triangles whose bounding box overlaps the closed box `[min, max]`, ascending.
    pub fn triangles_in_aabb(&self, min: Vec3, max: Vec3, out: &mut Vec<u32>) {
        out.clear();
        let (qmin, qmax) = (min.as_dvec3(), max.as_dvec3());
        let overlap = |a: DVec3, b: DVec3| a.cmple(qmax).all() && b.cmpge(qmin).all();
        self.traverse_boxes(&overlap, |t, tri| {
            let a = tri[0].min(tri[1]).min(tri[2]);
            let b = tri[0].max(tri[1]).max(tri[2]);
            if overlap(a, b) {
                out.push(t);
            }
        });
        out.sort_unstable();
    }

    /// Visits the triangles of every leaf whose (padded) box passes `node_test`, in tree order.
    pub(crate) fn traverse_boxes(
        &self,
        node_test: &dyn Fn(DVec3, DVec3) -> bool,
        mut visit: impl FnMut(u32, &[DVec3; 3]),
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = Vec::with_capacity(64);
        stack.push(0u32);
        while let Some(i) = stack.pop() {
            let n = self.nodes[i as usize];
            if !node_test(n.min, n.max) {
                continue;
            }
            if n.is_leaf() {
                for &t in &self.prims[n.first as usize..(n.first + n.count) as usize] {
                    visit(t, &self.tris[t as usize]);
                }
            } else {
                stack.push(n.first + 1);
                stack.push(n.first);
            }
        }
    }

    /// Ray traversal in f64. `visit` gets every hit with t in a slightly widened `[t_min, t_max]`
    /// (callers filter exactly); it may return a new, smaller `t_max` for pruning.
    pub(crate) fn traverse_ray(
        &self,
        origin: DVec3,
        dir: DVec3,
        t_min: f64,
        t_max: f64,
        mut visit: impl FnMut(&HitF64) -> Option<f64>,
    ) {
        if self.nodes.is_empty() || !origin.is_finite() || !dir.is_finite() || dir == DVec3::ZERO {
            return;
        }
        if t_min.is_nan() || t_max.is_nan() || t_min > t_max {
            return;
        }
        let pre = RayPre::new(origin, dir);
        let inv = dir.recip();
        let mut t_hi = t_max;
        let mut stack = Vec::with_capacity(64);
        stack.push(0u32);
        while let Some(i) = stack.pop() {
            let n = self.nodes[i as usize];
            if !ray_box(origin, dir, inv, n.min, n.max, t_min, t_hi) {
                continue;
            }
            if n.is_leaf() {
                for &t in &self.prims[n.first as usize..(n.first + n.count) as usize] {
                    if let Some(h) = pre.intersect(&self.tris[t as usize], t) {
                        if let Some(new_hi) = visit(&h) {
                            t_hi = t_hi.min(new_hi);
                        }
                    }
                }
            } else {
                stack.push(n.first + 1);
                stack.push(n.first);
            }
        }
    }
}

/// Conservative slab test of the ray segment `[t_min, t_max]` against a closed box.
#[inline]
fn ray_box(o: DVec3, d: DVec3, inv: DVec3, min: DVec3, max: DVec3, t_min: f64, t_max: f64) -> bool {
    let mut lo = t_min;
    let mut hi = t_max;
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < min[a] || o[a] > max[a] {
                return false;
            }
        } else {
            let t0 = (min[a] - o[a]) * inv[a];
            let t1 = (max[a] - o[a]) * inv[a];
            let (n, f) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
            // Widen by a relative 1e-12 against rounding (Ize 2013 style).
            let widen = 1e-12 * (n.abs().max(f.abs()));
            lo = lo.max(n - widen);
            hi = hi.min(f + widen);
        }
    }
    // Allow a tiny slack at the ends: t is checked exactly by the callers.
    lo <= hi + 1e-12 * hi.abs().max(lo.abs())
}

/// Per-ray precomputation of the watertight test (Woop, Benthin, Wald 2013).
pub(crate) struct RayPre {
    origin: DVec3,
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f64,
    sy: f64,
    sz: f64,
}

impl RayPre {
    pub(crate) fn new(origin: DVec3, dir: DVec3) -> Self {
        let ad = dir.abs();
        let kz = if ad.x >= ad.y && ad.x >= ad.z {
            0
        } else if ad.y >= ad.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        RayPre { origin, kx, ky, kz, sx: dir[kx] / dir[kz], sy: dir[ky] / dir[kz], sz: 1.0 / dir[kz] }
    }

    /// Watertight intersection; `None` for misses and for rays parallel to the triangle's plane.
    #[inline]
    pub(crate) fn intersect(&self, tri: &[DVec3; 3], index: u32) -> Option<HitF64> {
        let a = tri[0] - self.origin;
        let b = tri[1] - self.origin;
        let c = tri[2] - self.origin;
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let ax = a[kx] - self.sx * a[kz];
        let ay = a[ky] - self.sy * a[kz];
        let bx = b[kx] - self.sx * b[kz];
        let by = b[ky] - self.sy * b[kz];
        let cx = c[kx] - self.sx * c[kz];
        let cy = c[ky] - self.sy * c[kz];
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let az = self.sz * a[kz];
        let bz = self.sz * b[kz];
        let cz = self.sz * c[kz];
        let t = (u * az + v * bz + w * cz) / det;
        if !t.is_finite() {
            return None;
        }
        // det > 0 means the triangle winds clockwise seen along the ray in the sheared frame,
        // i.e. its counter-clockwise normal points along the ray: the ray exits.
        let inv = 1.0 / det;
        Some(HitF64 { t, triangle: index, bary: [u * inv, v * inv, w * inv], exiting: det < 0.0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(dir: DVec3, expect_exiting: bool) {
        // Triangle in the z = 1 plane, counter-clockwise seen from +z: normal +z.
        let tri = [DVec3::new(-1.0, -1.0, 1.0), DVec3::new(2.0, -1.0, 1.0), DVec3::new(-1.0, 2.0, 1.0)];
        let origin = DVec3::new(0.0, 0.0, 1.0) - dir;
        let h = RayPre::new(origin, dir).intersect(&tri, 0).expect("hit");
        assert!((h.t - 1.0).abs() < 1e-12);
        assert_eq!(h.exiting, expect_exiting);
        let p = tri[0] * h.bary[0] + tri[1] * h.bary[1] + tri[2] * h.bary[2];
        assert!((p - DVec3::new(0.0, 0.0, 1.0)).length() < 1e-12);
    }

    /// Every query of `a` and `b` answers alike on random rays, balls and boxes.
    fn same_answers(a: &TriangleBvh, b: &TriangleBvh, seed: u64, min_hits: usize) {
        let mut rng = crate::rng::SplitMix64::new(seed);
        let mut r = || (rng.next_f64() * 2.4 - 1.2) as f32;
        let (mut ha, mut hb, mut ta, mut tb) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut hits = 0;
        for _ in 0..300 {
            let (o, d) = (Vec3::new(r(), r(), r()), Vec3::new(r(), r(), r()));
            a.ray_hits(o, d, -10.0, 10.0, &mut ha);
            b.ray_hits(o, d, -10.0, 10.0, &mut hb);
            assert_eq!(ha, hb);
            hits += ha.len();
            assert_eq!(a.closest_hit(o, d, 0.0, 10.0), b.closest_hit(o, d, 0.0, 10.0));
            let rad = r().abs() * 0.5;
            a.triangles_near_sphere(o, rad, &mut ta);
            b.triangles_near_sphere(o, rad, &mut tb);
            assert_eq!(ta, tb);
            a.triangles_in_aabb(o.min(d), o.max(d), &mut ta);
            b.triangles_in_aabb(o.min(d), o.max(d), &mut tb);
            assert_eq!(ta, tb);
        }
        assert!(hits >= min_hits, "the rays should hit something ({hits})");
    }

    #[test]
    fn a_reused_tree_answers_as_a_new_build() {
        let mut rng = crate::rng::SplitMix64::new(3);
        let positions: Vec<Vec3> =
            (0..120).map(|_| Vec3::new(rng.next_f64() as f32, rng.next_f64() as f32, rng.next_f64() as f32)).collect();
        let mut tri = |n: u64| [0; 3].map(|_| rng.below(n) as u32);
        let base_tris: Vec<[u32; 3]> = (0..400).map(|_| tri(120)).collect();
        // Rewound in every way, then 60 more triangles (two of them invalid: out of range).
        let mut tris: Vec<[u32; 3]> = base_tris
            .iter()
            .enumerate()
            .map(|(i, &[a, b, c])| [[a, b, c], [b, c, a], [c, a, b], [a, c, b], [c, b, a], [b, a, c]][i % 6])
            .collect();
        tris.extend((0..60).map(|_| tri(120)));
        tris[410][1] = 999;
        tris[450][0] = 120;
        let base = TriangleBvh::new(&positions, &base_tris);
        let fresh = TriangleBvh::new(&positions, &tris);
        let reused = TriangleBvh::reuse(&base, &positions, &tris);
        // The reuse happened: base's tree and the added triangles' own under one new root.
        let rest = TriangleBvh::new(&positions, &tris[400..]);
        assert_eq!(reused.nodes.len(), base.nodes.len() + rest.nodes.len() + 1);
        assert_eq!(reused.triangle_count(), tris.len());
        same_answers(&reused, &fresh, 11, 300);
        // Nothing added; the base alone (every triangle rewound).
        let reused = TriangleBvh::reuse(&base, &positions, &tris[..400]);
        assert_eq!(reused.nodes.len(), base.nodes.len());
        same_answers(&reused, &TriangleBvh::new(&positions, &tris[..400]), 12, 300);
        // A base over other corners, or over fewer triangles than it has, is not reused.
        let moved: Vec<Vec3> = positions.iter().map(|p| *p + Vec3::splat(1e-3)).collect();
        let other = TriangleBvh::new(&moved, &base_tris);
        let rebuilt = TriangleBvh::reuse(&other, &positions, &tris);
        assert_eq!(rebuilt.nodes.len(), fresh.nodes.len());
        same_answers(&rebuilt, &fresh, 13, 300);
        same_answers(
            &TriangleBvh::reuse(&base, &positions, &tris[..10]),
            &TriangleBvh::new(&positions, &tris[..10]),
            14,
            10,
        );
        // An empty base: the new triangles' own tree.
        let empty = TriangleBvh::new(&positions, &[]);
        same_answers(&TriangleBvh::reuse(&empty, &positions, &tris), &fresh, 15, 300);
    }

    /// The triangle ids in the leaves under node `root`.
    fn leaves_under(tree: &TriangleBvh, root: usize) -> Vec<u32> {
        let (mut stack, mut out) = (vec![root], Vec::new());
        while let Some(i) = stack.pop() {
            let n = tree.nodes[i];
            if n.is_leaf() {
                out.extend(&tree.prims[n.first as usize..(n.first + n.count) as usize]);
            } else {
                stack.extend([n.first as usize, n.first as usize + 1]);
            }
        }
        out
    }

    #[test]
    fn a_tree_built_in_pieces_answers_as_one_build() {
        // 2000 random triangles (three invalid), cut while more than 150 remain: 16 pieces.
        let mut rng = crate::rng::SplitMix64::new(5);
        let positions: Vec<Vec3> =
            (0..300).map(|_| Vec3::new(rng.next_f64() as f32, rng.next_f64() as f32, rng.next_f64() as f32)).collect();
        let mut tris: Vec<[u32; 3]> = (0..2000).map(|_| [0; 3].map(|_| rng.below(300) as u32)).collect();
        tris[7][2] = 300;
        tris[900][0] = u32::MAX;
        tris[1999][1] = 301;
        let whole = TriangleBvh::build(&positions, &tris, usize::MAX);
        let pieces = TriangleBvh::build(&positions, &tris, 150);
        // Every valid triangle in exactly one leaf; every child after its parent, siblings
        // adjacent; every leaf within its parents' boxes.
        let mut seen = vec![0u32; tris.len()];
        for &t in &pieces.prims {
            seen[t as usize] += 1;
        }
        for (t, &n) in seen.iter().enumerate() {
            assert_eq!(n, u32::from(![7, 900, 1999].contains(&t)), "triangle {t}");
        }
        let leaves = pieces.nodes.iter().filter(|n| n.is_leaf()).count();
        assert_eq!(pieces.nodes.len(), 2 * leaves - 1);
        for (i, n) in pieces.nodes.iter().enumerate() {
            if !n.is_leaf() {
                assert!(n.first as usize > i && (n.first as usize + 1) < pieces.nodes.len());
                for c in [pieces.nodes[n.first as usize], pieces.nodes[n.first as usize + 1]] {
                    assert!(n.min.cmple(c.min).all() && c.max.cmple(n.max).all());
                }
            }
        }
        // The root cut at the median: its two subtrees hold 998 and 999 triangles, split by
        // the centres of the triangles' boxes along one axis.
        let (l, r) = (leaves_under(&pieces, 1), leaves_under(&pieces, 2));
        assert_eq!((l.len(), r.len()), (998, 999));
        let centroid = |t: &u32| {
            let [a, b, c] = pieces.tris[*t as usize];
            (a.min(b).min(c) + a.max(b).max(c)) * 0.5
        };
        assert!((0..3).any(|a| {
            let lmax = l.iter().map(|t| centroid(t)[a]).fold(f64::NEG_INFINITY, f64::max);
            r.iter().all(|t| centroid(t)[a] >= lmax)
        }));
        same_answers(&pieces, &whole, 21, 300);
        same_answers(&pieces, &TriangleBvh::build(&positions, &tris, 150), 22, 300);
        // Too few triangles to cut, and none.
        same_answers(&TriangleBvh::build(&positions, &tris[..3], 1), &TriangleBvh::new(&positions, &tris[..3]), 23, 0);
        assert!(TriangleBvh::build(&positions, &[], 1).nodes.is_empty());
    }

    #[test]
    fn a_long_row_of_equal_boxes_is_cut_before_obvhs_builds_it() {
        // 3 000 unit cubes two apart along x (36 000 triangles): obvhs' PLOC ties every merge
        // of equal, equally spaced boxes and merges about one pair per pass, so whole it
        // builds in O(n²) (25 000 cubes: 20 s). Above SPLIT_ABOVE the median cut comes first:
        // two halves of 18 000, left of each other along x, each within the bound.
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let (mut positions, mut tris) = (Vec::new(), Vec::new());
        for c in 0..3000u32 {
            let base = positions.len() as u32;
            positions.extend((0..8).map(|i| Vec3::new((2 * c + (i & 1)) as f32, (i >> 1 & 1) as f32, (i >> 2) as f32)));
            tris.extend(
                quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).map(|t| t.map(|v| v + base)),
            );
        }
        let tree = TriangleBvh::new(&positions, &tris);
        let (l, r) = (leaves_under(&tree, 1), leaves_under(&tree, 2));
        assert_eq!((l.len(), r.len()), (18_000, 18_000));
        let x = |t: &u32| tree.tris[*t as usize].iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max);
        let lmax = l.iter().map(x).fold(f64::NEG_INFINITY, f64::max);
        assert!(r.iter().all(|t| tree.tris[*t as usize].iter().all(|p| p.x > lmax)));
        // Every answer as a brute-force pass over the triangles gives it: rays and balls about
        // the row.
        let mut rng = crate::rng::SplitMix64::new(8);
        let mut hits = Vec::new();
        let mut found = 0;
        for _ in 0..200 {
            let o = Vec3::new(
                rng.next_f64() as f32 * 6000.0,
                rng.next_f64() as f32 * 3.0 - 1.0,
                rng.next_f64() as f32 * 3.0 - 1.0,
            );
            let d = Vec3::new(rng.next_f64() as f32 - 0.5, rng.next_f64() as f32 - 0.5, rng.next_f64() as f32 - 0.5);
            tree.ray_hits(o, d, 0.0, 20.0, &mut hits);
            let pre = RayPre::new(o.as_dvec3(), d.as_dvec3());
            // `ray_hits`' own reading: t in f32, strictly inside (0, 20).
            let mut brute: Vec<(f32, u32)> = (0..tree.tris.len() as u32)
                .filter_map(|t| pre.intersect(&tree.tris[t as usize], t))
                .map(|h| (h.t as f32, h.triangle))
                .filter(|h| h.0 > 0.0 && h.0 < 20.0)
                .collect();
            brute.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            assert_eq!(
                hits.iter().map(|h| h.triangle).collect::<Vec<_>>(),
                brute.iter().map(|h| h.1).collect::<Vec<_>>()
            );
            found += hits.len();
        }
        assert!(found > 50, "{found} hits");
    }

    #[test]
    fn exiting_sign_follows_normal() {
        check(DVec3::new(0.0, 0.0, 1.0), true);
        check(DVec3::new(0.1, 0.2, 1.0), true);
        check(DVec3::new(0.0, 0.0, -1.0), false);
        check(DVec3::new(0.3, -0.2, -1.0), false);
        check(DVec3::new(0.9, 0.0, 0.3), true);
    }
}
