//! The fast lookup the optimiser uses on the voxel solid of the input.
//!
//! The solid itself — which cells are inside, by the one inside rule |w| ≥ ½ at cell centres —
//! is built by [`spherebake_geom::voxel`]; [`Solid`] wraps that grid with per-row run lists, so
//! the volume of ball ∩ solid is a sum over the rows inside the ball's disc of one difference of
//! two piecewise-linear prefix lookups: O((r/h)²) per evaluation and continuous in the centre.
//!
//! A closed mesh of few triangles (a box, a prism: [`exact_is_cheaper`]) is answered exactly
//! instead ([`Solid::set_exact_mesh`]): V(ball ∩ mesh) summed over every triangle, O(T) per
//! evaluation. Its spheres are many cells wide, so their rows cost more than its triangles: a
//! 12-triangle cube at 64 spheres evaluates about 6 times faster (measured in
//! `docs/benchmarks.md`). The exact volume is the same solid the voxel grid samples (a closed
//! outward mesh has w ∈ {0, 1}), without the grid's error.

use glam::DVec3;
use spherebake_format::quant::{ceil_f64, floor_f64};
use spherebake_geom::volume;
pub use spherebake_geom::voxel::Bits;
use spherebake_geom::voxel::VoxelGrid;
use std::sync::Arc;

/// What one triangle's term of the exact ball volume costs, in voxel rows of
/// [`Solid::ball_volume`] (measured on the unit cube at 64 spheres: the rows of its
/// ≈ 20-cell balls took 6 times as long as its 12 triangle terms, ≈ 17 rows per triangle).
pub const TRIANGLE_ROWS: f64 = 16.0;

/// Whether the exact volume of a closed mesh of `triangles` triangles is cheaper per evaluation
/// than the rows of a typical ball of a fit of `k` spheres to a solid of `solid_cells` cells:
/// `triangles` × [`TRIANGLE_ROWS`] ≤ π r², with r (cells) the radius of a ball of the solid's
/// volume over k. Deterministic (it reads counts only). The unit cube (12 triangles, 128³ cells)
/// qualifies up to 1000 spheres; 384 triangles need balls of r ≥ 44 cells (a sphere or two at
/// 128 voxels); the 70 000-triangle bunny never.
pub fn exact_is_cheaper(triangles: usize, solid_cells: usize, k: usize) -> bool {
    let r = (3.0 * solid_cells as f64 / (4.0 * std::f64::consts::PI * k.max(1) as f64)).cbrt();
    triangles as f64 * TRIANGLE_ROWS <= std::f64::consts::PI * r * r
}

/// Cap on [`Solid`]'s per-row prefix table, bytes (2 per entry, `dims[0] + 1` entries per
/// multi-run row): the bunny at 128 voxels needs well under 1 MiB; a solid of a million folded
/// 1024-cell rows would need 2 GiB and keeps the run walk instead.
pub const PREFIX_TABLE_BYTES: usize = 64 << 20;

/// A closed outward mesh: positions and triangles.
type ExactMesh = (Vec<DVec3>, Vec<[u32; 3]>);

/// Voxel solid on a regular grid (cell centres at `origin + (i + 0.5) h`): the geom grid and
/// its row runs.
#[derive(Clone, Debug)]
pub struct Solid {
    /// The solid cells (x fastest, set = cell centre inside), as [`spherebake_geom::voxel`]
    /// built them; also the inside test at any point ([`VoxelGrid::contains`]).
    pub grid: VoxelGrid,
    /// `grid.origin`.
    pub origin: DVec3,
    /// Cell edge length, model units (`grid.cell_size`).
    pub h: f64,
    /// `grid.dims`.
    pub dims: [usize; 3],
    /// Runs `[a, b)` of solid cells of the rows listed in `multi`, in that order; row n's runs
    /// are `runs[run_start[n]..run_start[n + 1]]`, with `run_before[r]` the solid cells of the
    /// row before run r (the prefix counts, exact): the fallback of `prefix` when that table
    /// would be too large.
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
    /// Per multi-run row n (in `multi` order), its prefix counts P(0..=dims[0]) at
    /// `prefix[n · (dims[0] + 1)..]` — the solid cells left of each cell boundary — so a chord
    /// end is one lookup instead of a walk of the row's runs. Empty when the table would pass
    /// [`PREFIX_TABLE_BYTES`] (a solid of very many folded rows); the runs answer then, with the
    /// same integers, so the same values.
    prefix: Vec<u16>,
    /// Number of solid cells.
    pub solid_count: usize,
    /// A closed outward mesh (positions, triangles) whose exact volume answers
    /// [`Solid::ball_volume`] instead of the rows ([`Solid::set_exact_mesh`]).
    exact: Option<Arc<ExactMesh>>,
}

