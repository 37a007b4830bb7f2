//! Voxel solid of the input and the fast outside-volume proxy the optimiser uses.
//!
//! The solid is sampled at cell centres by ray parity along grid rows (x rows only for a
//! closed mesh, where parity is exact; majority of x, y and z parity for an open mesh, which
//! bridges small holes). Each x row keeps a prefix count of solid cells, so the volume of
//! ball ∩ solid is a sum over the rows inside the ball's disc of one difference of two
//! piecewise-linear prefix lookups: O((r/h)²) per evaluation and continuous in the centre.

use glam::DVec3;

/// Solid state of a 3×3×3 block of cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Neighbourhood {
    AllSolid,
    NoneSolid,
    Mixed,
}

/// Voxel solid on a regular grid (cell centres at `origin + (i + 0.5) h`).
#[derive(Clone, Debug)]
pub struct Solid {
    pub origin: DVec3,
    /// Cell edge length, model units.
    pub h: f64,
    pub dims: [usize; 3],
    /// x-fastest, `true` = cell centre inside the solid.
    pub solid: Vec<bool>,
    /// Per x row (j, k): `dims[0] + 1` prefix counts of solid cells (exact in f32: ≤ 2²⁴).
    prefix: Vec<f32>,
    /// Per x row: [a, b] when its solid cells form one run [a, b); [0, 0] when none or when
    /// they form several runs (those rows are listed in `multi` and use the prefix).
    span: Vec<[f32; 2]>,
    /// Per z slab k: `multi[multi_start[k]..multi_start[k + 1]]` are the rows j (ascending)
    /// whose solid cells form more than one run.
    multi: Vec<u32>,
    multi_start: Vec<usize>,
    /// Number of solid cells.
    pub solid_count: usize,
}

impl Solid {
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// Cell containing `p`, if inside the grid.
    pub fn cell_of(&self, p: DVec3) -> Option<[usize; 3]> {
        let u = (p - self.origin) / self.h;
        let mut out = [0usize; 3];
        for a in 0..3 {
            let v = u[a].floor();
            if !(v >= 0.0 && v < self.dims[a] as f64) {
                return None;
            }
            out[a] = v as usize;
        }
        Some(out)
    }

    /// Whether the cell containing `p` is solid (false outside the grid).
    pub fn is_solid_at(&self, p: DVec3) -> bool {
        self.cell_of(p).is_some_and(|[i, j, k]| self.solid[self.index(i, j, k)])
    }

    /// Classifies the 3×3×3 block of cells around `p` (cells outside the grid count as empty).
    pub fn neighbourhood(&self, p: DVec3) -> Neighbourhood {
        let u = (p - self.origin) / self.h;
        let (ci, cj, ck) = (u.x.floor() as i64, u.y.floor() as i64, u.z.floor() as i64);
        let mut n_solid = 0;
        for dk in -1..=1 {
            for dj in -1..=1 {
                for di in -1..=1 {
                    let (i, j, k) = (ci + di, cj + dj, ck + dk);
                    if i >= 0
                        && j >= 0
                        && k >= 0
                        && (i as usize) < self.dims[0]
                        && (j as usize) < self.dims[1]
                        && (k as usize) < self.dims[2]
                        && self.solid[self.index(i as usize, j as usize, k as usize)]
                    {
                        n_solid += 1;
                    }
                }
            }
        }
        match n_solid {
            0 => Neighbourhood::NoneSolid,
            27 => Neighbourhood::AllSolid,
            _ => Neighbourhood::Mixed,
        }
    }

    /// Volume of the solid, units³.
    pub fn volume(&self) -> f64 {
        self.solid_count as f64 * self.h * self.h * self.h
    }

