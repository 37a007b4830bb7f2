//! Surface tiles: each sample point as the planar patch its direction's Voronoi cell cuts out of its tangent plane,
//! and the exact irradiance of a planar polygon (Lambert's formula) for receivers close to the surface.
//!
//! A sample p_j of sphere (c, r) along geodesic direction ω_j stands for the surface its Voronoi cell (the
//! directions nearer to ω_j than to any other of the 92) sees from c. Its *tile* is the central projection of that
//! cell from c onto the sample's tangent plane {x : n_j·(x − p_j) = 0}: corner k is c + s_k v_k with v_k the cell's
//! k-th corner direction and s_k = n_j·(p_j − c) / (n_j·v_k), capped at min([`TILE_REACH`] t, max(r, t)),
//! t = |p_j − c| (the cap also applies where the plane is grazing or turned away, n_j·v_k ≤ 0). The cap at the
//! radius holds because a segment's surface lies inside its own sphere: a point of segment i has the smallest
//! scaled distance |x − c_i|/r_i, and the sphere that contains it has scaled distance ≤ 1, so tile area beyond the
//! ball stands for no surface of this segment (measured on the Duck at 64 spheres, splat oracle: 0.243 → 0.231).
//! For a locally planar surface the tiles of one sphere's samples tile its segment without gaps or overlaps, so a
//! receiver a hair under the surface (the ground under an object's belly) sees the whole surface above it, which
//! disks facing the receiver cannot give (their cosines vanish there).
//!
//! **Near the plane.** A receiver over a tile (its foot point on the tile's plane within the tile's reach of the
//! sample) and closer to the plane than h_min = [`TILE_MIN_HEIGHT`] · t is evaluated as if it stood h_min in front
//! of it (moved along the tile's normal): a tile is the tangent plane's stand-in, and that close the plane's
//! extrapolation beyond the curved surface, and for a posed leaf the rigid motion of its samples (which do not
//! follow the skinned surface), decide more than the tile does; a receiver right on the plane would otherwise see
//! a bright tile over half its view. Receivers near the plane's extension but beside the tile keep their place
//! (moving them would turn the tile towards them). Measured, 64 spheres, 4096 rays, uniform sky, rel RMSE ground /
//! model, for h_min / t = 0, 0.1, 0.2, 0.3, 0.5, 0.8: CesiumMan mid-walk (t = 1 s) 0.440 / 0.821, 0.383 / 0.625,
//! 0.339 / 0.530, 0.316 / 0.507, 0.307 / 0.524, 0.310 / 0.558; Duck 0.266 / 0.812, 0.253 / 0.815, 0.242 / 0.816,
//! 0.255 / 0.830, 0.302 / 0.865, 0.344 / 0.881; CesiumMan at rest 0.288 / 0.399, 0.288 / 0.398, 0.277 / 0.394,
//! 0.259 / 0.394, 0.256 / 0.402, 0.276 / 0.422; spot 0.128 / 0.585, 0.128 / 0.606, 0.128 / 0.643, 0.128 / 0.681,
//! 0.129 / 0.725, 0.129 / 0.743. 0.3 is the knee of the posed case.
//!
//! Irradiance of a planar polygon of unit radiance at p with unit normal N (Lambert 1760; e.g. Arvo 1995):
//! E = ½ |Σ_k Θ_k (û_k × û_{k+1})/|û_k × û_{k+1}| · N|, û_k the unit vectors from p to the corners, Θ_k the angle
//! between consecutive ones, after clipping the polygon to the receiver's upper half-space N·(x − p) ≥ 0
//! (Sutherland–Hodgman). A polygon covering the whole upper hemisphere gives π.
//!
//! **Areas.** The central projection gets a tile's size right only where the surface is locally planar and seen
//! from the centre without occlusion: a ray's farthest hit skips the nearer layers of a fold, rule 2 leaves the
//! directions of other segments empty, and curvature bends the surface away from the plane. Files of format minor 2
//! carry each sample's true share of the surface (spec §7.2, computed by the bake from the mesh); the tile is then
//! scaled about its sample to that area, so the tiles of a segment carry the segment's area, no more and no less.
//! Measured, 64 spheres, 4096 rays, uniform sky, ground rel RMSE with the splat oracle (every tile with the traced
//! radiance and ray-cast visibility), same fits: Duck 0.217 → 0.164, spot 0.097 → 0.057, CesiumMan 0.149 → 0.123.
//!
//! Cell corners: the circumcentres of the Delaunay triangles (the faces of the convex hull) of the 92 directions
//! around ω_j, in counter-clockwise order about ω_j (5 for the 12 icosahedron vertices, 6 elsewhere), computed once
//! in f64 from [`spherebake_sh::GEODESIC_DIRECTIONS`] ([`voronoi_cells`]).

