//! Solid voxelization of triangle soups that need not be closed.
//!
//! A cell is **surface** when its closed box overlaps a triangle (exact separating-axis test of
//! Akenine-Möller, in f64) and **solid** when it is surface or its centre is inside, i.e.
//! `|w(centre)| ≥ winding_threshold` for the winding number w: the exact integer from ray votes
//! where they are conclusive (below), else the generalized winding number ([`crate::winding`]).
//!
//! Why |w| and not w: a mesh whose triangles are all flipped (a common export error) gives w = −1
//! inside; with |w| it voxelizes like the correctly oriented mesh. Consequences, by damage type:
//! - **holes**: w falls off smoothly near the hole (≈ 1 − Ω_hole/4π); cells deep inside stay solid,
//!   a hole only changes cells near the missing patch (threshold 0.5 ≈ "more than half enclosed");
//! - **duplicated triangles / overlapping parts**: w = 2 in doubled regions, still solid;
//! - **fully flipped mesh**: the same solid as the unflipped one (w = −1 inside);
//! - **partly flipped parts** that overlap a correctly oriented part cancel (w = 0) in the overlap:
//!   the one case |w| cannot fix (no orientation-free definition can, without repairing the mesh);
//! - **open sheets** (a single plane) enclose nothing: only their surface cells are solid.
//!
//! Evaluating w at every cell centre would cost ~5–10 µs per cell, so the interior is classified
//! by axis-aligned rays first: for each row of cell centres along x, y and z, one watertight ray
//! cast records the signed crossings (+1 leaving through the front side, −1 entering). A row whose
//! crossings sum to zero (it enters as often as it leaves: it misses every hole) gives each of its
//! points the integer w = Σ crossings ahead of the point, which equals the winding number for any
//! closed mesh whatever the direction. Rows that pass through a hole (non-zero sum) or touch an
//! edge or vertex exactly (a crossing could count twice) abstain. A non-surface cell whose
//! non-abstaining rows number at least 2 and agree takes their value; otherwise — near holes, open
//! sheets, grazing rows, or when rows disagree — the hierarchical winding number decides.
//! So w is evaluated only in the "shadow" of holes; a wrong unanimous vote needs two rows of a
//! cell to pass through two holes each without a net crossing. Cells deep inside a holed mesh
//! therefore stay solid even where the generalized winding number of a large hole would dip
//! under the threshold (the rows see a closed object around them).
//!
//! Cost model (T triangles, n cells per axis, n³ cells): BVH + expansions O(T log T); surface
//! cells O(T · cells per triangle) SAT tests; 3n² ray casts of O(log T + hits); votes O(n³ · hits
//! per row); winding evaluations O(log T)-ish each, only for undecided cells (bunny, res 128: 3.9k
//! of 1.6M cells; res 256: 38k of 12.9M). Parallel over z-slabs with rayon; memory 2 bytes per cell plus the BVH (~120 B per triangle) and, only if
//! some cell needs it, the winding expansions (~220 B per triangle). Measured (2 cores, shared
//! machine, release): bunny 69k triangles at 64 / 128 / 256 cells: 80 / 160 / 650 ms CPU,
//! 1.3M-triangle icosphere with a hole at 128: ~3 s wall. Every cell's result depends only on
//! shared read-only data, so the output is identical for any thread count.

use crate::bvh::TriangleBvh;
use crate::winding::Expansions;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::OnceLock;

/// Voxelization settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoxelSettings {
    /// Cells along the longest axis of the mesh bounding box. Default 128, valid 1..=2048
    /// (clamped); memory is 2 bytes per cell.
    pub resolution: u32,
    /// A cell centre is inside when |winding number| ≥ this. Default 0.5, valid (0, 1] (values
    /// above 1 keep only multiply-covered regions; non-positive or non-finite values mean 0.5).
    pub winding_threshold: f64,
}