impl Solid {
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// Whether the cell containing `p` is solid (false outside the grid).
    pub fn is_solid_at(&self, p: DVec3) -> bool {
        self.grid.is_solid_at(p)
    }

    /// Volume of the solid, units³.
    pub fn volume(&self) -> f64 {
        self.solid_count as f64 * self.h * self.h * self.h
    }

    /// Proxy of V(ball ∩ solid), units³: rows of cells through the disc, fractional ends; or,
    /// [`Solid::set_exact_mesh`], the exact V(ball ∩ mesh) (clamped to [0, V(ball)]).
    pub fn ball_volume(&self, c: DVec3, r: f64) -> f64 {
        self.ball_volume_rows::<false>(c, r, 0.0).unwrap_or(0.0)
    }

    /// Proxy outside volume of ball(c, r), V(ball) − [`Solid::ball_volume`] clamped at 0,
    /// units³ — or `None` when the rows read so far prove it is at least `limit`: the unread
    /// slabs' rows can hold at most their chords, and a slab's chords sum to at most its disc
    /// π w² (radius w cells) plus the trapezoid rule's two end terms (the chord is concave).
    /// Whenever it returns `Some`, the value is the one [`Solid::ball_volume`] gives (the same
    /// rows summed in the same order), so a search that only keeps values below its best
    /// decides the same with less work.
    pub fn outside_below(&self, c: DVec3, r: f64, limit: f64) -> Option<f64> {
        if limit <= 0.0 {
            return None;
        }
        if self.exact.is_some() || r <= 0.0 {
            return Some(self.outside(c, r));
        }
        // Inside volume (cells) the ball must reach for an outside volume below `limit`.
        let need = (volume::ball_volume_f64(r) - limit) / (self.h * self.h * self.h);
        self.ball_volume_rows::<true>(c, r, need).map(|inside| outside_of(r, inside))
    }

    /// Proxy outside volume of ball(c, r), units³: V(ball) − [`Solid::ball_volume`], at least 0.
    pub fn outside(&self, c: DVec3, r: f64) -> f64 {
        outside_of(r, self.ball_volume(c, r))
    }

