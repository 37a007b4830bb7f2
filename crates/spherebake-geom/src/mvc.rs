//! Mean value coordinates of points with respect to a closed triangle mesh (Ju, Schaefer and
//! Warren 2005; Ren et al. 2006 cite them as [Tao et al. 2005]) and their folding into per-bone
//! skinning terms (math reference §7).
//!
//! Everything is f64. Positions are whatever space the caller gives (the bake uses the welded
//! rest-pose mesh in model space); bone terms use the skin's bind (mesh) space, so glTF joint
//! matrices `world(joint) × inverse_bind` apply to them directly.

use glam::{DMat4, DVec3};

/// Distances below this (model units) count as "on a vertex", and `π − h` below it as "on the
/// triangle" (math reference §7).
pub const MVC_EPSILON: f64 = 1e-8;

/// Where the query point lies relative to the mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum MvcLocation {
    /// Off the surface: the general formula.
    OffSurface,
    /// Within [`MVC_EPSILON`] of welded vertex `vertex`: the weights are δ.
    OnVertex { vertex: u32 },
    /// On triangle `triangle` (the `π − h < ε` branch): its barycentric weights.
    OnTriangle { triangle: u32 },
}

/// Mean value coordinates of one point.
#[derive(Clone, Debug, PartialEq)]
pub struct Mvc {
    /// Normalised weights λ, one per vertex (Σ λ = 1); may be negative for non-convex meshes
    /// and for points outside.
    pub weights: Vec<f64>,
    /// Σ of the raw weights w before normalisation (2× the integral of the definition).
    pub raw_sum: f64,
    /// `|Σ λ_v p_v − x|`, model units: 0 up to rounding on closed meshes (linear precision);
    /// larger on open meshes.
    pub linear_residual: f64,
    pub location: MvcLocation,
    /// Triangles skipped as degenerate (repeated or collinear vertices).
    pub degenerate_triangles: usize,
}

/// Why coordinates could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MvcError {
    #[error("triangle {triangle} references vertex {vertex}, but the mesh has {vertex_count} vertices")]
    VertexIndex { triangle: usize, vertex: u32, vertex_count: usize },
    #[error("query point ({x}, {y}, {z}) is not finite")]
    NonFinitePoint { x: f64, y: f64, z: f64 },
    #[error("vertex {vertex} position is not finite")]
    NonFiniteVertex { vertex: usize },
    #[error("raw mean value weights sum to {sum}, too close to 0 to normalise (point far outside an open mesh?)")]
    DegenerateSum { sum: f64 },
}