impl Default for VoxelSettings {
    fn default() -> Self {
        VoxelSettings { resolution: 128, winding_threshold: 0.5 }
    }
}

/// A solid voxel grid (cubic cells, x fastest).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VoxelGrid {
    /// Minimum corner of cell (0, 0, 0), model space.
    pub origin: DVec3,
    /// Edge length of the cubic cells, model units.
    pub cell_size: f64,
    /// Cells per axis; `[0, 0, 0]` when the mesh has no valid triangle.
    pub dims: [u32; 3],
    /// Cell is inside the solid (centre |w| ≥ threshold) or overlaps the surface.
    pub solid: Vec<bool>,
    /// Cell box overlaps at least one triangle.
    pub surface: Vec<bool>,
}

impl VoxelGrid {
    /// Linear index of cell (i, j, k), x fastest. Precondition: inside `dims`.
    pub fn index(&self, i: u32, j: u32, k: u32) -> usize {
        i as usize + self.dims[0] as usize * (j as usize + self.dims[1] as usize * k as usize)
    }

    /// Centre of cell (i, j, k), model space.
    pub fn cell_center(&self, i: u32, j: u32, k: u32) -> DVec3 {
        self.origin + (DVec3::new(i as f64, j as f64, k as f64) + 0.5) * self.cell_size
    }

    /// Minimum corner of cell (i, j, k), model space.
    pub fn cell_min(&self, i: u32, j: u32, k: u32) -> DVec3 {
        self.origin + DVec3::new(i as f64, j as f64, k as f64) * self.cell_size
    }

    /// Number of solid cells.
    pub fn solid_count(&self) -> usize {
        self.solid.iter().filter(|&&s| s).count()
    }

    /// Solid volume: solid cells × cell_size³ (model units³).
    pub fn volume(&self) -> f64 {
        self.solid_count() as f64 * self.cell_size.powi(3)
    }

    /// The boundary of the solid cell set as a closed, outward-oriented triangle mesh: two
    /// triangles per cell face between a solid cell and an empty (or outside-the-grid) cell,
    /// vertices shared on the grid lattice, so it is watertight (every directed edge has its
    /// reverse). Edges where two solid cells touch only along an edge are non-manifold (four
    /// faces); the enclosed volume is exactly [`VoxelGrid::volume`]. Deterministic vertex order.
    pub fn boundary_mesh(&self) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let [nx, ny, nz] = self.dims;
        let mut verts = Vec::new();
        let mut tris = Vec::new();
        let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
        let mut vid = |p: [u32; 3], verts: &mut Vec<DVec3>| -> u32 {
            *ids.entry(p).or_insert_with(|| {
                verts.push(self.cell_min(p[0], p[1], p[2]));
                (verts.len() - 1) as u32
            })
        };
        let solid_at = |i: i64, j: i64, k: i64| -> bool {
            if i < 0 || j < 0 || k < 0 || i >= nx as i64 || j >= ny as i64 || k >= nz as i64 {
                return false;
            }
            self.solid[self.index(i as u32, j as u32, k as u32)]
        };
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    if !self.solid[self.index(i, j, k)] {
                        continue;
                    }
                    let c = [i, j, k];
                    for axis in 0..3 {
                        for positive in [false, true] {
                            let mut nb = [i as i64, j as i64, k as i64];
                            nb[axis] += if positive { 1 } else { -1 };
                            if solid_at(nb[0], nb[1], nb[2]) {
                                continue;
                            }
                            // Face in the plane axis = c[axis] (+1 if positive); corners in the
                            // (b, c) axes, counter-clockwise around +axis.
                            let b = (axis + 1) % 3;
                            let cc = (axis + 2) % 3;
                            let mut corner = |db: u32, dc: u32| {
                                let mut p = c;
                                p[axis] += positive as u32;
                                p[b] += db;
                                p[cc] += dc;
                                vid(p, &mut verts)
                            };
                            let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
                            if positive {
                                tris.push([q[0], q[1], q[2]]);
                                tris.push([q[0], q[2], q[3]]);
                            } else {
                                tris.push([q[0], q[2], q[1]]);
                                tris.push([q[0], q[3], q[2]]);
                            }
                        }
                    }
                }
            }
        }
        (verts, tris)
    }
}

