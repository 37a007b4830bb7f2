//! Surface sample points per sphere (Guerrero et al. 2008 §4.2; math reference §8).
//!
//! Each sphere i = (cᵢ, rᵢ) of the set owns the *segment* Pᵢ: the surface points p whose scaled
//! distance d(p, Sⱼ) = |p − cⱼ| / rⱼ is smallest for j = i (ties to the lowest index, decided in
//! f64 on the stored f32 values of p, c and r). For each of the 92 geodesic directions ω
//! ([`spherebake_sh::GEODESIC_DIRECTIONS`], §5 order) the ray cᵢ + tω, t > 0, is cast through the
//! triangle BVH and classified with the *outward* normal of each hit triangle (the
//! counter-clockwise geometric normal, negated where [`spherebake_geom::orient`] says so): a hit is
//! back-side when n·ω > 0 (the ray leaves the object), front-side when n·ω < 0.
//!
//! 1. There are back-side hits and at least one lies in Pᵢ: the sample is the farthest such hit.
//! 2. There are back-side hits, none in Pᵢ: no sample (another sphere covers that part).
//! 3. There is no back-side hit (for a closed mesh: no hit at all, cᵢ is outside the object):
//!    cast cᵢ − tω and take the nearest front-side hit (n·(−ω) < 0) that lies in Pᵢ; no sample
//!    when there is none. Front-side hits along +ω are ignored throughout (for an open mesh a
//!    ray with only front-side hits along +ω falls under rule 3).
//!
//! Stored per sample ([`spherebake_format::SamplePoint`]): the hit position (barycentric
//! interpolation of the triangle's corners, model space, f32), the outward unit normal (the
//! vertex shading normals interpolated at the hit and renormalised, negated when it points
//! against the oriented geometric normal; the geometric normal when the mesh has no usable
//! vertex normals there, as at a glTF primitive without NORMAL, which holds
//! `spherebake_geom::normals::NO_NORMAL` and so is shaded flat), the direction index and the
//! rule (1 or 3). Samples are in increasing direction order.
//!
//! Ties: hits at equal t are ordered by triangle index (a ray through a shared edge reports both
//! triangles); rule 1 takes the last of the farthest, rule 3 the first of the nearest.
//! Input tolerance: spheres with a non-finite centre or a radius that is not finite and > 0
//! (the fitter may emit radius-0 spheres) own no segment and get no samples (their directions
//! are counted as [`RuleCounts::skipped`]); `flip` and `mesh.normals` entries that are missing count as
//! "not flipped" and "no shading normal". Nothing here panics on input data.
//!
//! Cost: 92 rays per sphere (plus 92 reverse rays for rule 3), each O(log T + hits); every hit
//! tested for segment membership walks a small bounding tree over the sphere centres (nodes
//! farther than dᵢ · r_max are skipped; early exit on the first sphere that beats i), about
//! O(log S) for well-spread sets, O(S) at worst.
//! Parallel over spheres with rayon, ordered collect: identical output for any thread count.

use glam::{DVec3, Vec3};
use rayon::prelude::*;
use serde::Serialize;
use spherebake_format::{SamplePoint, Samples};
use spherebake_geom::bvh::{Hit, TriangleBvh};
use spherebake_geom::Mesh;
use spherebake_sh::{NearestDirection, GEODESIC_DIRECTIONS, GEODESIC_DIRECTION_COUNT};
use std::time::Instant;

/// What happened for one (sphere, direction) pair.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RuleCounts {
    /// Rule 1: farthest back-side hit in the segment (a sample).
    pub rule1: u32,
    /// Rule 2: back-side hits, all outside the segment (no sample).
    pub rule2_empty: u32,
    /// Rule 3 with a front-side hit in the segment along −ω (a sample).
    pub rule3: u32,
    /// Rule 3 without such a hit (no sample).
    pub rule3_empty: u32,
    /// Directions of spheres that own no segment (radius 0 or invalid): not cast, no sample.
    pub skipped: u32,
}

impl RuleCounts {
    fn add(&mut self, o: &RuleCounts) {
        self.rule1 += o.rule1;
        self.rule2_empty += o.rule2_empty;
        self.rule3 += o.rule3;
        self.rule3_empty += o.rule3_empty;
        self.skipped += o.skipped;
    }

    /// Directions accounted for (92 per sphere).
    pub fn total(&self) -> u32 {
        self.rule1 + self.rule2_empty + self.rule3 + self.rule3_empty + self.skipped
    }
}

