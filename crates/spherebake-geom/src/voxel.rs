//! The solid of a triangle soup: the one definition of inside, and its voxelization.
//!
//! **Inside** ([`inside`]). A point p is inside when the winding number of the triangles at p
//! has |w(p)| ≥ ½. For a closed surface w is the integer count of signed crossings of any ray
//! from p to infinity; for an open soup it is the generalized winding number
//! ([`crate::winding`], Σ signed solid angles / 4π). Every stage of a bake asks this one rule:
//! the voxel solid here (at cell centres: the fit's energy, E of open meshes, its lattice
//! points), [`VoxelGrid::contains`] (at any point: the fit's pocket check), and
//! [`crate::orient`] (which side of a triangle has the larger |w|: samples, albedo).
//!
//! Why |w| ≥ ½, and not w ≥ ½ or ray parity:
//! - **orientation**: a mesh wound inside out gives w = −1 inside; with |w| it has the same
//!   solid as its correctly wound twin, whether it is closed or open (an inward-wound open mesh
//!   is not "everything outside");
//! - **holes**: w falls off smoothly near a hole (≈ 1 − Ω_hole/4π), so ½ reads "more than half
//!   enclosed": cells deep inside stay solid, only cells near the missing patch change. Parity
//!   flips the whole rest of every row through a hole, which is why it needed a vote of three
//!   axes;
//! - **duplicated triangles / overlapping parts**: w = 2 in doubled regions, still solid
//!   (parity calls the overlap of two closed parts outside);
//! - **partly flipped parts** that overlap a correctly wound part cancel (w = 0) in the overlap:
//!   the one case |w| cannot fix without repairing the mesh first (which [`crate::orient`] does:
//!   the bake hands the fit the outward-oriented triangles);
//! - **open sheets** (a single plane) enclose nothing: the solid is empty.
//!
//! **Cells the surface passes through are not solid for that reason**: a cell is solid exactly when
//! its centre is inside (for an open soup, a cell the rows leave undecided also needs its part of
//! the solid to reach the surface: see "Which undecided cells are evaluated" below; a cell the rows
//! decide is solid by its centre alone). The centre rule samples the definition without bias: where
//! the surface cuts a cell, the part of the cell inside and the part outside trade places, and the
//! solid volume converges to V(T) with errors of both signs that largely cancel (the closed
//! armadillo at 128 cells: +0.02 % of its exact volume, while the cells the surface cuts hold 28 %
//! of it; `tests/voxel_models.rs`). Counting every cut cell as solid instead adds about half of
//! that layer over the whole surface (the armadillo: +14.5 %), which would shrink E of open meshes
//! for no better fit and bias the fit's energy outward on every mesh. The surface itself is bounded
//! by the fit's rule 1 (every triangle inside a sphere), not through the solid. A soup that
//! encloses nothing has an empty solid; a caller that still needs one (the fit, for sheets) takes
//! [`surface_cells`], the layer of cells whose closed box meets a triangle.
//!
//! **Grid.** Cubic cells of edge h = (longest bounding-box extent) / resolution; the origin is
//! lo − 1.0137 h (the irregular offset keeps axis-aligned input faces off the cell-centre
//! lattice and off the ray rows below) and dims = ⌈(hi − origin) / h⌉ + 2, so the mesh has at
//! least one empty cell around it (resolution + 4 cells along the longest axis). Bits, x fastest.
//!
//! **Method.** w at the cell centres comes from axis-aligned rays first: for each row of cell
//! centres along x (and, when needed, y and z), the signed crossings of the row's line with the
//! triangles (+1 leaving through the front side, −1 entering) by the watertight test of
//! [`crate::bvh`] (Woop, Benthin, Wald), evaluated on each triangle for the rows its projection
//! covers: O(triangles + crossings) per axis, no tree walk, and a line through a shared edge
//! hits both triangles (never slips between them). A row whose crossings sum to zero (it misses
//! every hole) gives each of its points the integer w = Σ crossings ahead of it, exact for a
//! closed mesh; a row that passes through a hole (non-zero sum) or touches an edge or vertex
//! exactly (a crossing could count twice) abstains. Then, per cell:
//! - **closed** soup (every directed edge has exactly one reverse partner, [`is_closed`]): the
//!   first conclusive row of x, y, z decides (y and z rows are cast only if some x row
//!   abstains);
//! - **open** soup: the conclusive rows must number at least 2 and agree, since a row can pass
//!   through two holes without a net crossing;
//! - otherwise (near holes, open sheets, grazing rows, disagreement) the hierarchical
//!   generalized winding number at the centre decides ([`crate::winding`], built only when a
//!   cell is left undecided, so a closed mesh without grazing rows never builds it).
//!
//! **Which undecided cells are evaluated.** A closed soup's undecided cells are the few on grazing
//! rows: every one is. An open soup's can be nearly all of them (every row through a sheet
//! abstains), so only the undecided cells a flood reaches are evaluated and the rest are outside:
//! it starts at the undecided cells the surface passes through ([`surface_cells`]) or that touch
//! (26 neighbours) a cell the rows made solid, and spreads from each cell found inside to its
//! undecided neighbours. Exact in the continuum: away from the triangles w is harmonic, and on a
//! connected part of {|w| ≥ ½} w has one sign, so |w| = ±w is harmonic there too; by the maximum
//! principle every such part has a triangle in its closure (a part without one would have |w| = ½
//! on its boundary and more inside, or reach infinity, where w → 0). On the grid a part is dropped
//! only when its cells reach the surface through a neck thinner than a cell: 50 large random
//! triangles at 128 cells lost 17 of 717 000 solid cells (w from −0.500 to −0.511); none of the
//! shared models lost any (same files). So for an open soup the solid is the 26-connected parts of
//! the cells whose centre is inside that hold a cell the surface passes through or one the rows
//! decided (`flood_tests` checks this against a brute-force labelling). The seeds' surface test is
//! [`surface_cells`] when there are at least as many undecided cells as triangles, else a tree
//! query per undecided cell (a large mesh with a few big holes: the bunny subdivided to 1.1 M
//! triangles with its top fifth cut off voxelizes in 0.9 s as before, where listing all its surface
//! cells cost 1.4 s). Cost: a bush of 1 000 random cards (2 000 triangles) evaluates 593 000 of its
//! 1.65 M undecided cells, 16–17 → 7–7.6 s on one thread; where the surface and the solid fill the
//! grid (10 000 denser cards, large random triangles) it saves little.
//!
//! **Blocks.** The flood asks whole regions of an open soup, and a cell's winding number costs
//! most where large triangles are near (every leaf the cell is not far from is summed exactly:
//! Khronos' 254-triangle BoxAnimated evaluated 1.45 M cells at about 5 µs each). So a cell is
//! first looked up in blocks of 4 and then 2 cells a side, each decided at most once ([`Blocks`]):
//! away from the triangles ∇w is the Biot–Savart field of the soup's unpaired edges (paired edges
//! cancel), so on a block that meets no triangle |w − w(centre)| ≤ (1/4π) Σ_e |m_e| len_e / d_e²
//! · R, and a block whose centre's w is farther than that (plus a margin of 0.02, five times the
//! fast evaluation's largest measured error) from ½ is inside or outside whole. The rest (blocks
//! meeting the surface or near a hole's edge) fall to the next level and at last to the cell's
//! own evaluation. BoxAnimated: 356 000 cells evaluated instead of 1.45 M, its `fast` bake 14.4
//! → 10.1 s of CPU on one thread; every shared model gives the same solid. Cost per block tried:
//! one tree query, one term per cluster of 16 unpaired edges (edge by edge near it) and one
//! winding number. Not used where unpaired edges outnumber the triangles (a bush of cards: nearly
//! every block is near a card's edge, and trying them cost 7.0 → 8.0 s) or exceed 16 384.
//!
//! Cost model (T triangles, n cells per axis, N = n³ cells): O(T + crossings) per axis of rows; N
//! votes (one incremental walk per x row, two binary searches per cell for open soups); the winding
//! expansions O(T log T) plus O(log T)-ish per evaluated undecided cell (bunny, open, res 128: 0.3
//! % of the cells), and for an open soup's flood its surface cells (listed, at O(cells each
//! triangle meets), or one tree query per undecided cell, whichever is fewer). Memory: 2 bits per
//! cell (solid, undecided; 256 MB at 1024³) plus, while the rows are built, ~45 bytes per crossing
//! and 9 per row, and during an open soup's flood 2–3 bits per cell (cells queued, cells found,
//! surface cells when listed, which also take 4 bytes per cell a triangle meets while they are
//! found), 4 bytes per cell of the current frontier (each cell joins one frontier at most) and,
//! where the blocks are used, a byte per block of 2³ and of 4³ cells (1.1 bits per cell: 150 MB
//! at 1024³).
//! Parallel (rayon) over triangles, over blocks of cells and over each frontier; every cell's
//! result depends only on shared read-only data, the crossings are sorted by value and the
//! frontiers are built in one order, so the output is identical for any thread count.

use crate::bvh::{RayPre, TriangleBvh};
use crate::edges;
use crate::triangle::cover_samples;
use crate::winding::Expansions;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
#[cfg(test)]
use std::sync::atomic::AtomicUsize;
use std::sync::atomic::{AtomicU8, Ordering};

/// A point is inside when |w| is at least this (see the module docs).
pub const INSIDE_WINDING: f64 = 0.5;

/// The one definition of inside: |`winding_number`| ≥ ½ (NaN is outside).
#[inline]
pub fn inside(winding_number: f64) -> bool {
    winding_number.abs() >= INSIDE_WINDING
}

/// A fixed-length bit vector (one bit per voxel cell: 128 MB at 1024³ instead of 1 GB).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Bits {
    words: Vec<u64>,
    len: usize,
}

impl Bits {
    /// `len` bits, all clear.
    pub fn new(len: usize) -> Self {
        Bits { words: vec![0; len.div_ceil(64)], len }
    }
    /// Bit `i`. Precondition: `i < len` (checked in debug builds; beyond the last word panics).
    #[inline]
    pub fn get(&self, i: usize) -> bool {
        debug_assert!(i < self.len);
        self.words[i >> 6] >> (i & 63) & 1 == 1
    }
    /// Sets bit `i`. Precondition: `i < len`.
    #[inline]
    pub fn set(&mut self, i: usize) {
        debug_assert!(i < self.len);
        self.words[i >> 6] |= 1 << (i & 63);
    }
    /// Clears bit `i`. Precondition: `i < len`.
    #[inline]
    pub fn clear(&mut self, i: usize) {
        debug_assert!(i < self.len);
        self.words[i >> 6] &= !(1 << (i & 63));
    }
    /// Calls `f` with the index of every set bit in `range`, ascending: a word at a time, so a
    /// sparse range costs about its length / 64.
    #[inline]
    pub fn for_each_one_in(&self, range: std::ops::Range<usize>, mut f: impl FnMut(usize)) {
        if range.start >= range.end {
            return;
        }
        debug_assert!(range.end <= self.len);
        let (first, last) = (range.start >> 6, (range.end - 1) >> 6);
        for w in first..=last {
            let mut x = self.words[w];
            if w == first {
                x &= !0 << (range.start & 63);
            }
            if w == last {
                x &= !0 >> (63 - ((range.end - 1) & 63));
            }
            while x != 0 {
                f(w * 64 + x.trailing_zeros() as usize);
                x &= x - 1;
            }
        }
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
    /// Number of bits set in `self` and not in `other` (same length).
    pub fn count_and_not(&self, other: &Bits) -> usize {
        self.words.iter().zip(&other.words).map(|(a, b)| (a & !b).count_ones() as usize).sum()
    }
    /// Indices of the set bits, ascending.
    pub fn ones(&self) -> impl Iterator<Item = usize> + '_ {
        block_ones(&self.words, 0)
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

/// Voxelization settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VoxelSettings {
    /// Cells along the longest axis of the mesh bounding box (the grid adds up to 4 empty cells
    /// around it). Default 128, valid 1..=1024 (clamped); memory is 1 bit per cell.
    pub resolution: u32,
}

impl Default for VoxelSettings {
    fn default() -> Self {
        VoxelSettings { resolution: 128 }
    }
}

/// Solid state of the 3×3×3 block of cells around a point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Neighbourhood {
    AllSolid,
    NoneSolid,
    Mixed,
}

