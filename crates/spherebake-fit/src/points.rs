//! The point set the clustering works on: surface samples (triangle vertices, centroids, and a
//! barycentric grid on triangles larger than the sample spacing), thinned to one per cell of
//! half the lattice spacing, plus interior lattice points (grid corners inside the solid),
//! with neighbour lists for the flood fill.

use crate::solid::Solid;
use glam::DVec3;
use rayon::prelude::*;

/// Surface sample thinning cell, in lattice spacings.
const SURFACE_SPACING: f64 = 1.0;

/// Interior lattice spacing, in lattice spacings.
pub const INTERIOR_SPACING: f64 = 1.0;

/// A point, or a flat patch of surface samples bounded conservatively: every represented
/// sample q = p + u + w n with |u| ≤ `s` (u ⊥ n) and |w| ≤ `t`. `n` is a unit normal or zero
/// (then `s` bounds |q − p| and `t` = 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rep {
    pub p: DVec3,
    pub n: DVec3,
    pub s: f64,
    pub t: f64,
}

impl Rep {
    pub fn point(p: DVec3) -> Self {
        Self { p, n: DVec3::ZERO, s: 0.0, t: 0.0 }
    }

    /// Upper bound (exact for the disc/slab) of the distance from `c` to any represented
    /// sample; 1-Lipschitz in `c`.
    #[inline]
    pub fn far(&self, c: DVec3) -> f64 {
        let a = self.p - c;
        if self.s == 0.0 && self.t == 0.0 {
            return a.length();
        }
        let an = a.dot(self.n);
        let perp = (a.length_squared() - an * an).max(0.0).sqrt();
        ((an.abs() + self.t).powi(2) + (perp + self.s).powi(2)).sqrt()
    }
}

pub struct PointSet {
    /// Representative positions (patch centres, interior lattice points).
    pub points: Vec<DVec3>,
    /// Conservative representatives, parallel to `points`.
    pub reps: Vec<Rep>,
    /// `points[..surface_count]` are surface samples, the rest interior lattice points.
    pub surface_count: usize,
    /// CSR neighbour lists (offsets, neighbours), built on first use: only the flood fill
    /// reads them, and it runs only when the cover start is empty, while building them cost
    /// a third of the point stage (≈ 490 000 entries on a 12-triangle cube).
    adjacency: std::sync::OnceLock<(Vec<u32>, Vec<u32>)>,
    /// Lower corner of the neighbour bins (centred on the lattice points).
    bin_origin: DVec3,
    /// Lattice spacing, model units.
    pub h: f64,
}

impl PointSet {
    /// Points in the same or a face-adjacent bin (bins of the interior spacing, centred on
    /// the lattice points), `i` itself excluded.
    pub fn neighbours(&self, i: usize) -> &[u32] {
        let (offsets, adj) =
            self.adjacency.get_or_init(|| adjacency(&self.points, self.bin_origin, self.h * INTERIOR_SPACING));
        &adj[offsets[i] as usize..offsets[i + 1] as usize]
    }
}

/// CSR lists of [`PointSet::neighbours`].
fn adjacency(points: &[DVec3], bin_origin: DVec3, hb: f64) -> (Vec<u32>, Vec<u32>) {
    let mut binned: Vec<((i64, i64, i64), u32)> =
        points.iter().enumerate().map(|(i, p)| (key(*p, bin_origin, hb), i as u32)).collect();
    binned.sort_unstable();
    let find = |k: (i64, i64, i64)| -> &[((i64, i64, i64), u32)] {
        let s = binned.partition_point(|x| x.0 < k);
        let e = binned.partition_point(|x| x.0 <= k);
        &binned[s..e]
    };
    let mut adj_offsets = Vec::with_capacity(points.len() + 1);
    let mut adj = Vec::new();
    adj_offsets.push(0u32);
    for (i, p) in points.iter().enumerate() {
        let k = key(*p, bin_origin, hb);
        for d in [(0, 0, 0), (1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)] {
            for x in find((k.0 + d.0, k.1 + d.1, k.2 + d.2)) {
                if x.1 as usize != i {
                    adj.push(x.1);
                }
            }
        }
        adj_offsets.push(adj.len() as u32);
    }
    (adj_offsets, adj)
}

