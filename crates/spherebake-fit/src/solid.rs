//! Voxel solid of the input and the fast outside-volume proxy the optimiser uses.
//!
//! The solid is sampled at cell centres by ray parity along grid rows (x rows only for a
//! closed mesh, where parity is exact; majority of x, y and z parity for an open mesh, which
//! bridges small holes). Each x row keeps a prefix count of solid cells, so the volume of
//! ball ∩ solid is a sum over the rows inside the ball's disc of one difference of two
//! piecewise-linear prefix lookups: O((r/h)²) per evaluation and continuous in the centre.

use glam::DVec3;

/// A fixed-length bit vector (one bit per voxel cell: 128 MB at 1024³ instead of 1 GB).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Bits {
    words: Vec<u64>,
    len: usize,
}

impl Bits {
    pub fn new(len: usize) -> Self {
        Bits { words: vec![0; len.div_ceil(64)], len }
    }
    #[inline]
    pub fn get(&self, i: usize) -> bool {
        debug_assert!(i < self.len);
        self.words[i >> 6] >> (i & 63) & 1 == 1
    }
    #[inline]
    pub fn set(&mut self, i: usize) {
        debug_assert!(i < self.len);
        self.words[i >> 6] |= 1 << (i & 63);
    }
    pub fn len(&self) -> usize {
        self.len
    }
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
    pub fn count_ones(&self) -> usize {
        self.words.iter().map(|w| w.count_ones() as usize).sum()
    }
    /// Number of bits set in both `self` and not in `other` (same length).
    pub fn count_and_not(&self, other: &Bits) -> usize {
        self.words.iter().zip(&other.words).map(|(a, b)| (a & !b).count_ones() as usize).sum()
    }
}

impl FromIterator<bool> for Bits {
    fn from_iter<I: IntoIterator<Item = bool>>(it: I) -> Self {
        let mut b = Bits::default();
        for (i, v) in it.into_iter().enumerate() {
            if i % 64 == 0 {
                b.words.push(0);
            }
            if v {
                b.words[i >> 6] |= 1 << (i & 63);
            }
            b.len = i + 1;
        }
        b
    }
}

