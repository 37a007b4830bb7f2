//! Outward orientation of every triangle, decided by the solid (not by the file's winding).
//!
//! Real meshes are not always consistently oriented: whole files or parts are exported inside
//! out, single triangles are flipped. Stages that need "outward" (the sample placement's back /
//! front side test, Guerrero et al. 2008 §4.2) ask this module instead of trusting the
//! counter-clockwise normal.
//!
//! **Method.** The solid is the one the voxelizer uses: points where the generalized winding
//! number w has |w| ≥ ½ (see [`crate::winding`] and [`crate::voxel`]). For triangle t with
//! centroid c, counter-clockwise unit normal n and scale s = √(2·area), evaluate the winding
//! number of *all other triangles*, w′(q) = w(q) − Ω_t(q)/4π (fast hierarchical w minus t's exact
//! solid angle), at q± = c ± δn. Leaving t itself out is what makes the test independent of t's
//! own winding: the full w always jumps by +1 across t towards the back of its normal, whichever
//! way t is wound. For a closed mesh w′(q−) = w(q−) − a and w′(q+) = w(q+) + a with a = Ω_t(q−)/4π,
//! so the normalised score
//!
//! r = (|w′(q−)| − |w′(q+)|) / (1 − 2a)
//!
//! is +1 when n points out of the solid, −1 when it points in. The triangle is flipped when
//! r ≤ −½, kept when r ≥ ½; otherwise the test is repeated with a smaller offset (δ = s/2, then
//! s/16) and, if still undecided, the file's winding is kept and the triangle counted as
//! [`Orientation::ambiguous`].
//!
//! **By defect:**
//! - *whole mesh or whole part flipped*: w = −1 inside, |w| sees the same solid: every triangle
//!   of the part is flipped back;
//! - *isolated flipped triangles* (no flipped neighbour within about one triangle size): w′ does
//!   not depend on them, so each is decided by the correctly wound surface around it;
//! - *flipped patches* (several adjacent flipped triangles): the patch's own contribution to w′
//!   points the wrong way; small patches are still decided right, a patch that fills much of
//!   what q± sees is decided by the patch (wrongly) or left ambiguous;
//! - *overlapping parts / duplicated triangles*: w = 2 in the overlap; a triangle of one part
//!   inside another still sees |w| 2 behind and 1 in front, and keeps pointing away from its
//!   own part's interior;
//! - *holes*: w falls off smoothly near a hole, the score shrinks but keeps its sign;
//! - *open sheets* (a single plane, a flat pane, both sides outside): |w′| is the same on both
//!   sides, the triangle keeps the file's winding and is counted as ambiguous;
//! - *thin parts thinner than δ*: the smaller second offset usually decides them;
//! - *degenerate triangles* (zero area, non-finite or out-of-range corners): kept, counted in
//!   [`Orientation::degenerate`].
//!
//! Cost: two fast winding evaluations per triangle (four for the undecided ones), parallel over
//! triangles with rayon; each triangle's answer depends only on shared read-only data, so the
//! result is identical for any thread count.

use crate::winding::{solid_angle, WindingNumber};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::f64::consts::PI;

/// Offsets tried along the normal, as fractions of the triangle scale √(2·area).
const OFFSETS: [f64; 2] = [0.5, 1.0 / 16.0];
/// |score| at or above this decides.
const DECISIVE: f64 = 0.5;

/// Per-triangle outward orientation (see the module docs).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Orientation {
    /// Per input triangle: `true` when its counter-clockwise normal points into the solid and
    /// must be negated to point outward.
    pub flip: Vec<bool>,
    /// Number of `true` entries in `flip`.
    pub flipped: usize,
    /// Triangles the solid could not decide (open sheets, both sides outside): file winding kept.
    pub ambiguous: usize,
    /// Triangles without a normal (zero area, non-finite or out-of-range corners): kept.
    pub degenerate: usize,
}