/// Statistics of one [`place_samples`] run.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct SampleStats {
    /// Mean number of samples per sphere (0 without spheres).
    pub samples_per_sphere_mean: f64,
    /// Fewest samples of any sphere (0 without spheres).
    pub samples_per_sphere_min: u32,
    /// Share of all (sphere, direction) pairs left empty by rule 2, in [0, 1].
    pub share_rule2_empty: f64,
    /// Share of all (sphere, direction) pairs left empty by rule 3, in [0, 1].
    pub share_rule3_empty: f64,
    /// Totals over all spheres.
    pub counts: RuleCounts,
    /// Per sphere, in sphere order.
    pub per_sphere: Vec<RuleCounts>,
    /// Sample areas (`sample_areas`, spec §7.2): their sum, model units².
    pub area_assigned: f64,
    /// Mesh area in segments of spheres without samples (no sample to carry it), model units².
    pub area_unassigned: f64,
    /// Sub-triangles the area was split into.
    pub area_points: u64,
    /// Wall time of the stage, seconds.
    pub seconds: f64,
}

/// Places the surface samples of every sphere (see the module docs).
///
/// `bvh` must be built on `mesh.triangles` in their order, over `mesh.positions` or over the
/// welded ids and positions (the same corners; the hit barycentrics are applied to the
/// unwelded vertices' normals). `flip[t]` is true when triangle t's counter-clockwise
/// normal points inward ([`spherebake_geom::orient::outward_orientation`]). `spheres` are
/// `[x, y, z, r]`, model space, the stored f32 values.
///
/// Typical wiring (the triangle order of `welded_triangles()` is that of `mesh.triangles`):
/// ```text
/// let welded = mesh.welded_triangles();
/// let winding = WindingNumber::new(&mesh.welded_positions, &welded);
/// let orient = outward_orientation(&mesh.welded_positions, &welded, &winding);
/// let bvh = winding.into_bvh(); // or TriangleBvh::new(&mesh.positions, &mesh.triangles)
/// let (samples, stats) = place_samples(&mesh, &bvh, &orient.flip, &spheres);
/// ```
pub fn place_samples(mesh: &Mesh, bvh: &TriangleBvh, flip: &[bool], spheres: &[[f32; 4]]) -> (Samples, SampleStats) {
    let start = Instant::now();
    let ctx = Ctx::new(mesh, flip, spheres);
    let per: Vec<(Vec<SamplePoint>, RuleCounts)> =
        (0..spheres.len()).into_par_iter().map_init(Vec::new, |hits, i| ctx.sphere_samples(bvh, i, hits)).collect();
    let mut stats = SampleStats::default();
    let mut samples = Samples::default();
    let mut min = u32::MAX;
    for (s, c) in per {
        min = min.min(s.len() as u32);
        stats.counts.add(&c);
        stats.per_sphere.push(c);
        samples.push_sphere(&s);
    }
    let n = spheres.len();
    if n > 0 {
        let pairs = (n * GEODESIC_DIRECTION_COUNT) as f64;
        stats.samples_per_sphere_mean = samples.total() as f64 / n as f64;
        stats.samples_per_sphere_min = min;
        stats.share_rule2_empty = stats.counts.rule2_empty as f64 / pairs;
        stats.share_rule3_empty = stats.counts.rule3_empty as f64 / pairs;
    }
    let (areas, area) = sample_areas(mesh, &ctx, &samples);
    samples.areas = Some(areas);
    stats.area_assigned = area.assigned;
    stats.area_unassigned = area.unassigned;
    stats.area_points = area.points;
    stats.seconds = start.elapsed().as_secs_f64();
    (samples, stats)
}

/// Sub-triangle edge target for [`sample_areas`], as a share of the median sphere radius: a
/// sample's tile is about 0.37 t across (t its distance from the centre), so a tenth of a radius
/// puts ~10 sub-triangles or more on each tile.
const AREA_EDGE_PER_RADIUS: f64 = 0.1;
/// Most sub-triangles [`sample_areas`] uses in all (it coarsens its edge target until the
/// subdivision fits; a mesh with more triangles than this uses one point per triangle).
const AREA_MAX_POINTS: u64 = 1 << 22;
/// Most sub-triangles per sample (or one per triangle, if that is more): the work follows the
/// output. Without it, a fit that leaves many spheres tiny (the capsule at `--voxels 64`: more
/// than half of its radii below 10⁻⁶) set a tiny median radius and spent 7 s on 2²² points for
/// 408 samples. Measured at 64 spheres, the Duck, CesiumMan, spot, the bunny and the capsule
/// use 52–123 per sample, so this bound leaves them unchanged.
const AREA_MAX_POINTS_PER_SAMPLE: u64 = 256;
/// Most subdivisions of one triangle edge.
const AREA_MAX_SPLIT: u64 = 256;
/// Triangles per parallel work item (a constant, so the summation order, and with it every bit
/// of the result, does not depend on the thread count).
const AREA_CHUNK: usize = 1024;