use alloc::vec::Vec;
use spherebake_sh::{GEODESIC_DIRECTIONS, GEODESIC_DIRECTION_COUNT};

/// Largest number of corners of a Voronoi cell of the 92 directions (pentagons and hexagons).
pub const CELL_MAX_CORNERS: usize = 6;

/// Smallest distance of a receiver from a tile's plane, in units of the sample's distance t = |p_j − c| from its
/// sphere's centre (module docs, "Near the plane").
pub const TILE_MIN_HEIGHT: f64 = 0.3;

/// Cap of a tile corner's distance from the sphere centre, in units of the sample's own distance |p_j − c|.
pub const TILE_REACH: f64 = 2.0;

/// The Voronoi cell of one geodesic direction: unit corner directions, counter-clockwise about the direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// Corner directions (unit); only the first `count` are used.
    pub corners: [[f64; 3]; CELL_MAX_CORNERS],
    /// Number of corners (5 or 6).
    pub count: usize,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn norm(a: [f64; 3]) -> f64 {
    spherebake_sh::sqrt_f64(dot(a, a))
}

fn direction(j: usize) -> [f64; 3] {
    let d = GEODESIC_DIRECTIONS[j].map(f64::from);
    let l = norm(d);
    [d[0] / l, d[1] / l, d[2] / l]
}