/// Decides, for every triangle, whether its counter-clockwise normal must be flipped to point
/// away from the interior (see the module docs).
///
/// `winding` must be built over the same triangles in the same order (its own positions may be
/// the welded ones: only the geometry matters). Triangles beyond what `winding` knows are still
/// decided, just with their own contribution not removed exactly.
pub fn outward_orientation(positions: &[Vec3], triangles: &[[u32; 3]], winding: &WindingNumber) -> Orientation {
    let decisions: Vec<Decision> = triangles.par_iter().map(|tri| decide(positions, tri, winding)).collect();
    let mut out = Orientation { flip: Vec::with_capacity(decisions.len()), ..Default::default() };
    for d in decisions {
        out.flip.push(d == Decision::Flip);
        match d {
            Decision::Flip => out.flipped += 1,
            Decision::Ambiguous => out.ambiguous += 1,
            Decision::Degenerate => out.degenerate += 1,
            Decision::Keep => {}
        }
    }
    out
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Decision {
    Keep,
    Flip,
    Ambiguous,
    Degenerate,
}

fn decide(positions: &[Vec3], tri: &[u32; 3], winding: &WindingNumber) -> Decision {
    let corners = tri.map(|i| positions.get(i as usize).copied());
    let [Some(a), Some(b), Some(c)] = corners else { return Decision::Degenerate };
    if !(a.is_finite() && b.is_finite() && c.is_finite()) {
        return Decision::Degenerate;
    }
    let t = [a.as_dvec3(), b.as_dvec3(), c.as_dvec3()];
    let cross = (t[1] - t[0]).cross(t[2] - t[0]);
    let len = cross.length();
    if !(len > 0.0 && len.is_finite()) {
        return Decision::Degenerate;
    }
    let n = cross / len;
    let scale = len.sqrt(); // √(2·area)
    let centroid = (t[0] + t[1] + t[2]) / 3.0;
    for f in OFFSETS {
        let delta = f * scale;
        let behind = centroid - delta * n;
        let front = centroid + delta * n;
        // Own contribution, exact: +a behind the normal, −a in front (a < ½).
        let own_behind = solid_angle(&t, behind) / (4.0 * PI);
        let own_front = solid_angle(&t, front) / (4.0 * PI);
        let rest_behind = winding.eval(behind) - own_behind;
        let rest_front = winding.eval(front) - own_front;
        let norm = (1.0 - (own_behind - own_front)).max(1e-3);
        let score = (rest_behind.abs() - rest_front.abs()) / norm;
        if score >= DECISIVE {
            return Decision::Keep;
        }
        if score <= -DECISIVE {
            return Decision::Flip;
        }
    }
    Decision::Ambiguous
}

/// Geometric outward normal helper: the unit counter-clockwise normal of `tri`, negated when
/// `flip` is set; `None` for degenerate triangles.
pub fn oriented_normal(tri: [DVec3; 3], flip: bool) -> Option<DVec3> {
    let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).try_normalize()?;
    Some(if flip { -n } else { n })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed unit-ish octahedron, outward.
    fn octahedron() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let p = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        let t = vec![[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
        (p, t)
    }

    #[test]
    fn octahedron_outward_is_kept_and_inverted_is_flipped() {
        let (p, t) = octahedron();
        // Check the test mesh really is outward: signed volume > 0.
        let vol: f64 = t
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| p[i as usize].as_dvec3());
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        assert!((vol - 4.0 / 3.0).abs() < 1e-12, "{vol}");
        let w = WindingNumber::new(&p, &t);
        let o = outward_orientation(&p, &t, &w);
        assert_eq!(o.flip, vec![false; 8]);
        let inv: Vec<[u32; 3]> = t.iter().map(|f| [f[0], f[2], f[1]]).collect();
        let w = WindingNumber::new(&p, &inv);
        let o = outward_orientation(&p, &inv, &w);
        assert_eq!(o.flip, vec![true; 8]);
        assert_eq!((o.flipped, o.ambiguous, o.degenerate), (8, 0, 0));
    }

    #[test]
    fn one_flipped_face_of_octahedron_is_found() {
        let (p, mut t) = octahedron();
        for k in 0..8 {
            let orig = t[k];
            t[k] = [orig[0], orig[2], orig[1]];
            let w = WindingNumber::new(&p, &t);
            let o = outward_orientation(&p, &t, &w);
            let expect: Vec<bool> = (0..8).map(|i| i == k).collect();
            assert_eq!(o.flip, expect, "face {k}");
            t[k] = orig;
        }
    }

    #[test]
    fn single_plane_is_ambiguous_and_degenerate_is_counted() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0), Vec3::new(2.0, 0.0, 0.0)];
        let t = vec![[0, 1, 2], [1, 3, 2], [0, 1, 4], [0, 1, 9]];
        let w = WindingNumber::new(&p, &t);
        let o = outward_orientation(&p, &t, &w);
        assert_eq!(o.flip, vec![false; 4]);
        assert_eq!((o.flipped, o.ambiguous, o.degenerate), (0, 2, 2));
    }
}