/// Signed crossings of one row of cell centres, sorted by coordinate along the row's axis.
#[derive(Default)]
struct Row {
    /// Crossing coordinates along the row's axis, ascending.
    coords: Vec<f64>,
    /// `ahead[m]` = Σ signs of crossings m.. (+1 leaving, −1 entering); one extra 0 at the end.
    ahead: Vec<i32>,
    /// The row abstains: its ray touched an edge or a vertex (crossings may be double-counted)
    /// or its crossings do not sum to zero (it passes through a hole, so the counts ahead of and
    /// behind a point disagree).
    abstains: bool,
}

impl Row {
    fn new(mut hits: Vec<(f64, i32)>, touched_edge: bool) -> Row {
        hits.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut ahead = vec![0; hits.len() + 1];
        for m in (0..hits.len()).rev() {
            ahead[m] = ahead[m + 1] + hits[m].1;
        }
        let abstains = touched_edge || ahead[0] != 0;
        Row { coords: hits.iter().map(|h| h.0).collect(), ahead, abstains }
    }

    /// The winding estimate at coordinate `x` (crossings exactly at `x` ignored), `None` if the
    /// row abstains.
    #[inline]
    fn vote(&self, x: f64) -> Option<i32> {
        if self.abstains {
            return None;
        }
        Some(self.ahead[self.coords.partition_point(|&c| c <= x)])
    }
}

/// Voxelizes the triangle soup (see the module docs). Triangles with out-of-range indices or
/// non-finite corners are ignored. Deterministic and parallel (rayon, over z-slabs).
pub fn voxelize(positions: &[Vec3], triangles: &[[u32; 3]], settings: &VoxelSettings) -> VoxelGrid {
    let bvh = TriangleBvh::new(positions, triangles);
    voxelize_bvh(&bvh, settings)
}