/// Mean value coordinates of `x` with respect to the mesh (`positions`, `triangles`, counter-
/// clockwise = outward), following the formula of the math reference §7 with its ε.
///
/// Robustness: a point within ε of a vertex gets δ weights; a point on a triangle (`π − h < ε`)
/// gets that triangle's barycentric weights; triangles whose plane contains `x` (outside them)
/// or that are degenerate (repeated vertex ids, collinear or coincident corners) contribute
/// nothing, as their spherical projection has zero area.
///
/// # Errors
///
/// Out-of-range vertex ids, non-finite input, or a raw weight sum too close to 0 to normalise.
pub fn mean_value_coordinates(x: DVec3, positions: &[DVec3], triangles: &[[u32; 3]]) -> Result<Mvc, MvcError> {
    if !x.is_finite() {
        return Err(MvcError::NonFinitePoint { x: x.x, y: x.y, z: x.z });
    }
    let n = positions.len();
    for (t, tri) in triangles.iter().enumerate() {
        for &v in tri {
            if v as usize >= n {
                return Err(MvcError::VertexIndex { triangle: t, vertex: v, vertex_count: n });
            }
        }
    }
    let mut d = vec![0.0f64; n];
    let mut u = vec![DVec3::ZERO; n];
    for (j, &p) in positions.iter().enumerate() {
        if !p.is_finite() {
            return Err(MvcError::NonFiniteVertex { vertex: j });
        }
        let e = p - x;
        let dj = e.length();
        if dj < MVC_EPSILON {
            let mut weights = vec![0.0; n];
            weights[j] = 1.0;
            return Ok(Mvc {
                linear_residual: (p - x).length(),
                weights,
                raw_sum: 1.0,
                location: MvcLocation::OnVertex { vertex: j as u32 },
                degenerate_triangles: 0,
            });
        }
        d[j] = dj;
        u[j] = e / dj;
    }
    let mut w = vec![0.0f64; n];
    let mut degenerate = 0usize;
    for (t, tri) in triangles.iter().enumerate() {
        let ids = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
        if ids[0] == ids[1] || ids[1] == ids[2] || ids[0] == ids[2] {
            degenerate += 1;
            continue;
        }
        let uu = [u[ids[0]], u[ids[1]], u[ids[2]]];
        let dd = [d[ids[0]], d[ids[1]], d[ids[2]]];
        let mut theta = [0.0f64; 3];
        for i in 0..3 {
            let l = (uu[(i + 1) % 3] - uu[(i + 2) % 3]).length();
            theta[i] = 2.0 * (l / 2.0).min(1.0).asin();
        }
        let h = (theta[0] + theta[1] + theta[2]) / 2.0;
        if std::f64::consts::PI - h < MVC_EPSILON {
            // x lies on this triangle: barycentric weights.
            let bw: [f64; 3] = std::array::from_fn(|i| theta[i].sin() * dd[(i + 2) % 3] * dd[(i + 1) % 3]);
            let s: f64 = bw.iter().sum();
            if s > 0.0 && s.is_finite() {
                let mut weights = vec![0.0; n];
                for i in 0..3 {
                    weights[ids[i]] += bw[i] / s;
                }
                let residual = linear_residual(x, positions, &weights);
                return Ok(Mvc {
                    weights,
                    raw_sum: 1.0,
                    linear_residual: residual,
                    location: MvcLocation::OnTriangle { triangle: t as u32 },
                    degenerate_triangles: degenerate,
                });
            }
            // A degenerate (collinear) triangle through x: its neighbours decide.
            degenerate += 1;
            continue;
        }
        let sin_t = [theta[0].sin(), theta[1].sin(), theta[2].sin()];
        if sin_t.iter().any(|&s| s <= MVC_EPSILON) {
            // Coincident or collinear projected corners: zero spherical area.
            degenerate += 1;
            continue;
        }
        let det = uu[0].dot(uu[1].cross(uu[2]));
        let sign = if det < 0.0 { -1.0 } else { 1.0 };
        let mut c = [0.0f64; 3];
        let mut s = [0.0f64; 3];
        for i in 0..3 {
            c[i] = 2.0 * h.sin() * (h - theta[i]).sin() / (sin_t[(i + 1) % 3] * sin_t[(i + 2) % 3]) - 1.0;
            s[i] = sign * (1.0 - c[i] * c[i]).max(0.0).sqrt();
        }
        if s.iter().any(|v| v.abs() <= MVC_EPSILON) {
            continue; // x in the triangle's plane but outside it
        }
        for i in 0..3 {
            let (ip, im) = ((i + 1) % 3, (i + 2) % 3);
            w[ids[i]] += (theta[i] - c[ip] * theta[im] - c[im] * theta[ip]) / (dd[i] * sin_t[ip] * s[im]);
        }
    }
    let sum = sum_fixed(&w);
    let scale = w.iter().map(|v| v.abs()).fold(0.0, f64::max);
    if !sum.is_finite() || sum.abs() <= 1e-12 * scale.max(f64::MIN_POSITIVE) || sum == 0.0 {
        return Err(MvcError::DegenerateSum { sum });
    }
    for v in &mut w {
        *v /= sum;
    }
    let residual = linear_residual(x, positions, &w);
    Ok(Mvc {
        weights: w,
        raw_sum: sum,
        linear_residual: residual,
        location: MvcLocation::OffSurface,
        degenerate_triangles: degenerate,
    })
}

/// Sequential sum in index order (deterministic).
fn sum_fixed(v: &[f64]) -> f64 {
    v.iter().sum()
}

fn linear_residual(x: DVec3, positions: &[DVec3], weights: &[f64]) -> f64 {
    let mut acc = DVec3::ZERO;
    for (p, &l) in positions.iter().zip(weights) {
        acc += *p * l;
    }
    (acc - x).length()
}

