//! The point set the clustering works on: surface samples (triangle vertices, centroids, and a
//! barycentric grid on triangles larger than the sample spacing), thinned to one per cell of
//! half the lattice spacing, plus interior lattice points (grid corners inside the solid),
//! with neighbour lists for the flood fill.

use crate::solid::Solid;
use glam::DVec3;

/// Surface sample thinning cell, in lattice spacings.
const SURFACE_SPACING: f64 = 1.0;

pub struct PointSet {
    pub points: Vec<DVec3>,
    /// `points[..surface_count]` are surface samples, the rest interior lattice points.
    pub surface_count: usize,
    /// CSR neighbour lists.
    pub adj_offsets: Vec<u32>,
    pub adj: Vec<u32>,
    /// Lattice spacing, model units.
    pub h: f64,
}

impl PointSet {
    pub fn neighbours(&self, i: usize) -> &[u32] {
        &self.adj[self.adj_offsets[i] as usize..self.adj_offsets[i + 1] as usize]
    }
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

/// Builds the clustering point set. `h` = lattice spacing.
pub fn build(positions: &[DVec3], triangles: &[[u32; 3]], solid: &Solid, lo: DVec3, hi: DVec3, h: f64) -> PointSet {
    let fine = h * SURFACE_SPACING;
    let mut samples: Vec<DVec3> = Vec::with_capacity(triangles.len() * 2);
    for t in triangles {
        let a = positions[t[0] as usize];
        let b = positions[t[1] as usize];
        let c = positions[t[2] as usize];
        let l = (b - a).length().max((c - b).length()).max((a - c).length());
        let m = (l / fine).ceil().clamp(1.0, 256.0) as usize;
        if m <= 1 {
            samples.push(a);
            samples.push((a + b + c) / 3.0);
        } else {
            for i in 0..=m {
                for j in 0..=(m - i) {
                    let u = i as f64 / m as f64;
                    let v = j as f64 / m as f64;
                    samples.push(a + (b - a) * u + (c - a) * v);
                }
            }
            samples.push((a + b + c) / 3.0);
        }
    }
    // Thin: one sample per fine cell (the first in input order).
    let mut keyed: Vec<((i64, i64, i64), u32)> =
        samples.iter().enumerate().map(|(i, p)| (key(*p, lo, fine), i as u32)).collect();
    keyed.sort_unstable();
    keyed.dedup_by(|a, b| a.0 == b.0);
    let mut idx: Vec<u32> = keyed.iter().map(|x| x.1).collect();
    idx.sort_unstable();
    let mut points: Vec<DVec3> = idx.iter().map(|&i| samples[i as usize]).collect();
    let surface_count = points.len();
    points.extend(lattice_points(solid, lo, hi, h));
    // Bins centred on lattice points.
    let bin_origin = lo - DVec3::splat(0.5 * h);
    let mut binned: Vec<((i64, i64, i64), u32)> =
        points.iter().enumerate().map(|(i, p)| (key(*p, bin_origin, h), i as u32)).collect();
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
        let k = key(*p, bin_origin, h);
        for d in [(0, 0, 0), (1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)] {
            for x in find((k.0 + d.0, k.1 + d.1, k.2 + d.2)) {
                if x.1 as usize != i {
                    adj.push(x.1);
                }
            }
        }
        adj_offsets.push(adj.len() as u32);
    }
    PointSet { points, surface_count, adj_offsets, adj, h }
}