/// [`voxelize`] with a prebuilt BVH (reuse one tree for voxelization and ray casts).
pub fn voxelize_bvh(bvh: &TriangleBvh, settings: &VoxelSettings) -> VoxelGrid {
    let Some(root) = bvh.nodes.first() else {
        return VoxelGrid::default();
    };
    // Exact bounds of the valid triangles (the root box is padded).
    let mut lo = DVec3::INFINITY;
    let mut hi = DVec3::NEG_INFINITY;
    for &t in &bvh.prims {
        for p in bvh.tris[t as usize] {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    if !lo.is_finite() || !hi.is_finite() {
        lo = root.min;
        hi = root.max;
    }
    let res = settings.resolution.clamp(1, 2048);
    let extent = hi - lo;
    let mut cell = extent.max_element() / res as f64;
    if cell.is_nan() || cell <= 0.0 || !cell.is_finite() {
        cell = (lo.abs().max(hi.abs()).max_element() * 1e-6).max(1e-9);
    }
    let mut dims = [1u32; 3];
    let mut origin = lo;
    for a in 0..3 {
        let n = ((extent[a] / cell) * (1.0 - 1e-12)).ceil().clamp(1.0, res as f64) as u32;
        dims[a] = n;
        origin[a] = lo[a] - (n as f64 * cell - extent[a]) * 0.5;
    }
    let [nx, ny, nz] = dims;
    let cell_count = nx as usize * ny as usize * nz as usize;
    let center = |i: u32, j: u32, k: u32| origin + (DVec3::new(i as f64, j as f64, k as f64) + 0.5) * cell;

    // Rows: x rows indexed by (j, k), y rows by (i, k), z rows by (i, j).
    let cast = |axis: usize, p: DVec3| -> Row {
        let mut o = p;
        o[axis] = origin[axis] - cell;
        let mut dir = DVec3::ZERO;
        dir[axis] = 1.0;
        let mut hits = Vec::new();
        let mut touched_edge = false;
        bvh.traverse_ray(o, dir, 0.0, f64::INFINITY, |h| {
            touched_edge |= h.bary.contains(&0.0);
            hits.push((o[axis] + h.t, if h.exiting { 1 } else { -1 }));
            None
        });
        Row::new(hits, touched_edge)
    };
    let rows_x: Vec<Row> = (0..ny as usize * nz as usize)
        .into_par_iter()
        .map(|r| cast(0, center(0, (r % ny as usize) as u32, (r / ny as usize) as u32)))
        .collect();
    let rows_y: Vec<Row> = (0..nx as usize * nz as usize)
        .into_par_iter()
        .map(|r| cast(1, center((r % nx as usize) as u32, 0, (r / nx as usize) as u32)))
        .collect();
    let rows_z: Vec<Row> = (0..nx as usize * ny as usize)
        .into_par_iter()
        .map(|r| cast(2, center((r % nx as usize) as u32, (r / nx as usize) as u32, 0)))
        .collect();

    // Triangles per z-slab.
    let mut slab_tris: Vec<Vec<u32>> = vec![Vec::new(); nz as usize];
    let cell_range = |a: usize, min: f64, max: f64, n: u32| -> (u32, u32) {
        let eps = 1e-9;
        let lo = ((min - origin[a]) / cell - eps).floor().max(0.0);
        let hi = ((max - origin[a]) / cell + eps).floor().min(n as f64 - 1.0);
        (lo as u32, hi.max(lo) as u32)
    };
    for &t in &bvh.prims {
        let tri = &bvh.tris[t as usize];
        let zmin = tri[0].z.min(tri[1].z).min(tri[2].z);
        let zmax = tri[0].z.max(tri[1].z).max(tri[2].z);
        let (k0, k1) = cell_range(2, zmin, zmax, nz);
        for k in k0..=k1 {
            slab_tris[k as usize].push(t);
        }
    }

    // Built on first use only: closed meshes never need it.
    let winding: OnceLock<Expansions> = OnceLock::new();
    let threshold = settings.winding_threshold;
    let threshold = if threshold.is_finite() && threshold > 0.0 { threshold } else { 0.5 };
    let slab = nx as usize * ny as usize;
    let mut solid = vec![false; cell_count];
    let mut surface = vec![false; cell_count];
    solid.par_chunks_mut(slab).zip(surface.par_chunks_mut(slab)).enumerate().for_each(|(k, (sol, sur))| {
        let k = k as u32;
        let half = DVec3::splat(cell * 0.5 * (1.0 + 1e-9));
        for &t in &slab_tris[k as usize] {
            let tri = &bvh.tris[t as usize];
            let tmin = tri[0].min(tri[1]).min(tri[2]);
            let tmax = tri[0].max(tri[1]).max(tri[2]);
            let (i0, i1) = cell_range(0, tmin.x, tmax.x, nx);
            let (j0, j1) = cell_range(1, tmin.y, tmax.y, ny);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let idx = i as usize + nx as usize * j as usize;
                    if !sur[idx] && tri_box_overlap(tri, center(i, j, k), half) {
                        sur[idx] = true;
                    }
                }
            }
        }
        for j in 0..ny {
            for i in 0..nx {
                let idx = i as usize + nx as usize * j as usize;
                if sur[idx] {
                    sol[idx] = true;
                    continue;
                }
                let c = center(i, j, k);
                let rows = [
                    (&rows_x[j as usize + ny as usize * k as usize], c.x),
                    (&rows_y[i as usize + nx as usize * k as usize], c.y),
                    (&rows_z[i as usize + nx as usize * j as usize], c.z),
                ];
                let mut agreed: Option<i32> = None;
                let mut voters = 0;
                let mut conflict = false;
                for (row, x) in rows {
                    if let Some(w) = row.vote(x) {
                        voters += 1;
                        match agreed {
                            None => agreed = Some(w),
                            Some(v) if v != w => conflict = true,
                            _ => {}
                        }
                    }
                }
                let w = match agreed {
                    Some(v) if !conflict && voters >= 2 => v as f64,
                    _ => winding.get_or_init(|| Expansions::build(bvh)).eval(bvh, c),
                };
                sol[idx] = w.abs() >= threshold;
            }
        }
    });
    VoxelGrid { origin, cell_size: cell, dims, solid, surface }
}