/// Totals of one [`sample_areas`] run.
#[derive(Clone, Copy, Debug, Default)]
struct AreaTotals {
    assigned: f64,
    unassigned: f64,
    points: u64,
}

/// The surface area each sample stands for (spec §7.2, format minor 2), one per sample in
/// `samples` order, f32 model units². Every triangle is split uniformly into m² sub-triangles
/// (m = ⌈longest edge / h⌉, h = [`AREA_EDGE_PER_RADIUS`] × the median radius of the spheres
/// with samples, at least the mesh's longest edge / [`AREA_MAX_SPLIT`], coarsened
/// until at most [`AREA_MAX_POINTS`] sub-triangles and [`AREA_MAX_POINTS_PER_SAMPLE`] per sample,
/// or one per triangle, m ≤ [`AREA_MAX_SPLIT`]); each sub-triangle's
/// area goes to the sphere whose segment holds its centroid (smallest scaled distance, the same
/// rule as the samples) and there to the sample whose direction is nearest to the centroid's
/// direction from the centre, or when that direction has no sample, to the sample whose
/// direction is nearest to that direction. So a sphere's areas sum to its segment's area, and
/// all areas to the mesh's, except segments of spheres without samples.
///
/// Cost: O(P (log S + 92)) for P ≤ max(T, min([`AREA_MAX_POINTS`], 256 × samples)) points, parallel over fixed
/// chunks of triangles, summed in point order (deterministic for any thread count). A split
/// triangle walks the sphere tree once for its box's candidate owners, its points then scan
/// only those (the fast bunny's 280 000 points: 140 M instructions fewer than a walk per point).
fn sample_areas(mesh: &Mesh, ctx: &Ctx<'_>, samples: &Samples) -> (Vec<f32>, AreaTotals) {
    let mut totals = AreaTotals::default();
    let total = samples.total();
    // Per (sphere, direction): the global index of the sample that carries that direction.
    let n = samples.sphere_count();
    let mut carrier = vec![u32::MAX; n * GEODESIC_DIRECTION_COUNT];
    for i in 0..n {
        let range = samples.range_of(i);
        let own: Vec<(usize, u32)> =
            samples.of(i).iter().zip(range).map(|(p, g)| (usize::from(p.direction), g as u32)).collect();
        if own.is_empty() {
            continue;
        }
        for k in 0..GEODESIC_DIRECTION_COUNT {
            let wk = Vec3::from(GEODESIC_DIRECTIONS[k]).as_dvec3();
            let mut best: Option<(f64, u32)> = None;
            for &(j, g) in &own {
                let Some(wj) = GEODESIC_DIRECTIONS.get(j) else { continue };
                let d = wk.dot(Vec3::from(*wj).as_dvec3());
                if best.is_none_or(|(bd, _)| d > bd) {
                    best = Some((d, g));
                }
            }
            if let Some((_, g)) = best {
                carrier[i * GEODESIC_DIRECTION_COUNT + k] = g;
            }
        }
    }
    // The median radius of the spheres that carry samples: a fit stores the spheres it left
    // empty at the least positive normal f32 radius, and when they are the majority (the capsule at
    // 64 spheres uses 9) a median over all would set a sub-triangle edge of 10⁻³⁹.
    let mut radii: Vec<f64> =
        ctx.spheres.iter().filter(|s| s.2 < n && !samples.of(s.2).is_empty()).map(|s| s.1).collect();
    radii.sort_by(f64::total_cmp);
    let Some(&median) = radii.get(radii.len() / 2) else {
        return (vec![0.0; total], totals);
    };
    // Longest edge per triangle (NaN where it cannot be used): the subdivision's only input that the
    // budget loop below needs; corners are read again in the parallel pass.
    let corners = |t: usize| ctx.corners(t as u32).filter(|c| c.iter().all(|v| v.is_finite()));
    let longest: Vec<f64> = (0..mesh.triangles.len())
        .map(|t| {
            corners(t)
                .map_or(f64::NAN, |c| (c[1] - c[0]).length().max((c[2] - c[1]).length()).max((c[0] - c[2]).length()))
        })
        .collect();
    let split = |h: f64, longest: f64| -> u64 { ((longest / h).ceil() as u64).clamp(1, AREA_MAX_SPLIT) };
    let max_points = AREA_MAX_POINTS.min(AREA_MAX_POINTS_PER_SAMPLE.saturating_mul(total as u64));
    // Below the longest edge over AREA_MAX_SPLIT, the longest triangles' splits are clamped and
    // the count below stops following h², so the coarsening step could not catch up with a
    // tiny start; from this floor on it does, in a few steps.
    let longest_edge = longest.iter().copied().filter(|l| l.is_finite()).fold(0.0, f64::max);
    let mut h = (AREA_EDGE_PER_RADIUS * median).max(longest_edge / AREA_MAX_SPLIT as f64);
    for _ in 0..32 {
        let count: u64 = longest.iter().filter(|l| l.is_finite()).map(|&l| split(h, l).pow(2)).sum();
        if count <= max_points {
            break;
        }
        h *= ((count as f64 / max_points as f64).sqrt()).max(1.01);
    }
    let nearest = NearestDirection::new();
    // The sample that carries a surface point: its segment's sphere (the previous point's
    // owner as the search's hint), then the nearest direction (the largest dot product, ties
    // to the lowest index).
    // With `cands` (the spheres that may own a point of the point's triangle), the owner is
    // found among them alone: the same answer.
    let carrier_of = |x: DVec3, hint: &mut Option<usize>, cands: Option<&[(usize, f64)]>| -> Option<u32> {
        let (slot, k, ck) = match cands {
            Some(cands) => SphereTree::owner_among(&ctx.spheres, cands, x)?,
            None => ctx.tree.owner(&ctx.spheres, x, *hint)?,
        };
        *hint = Some(slot);
        let q = nearest.nearest((x - ck).to_array());
        carrier.get(k * GEODESIC_DIRECTION_COUNT + q).copied().filter(|&g| g != u32::MAX)
    };
    let per_chunk: Vec<(Vec<(u32, f64)>, AreaTotals)> = longest
        .par_chunks(AREA_CHUNK)
        .enumerate()
        .map(|(ci, chunk)| {
            let mut out: Vec<(u32, f64)> = Vec::new();
            let mut t = AreaTotals::default();
            let mut hint = None;
            let mut cands = Vec::new();
            for (k, &edge) in chunk.iter().enumerate() {
                let Some(c) = corners(ci * AREA_CHUNK + k).filter(|_| edge.is_finite()) else { continue };
                let m = split(h, edge);
                let area = 0.5 * (c[1] - c[0]).cross(c[2] - c[0]).length();
                if !(area.is_finite() && area > 0.0) {
                    continue;
                }
                let w = area / (m * m) as f64;
                let (e1, e2) = ((c[1] - c[0]) / m as f64, (c[2] - c[0]) / m as f64);
                // Split triangles (four points or more) find their points' owners among the
                // spheres that may own a point of the triangle's box, padded for the rounding
                // of the points (a few ulps of the corners), listed once: a list of a few
                // where each point's own walk of the sphere tree visits dozens.
                let cands = (m > 1).then(|| {
                    let (lo, hi) = (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2]));
                    let pad = DVec3::splat((lo.abs().max(hi.abs()).max_element() + (hi - lo).max_element()) * 1e-9);
                    ctx.tree.candidates(&ctx.spheres, lo - pad, hi + pad, hint, &mut cands);
                    &cands[..]
                });
                // Upward sub-triangles (i, j), i + j ≤ m − 1, centroid at (i + ⅓, j + ⅓); downward
                // ones, i + j ≤ m − 2, at (i + ⅔, j + ⅔), in units of the edge steps.
                for i in 0..m {
                    for j in 0..m - i {
                        for (off, ok) in [(1.0 / 3.0, true), (2.0 / 3.0, i + j + 2 <= m)] {
                            if !ok {
                                continue;
                            }
                            t.points += 1;
                            match carrier_of(c[0] + e1 * (i as f64 + off) + e2 * (j as f64 + off), &mut hint, cands) {
                                Some(g) => {
                                    out.push((g, w));
                                    t.assigned += w;
                                }
                                None => t.unassigned += w,
                            }
                        }
                    }
                }
            }
            (out, t)
        })
        .collect();
    // Each sample's area is summed in the points' order (chunk by chunk, each list in push
    // order), whatever the threads; the lists need no sorting: the sums of different samples
    // never mix.
    let mut acc = vec![0.0f64; total];
    for (list, t) in per_chunk {
        for (g, w) in list {
            if let Some(a) = acc.get_mut(g as usize) {
                *a += w;
            }
        }
        totals.assigned += t.assigned;
        totals.unassigned += t.unassigned;
        totals.points += t.points;
    }
    (acc.into_iter().map(|a| a as f32).collect(), totals)
}

