//! How far an animated skeleton can move between two sampled times: upper bounds on the change
//! of every node's local TRS and of every world (joint) transform over a time window, from the
//! channels' interpolants ([`crate::anim`]'s sampling). `spherebake-bake`'s `--pose-margin auto`
//! grows sphere radii by these bounds so that a pose *between* its sampled times stays covered.
//!
//! # Windows
//!
//! A window of animation `a` is a time interval `[lo, hi]` with a *reference* pose at one end:
//! the pose at `lo` ([`anim::sample_local`], right-continuous) or the limit just before `hi`
//! ([`anim::sample_local_before`]). The bounds below hold between the reference and the pose at
//! any time `t` with `lo ≤ t < hi`, and also `t = hi` when the window is `closed`: they bound
//! the *length of the path* every channel traces over the window (plus the jumps at keys inside
//! it), which bounds the distance between any two of its values there, both ends included.
//!
//! # Channels (path length over a window)
//!
//! Per key segment `k` the sampler evaluates the segment at `u = (t − t_k) / (t_{k+1} − t_k)`
//! computed in f32 ([`anim::segment_u`], monotone in `t`), so a window covers the parameter
//! range `[u(lo), u(hi)]` of each segment it overlaps, and the path length there is
//! `∫ |value'(u)| du`:
//!
//! - STEP: 0 inside a segment; the jump at a key inside the window counts separately.
//! - LINEAR translation / scale: `|v₁ − v₀| · Δu` (Euclidean for translations, the largest
//!   component for scales, which is the spectral norm of the diagonal scale matrix).
//! - LINEAR rotation (shortest-path slerp of the normalised keys, angle `φ = acos(q₀·q₁)` on the
//!   unit quaternion sphere S³): `φ · Δu`; where the sampler normalises a linear blend instead
//!   (`q₀·q₁ > 0.9995`), the blend `p(u)` has `|p'| = 2 sin(φ/2)` and `|p| ≥ cos(φ/2)`, so its
//!   normalisation moves at most `2 tan(φ/2)` per unit `u`: `2 tan(φ/2) · Δu`.
//! - CUBICSPLINE: the Hermite curve `p(u) = h₀₀ v₀ + h₁₀ Δt b₀ + h₀₁ v₁ + h₁₁ Δt a₁` (out-tangent
//!   `b₀`, in-tangent `a₁`) has `p'(u) = (6u² − 6u)(v₀ − v₁) + (3u² − 4u + 1) Δt b₀ +
//!   (3u² − 2u) Δt a₁`; each quadratic's largest magnitude over `[u(lo), u(hi)]` (at an end or
//!   its vertex) gives `K ≥ |p'|` there, and the length is at most `K · Δu`. This covers the
//!   overshoot of the curve past its keys: nothing assumes the values stay between them. For
//!   rotations the sampler normalises `p`; `p/|p|` moves at most `|p'| / |p|`, and `|p|` is at
//!   least `m = (|p(u(lo))| + |p(u(hi))| − K Δu) / 2` over the range (`|p|` is `K`-Lipschitz), so
//!   the arc is at most `K Δu / m`, or unbounded when `m ≤ 0` (the curve may pass through zero).
//! - Keys inside the window (and at `hi` of a closed window) add the jump between the value just
//!   before and at the key ([`anim::sample_channel_before`] and [`anim::sample_channel`]); a
//!   window whose ends are sampled keys has none.
//!
//! Several channels driving the same node property: the largest of their lengths (the sampler
//! applies one of them).
//!
//! # Nodes and joints
//!
//! A rotation path of arc `s` on S³ changes the rotation matrix by at most
//! `‖R − R'‖₂ = 2 sin(θ/2) ≤ 2 sin(min(s, π/2))` (θ the rotation angle between the two, `θ/2`
//! the quaternion angle up to sign, at most the path length). Any two rotations differ by at
//! most 2, so a NaN or unbounded arc still gives the finite bound 2 (the sampler always returns a
//! unit quaternion, the identity for an unusable key).
//!
//! A local transform `L = T R S` changes by `‖ΔA_L‖₂ ≤ δR (s₀ + δS) + δS =: α_L` in its linear
//! part (`A = R S`; `s₀` the reference's largest |scale|, `δR`, `δS`, `δT` the node's bounds) and
//! by `β_L = δT` in its translation. A world transform `W = P L` (parent `P`, composed as
//! [`anim::world_matrices`] does, [`anim::composition_order`]) changes at a point `x` by
//! `ΔW x = ΔP (L x) + P₀ ΔL x`, so with `‖A_L‖ ≤ s₀ + α_L` and `|t_L| ≤ |T₀| + δT` over the
//! window:
//!
//! ```text
//! α_W = α_P (s₀ + α_L) + ‖A_P₀‖ α_L          (‖ΔA_W‖₂)
//! β_W = α_P (|T₀| + δT) + β_P + ‖A_P₀‖ β_L    (|Δt_W|)
//! ```
//!
//! with `‖A_P₀‖` a bound on the spectral norm of the parent's reference linear part (the smaller
//! of its Frobenius norm and the square root of Gershgorin's bound on `AᵀA`: 1 for a rotation)
//! and `α = β = 0` above the roots. A point `x` carried by a joint matrix `M = W B`
//! (`B` the inverse bind) then moves by at most `α_W |B x| + β_W`: `|B x|` is the lever arm, the
//! distance of `x` from the joint in the joint's own frame; a homogeneous `(q, b)` (a sphere's
//! skin term) by `α_W |B (q, b)|_xyz + β_W |b|`.
//!
//! All bounds are first order in the window length: halving a window about halves them.
//! Arithmetic is f64 on the f32 key data; the sampler's own f32 rounding (≈ 1e-7 relative) is
//! not included (callers add a relative slack).

