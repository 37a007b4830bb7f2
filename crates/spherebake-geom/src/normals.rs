//! Shading normals for triangles whose file gives none.
//!
//! - **glTF**: a primitive without `NORMAL` is shaded flat (§3.7.2.1: "client implementations
//!   MUST calculate flat normals"). The importer stores [`NO_NORMAL`] at its vertices, and every
//!   consumer (the bake's surface samples, the reference renderer) shades a triangle whose
//!   corners hold it with the triangle's geometric normal.
//! - **OBJ**: the format has no rule for faces without `vn`, and tools differ (Blender and
//!   three.js shade them flat, MeshLab smooth). Where the file has smoothing groups (`s`),
//!   they decide, as the format defines them (`s off` flat, `s N` smooth within group N).
//!   Else [`crease_normals`] smooths across edges whose faces meet at up to
//!   [`CREASE_ANGLE_DEG`] and keeps harder edges sharp, as Unity's and 3ds Max's importers do
//!   with their smoothing angle: a scan or a tessellated curve stays smooth, a box keeps its
//!   faces flat (smoothing a cube's corners tilts its sample normals by up to 55°, and lights
//!   it from the wrong side).
//!
//! Cost: O(corners × valence) with the valence held to [`MAX_CREASE_VALENCE`] (a position
//! shared by more triangles, a fan's apex or a pole, gives its corners their own face's
//! normal), so O(64 × corners) at worst; corners of triangles without area take their
//! position's whole sum, summed once per position; one hash per position and per split corner.
//! A position whose triangles all lie pairwise within the crease angle (a smooth region) is
//! summed once for all its corners, after k (k + 1) / 2 comparisons of its k triangles.

use glam::{DVec3, Vec3};
use std::collections::HashMap;

/// The normal of a vertex that the file does not give and that is shaded flat: each triangle
/// at it uses its own geometric normal. Zero, so an interpolated sum over such corners has no
/// direction and consumers fall back to the geometric normal (`try_normalize` is `None`).
pub const NO_NORMAL: Vec3 = Vec3::ZERO;

/// Faces meeting at up to this angle (degrees) share smoothed normals at their common
/// positions; harder edges stay sharp ([`crease_normals`]). Unity's import default.
pub const CREASE_ANGLE_DEG: f64 = 60.0;

/// The smoothing group of a triangle no group speaks for ([`crease_normals`]: the crease angle
/// decides).
pub const NO_GROUP: u32 = u32::MAX;

/// Positions shared by more triangles than this give each corner its own face's normal
/// (bounds the per-corner comparison of [`crease_normals`]).
pub const MAX_CREASE_VALENCE: usize = 64;

/// Triangles, vertices and normals after [`crease_normals`].
#[derive(Clone, Debug, PartialEq)]
pub struct CreaseNormals {
    /// The input triangles, re-indexed into the output vertices.
    pub triangles: Vec<[u32; 3]>,
    /// Per output vertex, the input vertex it copies: `0..n` first (each input vertex keeps its
    /// index), then one copy per extra normal a vertex needs, in the order first met.
    pub source: Vec<u32>,
    /// Per output vertex, its unit normal (+Z where no triangle around it has a direction).
    pub normals: Vec<Vec3>,
}

/// Per-corner shading normals with a crease angle ([`CREASE_ANGLE_DEG`]), for triangles whose
/// file gives no normals. Each corner gets the area-weighted mean of the geometric normals of
/// the triangles around its position (bit-equal positions, `-0.0` = `0.0`) that lie within the
/// crease angle of its own triangle's normal, its own included, so a corner's normal is never
/// more than the crease angle from its face. A vertex whose corners get different normals is
/// split: the first normal keeps the vertex, each further one a copy (`source` names what
/// to copy: UVs, colours).
///
/// The corners of a degenerate triangle (no area) get the mean of every triangle around their
/// positions; the corners at a position shared by more than [`MAX_CREASE_VALENCE`] triangles
/// get their own face's normal.
///
/// With `groups` (one per triangle, an OBJ file's `s` lines), a triangle's group decides
/// instead: group 0 is flat (each corner its own face's normal), a group N > 0 is smooth
/// across every edge to triangles of group N whatever the angle (a triangle wound the other
/// way adds its area turned to this side), and [`NO_GROUP`] keeps the crease angle among the
/// triangles of no group. Smoothing joins triangles by shared position, so two that touch
/// only at a corner are averaged there too.
///
/// Deterministic: only the input's order decides.
pub fn crease_normals(positions: &[Vec3], triangles: &[[u32; 3]], groups: Option<&[u32]>) -> CreaseNormals {
    crease_normals_with(positions, triangles, groups, true)
}

