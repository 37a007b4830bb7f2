//! Exact volume of a ball ∩ a closed triangle mesh (Wang et al. 2006 style), and the outside
//! volume V(S − T) = V(S) − V(S ∩ T) the sphere-set fit minimises (Ren et al. 2006, eq. 35).
//!
//! Method (`shared/research/math-reference.md` §6): for a closed, outward-oriented mesh T and a
//! ball B(c, r), V(B ∩ T) = Σ_f V_f where V_f is the signed volume of (cone from c over the
//! triangle f) ∩ B. This holds for c inside or outside T: along any ray from c the signed
//! crossings beyond a point sum to 1 inside T and 0 outside.
//!
//! All arithmetic is f64; positions are model space in the input's units, volumes in units³.
//!
//! **Open meshes.** The formula needs a closed mesh. For a mesh that is not closed the caller
//! defines the solid some other way — the fit crate uses the voxelized solid and passes the
//! voxel solid's closed boundary mesh as T, so "outside volume" then means the part of the ball
//! outside the *voxel* solid. Its error against any smooth reading of the open surface is
//! bounded by the voxel layer the surface passes through (≲ surface area × cell size).
//!
//! **Culling.** Triangles that do not meet the ball contribute exactly σ r³Ω/3 (a spherical
//! sector), whose sum over *all* triangles is r³/3 · 4π · w(c), w the winding number of c.
//! [`ball_mesh_intersection_volume_near`] uses that: given w(c) and a conservative list of the
//! triangles that may meet the ball, it is exact while touching only those triangles.

use glam::DVec3;
use std::f64::consts::PI;

/// Volume of a ball of radius `r`: 4/3 π r³.
pub fn ball_volume_f64(r: f64) -> f64 {
    4.0 / 3.0 * PI * r * r * r
}

/// Unsigned solid angle subtended by triangle (a, b, c) seen from the origin, in steradians
/// (Van Oosterom & Strackee).
pub fn triangle_solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    signed_triangle_solid_angle(a, b, c).abs()
}

/// Signed solid angle of triangle (a, b, c) seen from the origin, in steradians, in [−2π, 2π]
/// (Van Oosterom & Strackee 1983: Ω = 2 atan2(a·(b×c), |a||b||c| + (a·b)|c| + (b·c)|a| + (c·a)|b|)):
/// positive when the origin sees the triangle's back (the side its normal (b−a)×(c−a) points
/// away from); reversing the winding negates it; 0 for a degenerate triangle or one whose plane
/// holds the origin. The one copy of the formula: the exact volumes here and the winding numbers
/// (`winding`, `orient`) use it.
pub fn signed_triangle_solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let la = a.length();
    let lb = b.length();
    let lc = c.length();
    let det = a.dot(b.cross(c));
    let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    2.0 * det.atan2(den)
}

/// Signed volume of (cone from `center` over triangle (a0, a1, a2)) ∩ ball(center, r), in
/// units³. Positive when the centre lies on the inner side of the triangle (behind an outward
/// face). Reversing the winding negates it. The sum over a closed outward mesh is V(B ∩ T).
pub fn triangle_ball_volume(center: DVec3, r: f64, a0: DVec3, a1: DVec3, a2: DVec3) -> f64 {
    if r <= 0.0 {
        return 0.0;
    }
    let a0 = a0 - center;
    let a1 = a1 - center;
    let a2 = a2 - center;
    let nraw = (a1 - a0).cross(a2 - a0);
    let nlen = nraw.length();
    if nlen == 0.0 || !nlen.is_finite() {
        return 0.0;
    }
    let n = nraw / nlen;
    let hs = n.dot(a0);
    if hs == 0.0 {
        return 0.0;
    }
    let sigma = hs.signum();
    let h = hs.abs();
    let omega = triangle_solid_angle(a0, a1, a2);
    let r3 = r * r * r;
    if h >= r {
        return sigma * r3 * omega / 3.0;
    }
    let q0 = n * hs;
    let rho2 = r * r - h * h;
    let mut caps = 0.0;
    for (a, b) in [(a0, a1), (a1, a2), (a2, a0)] {
        let s = ((a - q0).cross(b - q0)).dot(n);
        if s == 0.0 {
            continue;
        }
        caps += s.signum() * edge_cap_term(a, b, q0, h, r, rho2);
    }
    sigma * (r3 * omega / 3.0 - caps)
}

/// C_e of the math reference: the cap volume beyond the plane inside the cone over (q0, a, b).
fn edge_cap_term(a: DVec3, b: DVec3, q0: DVec3, h: f64, r: f64, rho2: f64) -> f64 {
    // Crossings of the segment a + t (b − a), t ∈ (0, 1), with the circle |x − q0|² = ρ².
    let d = b - a;
    let f = a - q0;
    let qa = d.dot(d);
    let qb = 2.0 * f.dot(d);
    let qc = f.dot(f) - rho2;
    let mut ts = [0.0f64, 0.0, 0.0, 0.0];
    let mut nt = 1usize;
    if qa > 0.0 {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc > 0.0 {
            let sq = disc.sqrt();
            // Numerically stable roots.
            let qq = -0.5 * (qb + qb.signum() * sq);
            let (mut t1, mut t2) = if qq != 0.0 { (qq / qa, qc / qq) } else { (0.0, 0.0) };
            if t1 > t2 {
                std::mem::swap(&mut t1, &mut t2);
            }
            for t in [t1, t2] {
                if t > 0.0 && t < 1.0 {
                    ts[nt] = t;
                    nt += 1;
                }
            }
        }
    }
    ts[nt] = 1.0;
    nt += 1;
    let cap_wedge = (r - h) * (r - h) * (2.0 * r + h) / 6.0;
    let r3 = r * r * r;
    let mut sum = 0.0;
    for w in ts[..nt].windows(2) {
        let (t0, t1) = (w[0], w[1]);
        if t1 <= t0 {
            continue;
        }
        let p = a + d * t0;
        let pp = a + d * t1;
        let mid = a + d * (0.5 * (t0 + t1)) - q0;
        let u = p - q0;
        let v = pp - q0;
        if mid.length_squared() <= rho2 {
            let omega = triangle_solid_angle(q0, p, pp);
            sum += r3 * omega / 3.0 - h / 3.0 * u.cross(v).length() / 2.0;
        } else {
            let alpha = u.cross(v).length().atan2(u.dot(v));
            sum += alpha * cap_wedge;
        }
    }
    sum
}