use std::f64::consts::FRAC_PI_2;

use glam::{DVec4, Mat4, Vec4};

use crate::anim::{self, Trs};
use crate::mesh::{AnimChannel, AnimPath, Interpolation, Skeleton};

/// Bound on how far one node's local TRS moves over a window (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LocalMotion {
    /// `|T(t) − T(t')|`.
    pub translation: f64,
    /// `‖R(t) − R(t')‖₂`, at most 2.
    pub rotation: f64,
    /// `max_i |S_i(t) − S_i(t')|`.
    pub scale: f64,
}

/// Bound on how far an affine map `x ↦ A x + t` moves over a window: `‖A(t) − A(t')‖₂ ≤ linear`,
/// `|t(t) − t(t')| ≤ translation`; so a point `x` moves by at most `linear·|x| + translation`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AffineMotion {
    pub linear: f64,
    pub translation: f64,
}

impl AffineMotion {
    /// The larger of two bounds, component by component (a bound for the union of two windows
    /// that share their reference pose).
    #[must_use]
    pub fn max(self, o: AffineMotion) -> AffineMotion {
        AffineMotion { linear: nan_max(self.linear, o.linear), translation: nan_max(self.translation, o.translation) }
    }

    /// Whether both parts are finite.
    #[must_use]
    pub fn is_finite(&self) -> bool {
        self.linear.is_finite() && self.translation.is_finite()
    }
}