/// Index of the sphere whose segment contains `p`: argmin |p − cⱼ| / rⱼ, ties to the lowest
/// index, f64. `None` when no sphere is valid (see the module docs).
pub fn segment_of(p: Vec3, spheres: &[[f32; 4]]) -> Option<usize> {
    let p = p.as_dvec3();
    let mut best: Option<(usize, f64)> = None;
    for (j, s) in spheres.iter().enumerate() {
        let Some((c, r)) = valid_sphere(s) else { continue };
        let d = (p - c).length() / r;
        if best.is_none_or(|(_, bd)| d < bd) {
            best = Some((j, d));
        }
    }
    best.map(|(j, _)| j)
}

/// A sphere that owns a segment: finite, with a radius above the least positive normal f32. A fit
/// stores the spheres it leaves empty at exactly that radius (a point: the format asks r > 0); they
/// own no segment and get no samples, like a sphere of radius 0. They used to get samples, of no
/// area, whose light the runtime drops (the capsule at 64 spheres: 193 of its 405 samples).
fn valid_sphere(s: &[f32; 4]) -> Option<(DVec3, f64)> {
    let c = DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64);
    let r = s[3] as f64;
    (c.is_finite() && r.is_finite() && r > f64::from(f32::MIN_POSITIVE)).then_some((c, r))
}