/// [`crease_normals`], with `share`: whether a position's shared normal is computed once
/// (`false` computes every corner on its own, for the test that holds the two equal).
fn crease_normals_with(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    groups: Option<&[u32]>,
    share: bool,
) -> CreaseNormals {
    let group = |t: usize| groups.and_then(|g| g.get(t).copied()).unwrap_or(NO_GROUP);
    let n = positions.len();
    // Welded position per vertex.
    let (weld, firsts) = crate::mesh::weld(positions);
    let welded = firsts.len();
    drop(firsts);
    let valid = |v: u32| (v as usize) < n;
    // Area-weighted and unit geometric normals, computed in f64 and kept in f32 (24 bytes per
    // triangle; zero for a triangle without area). The area vectors are relative to the
    // largest (so a model of any scale keeps them out of f32's underflow); sums are f64.
    let cross = |t: &[u32; 3]| -> Option<DVec3> {
        if !t.iter().all(|&v| valid(v)) {
            return None;
        }
        let [a, b, c] = t.map(|v| positions[v as usize].as_dvec3());
        Some((b - a).cross(c - a)).filter(|x| x.is_finite())
    };
    let largest = triangles.iter().filter_map(cross).map(DVec3::length).fold(0.0, f64::max);
    let (area, unit): (Vec<Vec3>, Vec<Vec3>) = triangles
        .iter()
        .map(|t| match cross(t).and_then(|x| Some((x / largest, x.try_normalize()?))) {
            Some((x, u)) => (x.as_vec3(), u.as_vec3()),
            None => (Vec3::ZERO, Vec3::ZERO),
        })
        .unzip();
    // Triangles around each welded position (CSR; a triangle twice if it names the position
    // twice, which only a degenerate one does and it adds no area).
    let mut start = vec![0usize; welded + 1];
    for t in triangles {
        for &v in t.iter().filter(|&&v| valid(v)) {
            start[weld[v as usize] as usize + 1] += 1;
        }
    }
    for i in 0..welded {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut around = vec![0u32; start[welded]];
    for (ti, t) in triangles.iter().enumerate() {
        for &v in t.iter().filter(|&&v| valid(v)) {
            let w = weld[v as usize] as usize;
            around[fill[w]] = ti as u32;
            fill[w] += 1;
        }
    }
    // Each position's whole area-weighted normal, for the corners of triangles without area
    // (one pass, so a position shared by many of them costs no more than its triangles; none
    // when every triangle has an area).
    let whole: Vec<DVec3> = if unit.contains(&Vec3::ZERO) {
        (0..welded).map(|w| around[start[w]..start[w + 1]].iter().map(|&o| area[o as usize].as_dvec3()).sum()).collect()
    } else {
        Vec::new()
    };
    let cos_crease = CREASE_ANGLE_DEG.to_radians().cos();
    let corner_normal = |ti: usize, v: u32| -> Vec3 {
        let w = weld[v as usize] as usize;
        let near = &around[start[w]..start[w + 1]];
        let u = unit[ti].as_dvec3();
        let g = group(ti);
        let sum: DVec3 = if u == DVec3::ZERO {
            whole[w]
        } else if near.len() > MAX_CREASE_VALENCE || g == 0 {
            u
        } else {
            // Within a group, a neighbour wound the other way (an inconsistently wound or
            // double-sided mesh: the bake orients triangles only later) adds its area turned
            // to this side, so opposite faces do not cancel.
            let part = |o: usize| -> Option<DVec3> {
                let (a, d) = (area[o].as_dvec3(), unit[o].as_dvec3().dot(u));
                match g {
                    NO_GROUP => (group(o) == NO_GROUP && d >= cos_crease).then_some(a),
                    _ => (group(o) == g).then_some(if d < 0.0 { -a } else { a }),
                }
            };
            near.iter().filter_map(|&o| part(o as usize)).sum()
        };
        // A sum whose terms all underflowed (areas below 10⁻³⁸ of the largest) is the face's.
        sum.try_normalize().or_else(|| u.try_normalize()).map_or(Vec3::Z, |s| s.as_vec3())
    };
    // The normal of every corner at a welded position whose triangles all have an area, are
    // in no smoothing group and lie pairwise within the crease angle (a smooth region: most
    // positions of a scan), `None` where the corners may differ. Each such corner's sum is
    // over all the position's triangles in one order, so it is the same sum: computed once,
    // at the position's first corner, after k (k + 1) / 2 comparisons where its corners made
    // k² (the dot product is symmetric in f64: x·x' + y·y' + z·z' either way). Bit-equal to
    // `corner_normal` at each corner (a sum that cannot be normalised falls back per corner).
    let shared_normal = |w: usize| -> Option<Vec3> {
        let near = &around[start[w]..start[w + 1]];
        if !share || near.len() > MAX_CREASE_VALENCE {
            return None;
        }
        for (i, &a) in near.iter().enumerate() {
            let ua = unit[a as usize];
            if ua == Vec3::ZERO || group(a as usize) != NO_GROUP {
                return None;
            }
            let ua = ua.as_dvec3();
            if !near[i..].iter().all(|&b| unit[b as usize].as_dvec3().dot(ua) >= cos_crease) {
                return None;
            }
        }
        let sum: DVec3 = near.iter().map(|&o| area[o as usize].as_dvec3()).sum();
        sum.try_normalize().map(DVec3::as_vec3)
    };
    let mut shared: Vec<Option<Option<Vec3>>> = vec![None; welded];
    // Split vertices whose corners differ: the first normal keeps the vertex.
    let mut normals = vec![None::<Vec3>; n];
    let mut extra: HashMap<(u32, [u32; 3]), u32> = HashMap::new();
    let mut source: Vec<u32> = (0..n as u32).collect();
    let mut extra_normals = Vec::new();
    let mut out = Vec::with_capacity(triangles.len());
    for (ti, t) in triangles.iter().enumerate() {
        out.push(t.map(|v| {
            if !valid(v) {
                return v;
            }
            let w = weld[v as usize] as usize;
            let m = match *shared[w].get_or_insert_with(|| shared_normal(w)) {
                Some(m) => m,
                None => corner_normal(ti, v),
            };
            match normals[v as usize] {
                None => {
                    normals[v as usize] = Some(m);
                    v
                }
                Some(first) if first.to_array().map(f32::to_bits) == m.to_array().map(f32::to_bits) => v,
                Some(_) => *extra.entry((v, m.to_array().map(f32::to_bits))).or_insert_with(|| {
                    source.push(v);
                    extra_normals.push(m);
                    (source.len() - 1) as u32
                }),
            }
        }));
    }
    let normals = normals.into_iter().map(|m| m.unwrap_or(Vec3::Z)).chain(extra_normals).collect();
    CreaseNormals { triangles: out, source, normals }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let p: Vec<Vec3> =
            (0..8).map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32)).collect();
        // Outward counter-clockwise quads, two triangles each.
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let t = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
        (p, t)
    }

    fn face_normal(p: &[Vec3], t: [u32; 3]) -> Vec3 {
        let [a, b, c] = t.map(|v| p[v as usize].as_dvec3());
        (b - a).cross(c - a).normalize().as_vec3()
    }

    #[test]
    fn a_cube_keeps_each_face_flat_with_three_copies_of_each_corner() {
        // At any scale: areas of 10⁻⁴⁸ underflow f32, so they are kept relative to the largest.
        for scale in [1.0, 1e-24, 1e18] {
            cube_at(scale);
        }
    }

    fn cube_at(scale: f32) {
        let (p, t) = cube();
        let p: Vec<Vec3> = p.iter().map(|&q| q * scale).collect();
        let r = crease_normals(&p, &t, None);
        // Each corner position meets three faces at 90°: three normals, so 8 × 3 vertices.
        assert_eq!(r.normals.len(), 24);
        assert_eq!(r.source.len(), 24);
        for (orig, new) in t.iter().zip(&r.triangles) {
            let want = face_normal(&p, *orig);
            for k in 0..3 {
                let v = new[k] as usize;
                assert_eq!(r.source[v], orig[k], "a copy names its vertex");
                assert!(r.normals[v].abs_diff_eq(want, 1e-6), "scale {scale}: {} vs face {want}", r.normals[v]);
            }
        }
    }

    #[test]
    fn a_prism_of_sixteen_sides_is_smooth_around_and_sharp_at_its_caps() {
        // Sides 22.5° apart (smoothed); caps at 90° (sharp). Vertices 0..16 bottom, 16..32 top,
        // 32 and 33 the caps' centres.
        let m = 16u32;
        let mut p = Vec::new();
        for z in [0.0, 1.0] {
            for i in 0..m {
                let a = i as f32 * std::f32::consts::TAU / m as f32;
                p.push(Vec3::new(a.cos(), a.sin(), z));
            }
        }
        p.push(Vec3::ZERO);
        p.push(Vec3::Z);
        let mut t = Vec::new();
        for i in 0..m {
            let j = (i + 1) % m;
            t.push([i, j, m + j]);
            t.push([i, m + j, m + i]);
            t.push([2 * m, j, i]);
            t.push([2 * m + 1, m + i, m + j]);
        }
        let r = crease_normals(&p, &t, None);
        // Each rim vertex: one side normal (the input vertex) and one cap normal (a copy).
        assert_eq!(r.normals.len(), p.len() + 2 * m as usize);
        for (orig, new) in t.iter().zip(&r.triangles) {
            let side = orig.iter().all(|&v| v < 2 * m);
            for k in 0..3 {
                let v = new[k] as usize;
                let q = p[orig[k] as usize];
                // A side corner: the area-weighted mean of the side triangles that touch its
                // position (known by construction, not by angle); the cap's axis on a cap.
                let want = if side {
                    let touching = t.iter().filter(|s| s.iter().all(|&v| v < 2 * m) && s.contains(&orig[k]));
                    let sum: Vec3 = touching
                        .map(|s| {
                            let [a, b, c] = s.map(|v| p[v as usize]);
                            (b - a).cross(c - a)
                        })
                        .sum();
                    // Within 6° of the radial direction (two sides 22.5° apart, weighted 2 : 1).
                    assert!(sum.normalize().dot(Vec3::new(q.x, q.y, 0.0).normalize()) > 6f32.to_radians().cos());
                    sum.normalize()
                } else {
                    face_normal(&p, *orig)
                };
                assert!(r.normals[v].abs_diff_eq(want, 1e-5), "corner {q}: {} vs {want}", r.normals[v]);
            }
        }
    }

    #[test]
    fn every_corner_lies_within_the_crease_angle_of_its_face() {
        // Random soups over a small lattice (repeated positions, folds, flips, degenerate
        // triangles): the mean of unit vectors within the angle of a face stays within it.
        let mut rng = crate::rng::SplitMix64::new(0x5EED_0FC0_FFEE);
        let cos = CREASE_ANGLE_DEG.to_radians().cos() as f32 - 1e-5;
        for round in 0..200 {
            let nv = 4 + (rng.next_u64() % 20) as u32;
            let p: Vec<Vec3> = (0..nv)
                .map(|_| {
                    let mut c = || (rng.next_u64() % 4) as f32 * 0.5;
                    Vec3::new(c(), c(), c())
                })
                .collect();
            let nt = 1 + rng.next_u64() % 40;
            let t: Vec<[u32; 3]> = (0..nt).map(|_| [0; 3].map(|_| (rng.next_u64() % nv as u64) as u32)).collect();
            let r = crease_normals(&p, &t, None);
            assert_eq!(r.triangles.len(), t.len());
            assert_eq!(r.source.len(), r.normals.len());
            for (orig, new) in t.iter().zip(&r.triangles) {
                let [a, b, c] = orig.map(|v| p[v as usize]);
                let Some(f) = (b - a).cross(c - a).try_normalize() else { continue };
                for k in 0..3 {
                    let v = new[k] as usize;
                    assert_eq!(p[r.source[v] as usize], p[orig[k] as usize], "round {round}");
                    let nrm = r.normals[v];
                    assert!((nrm.length() - 1.0).abs() < 1e-5, "round {round}: {nrm}");
                    assert!(nrm.dot(f) >= cos, "round {round}: corner {k} {nrm} vs face {f}");
                }
            }
        }
    }

    /// A position's normal computed once for all its corners ([`crease_normals`]) is each
    /// corner's own, to the bit: smooth grids (every position shared), folds and creases at
    /// any angle, smoothing groups, degenerate and repeated triangles, at several scales.
    #[test]
    fn a_shared_normal_is_each_corners_own() {
        let mut rng = crate::rng::SplitMix64::new(0x5A4E_D0C0_4E55);
        for round in 0..300 {
            // A height field of k × k points, bumpy enough that some folds pass the crease
            // angle and some do not; now and then a random soup over a lattice instead.
            let k = 3 + (rng.next_u64() % 6) as u32;
            let bump = [0.05, 0.5, 2.0][round % 3];
            let scale = [1.0, 1e-20, 1e15][(round / 3) % 3];
            let mut h = || (rng.next_u64() % 1000) as f32 / 1000.0 * bump;
            let mut p: Vec<Vec3> = (0..k * k).map(|i| Vec3::new((i % k) as f32, (i / k) as f32, h()) * scale).collect();
            let mut t: Vec<[u32; 3]> = Vec::new();
            for y in 0..k - 1 {
                for x in 0..k - 1 {
                    let i = y * k + x;
                    t.push([i, i + 1, i + k + 1]);
                    t.push([i, i + k + 1, i + k]);
                }
            }
            if round % 5 == 4 {
                let nv = p.len() as u64;
                let extra: Vec<[u32; 3]> =
                    (0..1 + rng.next_u64() % 20).map(|_| [0; 3].map(|_| (rng.next_u64() % nv) as u32)).collect();
                t.extend(extra);
                p.push(p[0]);
                t.push([nv as u32, 1, 2]);
            }
            let groups: Option<Vec<u32>> = (round % 4 == 3)
                .then(|| t.iter().map(|_| [NO_GROUP, NO_GROUP, 0, 1][(rng.next_u64() % 4) as usize]).collect());
            let g = groups.as_deref();
            assert_eq!(
                bits(&crease_normals_with(&p, &t, g, true)),
                bits(&crease_normals_with(&p, &t, g, false)),
                "round {round}"
            );
        }
        let (p, t) = cube();
        assert_eq!(bits(&crease_normals_with(&p, &t, None, true)), bits(&crease_normals_with(&p, &t, None, false)));
    }

    /// A result's triangles, sources and normals' bits.
    fn bits(r: &CreaseNormals) -> (Vec<[u32; 3]>, Vec<u32>, Vec<[u32; 3]>) {
        (r.triangles.clone(), r.source.clone(), r.normals.iter().map(|n| n.to_array().map(f32::to_bits)).collect())
    }

    #[test]
    fn a_busy_apex_gives_its_corners_their_own_faces_normals() {
        // A cone of 100 sides: the apex is shared by 100 triangles (> MAX_CREASE_VALENCE).
        let m = 100u32;
        let mut p: Vec<Vec3> = (0..m)
            .map(|i| {
                let a = i as f32 * std::f32::consts::TAU / m as f32;
                Vec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        p.push(Vec3::new(0.0, 0.0, 0.2));
        let t: Vec<[u32; 3]> = (0..m).map(|i| [i, (i + 1) % m, m]).collect();
        let r = crease_normals(&p, &t, None);
        for (orig, new) in t.iter().zip(&r.triangles) {
            let v = new[2] as usize;
            assert!(r.normals[v].abs_diff_eq(face_normal(&p, *orig), 1e-6));
        }
        // The base corners (two sides each, 3.6° apart) are smoothed: not their face's normal.
        let v = r.triangles[0][0] as usize;
        assert!(!r.normals[v].abs_diff_eq(face_normal(&p, t[0]), 1e-4));
    }
}