    /// The rows' sum of [`Solid::ball_volume`]; with `BOUNDED`, `None` as soon as the slabs
    /// read and a bound on the rest show the inside volume stays below `need` cells.
    #[inline(always)]
    fn ball_volume_rows<const BOUNDED: bool>(&self, c: DVec3, r: f64, need: f64) -> Option<f64> {
        if r <= 0.0 {
            return Some(0.0);
        }
        if let Some(mesh) = &self.exact {
            let (pos, tris) = (&mesh.0, &mesh.1);
            let v: f64 = tris
                .iter()
                .map(|t| volume::triangle_ball_volume(c, r, pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]))
                .sum();
            return Some(v.clamp(0.0, volume::ball_volume_f64(r)));
        }
        let h = self.h;
        let nx = self.dims[0];
        let u = (c - self.origin) / h;
        let ru = r / h;
        let r2 = ru * ru;
        // Row centres at j + 0.5.
        let k0 = (ceil_f64(u.z - ru - 0.5).max(0.0)) as usize;
        let k1 = floor_f64(u.z + ru - 0.5);
        if k1 < 0.0 {
            return Some(0.0);
        }
        let k1 = (k1 as usize).min(self.dims[2].saturating_sub(1));
        let j0 = (ceil_f64(u.y - ru - 0.5).max(0.0)) as usize;
        let j1f = floor_f64(u.y + ru - 0.5);
        if j1f < 0.0 {
            return Some(0.0);
        }
        let j1 = (j1f as usize).min(self.dims[1].saturating_sub(1));
        let mut sum = 0.0;
        let ny = self.dims[1];
        let (j0f, j1f) = (j0 as f64, j1 as f64);
        // Indices below are less than a grid dimension (a u32 in the VoxelGrid), so they are
        // converted to and from f64 and f32 through u32: one instruction each, where a usize's
        // conversion takes a dozen on x86-64 without AVX-512; the same values.
        // Bounded: the most the unread slabs can add (cells). A slab's rows sample the chord
        // f(y) = 2 √(w² − y²) of its disc (radius w) at unit steps y_a..y_b; f is concave, so
        // the trapezoid rule under-reads its integral: Σ f(y_j) ≤ π w² + (f(y_a) + f(y_b)) / 2.
        let disc = |k: usize| {
            let dz = f64::from(k as u32) + 0.5 - u.z;
            let w2 = r2 - dz * dz;
            if w2 <= 0.0 {
                return 0.0;
            }
            let w = w2.sqrt();
            let ya = floor_f64(u.y - w - 0.5) + 1.0 + 0.5 - u.y;
            let yb = ceil_f64(u.y + w - 0.5) - 1.0 + 0.5 - u.y;
            if yb < ya {
                return 0.0;
            }
            let f = |y: f64| (w2 - y * y).max(0.0).sqrt();
            std::f64::consts::PI * w2 + f(ya) + f(yb)
        };
        // Each slab's bound is summed up front and subtracted once the slab is read: kept
        // here for up to DISCS slabs (balls of r < 64 cells) rather than computed twice (a
        // root, two floors and two more roots each), the same values in the same order, so the
        // same bound.
        const DISCS: usize = 128;
        let mut discs = [0.0f64; DISCS];
        let kept = BOUNDED && k1.saturating_sub(k0) < DISCS;
        let mut unread = 0.0;
        if BOUNDED {
            for k in k0..=k1 {
                let d = disc(k);
                if kept {
                    discs[k - k0] = d;
                }
                unread += d;
            }
        }
        for k in k0..=k1 {
            let dz = f64::from(k as u32) + 0.5 - u.z;
            let rem_z = r2 - dz * dz;
            if BOUNDED {
                // After this slab, the rest adds at most `unread` (checked with a margin for
                // rounding below).
                unread -= if kept { discs[k - k0] } else { disc(k) };
            }
            if rem_z <= 0.0 {
                continue;
            }
            // Rows j with (j + 0.5 − u.y)² < rem_z only.
            let w = rem_z.sqrt();
            let ja = (floor_f64(u.y - w - 0.5) + 1.0).max(j0f);
            let jb = (ceil_f64(u.y + w - 0.5) - 1.0).min(j1f);
            if jb < ja {
                continue;
            }
            // 0 ≤ ja ≤ jb ≤ j1 here.
            let (ja, jb) = (ja as u32 as usize, jb as u32 as usize);
            let lo = ja + ny * k;
            let spans = &self.span[lo..=jb + ny * k];
            // Branch-free over the rows (multi-run rows have span [0, 0] here and are added
            // from the prefix below).
            // f32 lanes (4 per SSE register): chord ends within 2⁻²⁴ × 1024 cells, far below
            // the proxy's own error; the slab sum is accumulated in f64.
            let y0 = (f64::from(ja as u32) + 0.5 - u.y) as f32;
            let (ux, rz) = (u.x as f32, rem_z as f32);
            // Row `n`, its offset from ja as an f32 (an integer below 2²⁴, so exact).
            let row = |n: f32, [a, b]: [f32; 2]| {
                let dy = y0 + n;
                let half = (rz - dy * dy).max(0.0).sqrt();
                ((ux + half).min(b) - (ux - half).max(a)).max(0.0)
            };
            // Eight independent lanes so the compiler vectorises (a single running f32 sum
            // cannot be reordered). The offsets are counted in f32 (`at`, exact), not converted
            // from the usize index per row: that conversion has no SSE2 vector form, so it was
            // done lane by lane, as much work as the rest of the row. (The chord's ends written
            // as compares instead of `min`/`max`, whose NaN fix-up costs 4 instructions per 4
            // lanes, vectorised worse: part of the lanes branch per row.)
            const LANE: [f32; 8] = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0];
            let mut lanes = [0.0f32; 8];
            let chunks = spans.chunks_exact(8);
            let rest = chunks.remainder();
            let mut at = LANE;
            for chunk in chunks {
                for ((lane, &sp), n) in lanes.iter_mut().zip(chunk).zip(&mut at) {
                    *lane += row(*n, sp);
                    *n += 8.0;
                }
            }
            let mut acc: f64 = lanes.iter().map(|&x| x as f64).sum();
            // The last rows (fewer than 8, 3.6 on average on the bunny) through the same lanes,
            // each still added to the f64 sum in order: the same values, at a vector step's
            // cost instead of a scalar row's each. The step reads the 8 spans from the first
            // of them on (the rows after them are computed and dropped), or, at the end of the
            // grid, a copy padded with empty spans.
            if !rest.is_empty() {
                let first = lo + spans.len() - rest.len();
                let pad: [[f32; 2]; 8];
                let tail: &[[f32; 2]; 8] = match self.span.get(first..first + 8).and_then(|t| t.try_into().ok()) {
                    Some(t) => t,
                    None => {
                        let mut p = [[0.0f32; 2]; 8];
                        p[..rest.len()].copy_from_slice(rest);
                        pad = p;
                        &pad
                    }
                };
                let mut last = [0.0f32; 8];
                for ((v, &sp), &n) in last.iter_mut().zip(tail).zip(&at) {
                    *v = row(n, sp);
                }
                for &v in &last[..rest.len()] {
                    acc += v as f64;
                }
            }
            sum += acc;
            let (ms, me) = (self.multi_start[k], self.multi_start[k + 1]);
            let multi = &self.multi[ms..me];
            let m0 = multi.partition_point(|&j| (j as usize) < ja);
            for (mi, &j) in multi.iter().enumerate().skip(m0) {
                if j as usize > jb {
                    break;
                }
                let dy = f64::from(j) + 0.5 - u.y;
                let rem = rem_z - dy * dy;
                if rem <= 0.0 {
                    continue;
                }
                let half = rem.sqrt();
                let n = ms + mi;
                if self.prefix.is_empty() {
                    let (r0, r1) = (self.run_start[n], self.run_start[n + 1]);
                    let (runs, before) = (&self.runs[r0..r1], &self.run_before[r0..r1]);
                    let mut cur = 0;
                    let x0 = prefix_from(runs, before, nx, u.x - half, &mut cur);
                    sum += prefix_from(runs, before, nx, u.x + half, &mut cur) - x0;
                } else {
                    let table = &self.prefix[n * (nx + 1)..(n + 1) * (nx + 1)];
                    sum += prefix_at(table, u.x + half) - prefix_at(table, u.x - half);
                }
            }
            if BOUNDED && (sum + unread.max(0.0)) * (1.0 + 1e-6) + 1e-6 < need {
                return None;
            }
        }
        Some(sum * h * h * h)
    }
}