fn key(p: DVec3, o: DVec3, h: f64) -> (i64, i64, i64) {
    let u = (p - o) / h;
    (u.x.floor() as i64, u.y.floor() as i64, u.z.floor() as i64)
}

/// Interior lattice points: corners `origin + (i, j, k) h` whose solid cell is solid.
pub fn lattice_points(solid: &Solid, lo: DVec3, hi: DVec3, h: f64) -> Vec<DVec3> {
    let n = ((hi - lo) / h).ceil();
    let mut out = Vec::new();
    for k in 0..=(n.z as i64) {
        for j in 0..=(n.y as i64) {
            for i in 0..=(n.x as i64) {
                let p = lo + DVec3::new(i as f64, j as f64, k as f64) * h;
                if solid.is_solid_at(p) {
                    out.push(p);
                }
            }
        }
    }
    out
}

/// Which of `points` to keep so that no cube of edge `cell` (cells aligned on `origin`) holds
/// more than `cap` of them: the first `cap` of each cell in input order. This holds a point set
/// to what the voxel grid resolves (cost follows the grid, not the triangle count: the bunny
/// subdivided to 1.1 M triangles has about ten vertices per voxel cell). Deterministic; cost
/// O(n log n). `cap` = 0 keeps everything.
pub fn keep_per_cell(points: &[DVec3], origin: DVec3, cell: f64, cap: usize) -> Vec<bool> {
    let n = points.len();
    if cap == 0 || cell.is_nan() || cell <= 0.0 {
        return vec![true; n];
    }
    let keys: Vec<(i64, i64, i64)> = points.par_iter().map(|p| key(*p, origin, cell)).collect();
    // Cells packed into one u64 (21 bits per axis, offset from the lowest) when they fit, so
    // the sort moves 16-byte pairs; a parallel sort of unique (cell, index) pairs is
    // deterministic.
    let lo = keys.iter().fold((i64::MAX, i64::MAX, i64::MAX), |a, k| (a.0.min(k.0), a.1.min(k.1), a.2.min(k.2)));
    let fits = keys.iter().all(|k| {
        [k.0.wrapping_sub(lo.0), k.1.wrapping_sub(lo.1), k.2.wrapping_sub(lo.2)]
            .iter()
            .all(|&d| (0..1 << 21).contains(&d))
    });
    let mut keep = vec![false; n];
    if fits {
        let mut packed: Vec<(u64, u32)> = keys
            .par_iter()
            .enumerate()
            .map(|(i, k)| {
                let d = [k.0 - lo.0, k.1 - lo.1, k.2 - lo.2].map(|v| v as u64);
                ((d[2] << 42) | (d[1] << 21) | d[0], i as u32)
            })
            .collect();
        packed.par_sort_unstable();
        for group in packed.chunk_by(|a, b| a.0 == b.0) {
            for x in &group[..group.len().min(cap)] {
                keep[x.1 as usize] = true;
            }
        }
        return keep;
    }
    let mut keyed: Vec<((i64, i64, i64), u32)> = keys.into_iter().enumerate().map(|(i, k)| (k, i as u32)).collect();
    keyed.sort_unstable();
    let mut s0 = 0;
    while s0 < keyed.len() {
        let mut e = s0;
        while e < keyed.len() && keyed[e].0 == keyed[s0].0 {
            e += 1;
        }
        // Sorted by (cell, index): the group's first `cap` are its first in input order.
        for x in &keyed[s0..e.min(s0 + cap)] {
            keep[x.1 as usize] = true;
        }
        s0 = e;
    }
    keep
}

/// Points a barycentric grid of `m` divisions per edge holds.
fn grid_points(m: usize) -> usize {
    (m + 1) * (m + 2) / 2
}