/// One vertex's skin influences in f64: `(bone, weight)` pairs; weight 0 marks an unused pair.
/// Rows should sum to 1; a row summing to 0 is a static vertex (moved by no bone).
pub type SkinRow = [(u32, f64); 8];

/// A homogeneous point `(q, b)` in the skin's bind space attached to one bone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoneTerm {
    pub bone: u32,
    /// xyz part, bind (mesh) space, model units × weight.
    pub q: DVec3,
    /// w part (the bone's share of the centre; may be negative).
    pub b: f64,
}

impl BoneTerm {
    /// `M · (q, b)`, xyz part (`m` maps bind space to the scene).
    #[must_use]
    pub fn transformed(&self, m: &DMat4) -> DVec3 {
        m.transform_vector3(self.q) + m.w_axis.truncate() * self.b
    }
}

/// Where [`mean_value_coordinates`] cannot normalise ([`MvcError::DegenerateSum`]: a rest
/// pose that folds a closed mesh onto itself, so the solid angles cancel, or a point far
/// outside an open mesh), or normalises only into weights that nearly cancel (the bake's
/// `skin` stage decides), the barycentric weights of the surface point nearest to `x` (Σ λ = 1,
/// at most three non-zero, on the first nearest triangle in order) and that point's distance
/// to `x`, which is then `|Σ λ_v p_v − x|`. A degenerate nearest triangle gives its corner
/// nearest to `x` weight 1. `None` when no triangle has in-range ids and finite corners.
/// Cost O(triangles).
#[must_use]
pub fn nearest_surface_weights(x: DVec3, positions: &[DVec3], triangles: &[[u32; 3]]) -> Option<(Vec<f64>, f64)> {
    let mut best: Option<(f64, [u32; 3], [f64; 3])> = None;
    for t in triangles {
        let [Some(a), Some(b), Some(c)] = t.map(|v| positions.get(v as usize).copied()) else { continue };
        let c = [a, b, c];
        if !c.iter().all(|p| p.is_finite()) {
            continue;
        }
        let (q, l) = crate::triangle::closest_point_and_weights(x, &c);
        let d2 = x.distance_squared(q);
        if best.is_none_or(|(b, ..)| d2 < b) {
            best = Some((d2, *t, l));
        }
    }
    let (d2, t, l) = best?;
    let mut weights = vec![0.0; positions.len()];
    for (v, l) in t.iter().zip(l) {
        weights[*v as usize] += l;
    }
    Some((weights, d2.sqrt()))
}

/// Folds mean value coordinates λ (one per vertex) with per-vertex skin rows into per-bone
/// terms: `b_j = Σ_v λ_v s_vj`, `q_j = Σ_v λ_v s_vj p_v` with `p_v = bind_positions[v]`
/// (math reference §7). Returns one term per bone `0..bone_count` (index = bone); influences
/// naming a bone `>= bone_count` are ignored. Then `Σ_j M_j (q_j, b_j)` is exactly the MVC
/// combination of the linear-blend-skinned vertices for any joint matrices `M_j`.
///
/// `lambda`, `bind_positions` and `rows` are indexed alike; extra entries of the longer ones
/// are ignored.
#[must_use]
pub fn fold_into_bones(lambda: &[f64], bind_positions: &[DVec3], rows: &[SkinRow], bone_count: usize) -> Vec<BoneTerm> {
    let mut terms: Vec<BoneTerm> =
        (0..bone_count).map(|j| BoneTerm { bone: j as u32, q: DVec3::ZERO, b: 0.0 }).collect();
    for ((&l, &p), row) in lambda.iter().zip(bind_positions).zip(rows) {
        if l == 0.0 {
            continue;
        }
        for &(j, s) in row {
            if s == 0.0 {
                continue;
            }
            if let Some(t) = terms.get_mut(j as usize) {
                t.b += l * s;
                t.q += p * (l * s);
            }
        }
    }
    terms
}

/// Indices of the `k` terms of largest `|b|` (ties: lower bone first), among terms with `b ≠ 0`
/// or `q ≠ 0`; sorted by decreasing `|b|`.
#[must_use]
pub fn largest_terms(terms: &[BoneTerm], k: usize) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..terms.len()).filter(|&i| terms[i].b != 0.0 || terms[i].q != DVec3::ZERO).collect();
    idx.sort_by(|&a, &b| terms[b].b.abs().total_cmp(&terms[a].b.abs()).then(a.cmp(&b)));
    idx.truncate(k);
    idx
}