/// V(B(center, r) ∩ T) for a closed, outward-oriented mesh T, summing over every triangle.
/// Triangles with an out-of-range index are skipped (callers validate indices).
pub fn ball_mesh_intersection_volume(center: DVec3, r: f64, positions: &[DVec3], triangles: &[[u32; 3]]) -> f64 {
    let mut sum = 0.0;
    for t in triangles {
        if let Some((a, b, c)) = corners(positions, t) {
            sum += triangle_ball_volume(center, r, a, b, c);
        }
    }
    sum
}

/// V(B(center, r) ∩ T) touching only the triangles in `near`, exact provided every triangle
/// *not* listed lies entirely outside the open ball and `winding_at_center` is the winding
/// number of `center` w.r.t. T (1 inside, 0 outside for a closed outward mesh).
pub fn ball_mesh_intersection_volume_near(
    center: DVec3,
    r: f64,
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    near: &[u32],
    winding_at_center: f64,
) -> f64 {
    let r3 = r * r * r;
    // Σ over far triangles of σ r³ Ω / 3 = r³/3 (4π w − Σ_near σΩ).
    let mut near_sector = 0.0;
    let mut near_exact = 0.0;
    for &ti in near {
        let Some(t) = triangles.get(ti as usize) else { continue };
        let Some((a, b, c)) = corners(positions, t) else { continue };
        near_exact += triangle_ball_volume(center, r, a, b, c);
        near_sector += signed_triangle_solid_angle(a - center, b - center, c - center);
    }
    // The signed solid angle convention: positive seen from behind, which is the σ > 0 side.
    r3 / 3.0 * (4.0 * PI * winding_at_center - near_sector) + near_exact
}

/// Outside volume V(B − T) = V(B) − V(B ∩ T), units³, summing over every triangle.
pub fn ball_outside_volume(center: DVec3, r: f64, positions: &[DVec3], triangles: &[[u32; 3]]) -> f64 {
    ball_volume_f64(r) - ball_mesh_intersection_volume(center, r, positions, triangles)
}

/// Signed enclosed volume Σ a·(b×c)/6 of a triangle mesh (the enclosed volume when closed and
/// outward-oriented), units³.
pub fn mesh_signed_volume(positions: &[DVec3], triangles: &[[u32; 3]]) -> f64 {
    let mut sum = 0.0;
    for t in triangles {
        if let Some((a, b, c)) = corners(positions, t) {
            sum += a.dot(b.cross(c));
        }
    }
    sum / 6.0
}

/// Generalised winding number of `p` w.r.t. a triangle soup (Jacobson et al. 2013):
/// Σ signed solid angle / 4π. 1 inside and 0 outside a closed outward mesh; smooth in between
/// for open ones. Brute force over every triangle.
pub fn winding_number_brute(p: DVec3, positions: &[DVec3], triangles: &[[u32; 3]]) -> f64 {
    let mut sum = 0.0;
    for t in triangles {
        if let Some((a, b, c)) = corners(positions, t) {
            sum += signed_triangle_solid_angle(a - p, b - p, c - p);
        }
    }
    sum / (4.0 * PI)
}

fn corners(positions: &[DVec3], t: &[u32; 3]) -> Option<(DVec3, DVec3, DVec3)> {
    Some((*positions.get(t[0] as usize)?, *positions.get(t[1] as usize)?, *positions.get(t[2] as usize)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn octant_triangle_subtends_an_eighth_of_the_sphere() {
        // The triangle X, Y, Z cuts the first octant: 4π / 8 = π/2; its normal points away from the origin.
        let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
        assert!((signed_triangle_solid_angle(x, y, z) - PI / 2.0).abs() < 1e-15);
        assert!((signed_triangle_solid_angle(x, z, y) + PI / 2.0).abs() < 1e-15);
        assert!((triangle_solid_angle(x, z, y) - PI / 2.0).abs() < 1e-15);
        // Scaling the vertices does not change it.
        assert!((signed_triangle_solid_angle(3.0 * x, 0.5 * y, 7.0 * z) - PI / 2.0).abs() < 1e-15);
        // Origin in the triangle's plane: 0.
        assert_eq!(signed_triangle_solid_angle(x, y, x + y), 0.0);
        // Far away: Ω ≈ area / d² (a unit right triangle at distance 1000 along its normal).
        let d = 1000.0;
        let far =
            signed_triangle_solid_angle(DVec3::new(0.0, 0.0, d), DVec3::new(0.0, 1.0, d), DVec3::new(1.0, 0.0, d));
        assert!((far.abs() / (0.5 / (d * d)) - 1.0).abs() < 1e-5, "{far}");
    }
}