/// Most cells [`VoxelGrid::boundary_share`] looks at.
pub const BOUNDARY_SHARE_PROBES: usize = 1 << 18;

/// Divisions per edge [`VoxelGrid::holds_triangle`] reads a triangle at at most (a triangle
/// longer than 64 cells is not read, and so not held).
pub const HOLDS_MAX_DIVISIONS: usize = 64;

/// A solid voxel grid (cubic cells, x fastest): cell (i, j, k) is solid when its centre is
/// inside (see the module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VoxelGrid {
    /// Minimum corner of cell (0, 0, 0), model space.
    pub origin: DVec3,
    /// Edge length of the cubic cells, model units.
    pub cell_size: f64,
    /// Cells per axis; `[0, 0, 0]` when the mesh has no valid triangle.
    pub dims: [u32; 3],
    /// One bit per cell, x fastest: the cell's centre is inside.
    pub solid: Bits,
    /// Cells of a closed soup whose centre the rows find inside twice or more (|w| ≥ 2): closed
    /// parts that overlap, or a surface that passes through itself. There the union is solid
    /// once, but the mesh's signed volume and any integral of w count it twice. 0 for open
    /// soups (their w is not an integer count).
    pub covered_twice: usize,
}

impl VoxelGrid {
    /// Number of cells.
    pub fn cell_count(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }

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

    /// The cell containing `p` (half-open cells), if inside the grid.
    pub fn cell_of(&self, p: DVec3) -> Option<[u32; 3]> {
        let u = (p - self.origin) / self.cell_size;
        let mut out = [0u32; 3];
        for a in 0..3 {
            // Without a floor (the fit's pocket checks call this per poll): for an integer d,
            // ⌊u⌋ ∈ [0, d) exactly when u ∈ [0, d) (NaN in neither), and there ⌊u⌋ is the
            // truncating cast.
            let v = u[a];
            if !(v >= 0.0 && v < f64::from(self.dims[a])) {
                return None;
            }
            out[a] = v as u32;
        }
        Some(out)
    }

    /// Whether the cell containing `p` is solid (false outside the grid).
    pub fn is_solid_at(&self, p: DVec3) -> bool {
        self.cell_of(p).is_some_and(|[i, j, k]| self.solid.get(self.index(i, j, k)))
    }