struct Ctx<'a> {
    mesh: &'a Mesh,
    flip: &'a [bool],
    /// Valid spheres as (centre, radius, index); invalid ones are left out.
    spheres: Vec<(DVec3, f64, usize)>,
    tree: SphereTree,
    raw: &'a [[f32; 4]],
    has_normals: bool,
}

impl<'a> Ctx<'a> {
    fn new(mesh: &'a Mesh, flip: &'a [bool], spheres: &'a [[f32; 4]]) -> Self {
        let mut valid: Vec<(DVec3, f64, usize)> =
            spheres.iter().enumerate().filter_map(|(j, s)| valid_sphere(s).map(|(c, r)| (c, r, j))).collect();
        let tree = SphereTree::build(&mut valid);
        Ctx { mesh, flip, spheres: valid, tree, raw: spheres, has_normals: mesh.normals.len() == mesh.positions.len() }
    }

    /// True when `p` lies in sphere `i`'s segment: no sphere j has a smaller scaled distance
    /// (j < i: not larger).
    fn in_segment(&self, p: DVec3, i: usize, ci: DVec3, ri: f64) -> bool {
        let di = (p - ci).length() / ri;
        !self.tree.any_beats(&self.spheres, p, i, di)
    }

    fn corners(&self, t: u32) -> Option<[DVec3; 3]> {
        let tri = self.mesh.triangles.get(t as usize)?;
        let mut out = [DVec3::ZERO; 3];
        for (o, &v) in out.iter_mut().zip(tri) {
            *o = self.mesh.positions.get(v as usize)?.as_dvec3();
        }
        Some(out)
    }

    /// Outward geometric unit normal of triangle t.
    fn outward(&self, t: u32, corners: &[DVec3; 3]) -> Option<DVec3> {
        let flip = self.flip.get(t as usize).copied().unwrap_or(false);
        spherebake_geom::orient::oriented_normal(*corners, flip)
    }

    /// The stored position (f32) and normal of a hit.
    fn sample_at(&self, h: &Hit, corners: &[DVec3; 3], n_geo: DVec3) -> (Vec3, Vec3) {
        let (u, v) = (h.u as f64, h.v as f64);
        let w = [1.0 - u - v, u, v];
        let p = corners[0] * w[0] + corners[1] * w[1] + corners[2] * w[2];
        let mut n = n_geo;
        if self.has_normals {
            let tri = self.mesh.triangles[h.triangle as usize];
            let s: DVec3 = (0..3).map(|k| self.mesh.normals[tri[k] as usize].as_dvec3() * w[k]).sum();
            if let Some(s) = s.try_normalize() {
                n = if s.dot(n_geo) < 0.0 { -s } else { s };
            }
        }
        (p.as_vec3(), n.as_vec3())
    }