/// `max` that keeps a NaN (an unusable bound must stay unusable).
fn nan_max(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

fn dvec(v: Vec4) -> DVec4 {
    v.as_dvec4()
}

/// Distance between two values of a channel: Euclidean (translation), largest component
/// (scale), quaternion angle up to sign (rotation, radians on S³).
fn distance(path: AnimPath, a: Vec4, b: Vec4) -> f64 {
    let (a, b) = (dvec(a), dvec(b));
    match path {
        AnimPath::Translation => (a - b).truncate().length(),
        AnimPath::Scale => (a - b).truncate().abs().max_element(),
        AnimPath::Rotation => quat_angle(a, b),
    }
}

/// Angle between two quaternions up to sign (radians, in `[0, π/2]`), by `2 atan2(|a − b|,
/// |a + b|)` of the normalised pair on one hemisphere: accurate for small angles, where `acos`
/// of the dot product loses half the digits. NaN for a zero or non-finite quaternion.
fn quat_angle(a: DVec4, b: DVec4) -> f64 {
    let (a, mut b) = (a.normalize(), b.normalize());
    if a.dot(b) < 0.0 {
        b = -b;
    }
    2.0 * (a - b).length().atan2((a + b).length())
}

/// The norm of a key difference or tangent: as [`distance`], Euclidean in 4-D for rotations
/// (the raw Hermite quaternion).
fn norm(path: AnimPath, v: DVec4) -> f64 {
    match path {
        AnimPath::Translation => v.truncate().length(),
        AnimPath::Scale => v.truncate().abs().max_element(),
        AnimPath::Rotation => v.length(),
    }
}

/// Largest `|a u² + b u + c|` over `u ∈ [lo, hi]`.
fn sup_abs_quadratic(a: f64, b: f64, c: f64, lo: f64, hi: f64) -> f64 {
    let f = |u: f64| (a * u * u + b * u + c).abs();
    let mut m = f(lo).max(f(hi));
    if a != 0.0 {
        let v = -b / (2.0 * a);
        if v > lo && v < hi {
            m = m.max(f(v));
        }
    }
    m
}

/// Path length of segment `k` of `ch` over `u ∈ [ua, ub]` (module docs, "Channels").
fn segment_length(ch: &AnimChannel, k: usize, ua: f32, ub: f32) -> f64 {
    let du = f64::from(ub) - f64::from(ua);
    if du <= 0.0 {
        return 0.0;
    }
    let comps = anim::components(ch);
    match ch.interpolation {
        Interpolation::Step => 0.0,
        Interpolation::Linear => {
            let (a, b) = (anim::key_value(ch, comps, k), anim::key_value(ch, comps, k + 1));
            if ch.path == AnimPath::Rotation {
                // The sampler's shortest-path slerp of the f32-normalised keys.
                let qa = dvec(glam::Quat::from_vec4(a).normalize().into());
                let qb = dvec(glam::Quat::from_vec4(b).normalize().into());
                // The sampler's branch test on its own (unrenormalised) dot product.
                let d = qa.dot(qb).abs();
                let phi = quat_angle(qa, qb);
                if phi.is_nan() {
                    return f64::NAN;
                }
                if d > anim::SLERP_LERP_DOT {
                    2.0 * (phi / 2.0).tan() * du
                } else {
                    phi * du
                }
            } else {
                norm(ch.path, dvec(b) - dvec(a)) * du
            }
        }
        Interpolation::CubicSpline => {
            let v0 = dvec(anim::key_value(ch, comps, 3 * k + 1));
            let b0 = dvec(anim::key_value(ch, comps, 3 * k + 2));
            let a1 = dvec(anim::key_value(ch, comps, 3 * (k + 1)));
            let v1 = dvec(anim::key_value(ch, comps, 3 * (k + 1) + 1));
            let dt = f64::from(ch.times[k + 1] - ch.times[k]);
            let (lo, hi) = (f64::from(ua), f64::from(ub));
            let speed = sup_abs_quadratic(6.0, -6.0, 0.0, lo, hi) * norm(ch.path, v0 - v1)
                + sup_abs_quadratic(3.0, -4.0, 1.0, lo, hi) * dt * norm(ch.path, b0)
                + sup_abs_quadratic(3.0, -2.0, 0.0, lo, hi) * dt * norm(ch.path, a1);
            let length = speed * du;
            if ch.path != AnimPath::Rotation {
                return length;
            }
            let hermite = |u: f64| {
                let (u2, u3) = (u * u, u * u * u);
                v0 * (2.0 * u3 - 3.0 * u2 + 1.0)
                    + b0 * (dt * (u3 - 2.0 * u2 + u))
                    + v1 * (-2.0 * u3 + 3.0 * u2)
                    + a1 * (dt * (u3 - u2))
            };
            let m = (hermite(lo).length() + hermite(hi).length() - length) / 2.0;
            if m > 0.0 {
                length / m
            } else {
                f64::INFINITY
            }
        }
    }
}

/// Upper bound on the path length of channel `ch` over the window `[lo, hi]` (`closed`: the
/// time `hi` itself included; module docs): translation in model units (Euclidean), scale as
/// the largest component change, rotation as the quaternion arc (radians on S³). NaN when `lo`
/// or `hi` is NaN or `lo > hi`; 0 for a channel without keys.
///
/// Cost: O(log keys + keys in the window).
#[must_use]
pub fn channel_variation(ch: &AnimChannel, lo: f32, hi: f32, closed: bool) -> f64 {
    let times = &ch.times;
    let n = times.len();
    if lo.is_nan() || hi.is_nan() || lo > hi {
        return f64::NAN;
    }
    let Some(mut k) = anim::segment_at(times, lo, false) else { return 0.0 };
    let mut total = 0.0;
    // Segments overlapping the window.
    while k + 1 < n && times[k] < hi {
        let (t0, t1) = (times[k], times[k + 1]);
        if t1 > t0 {
            let (a, b) = (lo.max(t0), hi.min(t1));
            if b > a {
                total += segment_length(ch, k, anim::segment_u(times, k, a), anim::segment_u(times, k, b));
            }
        }
        k += 1;
    }
    // Jumps at the keys strictly inside (and at hi when closed).
    let mut i = times.partition_point(|&x| x <= lo);
    while i < n && (times[i] < hi || (closed && times[i] == hi)) {
        let t = times[i];
        if let (Some(a), Some(b)) = (anim::sample_channel_before(ch, t), anim::sample_channel(ch, t)) {
            total += distance(ch.path, a, b);
        }
        while i < n && times[i] == t {
            i += 1;
        }
    }
    total
}

/// Per node of `skel`, how far its local TRS moves over the window `[lo, hi]` of animation
/// `anim` (zero for nodes the animation does not drive; module docs).
///
/// Cost: O(nodes + Σ over channels of (log keys + keys in the window)).
#[must_use]
pub fn local_motion(skel: &Skeleton, anim: usize, lo: f32, hi: f32, closed: bool) -> Vec<LocalMotion> {
    let mut out = vec![LocalMotion::default(); skel.nodes.len()];
    let mut arcs = vec![0.0f64; skel.nodes.len()];
    let Some(a) = skel.animations.get(anim) else { return out };
    for ch in &a.channels {
        if ch.times.is_empty() || ch.node >= out.len() {
            continue;
        }
        let v = channel_variation(ch, lo, hi, closed);
        let slot = &mut out[ch.node];
        match ch.path {
            AnimPath::Translation => slot.translation = nan_max(slot.translation, v),
            AnimPath::Scale => slot.scale = nan_max(slot.scale, v),
            AnimPath::Rotation => arcs[ch.node] = nan_max(arcs[ch.node], v),
        }
    }
    for (m, arc) in out.iter_mut().zip(arcs) {
        // NaN or unbounded arcs: any two rotations differ by at most 2 (f64::min drops a NaN).
        m.rotation = 2.0 * arc.min(FRAC_PI_2).sin();
        if arc.is_nan() {
            m.rotation = 2.0;
        }
    }
    out
}

/// Upper bound on the spectral norm of a matrix's upper-left 3×3 block `A`: the smaller of its
/// Frobenius norm and the square root of the largest absolute row sum of `AᵀA` (Gershgorin's
/// bound on its largest eigenvalue). Both are exact for a rotation times a uniform scale, where
/// the Frobenius norm alone would be √3 times too large at every level of the hierarchy.
fn linear_norm(m: &Mat4) -> f64 {
    let m = m.as_dmat4();
    let cols = [m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate()];
    let frobenius = cols.iter().map(|c| c.length_squared()).sum::<f64>().sqrt();
    // (AᵀA)_ij = col_i · col_j.
    let gershgorin = cols.iter().map(|ci| cols.iter().map(|cj| ci.dot(*cj).abs()).sum::<f64>()).fold(0.0, f64::max);
    frobenius.min(gershgorin.sqrt())
}

/// Per node, how far its world transform moves over a window, given the reference pose's local
/// TRS and world matrices ([`anim::sample_local`] / [`anim::sample_local_before`] and
/// [`anim::world_matrices`] of it) and [`local_motion`] of the window: the composition rule of
/// the module docs, nodes in [`anim::composition_order`]. NaN propagates (an unusable bound).
///
/// Cost: O(nodes).
#[must_use]
pub fn world_motion(skel: &Skeleton, locals: &[Trs], worlds: &[Mat4], local: &[LocalMotion]) -> Vec<AffineMotion> {
    let n = skel.nodes.len().min(locals.len()).min(worlds.len()).min(local.len());
    let mut out = vec![AffineMotion::default(); n];
    for (c, parent) in anim::composition_order(skel, n) {
        let (t0, _, s0) = locals[c];
        let lm = local[c];
        let s0 = f64::from(s0.abs().max_element());
        let t0 = f64::from(t0.length());
        let alpha_l = lm.rotation * (s0 + lm.scale) + lm.scale;
        let beta_l = lm.translation;
        out[c] = match parent {
            None => AffineMotion { linear: alpha_l, translation: beta_l },
            Some(p) => {
                let (pm, pn) = (out[p], linear_norm(&worlds[p]));
                AffineMotion {
                    linear: pm.linear * (s0 + alpha_l) + pn * alpha_l,
                    translation: pm.linear * (t0 + lm.translation) + pm.translation + pn * beta_l,
                }
            }
        };
    }
    out
}

/// Per bone of `skel`, the motion of its node's world transform ([`world_motion`]); zero for a
/// bone whose node is out of range (its joint matrix is the inverse bind alone). Apply the
/// inverse bind through the lever arm: a bind-space point `x` moves by at most
/// `linear · |B x| + translation`.
#[must_use]
pub fn bone_motion(skel: &Skeleton, world: &[AffineMotion]) -> Vec<AffineMotion> {
    skel.bones.iter().map(|b| world.get(b.node).copied().unwrap_or_default()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{Animation, Bone, Node};
    use glam::{Quat, Vec3};

    fn chan(path: AnimPath, interpolation: Interpolation, times: Vec<f32>, values: Vec<f32>) -> AnimChannel {
        AnimChannel { node: 0, path, interpolation, times, values }
    }

    /// Largest distance from the reference of sampled values over a window, by brute force.
    fn sampled_spread(ch: &AnimChannel, lo: f32, hi: f32, reference: Vec4) -> f64 {
        (0..=2000)
            .map(|i| {
                let t = lo + (hi - lo) * i as f32 / 2000.0;
                distance(ch.path, anim::sample_channel(ch, t).unwrap(), reference)
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn linear_translation_length_is_exact() {
        // 0 → (3, 4, 0) over 2 s: speed 2.5 per second; [0.5, 1.0] covers 1.25.
        let c = chan(AnimPath::Translation, Interpolation::Linear, vec![0.0, 2.0], vec![0.0, 0.0, 0.0, 3.0, 4.0, 0.0]);
        assert!((channel_variation(&c, 0.5, 1.0, true) - 1.25).abs() < 1e-6);
        // Outside the key range the channel is constant.
        assert_eq!(channel_variation(&c, 2.0, 5.0, true), 0.0);
        assert_eq!(channel_variation(&c, -3.0, 0.0, true), 0.0);
        // Across the whole range, the full length.
        assert!((channel_variation(&c, -1.0, 3.0, true) - 5.0).abs() < 1e-6);
        assert!(channel_variation(&c, 1.0, 0.5, true).is_nan());
        assert!(channel_variation(&c, f32::NAN, 0.5, true).is_nan());
    }

    #[test]
    fn slerp_arc_is_half_the_rotation_angle_per_window() {
        // 0 → 120° about z over 1 s: quaternion arc 60° = π/3 in total.
        let q = Quat::from_rotation_z(120f32.to_radians());
        let c = chan(
            AnimPath::Rotation,
            Interpolation::Linear,
            vec![0.0, 1.0],
            vec![0.0, 0.0, 0.0, 1.0, q.x, q.y, q.z, q.w],
        );
        let arc = channel_variation(&c, 0.25, 0.5, true);
        assert!((arc - std::f64::consts::PI / 12.0).abs() < 1e-6, "{arc}");
        // Node bound: 2 sin(arc) = ‖R(30°) − I‖ = 2 sin(15°).
        let skel = Skeleton {
            nodes: vec![Node {
                name: "n".into(),
                parent: None,
                translation: [0.0; 3],
                rotation: [0.0, 0.0, 0.0, 1.0],
                scale: [1.0; 3],
            }],
            bones: vec![],
            animations: vec![Animation { name: "a".into(), channels: vec![c] }],
        };
        let m = local_motion(&skel, 0, 0.25, 0.5, true);
        assert!((m[0].rotation - 2.0 * 15f64.to_radians().sin()).abs() < 1e-6);
    }

    #[test]
    fn nlerp_branch_bound_covers_the_sampler() {
        // 2° apart: the sampler normalises a linear blend; the bound is 2 tan(φ/2) per unit u.
        let q = Quat::from_rotation_x(2f32.to_radians());
        let c = chan(
            AnimPath::Rotation,
            Interpolation::Linear,
            vec![0.0, 1.0],
            vec![0.0, 0.0, 0.0, 1.0, q.x, q.y, q.z, q.w],
        );
        let b = channel_variation(&c, 0.0, 0.5, true);
        let r = anim::sample_channel(&c, 0.0).unwrap();
        let s = sampled_spread(&c, 0.0, 0.5, r);
        assert!(s <= b * (1.0 + 1e-5), "{s} > {b}");
        assert!(b < s * 1.01, "tight: {b} vs {s}");
    }

    #[test]
    fn step_jumps_count_only_inside_the_window() {
        let c = chan(
            AnimPath::Scale,
            Interpolation::Step,
            vec![0.0, 1.0, 2.0],
            vec![1.0, 1.0, 1.0, 3.0, 1.0, 1.0, 2.0, 2.0, 2.0],
        );
        // Inside a segment: constant.
        assert_eq!(channel_variation(&c, 0.2, 0.9, true), 0.0);
        // A window ending at the key, open at hi: the jump is not in it.
        assert_eq!(channel_variation(&c, 0.5, 1.0, false), 0.0);
        // Closed: it is (scale x 1 → 3).
        assert!((channel_variation(&c, 0.5, 1.0, true) - 2.0).abs() < 1e-9);
        // Starting at the key: the reference is the value at the key, no jump.
        assert_eq!(channel_variation(&c, 1.0, 1.5, true), 0.0);
        // Both keys inside: 2 + max(|2−3|, |2−1|, |2−1|) = 3.
        assert!((channel_variation(&c, 0.5, 2.5, true) - 3.0).abs() < 1e-9);
    }

    #[test]
    fn cubic_overshoot_is_bounded() {
        // Values 0 → 0 with large tangents: the curve overshoots to 0.25·Δt·m between equal keys.
        let values = vec![
            0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 8.0, 0.0, 0.0, // key 0: in, value, out
            8.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, // key 1
        ];
        let c = chan(AnimPath::Translation, Interpolation::CubicSpline, vec![0.0, 1.0], values);
        let b = channel_variation(&c, 0.0, 0.5, true);
        let s = sampled_spread(&c, 0.0, 0.5, anim::sample_channel(&c, 0.0).unwrap());
        // Hermite x(u) = 8(u³ − 2u² + u) + 8(u³ − u²) = 16u³ − 24u² + 8u, both keys 0: it peaks
        // at u = (3 − √3)/6 with x = 4√3/9 ≈ 0.770.
        assert!(s > 0.7, "overshoot {s}");
        assert!(s <= b, "{s} > {b}");
        // Keys alone would say 0.
        let l = chan(AnimPath::Translation, Interpolation::Linear, vec![0.0, 1.0], vec![0.0; 6]);
        assert_eq!(channel_variation(&l, 0.0, 0.5, true), 0.0);
    }

    #[test]
    fn world_motion_composes_lever_arms() {
        // Root rotates 0 → 90° about z over 1 s; child 2 units along x. Over [0, 0.5] the child's
        // origin moves along a 45° arc of radius 2: chord 2·2 sin(22.5°); the bound is
        // α_P·|t_L| = 2 sin(arc) · 2 with arc = π/8 (quaternion) → 4 sin(22.5°), equal.
        let q = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
        let skel = Skeleton {
            nodes: vec![
                Node {
                    name: "root".into(),
                    parent: None,
                    translation: [0.0; 3],
                    rotation: [0.0, 0.0, 0.0, 1.0],
                    scale: [1.0; 3],
                },
                Node {
                    name: "child".into(),
                    parent: Some(0),
                    translation: [2.0, 0.0, 0.0],
                    rotation: [0.0, 0.0, 0.0, 1.0],
                    scale: [1.0; 3],
                },
            ],
            bones: vec![Bone { name: "child".into(), node: 1, parent: None, inverse_bind: Mat4::IDENTITY }],
            animations: vec![Animation {
                name: "a".into(),
                channels: vec![chan(
                    AnimPath::Rotation,
                    Interpolation::Linear,
                    vec![0.0, 1.0],
                    vec![0.0, 0.0, 0.0, 1.0, q.x, q.y, q.z, q.w],
                )],
            }],
        };
        let locals = anim::sample_local(&skel, Some(0), 0.0);
        let worlds = anim::world_matrices(&skel, &locals);
        let lm = local_motion(&skel, 0, 0.0, 0.5, true);
        let wm = world_motion(&skel, &locals, &worlds, &lm);
        let bm = bone_motion(&skel, &wm);
        let want = 4.0 * 22.5f64.to_radians().sin();
        assert!((bm[0].translation - want).abs() < 1e-6, "{:?}", bm[0]);
        // The brute-force motion of the child's origin is the same chord.
        let w1 = anim::world_matrices(&skel, &anim::sample_local(&skel, Some(0), 0.5));
        let moved = (w1[1].transform_point3(Vec3::ZERO) - worlds[1].transform_point3(Vec3::ZERO)).length();
        assert!((f64::from(moved) - want).abs() < 1e-5);
    }

    /// Random chains of 4 nodes (random rest TRS, scales 0.5..2 per axis) driven by random
    /// LINEAR / STEP / CUBICSPLINE channels on every path, random windows: the world motion
    /// bound must hold against the sampled change of every world matrix (linear part in the
    /// spectral norm, bounded from below by its action on random unit vectors, and translation).
    #[test]
    fn world_motion_bounds_sampled_motion() {
        let mut rng = crate::rng::SplitMix64::new(7);
        let mut r = move |lo: f64, hi: f64| (lo + (hi - lo) * rng.next_f64()) as f32;
        let modes = [Interpolation::Linear, Interpolation::Step, Interpolation::CubicSpline];
        let mut worst: f64 = 0.0;
        for case in 0..200 {
            let nodes: Vec<Node> = (0..4)
                .map(|i| {
                    let q = Quat::from_axis_angle(
                        Vec3::new(r(-1.0, 1.0), r(-1.0, 1.0), r(0.1, 1.0)).normalize(),
                        r(-3.0, 3.0),
                    );
                    Node {
                        name: String::new(),
                        parent: if i == 0 { None } else { Some(i - 1) },
                        translation: [r(-1.0, 1.0), r(-1.0, 1.0), r(-1.0, 1.0)],
                        rotation: q.to_array(),
                        scale: [r(0.5, 2.0), r(0.5, 2.0), r(0.5, 2.0)],
                    }
                })
                .collect();
            let mut channels = Vec::new();
            for node in 0..4 {
                for path in [AnimPath::Translation, AnimPath::Rotation, AnimPath::Scale] {
                    // Each channel its own key range: windows run past some channels' ends.
                    let times: Vec<f32> = vec![r(0.0, 0.2), r(0.3, 0.6), r(0.7, 1.0)];
                    let interpolation = modes[(case + node + path as usize) % 3];
                    let comps = if path == AnimPath::Rotation { 4 } else { 3 };
                    let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
                    let values: Vec<f32> = (0..times.len() * per_key * comps)
                        .map(|_| match path {
                            AnimPath::Scale => r(0.5, 2.0),
                            _ => r(-1.0, 1.0),
                        })
                        .collect();
                    channels.push(AnimChannel { node, path, interpolation, times, values });
                }
            }
            let skel = Skeleton { nodes, bones: vec![], animations: vec![Animation { name: String::new(), channels }] };
            let (lo, hi) = {
                let (a, b) = (r(-0.1, 1.1), r(-0.1, 1.1));
                (a.min(b), a.max(b))
            };
            for (reference_at, before) in [(lo, false), (hi, true)] {
                let locals = if before {
                    anim::sample_local_before(&skel, Some(0), reference_at)
                } else {
                    anim::sample_local(&skel, Some(0), reference_at)
                };
                let worlds = anim::world_matrices(&skel, &locals);
                let bound = world_motion(&skel, &locals, &worlds, &local_motion(&skel, 0, lo, hi, !before));
                for k in 0..=200 {
                    let t = lo + (hi - lo) * k as f32 / 200.0;
                    if before && t >= hi {
                        continue; // [lo, hi) for the left-limit reference
                    }
                    let w = anim::world_matrices(&skel, &anim::sample_local(&skel, Some(0), t));
                    for n in 0..4 {
                        let d = w[n].as_dmat4() - worlds[n].as_dmat4();
                        let dt = d.w_axis.truncate().length();
                        let mut da: f64 = 0.0;
                        for x in [glam::DVec3::X, glam::DVec3::Y, glam::DVec3::Z, glam::DVec3::ONE.normalize()] {
                            da = da.max(d.transform_vector3(x).length());
                        }
                        let b = bound[n];
                        let slack = 1e-5 * (1.0 + b.linear + b.translation);
                        assert!(da <= b.linear + slack, "case {case} node {n} t {t}: ‖ΔA‖ ≥ {da} > {}", b.linear);
                        assert!(
                            dt <= b.translation + slack,
                            "case {case} node {n} t {t}: |Δt| {dt} > {}",
                            b.translation
                        );
                        worst = worst.max(da / b.linear.max(1e-12)).max(dt / b.translation.max(1e-12));
                    }
                }
            }
        }
        eprintln!("largest sampled / bound: {worst:.3}");
    }
}