    /// Proxy of V(ball ∩ solid), units³: rows of cells through the disc, fractional ends.
    pub fn ball_volume(&self, c: DVec3, r: f64) -> f64 {
        if r <= 0.0 {
            return 0.0;
        }
        let h = self.h;
        let nx = self.dims[0];
        let u = (c - self.origin) / h;
        let ru = r / h;
        let r2 = ru * ru;
        // Row centres at j + 0.5.
        let k0 = ((u.z - ru - 0.5).ceil().max(0.0)) as usize;
        let k1 = (u.z + ru - 0.5).floor();
        if k1 < 0.0 {
            return 0.0;
        }
        let k1 = (k1 as usize).min(self.dims[2].saturating_sub(1));
        let j0 = ((u.y - ru - 0.5).ceil().max(0.0)) as usize;
        let j1f = (u.y + ru - 0.5).floor();
        if j1f < 0.0 {
            return 0.0;
        }
        let j1 = (j1f as usize).min(self.dims[1].saturating_sub(1));
        let mut sum = 0.0;
        let ny = self.dims[1];
        for k in k0..=k1 {
            let dz = k as f64 + 0.5 - u.z;
            let rem_z = r2 - dz * dz;
            if rem_z <= 0.0 {
                continue;
            }
            // Rows j with (j + 0.5 − u.y)² < rem_z only.
            let w = rem_z.sqrt();
            let ja = ((u.y - w - 0.5).floor() + 1.0).max(j0 as f64) as usize;
            let jb = ((u.y + w - 0.5).ceil() - 1.0).min(j1 as f64);
            if jb < ja as f64 {
                continue;
            }
            let jb = jb as usize;
            let lo = ja + ny * k;
            let spans = &self.span[lo..=jb + ny * k];
            // Branch-free over the rows (multi-run rows have span [0, 0] here and are added
            // from the prefix below).
            // f32 lanes (4 per SSE register): chord ends within 2⁻²⁴ × 1024 cells, far below
            // the proxy's own error; the slab sum is accumulated in f64.
            let y0 = (ja as f64 + 0.5 - u.y) as f32;
            let (ux, rz) = (u.x as f32, rem_z as f32);
            let row = |n: usize, [a, b]: [f32; 2]| {
                let dy = y0 + n as f32;
                let half = (rz - dy * dy).max(0.0).sqrt();
                ((ux + half).min(b) - (ux - half).max(a)).max(0.0)
            };
            // Eight independent lanes so the compiler vectorises (a single running f32 sum
            // cannot be reordered).
            let mut lanes = [0.0f32; 8];
            let chunks = spans.chunks_exact(8);
            let rest = chunks.remainder();
            for (c, chunk) in chunks.enumerate() {
                for (l, (lane, &sp)) in lanes.iter_mut().zip(chunk).enumerate() {
                    *lane += row(c * 8 + l, sp);
                }
            }
            let mut acc: f64 = lanes.iter().map(|&x| x as f64).sum();
            let base = spans.len() - rest.len();
            for (n, &sp) in rest.iter().enumerate() {
                acc += row(base + n, sp) as f64;
            }
            sum += acc;
            let multi = &self.multi[self.multi_start[k]..self.multi_start[k + 1]];
            let m0 = multi.partition_point(|&j| (j as usize) < ja);
            for &j in &multi[m0..] {
                let j = j as usize;
                if j > jb {
                    break;
                }
                let dy = j as f64 + 0.5 - u.y;
                let rem = rem_z - dy * dy;
                if rem <= 0.0 {
                    continue;
                }
                let half = rem.sqrt();
                let rj = j + ny * k;
                let pre = &self.prefix[rj * (nx + 1)..(rj + 1) * (nx + 1)];
                sum += prefix_at(pre, u.x + half) - prefix_at(pre, u.x - half);
            }
        }
        sum * h * h * h
    }

    /// Closed outward boundary mesh of the solid cells (two triangles per exposed face), with
    /// the (ascending) index of the solid cell each triangle bounds.
    pub fn boundary_mesh(&self) -> (Vec<DVec3>, Vec<[u32; 3]>, Vec<u32>) {
        let [nx, ny, nz] = self.dims;
        let mut pos = Vec::new();
        let mut tris = Vec::new();
        let mut cells = Vec::new();
        let get = |i: i64, j: i64, k: i64| -> bool {
            i >= 0
                && j >= 0
                && k >= 0
                && (i as usize) < nx
                && (j as usize) < ny
                && (k as usize) < nz
                && self.solid[self.index(i as usize, j as usize, k as usize)]
        };
        for k in 0..nz as i64 {
            for j in 0..ny as i64 {
                for i in 0..nx as i64 {
                    if !get(i, j, k) {
                        continue;
                    }
                    for axis in 0..3 {
                        for dir in [-1i64, 1] {
                            let mut nb = [i, j, k];
                            nb[axis] += dir;
                            if get(nb[0], nb[1], nb[2]) {
                                continue;
                            }
                            let u = (axis + 1) % 3;
                            let v = (axis + 2) % 3;
                            let base = pos.len() as u32;
                            for (du, dv) in [(0, 0), (1, 0), (1, 1), (0, 1)] {
                                let mut x = [i as f64, j as f64, k as f64];
                                if dir > 0 {
                                    x[axis] += 1.0;
                                }
                                x[u] += du as f64;
                                x[v] += dv as f64;
                                pos.push(self.origin + DVec3::from_array(x) * self.h);
                            }
                            if dir > 0 {
                                tris.push([base, base + 1, base + 2]);
                                tris.push([base, base + 2, base + 3]);
                            } else {
                                tris.push([base, base + 2, base + 1]);
                                tris.push([base, base + 3, base + 2]);
                            }
                            let ci = self.index(i as usize, j as usize, k as usize) as u32;
                            cells.push(ci);
                            cells.push(ci);
                        }
                    }
                }
            }
        }
        (pos, tris, cells)
    }
}