    fn sphere_samples(&self, bvh: &TriangleBvh, i: usize, hits: &mut Vec<Hit>) -> (Vec<SamplePoint>, RuleCounts) {
        let mut counts = RuleCounts::default();
        let mut out = Vec::new();
        let Some((ci, ri)) = valid_sphere(&self.raw[i]) else {
            counts.skipped = GEODESIC_DIRECTION_COUNT as u32;
            return (out, counts);
        };
        let origin = Vec3::new(self.raw[i][0], self.raw[i][1], self.raw[i][2]);
        for (k, d) in GEODESIC_DIRECTIONS.iter().enumerate() {
            let omega = Vec3::from_array(*d);
            let od = omega.as_dvec3();
            bvh.ray_hits(origin, omega, 0.0, f32::INFINITY, hits);
            let mut any_back = false;
            let mut found = None;
            // Farthest first: the first back-side hit in the segment is the sample.
            for h in hits.iter().rev() {
                let Some(corners) = self.corners(h.triangle) else { continue };
                let Some(n) = self.outward(h.triangle, &corners) else { continue };
                if n.dot(od) <= 0.0 {
                    continue;
                }
                any_back = true;
                let (p, normal) = self.sample_at(h, &corners, n);
                if self.in_segment(p.as_dvec3(), i, ci, ri) {
                    found = Some((p, normal));
                    break;
                }
            }
            let rule = if let Some(s) = found {
                counts.rule1 += 1;
                Some((s, 1))
            } else if any_back {
                counts.rule2_empty += 1;
                None
            } else {
                bvh.ray_hits(origin, -omega, 0.0, f32::INFINITY, hits);
                let mut found = None;
                for h in hits.iter() {
                    let Some(corners) = self.corners(h.triangle) else { continue };
                    let Some(n) = self.outward(h.triangle, &corners) else { continue };
                    // Front-side along −ω: n·(−ω) < 0.
                    if n.dot(-od) >= 0.0 {
                        continue;
                    }
                    let (p, normal) = self.sample_at(h, &corners, n);
                    if self.in_segment(p.as_dvec3(), i, ci, ri) {
                        found = Some((p, normal));
                        break;
                    }
                }
                match found {
                    Some(s) => {
                        counts.rule3 += 1;
                        Some((s, 3))
                    }
                    None => {
                        counts.rule3_empty += 1;
                        None
                    }
                }
            };
            if let Some(((p, n), rule)) = rule {
                out.push(SamplePoint { position: p.to_array(), normal: n.to_array(), direction: k as u8, rule });
            }
        }
        (out, counts)
    }
}

/// Bounding tree over the sphere centres for the segment test: each node knows the box of its
/// centres and its largest radius, so a whole node is skipped when even its largest sphere at
/// the box's nearest point would be farther (scaled) than sphere i: dist(p, box) / r_max > dᵢ.
/// The answer (does any sphere beat i) does not depend on the tree's shape.
struct SphereTree {
    nodes: Vec<SphereNode>,
}

#[derive(Clone, Copy)]
struct SphereNode {
    min: DVec3,
    max: DVec3,
    r_max: f64,
    /// Leaf: range `start..end` of the reordered sphere list; inner: children at `start`, `end`.
    start: u32,
    end: u32,
    leaf: bool,
}

const SPHERE_LEAF: usize = 8;

impl SphereTree {
    /// Reorders `spheres` (median splits along the longest axis of the centre box) and builds
    /// the nodes; node 0 is the root.
    fn build(spheres: &mut [(DVec3, f64, usize)]) -> SphereTree {
        let mut tree = SphereTree { nodes: Vec::new() };
        if !spheres.is_empty() {
            tree.build_node(spheres, 0);
        }
        tree
    }

    fn build_node(&mut self, s: &mut [(DVec3, f64, usize)], offset: usize) -> u32 {
        let (mut min, mut max, mut r_max) = (DVec3::INFINITY, DVec3::NEG_INFINITY, 0.0f64);
        for (c, r, _) in s.iter() {
            min = min.min(*c);
            max = max.max(*c);
            r_max = r_max.max(*r);
        }
        let id = self.nodes.len() as u32;
        self.nodes.push(SphereNode {
            min,
            max,
            r_max,
            start: offset as u32,
            end: (offset + s.len()) as u32,
            leaf: true,
        });
        if s.len() > SPHERE_LEAF {
            let ext = max - min;
            let axis = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            // Total order (coordinate, then index) keeps the build deterministic.
            s.sort_unstable_by(|a, b| a.0[axis].total_cmp(&b.0[axis]).then(a.2.cmp(&b.2)));
            let mid = s.len() / 2;
            let (l, r) = s.split_at_mut(mid);
            let left = self.build_node(l, offset);
            let right = self.build_node(r, offset + mid);
            let n = &mut self.nodes[id as usize];
            n.leaf = false;
            n.start = left;
            n.end = right;
        }
        id
    }

    /// The sphere whose segment holds `p`, argmin_j |p − c_j| / r_j with ties to the lowest
    /// index (the answer [`segment_of`] gives), as (its slot in `spheres`, index, centre);
    /// `None` without spheres. `hint`, a slot of `spheres` (the owner of a nearby point), only sets
    /// the first bound: every sphere at most as far as the hint's is still visited, so the
    /// answer is the same with any hint or none, and a good one prunes most nodes.
    fn owner(&self, spheres: &[(DVec3, f64, usize)], p: DVec3, hint: Option<usize>) -> Option<(usize, usize, DVec3)> {
        let mut best: Option<(f64, usize, DVec3, usize)> = None;
        let mut bound = f64::INFINITY;
        if let Some((h, &(c, r, j))) = hint.and_then(|h| Some((h, spheres.get(h)?))) {
            let dj = (p - c).length() / r;
            if dj.is_finite() {
                best = Some((dj, j, c, h));
                bound = dj;
            }
        }
        self.walk(spheres, p, bound, |c, dj, j, slot, bound| {
            if best.is_none_or(|(bd, bj, _, _)| dj < bd || (dj == bd && j < bj)) {
                best = Some((dj, j, c, slot));
                *bound = dj;
            }
            false
        });
        best.map(|(_, j, c, slot)| (slot, j, c))
    }