/// Triangle / axis-aligned box overlap (Akenine-Möller 2001, separating axis theorem), closed
/// sets: touching counts as overlap.
pub fn tri_box_overlap(tri: &[DVec3; 3], box_center: DVec3, half: DVec3) -> bool {
    let v0 = tri[0] - box_center;
    let v1 = tri[1] - box_center;
    let v2 = tri[2] - box_center;
    // 1. Box face normals (the triangle's AABB against the box).
    let mn = v0.min(v1).min(v2);
    let mx = v0.max(v1).max(v2);
    if mn.x > half.x || mx.x < -half.x || mn.y > half.y || mx.y < -half.y || mn.z > half.z || mx.z < -half.z {
        return false;
    }
    let e = [v1 - v0, v2 - v1, v0 - v2];
    // 2. The nine edge × axis cross products.
    for edge in e {
        for a in 0..3 {
            let mut axis_unit = DVec3::ZERO;
            axis_unit[a] = 1.0;
            let ax = axis_unit.cross(edge);
            if ax == DVec3::ZERO {
                continue;
            }
            let p0 = v0.dot(ax);
            let p1 = v1.dot(ax);
            let p2 = v2.dot(ax);
            let r = half.x * ax.x.abs() + half.y * ax.y.abs() + half.z * ax.z.abs();
            if p0.min(p1).min(p2) > r || p0.max(p1).max(p2) < -r {
                return false;
            }
        }
    }
    // 3. The triangle's plane.
    let n = e[0].cross(e[1]);
    let d = n.dot(v0);
    let r = half.x * n.x.abs() + half.y * n.y.abs() + half.z * n.z.abs();
    d.abs() <= r
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(tri: [DVec3; 3], expected: bool) {
        assert_eq!(tri_box_overlap(&tri, DVec3::ZERO, DVec3::splat(0.5)), expected, "{tri:?}");
    }

    #[test]
    fn sat_cases() {
        // Large triangle through the box.
        check([DVec3::new(-5.0, -5.0, 0.1), DVec3::new(5.0, -5.0, 0.1), DVec3::new(0.0, 5.0, 0.1)], true);
        // Plane misses the box.
        check([DVec3::new(-5.0, -5.0, 0.6), DVec3::new(5.0, -5.0, 0.6), DVec3::new(0.0, 5.0, 0.6)], false);
        // Touching a face counts.
        check([DVec3::new(-5.0, -5.0, 0.5), DVec3::new(5.0, -5.0, 0.5), DVec3::new(0.0, 5.0, 0.5)], true);
        // Near the corner, separated only by an edge-cross axis: the plane x + y = 1.2 (vertical).
        check([DVec3::new(1.2, 0.0, -3.0), DVec3::new(0.0, 1.2, -3.0), DVec3::new(0.6, 0.6, 3.0)], false);
        check([DVec3::new(0.9, 0.0, -3.0), DVec3::new(0.0, 0.9, -3.0), DVec3::new(0.45, 0.45, 3.0)], true);
        // Triangle entirely inside.
        check([DVec3::new(0.1, 0.1, 0.1), DVec3::new(0.2, 0.1, 0.1), DVec3::new(0.1, 0.2, 0.1)], true);
    }
}
