//! Triangulation of an OBJ face of four or more corners (a polygon), in the plane of its Newell
//! normal, keeping its winding: every triangle faces the way the polygon does.
//!
//! A polygon whose fan from its first corner is a triangulation of it (every convex polygon,
//! and any polygon that first corner sees whole) gets that fan: the triangles tobj gave every
//! face before, so convex faces import exactly as they did. A convex polygon (up to the rounding
//! of its f32 positions) of more than [`FAN_MAX_CORNERS`] corners is split in halves instead
//! (triangle (a, m, b) with m midway from corner a to corner b, then the two halves alike):
//! the fan's n − 2 triangles all reach from corner 0 across the polygon, slivers whose summed
//! perimeter grows as n times its width, and every later stage (the BVH, the voxel rows, the
//! bounding pass's pieces) pays for their length; the halves' triangles sum to about the
//! polygon's perimeter times log₂ n. Any other polygon (concave: an L, a star) is ear-clipped: the fan would cover area outside it. Ear clipping takes the first
//! ear from the second corner on, in polygon order, and is O(n²) for n corners; a concave
//! polygon of more than [`MAX_EAR_CLIP_CORNERS`] corners, or one where no ear is found
//! (self-intersecting or degenerate), gets the fan, and the importer warns once per file.
//! Everything is deterministic: the same polygon gives the same triangles.

use glam::{DVec2, DVec3, Vec3};

/// Most corners a concave polygon is ear-clipped with: a file is checked in time linear in its
/// corners times this (a hostile file of concave polygons), and real polygons this size
/// (letter outlines, floor plans) are rare. A larger concave polygon gets the fan.
pub(crate) const MAX_EAR_CLIP_CORNERS: usize = 256;

/// Most corners a convex polygon keeps the fan with (see the module docs); cylinder caps
/// and other everyday n-gons import as tobj gave them.
pub(crate) const FAN_MAX_CORNERS: usize = 32;

/// How a polygon was triangulated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum How {
    /// The fan from the first corner, a triangulation of the polygon (or the polygon has no
    /// area: its Newell normal is zero).
    Fan,
    /// Convex, more than [`FAN_MAX_CORNERS`] corners: split in halves.
    Halves,
    /// Ear-clipped (concave).
    EarClipped,
    /// Concave, more than [`MAX_EAR_CLIP_CORNERS`] corners: the fan.
    FanOverCap,
    /// Concave and no ear found (self-intersecting or degenerate): the fan.
    FanNoEar,
}

/// Scratch space for [`Triangulator::polygon`], reused from polygon to polygon.
#[derive(Debug, Default)]
pub(crate) struct Triangulator {
    /// The corners in the polygon's plane, counter-clockwise seen from its Newell normal.
    pts: Vec<DVec2>,
    prev: Vec<u32>,
    next: Vec<u32>,
    /// The corner turns left (strictly): an ear candidate and no blocker.
    convex: Vec<bool>,
    ear: Vec<bool>,
    /// The corners that are not convex (reflex or straight), the only ones that can lie in an
    /// ear's triangle of a simple polygon; `at[i]` is corner i's place in it (`u32::MAX`: none).
    reflex: Vec<u32>,
    at: Vec<u32>,
    /// Ear-clipped triangles, as corners.
    tris: Vec<[u32; 3]>,
}

/// Twice the signed area of triangle (a, b, c): positive when counter-clockwise.
fn orient(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    (b - a).perp_dot(c - a)
}

/// Moving a corner by the f32 rounding of `largest` (per coordinate) changes the cross product
/// of two edges d × e by at most about this times |d| + |e|.
fn rounding_slack(largest: f64) -> f64 {
    8.0 * f64::from(f32::EPSILON) * largest
}