impl std::ops::Index<usize> for Bits {
    type Output = bool;
    fn index(&self, i: usize) -> &bool {
        if self.get(i) {
            &true
        } else {
            &false
        }
    }
}

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
    /// x-fastest, set = cell centre inside the solid.
    pub solid: Bits,
    /// Runs `[a, b)` of solid cells of the rows listed in `multi`, in that order; row n's runs
    /// are `runs[run_start[n]..run_start[n + 1]]`, with `run_before[r]` the solid cells of the
    /// row before run r (the prefix counts, exact, without a (dims[0] + 1) array per row).
    runs: Vec<[u32; 2]>,
    run_before: Vec<u32>,
    run_start: Vec<usize>,
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
        let _ = nx;
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
            let (ms, me) = (self.multi_start[k], self.multi_start[k + 1]);
            let multi = &self.multi[ms..me];
            let m0 = multi.partition_point(|&j| (j as usize) < ja);
            for (mi, &j) in multi.iter().enumerate().skip(m0) {
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
                let n = ms + mi;
                let (r0, r1) = (self.run_start[n], self.run_start[n + 1]);
                let (runs, before) = (&self.runs[r0..r1], &self.run_before[r0..r1]);
                let mut cur = 0;
                let x0 = prefix_from(runs, before, nx, u.x - half, &mut cur);
                sum += prefix_from(runs, before, nx, u.x + half, &mut cur) - x0;
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

/// Calls `f` on points of triangle (a, b, c) such that every point of the triangle lies within
/// `spacing` of one: rows from the vertex opposite the shortest edge towards that edge, each row
/// sampled in proportion to its own length. A sliver costs about length / spacing points, not
/// (length / spacing)² as a barycentric grid over its long edges would (issue 17: a fan of 30 000
/// slivers spent 21 s here). At most 4096 rows and 4096 points per row.
pub fn cover_samples(a: DVec3, b: DVec3, c: DVec3, spacing: f64, mut f: impl FnMut(DVec3)) {
    // Apex opposite the shortest edge.
    let (ab, bc, ca) = ((b - a).length(), (c - b).length(), (a - c).length());
    let (apex, p, q, base) = if bc <= ab && bc <= ca {
        (a, b, c, bc)
    } else if ca <= ab {
        (b, c, a, ca)
    } else {
        (c, a, b, ab)
    };
    let long = (p - apex).length().max((q - apex).length());
    if !(long.is_finite() && base.is_finite() && spacing > 0.0) {
        f(apex);
        return;
    }
    let rows = (long / spacing).ceil().clamp(1.0, 4096.0) as usize;
    for r in 0..=rows {
        let s = r as f64 / rows as f64;
        let (u, v) = (apex + (p - apex) * s, apex + (q - apex) * s);
        let n = (s * base / spacing).ceil().clamp(1.0, 4096.0) as usize;
        for k in 0..=n {
            f(u + (v - u) * (k as f64 / n as f64));
        }
    }
}

/// The row's prefix count at x (cells), linear inside a cell: P(i) + (x − i)(P(i+1) − P(i)),
/// i.e. the solid length of the row left of x; the row (of `n` cells) is given by its solid
/// runs and the solid cells before each. P values are exact integers, so this is bit-identical
/// to a lookup in a full prefix array.
#[inline]
/// Solid cells of a multi-run row in [0, x), linear within cell ⌊x⌋ (`n` cells in the row).
/// `*r` is a cursor: a count of runs known to start before ⌊x⌋ (0 always is), left at the
/// count of runs starting before ⌊x⌋. A chord's two ends share it (left end first), so a row's
/// runs are walked once: rows hold few runs, and two binary searches per end cost more (16 %
/// of a bunny bake's samples). The counts are those a search gives, so are the values.
fn prefix_from(runs: &[[u32; 2]], before: &[u32], n: usize, x: f64, r: &mut usize) -> f64 {
    // Solid cells in [0, i) given c, the number of runs starting before i.
    let p = |i: usize, c: usize| -> u32 {
        if c == 0 {
            return 0;
        }
        let [a, b] = runs[c - 1];
        before[c - 1] + (i.min(b as usize) - a as usize) as u32
    };
    let mut count = |i: usize| -> usize {
        while *r < runs.len() && (runs[*r][0] as usize) < i {
            *r += 1;
        }
        *r
    };
    if x <= 0.0 {
        return 0.0;
    }
    if x >= n as f64 {
        let c = count(n);
        return p(n, c) as f64;
    }
    let i = x as usize;
    let c0 = count(i);
    // Runs starting before i + 1: those before i and the one starting at i, if any (runs
    // are disjoint, so their starts are distinct).
    let c1 = c0 + usize::from(runs.get(c0).is_some_and(|run| run[0] as usize == i));
    let (a, b) = (p(i, c0) as f64, p(i + 1, c1) as f64);
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
    // Votes per cell as bits (one axis' parity each): at least one, at least two.
    let (mut once, mut twice) = (Bits::new(n), Bits::new(n));
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
                    let idx = c[0] + dims[0] * (c[1] + dims[1] * c[2]);
                    if once.get(idx) {
                        twice.set(idx);
                    } else {
                        once.set(idx);
                    }
                }
            }
            s = e;
        }
    }
    let solid = if closed { once } else { twice };
    Solid::from_cells(origin, h, dims, solid)
}