/// Grid divisions per triangle so that point sets grow with the surface, not with edge length
/// (issue 17: one OBJ face of 30 000 vertices, a fan of slivers, asked for a 6 GB point set).
/// `want(l)` gives the divisions the caller would use for a triangle of longest edge `l`; a
/// triangle flatter than about 1 : 30 gets fewer, in proportion to the square root of its area
/// (a well-shaped triangle keeps `want(l)`), never below `min`; and if the whole mesh would still
/// exceed `budget` grid points, every count is scaled down by the same factor. Deterministic.
pub fn grid_plan(
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    want: impl Fn(f64) -> usize + Sync,
    min: usize,
    budget: usize,
) -> Vec<usize> {
    // Per triangle in parallel (an ordered collect of a pure function; the total is an
    // integer sum): the same plan whatever the thread count.
    let mut ms: Vec<usize> = triangles
        .par_iter()
        .map(|t| {
            let (a, b, c) = (positions[t[0] as usize], positions[t[1] as usize], positions[t[2] as usize]);
            let l = (b - a).length().max((c - b).length()).max((a - c).length());
            let m = want(l);
            let area = 0.5 * (b - a).cross(c - a).length();
            if l.is_nan() || l <= 0.0 || !area.is_finite() {
                return m.min(min.max(1));
            }
            let cap = (m as f64 * 8.0 * area.sqrt() / l).ceil() as usize;
            m.min(cap.max(min))
        })
        .collect();
    let total: usize = ms.par_iter().map(|&m| grid_points(m)).sum();
    if total > budget {
        let f = (budget as f64 / total as f64).sqrt();
        ms.par_iter_mut().for_each(|m| *m = ((*m as f64 * f).floor() as usize).max(min));
    }
    ms
}

/// Grid points per mesh for the point sets (about 100 MB at most for the largest set).
pub const GRID_BUDGET: usize = 2_000_000;