/// Result of [`truncate_terms`].
#[derive(Clone, Debug, PartialEq)]
pub struct Truncated {
    /// At most `k` terms, by decreasing `|b|` of the full fold.
    pub terms: Vec<BoneTerm>,
    /// Homogeneous remainder `(X, W)` (scene space at rest) that was redistributed: `|X|` and `W`.
    pub remainder_xyz: f64,
    pub remainder_w: f64,
    /// True when no kept bone had an invertible rest joint matrix, so the remainder was dropped
    /// (the rest centre is then not reproduced exactly).
    pub remainder_dropped: bool,
}

/// Keeps the `k` bones of largest `|b_j|` and renormalises so that the rest pose and any rigid
/// motion common to all joints stay exact.
///
/// With `K` the kept bones and `rest_joints[j]` the joint matrices of the rest pose (bind space →
/// the space of `centre_rest`), the remainder `(X, W) = (centre_rest, 1) − Σ_K M_j^rest (q_j, b_j)`
/// holds the dropped bones and, on open meshes, the MVC linear-precision residual. Each kept bone
/// takes the share `β_j = b_j / Σ_K b` of it, pulled back into its bind space:
/// `b̃_j = b_j + β_j W = b_j / Σ_K b`, `q̃_j = q_j + β_j A_j⁻¹ (X − W t_j)`
/// (`M_j = [A_j | t_j]`). So `Σ_K M_j^rest (q̃_j, b̃_j) = (centre_rest, 1)` exactly and for
/// `M_j = G M_j^rest` the centre moves by `G`. When `|Σ_K b| < 0.25` (weights of mixed sign
/// cancelling) the shares are `|b_j| / Σ_K |b|` instead, which keeps both properties. With every
/// bone kept on a closed mesh the remainder is rounding only and the result is the exact fold.
/// If no kept term exists (no vertex near the point is skinned), bone 0 alone carries `(c, 1)`.
#[must_use]
pub fn truncate_terms(terms: &[BoneTerm], k: usize, centre_rest: DVec3, rest_joints: &[DMat4]) -> Truncated {
    let mut kept: Vec<BoneTerm> = largest_terms(terms, k.max(1)).into_iter().map(|i| terms[i]).collect();
    if kept.is_empty() {
        if terms.is_empty() {
            return Truncated {
                terms: Vec::new(),
                remainder_xyz: centre_rest.length(),
                remainder_w: 1.0,
                remainder_dropped: true,
            };
        }
        kept.push(BoneTerm { bone: terms[0].bone, q: DVec3::ZERO, b: 0.0 });
    }
    let joint = |j: u32| rest_joints.get(j as usize).copied().unwrap_or(DMat4::IDENTITY);
    let mut sum_xyz = DVec3::ZERO;
    let mut sum_w = 0.0;
    for t in &kept {
        sum_xyz += t.transformed(&joint(t.bone));
        sum_w += t.b;
    }
    let x_rem = centre_rest - sum_xyz;
    let w_rem = 1.0 - sum_w;
    // Kept bones whose rest matrix can be inverted (pull-back into their bind space).
    let inverses: Vec<Option<DMat4>> = kept
        .iter()
        .map(|t| {
            let m = joint(t.bone);
            let det = m.determinant();
            (det.is_finite() && det.abs() > 1e-12 * m.x_axis.length().max(1e-300).powi(3)).then(|| m.inverse())
        })
        .collect();
    let usable: Vec<usize> = (0..kept.len()).filter(|&i| inverses[i].is_some()).collect();
    if usable.is_empty() {
        return Truncated { terms: kept, remainder_xyz: x_rem.length(), remainder_w: w_rem, remainder_dropped: true };
    }
    let signed: f64 = usable.iter().map(|&i| kept[i].b).sum();
    let absolute: f64 = usable.iter().map(|&i| kept[i].b.abs()).sum();
    let shares: Vec<f64> = usable
        .iter()
        .map(|&i| {
            if signed.abs() >= 0.25 {
                kept[i].b / signed
            } else if absolute > 0.0 {
                kept[i].b.abs() / absolute
            } else {
                1.0 / usable.len() as f64
            }
        })
        .collect();
    for (&i, &beta) in usable.iter().zip(&shares) {
        let inv = inverses[i].unwrap_or(DMat4::IDENTITY);
        let m = joint(kept[i].bone);
        let t = m.w_axis.truncate();
        kept[i].q += inv.transform_vector3(x_rem - t * w_rem) * beta;
        kept[i].b += beta * w_rem;
    }
    Truncated { terms: kept, remainder_xyz: x_rem.length(), remainder_w: w_rem, remainder_dropped: false }
}