/// No corner of the polygon `plane(i)` (counter-clockwise) turns right by more than the
/// rounding of f32 positions as large as `largest` (the allowance of
/// [`Triangulator::fan_is_a_triangulation`], which has checked that the polygon winds once):
/// convex up to that rounding. (A circle of 12 500 corners in f32 is no more convex than
/// this: each corner's sagitta, 3·10⁻⁸ of the radius, is under the rounding of its position.)
fn convex_within_rounding(n: usize, plane: &impl Fn(usize) -> DVec2, largest: f64) -> bool {
    let slack = rounding_slack(largest);
    let (mut a, mut b) = (plane(n - 1), plane(0));
    (0..n).all(|i| {
        let c = plane((i + 1) % n);
        let (d, e) = (b - a, c - b);
        let left = d.perp_dot(e) >= -slack * (d.length() + e.length());
        (a, b) = (b, c);
        left
    })
}

/// The n − 2 triangles of a convex polygon split in halves: (a, m, b) for the corners a..=b,
/// m = ⌊(a + b) / 2⌋, then a..=m and m..=b alike (an explicit stack of O(log n) ranges), each
/// in the polygon's winding.
fn halves(corners: &[u32], out: &mut Vec<[u32; 3]>) {
    let mut ranges = vec![(0usize, corners.len() - 1)];
    while let Some((a, b)) = ranges.pop() {
        if b - a < 2 {
            continue;
        }
        let m = (a + b) / 2;
        out.push([corners[a], corners[m], corners[b]]);
        ranges.push((m, b));
        ranges.push((a, m));
    }
}

impl Triangulator {
    /// Appends the n − 2 triangles of the polygon `corners` (indices into `positions`, n ≥ 3)
    /// to `out`.
    pub(crate) fn polygon(&mut self, positions: &[Vec3], corners: &[u32], out: &mut Vec<[u32; 3]>) -> How {
        let n = corners.len();
        let fan = |out: &mut Vec<[u32; 3]>| {
            out.extend((1..n.saturating_sub(1)).map(|i| [corners[0], corners[i], corners[i + 1]]));
        };
        if n <= 3 {
            fan(out);
            return How::Fan;
        }
        let p = |i: usize| positions[corners[i] as usize].as_dvec3();
        let o = p(0);
        // Newell's normal, about the first corner (Σ dᵢ × dᵢ₊₁ over the fan: the same vector,
        // with less cancellation), and the largest coordinate, for the rounding allowance.
        let (mut normal, mut largest) = (DVec3::ZERO, 0.0f64);
        let mut d = p(1) - o;
        for i in 1..n {
            largest = largest.max(p(i).abs().max_element());
            if i + 1 < n {
                let e = p(i + 1) - o;
                normal += d.cross(e);
                d = e;
            }
        }
        largest = largest.max(o.abs().max_element());
        let Some(w) = normal.try_normalize() else {
            // No area, no plane: nothing better than the fan.
            fan(out);
            return How::Fan;
        };
        // An orthonormal basis (u, v) of the plane with u × v = w: the axis w is least along,
        // crossed with w (exact for an axis-aligned normal).
        let a = w.abs();
        let axis = if a.x <= a.y && a.x <= a.z {
            DVec3::X
        } else if a.y <= a.z {
            DVec3::Y
        } else {
            DVec3::Z
        };
        let u = axis.cross(w).normalize();
        let v = w.cross(u);
        let plane = |i: usize| {
            let q = p(i) - o;
            DVec2::new(q.dot(u), q.dot(v))
        };
        if self.fan_is_a_triangulation(n, &plane, largest) {
            if n > FAN_MAX_CORNERS && convex_within_rounding(n, &plane, largest) {
                halves(corners, out);
                return How::Halves;
            }
            fan(out);
            return How::Fan;
        }
        if n > MAX_EAR_CLIP_CORNERS {
            fan(out);
            return How::FanOverCap;
        }
        self.pts.clear();
        self.pts.extend((0..n).map(plane));
        if !self.ear_clip() {
            fan(out);
            return How::FanNoEar;
        }
        out.extend(self.tris.iter().map(|t| t.map(|k| corners[k as usize])));
        How::EarClipped
    }