/// Builds the clustering point set. `h` = lattice spacing.
pub fn build(positions: &[DVec3], triangles: &[[u32; 3]], solid: &Solid, lo: DVec3, hi: DVec3, h: f64) -> PointSet {
    let fine = h * SURFACE_SPACING;
    let mut samples: Vec<DVec3> = Vec::with_capacity(triangles.len() * 2);
    let want = |l: f64| (l / fine).ceil().clamp(1.0, 256.0) as usize;
    let plan = grid_plan(positions, triangles, want, 1, GRID_BUDGET);
    // A sliver's grid is held below `want` (`grid_plan`), which along a long thin part leaves
    // points only every several spacings: a 100 : 1 cylinder of 128 triangles kept 11 points
    // at a fine voxel grid (no lattice point inside it), and the fit 11 of 32 spheres. So a
    // sliver also gets points along its longest edge at the spacing, within the same budget.
    let longest = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|v| positions[v as usize]);
        [(a, b), (b, c), (c, a)].into_iter().max_by(|x, y| (x.1 - x.0).length().total_cmp(&(y.1 - y.0).length()))
    };
    let longest_edges: Vec<Option<(DVec3, DVec3)>> = triangles.iter().map(longest).collect();
    let mut edge: Vec<usize> = longest_edges
        .iter()
        .zip(&plan)
        .map(|(l, &m)| l.map_or(0, |(a, b)| want((b - a).length())).saturating_sub(m).min(256))
        .map(|e| if e > 0 { e + 1 } else { 0 })
        .collect();
    let total: usize = plan.iter().map(|&m| grid_points(m)).sum::<usize>() + edge.iter().sum::<usize>();
    if total > GRID_BUDGET {
        let f = GRID_BUDGET as f64 / total as f64;
        edge.iter_mut().for_each(|e| *e = (*e as f64 * f).floor() as usize);
    }
    for (((t, &m), &e), l) in triangles.iter().zip(&plan).zip(&edge).zip(&longest_edges) {
        let a = positions[t[0] as usize];
        let b = positions[t[1] as usize];
        let c = positions[t[2] as usize];
        if m <= 1 {
            samples.push(a);
        } else {
            samples.extend(spherebake_geom::triangle::triangle_grid(a, b, c, m).map(|(_, _, p)| p));
        }
        if e > 1 {
            if let Some((p, q)) = *l {
                samples.extend((0..e).map(|i| p.lerp(q, i as f64 / (e - 1) as f64)));
            }
        }
        samples.push((a + b + c) / 3.0);
    }
    // One representative per fine cell, cells in key order: the cell's first sample in mesh
    // order. (Conservative patches — the cell's centroid with a normal and a disc bound —
    // over-inflated spheres by about a sample cell; a plain sample point per cell measured
    // better, the dense polish and the exactness pass restoring full coverage.) The keys are
    // distinct (sample index), so the parallel sort is the same whatever the thread count.
    let mut keyed: Vec<((i64, i64, i64), u32)> =
        samples.par_iter().enumerate().map(|(i, p)| (key(*p, lo, fine), i as u32)).collect();
    keyed.par_sort_unstable();
    let mut reps: Vec<Rep> = keyed.chunk_by(|a, b| a.0 == b.0).map(|g| Rep::point(samples[g[0].1 as usize])).collect();
    let mut points: Vec<DVec3> = reps.iter().map(|r| r.p).collect();
    let surface_count = points.len();
    let interior = lattice_points(solid, lo, hi, h * INTERIOR_SPACING);
    reps.extend(interior.iter().map(|p| Rep::point(*p)));
    points.extend(interior);
    // Bins centred on lattice points.
    let bin_origin = lo - DVec3::splat(0.5 * h * INTERIOR_SPACING);
    PointSet { points, reps, surface_count, adjacency: std::sync::OnceLock::new(), bin_origin, h }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keep_per_cell_keeps_the_first_cap_points_of_each_cell() {
        let mut rng = crate::rng::SplitMix64::new(11);
        let (origin, cell) = (DVec3::new(-0.3, 0.1, -2.0), 0.25);
        // Clustered points, so many cells hold several.
        let points: Vec<DVec3> =
            (0..2000).map(|_| DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64() * 0.1)).collect();
        for cap in [1usize, 2, 5] {
            let keep = keep_per_cell(&points, origin, cell, cap);
            // Brute force: a point is kept iff fewer than `cap` earlier points share its cell.
            let cell_of = |p: DVec3| ((p - origin) / cell).floor().to_array().map(|v| v as i64);
            for (i, p) in points.iter().enumerate() {
                let earlier = points[..i].iter().filter(|q| cell_of(**q) == cell_of(*p)).count();
                assert_eq!(keep[i], earlier < cap, "point {i}, cap {cap}");
            }
            assert!(keep.iter().filter(|&&k| !k).count() > 0, "cap {cap} thins something");
        }
        assert!(keep_per_cell(&points, origin, cell, 0).iter().all(|&k| k));
        // Cells too far apart to pack into 21 bits per axis take the general path.
        let far: Vec<DVec3> = points.iter().enumerate().map(|(i, p)| *p + DVec3::X * 1e9 * (i % 2) as f64).collect();
        let keep = keep_per_cell(&far, origin, cell, 1);
        let cell_of = |p: DVec3| ((p - origin) / cell).floor().to_array().map(|v| v as i64);
        for (i, p) in far.iter().enumerate() {
            assert_eq!(keep[i], !far[..i].iter().any(|q| cell_of(*q) == cell_of(*p)), "far point {i}");
        }
    }

    #[test]
    fn neighbours_are_the_points_in_the_same_or_a_face_adjacent_bin() {
        let mut rng = crate::rng::SplitMix64::new(3);
        let points: Vec<DVec3> =
            (0..300).map(|_| DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 2.0).collect();
        let n = points.len();
        let (origin, h) = (DVec3::splat(-0.05), 0.2);
        let set = PointSet {
            reps: points.iter().map(|p| Rep::point(*p)).collect(),
            points: points.clone(),
            surface_count: n,
            adjacency: std::sync::OnceLock::new(),
            bin_origin: origin,
            h,
        };
        let bin = |p: DVec3| ((p - origin) / h).floor();
        for i in 0..n {
            let mut got = set.neighbours(i).to_vec();
            got.sort_unstable();
            let want: Vec<u32> = (0..n as u32)
                .filter(|&j| {
                    let d = (bin(points[j as usize]) - bin(points[i])).abs();
                    j as usize != i && d.x + d.y + d.z <= 1.0
                })
                .collect();
            assert_eq!(got, want, "point {i}");
        }
    }
}