/// The row's prefix count at x (cells), linear inside a cell: P(i) + (x − i)(P(i+1) − P(i)),
/// i.e. the solid length of the row left of x.
#[inline]
fn prefix_at(pre: &[f32], x: f64) -> f64 {
    let n = pre.len() - 1;
    if x <= 0.0 {
        return 0.0;
    }
    if x >= n as f64 {
        return pre[n] as f64;
    }
    let i = x as usize;
    let (a, b) = (pre[i] as f64, pre[i + 1] as f64);
    a + (x - i as f64) * (b - a)
}

/// Voxelizes a triangle mesh with `resolution` cells along the longest bounding-box axis.
/// `closed`: use x-row parity only (exact for closed meshes); otherwise majority of 3 axes.
pub fn voxelize(positions: &[DVec3], triangles: &[[u32; 3]], resolution: u32, closed: bool) -> Solid {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for t in triangles {
        for &v in t {
            lo = lo.min(positions[v as usize]);
            hi = hi.max(positions[v as usize]);
        }
    }
    let extent = (hi - lo).max_element().max(1e-30);
    let h = extent / resolution.max(1) as f64;
    // An irregular offset keeps axis-aligned input faces off the cell-centre lattice.
    let origin = lo - DVec3::splat(h * 1.013_7);
    let mut dims = [0usize; 3];
    for a in 0..3 {
        dims[a] = (((hi[a] - origin[a]) / h).ceil() as usize + 2).max(1);
    }
    let n = dims[0] * dims[1] * dims[2];
    let axes: &[usize] = if closed { &[0] } else { &[0, 1, 2] };
    let mut votes = vec![0u8; n];
    for &axis in axes {
        let u = (axis + 1) % 3;
        let v = (axis + 2) % 3;
        // (ray id, coordinate along axis in cell units)
        let mut hits: Vec<(u32, f64)> = Vec::new();
        for t in triangles {
            let p = [positions[t[0] as usize], positions[t[1] as usize], positions[t[2] as usize]];
            let q: Vec<[f64; 3]> = p
                .iter()
                .map(|x| {
                    let w = (*x - origin) / h;
                    [w[u] - 0.5, w[v] - 0.5, w[axis]]
                })
                .collect();
            let umin = q.iter().map(|x| x[0]).fold(f64::INFINITY, f64::min).ceil().max(0.0) as i64;
            let umax = q.iter().map(|x| x[0]).fold(f64::NEG_INFINITY, f64::max).floor() as i64;
            let vmin = q.iter().map(|x| x[1]).fold(f64::INFINITY, f64::min).ceil().max(0.0) as i64;
            let vmax = q.iter().map(|x| x[1]).fold(f64::NEG_INFINITY, f64::max).floor() as i64;
            let umax = umax.min(dims[u] as i64 - 1);
            let vmax = vmax.min(dims[v] as i64 - 1);
            for jv in vmin..=vmax {
                for iu in umin..=umax {
                    let (x, y) = (iu as f64, jv as f64);
                    let e = |a: &[f64; 3], b: &[f64; 3]| (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]);
                    let d0 = e(&q[1], &q[2]);
                    let d1 = e(&q[2], &q[0]);
                    let d2 = e(&q[0], &q[1]);
                    let pos = d0 >= 0.0 && d1 >= 0.0 && d2 >= 0.0;
                    let neg = d0 <= 0.0 && d1 <= 0.0 && d2 <= 0.0;
                    let s = d0 + d1 + d2;
                    if (pos || neg) && s != 0.0 {
                        let z = (d0 * q[0][2] + d1 * q[1][2] + d2 * q[2][2]) / s;
                        let ray = (iu as usize + dims[u] * jv as usize) as u32;
                        hits.push((ray, z));
                    }
                }
            }
        }
        hits.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        let mut s = 0;
        while s < hits.len() {
            let ray = hits[s].0;
            let mut e = s;
            while e < hits.len() && hits[e].0 == ray {
                e += 1;
            }
            let iu = ray as usize % dims[u];
            let jv = ray as usize / dims[u];
            let mut m = s;
            for ia in 0..dims[axis] {
                let z = ia as f64 + 0.5;
                while m < e && hits[m].1 < z {
                    m += 1;
                }
                if (m - s) % 2 == 1 {
                    let mut c = [0usize; 3];
                    c[axis] = ia;
                    c[u] = iu;
                    c[v] = jv;
                    votes[c[0] + dims[0] * (c[1] + dims[1] * c[2])] += 1;
                }
            }
            s = e;
        }
    }
    let need = if closed { 1 } else { 2 };
    let solid: Vec<bool> = votes.iter().map(|&x| x >= need).collect();
    Solid::from_cells(origin, h, dims, solid)
}