    /// Whether the fan from corner 0 triangulates the polygon (corners `plane(i)`, corner 0 at
    /// the origin): each fan triangle (0, i, i + 1) turns left, up to the rounding of f32
    /// positions as large as `largest`, and together they turn less than a full circle about
    /// corner 0. Consecutive wedges that do not wrap around are disjoint, and their triangles
    /// are then the polygon, star-shaped from corner 0.
    fn fan_is_a_triangulation(&self, n: usize, plane: &impl Fn(usize) -> DVec2, largest: f64) -> bool {
        let slack = rounding_slack(largest);
        let mut turned = 0.0f64;
        let mut d = plane(1);
        for i in 1..n - 1 {
            let e = plane(i + 1);
            let (cross, dot) = (d.perp_dot(e), d.dot(e));
            if cross < -slack * (d.length() + e.length()) {
                return false;
            }
            // A wedge within the slack of straight back is not one either way: refuse it.
            if cross < 0.0 && dot <= 0.0 {
                return false;
            }
            // Two wedges of less than π each cannot wrap (quads: no trigonometry).
            if n > 4 && cross > 0.0 {
                turned += cross.atan2(dot);
            }
            d = e;
        }
        turned < std::f64::consts::TAU
    }

    /// Ear-clips the polygon `self.pts` (counter-clockwise) into `self.tris`: from corner 1 on,
    /// the first corner that is an ear (it turns left and no corner that does not lies in or on
    /// its triangle, corners at the same point as the triangle's excepted: a keyhole polygon's
    /// bridge) is cut off, and the search goes on from the corner after it. Ear flags are kept
    /// and only the two neighbours of a cut ear are looked at again (in a simple polygon no
    /// other corner's changes), so this is O(n²). False when a full turn finds no ear.
    fn ear_clip(&mut self) -> bool {
        let n = self.pts.len();
        self.tris.clear();
        self.prev.clear();
        self.next.clear();
        self.prev.extend((0..n).map(|i| ((i + n - 1) % n) as u32));
        self.next.extend((0..n).map(|i| ((i + 1) % n) as u32));
        self.convex.clear();
        self.convex.resize(n, false);
        self.ear.clear();
        self.ear.resize(n, false);
        self.reflex.clear();
        self.at.clear();
        self.at.resize(n, u32::MAX);
        for i in 0..n {
            self.classify(i);
        }
        for i in 0..n {
            self.ear[i] = self.is_ear(i);
        }
        let (mut cur, mut left, mut misses) = (1usize, n, 0usize);
        while left > 3 {
            if self.ear[cur] {
                let (a, c) = (self.prev[cur] as usize, self.next[cur] as usize);
                self.tris.push([a as u32, cur as u32, c as u32]);
                self.next[a] = c as u32;
                self.prev[c] = a as u32;
                left -= 1;
                for k in [a, c] {
                    self.classify(k);
                }
                for k in [a, c] {
                    self.ear[k] = self.is_ear(k);
                }
                cur = c;
                misses = 0;
            } else {
                cur = self.next[cur] as usize;
                misses += 1;
                if misses >= left {
                    return false;
                }
            }
        }
        self.tris.push([self.prev[cur], cur as u32, self.next[cur]]);
        true
    }

    /// Sets corner i's convex flag from its current neighbours and its place in `reflex`.
    fn classify(&mut self, i: usize) {
        let (a, c) = (self.prev[i] as usize, self.next[i] as usize);
        let convex = orient(self.pts[a], self.pts[i], self.pts[c]) > 0.0;
        self.convex[i] = convex;
        let listed = self.at[i] != u32::MAX;
        if convex && listed {
            let k = self.at[i] as usize;
            self.reflex.swap_remove(k);
            if let Some(&moved) = self.reflex.get(k) {
                self.at[moved as usize] = k as u32;
            }
            self.at[i] = u32::MAX;
        } else if !convex && !listed {
            self.at[i] = self.reflex.len() as u32;
            self.reflex.push(i as u32);
        }
    }