/// `Σ_j M_j (q_j, b_j)`, xyz part: the posed centre (`joints[bone]`, identity when missing).
#[must_use]
pub fn pose_terms(terms: &[BoneTerm], joints: &[DMat4]) -> DVec3 {
    terms.iter().map(|t| t.transformed(&joints.get(t.bone as usize).copied().unwrap_or(DMat4::IDENTITY))).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The box [0, 2] × [0, 1] × [0, 3] as 12 triangles, and random points inside and outside
    /// it: the fallback's point Σ λ_v p_v lies on the box's surface, at the box's analytic
    /// distance from the query (outside: the clamped offset; inside: the nearest face), with
    /// Σ λ = 1, weights in [0, 1] on at most three vertices.
    #[test]
    fn the_nearest_surface_weights_give_the_box_point_at_its_analytic_distance() {
        let hi = DVec3::new(2.0, 1.0, 3.0);
        let p: Vec<DVec3> =
            (0..8).map(|i| DVec3::new((i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2) as f64) * hi).collect();
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let tris: Vec<[u32; 3]> = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
        let mut rng = crate::rng::SplitMix64::new(5);
        for n in 0..500 {
            let x = DVec3::new(rng.next_f64() * 6.0 - 2.0, rng.next_f64() * 5.0 - 2.0, rng.next_f64() * 7.0 - 2.0);
            let outside = (x - x.clamp(DVec3::ZERO, hi)).length();
            let inside = x.min_element().min((hi - x).min_element());
            let want = if outside > 0.0 { outside } else { inside };
            let (w, d) = nearest_surface_weights(x, &p, &tris).unwrap();
            assert!((d - want).abs() < 1e-12, "{n}: {x}: distance {d}, box {want}");
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            assert!(w.iter().all(|&l| (0.0..=1.0).contains(&l)) && w.iter().filter(|&&l| l != 0.0).count() <= 3);
            let q: DVec3 = w.iter().zip(&p).map(|(&l, &v)| l * v).sum();
            assert!(((q - x).length() - want).abs() < 1e-9, "{n}: the weights' point {q} is not at the distance");
            let on_face = (0..3).any(|a| q[a].abs() < 1e-9 || (q[a] - hi[a]).abs() < 1e-9);
            assert!(
                on_face && q.cmpge(DVec3::splat(-1e-9)).all() && q.cmple(hi + 1e-9).all(),
                "{n}: {q} not on the box"
            );
        }
        // A point off a lone degenerate triangle (collinear corners) takes its nearest corner.
        let line = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
        let (w, d) = nearest_surface_weights(DVec3::new(2.5, 0.0, 0.0), &line, &[[0, 1, 2]]).unwrap();
        assert_eq!((w, d), (vec![0.0, 0.0, 1.0], 0.5));
        assert!(nearest_surface_weights(DVec3::ZERO, &line, &[[0, 1, 9]]).is_none());
    }

    fn check(x: DVec3, expected_vertex: Option<u32>) {
        let p = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let m = mean_value_coordinates(x, &p, &[[0, 1, 2], [0, 2, 1]]).unwrap();
        if let Some(v) = expected_vertex {
            assert_eq!(m.location, MvcLocation::OnVertex { vertex: v });
        }
    }

    #[test]
    fn vertex_snap() {
        check(DVec3::new(1e-10, 0.0, 0.0), Some(0));
        check(DVec3::new(0.0, 1.0, 1e-9), Some(2));
    }
}