/// The Voronoi cells of the 92 geodesic directions (see the module docs), index = direction.
#[must_use]
pub fn voronoi_cells() -> Vec<Cell> {
    let dirs: Vec<[f64; 3]> = (0..GEODESIC_DIRECTION_COUNT).map(direction).collect();
    let mut cells = Vec::with_capacity(GEODESIC_DIRECTION_COUNT);
    for (j, &d) in dirs.iter().enumerate() {
        // The nearest neighbours: at most 6 in a geodesic sphere; 8 candidates leave room for ties.
        let mut near: Vec<(f64, usize)> =
            dirs.iter().enumerate().filter(|&(k, _)| k != j).map(|(k, &e)| (-dot(d, e), k)).collect();
        near.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        near.truncate(8);
        // Tangent frame about d, for ordering the corners.
        let helper = if d[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
        let e1 = {
            let c = cross(d, helper);
            let l = norm(c);
            [c[0] / l, c[1] / l, c[2] / l]
        };
        let e2 = cross(d, e1);
        let mut corners: Vec<(f64, [f64; 3])> = Vec::new();
        for a in 0..near.len() {
            for b in a + 1..near.len() {
                let (pa, pb) = (dirs[near[a].1], dirs[near[b].1]);
                let mut m = cross(sub(pa, d), sub(pb, d));
                let l = norm(m);
                if l < 1e-12 {
                    continue;
                }
                m = [m[0] / l, m[1] / l, m[2] / l];
                if dot(m, d) < 0.0 {
                    m = [-m[0], -m[1], -m[2]];
                }
                // Delaunay: no direction lies strictly nearer to the circumcentre than the triangle's corners.
                let rad = dot(m, d);
                if dirs.iter().any(|&e| dot(m, e) > rad + 1e-9) {
                    continue;
                }
                if corners.iter().any(|(_, c)| dot(*c, m) > 1.0 - 1e-12) {
                    continue;
                }
                let ang = spherebake_sh::atan2_f64(dot(m, e2), dot(m, e1));
                corners.push((ang, m));
            }
        }
        corners.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut cell = Cell { corners: [[0.0; 3]; CELL_MAX_CORNERS], count: corners.len().min(CELL_MAX_CORNERS) };
        for (k, (_, m)) in corners.iter().take(CELL_MAX_CORNERS).enumerate() {
            cell.corners[k] = *m;
        }
        cells.push(cell);
    }
    cells
}

/// The tile of a sample (module docs): corners of the central projection of `cell` from `center` onto the plane
/// through `position` with unit normal `normal`, each at most min(2t, max(`radius`, t)) from the centre
/// (t = |position − center|). Returns the corner count (0 when the sample sits on the centre or is not finite).
pub fn sample_tile(
    cell: &Cell,
    center: [f64; 3],
    radius: f64,
    position: [f64; 3],
    normal: [f64; 3],
    out: &mut [[f64; 3]; CELL_MAX_CORNERS],
) -> usize {
    let rel = sub(position, center);
    let t = norm(rel);
    if t.is_nan() || t <= 0.0 || !t.is_finite() || !radius.is_finite() {
        return 0;
    }
    let num = dot(normal, rel);
    let cap = (TILE_REACH * t).min(radius.max(t));
    let count = cell.count.min(CELL_MAX_CORNERS);
    for (o, &v) in out.iter_mut().zip(&cell.corners[..count]) {
        let den = dot(normal, v);
        let s = if den > 0.0 && num > 0.0 { (num / den).min(cap) } else { cap };
        *o = [center[0] + s * v[0], center[1] + s * v[1], center[2] + s * v[2]];
    }
    count
}

/// Area of a planar polygon (corners in order): half the length of Σ c_k × c_{k+1}. 0 for fewer than 3 corners.
#[must_use]
pub fn polygon_area(corners: &[[f64; 3]]) -> f64 {
    let mut s = [0.0f64; 3];
    for (k, a) in corners.iter().enumerate() {
        let b = corners[(k + 1) % corners.len()];
        let c = cross(*a, b);
        s = [s[0] + c[0], s[1] + c[1], s[2] + c[2]];
    }
    if corners.len() < 3 {
        return 0.0;
    }
    0.5 * norm(s)
}

/// Scales a tile about its sample `x` so that its area becomes `area` (the file's sample area, spec §7.2): corners
/// move by √(area / A) along their offsets from `x`. Unchanged when `area` is `None`, not finite or negative, or the
/// tile has no area.
pub fn scale_tile_to_area(tile: &mut [[f64; 3]], x: [f64; 3], area: Option<f64>) {
    let Some(a) = area.filter(|a| a.is_finite() && *a >= 0.0) else { return };
    let current = polygon_area(tile);
    if !(current.is_finite() && current > 0.0) {
        return;
    }
    let f = spherebake_sh::sqrt_f64(a / current);
    for c in tile.iter_mut() {
        *c = [x[0] + f * (c[0] - x[0]), x[1] + f * (c[1] - x[1]), x[2] + f * (c[2] - x[2])];
    }
}

/// One sample's tile, everything relative to its sphere's centre: the direction cell `cell` of a sphere of radius
/// `radius`, the sample at `x` with unit outward normal `normal`, and the file's sample `area` (spec §7.2; the tile
/// is scaled to it about the sample, [`scale_tile_to_area`], module docs "Areas").
#[derive(Clone, Copy, Debug)]
pub struct SampleTile<'c> {
    /// The Voronoi cell of the sample's direction ([`voronoi_cells`]).
    pub cell: &'c Cell,
    /// The sphere's radius, model units.
    pub radius: f64,
    /// The sample point relative to the centre.
    pub x: [f64; 3],
    /// The sample's unit outward normal.
    pub normal: [f64; 3],
    /// The sample's surface area (model units²), or `None` for the tile's own.
    pub area: Option<f64>,
}