impl Solid {
    /// Builds the row prefix sums for a given cell classification.
    pub fn from_cells(origin: DVec3, h: f64, dims: [usize; 3], solid: Bits) -> Solid {
        let nx = dims[0];
        let rows = dims[1] * dims[2];
        let mut span = vec![[0f32; 2]; rows];
        let mut multi_rows: Vec<usize> = Vec::new();
        let (mut runs_all, mut run_before, mut run_start) = (Vec::new(), Vec::new(), vec![0usize]);
        let mut row_runs: Vec<[u32; 2]> = Vec::new();
        let mut count = 0usize;
        for (row, sp) in span.iter_mut().enumerate() {
            let mut acc = 0u32;
            row_runs.clear();
            for i in 0..nx {
                if solid.get(row * nx + i) {
                    if i == 0 || !solid.get(row * nx + i - 1) {
                        row_runs.push([i as u32, i as u32 + 1]);
                    } else if let Some(r) = row_runs.last_mut() {
                        r[1] = i as u32 + 1;
                    }
                    acc += 1;
                }
            }
            *sp = match row_runs.len() {
                0 => [0.0, 0.0],
                1 => [row_runs[0][0] as f32, row_runs[0][1] as f32],
                _ => {
                    multi_rows.push(row);
                    let mut before = 0u32;
                    for r in &row_runs {
                        runs_all.push(*r);
                        run_before.push(before);
                        before += r[1] - r[0];
                    }
                    run_start.push(runs_all.len());
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
        Solid {
            origin,
            h,
            dims,
            solid,
            runs: runs_all,
            run_before,
            run_start,
            span,
            multi,
            multi_start,
            solid_count: count,
        }
    }

    /// The same grid with every cell that contains a surface sample (barycentric grid of
    /// spacing ≤ h/2 on each triangle) also solid: the fallback solid for meshes that enclose
    /// no volume (single sheets).
    pub fn with_surface_cells(&self, positions: &[DVec3], triangles: &[[u32; 3]]) -> Solid {
        let mut solid = self.solid.clone();
        for t in triangles {
            let (a, b, c) = (positions[t[0] as usize], positions[t[1] as usize], positions[t[2] as usize]);
            cover_samples(a, b, c, 0.5 * self.h, |p| {
                if let Some([x, y, z]) = self.cell_of(p) {
                    let idx = self.index(x, y, z);
                    solid.set(idx);
                }
            });
        }
        Solid::from_cells(self.origin, self.h, self.dims, solid)
    }
}

#[cfg(test)]
mod prefix_tests {
    use super::prefix_from;

    #[test]
    fn the_prefix_counts_solid_cells_and_shares_its_cursor_between_ends() {
        // A row of 40 cells with the maximal runs [3, 7), [9, 10),
        // [15, 31), [33, 40).
        let runs = [[3u32, 7], [9, 10], [15, 31], [33, 40]];
        let mut before = Vec::new();
        let mut acc = 0;
        for r in &runs {
            before.push(acc);
            acc += r[1] - r[0];
        }
        let solid = |j: usize| runs.iter().any(|r| (r[0] as usize) <= j && j < r[1] as usize);
        let brute = |x: f64| -> f64 {
            let x = x.clamp(0.0, 40.0);
            let i = x.floor() as usize;
            let whole = (0..i.min(40)).filter(|&j| solid(j)).count() as f64;
            whole + if i < 40 && solid(i) { x - i as f64 } else { 0.0 }
        };
        let xs = [-1.0, 0.0, 0.5, 3.0, 3.25, 6.99, 7.0, 8.5, 9.0, 9.5, 14.2, 15.0, 30.7, 33.0, 39.5, 40.0, 41.0];
        for (a, &x0) in xs.iter().enumerate() {
            for &x1 in &xs[a..] {
                let mut cur = 0;
                let p0 = prefix_from(&runs, &before, 40, x0, &mut cur);
                let p1 = prefix_from(&runs, &before, 40, x1, &mut cur);
                assert!((p0 - brute(x0)).abs() < 1e-12, "x0 {x0}: {p0} vs {}", brute(x0));
                assert!((p1 - brute(x1)).abs() < 1e-12, "x1 {x1} after {x0}: {p1} vs {}", brute(x1));
            }
        }
    }
}

#[cfg(test)]
mod cover_samples_tests {
    use super::*;

    #[test]
    fn samples_cover_the_triangle_and_a_sliver_costs_its_length() {
        let tris = [
            [DVec3::ZERO, DVec3::X, DVec3::Y],
            [DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0), DVec3::new(2.0, 0.002, 0.0)],
            [DVec3::new(0.3, -1.0, 0.5), DVec3::new(-0.7, 0.4, 1.0), DVec3::new(1.1, 0.9, -0.2)],
        ];
        let spacing = 0.05;
        for [a, b, c] in tris {
            let mut pts = Vec::new();
            cover_samples(a, b, c, spacing, |p| pts.push(p));
            let m = 200;
            for (_, _, x) in spherebake_geom::triangle::triangle_grid(a, b, c, m) {
                let d = pts.iter().map(|p| p.distance(x)).fold(f64::INFINITY, f64::min);
                assert!(d <= spacing, "{x} is {d} from the nearest sample");
            }
        }
        let mut n = 0;
        cover_samples(tris[1][0], tris[1][1], tris[1][2], spacing, |_| n += 1);
        assert!(n <= 2 * (2.0 / spacing) as usize + 4, "a sliver of length 2: {n} samples");
    }
}