impl Solid {
    /// Builds the row prefix sums for a given cell classification.
    pub fn from_cells(origin: DVec3, h: f64, dims: [usize; 3], solid: Vec<bool>) -> Solid {
        let nx = dims[0];
        let rows = dims[1] * dims[2];
        let mut prefix = vec![0f32; rows * (nx + 1)];
        let mut span = vec![[0f32; 2]; rows];
        let mut multi_rows: Vec<usize> = Vec::new();
        let mut count = 0usize;
        for row in 0..rows {
            let mut acc = 0u32;
            let (mut first, mut last, mut runs) = (0usize, 0usize, 0usize);
            for i in 0..nx {
                if solid[row * nx + i] {
                    if acc == 0 {
                        first = i;
                    }
                    if i == 0 || !solid[row * nx + i - 1] {
                        runs += 1;
                    }
                    last = i;
                    acc += 1;
                }
                prefix[row * (nx + 1) + i + 1] = acc as f32;
            }
            span[row] = match runs {
                0 => [0.0, 0.0],
                1 => [first as f32, (last + 1) as f32],
                _ => {
                    multi_rows.push(row);
                    [0.0, 0.0]
                }
            };
            count += acc as usize;
        }
        // Rows are j-fastest within a slab k, so `multi_rows` is sorted by (k, j).
        let ny = dims[1];
        let mut multi_start = vec![0usize; dims[2] + 1];
        for &row in &multi_rows {
            multi_start[row / ny + 1] += 1;
        }
        for k in 0..dims[2] {
            multi_start[k + 1] += multi_start[k];
        }
        let multi: Vec<u32> = multi_rows.iter().map(|&row| (row % ny) as u32).collect();
        Solid { origin, h, dims, solid, prefix, span, multi, multi_start, solid_count: count }
    }

    /// The same grid with every cell that contains a surface sample (barycentric grid of
    /// spacing ≤ h/2 on each triangle) also solid: the fallback solid for meshes that enclose
    /// no volume (single sheets).
    pub fn with_surface_cells(&self, positions: &[DVec3], triangles: &[[u32; 3]]) -> Solid {
        let mut solid = self.solid.clone();
        for t in triangles {
            let (a, b, c) = (positions[t[0] as usize], positions[t[1] as usize], positions[t[2] as usize]);
            let l = (b - a).length().max((c - b).length()).max((a - c).length());
            let m = (2.0 * l / self.h).ceil().clamp(1.0, 4096.0) as usize;
            for i in 0..=m {
                for j in 0..=(m - i) {
                    let p = a + (b - a) * (i as f64 / m as f64) + (c - a) * (j as f64 / m as f64);
                    if let Some([x, y, z]) = self.cell_of(p) {
                        let idx = self.index(x, y, z);
                        solid[idx] = true;
                    }
                }
            }
        }
        Solid::from_cells(self.origin, self.h, self.dims, solid)
    }
}