impl SampleTile<'_> {
    /// Irradiance at a receiver at `p` with unit normal `n` (relative to the centre too) from the tile, per unit
    /// radiance. 0 when the receiver stands behind the tile's plane (tiles emit on their front side); over the tile
    /// and closer to its plane than [`TILE_MIN_HEIGHT`] · |x| it is moved out to that height (module docs, "Near
    /// the plane"). Allocation-free.
    #[must_use]
    pub fn irradiance(&self, p: [f64; 3], n: [f64; 3]) -> f64 {
        let (x, normal) = (self.x, self.normal);
        let Some((tile, k, h)) = self.facing(p) else { return 0.0 };
        let h_min = TILE_MIN_HEIGHT * norm(x);
        // Over the tile: the receiver's foot point on the plane lies within the tile's reach from the sample.
        let d = sub(p, x);
        let lateral2 = dot(d, d) - h * h;
        let reach2 = tile[..k].iter().map(|c| dot(sub(*c, x), sub(*c, x))).fold(0.0f64, f64::max);
        let q = if h < h_min && lateral2 <= reach2 {
            let s = h_min - h;
            [p[0] + s * normal[0], p[1] + s * normal[1], p[2] + s * normal[2]]
        } else {
            p
        };
        polygon_irradiance(q, n, &tile[..k])
    }

    /// Share of the cosine-weighted view of a receiver at `p` (unit normal `n`) that the tile covers, in [0, 1] (its
    /// polygon irradiance / π), as [`SampleTile::irradiance`] but with the receiver where it is (no near-plane rule:
    /// a receiver against a tile is covered by it). 0 behind the tile's plane. Allocation-free.
    #[must_use]
    pub fn cover(&self, p: [f64; 3], n: [f64; 3]) -> f64 {
        let Some((tile, k, _)) = self.facing(p) else { return 0.0 };
        polygon_irradiance(p, n, &tile[..k]) / core::f64::consts::PI
    }

    /// The tile scaled to its area ([`sample_tile`], [`scale_tile_to_area`]), its corner count and the receiver's
    /// height over its plane; `None` when the receiver is not in front of it.
    fn facing(&self, p: [f64; 3]) -> Option<([[f64; 3]; CELL_MAX_CORNERS], usize, f64)> {
        let h = dot(sub(p, self.x), self.normal);
        if h.is_nan() || h <= 0.0 {
            return None;
        }
        let mut tile = [[0.0f64; 3]; CELL_MAX_CORNERS];
        let k = sample_tile(self.cell, [0.0; 3], self.radius, self.x, self.normal, &mut tile);
        scale_tile_to_area(&mut tile[..k], self.x, self.area);
        Some((tile, k, h))
    }
}

/// Irradiance at `p` (unit normal `n`) from a planar polygon of unit radiance (module docs): its projected solid
/// angle, in [0, π], after clipping to the half-space n·(x − p) ≥ 0. At most [`CELL_MAX_CORNERS`] corners are read;
/// fewer than 3 give 0. Allocation-free.
#[must_use]
pub fn polygon_irradiance(p: [f64; 3], n: [f64; 3], corners: &[[f64; 3]]) -> f64 {
    let count = corners.len().min(CELL_MAX_CORNERS);
    if count < 3 {
        return 0.0;
    }
    // Clip (Sutherland–Hodgman) in coordinates relative to p.
    let mut q = [[0.0f64; 3]; CELL_MAX_CORNERS + 1];
    let mut m = 0usize;
    for k in 0..count {
        let a = sub(corners[k], p);
        let b = sub(corners[(k + 1) % count], p);
        let (ha, hb) = (dot(a, n), dot(b, n));
        if ha >= 0.0 && m < q.len() {
            q[m] = a;
            m += 1;
        }
        if (ha >= 0.0) != (hb >= 0.0) && m < q.len() {
            let t = ha / (ha - hb);
            q[m] = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])];
            m += 1;
        }
    }
    if m < 3 {
        return 0.0;
    }
    let mut u = [[0.0f64; 3]; CELL_MAX_CORNERS + 1];
    for k in 0..m {
        let l = norm(q[k]);
        if l.is_nan() || l <= 0.0 {
            // The receiver sits on a corner (or the input is not finite): no defined view.
            return 0.0;
        }
        u[k] = [q[k][0] / l, q[k][1] / l, q[k][2] / l];
    }
    let mut sum = 0.0;
    for k in 0..m {
        let (a, b) = (u[k], u[(k + 1) % m]);
        let c = cross(a, b);
        let s = norm(c);
        if s <= 0.0 {
            continue;
        }
        let theta = spherebake_sh::atan2_f64(s, dot(a, b));
        sum += theta * dot(c, n) / s;
    }
    if !sum.is_finite() {
        return 0.0;
    }
    (0.5 * sum).abs().min(core::f64::consts::PI)
}

/// Solid angle (steradians) of the Voronoi cell of direction `j`: the fan of spherical triangles (ω_j, c_k, c_k+1)
/// over its corners, each by Van Oosterom and Strackee's tan(Ω/2) = |a·(b×c)| / (1 + a·b + b·c + c·a).
#[must_use]
pub fn cell_solid_angle(cell: &Cell, j: usize) -> f64 {
    let a = direction(j);
    let n = cell.count.min(CELL_MAX_CORNERS);
    let mut total = 0.0;
    for k in 0..n {
        let b = cell.corners[k];
        let c = cell.corners[(k + 1) % n];
        let num = dot(a, cross(b, c)).abs();
        let den = 1.0 + dot(a, b) + dot(b, c) + dot(c, a);
        total += 2.0 * spherebake_sh::atan2_f64(num, den);
    }
    total
}