    /// Whether a sphere j ≠ i has d_j < dᵢ, or d_j = dᵢ with j < i, at `p`.
    fn any_beats(&self, spheres: &[(DVec3, f64, usize)], p: DVec3, i: usize, di: f64) -> bool {
        self.walk(spheres, p, di, |_, dj, j, _, _| j != i && (dj < di || (dj == di && j < i)))
    }

    /// Visits the spheres of the nodes that may hold one with scaled distance d_j ≤ `bound` at `p`
    /// (a node is skipped when dist(p, box) / r_max > bound, with a relative margin so rounding
    /// never prunes an exact tie), calling `visit(c_j, d_j, j, slot, &mut bound)` (slot: the
    /// sphere's place in `spheres`), which may lower the bound; stops and returns true as soon
    /// as `visit` does.
    fn walk(
        &self,
        spheres: &[(DVec3, f64, usize)],
        p: DVec3,
        bound: f64,
        mut visit: impl FnMut(DVec3, f64, usize, usize, &mut f64) -> bool,
    ) -> bool {
        self.walk_near(
            spheres,
            |min, max| (p - p.clamp(min, max)).length(),
            bound,
            |c, r, j, slot, bound| visit(c, (p - c).length() / r, j, slot, bound),
        )
    }

    /// [`SphereTree::walk`] for any query: `gap(min, max)` is its distance to a node's box;
    /// `visit(c_j, r_j, j, slot, &mut bound)` is called for the spheres of every node with
    /// gap ≤ bound · r_max (with the same margin).
    fn walk_near(
        &self,
        spheres: &[(DVec3, f64, usize)],
        gap: impl Fn(DVec3, DVec3) -> f64,
        mut bound: f64,
        mut visit: impl FnMut(DVec3, f64, usize, usize, &mut f64) -> bool,
    ) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let n = self.nodes[stack[top] as usize];
            if gap(n.min, n.max) > bound * n.r_max * (1.0 + 1e-9) {
                continue;
            }
            if n.leaf {
                for (slot, &(c, r, j)) in spheres.iter().enumerate().take(n.end as usize).skip(n.start as usize) {
                    if visit(c, r, j, slot, &mut bound) {
                        return true;
                    }
                }
            } else if top + 2 <= stack.len() {
                stack[top] = n.start;
                stack[top + 1] = n.end;
                top += 2;
            }
        }
        false
    }

    /// The slots of the spheres that may own a point of the box `[lo, hi]` into `out`: a
    /// superset of the [`SphereTree::owner`] of every point in it, and of every sphere tied with
    /// that owner there. With u the least over the spheres of (farthest distance from the box to
    /// c_j) / r_j, every point of the box has an owner with d ≤ u, so a sphere whose nearest
    /// distance to the box over its radius exceeds u (with the walk's relative margin, far
    /// above the rounding) owns none of it. `hint`, a slot, only sets the first bound.
    fn candidates(
        &self,
        spheres: &[(DVec3, f64, usize)],
        lo: DVec3,
        hi: DVec3,
        hint: Option<usize>,
        out: &mut Vec<(usize, f64)>,
    ) {
        out.clear();
        let far = |c: DVec3| (c - lo).abs().max((c - hi).abs()).length();
        let mut u = f64::INFINITY;
        if let Some(&(c, r, _)) = hint.and_then(|h| spheres.get(h)) {
            u = u.min(far(c) / r);
        }
        self.walk_near(
            spheres,
            |min, max| (lo - max).max(min - hi).max(DVec3::ZERO).length(),
            u,
            |c, r, _, slot, bound| {
                u = u.min(far(c) / r);
                *bound = u;
                let d = (c - c.clamp(lo, hi)).length() / r;
                if d <= u * (1.0 + 1e-9) {
                    out.push((slot, d));
                }
                false
            },
        );
        out.retain(|&(_, d)| d <= u * (1.0 + 1e-9));
    }

    /// [`SphereTree::owner`] of `p` found among `cands` (slots, in any order; they must hold
    /// it: [`SphereTree::candidates`] of a box around p): the same smallest d and ties to the
    /// lowest index, so the same answer.
    fn owner_among(spheres: &[(DVec3, f64, usize)], cands: &[(usize, f64)], p: DVec3) -> Option<(usize, usize, DVec3)> {
        let mut best: Option<(f64, usize, DVec3, usize)> = None;
        for &(slot, _) in cands {
            let (c, r, j) = spheres[slot];
            let dj = (p - c).length() / r;
            if best.is_none_or(|(bd, bj, _, _)| dj < bd || (dj == bd && j < bj)) {
                best = Some((dj, j, c, slot));
            }
        }
        best.map(|(_, j, c, slot)| (slot, j, c))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The owner found among a box's candidates is the brute-force owner ([`segment_of`], ties
    /// to the lowest index) of every point of the box, for boxes of every size, points on its
    /// faces and corners, and exact duplicate spheres; fails when a candidate that owns a point
    /// is left out.
    #[test]
    fn box_candidates_hold_every_owner() {
        let mut rng = spherebake_geom::rng::SplitMix64::new(55);
        let mut next = || rng.next_f64() as f32;
        let mut cands = Vec::new();
        for &n in &[1usize, 3, 9, 40, 300] {
            let mut spheres: Vec<[f32; 4]> =
                (0..n).map(|_| [next() * 4.0 - 2.0, next() * 4.0 - 2.0, next() * 4.0 - 2.0, 0.05 + next()]).collect();
            if n > 2 {
                spheres[n - 1] = spheres[1];
            }
            let mesh = Mesh::default();
            let ctx = Ctx::new(&mesh, &[], &spheres);
            for b in 0..300 {
                let size = [1e-3f32, 0.05, 0.5, 3.0][b % 4];
                let lo = Vec3::new(next() * 6.0 - 3.0, next() * 6.0 - 3.0, next() * 6.0 - 3.0);
                let hi = lo + Vec3::new(next(), next(), next()) * size;
                let hint = [None, Some(0), Some(n / 2), Some(n + 5)][b % 4];
                ctx.tree.candidates(&ctx.spheres, lo.as_dvec3(), hi.as_dvec3(), hint, &mut cands);
                for k in 0..40 {
                    let t = Vec3::new(next(), next(), next());
                    // Corners and face points too: a coordinate at lo or hi.
                    let t = if k % 4 == 0 {
                        t.round()
                    } else if k % 4 == 1 {
                        Vec3::new(t.x.round(), t.y, t.z)
                    } else {
                        t
                    };
                    let p = (lo + (hi - lo) * t).clamp(lo, hi);
                    let want = segment_of(p, &spheres).expect("valid spheres");
                    let got = SphereTree::owner_among(&ctx.spheres, &cands, p.as_dvec3()).map(|o| o.1);
                    assert_eq!(got, Some(want), "n {n} box {b} point {k}");
                }
            }
        }
    }

    /// The tree's "does any sphere beat i" equals the brute-force argmin, including exact ties.
    #[test]
    fn sphere_tree_matches_brute_force() {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) as f32
        };
        for &n in &[1usize, 5, 9, 40, 300] {
            let mut spheres: Vec<[f32; 4]> =
                (0..n).map(|_| [next() * 4.0 - 2.0, next() * 4.0 - 2.0, next() * 4.0 - 2.0, 0.05 + next()]).collect();
            if n > 2 {
                spheres[n - 1] = spheres[0]; // an exact duplicate: ties go to the lower index
            }
            let mesh = Mesh::default();
            let ctx = Ctx::new(&mesh, &[], &spheres);
            for _ in 0..2000 {
                let p = Vec3::new(next() * 6.0 - 3.0, next() * 6.0 - 3.0, next() * 6.0 - 3.0).as_dvec3();
                let owner = segment_of(p.as_vec3(), &spheres).expect("valid spheres");
                let p32 = p.as_vec3().as_dvec3();
                assert_eq!(ctx.tree.owner(&ctx.spheres, p32, None).map(|o| o.1), Some(owner), "n {n}");
                // Any hint (the duplicate's slot, far spheres, an out-of-range slot) gives the
                // same owner, and the slot returned holds it.
                for hint in [0, n / 2, n - 1, n + 3] {
                    let got = ctx.tree.owner(&ctx.spheres, p32, Some(hint)).expect("owner");
                    assert_eq!((got.1, ctx.spheres[got.0].2), (owner, owner), "n {n} hint {hint}");
                }
                for (i, s) in spheres.iter().enumerate() {
                    let (c, r) = valid_sphere(s).expect("valid");
                    assert_eq!(ctx.in_segment(p32, i, c, r), i == owner, "n {n} sphere {i}");
                }
            }
        }
    }
}