/// V(ball of radius r) − `inside`, at least 0 (units³): the one formula of the proxy outside
/// volume, so [`Solid::outside`] and [`Solid::outside_below`] give the same bits.
fn outside_of(r: f64, inside: f64) -> f64 {
    (volume::ball_volume_f64(r) - inside).max(0.0)
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

/// [`prefix_from`] read from a row's full prefix table `p` (`p.len()` = cells + 1): the same
/// integers and the same interpolation, so bit-identical values.
#[inline]
fn prefix_at(p: &[u16], x: f64) -> f64 {
    let n = p.len() - 1;
    if x <= 0.0 {
        return 0.0;
    }
    if x >= n as f64 {
        return p[n] as f64;
    }
    // 0 < x < n < 2¹⁶: through u32, whose casts to and from f64 are one instruction each (a
    // usize's take a dozen on x86-64 without AVX-512); the same integer.
    let i = x as u32;
    let (a, b) = (p[i as usize] as f64, p[i as usize + 1] as f64);
    a + (x - i as f64) * (b - a)
}

impl Solid {
    /// The lookup of a grid of cells given directly (tests, baselines): `solid` has one bit per
    /// cell of `dims`, x fastest.
    pub fn from_cells(origin: DVec3, h: f64, dims: [usize; 3], solid: Bits) -> Solid {
        Solid::from_grid(VoxelGrid { origin, cell_size: h, dims: dims.map(|d| d as u32), solid, covered_twice: 0 })
    }

    /// Builds the row runs of the solid `grid` ([`spherebake_geom::voxel::voxelize_bvh`]).
    pub fn from_grid(grid: VoxelGrid) -> Solid {
        let (origin, h) = (grid.origin, grid.cell_size);
        let dims = grid.dims.map(|d| d as usize);
        let solid = &grid.solid;
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
        // Counts fit u16: a row has at most 1024 cells (geom::voxel's cap), checked here.
        let entries = multi_rows.len() * (nx + 1);
        let prefix = if entries * 2 <= PREFIX_TABLE_BYTES && nx < u16::MAX as usize {
            let mut prefix = Vec::with_capacity(entries);
            for &row in &multi_rows {
                let mut acc = 0u16;
                prefix.push(0);
                for i in 0..nx {
                    acc += u16::from(solid.get(row * nx + i));
                    prefix.push(acc);
                }
            }
            prefix
        } else {
            Vec::new()
        };
        Solid {
            grid,
            origin,
            h,
            dims,
            runs: runs_all,
            run_before,
            run_start,
            span,
            multi,
            multi_start,
            prefix,
            solid_count: count,
            exact: None,
        }
    }

    /// Makes [`Solid::ball_volume`] answer exactly over a closed, outward-oriented mesh (the
    /// one the grid was voxelized from; indices in range): Σ over every triangle of the signed
    /// volume of the cone from the centre over the triangle, cut by the ball
    /// ([`volume::triangle_ball_volume`]), which for a closed mesh is V(ball ∩ mesh) with no
    /// winding number needed. O(triangles) per evaluation: for small meshes only
    /// ([`exact_is_cheaper`]). The grid and its other queries are unchanged.
    pub fn set_exact_mesh(&mut self, positions: &[DVec3], triangles: &[[u32; 3]]) {
        self.exact = Some(Arc::new((positions.to_vec(), triangles.to_vec())));
    }

    /// Whether [`Solid::ball_volume`] is the exact volume ([`Solid::set_exact_mesh`]).
    pub fn is_exact(&self) -> bool {
        self.exact.is_some()
    }
}

#[cfg(test)]
mod exact_tests {
    use super::*;
    use std::f64::consts::PI;

    /// The unit cube [0, 1]³ as 12 outward triangles, and its voxel solid at 16 cells.
    fn cube() -> (Vec<DVec3>, Vec<[u32; 3]>, Solid) {
        let pos: Vec<DVec3> =
            (0..8).map(|i| DVec3::new((i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2 & 1) as f64)).collect();
        // Faces as quads (outward, counter-clockwise), split into two triangles each.
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let tris = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
        let n = 16;
        let mut cells = Bits::new(n * n * n);
        (0..n * n * n).for_each(|i| cells.set(i));
        let solid = Solid::from_cells(DVec3::ZERO, 1.0 / n as f64, [n; 3], cells);
        (pos, tris, solid)
    }

    #[test]
    fn the_exact_ball_volume_of_a_cube_is_the_analytic_one() {
        let (pos, tris, rows) = cube();
        let mut exact = rows.clone();
        exact.set_exact_mesh(&pos, &tris);
        assert!(exact.is_exact() && !rows.is_exact());
        let ball = |r: f64| 4.0 / 3.0 * PI * r * r * r;
        let r = 0.3;
        // Inside; centred on a face, an edge, a corner (the cube cuts a half, a quarter, an
        // eighth); a ball holding the whole cube; a ball beside it.
        let cases = [
            (DVec3::splat(0.5), ball(r)),
            (DVec3::new(0.5, 0.5, 0.0), ball(r) / 2.0),
            (DVec3::new(0.5, 0.0, 0.0), ball(r) / 4.0),
            (DVec3::ZERO, ball(r) / 8.0),
            (DVec3::new(1.0, 1.0, 1.0), ball(r) / 8.0),
        ];
        for (c, want) in cases {
            let got = exact.ball_volume(c, r);
            assert!((got - want).abs() < 1e-12, "centre {c}: {got} vs {want}");
        }
        assert!((exact.ball_volume(DVec3::splat(0.5), 0.9) - 1.0).abs() < 1e-12);
        assert_eq!(exact.ball_volume(DVec3::new(3.0, 0.5, 0.5), 0.5), 0.0);
        assert_eq!(exact.ball_volume(DVec3::splat(0.5), 0.0), 0.0);
        // The rows agree within the grid's error (16 cells: a few per cent of the ball) at
        // random balls; the grid is unchanged.
        let mut rng = spherebake_geom::rng::SplitMix64::new(7);
        for _ in 0..200 {
            let c = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 1.4 - 0.2;
            let r = 0.1 + 0.4 * rng.next_f64();
            let (e, v) = (exact.ball_volume(c, r), rows.ball_volume(c, r));
            assert!((e - v).abs() <= 0.08 * ball(r), "c {c} r {r}: exact {e}, rows {v}");
        }
        assert_eq!(exact.solid_count, rows.solid_count);
    }

    #[test]
    fn the_exact_volume_is_chosen_when_its_triangles_cost_less_than_a_balls_rows() {
        // The unit cube at 128 cells (2.1 M solid cells): a ball of 1/64 of it has r ≈ 19.8
        // cells, 1237 rows against 12 × 16 = 192; at 1024 spheres r ≈ 7.9 cells, 194 rows.
        let cube = 128usize.pow(3);
        assert!(exact_is_cheaper(12, cube, 64));
        assert!(exact_is_cheaper(12, cube, 1000));
        assert!(!exact_is_cheaper(12, cube, 1100));
        // 384 triangles (the capsule fixture) need r ≥ 44.2 cells, a ball of 362 000 cells.
        assert!(exact_is_cheaper(384, 400_000, 1));
        assert!(!exact_is_cheaper(384, 400_000, 2));
        // The bunny (70 000 triangles) never.
        assert!(!exact_is_cheaper(70_000, cube, 1));
    }
}

#[cfg(test)]
mod prefix_tests {
    use super::{prefix_at, prefix_from, Solid};
    use glam::DVec3;

    /// A folded solid of 23 × 17 × 19 cells: a spherical shell with a lattice of holes
    /// and specks, so most rows hold several runs.
    fn folded() -> ([usize; 3], super::Bits) {
        let dims = [23usize, 17, 19];
        let n = dims[0] * dims[1] * dims[2];
        let c = DVec3::new(11.5, 8.5, 9.5);
        let cells = (0..n)
            .map(|idx| {
                let (i, j, k) = (idx % dims[0], (idx / dims[0]) % dims[1], idx / (dims[0] * dims[1]));
                let d = DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5).distance(c);
                (4.0..7.0).contains(&d) || (i * 7 + j * 3 + k) % 11 == 0
            })
            .collect();
        (dims, cells)
    }

    #[test]
    fn the_prefix_table_and_the_run_walk_answer_the_same_bits() {
        // A folded solid (a shell with holes: most rows hold several runs); the table path
        // against the run walk it replaces when the table would be too large. Each is checked
        // against brute force in tests/ball_volume.rs (the table is the path taken there).
        let (dims, cells) = folded();
        let table = Solid::from_cells(DVec3::new(-2.0, 1.0, 0.5), 0.3, dims, cells);
        assert!(!table.multi.is_empty() && table.prefix.len() == table.multi.len() * (dims[0] + 1));
        let walk = Solid { prefix: Vec::new(), ..table.clone() };
        for a in 0..400u32 {
            let t = |m: u32| ((a * m) % 97) as f64 / 97.0;
            let c = table.origin + DVec3::new(t(13), t(29), t(53)) * 8.0 - 1.0;
            let r = 0.2 + 5.0 * t(71);
            assert_eq!(table.ball_volume(c, r).to_bits(), walk.ball_volume(c, r).to_bits(), "c {c} r {r}");
        }
    }

    #[test]
    fn outside_below_gives_the_outside_volume_or_proves_it_is_not_below_the_limit() {
        // Two solids: a folded shell (most rows several runs) and a full block (every row
        // wholly inside each chord, where the bound on the unread slabs is tightest: the rows
        // hold exactly their chords). The reference is V(ball) − ball_volume.
        let (dims, folded) = folded();
        let full: super::Bits = (0..dims.iter().product::<usize>()).map(|_| true).collect();
        let (mut some, mut none) = (0, 0);
        for cells in [folded, full] {
            let solid = Solid::from_cells(DVec3::new(-2.0, 1.0, 0.5), 0.3, dims, cells);
            for a in 0..300u32 {
                let t = |m: u32| ((a * m) % 97) as f64 / 97.0;
                // Centres inside the block, radii up to 2.1 (7 cells) so balls stay inside.
                let c = solid.origin + DVec3::new(2.6 + 1.7 * t(13), 2.6 + 0.5 * t(29), 2.6 + 0.5 * t(53));
                let r = 0.2 + 1.9 * t(71);
                let truth = (spherebake_geom::volume::ball_volume_f64(r) - solid.ball_volume(c, r)).max(0.0);
                for f in [0.25, 0.9, 0.999, 1.000_001, 1.01, 2.0] {
                    let limit = truth * f + if f > 1.0 { 1e-12 } else { 0.0 };
                    match solid.outside_below(c, r, limit) {
                        Some(v) => {
                            assert_eq!(v.to_bits(), truth.to_bits(), "c {c} r {r}");
                            some += 1;
                        }
                        None => {
                            assert!(truth >= limit, "c {c} r {r}: {truth} < limit {limit} but rejected");
                            none += 1;
                        }
                    }
                }
            }
        }
        // Both answers occur (the bound does cut evaluations short).
        assert!(some > 100 && none > 100, "some {some} none {none}");
    }

    #[test]
    fn the_prefix_table_lookup_interpolates_within_a_cell_and_clamps_at_the_ends() {
        // Row of 5 cells, solid 1, 2, 4: P = [0, 0, 1, 2, 2, 3].
        let p = [0u16, 0, 1, 2, 2, 3];
        for (x, want) in [
            (-1.0, 0.0),
            (0.0, 0.0),
            (0.5, 0.0),
            (1.25, 0.25),
            (2.5, 1.5),
            (3.9, 2.0),
            (4.5, 2.5),
            (5.0, 3.0),
            (9.0, 3.0),
        ] {
            assert_eq!(prefix_at(&p, x), want, "x {x}");
        }
    }

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
mod rows_tests {
    use super::{outside_of, Bits, Solid};
    use glam::DVec3;
    use spherebake_format::quant::{ceil_f64, floor_f64};
    use spherebake_geom::rng::SplitMix64;

    /// The rows' sum as [`Solid::ball_volume`] read it before its lanes counted their rows in
    /// f32 and its last rows went through a vector step: each row's offset converted from its
    /// index, rows 8n + l into lane l, the rows after the last 8 added one by one, and the
    /// multi-run rows' prefix read at ⌊x⌋ from the table.
    fn reference(s: &Solid, c: DVec3, r: f64) -> f64 {
        if r <= 0.0 {
            return 0.0;
        }
        let (h, nx, ny) = (s.h, s.dims[0], s.dims[1]);
        let u = (c - s.origin) / h;
        let ru = r / h;
        let r2 = ru * ru;
        let k0 = (ceil_f64(u.z - ru - 0.5).max(0.0)) as usize;
        let k1 = floor_f64(u.z + ru - 0.5);
        let j0 = (ceil_f64(u.y - ru - 0.5).max(0.0)) as usize;
        let j1 = floor_f64(u.y + ru - 0.5);
        if k1 < 0.0 || j1 < 0.0 {
            return 0.0;
        }
        let (k1, j1) = ((k1 as usize).min(s.dims[2] - 1), (j1 as usize).min(ny - 1));
        let lookup = |p: &[u16], x: f64| -> f64 {
            let x = x.clamp(0.0, nx as f64);
            let i = (x.floor() as usize).min(nx - 1);
            let (a, b) = (p[i] as f64, p[i + 1] as f64);
            a + (x - i as f64) * (b - a)
        };
        let mut sum = 0.0;
        for k in k0..=k1 {
            let dz = k as f64 + 0.5 - u.z;
            let rem_z = r2 - dz * dz;
            if rem_z <= 0.0 {
                continue;
            }
            let w = rem_z.sqrt();
            let ja = (floor_f64(u.y - w - 0.5) + 1.0).max(j0 as f64) as usize;
            let jb = (ceil_f64(u.y + w - 0.5) - 1.0).min(j1 as f64);
            if jb < ja as f64 {
                continue;
            }
            let jb = jb as usize;
            let spans = &s.span[ja + ny * k..=jb + ny * k];
            let (y0, ux, rz) = ((ja as f64 + 0.5 - u.y) as f32, u.x as f32, rem_z as f32);
            let chord = |n: usize| {
                let [a, b] = spans[n];
                let dy = y0 + n as f32;
                let half = (rz - dy * dy).max(0.0).sqrt();
                ((ux + half).min(b) - (ux - half).max(a)).max(0.0)
            };
            let full = spans.len() / 8 * 8;
            let mut lanes = [0.0f32; 8];
            for n in 0..full {
                lanes[n % 8] += chord(n);
            }
            let mut acc = 0.0;
            for lane in lanes {
                acc += lane as f64;
            }
            for n in full..spans.len() {
                acc += chord(n) as f64;
            }
            sum += acc;
            for n in s.multi_start[k]..s.multi_start[k + 1] {
                let j = s.multi[n] as usize;
                let dy = j as f64 + 0.5 - u.y;
                let rem = rem_z - dy * dy;
                if j < ja || j > jb || rem <= 0.0 {
                    continue;
                }
                let half = rem.sqrt();
                let p = &s.prefix[n * (nx + 1)..(n + 1) * (nx + 1)];
                sum += lookup(p, u.x + half) - lookup(p, u.x - half);
            }
        }
        sum * h * h * h
    }

    #[test]
    fn the_rows_sum_is_the_reference_sum_to_the_bit() {
        // Random solids of cells (blobs of runs: single-run, multi-run and empty rows), one of
        // them 300 slabs deep so a ball spans more slabs than the bound keeps (r > 64 cells);
        // balls anywhere around them, many at the grid's far corner (the last rows of the last
        // slab, read from a padded copy) and beyond it.
        let mut rng = SplitMix64::new(55);
        for (case, dims) in [[23usize, 17, 19], [40, 31, 12], [9, 13, 300], [1, 1, 1]].into_iter().enumerate() {
            let n = dims.iter().product::<usize>();
            let fill = 0.2 + 0.7 * rng.next_f64();
            let cells: Bits = (0..n).map(|i| i % 7 == 0 || rng.next_f64() < fill).collect();
            let h = 0.1 + rng.next_f64();
            let s = Solid::from_cells(DVec3::new(-1.0, 2.0, 0.5), h, dims, cells);
            assert!(!s.prefix.is_empty() || s.multi.is_empty());
            let size = DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64) * h;
            for t in 0..600 {
                let f = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
                let f = if t % 3 == 0 { DVec3::ONE - f * 0.2 } else { f * 1.4 - 0.2 };
                let c = s.origin + f * size;
                let r = rng.next_f64() * rng.next_f64() * size.max_element() * 0.8;
                let want = reference(&s, c, r);
                assert_eq!(s.ball_volume(c, r).to_bits(), want.to_bits(), "case {case}: c {c} r {r}");
                let truth = outside_of(r, want);
                for limit in [truth * 0.5, truth, truth * 1.001 + 1e-12, f64::INFINITY] {
                    match s.outside_below(c, r, limit) {
                        Some(v) => assert_eq!(v.to_bits(), truth.to_bits(), "case {case}: c {c} r {r}"),
                        None => assert!(truth >= limit, "case {case}: c {c} r {r}: {truth} < {limit}"),
                    }
                }
            }
        }
    }
}