    /// Classifies the 3×3×3 block of cells around `p` (cells outside the grid count as empty; a
    /// non-finite `p` is [`Neighbourhood::NoneSolid`]).
    pub fn neighbourhood(&self, p: DVec3) -> Neighbourhood {
        if !p.is_finite() {
            return Neighbourhood::NoneSolid;
        }
        let u = ((p - self.origin) / self.cell_size).floor();
        let mut n_solid = 0;
        for dk in -1..=1 {
            for dj in -1..=1 {
                for di in -1..=1 {
                    let c = [u.x + di as f64, u.y + dj as f64, u.z + dk as f64];
                    if (0..3).all(|a| c[a] >= 0.0 && c[a] < self.dims[a] as f64)
                        && self.solid.get(self.index(c[0] as u32, c[1] as u32, c[2] as u32))
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

    /// The inside test at any point `p`, for the same triangles the grid was built from: read
    /// off the grid where the 3×3×3 block of cells around `p` agrees (all solid: inside; none:
    /// outside), else [`inside`]`(winding_number(p))`, with `winding_number` evaluating those
    /// triangles' winding number (brute force or hierarchical). The grid answers only away
    /// from the surface, where cell centres and the point agree unless a feature thinner than
    /// a cell passes between them.
    pub fn contains(&self, p: DVec3, winding_number: impl FnOnce(DVec3) -> f64) -> bool {
        match self.neighbourhood(p) {
            Neighbourhood::AllSolid => true,
            Neighbourhood::NoneSolid => false,
            Neighbourhood::Mixed => inside(winding_number(p)),
        }
    }

    /// Whether the grid alone reads the whole triangle (a, b, c) inside: every point of it lies
    /// in the all-solid 3×3×3 block ([`Neighbourhood::AllSolid`]) of one of its sample points,
    /// so in solid cells, away from the solid's boundary. The samples are the corners, then a
    /// barycentric grid of spacing at most one cell (any point of a grid's small triangle is
    /// within its longest edge, at most a cell, of each of its corners, so within the block of
    /// a corner's cell). A triangle wanting more than [`HOLDS_MAX_DIVISIONS`] divisions, or
    /// with a non-finite corner, is not read (false), so the cost is bounded: at most the
    /// corners on a triangle at the boundary, O(area / cell²) blocks on one inside.
    ///
    /// Such triangles are inner faces of the solid (the faces between touching or overlapping
    /// parts: a voxel model exported as one cube per voxel, a character's limb pushed into its
    /// body); they bound nothing.
    pub fn holds_triangle(&self, a: DVec3, b: DVec3, c: DVec3) -> bool {
        let all = |p: DVec3| self.neighbourhood(p) == Neighbourhood::AllSolid;
        if !(all(a) && all(b) && all(c)) {
            return false;
        }
        let longest = a.distance(b).max(b.distance(c)).max(c.distance(a));
        let m = (longest / self.cell_size).ceil();
        // Finite: the corners' blocks were read, so the corners are finite.
        if m > HOLDS_MAX_DIVISIONS as f64 {
            return false;
        }
        m < 2.0 || crate::triangle::triangle_grid(a, b, c, m as usize).all(|(_, _, p)| all(p))
    }

    /// Number of solid cells.
    pub fn solid_count(&self) -> usize {
        self.solid.count_ones()
    }

    /// Solid volume: solid cells × cell_size³ (model units³).
    pub fn volume(&self) -> f64 {
        self.solid_count() as f64 * self.cell_size.powi(3)
    }

    /// Cell (i, j, k) of linear index `idx`. Precondition: `idx < cell_count()`.
    fn cell_coords(&self, idx: usize) -> [u32; 3] {
        let (nx, ny) = (self.dims[0] as usize, self.dims[1] as usize);
        let (i, r) = (idx % nx, idx / nx);
        [i as u32, (r % ny) as u32, (r / ny) as u32]
    }

    /// Whether the neighbour of cell `c` across its face on `axis` (the + side when
    /// `positive`) is solid; cells outside the grid are not.
    fn face_neighbour_solid(&self, c: [u32; 3], axis: usize, positive: bool) -> bool {
        let mut nb = c;
        if positive {
            nb[axis] += 1;
            if nb[axis] >= self.dims[axis] {
                return false;
            }
        } else if nb[axis] == 0 {
            return false;
        } else {
            nb[axis] -= 1;
        }
        self.solid.get(self.index(nb[0], nb[1], nb[2]))
    }

    /// The grid of `block`³-cell blocks (same origin, cells `block` times as wide, dims rounded
    /// up): a block is solid when at least `min_solid` of its cells are (clamped to
    /// 1..=`block`³; cells past the fine grid's edge count as empty). A sampling of this solid,
    /// not a second solid: every block is decided by the cells it holds. `covered_twice` is 0.
    /// `block` 1 is a copy. Cost O(cells).
    pub fn coarsened(&self, block: u32, min_solid: u32) -> VoxelGrid {
        let b = block.max(1);
        let min_solid = min_solid.clamp(1, b * b * b);
        let dims = self.dims.map(|d| d.div_ceil(b));
        let (nx, ny) = (dims[0] as usize, dims[1] as usize);
        let mut count = vec![0u32; dims.iter().map(|&d| d as usize).product()];
        for k in 0..self.dims[2] {
            for j in 0..self.dims[1] {
                let row = (j / b) as usize * nx + (k / b) as usize * nx * ny;
                let base = self.index(0, j, k);
                for i in 0..self.dims[0] {
                    if self.solid.get(base + i as usize) {
                        count[row + (i / b) as usize] += 1;
                    }
                }
            }
        }
        VoxelGrid {
            origin: self.origin,
            cell_size: self.cell_size * b as f64,
            dims,
            solid: count.iter().map(|&c| c >= min_solid).collect(),
            covered_twice: 0,
        }
    }

    /// Share of the solid cells that lie on the solid's boundary (at least one of their six
    /// face neighbours empty or outside the grid); 0 for an empty solid. Exact when the grid
    /// has at most [`BOUNDARY_SHARE_PROBES`] cells, else estimated from that many cells drawn
    /// at random (a fixed seed: deterministic; a regular stride aliases with the rows). A slab
    /// t cells thick has 2 / t of its cells there, a solid ball of radius R cells about 3 / R.
    /// Cost: O(min(cells, probes)).
    pub fn boundary_share(&self) -> f64 {
        let n = self.cell_count();
        let on_boundary = |idx: usize| {
            let c = self.cell_coords(idx);
            (0..3).any(|axis| [false, true].iter().any(|&p| !self.face_neighbour_solid(c, axis, p)))
        };
        let (mut solid, mut boundary) = (0usize, 0usize);
        let mut probe = |idx: usize| {
            if self.solid.get(idx) {
                solid += 1;
                boundary += on_boundary(idx) as usize;
            }
        };
        if n <= BOUNDARY_SHARE_PROBES {
            (0..n).for_each(&mut probe);
        } else {
            let mut rng = crate::rng::SplitMix64::new(0x5eed);
            (0..BOUNDARY_SHARE_PROBES).for_each(|_| probe(rng.below(n as u64) as usize));
        }
        if solid == 0 {
            0.0
        } else {
            boundary as f64 / solid as f64
        }
    }

    /// The boundary of the solid cell set as a closed, outward-oriented triangle mesh: two
    /// triangles per cell face between a solid cell and an empty (or outside-the-grid) cell,
    /// vertices shared on the grid lattice, so it is watertight (every directed edge has its
    /// reverse). Edges where two solid cells touch only along an edge are non-manifold (four
    /// faces); the enclosed volume is exactly [`VoxelGrid::volume`]. Also returns, per
    /// triangle, the linear index of the solid cell it bounds (ascending: cells are visited in
    /// index order). Deterministic vertex order.
    pub fn boundary_mesh(&self) -> (Vec<DVec3>, Vec<[u32; 3]>, Vec<u32>) {
        let mut verts = Vec::new();
        let mut tris = Vec::new();
        let mut cells = Vec::new();
        let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
        let mut vid = |p: [u32; 3], verts: &mut Vec<DVec3>| -> u32 {
            *ids.entry(p).or_insert_with(|| {
                verts.push(self.cell_min(p[0], p[1], p[2]));
                (verts.len() - 1) as u32
            })
        };
        for idx in self.solid.ones() {
            let c = self.cell_coords(idx);
            for axis in 0..3 {
                for positive in [false, true] {
                    if self.face_neighbour_solid(c, axis, positive) {
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
                    cells.push(idx as u32);
                    cells.push(idx as u32);
                }
            }
        }
        (verts, tris, cells)
    }
}

/// Whether the triangles form a closed surface by their indices: every triangle has three
/// distinct in-range corners with finite positions, and every directed edge (a, b) occurs once
/// and its reverse (b, a) once. Then every conclusive row of [`voxelize`] is exact.
pub fn is_closed(positions: &[Vec3], triangles: &[[u32; 3]]) -> bool {
    let mut edges: Vec<(u32, u32)> = Vec::with_capacity(3 * triangles.len());
    for t in triangles {
        if t[0] == t[1] || t[1] == t[2] || t[2] == t[0] {
            return false;
        }
        for &v in t {
            if !positions.get(v as usize).is_some_and(|p| p.is_finite()) {
                return false;
            }
        }
        edges.extend([(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]);
    }
    edges.sort_unstable();
    !edges.is_empty()
        && edges.windows(2).all(|w| w[0] != w[1])
        && edges.iter().all(|&(a, b)| edges.binary_search(&(b, a)).is_ok())
}

/// The winding number at `p` of a closed surface (every directed edge paired, [`is_closed`])
/// held in `bvh`, from the signed crossings of the axis lines through `p` (+1 leaving through
/// a triangle's front side, −1 entering, the watertight test of [`crate::bvh`]): the first
/// line of x, y, z that touches no edge or vertex, crosses no triangle at `p` itself and sums
/// to zero gives w = the crossings ahead of `p`, an exact integer. `None` when no line is
/// conclusive (the caller then sums solid angles). Cost O(log T + crossings) per line,
/// against O(T) for the solid-angle sum.
pub fn closed_winding_by_rays(bvh: &TriangleBvh, p: DVec3) -> Option<i32> {
    let root = bvh.nodes.first()?;
    if !p.is_finite() {
        return None;
    }
    // Every triangle lies within `reach` of p along any line, so [−reach, reach] holds them all.
    let reach = (root.max - root.min).length() + (p - (root.min + root.max) * 0.5).length() + 1.0;
    'axes: for axis in 0..3 {
        let mut dir = DVec3::ZERO;
        dir[axis] = 1.0;
        let (mut total, mut ahead, mut grazed) = (0i32, 0i32, false);
        bvh.traverse_ray(p, dir, -reach, reach, |h| {
            let sign = if h.exiting { 1 } else { -1 };
            total += sign;
            if h.t > 0.0 {
                ahead += sign;
            }
            grazed |= h.t == 0.0 || h.bary.contains(&0.0);
            None
        });
        if grazed || total != 0 {
            continue 'axes;
        }
        return Some(ahead);
    }
    None
}

/// Voxelizes the triangle soup (see the module docs), closed or not as [`is_closed`] finds.
/// Triangles with out-of-range indices or non-finite corners are ignored.
pub fn voxelize(positions: &[Vec3], triangles: &[[u32; 3]], settings: &VoxelSettings) -> VoxelGrid {
    let bvh = TriangleBvh::new(positions, triangles);
    voxelize_bvh(&bvh, is_closed(positions, triangles), settings)
}

/// The grid layout: origin, cell size and dims (see the module docs); `None` without a valid
/// triangle.
fn layout(bvh: &TriangleBvh, resolution: u32) -> Option<(DVec3, f64, [u32; 3])> {
    let mut lo = DVec3::INFINITY;
    let mut hi = DVec3::NEG_INFINITY;
    for &t in &bvh.prims {
        for p in bvh.tris[t as usize] {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let res = resolution.clamp(1, 1024);
    let extent = (hi - lo).max_element().max(1e-30);
    let h = extent / res as f64;
    if !(h.is_finite() && h > 0.0) {
        return None;
    }
    let origin = lo - DVec3::splat(h * 1.013_7);
    let mut dims = [1u32; 3];
    for a in 0..3 {
        dims[a] = (((hi[a] - origin[a]) / h).ceil() + 2.0).clamp(1.0, res as f64 + 4.0) as u32;
    }
    Some((origin, h, dims))
}

/// Signed crossings of every row of cell centres along one axis, one flat list.
struct Rows {
    /// Row r's crossings are `start[r]..start[r + 1]`.
    start: Vec<usize>,
    /// Crossing coordinates along the axis, ascending within a row.
    coords: Vec<f64>,
    /// `ahead[m]` = Σ signs of crossings m.. of the row (+1 leaving, −1 entering).
    ahead: Vec<i32>,
    /// The row abstains: its line touched an edge or a vertex exactly (a crossing may count
    /// twice) or its crossings do not sum to zero (it passes through a hole).
    abstains: Vec<bool>,
}

impl Rows {
    /// Casts the rows along `axis` (rows indexed `iu + dims[u] · iv`, u = axis + 1, v = axis + 2).
    fn cast(bvh: &TriangleBvh, origin: DVec3, h: f64, dims: [u32; 3], axis: usize) -> Rows {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let (nu, nv) = (dims[u], dims[v]);
        let mut dir = DVec3::ZERO;
        dir[axis] = 1.0;
        // Candidate rows of a coordinate range, a thousandth of a cell wider on each side (the
        // watertight test decides exactly).
        let range = |a: usize, min: f64, max: f64, n: u32| -> Option<(u32, u32)> {
            let lo = ((min - origin[a]) / h - 0.5 - 1e-3).ceil().max(0.0);
            let hi = ((max - origin[a]) / h - 0.5 + 1e-3).floor().min(n as f64 - 1.0);
            (lo <= hi).then_some((lo as u32, hi as u32))
        };
        // (row, coordinate, exiting, touched an edge or vertex)
        let mut hits: Vec<(u32, f64, bool, bool)> = bvh
            .prims
            .par_iter()
            .flat_map_iter(|&t| {
                let tri = &bvh.tris[t as usize];
                let (mn, mx) = (tri[0].min(tri[1]).min(tri[2]), tri[0].max(tri[1]).max(tri[2]));
                let mut out = Vec::new();
                let (Some((u0, u1)), Some((v0, v1))) = (range(u, mn[u], mx[u], nu), range(v, mn[v], mx[v], nv)) else {
                    return out;
                };
                for iv in v0..=v1 {
                    for iu in u0..=u1 {
                        let mut o = DVec3::ZERO;
                        o[axis] = origin[axis] - h;
                        o[u] = origin[u] + (iu as f64 + 0.5) * h;
                        o[v] = origin[v] + (iv as f64 + 0.5) * h;
                        if let Some(hit) = RayPre::new(o, dir).intersect(tri, t) {
                            out.push((iu + nu * iv, o[axis] + hit.t, hit.exiting, hit.bary.contains(&0.0)));
                        }
                    }
                }
                out
            })
            .collect();
        // Bucketed by row (a counting sort: rows are dense), then each row's few crossings sorted
        // by every field: equal entries are identical, so the order is the same for any thread
        // count.
        let rows = nu as usize * nv as usize;
        let mut start = vec![0usize; rows + 1];
        for hit in &hits {
            start[hit.0 as usize + 1] += 1;
        }
        for r in 0..rows {
            start[r + 1] += start[r];
        }
        let mut next = start.clone();
        let mut sorted = vec![(0u32, 0.0f64, false, false); hits.len()];
        for hit in hits.drain(..) {
            let slot = &mut next[hit.0 as usize];
            sorted[*slot] = hit;
            *slot += 1;
        }
        let hits = sorted;
        let mut ahead = vec![0i32; hits.len()];
        let mut coords = vec![0.0f64; hits.len()];
        let mut abstains = vec![false; rows];
        let mut row_hits = Vec::new();
        for r in 0..rows {
            let (s, e) = (start[r], start[r + 1]);
            if s == e {
                continue;
            }
            row_hits.clear();
            row_hits.extend_from_slice(&hits[s..e]);
            row_hits.sort_unstable_by(|a, b| a.1.total_cmp(&b.1).then(a.2.cmp(&b.2)).then(a.3.cmp(&b.3)));
            let mut sum = 0;
            let mut touched = false;
            for (m, hit) in row_hits.iter().enumerate().rev() {
                sum += if hit.2 { 1 } else { -1 };
                ahead[s + m] = sum;
                coords[s + m] = hit.1;
                touched |= hit.3;
            }
            abstains[r] = touched || sum != 0;
        }
        Rows { start, coords, ahead, abstains }
    }

    /// The winding estimate of row `r` at coordinate `x` (crossings exactly at `x` count as
    /// behind it), `None` if the row abstains.
    #[inline]
    fn vote(&self, r: usize, x: f64) -> Option<i32> {
        if self.abstains[r] {
            return None;
        }
        let (s, e) = (self.start[r], self.start[r + 1]);
        let m = s + self.coords[s..e].partition_point(|&c| c <= x);
        Some(if m == e { 0 } else { self.ahead[m] })
    }
}

/// [`voxelize`] with a prebuilt BVH (reuse one tree for voxelization, ray casts and exact
/// volumes). `closed`: the caller knows the triangles form a closed surface ([`is_closed`]);
/// then one conclusive row decides a cell. Passing `false` is always correct, only slower.
pub fn voxelize_bvh(bvh: &TriangleBvh, closed: bool, settings: &VoxelSettings) -> VoxelGrid {
    voxelize_cells(bvh, closed, settings, Undecided::FromSurface)
}

/// Which of the cells the rows leave undecided get a winding number (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Undecided {
    /// Every one (closed meshes always: their undecided cells are the few on grazing rows).
    Every,
    /// Open soups: those a flood from the surface cells through solid cells reaches.
    FromSurface,
    /// None (tests: the cells the rows decide alone).
    #[cfg(test)]
    Skip,
    /// [`Undecided::FromSurface`] with the surface test by tree queries whatever the counts.
    #[cfg(test)]
    FromSurfaceByTree,
    /// [`Undecided::FromSurface`] without [`Blocks`]: every cell the flood reaches evaluated.
    #[cfg(test)]
    FromSurfacePerCell,
}

fn voxelize_cells(bvh: &TriangleBvh, closed: bool, settings: &VoxelSettings, undecided: Undecided) -> VoxelGrid {
    let Some((origin, h, dims)) = layout(bvh, settings.resolution) else {
        return VoxelGrid::default();
    };
    let [nx, ny, nz] = dims.map(|d| d as usize);
    let n = nx * ny * nz;
    let centre = |a: usize, i: usize| origin[a] + (i as f64 + 0.5) * h;
    let rows_x = Rows::cast(bvh, origin, h, dims, 0);
    let (rows_y, rows_z) = if !closed || rows_x.abstains.iter().any(|&a| a) {
        (Some(Rows::cast(bvh, origin, h, dims, 1)), Some(Rows::cast(bvh, origin, h, dims, 2)))
    } else {
        (None, None)
    };
    // The y and z votes of cell (i, j, k), `None` where not cast or abstaining.
    let vote_y = |i: usize, j: usize, k: usize| rows_y.as_ref().and_then(|r| r.vote(k + nz * i, centre(1, j)));
    let vote_z = |i: usize, j: usize, k: usize| rows_z.as_ref().and_then(|r| r.vote(i + nx * j, centre(2, k)));

    // Cell (i, j, k)'s integer w given its x row's vote, `None` when the rows leave it undecided.
    let decide = |vote_x: Option<i32>, i: usize, j: usize, k: usize| -> Option<i32> {
        if closed {
            vote_x.or_else(|| vote_y(i, j, k)).or_else(|| vote_z(i, j, k))
        } else {
            let votes = [vote_x, vote_y(i, j, k), vote_z(i, j, k)];
            let mut cast = votes.iter().flatten();
            let first = cast.next().copied();
            let (mut voters, mut agree) = (usize::from(first.is_some()), true);
            for &w in cast {
                voters += 1;
                agree &= Some(w) == first;
            }
            first.filter(|_| agree && voters >= 2)
        }
    };

    // Pass 1, the rows: solid bits where they decide inside, undecided bits where they abstain.
    let mut words = vec![0u64; n.div_ceil(64)];
    let mut open_words = vec![0u64; n.div_ceil(64)];
    let covered_twice = std::sync::atomic::AtomicUsize::new(0);
    words.par_chunks_mut(BLOCK_WORDS).zip(open_words.par_chunks_mut(BLOCK_WORDS)).enumerate().for_each(
        |(b, (block, open_block))| {
            let mut twice = 0;
            let c0 = b * BLOCK_WORDS * 64;
            let c1 = (c0 + block.len() * 64).min(n);
            // The x rows meeting the block, each walked once.
            for r in c0 / nx..c1.div_ceil(nx) {
                let (j, k) = (r % ny, r / ny);
                let base = r * nx;
                let (i0, i1) = (c0.max(base) - base, c1.min(base + nx) - base);
                let mut set = |i: usize, w: Option<i32>| {
                    let idx = base + i - c0;
                    twice += usize::from(closed && w.is_some_and(|w| w.abs() >= 2));
                    match w {
                        Some(w) if inside(w as f64) => block[idx >> 6] |= 1 << (idx & 63),
                        Some(_) => {}
                        None => open_block[idx >> 6] |= 1 << (idx & 63),
                    }
                };
                if rows_x.abstains[r] {
                    for i in i0..i1 {
                        set(i, decide(None, i, j, k));
                    }
                    continue;
                }
                let (s, e) = (rows_x.start[r], rows_x.start[r + 1]);
                let coords = &rows_x.coords[s..e];
                // The first crossing ahead of the cell centre.
                let mut m = coords.partition_point(|&c| c <= centre(0, i0));
                for i in i0..i1 {
                    let x = centre(0, i);
                    while m < coords.len() && coords[m] <= x {
                        m += 1;
                    }
                    let w = if m == coords.len() { 0 } else { rows_x.ahead[s + m] };
                    // Closed: the conclusive x row decides alone.
                    set(i, if closed { Some(w) } else { decide(Some(w), i, j, k) });
                }
            }
            covered_twice.fetch_add(twice, Ordering::Relaxed);
        },
    );
    let mut grid = VoxelGrid {
        origin,
        cell_size: h,
        dims,
        solid: Bits { words, len: n },
        covered_twice: covered_twice.load(Ordering::Relaxed),
    };
    let open = Bits { words: open_words, len: n };
    if open.words.iter().all(|&w| w == 0) {
        return grid;
    }
    #[cfg(test)]
    if undecided == Undecided::Skip {
        return grid;
    }

    // Pass 2, the winding number at the undecided cells' centres.
    let winding = Expansions::build(bvh);
    let w_at = |c: usize| {
        let [i, j, k] = cell_coords(c, dims);
        winding.eval(bvh, DVec3::new(centre(0, i), centre(1, j), centre(2, k)))
    };
    let solid_at = |c: usize| inside(w_at(c));
    // An open soup's flood asks whole regions: blocks of cells decided from one winding number
    // each where they can be (module docs, "Blocks").
    let blocks =
        if closed || undecided == Undecided::Every { None } else { Blocks::new(bvh, &winding, origin, h, dims) };
    #[cfg(test)]
    let blocks = blocks.filter(|_| undecided != Undecided::FromSurfacePerCell);
    let flood_solid_at = |c: usize| match blocks.as_ref().and_then(|b| b.decide_cell(c)) {
        Some(inside) => inside,
        None => solid_at(c),
    };
    let evaluate = |cells: &[u32]| -> Vec<u32> {
        let keep: Vec<bool> = cells.par_iter().map(|&c| flood_solid_at(c as usize)).collect();
        cells.iter().zip(keep).filter(|(_, s)| *s).map(|(&c, _)| c).collect()
    };
    if closed || undecided == Undecided::Every {
        let open_words = &open.words;
        grid.solid.words.par_chunks_mut(BLOCK_WORDS).zip(open_words.par_chunks(BLOCK_WORDS)).enumerate().for_each(
            |(b, (solid_block, open_block))| {
                let mut twice = 0;
                for c in block_ones(open_block, b * BLOCK_WORDS) {
                    let w = w_at(c);
                    // A closed soup's w is an integer; the fast evaluation is within 4e-3 of it.
                    twice += usize::from(closed && w.abs() >= 1.5);
                    if inside(w) {
                        solid_block[c / 64 - b * BLOCK_WORDS] |= 1 << (c % 64);
                    }
                }
                covered_twice.fetch_add(twice, Ordering::Relaxed);
            },
        );
        grid.covered_twice = covered_twice.into_inner();
        return grid;
    }
    // Open soups: the flood (module docs) from the undecided cells the surface passes through
    // or that touch a solid cell (26 neighbours), in index order.
    // The surface cells: all of them when there are at least as many undecided cells as
    // triangles (a soup of sheets), else a tree query per undecided cell (a large mesh with a
    // few holes); the same cells either way.
    let by_tree = open.count_ones() < bvh.triangle_count();
    #[cfg(test)]
    let by_tree = by_tree || undecided == Undecided::FromSurfaceByTree;
    let surface = (!by_tree).then(|| surface_cells(bvh, &grid));
    let g = &grid;
    let on_surface = |c: usize| match &surface {
        Some(s) => s.get(c),
        None => cell_meets_surface(bvh, g, c),
    };
    let found = flood(&open, &grid.solid, dims, on_surface, evaluate);
    #[cfg(test)]
    if let Some(b) = &blocks {
        BLOCKS_DECIDED.with(|n| n.set(n.get() + b.decided.load(Ordering::Relaxed)));
    }
    for (s, f) in grid.solid.words.iter_mut().zip(&found.words) {
        *s |= f;
    }
    grid
}

#[cfg(test)]
thread_local! {
    /// Blocks decided whole by this thread's voxelizations (tests: the blocks are exercised).
    static BLOCKS_DECIDED: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// Block edges, in cells, of the two levels of [`Blocks`], largest first.
const BLOCK_EDGES: [usize; 2] = [4, 2];

/// A block is decided only when its winding number stays this far from ½ (beyond the bound):
/// five times the fast evaluation's largest measured error (4e-3, [`crate::winding`]), so a cell
/// of a decided block gets what its own evaluation would give.
const BLOCK_MARGIN: f64 = 0.02;

/// Above this many unpaired edges, or more unpaired edges than triangles, the blocks are not
/// used: each block's bound sums the edges (in clusters), and where most triangles border a hole
/// (a bush of cards: 4 000 unpaired edges on 2 000 triangles) nearly every block is near one, so
/// the blocks decided too few cells to pay for the blocks tried (measured: 7.0 → 8.0 s CPU).
const BLOCK_MAX_EDGES: usize = 1 << 14;

/// Whole blocks of an open soup's cells decided from one winding number (module docs,
/// "Blocks"). Away from the triangles w is smooth, and its gradient is the Biot–Savart field of
/// the soup's unpaired edges: each triangle's solid angle has the gradient of a unit current
/// around its edges, and an edge two triangles run in opposite directions cancels. So on a box
/// that meets no triangle, |∇w| ≤ (1/4π) Σ_e |m_e| len_e / d_e², with d_e the distance from the
/// box to edge e and m_e its net count (one per direction), and every point of the box is within
/// R (the half-diagonal) of the centre: when |w(centre)| stays more than that bound times R (plus
/// [`BLOCK_MARGIN`]) away from ½, every cell centre of the box is on the centre's side. Levels of
/// [`BLOCK_EDGES`] cells (a level of 8 saved nothing more on BoxAnimated): a block that cannot be
/// decided leaves its cells to the next level, and at the last to their own evaluation. Each
/// block is decided at most once (a byte per block, written by whichever thread asks first;
/// every thread would write the same value, so the result does not depend on the thread count).
struct Blocks<'a> {
    bvh: &'a TriangleBvh,
    winding: &'a Expansions,
    /// The soup's unpaired edges, for the gradient bound.
    edges: EdgeField,
    origin: DVec3,
    h: f64,
    dims: [u32; 3],
    /// Per level: blocks along each axis, and one byte per block (0 not yet decided, 1 inside,
    /// 2 outside, 3 mixed).
    levels: [([usize; 3], Vec<AtomicU8>); 2],
    #[cfg(test)]
    decided: AtomicUsize,
}

impl<'a> Blocks<'a> {
    /// `None` when the soup has more than [`BLOCK_MAX_EDGES`] unpaired edges or more than it has
    /// triangles.
    fn new(bvh: &'a TriangleBvh, winding: &'a Expansions, origin: DVec3, h: f64, dims: [u32; 3]) -> Option<Self> {
        let edges = unpaired_edges(&bvh.tris);
        if edges.len() > BLOCK_MAX_EDGES.min(bvh.tris.len()) {
            return None;
        }
        let edges = EdgeField::new(edges);
        let levels = BLOCK_EDGES.map(|e| {
            let nb = dims.map(|d| (d as usize).div_ceil(e));
            (nb, (0..nb[0] * nb[1] * nb[2]).map(|_| AtomicU8::new(0)).collect())
        });
        Some(Blocks {
            bvh,
            winding,
            edges,
            origin,
            h,
            dims,
            levels,
            #[cfg(test)]
            decided: AtomicUsize::new(0),
        })
    }

    /// Whether cell `c` is inside, when a block holding it is decided; `None` leaves the cell to
    /// its own evaluation.
    fn decide_cell(&self, c: usize) -> Option<bool> {
        let cell = cell_coords(c, self.dims);
        for (level, (nb, bytes)) in self.levels.iter().enumerate() {
            let e = BLOCK_EDGES[level];
            let b = cell.map(|x| x / e);
            let byte = &bytes[b[0] + nb[0] * (b[1] + nb[1] * b[2])];
            let mut v = byte.load(Ordering::Relaxed);
            if v == 0 {
                v = self.decide_block(b.map(|x| x * e), e);
                byte.store(v, Ordering::Relaxed);
            }
            match v {
                1 => return Some(true),
                2 => return Some(false),
                _ => {}
            }
        }
        None
    }

    /// The block of edge `e` cells whose first cell is `first`: 1 inside, 2 outside, 3 mixed.
    fn decide_block(&self, first: [usize; 3], e: usize) -> u8 {
        let last = std::array::from_fn::<usize, 3, _>(|a| (first[a] + e).min(self.dims[a] as usize) - 1);
        let at = |i: [usize; 3]| self.origin + (DVec3::new(i[0] as f64, i[1] as f64, i[2] as f64) + 0.5) * self.h;
        let (lo, hi) = (at(first), at(last));
        let (centre, half) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
        // The box of the block's cell centres, widened as a surface cell's is, meets no triangle.
        let widened = half + DVec3::splat(self.h * 1e-9);
        let meets = std::cell::Cell::new(false);
        let node = |a: DVec3, b: DVec3| {
            !meets.get() && (a - centre).cmple(widened).all() && (b - centre).cmpge(-widened).all()
        };
        self.bvh.traverse_boxes(&node, |_, tri| {
            if !meets.get() && tri_box_overlap(tri, centre, widened) {
                meets.set(true);
            }
        });
        if meets.get() {
            return 3;
        }
        // The edges' bound on how far w moves over the block (before the winding number, which
        // costs more: near a hole's edge the block is mixed whatever w is; the sum stops where
        // even |w| = 2 would leave no room), then the room |w(centre)| leaves on its side of ½.
        let r = half.length();
        let to_slack = r / (4.0 * std::f64::consts::PI);
        let most_room = 2.0 - INSIDE_WINDING - BLOCK_MARGIN;
        let Some(bound) = self.edges.gradient_bound(centre, r, most_room / to_slack) else {
            return 3;
        };
        let w = self.winding.eval(self.bvh, centre).abs();
        if bound * to_slack >= (w - INSIDE_WINDING).abs() - BLOCK_MARGIN {
            return 3;
        }
        let v = if w >= INSIDE_WINDING { 1 } else { 2 };
        #[cfg(test)]
        self.decided.fetch_add(1, Ordering::Relaxed);
        v
    }
}

/// The directed edges of `tris` that no edge runs back along (corners compared by exact
/// position), each with its net count: (from, to, |count|), from the corner with the lower bits
/// to the higher, in ascending order of their bits. Zero-length edges are left out.
fn unpaired_edges(tris: &[[DVec3; 3]]) -> Vec<(DVec3, DVec3, f64)> {
    // An edge by its corners' bits, low first ([`edges::directed`]).
    let bits = |p: DVec3| [p.x, p.y, p.z].map(f64::to_bits);
    let point = |b: [u64; 3]| DVec3::from_array(b.map(f64::from_bits));
    let mut keyed: Vec<_> = tris
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| (bits(a), bits(b)))
        .filter(|(a, b)| a != b)
        .map(|(a, b)| edges::directed(a, b))
        .collect();
    edges::group_edges(&mut keyed)
        .filter(|g| g.net() != 0)
        .map(|g| (point(g.key.0), point(g.key.1), g.net().unsigned_abs() as f64))
        .collect()
}

/// Edges per cluster of an [`EdgeField`].
const EDGE_CLUSTER: usize = 16;

/// A cluster counts as one term when its ball is farther than this many of its radii from the
/// block's ball (each of its edges is then at most 2 radii farther than the term assumes, so the
/// term overstates their sum by at most (1 + 2/3)²); nearer, edge by edge.
const CLUSTER_FAR: f64 = 3.0;

/// The unpaired edges (a, b, |net count|) in clusters of at most [`EDGE_CLUSTER`] (median
/// splits of their midpoints along the widest axis, in a fixed order), each with a ball holding
/// its edges and its Σ |m| len, so a far cluster costs one term of the gradient bound.
struct EdgeField {
    edges: Vec<(DVec3, DVec3, f64)>,
    /// (first edge, past the last, ball centre, ball radius, Σ |m| len).
    clusters: Vec<(usize, usize, DVec3, f64, f64)>,
}

impl EdgeField {
    fn new(mut edges: Vec<(DVec3, DVec3, f64)>) -> Self {
        let mut clusters = Vec::new();
        let mut stack = vec![(0, edges.len())];
        while let Some((s, e)) = stack.pop() {
            if e - s > EDGE_CLUSTER {
                let part = &mut edges[s..e];
                let mid = |x: &(DVec3, DVec3, f64)| (x.0 + x.1) * 0.5;
                let (lo, hi) = part
                    .iter()
                    .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), x| (lo.min(mid(x)), hi.max(mid(x))));
                let axis = (hi - lo).max_position();
                let half = part.len() / 2;
                part.select_nth_unstable_by(half, |x, y| mid(x)[axis].total_cmp(&mid(y)[axis]));
                stack.push((s + half, e));
                stack.push((s, s + half));
                continue;
            }
            let part = &edges[s..e];
            let (lo, hi) = part.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x.0).min(x.1), hi.max(x.0).max(x.1))
            });
            let centre = (lo + hi) * 0.5;
            let radius = part.iter().map(|x| (x.0 - centre).length().max((x.1 - centre).length())).fold(0.0, f64::max);
            let weight = part.iter().map(|x| x.2 * (x.1 - x.0).length()).sum();
            clusters.push((s, e, centre, radius, weight));
        }
        EdgeField { edges, clusters }
    }

    /// Σ |m| len / d² over the edges, d being each edge's distance from the ball of radius `r`
    /// around `c` (a cluster whose ball is [`CLUSTER_FAR`] radii clear of it counts as its
    /// Σ |m| len over the nearest distance of its ball). `None` when an edge comes within `r` of
    /// `c` or the sum reaches `limit`.
    fn gradient_bound(&self, c: DVec3, r: f64, limit: f64) -> Option<f64> {
        let mut sum = 0.0;
        for &(s, e, centre, radius, weight) in &self.clusters {
            let d = (centre - c).length() - radius - r;
            if d > CLUSTER_FAR * radius {
                sum += weight / (d * d);
            } else {
                for &(a, b, m) in &self.edges[s..e] {
                    let d = segment_distance(c, a, b) - r;
                    if d <= 0.0 {
                        return None;
                    }
                    sum += m * (b - a).length() / (d * d);
                }
            }
            if sum >= limit {
                return None;
            }
        }
        Some(sum)
    }
}