    /// Whether corner i is an ear now (see [`Triangulator::ear_clip`]).
    fn is_ear(&self, i: usize) -> bool {
        if !self.convex[i] {
            return false;
        }
        let (a, c) = (self.prev[i] as usize, self.next[i] as usize);
        let (pa, pi, pc) = (self.pts[a], self.pts[i], self.pts[c]);
        !self.reflex.iter().any(|&r| {
            let r = r as usize;
            let q = self.pts[r];
            r != a
                && r != c
                && q != pa
                && q != pi
                && q != pc
                && orient(pa, pi, q) >= 0.0
                && orient(pi, pc, q) >= 0.0
                && orient(pc, pa, q) >= 0.0
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn xor(seed: u64) -> impl FnMut() -> f64 {
        let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    fn run(points: &[Vec3]) -> (Vec<[u32; 3]>, How) {
        let corners: Vec<u32> = (0..points.len() as u32).collect();
        let mut out = Vec::new();
        let how = Triangulator::default().polygon(points, &corners, &mut out);
        assert_eq!(out.len(), points.len() - 2);
        (out, how)
    }

    /// A random rotation's image of (x, y, 0) points, moved away from the origin.
    fn placed(flat: &[(f64, f64)], seed: u64) -> Vec<Vec3> {
        let mut r = xor(seed);
        let q = glam::DQuat::from_euler(glam::EulerRot::XYZ, 6.0 * r(), 6.0 * r(), 6.0 * r());
        let t = DVec3::new(r() * 10.0 - 5.0, r() * 10.0 - 5.0, r() * 10.0 - 5.0);
        flat.iter().map(|&(x, y)| (q * DVec3::new(x, y, 0.0) + t).as_vec3()).collect()
    }

    fn area(points: &[Vec3], tris: &[[u32; 3]], normal: Vec3) -> (f64, bool) {
        let mut total = 0.0;
        let mut all_agree = true;
        for t in tris {
            let [a, b, c] = t.map(|i| points[i as usize].as_dvec3());
            let x = (b - a).cross(c - a);
            total += x.length() / 2.0;
            all_agree &= x.dot(normal.as_dvec3()) > 0.0;
        }
        (total, all_agree)
    }

    /// Convex polygons (random, placed anywhere in space) of up to [`FAN_MAX_CORNERS`]
    /// corners get exactly the fan from their first corner, as tobj gave them.
    #[test]
    fn convex_polygons_get_the_fan() {
        for seed in 0..300u64 {
            let mut r = xor(seed);
            let n = 4 + (seed as usize * 7) % (FAN_MAX_CORNERS - 3);
            let mut angles: Vec<f64> = (0..n).map(|_| r() * std::f64::consts::TAU).collect();
            angles.sort_by(f64::total_cmp);
            let (rx, ry) = (0.1 + r() * 3.0, 0.1 + r() * 3.0);
            let flat: Vec<(f64, f64)> = angles.iter().map(|a| (rx * a.cos(), ry * a.sin())).collect();
            let pts = placed(&flat, seed);
            let (tris, how) = run(&pts);
            let fan: Vec<[u32; 3]> = (1..n as u32 - 1).map(|i| [0, i, i + 1]).collect();
            assert_eq!((how, tris), (How::Fan, fan), "seed {seed}, {n} corners");
        }
        // A straight corner (a vertex on an edge) next to the first keeps the fan.
        let flat = [(0.0, 0.0), (0.5, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)];
        assert_eq!(run(&placed(&flat, 3)).1, How::Fan);
    }

    /// Σ over `tris` of the triangles' perimeters.
    fn perimeters(points: &[Vec3], tris: &[[u32; 3]]) -> f64 {
        let p = |i: u32| points[i as usize].as_dvec3();
        tris.iter().map(|t| p(t[0]).distance(p(t[1])) + p(t[1]).distance(p(t[2])) + p(t[2]).distance(p(t[0]))).sum()
    }

    /// Convex polygons of more than [`FAN_MAX_CORNERS`] corners (random ellipses, placed
    /// anywhere in space) are split in halves: n − 2 triangles of distinct corners, each facing
    /// the polygon's way, covering its area (the shoelace formula on the flat corners) once,
    /// whose perimeters sum to at most 2 P ⌈log₂ n⌉ for the polygon's perimeter P (each level
    /// of halves splits the boundary into arcs, and a triangle's three sides are at most twice
    /// its arc). The fan's sum is about n times the polygon's width.
    #[test]
    fn large_convex_polygons_are_split_in_halves_into_their_area() {
        for seed in 0..200u64 {
            let mut r = xor(seed + 7000);
            let n = FAN_MAX_CORNERS + 1 + (seed as usize * 37) % 600;
            // Corners jittered about even angles: no two within a third of the even step, so
            // every corner turns left by far more than the f32 rounding.
            let step = std::f64::consts::TAU / n as f64;
            let angles: Vec<f64> = (0..n).map(|i| (i as f64 + 0.6 * r()) * step).collect();
            let (rx, ry) = (1.0 + r() * 2.0, 1.0 + r() * 2.0);
            let flat: Vec<(f64, f64)> = angles.iter().map(|a| (rx * a.cos(), ry * a.sin())).collect();
            let pts = placed(&flat, seed);
            let (tris, how) = run(&pts);
            assert_eq!(how, How::Halves, "seed {seed}, {n} corners");
            assert!(tris.iter().all(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]), "seed {seed}");
            let shoelace: f64 =
                (0..n).map(|i| flat[i].0 * flat[(i + 1) % n].1 - flat[(i + 1) % n].0 * flat[i].1).sum::<f64>() / 2.0;
            let normal = (pts[1] - pts[0]).cross(pts[2] - pts[0]);
            let (total, facing) = area(&pts, &tris, normal);
            assert!(facing, "seed {seed}: a triangle faces the other way");
            assert!((total - shoelace).abs() <= 1e-5 * shoelace, "seed {seed}: area {total} against {shoelace}");
            let perimeter: f64 = (0..n).map(|i| pts[i].as_dvec3().distance(pts[(i + 1) % n].as_dvec3())).sum();
            let bound = 2.0 * perimeter * (n as f64).log2().ceil();
            let sum = perimeters(&pts, &tris);
            assert!(sum <= bound, "seed {seed}: {sum} > {bound}");
            let fan: Vec<[u32; 3]> = (1..n as u32 - 1).map(|i| [0, i, i + 1]).collect();
            assert!(perimeters(&pts, &fan) > sum, "seed {seed}");
        }
        // A circle of 12 500 corners in f32 (convex only up to the rounding): the fan's
        // triangles would sum to about 2 500 perimeters, the halves' to at most 28.
        let n = 12_500;
        let flat: Vec<(f64, f64)> =
            (0..n).map(|i| i as f64 * std::f64::consts::TAU / n as f64).map(|a| (a.cos(), a.sin())).collect();
        let pts = placed(&flat, 11);
        let (tris, how) = run(&pts);
        assert_eq!(how, How::Halves);
        let perimeter = std::f64::consts::TAU;
        assert!(perimeters(&pts, &tris) <= 2.0 * perimeter * 14.0);
        let fan: Vec<[u32; 3]> = (1..n as u32 - 1).map(|i| [0, i, i + 1]).collect();
        assert!(perimeters(&pts, &fan) > 2000.0 * perimeter);
        // Star-shaped from corner 0 but not convex (one corner pushed in): the fan, as before.
        let mut dent = flat.clone();
        dent[n / 2] = (0.5 * dent[n / 2].0, 0.5 * dent[n / 2].1);
        assert_eq!(run(&placed(&dent, 11)).1, How::Fan);
    }

    /// Star-shaped polygons about a centre (random radii: concave) are ear-clipped into
    /// triangles that face the polygon's way and cover its area exactly once.
    #[test]
    fn concave_polygons_are_ear_clipped_into_their_area() {
        let mut clipped = 0;
        for seed in 0..300u64 {
            let mut r = xor(seed + 1000);
            let n = 5 + (seed as usize * 13) % 200;
            let flat: Vec<(f64, f64)> = (0..n)
                .map(|k| {
                    let a = (k as f64 + 0.5 * r()) / n as f64 * std::f64::consts::TAU;
                    let rad = 0.2 + r();
                    (rad * a.cos(), rad * a.sin())
                })
                .collect();
            // The shoelace area, and the normal: +z turned with the points.
            let shoelace: f64 = (0..n)
                .map(|i| {
                    let (a, b) = (flat[i], flat[(i + 1) % n]);
                    a.0 * b.1 - a.1 * b.0
                })
                .sum::<f64>()
                / 2.0;
            let pts = placed(&flat, seed);
            let plane = placed(&[(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)], seed);
            let normal = (plane[1] - plane[0]).cross(plane[2] - plane[0]);
            let (tris, how) = run(&pts);
            clipped += usize::from(how == How::EarClipped);
            let (total, agree) = area(&pts, &tris, normal);
            assert!(agree, "seed {seed}: {how:?}");
            assert!((total - shoelace).abs() < 1e-4 * shoelace, "seed {seed}: {total} vs {shoelace} ({how:?})");
        }
        assert!(clipped > 250, "{clipped}");
    }

    /// Random simple polygons (random points, crossings undone by 2-opt moves until there are
    /// none: every shape, holes' keyholes aside) are ear-clipped into triangles that face the
    /// polygon's way and cover its area once.
    #[test]
    fn random_simple_polygons_are_ear_clipped_into_their_area() {
        let cross = |a: (f64, f64), b: (f64, f64), c: (f64, f64)| (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
        let (mut clipped, mut fans) = (0, 0);
        for seed in 0..200u64 {
            let mut r = xor(seed + 5000);
            let n = 5 + (seed as usize * 11) % 60;
            let mut flat: Vec<(f64, f64)> = (0..n).map(|_| (r(), r())).collect();
            // 2-opt: reverse the run between two crossing edges until no two cross.
            'untangle: loop {
                for i in 0..n {
                    for j in i + 2..n {
                        if i == 0 && j == n - 1 {
                            continue;
                        }
                        let (a, b, c, d) = (flat[i], flat[i + 1], flat[j], flat[(j + 1) % n]);
                        if cross(a, b, c) * cross(a, b, d) < 0.0 && cross(c, d, a) * cross(c, d, b) < 0.0 {
                            flat[i + 1..=j].reverse();
                            continue 'untangle;
                        }
                    }
                }
                break;
            }
            let shoelace: f64 = (0..n).map(|i| cross((0.0, 0.0), flat[i], flat[(i + 1) % n])).sum::<f64>() / 2.0;
            if shoelace < 0.0 {
                flat.reverse();
            }
            let pts = placed(&flat, seed);
            let plane = placed(&[(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)], seed);
            let normal = (plane[1] - plane[0]).cross(plane[2] - plane[0]);
            let (tris, how) = run(&pts);
            clipped += usize::from(how == How::EarClipped);
            fans += usize::from(how == How::Fan);
            let (total, agree) = area(&pts, &tris, normal);
            assert!(agree, "seed {seed}: {how:?}");
            let want = shoelace.abs();
            assert!((total - want).abs() < 1e-4 * want, "seed {seed}: {total} vs {want} ({how:?})");
        }
        assert_eq!(clipped + fans, 200);
        assert!(clipped > 150, "{clipped}");
    }

    /// Concave polygons past the cap, and self-intersecting ones with no ear, get the fan.
    #[test]
    fn what_cannot_be_clipped_gets_the_fan() {
        let n = MAX_EAR_CLIP_CORNERS + 1;
        let comb: Vec<(f64, f64)> = (0..n)
            .map(|k| {
                let a = k as f64 / n as f64 * std::f64::consts::TAU;
                let rad = if k % 2 == 0 { 1.0 } else { 0.5 };
                (rad * a.cos(), rad * a.sin())
            })
            .collect();
        let (tris, how) = run(&placed(&comb, 1));
        assert_eq!(how, How::FanOverCap);
        assert_eq!(tris[0], [0, 1, 2]);
        assert_eq!(run(&placed(&comb[..n - 1], 1)).1, How::EarClipped);
        // Self-intersecting, with an area (a normal) but no ear.
        let knot = [(0.0, 4.0), (4.0, 1.0), (2.0, 4.0), (2.0, 0.0), (1.0, 2.0), (6.0, 3.0)];
        let (tris, how) = run(&knot.map(|(x, y)| Vec3::new(x, y, 0.0)));
        assert_eq!(how, How::FanNoEar);
        assert_eq!(tris, [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]]);
        // No area at all: the fan, nothing to warn about.
        let line = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::X * 3.0];
        assert_eq!(run(&line).1, How::Fan);
    }
}