/// Distance from `p` to the segment a–b.
fn segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 { ((p - a).dot(ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (p - (a + ab * t)).length()
}

/// Words of [`Bits`] per parallel block of the voxelizer's passes (16 384 cells).
const BLOCK_WORDS: usize = 256;

/// The open soup's flood (module docs): the undecided cells (`open`) found inside, given the
/// cells the rows made solid (`solid`, disjoint from `open`). Seeds are the undecided cells
/// `on_surface` or touching (26 neighbours) a solid cell; `evaluate` returns the cells of a
/// frontier that are inside (its order), and the flood spreads from each to its undecided
/// neighbours (26). Each undecided cell is evaluated at most once, in frontier order, so the
/// result does not depend on the thread count. Returns the cells found (one bit per cell).
fn flood(
    open: &Bits,
    solid: &Bits,
    dims: [u32; 3],
    on_surface: impl Fn(usize) -> bool + Sync,
    evaluate: impl Fn(&[u32]) -> Vec<u32>,
) -> Bits {
    let seed = |c: usize| on_surface(c) || neighbours_26(c, dims).any(|q| solid.get(q));
    let mut frontier: Vec<u32> = open
        .words
        .par_chunks(BLOCK_WORDS)
        .enumerate()
        .flat_map_iter(|(b, open_block)| {
            block_ones(open_block, b * BLOCK_WORDS).filter(|&c| seed(c)).map(|c| c as u32).collect::<Vec<_>>()
        })
        .collect();
    // A cell is marked when it joins a frontier, so each is evaluated once and a frontier holds
    // no cell twice.
    let mut seen = Bits::new(open.len);
    for &c in &frontier {
        seen.set(c as usize);
    }
    let mut all = Bits::new(open.len);
    while !frontier.is_empty() {
        let found = evaluate(&frontier);
        let mut next: Vec<u32> = Vec::new();
        for &c in &found {
            all.set(c as usize);
            for q in neighbours_26(c as usize, dims) {
                if open.get(q) && !seen.get(q) {
                    seen.set(q);
                    next.push(q as u32);
                }
            }
        }
        frontier = next;
    }
    all
}

/// Whether the closed box of cell `c` (linear index) meets a triangle of `bvh`: the cell is in
/// [`surface_cells`] (the same widened box and test), found by a tree query.
fn cell_meets_surface(bvh: &TriangleBvh, grid: &VoxelGrid, c: usize) -> bool {
    let (centre, half) = (centre_of(grid, c), surface_box_half(grid.cell_size));
    let meets = std::cell::Cell::new(false);
    // Nodes relative to the centre, as `tri_box_overlap` tests (rounding is monotone, so a node
    // holding a triangle that meets the box is never pruned); none once one triangle meets it.
    let node =
        |lo: DVec3, hi: DVec3| !meets.get() && (lo - centre).cmple(half).all() && (hi - centre).cmpge(-half).all();
    bvh.traverse_boxes(&node, |_, tri| {
        if !meets.get() && tri_box_overlap(tri, centre, half) {
            meets.set(true);
        }
    });
    meets.get()
}

/// Cell (i, j, k) of linear index `c` (x fastest) on a grid of `dims` cells.
fn cell_coords(c: usize, dims: [u32; 3]) -> [usize; 3] {
    let [nx, ny, _] = dims.map(|d| d as usize);
    [c % nx, c / nx % ny, c / (nx * ny)]
}

/// The centre of cell `c` (linear index) of `grid`.
fn centre_of(grid: &VoxelGrid, c: usize) -> DVec3 {
    let [i, j, k] = cell_coords(c, grid.dims);
    grid.cell_center(i as u32, j as u32, k as u32)
}

/// Half the edge of the box a surface cell's triangle must meet: the cell, widened by 1e-9
/// relative so that touching counts.
fn surface_box_half(cell_size: f64) -> DVec3 {
    DVec3::splat(cell_size * 0.5 * (1.0 + 1e-9))
}

/// The linear indices of the set bits of `block`, a run of words whose first is word
/// `first_word` of its bit vector, ascending.
fn block_ones(block: &[u64], first_word: usize) -> impl Iterator<Item = usize> + '_ {
    block.iter().enumerate().flat_map(move |(w, &word)| {
        let mut x = word;
        std::iter::from_fn(move || {
            (x != 0).then(|| {
                let bit = x.trailing_zeros() as usize;
                x &= x - 1;
                (first_word + w) * 64 + bit
            })
        })
    })
}

/// The linear indices of the (up to 26) cells sharing a face, edge or corner with cell `c`.
fn neighbours_26(c: usize, dims: [u32; 3]) -> impl Iterator<Item = usize> {
    let [nx, ny, nz] = dims.map(|d| d as usize);
    let [i, j, k] = cell_coords(c, dims);
    let near = |v: usize, n: usize| v.saturating_sub(1)..(v + 2).min(n);
    near(k, nz)
        .flat_map(move |z| near(j, ny).flat_map(move |y| near(i, nx).map(move |x| x + nx * (y + ny * z))))
        .filter(move |&q| q != c)
}

/// The cells whose closed box meets a triangle of `bvh` (exact separating-axis test, boxes
/// widened by 1e-9 relative so touching counts), on `grid`'s layout: the solid of a soup that
/// encloses nothing (see the module docs). Candidates are the 3×3×3 blocks around samples
/// spaced half a cell on each triangle ([`cover_samples`]: every point of a triangle is within
/// half a cell of one, so every cell it meets is in the block of one), so a sliver costs its
/// length in cells, not its bounding box. Deterministic, parallel over triangles.
pub fn surface_cells(bvh: &TriangleBvh, grid: &VoxelGrid) -> Bits {
    let mut bits = Bits::new(grid.cell_count());
    if bits.is_empty() {
        return bits;
    }
    let h = grid.cell_size;
    let half = surface_box_half(h);
    let dims = grid.dims.map(|d| d as i64);
    let cells: Vec<Vec<u32>> = bvh
        .prims
        .par_iter()
        .map(|&t| {
            let tri = &bvh.tris[t as usize];
            // The cells of the samples, then their 3×3×3 blocks, each list deduplicated (a
            // sliver has about two samples per cell along its length).
            let mut sampled: Vec<[i64; 3]> = Vec::new();
            cover_samples(tri[0], tri[1], tri[2], 0.5 * h, |p| {
                let u = ((p - grid.origin) / h).floor();
                if u.is_finite() {
                    sampled.push([u.x as i64, u.y as i64, u.z as i64]);
                }
            });
            sampled.sort_unstable();
            sampled.dedup();
            let mut cand: Vec<u32> = Vec::with_capacity(sampled.len() * 9);
            for c in sampled {
                for dk in -1..=1 {
                    for dj in -1..=1 {
                        for di in -1..=1 {
                            let q = [c[0] + di, c[1] + dj, c[2] + dk];
                            if (0..3).all(|a| q[a] >= 0 && q[a] < dims[a]) {
                                cand.push(grid.index(q[0] as u32, q[1] as u32, q[2] as u32) as u32);
                            }
                        }
                    }
                }
            }
            cand.sort_unstable();
            cand.dedup();
            cand.retain(|&idx| tri_box_overlap(tri, centre_of(grid, idx as usize), half));
            cand.shrink_to_fit();
            cand
        })
        .collect();
    for idx in cells.into_iter().flatten() {
        bits.set(idx as usize);
    }
    bits
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

    /// `cell_of` (compare, then truncate) answers as the floor it replaced: ⌊u⌋ per axis, the
    /// cell when every ⌊u⌋ lies in [0, dims). Points anywhere near and beyond the grid, on cell
    /// faces exactly, and non-finite.
    #[test]
    fn cell_of_matches_the_floor() {
        let reference = |g: &VoxelGrid, p: DVec3| -> Option<[u32; 3]> {
            let u = (p - g.origin) / g.cell_size;
            let mut out = [0u32; 3];
            for a in 0..3 {
                let v = u[a].floor();
                if !(v >= 0.0 && v < g.dims[a] as f64) {
                    return None;
                }
                out[a] = v as u32;
            }
            Some(out)
        };
        let mut rng = crate::rng::SplitMix64::new(55);
        for _ in 0..20 {
            let dims = [1 + rng.below(40) as u32, 1 + rng.below(40) as u32, 1 + rng.below(40) as u32];
            let origin = DVec3::new(rng.next_f64() - 0.5, rng.next_f64() * 4.0 - 2.0, rng.next_f64() * 100.0 - 50.0);
            let cell_size = 0.01 + rng.next_f64();
            let grid = VoxelGrid { origin, cell_size, dims, solid: Bits::new(0), covered_twice: 0 };
            for k in 0..5000 {
                let mut u = [0.0; 3];
                for (a, v) in u.iter_mut().enumerate() {
                    let span = f64::from(dims[a]) + 4.0;
                    // On a cell face (or just beside one after the scaling rounds), within
                    // 10⁻¹² of the grid's first or last face, or anywhere.
                    let edge = [0.0, f64::from(dims[a])][rng.below(2) as usize];
                    *v = match k % 4 {
                        0 => rng.below(span as u64) as f64 - 2.0,
                        1 => edge + (rng.next_f64() - 0.5) * 1e-12,
                        _ => rng.next_f64() * span - 2.0,
                    };
                }
                let p = origin + DVec3::from(u) * cell_size;
                assert_eq!(grid.cell_of(p), reference(&grid, p), "dims {dims:?} u {u:?}");
            }
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e300, -1e300, -0.0] {
                let p = DVec3::new(bad, origin.y, origin.z);
                assert_eq!(grid.cell_of(p), reference(&grid, p), "x {bad}");
            }
        }
    }

    #[test]
    fn a_held_triangle_lies_in_solid_cells_and_one_far_inside_is_held() {
        // A 40³ grid of unit cells, solid except a 6-cell-wide tunnel along z through the
        // middle (x, y in [17, 23)). Oracles, written apart from the block rule: a triangle
        // held must have every point of a fine sampling (a quarter of a cell) in a solid cell;
        // a triangle whose every fine sample has its whole 5 × 5 × 5 block solid (two cells
        // from any empty cell) must be held.
        let n = 40u32;
        let mut solid = Bits::new((n * n * n) as usize);
        let tunnel = |i: u32, j: u32| (17..23).contains(&i) && (17..23).contains(&j);
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    if !tunnel(i, j) {
                        solid.set((i + n * (j + n * k)) as usize);
                    }
                }
            }
        }
        let grid = VoxelGrid { origin: DVec3::ZERO, cell_size: 1.0, dims: [n; 3], solid, covered_twice: 0 };
        let cell_solid = |p: DVec3| grid.is_solid_at(p);
        let fine = |[a, b, c]: [DVec3; 3]| {
            let m = (a.distance(b).max(b.distance(c)).max(c.distance(a)) * 4.0).ceil().max(1.0) as usize;
            crate::triangle::triangle_grid(a, b, c, m).map(|(_, _, p)| p).collect::<Vec<_>>()
        };
        let far_inside = |p: DVec3| {
            (-2..=2).all(|dz| {
                (-2..=2).all(|dy| (-2..=2).all(|dx| cell_solid(p + DVec3::new(dx as f64, dy as f64, dz as f64))))
            })
        };
        let mut rng = crate::rng::SplitMix64::new(5);
        let (mut held, mut far, mut crossing) = (0, 0, 0);
        for t in 0..1500 {
            // Triangles of every size up to 20 cells, anywhere in (and a little beyond) the grid.
            // Every fourth from one side of the tunnel to the other.
            let size = [1.5, 6.0, 20.0][t % 3];
            let mut r = || DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
            let tri = if t % 4 == 3 {
                let side = |u: DVec3, x0: f64| DVec3::new(x0, 12.0, 4.0) + u * DVec3::new(5.0, 16.0, 32.0);
                [side(r(), 8.0), side(r(), 27.0), side(r(), 27.0)]
            } else {
                let a = r() * 44.0 - 2.0;
                [a, a + (r() - 0.5) * size, a + (r() - 0.5) * size]
            };
            let samples = fine(tri);
            let h = grid.holds_triangle(tri[0], tri[1], tri[2]);
            if h {
                held += 1;
                assert!(samples.iter().all(|&p| cell_solid(p)), "held but reaches an empty cell: {tri:?}");
            }
            if samples.iter().all(|&p| far_inside(p)) {
                far += 1;
                assert!(h, "two cells inside everywhere but not held: {tri:?}");
            }
            // Corners beside the tunnel on both sides, the middle across it.
            if !h && tri.iter().all(|&p| far_inside(p)) {
                crossing += 1;
            }
        }
        assert!(held > 200 && far > 100 && crossing > 100, "held {held}, far inside {far}, crossing {crossing}");
        // A triangle across the tunnel whose corners are deep in the solid.
        let across = [DVec3::new(10.0, 20.0, 20.0), DVec3::new(30.0, 19.0, 20.0), DVec3::new(30.0, 21.0, 21.0)];
        assert!(across.iter().all(|&p| far_inside(p)) && !grid.holds_triangle(across[0], across[1], across[2]));
        // Longer than HOLDS_MAX_DIVISIONS cells: not read, so not held, even deep inside a
        // solid block of 80³ cells; one cell shorter it is held.
        let m = 80u32;
        let mut all = Bits::new((m * m * m) as usize);
        (0..(m * m * m) as usize).for_each(|i| all.set(i));
        let block = VoxelGrid { origin: DVec3::ZERO, cell_size: 1.0, dims: [m; 3], solid: all, covered_twice: 0 };
        let max = HOLDS_MAX_DIVISIONS as f64;
        let (a, b) = (DVec3::new(8.0, 8.0, 8.0), DVec3::new(12.0, 8.0, 8.0));
        assert!(block.holds_triangle(a, b, DVec3::new(8.0, 8.0, 8.0 + max - 0.5)));
        assert!(!block.holds_triangle(a, b, DVec3::new(8.0, 8.0, 8.0 + max + 0.5)));
        assert!(!grid.holds_triangle(DVec3::NAN, DVec3::ONE * 5.0, DVec3::ONE * 6.0));
    }

    fn check(tri: [DVec3; 3], expected: bool) {
        assert_eq!(tri_box_overlap(&tri, DVec3::ZERO, DVec3::splat(0.5)), expected, "{tri:?}");
    }

    #[test]
    fn closed_winding_by_rays_is_the_solid_angle_sum() {
        // An outward unit cube, an outward ball inside it (w = 2 there) and an inward ball
        // beside it (w = −1): every conclusive answer is the rounded solid-angle sum.
        let mut pos: Vec<Vec3> =
            (0..8).map(|i| Vec3::new((i & 1) as f32, (i >> 1 & 1) as f32, (i >> 2) as f32)).collect();
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let mut tris: Vec<[u32; 3]> = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
        let (ball_pos, ball_tris) = crate::sphere::icosphere(2);
        for (centre, r, inward) in [(Vec3::splat(0.5), 0.3f32, false), (Vec3::new(2.0, 0.5, 0.5), 0.4, true)] {
            let base = pos.len() as u32;
            pos.extend(ball_pos.iter().map(|p| centre + Vec3::from(*p) * r));
            tris.extend(
                ball_tris.iter().map(|t| if inward { [t[0], t[2], t[1]] } else { *t }).map(|t| t.map(|v| v + base)),
            );
        }
        assert!(is_closed(&pos, &tris));
        let bvh = TriangleBvh::new(&pos, &tris);
        let p64: Vec<DVec3> = pos.iter().map(|p| p.as_dvec3()).collect();
        let brute = |p: DVec3| crate::volume::winding_number_brute(p, &p64, &tris);
        let mut rng = crate::rng::SplitMix64::new(9);
        let (mut answered, mut seen) = (0, [false; 4]);
        for _ in 0..3000 {
            let p = DVec3::new(rng.next_f64() * 3.2 - 0.6, rng.next_f64() * 2.0 - 0.5, rng.next_f64() * 2.0 - 0.5);
            let w = brute(p);
            if let Some(v) = closed_winding_by_rays(&bvh, p) {
                assert!((w - f64::from(v)).abs() < 1e-6, "{p}: rays {v}, solid angles {w}");
                seen[(v + 1) as usize] = true;
                answered += 1;
            }
        }
        assert!(answered >= 2990, "{answered} of 3000 answered");
        assert_eq!(seen, [true; 4], "w = −1, 0, 1, 2 all met");
        // On the surface every axis line grazes an edge or passes through the point: no answer.
        assert_eq!(closed_winding_by_rays(&bvh, DVec3::new(0.5, 1.0, 0.25)), None);
        // A point whose x line runs along a cube edge is answered by another axis.
        assert_eq!(closed_winding_by_rays(&bvh, DVec3::new(-0.5, 0.0, 0.0)), Some(0));
        assert_eq!(closed_winding_by_rays(&TriangleBvh::new(&pos, &[]), DVec3::ZERO), None);
        // A line with unbalanced crossings passes through a hole: the cube without its faces at
        // x = 1, y = 1 and z = 1 has no answer inside (a point off the faces' diagonals).
        let open: Vec<[u32; 3]> = [0, 4, 8].iter().flat_map(|&i| [tris[i], tris[i + 1]]).collect();
        assert_eq!(closed_winding_by_rays(&TriangleBvh::new(&pos, &open), DVec3::new(0.3, 0.6, 0.45)), None);
    }

    #[test]
    fn closedness_by_indices() {
        // Octahedron: closed; without a face, with a face twice, flipped face, bad index.
        let p = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        let t = vec![[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
        assert!(is_closed(&p, &t));
        let reversed: Vec<[u32; 3]> = t.iter().map(|f| [f[0], f[2], f[1]]).collect();
        assert!(is_closed(&p, &reversed));
        assert!(!is_closed(&p, &t[1..]));
        let mut twice = t.clone();
        twice.push(t[0]);
        assert!(!is_closed(&p, &twice));
        let mut flipped = t.clone();
        flipped[3] = [t[3][0], t[3][2], t[3][1]];
        assert!(!is_closed(&p, &flipped));
        let mut bad = t.clone();
        bad[0][0] = 9;
        assert!(!is_closed(&p, &bad));
        let mut nan = p.clone();
        nan[0] = Vec3::NAN;
        assert!(!is_closed(&nan, &t));
        assert!(!is_closed(&p, &[]));
    }

    #[test]
    fn bits_ones_are_the_set_bits() {
        let pattern = |i: usize| i % 7 == 0 || i % 64 == 63 || i == 129;
        let b: Bits = (0..200).map(pattern).collect();
        let ones: Vec<usize> = b.ones().collect();
        let want: Vec<usize> = (0..200).filter(|&i| pattern(i)).collect();
        assert_eq!(ones, want);
        assert_eq!(b.count_ones(), want.len());
        assert!(Bits::new(0).ones().next().is_none());
    }

    /// `for_each_one_in` against a bit-by-bit filter of the range, and `clear` against `set`,
    /// on random bits and random ranges (within one word, across words, empty, to the end).
    #[test]
    fn bits_ones_in_a_range_are_the_set_bits_there() {
        let mut rng = crate::rng::SplitMix64::new(71);
        for round in 0..300 {
            let n = 1 + (rng.next_u64() % 400) as usize;
            let density = [0.02, 0.3, 0.9][round % 3];
            let mut b = Bits::new(n);
            let mut want = vec![false; n];
            for _ in 0..3 * n {
                let i = (rng.next_u64() % n as u64) as usize;
                let on = rng.next_f64() < density;
                if on {
                    b.set(i);
                } else {
                    b.clear(i);
                }
                want[i] = on;
            }
            assert_eq!(b.ones().collect::<Vec<_>>(), (0..n).filter(|&i| want[i]).collect::<Vec<_>>());
            for _ in 0..20 {
                let a = (rng.next_u64() % (n as u64 + 1)) as usize;
                let e = if round % 5 == 0 { n } else { (rng.next_u64() % (n as u64 + 1)) as usize };
                let mut got = Vec::new();
                b.for_each_one_in(a..e, |i| got.push(i));
                let expect: Vec<usize> = (a..e.max(a)).filter(|&i| want[i]).collect();
                assert_eq!(got, expect, "n {n}, range {a}..{e}");
            }
        }
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

#[cfg(test)]
mod flood_tests {
    use super::*;
    use crate::rng::SplitMix64;

    /// The flood alone on random small grids, against a brute-force labelling written apart:
    /// the inside undecided cells it returns are those of the 26-connected parts of
    /// (rows-solid ∪ inside undecided) that hold a rows-solid cell or an inside undecided cell
    /// on the surface; no cell is evaluated twice. The cases include parts that touch the
    /// rows-solid cells only at an edge or a corner (checked: a labelling that joins undecided
    /// to rows-solid cells by faces only differs on some), and one such part built by hand.
    #[test]
    fn the_flood_keeps_exactly_the_parts_that_reach_a_solid_or_surface_cell() {
        let coords = |c: usize, d: [u32; 3]| {
            let (nx, ny) = (d[0] as usize, d[1] as usize);
            [(c % nx) as i64, (c / nx % ny) as i64, (c / (nx * ny)) as i64]
        };
        // Brute force: `rows` rows-solid, `inside` inside undecided cells, `surf` on the surface.
        // `faces_only`: a rows-solid and an undecided cell are joined only across a face.
        let reference = |d: [u32; 3], rows: &[bool], inside: &[bool], surf: &[bool], faces_only: bool| {
            let n = rows.len();
            let member = |c: usize| rows[c] || inside[c];
            let mut label = vec![usize::MAX; n];
            let mut keep = Vec::new();
            for s in 0..n {
                if !member(s) || label[s] != usize::MAX {
                    continue;
                }
                let id = keep.len();
                let (mut stack, mut holds) = (vec![s], false);
                label[s] = id;
                while let Some(c) = stack.pop() {
                    holds |= rows[c] || (inside[c] && surf[c]);
                    let a = coords(c, d);
                    for q in 0..n {
                        let b = coords(q, d);
                        let diff: Vec<i64> = (0..3).map(|t| (a[t] - b[t]).abs()).collect();
                        let near = diff.iter().all(|&x| x <= 1) && q != c;
                        let mixed = rows[c] != rows[q];
                        let joined = near && (!faces_only || !mixed || diff.iter().sum::<i64>() == 1);
                        if joined && member(q) && label[q] == usize::MAX {
                            label[q] = id;
                            stack.push(q);
                        }
                    }
                }
                keep.push(holds);
            }
            (0..n).filter(|&c| inside[c] && keep[label[c]]).map(|c| c as u32).collect::<Vec<u32>>()
        };
        let run = |d: [u32; 3], rows: &[bool], open: &[bool], inside: &[bool], surf: &[bool]| {
            let n = rows.len();
            let (mut ob, mut sb) = (Bits::new(n), Bits::new(n));
            for c in 0..n {
                if open[c] {
                    ob.set(c);
                }
                if rows[c] {
                    sb.set(c);
                }
            }
            let evaluated = std::cell::RefCell::new(vec![0u32; n]);
            let found = flood(
                &ob,
                &sb,
                d,
                |c| surf[c],
                |cells: &[u32]| {
                    let mut e = evaluated.borrow_mut();
                    for &c in cells {
                        assert!(open[c as usize], "evaluated a decided cell {c}");
                        e[c as usize] += 1;
                    }
                    cells.iter().copied().filter(|&c| inside[c as usize]).collect()
                },
            );
            assert!(evaluated.borrow().iter().all(|&k| k <= 1), "a cell evaluated twice");
            let got: Vec<u32> = (0..n).filter(|&c| found.get(c)).map(|c| c as u32).collect();
            got
        };
        // By hand, on 4 × 3 × 3 cells: a rows-solid cell at (0, 0, 0); inside undecided cells
        // off the surface at (1, 1, 1), touching it at a corner only (kept), and at (3, 2, 2),
        // touching no solid cell (dropped).
        let d = [4, 3, 3];
        let at = |i: usize, j: usize, k: usize| i + 4 * (j + 3 * k);
        let (mut rows, mut open, mut inside) = (vec![false; 36], vec![true; 36], vec![false; 36]);
        rows[at(0, 0, 0)] = true;
        open[at(0, 0, 0)] = false;
        inside[at(1, 1, 1)] = true;
        inside[at(3, 2, 2)] = true;
        assert_eq!(run(d, &rows, &open, &inside, &[false; 36]), vec![at(1, 1, 1) as u32]);
        let mut rng = SplitMix64::new(23);
        let mut diagonal_cases = 0;
        for case in 0..200 {
            let d = [3 + rng.below(4) as u32, 3 + rng.below(4) as u32, 2 + rng.below(4) as u32];
            let n = d.iter().map(|&x| x as usize).product();
            let (mut rows, mut open, mut inside, mut surf) =
                (vec![false; n], vec![false; n], vec![false; n], vec![false; n]);
            for c in 0..n {
                let u = rng.next_f64();
                if u < 0.06 {
                    rows[c] = true;
                } else if u < 0.5 {
                    open[c] = true;
                    inside[c] = rng.next_f64() < 0.45;
                    surf[c] = rng.next_f64() < 0.05;
                }
            }
            let got = run(d, &rows, &open, &inside, &surf);
            let want = reference(d, &rows, &inside, &surf, false);
            assert_eq!(got, want, "case {case}");
            if reference(d, &rows, &inside, &surf, true) != want {
                diagonal_cases += 1;
            }
        }
        assert!(diagonal_cases >= 5, "only {diagonal_cases} cases need edge or corner contacts");
    }

    /// Case 0: 20 random triangles across the unit cube; 1: 150 small random cards (two
    /// triangles each); 2: a closed outward octahedron with 10 random triangles around it;
    /// 3: the octahedron with two small triangles beside it, in the planes x = 0.05 and
    /// y = 0.05, each in the way of one or two rows: the interior cells on both an x and a y
    /// row through them are undecided, alone among cells the rows made solid.
    fn soup(case: usize, rng: &mut SplitMix64) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut pt = || Vec3::new(rng.next_f64() as f32, rng.next_f64() as f32, rng.next_f64() as f32);
        let (mut pos, mut tris) = (Vec::new(), Vec::new());
        let add = |pos: &mut Vec<Vec3>, tris: &mut Vec<[u32; 3]>, c: [Vec3; 3]| {
            let b = pos.len() as u32;
            pos.extend(c);
            tris.push([b, b + 1, b + 2]);
        };
        match case % 4 {
            0 => {
                for _ in 0..20 {
                    let c = [pt(), pt(), pt()];
                    add(&mut pos, &mut tris, c);
                }
            }
            1 => {
                for _ in 0..150 {
                    let (c, a, b) = (pt(), (pt() - 0.5).normalize() * 0.05, (pt() - 0.5).normalize() * 0.05);
                    add(&mut pos, &mut tris, [c - a - b, c + a - b, c + a + b]);
                    add(&mut pos, &mut tris, [c - a - b, c + a + b, c - a + b]);
                }
            }
            _ => {
                let o = Vec3::splat(0.5);
                let ax = [Vec3::X * 0.3, Vec3::Y * 0.3, Vec3::Z * 0.3];
                for sx in [-1.0f32, 1.0] {
                    for sy in [-1.0f32, 1.0] {
                        for sz in [-1.0f32, 1.0] {
                            let (a, b, c) = (o + ax[0] * sx, o + ax[1] * sy, o + ax[2] * sz);
                            // Outward: counter-clockwise seen from the octant's side.
                            let flip = sx * sy * sz < 0.0;
                            add(&mut pos, &mut tris, if flip { [a, c, b] } else { [a, b, c] });
                        }
                    }
                }
                if case % 4 == 2 {
                    for _ in 0..10 {
                        let c = [pt(), pt(), pt()];
                        add(&mut pos, &mut tris, c);
                    }
                } else {
                    let (a, b) = (0.49 + 0.001 * case as f32, 0.53);
                    add(&mut pos, &mut tris, [Vec3::new(0.05, a, a), Vec3::new(0.05, b, a), Vec3::new(0.05, a, b)]);
                    add(&mut pos, &mut tris, [Vec3::new(a, 0.05, a), Vec3::new(a, 0.05, b), Vec3::new(b, 0.05, a)]);
                }
            }
        }
        (pos, tris)
    }

    /// The flood keeps exactly the 26-connected parts of the every-cell solid that hold a cell
    /// the rows decided or a cell the surface passes through (a brute-force labelling here).
    #[test]
    fn open_soup_solid_is_the_parts_that_reach_the_surface() {
        let mut rng = SplitMix64::new(11);
        let (mut added, mut dropped) = (0, 0);
        // Twelve soups at 40 cells, then five of 50 large random triangles at 48 cells.
        for case in 0..17 {
            let (res, (pos, tris)) = if case < 12 {
                (40, soup(case, &mut rng))
            } else {
                let mut rng = SplitMix64::new(case as u64 - 11);
                let mut pt = || Vec3::new(rng.next_f64() as f32, rng.next_f64() as f32, rng.next_f64() as f32);
                (48, ((0..150).map(|_| pt()).collect(), (0..50).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect()))
            };
            let bvh = TriangleBvh::new(&pos, &tris);
            let s = VoxelSettings { resolution: res };
            let every = voxelize_cells(&bvh, false, &s, Undecided::Every);
            let rows = voxelize_cells(&bvh, false, &s, Undecided::Skip);
            let flood = voxelize_cells(&bvh, false, &s, Undecided::FromSurface);
            assert_eq!(flood, voxelize_bvh(&bvh, false, &s));
            assert_eq!(flood, voxelize_cells(&bvh, false, &s, Undecided::FromSurfaceByTree), "case {case}");
            // The blocks decide as every cell's own evaluation would.
            assert_eq!(flood, voxelize_cells(&bvh, false, &s, Undecided::FromSurfacePerCell), "case {case}");
            let surf = surface_cells(&bvh, &every);
            // The per-cell tree query finds the same surface cells.
            assert!((0..every.cell_count()).all(|c| cell_meets_surface(&bvh, &every, c) == surf.get(c)), "case {case}");
            let [nx, ny, nz] = every.dims.map(|d| d as i64);
            let n = every.cell_count();
            let mut seen = vec![false; n];
            let mut want = Bits::new(n);
            for start in every.solid.ones() {
                if seen[start] {
                    continue;
                }
                seen[start] = true;
                let (mut part, mut q, mut reaches) = (vec![start], 0, false);
                while q < part.len() {
                    let c = part[q] as i64;
                    q += 1;
                    reaches |= rows.solid.get(c as usize) || surf.get(c as usize);
                    let (i, j, k) = (c % nx, c / nx % ny, c / (nx * ny));
                    for (di, dj, dk) in (0..27).map(|t| (t % 3 - 1, t / 3 % 3 - 1, t / 9 - 1)) {
                        let (a, b, d) = (i + di, j + dj, k + dk);
                        if a < 0 || b < 0 || d < 0 || a >= nx || b >= ny || d >= nz {
                            continue;
                        }
                        let m = (a + nx * (b + ny * d)) as usize;
                        if every.solid.get(m) && !seen[m] {
                            seen[m] = true;
                            part.push(m);
                        }
                    }
                }
                if reaches {
                    part.iter().for_each(|&c| want.set(c));
                }
            }
            assert!(flood.solid == want, "case {case}: {} cells against {}", flood.solid_count(), want.count_ones());
            if case < 12 && case % 4 == 3 {
                // Interior cells the rows left undecided, all solid (away from the surface).
                assert!(rows.solid != every.solid && flood.solid == every.solid, "case {case}");
            }
            added += flood.solid.count_and_not(&rows.solid);
            dropped += every.solid.count_and_not(&flood.solid);
        }
        // The winding pass decided cells in these soups (the test is not about the rows alone),
        // and the large random triangles leave cells inside that do not reach the surface
        // through cells inside (2 at seed 4 when written).
        assert!(added > 100 && dropped > 0, "{added} cells found by the flood, {dropped} dropped");
        println!(
            "flood added {added} cells to the rows' solid; {dropped} solid cells not reaching the surface dropped"
        );
    }

    /// The bound of [`Blocks`]: on a box that meets no triangle, the winding number (brute
    /// force) moves from the box centre by at most (1/4π) Σ |m| len / d² times the distance, over
    /// the unpaired edges. Random soups (a closed octahedron's paired edges must cancel: the bound
    /// is then about its holes and stray triangles only) and random boxes.
    #[test]
    fn the_winding_number_moves_no_faster_than_the_unpaired_edges_allow() {
        let mut rng = SplitMix64::new(5);
        let (mut checked, mut tight) = (0, 0.0f64);
        for case in 0..12 {
            let (pos, tris) = soup(case, &mut rng);
            let t64: Vec<[DVec3; 3]> = tris.iter().map(|t| t.map(|v| pos[v as usize].as_dvec3())).collect();
            let edges = unpaired_edges(&t64);
            let field = EdgeField::new(edges.clone());
            assert!(case % 4 >= 2 || field.clusters.len() > 1, "case {case}: the clusters are exercised");
            if case % 4 >= 2 {
                // The octahedron's 12 edges are paired: only the extra triangles' edges remain.
                let extra = t64.len() - 8;
                assert_eq!(edges.len(), 3 * extra, "case {case}");
            }
            let brute = |p: DVec3| {
                t64.iter().map(|t| crate::winding::solid_angle(t, p)).sum::<f64>() / (4.0 * std::f64::consts::PI)
            };
            for _ in 0..200 {
                let centre = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 1.4 - 0.2;
                let half = DVec3::splat(0.01 + 0.05 * rng.next_f64());
                if t64.iter().any(|t| tri_box_overlap(t, centre, half)) {
                    continue;
                }
                let r = half.length();
                let Some(bound) = field.gradient_bound(centre, r, f64::INFINITY) else {
                    continue;
                };
                // The clusters only ever raise the sum over the edges one by one.
                let each: f64 = edges
                    .iter()
                    .map(|&(a, b, m)| m * (b - a).length() / (segment_distance(centre, a, b) - r).powi(2))
                    .sum();
                assert!(bound >= each * (1.0 - 1e-12), "case {case}: {bound} < {each}");
                let g = bound / (4.0 * std::f64::consts::PI);
                let w0 = brute(centre);
                for _ in 0..8 {
                    let u = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 2.0 - 1.0;
                    let p = centre + u * half;
                    let moved = (brute(p) - w0).abs();
                    let allowed = g * (p - centre).length();
                    assert!(moved <= allowed + 1e-12, "case {case}: moved {moved} > {allowed}");
                    if allowed > 1e-6 {
                        tight = tight.max(moved / allowed);
                    }
                    checked += 1;
                }
            }
        }
        // Enough boxes were tested, and the bound is not vacuous (somewhere within 20× of the move).
        assert!(checked > 2000 && tight > 0.05, "{checked} points, tightest ratio {tight}");
    }

    /// Where the blocks are used (fewer unpaired edges than triangles), they decide as every
    /// cell's own evaluation would: boxes with large faces and holes, like Khronos' BoxAnimated
    /// (a box without its lid and one side, 8 triangles, so that only one axis of rows is
    /// conclusive inside it; a closed box inside it and one beside it; each face in two
    /// triangles; random sizes and places), at 24 to 49 cells.
    #[test]
    fn blocks_decide_open_boxes_as_their_cells_would() {
        let mut rng = SplitMix64::new(23);
        let corners = |lo: Vec3, hi: Vec3| -> Vec<Vec3> {
            (0..8).map(|i| Vec3::new([lo.x, hi.x][i & 1], [lo.y, hi.y][i >> 1 & 1], [lo.z, hi.z][i >> 2])).collect()
        };
        // Outward quads of the cube on corners 0..8 (x fastest), the top (+z) last.
        let quads = [[0, 2, 3, 1], [0, 1, 5, 4], [1, 3, 7, 5], [3, 2, 6, 7], [2, 0, 4, 6], [4, 5, 7, 6]];
        for case in 0..6 {
            let (mut pos, mut tris) = (Vec::new(), Vec::new());
            let mut add_box = |lo: Vec3, hi: Vec3, faces: usize| {
                let b = pos.len() as u32;
                pos.extend(corners(lo, hi));
                for q in &quads[..faces] {
                    tris.push([b + q[0], b + q[1], b + q[2]]);
                    tris.push([b + q[0], b + q[2], b + q[3]]);
                }
            };
            let mut r = || rng.next_f64() as f32;
            add_box(Vec3::ZERO, Vec3::new(1.0 + r(), 1.0 + r(), 1.0 + r()), 4);
            let (a, b) = (Vec3::splat(0.2 + 0.2 * r()), Vec3::splat(0.6 + 0.2 * r()));
            add_box(a, b, 6);
            add_box(Vec3::new(2.2, 0.0, 0.0), Vec3::new(2.5 + r(), 0.5, 0.5 + r()), 6);
            let bvh = TriangleBvh::new(&pos, &tris);
            let s = VoxelSettings { resolution: 24 + 5 * case as u32 };
            let before = BLOCKS_DECIDED.with(|n| n.get());
            let grid = voxelize_cells(&bvh, false, &s, Undecided::FromSurface);
            let decided = BLOCKS_DECIDED.with(|n| n.get()) - before;
            assert_eq!(grid, voxelize_cells(&bvh, false, &s, Undecided::FromSurfacePerCell), "case {case}");
            assert!(decided > 20, "case {case}: only {decided} blocks decided whole");
            assert!(grid.solid_count() > 0, "case {case}");
        }
    }
}

#[cfg(test)]
mod boundary_share_tests {
    use super::*;
    use crate::rng::SplitMix64;

    fn grid(dims: [u32; 3], solid: impl Fn(i64, i64, i64) -> bool) -> VoxelGrid {
        let n = dims.iter().map(|&d| d as usize).product();
        let mut bits = Bits::new(n);
        let mut c = 0;
        for k in 0..dims[2] as i64 {
            for j in 0..dims[1] as i64 {
                for i in 0..dims[0] as i64 {
                    if solid(i, j, k) {
                        bits.set(c);
                    }
                    c += 1;
                }
            }
        }
        VoxelGrid { origin: DVec3::ZERO, cell_size: 1.0, dims, solid: bits, covered_twice: 0 }
    }

    /// Small random grids (every cell probed) against a count written apart: a solid cell is on
    /// the boundary unless its six face neighbours are inside the grid and solid.
    #[test]
    fn small_grids_give_the_exact_share() {
        let mut rng = SplitMix64::new(7);
        for case in 0..40 {
            let dims = [1 + rng.below(9) as u32, 1 + rng.below(9) as u32, 1 + rng.below(9) as u32];
            let fill = [0.3, 0.7, 0.95, 1.0][case % 4];
            let cells: Vec<bool> = (0..dims.iter().product::<u32>()).map(|_| rng.next_f64() < fill).collect();
            let at = |i: i64, j: i64, k: i64| {
                let inside = (0..3).all(|t| [i, j, k][t] >= 0 && [i, j, k][t] < dims[t] as i64);
                inside && cells[(i + dims[0] as i64 * (j + dims[1] as i64 * k)) as usize]
            };
            let g = grid(dims, at);
            let (mut solid, mut boundary) = (0, 0);
            for k in 0..dims[2] as i64 {
                for j in 0..dims[1] as i64 {
                    for i in 0..dims[0] as i64 {
                        if at(i, j, k) {
                            solid += 1;
                            let nbs = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)];
                            boundary += nbs.iter().any(|&(a, b, c)| !at(i + a, j + b, k + c)) as usize;
                        }
                    }
                }
            }
            let want = if solid == 0 { 0.0 } else { boundary as f64 / solid as f64 };
            assert_eq!(g.boundary_share(), want, "case {case}, dims {dims:?}");
        }
    }

    /// Grids past the probe budget, against their analytic shares: a full 128³ grid
    /// ((128³ − 126³) / 128³), slabs t cells thick (2 / t), a solid ball (its shell's share).
    #[test]
    fn large_grids_are_estimated_within_a_percent() {
        let full = grid([128; 3], |_, _, _| true);
        assert!(full.cell_count() > 4 * BOUNDARY_SHARE_PROBES);
        let want = (128f64.powi(3) - 126f64.powi(3)) / 128f64.powi(3);
        assert!((full.boundary_share() - want).abs() < 0.01 * want + 1e-3, "{} against {want}", full.boundary_share());
        // The same box with empty cells around it, in grids of several sizes.
        for n in [129, 130, 131, 133, 136, 140] {
            let lo = (n - 128) / 2;
            let boxed = grid([n as u32; 3], |i, j, k| [i, j, k].iter().all(|&x| (lo..lo + 128).contains(&x)));
            let got = boxed.boundary_share();
            assert!((got - want).abs() < 0.05 * want, "box in {n}³: {got} against {want}");
        }
        for t in [1, 2, 3, 5] {
            let slab = grid([160, 160, 40], |i, j, k| {
                (1..159).contains(&i) && (1..159).contains(&j) && (10..10 + t).contains(&k)
            });
            // Its two faces (158² cells each) and, in each of the t − 2 layers between, its rim
            // (4 × 157 cells) are on the boundary, of 158² × t cells.
            let want = if t <= 2 {
                1.0
            } else {
                (2.0 * 158.0 * 158.0 + 4.0 * 157.0 * (t - 2) as f64) / (158.0 * 158.0 * t as f64)
            };
            let got = slab.boundary_share();
            assert!((got - want).abs() < 0.02 * want, "slab {t}: {got} against {want}");
        }
        let ball = grid([96; 3], |i, j, k| {
            let d = |x: i64| x as f64 + 0.5 - 48.0;
            d(i) * d(i) + d(j) * d(j) + d(k) * d(k) <= 40.0 * 40.0
        });
        let (solid, boundary) = (ball.solid_count(), {
            let b = &ball;
            b.solid
                .ones()
                .filter(|&idx| {
                    let c = b.cell_coords(idx);
                    (0..3).any(|a| [false, true].iter().any(|&p| !b.face_neighbour_solid(c, a, p)))
                })
                .count()
        });
        let want = boundary as f64 / solid as f64;
        assert!((ball.boundary_share() - want).abs() < 0.05 * want, "ball {} against {want}", ball.boundary_share());
    }

    /// Each block of a coarsened grid against a count of the fine cells whose centres lie in
    /// it (random grids of odd and even sizes, blocks 1–3, every threshold).
    #[test]
    fn a_coarsened_block_is_solid_when_enough_of_the_cells_it_holds_are() {
        let mut rng = SplitMix64::new(11);
        for case in 0..60 {
            let dims = [1 + rng.below(11) as u32, 1 + rng.below(11) as u32, 1 + rng.below(11) as u32];
            let fill = [0.2, 0.5, 0.8][case % 3];
            let cells: Vec<bool> = (0..dims.iter().product::<u32>()).map(|_| rng.next_f64() < fill).collect();
            let mut g = grid(dims, |i, j, k| cells[(i + dims[0] as i64 * (j + dims[1] as i64 * k)) as usize]);
            g.origin = DVec3::new(-1.5, 0.25, 3.0);
            g.cell_size = 0.1;
            let b = 1 + (case / 3 % 3) as u32;
            for min in 1..=b * b * b {
                let c = g.coarsened(b, min);
                assert_eq!(c.cell_size, 0.1 * b as f64);
                assert_eq!(c.origin, g.origin);
                // Blocks cover the fine grid, and no block lies wholly past it.
                for (a, (&cd, &d)) in c.dims.iter().zip(&dims).enumerate() {
                    assert!(cd * b >= d && (cd - 1) * b < d, "case {case} axis {a}");
                }
                let mut count = vec![0u32; c.cell_count()];
                for k in 0..dims[2] {
                    for j in 0..dims[1] {
                        for i in 0..dims[0] {
                            if g.solid.get(g.index(i, j, k)) {
                                let [ci, cj, ck] =
                                    c.cell_of(g.cell_center(i, j, k)).expect("a fine centre lies in a block");
                                count[c.index(ci, cj, ck)] += 1;
                            }
                        }
                    }
                }
                for (n, &m) in count.iter().enumerate() {
                    assert_eq!(c.solid.get(n), m >= min, "case {case}, block {b}, at least {min}: block {n} holds {m}");
                }
            }
        }
        // Thresholds beyond 1..=b³ are clamped: 0 does not make empty blocks solid.
        let g = grid([4, 4, 4], |i, _, _| i == 0);
        let ones = |c: VoxelGrid| c.solid.ones().collect::<Vec<_>>();
        assert_eq!(ones(g.coarsened(2, 0)), ones(g.coarsened(2, 1)));
        assert_eq!(ones(g.coarsened(2, 1)).len(), 4, "the blocks at x = 0");
        assert_eq!(g.coarsened(2, 99).solid.count_ones(), 0);
    }
}
