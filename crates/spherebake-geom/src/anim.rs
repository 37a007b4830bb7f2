//! Animation posing: sample glTF-style channels into node TRS, compose world matrices, build
//! joint matrices and skin vertices by linear blend skinning (LBS).
//!
//! Conventions follow glTF 2.0: times in seconds, rotations as unit quaternions (xyzw), each
//! channel clamps the time to its own key range, LINEAR rotations use normalised shortest-path
//! slerp, CUBICSPLINE uses Hermite interpolation with tangents scaled by the key interval.
//! Composition is done in f64 and returned as f32.

use glam::{DMat4, DQuat, DVec3, Mat4, Quat, Vec3, Vec4};

use crate::mesh::{AnimChannel, AnimPath, Interpolation, Skeleton, Skin};

/// Local (translation, rotation, scale) of one node.
pub type Trs = (Vec3, Quat, Vec3);

fn key_vec4(ch: &AnimChannel, comps: usize, index: usize) -> Vec4 {
    let mut v = [0.0f32; 4];
    for (k, o) in v.iter_mut().enumerate().take(comps) {
        *o = ch.values.get(index * comps + k).copied().unwrap_or(0.0);
    }
    Vec4::from_array(v)
}

/// Samples one channel at `time_s` (clamped to its key range). Returns `None` for a channel
/// without keys. For rotations the result is a normalised xyzw quaternion in a `Vec4`.
///
/// The value is right-continuous in time: at a key time it is the segment that *starts* there
/// (for STEP the new key's value). [`sample_channel_before`] gives the limit from the left.
#[must_use]
pub fn sample_channel(ch: &AnimChannel, time_s: f32) -> Option<Vec4> {
    sample_channel_side(ch, time_s, false)
}

/// The limit of [`sample_channel`] as the time approaches `time_s` from below: at a STEP key the
/// previous key's value, where two keys share a time the first one's; elsewhere (and at or
/// before the first key or after the last, where the channel is constant) the same as
/// [`sample_channel`].
#[must_use]
pub fn sample_channel_before(ch: &AnimChannel, time_s: f32) -> Option<Vec4> {
    sample_channel_side(ch, time_s, true)
}

/// Index of the key segment `[times[k], times[k + 1]]` that [`sample_channel`] (`before` false)
/// or [`sample_channel_before`] (`before` true) evaluates at `t`, with `t` clamped to the key
/// range; `n - 1` (no segment: the last value) after the last key. `None` without keys.
#[must_use]
pub fn segment_at(times: &[f32], time_s: f32, before: bool) -> Option<usize> {
    let (&first, &last) = (times.first()?, times.last()?);
    // max / min rather than clamp: no panic on a NaN or unsorted key range (hostile input).
    let t = time_s.max(first).min(last);
    // After the last key the channel is constant: the limit from the left is its value there.
    let k = if before && t > first && time_s <= last {
        // Last key strictly before t.
        times.partition_point(|&x| x < t)
    } else {
        // Last key at or before t.
        times.partition_point(|&x| x <= t)
    };
    Some(k.saturating_sub(1))
}

/// The segment parameter `u ∈ [0, 1]` of time `time_s` in segment `k` exactly as the sampler
/// computes it (f32, clamped to the key range, `0` for a zero-length segment).
#[must_use]
pub fn segment_u(times: &[f32], k: usize, time_s: f32) -> f32 {
    let (Some(&first), Some(&last)) = (times.first(), times.last()) else { return 0.0 };
    let (Some(&t0), Some(&t1)) = (times.get(k), times.get(k + 1)) else { return 0.0 };
    let t = time_s.max(first).min(last);
    let dt = t1 - t0;
    if dt > 0.0 {
        ((t - t0) / dt).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Key `index`'s value (`comps` components; CubicSpline callers pass the flattened index).
pub(crate) fn key_value(ch: &AnimChannel, comps: usize, index: usize) -> Vec4 {
    key_vec4(ch, comps, index)
}

/// Components per key value of a channel: 4 for rotations, 3 otherwise.
pub(crate) fn components(ch: &AnimChannel) -> usize {
    if ch.path == AnimPath::Rotation {
        4
    } else {
        3
    }
}

fn sample_channel_side(ch: &AnimChannel, time_s: f32, before: bool) -> Option<Vec4> {
    let n = ch.times.len();
    let k = segment_at(&ch.times, time_s, before)?;
    let comps = components(ch);
    let cubic = ch.interpolation == Interpolation::CubicSpline;
    // Key k's value index in the flattened array (CubicSpline stores in-tangent, value, out-tangent).
    let value = |k: usize| if cubic { key_vec4(ch, comps, 3 * k + 1) } else { key_vec4(ch, comps, k) };
    let out = if k + 1 >= n {
        value(n - 1)
    } else {
        let dt = ch.times[k + 1] - ch.times[k];
        let u = segment_u(&ch.times, k, time_s);
        match ch.interpolation {
            Interpolation::Step => value(k),
            Interpolation::Linear => {
                let (a, b) = (value(k), value(k + 1));
                if ch.path == AnimPath::Rotation {
                    let qa = Quat::from_vec4(a).normalize();
                    let mut qb = Quat::from_vec4(b).normalize();
                    if qa.dot(qb) < 0.0 {
                        qb = -qb;
                    }
                    Vec4::from(slerp(qa, qb, u))
                } else {
                    a.lerp(b, u)
                }
            }
            Interpolation::CubicSpline => {
                let v0 = key_vec4(ch, comps, 3 * k + 1);
                let b0 = key_vec4(ch, comps, 3 * k + 2); // out-tangent of key k
                let a1 = key_vec4(ch, comps, 3 * (k + 1)); // in-tangent of key k+1
                let v1 = key_vec4(ch, comps, 3 * (k + 1) + 1);
                let (u2, u3) = (u * u, u * u * u);
                v0 * (2.0 * u3 - 3.0 * u2 + 1.0)
                    + b0 * (dt * (u3 - 2.0 * u2 + u))
                    + v1 * (-2.0 * u3 + 3.0 * u2)
                    + a1 * (dt * (u3 - u2))
            }
        }
    };
    Some(if ch.path == AnimPath::Rotation { out.try_normalize().unwrap_or(Vec4::W) } else { out })
}

/// Threshold of [`slerp`]: above this quaternion dot product it normalises a linear blend.
pub(crate) const SLERP_LERP_DOT: f64 = 0.9995;

/// Shortest-path-ready slerp (the caller flips `b` to the same hemisphere), computed in f64.
fn slerp(a: Quat, b: Quat, u: f32) -> Quat {
    let (a, b, u) = (a.as_dquat(), b.as_dquat(), f64::from(u));
    let d = a.dot(b).clamp(-1.0, 1.0);
    let q = if d > SLERP_LERP_DOT {
        DQuat::from_vec4(a.to_array().into()).lerp(b, u)
    } else {
        let th = d.acos();
        let s = th.sin();
        DQuat::from_vec4(
            glam::DVec4::from(a.to_array()) * ((1.0 - u) * th).sin() / s
                + glam::DVec4::from(b.to_array()) * (u * th).sin() / s,
        )
    };
    q.normalize().as_quat()
}

/// Per node local TRS at `time_s` seconds of animation `anim` (rest TRS for nodes the animation
/// does not drive, and for every node when `anim` is `None` or out of range).
#[must_use]
pub fn sample_local(skel: &Skeleton, anim: Option<usize>, time_s: f32) -> Vec<Trs> {
    sample_local_side(skel, anim, time_s, false)
}

/// [`sample_local`] with every channel at its limit from the left ([`sample_channel_before`]):
/// the pose just before `time_s`, which differs from the pose at `time_s` only where a STEP key
/// (or two keys at one time) makes a channel jump at `time_s`.
#[must_use]
pub fn sample_local_before(skel: &Skeleton, anim: Option<usize>, time_s: f32) -> Vec<Trs> {
    sample_local_side(skel, anim, time_s, true)
}

fn sample_local_side(skel: &Skeleton, anim: Option<usize>, time_s: f32, before: bool) -> Vec<Trs> {
    let mut out: Vec<Trs> = skel
        .nodes
        .iter()
        .map(|n| {
            let r = Vec4::from(n.rotation).try_normalize().map_or(Quat::IDENTITY, Quat::from_vec4);
            (Vec3::from(n.translation), r, Vec3::from(n.scale))
        })
        .collect();
    let Some(a) = anim.and_then(|i| skel.animations.get(i)) else { return out };
    for ch in &a.channels {
        let (Some(slot), Some(v)) = (out.get_mut(ch.node), sample_channel_side(ch, time_s, before)) else { continue };
        match ch.path {
            AnimPath::Translation => slot.0 = v.truncate(),
            AnimPath::Rotation => slot.1 = Quat::from_vec4(v),
            AnimPath::Scale => slot.2 = v.truncate(),
        }
    }
    out
}

/// The order in which [`world_matrices`] composes nodes, with the parent each node is composed
/// onto: `(node, parent)` pairs, every parent listed before its children. `parent` is `None`
/// for roots, for a parent index out of range and for the node of a cycle whose parent closes the
/// cycle (the cycle is cut there). The first `n` nodes (`n` ≤ the node count).
#[must_use]
pub fn composition_order(skel: &Skeleton, n: usize) -> Vec<(usize, Option<usize>)> {
    let n = n.min(skel.nodes.len());
    let mut done = vec![false; n];
    let mut order = Vec::with_capacity(n);
    let mut chain = Vec::new();
    for i in 0..n {
        // Walk up to the first node already composed (or a root), then compose downwards.
        chain.clear();
        let mut cur = Some(i);
        while let Some(c) = cur {
            if done[c] || chain.len() > n || chain.contains(&c) {
                break;
            }
            chain.push(c);
            cur = skel.nodes[c].parent.filter(|&p| p < n);
        }
        let mut parent = cur.filter(|&c| done[c]);
        for &c in chain.iter().rev() {
            order.push((c, parent));
            done[c] = true;
            parent = Some(c);
        }
    }
    order
}

/// World matrices from local TRS (`locals[i]` for node `i`), parents composed before children
/// whatever the node order. A parent index out of range, or a cycle, is treated as a root.
pub fn world_matrices(skel: &Skeleton, locals: &[Trs]) -> Vec<Mat4> {
    let n = skel.nodes.len().min(locals.len());
    let local = |i: usize| {
        let (t, r, s) = locals[i];
        DMat4::from_scale_rotation_translation(s.as_dvec3(), r.as_dquat().normalize(), t.as_dvec3())
    };
    let mut world: Vec<DMat4> = vec![DMat4::IDENTITY; n];
    for (c, parent) in composition_order(skel, n) {
        // Roots too are multiplied onto the identity, so the products are those of the
        // walk-up composition this order was taken from, bit for bit.
        world[c] = parent.map_or(DMat4::IDENTITY, |p| world[p]) * local(c);
    }
    world.into_iter().map(|m| m.as_mat4()).collect()
}

/// Joint matrices per bone: `world(bone.node) × inverse_bind` (bind / mesh space → scene).
/// A bone whose node has no world matrix gets its inverse bind alone.
pub fn joint_matrices(skel: &Skeleton, worlds: &[Mat4]) -> Vec<Mat4> {
    skel.bones
        .iter()
        .map(|b| {
            let w = worlds.get(b.node).copied().unwrap_or(Mat4::IDENTITY);
            (w.as_dmat4() * b.inverse_bind.as_dmat4()).as_mat4()
        })
        .collect()
}

/// Linear blend skinning of [`Skin::bind_positions`]: Σ w_i J[joint_i] p. Vertices without any
/// weight (rigid parts attached to no bone) keep their bind position, which the importer sets to
/// the rest position.
pub fn skin_vertices(skin: &Skin, joint_mats: &[Mat4]) -> Vec<Vec3> {
    let jm: Vec<DMat4> = joint_mats.iter().map(Mat4::as_dmat4).collect();
    skin.bind_positions
        .iter()
        .zip(&skin.influences)
        .map(|(&p, inf)| {
            let p = p.as_dvec3();
            let mut acc = DVec3::ZERO;
            let mut wsum = 0.0;
            for (&j, &w) in inf.joints.iter().zip(&inf.weights) {
                if w > 0.0 {
                    if let Some(m) = jm.get(j as usize) {
                        acc += m.transform_point3(p) * f64::from(w);
                        wsum += f64::from(w);
                    }
                }
            }
            if wsum > 0.0 {
                (acc / wsum).as_vec3()
            } else {
                p.as_vec3()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{Animation, Bone, Node, SkinInfluences};

    fn chan(path: AnimPath, interpolation: Interpolation, times: Vec<f32>, values: Vec<f32>) -> AnimChannel {
        AnimChannel { node: 0, path, interpolation, times, values }
    }

    fn close(a: Vec4, b: Vec4, tol: f32) -> bool {
        (a - b).abs().max_element() <= tol
    }

    #[test]
    fn linear_translation_halfway_and_clamped() {
        let c = chan(AnimPath::Translation, Interpolation::Linear, vec![1.0, 3.0], vec![0.0, 0.0, 0.0, 2.0, 4.0, -6.0]);
        assert!(close(sample_channel(&c, 2.0).unwrap(), Vec4::new(1.0, 2.0, -3.0, 0.0), 1e-6));
        assert!(close(sample_channel(&c, 2.5).unwrap(), Vec4::new(1.5, 3.0, -4.5, 0.0), 1e-6));
        // Clamped to the key range on both sides.
        assert!(close(sample_channel(&c, -5.0).unwrap(), Vec4::ZERO, 0.0));
        assert!(close(sample_channel(&c, 9.0).unwrap(), Vec4::new(2.0, 4.0, -6.0, 0.0), 0.0));
    }

    #[test]
    fn step_holds_previous_key() {
        let c = chan(AnimPath::Scale, Interpolation::Step, vec![0.0, 1.0], vec![1.0, 1.0, 1.0, 2.0, 2.0, 2.0]);
        assert_eq!(sample_channel(&c, 0.999).unwrap().x, 1.0);
        assert_eq!(sample_channel(&c, 1.0).unwrap().x, 2.0);
    }

    #[test]
    fn slerp_about_z_is_half_angle_and_shortest_path() {
        // 0 → 90° about Z; halfway is 45°: (0, 0, sin 22.5°, cos 22.5°).
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let c =
            chan(AnimPath::Rotation, Interpolation::Linear, vec![0.0, 1.0], vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, h, h]);
        let e = Vec4::new(0.0, 0.0, (std::f32::consts::PI / 8.0).sin(), (std::f32::consts::PI / 8.0).cos());
        assert!(close(sample_channel(&c, 0.5).unwrap(), e, 1e-6));
        // 1/4 of the way: 22.5° rotation (not the 1/4 chord of a lerp).
        let e = Vec4::new(0.0, 0.0, (std::f32::consts::PI / 16.0).sin(), (std::f32::consts::PI / 16.0).cos());
        assert!(close(sample_channel(&c, 0.25).unwrap(), e, 1e-6));
        // The second key stored as −q: the same rotation, so the shortest path is still 45°.
        let c =
            chan(AnimPath::Rotation, Interpolation::Linear, vec![0.0, 1.0], vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -h, -h]);
        let q = Quat::from_vec4(sample_channel(&c, 0.5).unwrap());
        assert!((q.angle_between(Quat::from_rotation_z(std::f32::consts::FRAC_PI_4))) < 1e-5);
    }

    #[test]
    fn cubic_spline_hits_keys_and_hermite_midpoint() {
        // Keys (in-tangent, value, out-tangent) per key, 1-D in x: v0 = 0, v1 = 1, out0 = 2,
        // in1 = 0, interval 2 s. Hermite at u = 1/2: 0.5·v0 + 0.125·dt·b0 + 0.5·v1 − 0.125·dt·a1
        // = 0 + 0.125·2·2 + 0.5 − 0 = 1.0.
        let values = vec![
            9.0, 9.0, 9.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, // key 0
            0.0, 0.0, 0.0, 1.0, 5.0, 7.0, 9.0, 9.0, 9.0, // key 1
        ];
        let c = chan(AnimPath::Translation, Interpolation::CubicSpline, vec![1.0, 3.0], values);
        assert!(close(sample_channel(&c, 1.0).unwrap(), Vec4::ZERO, 1e-6));
        assert!(close(sample_channel(&c, 3.0).unwrap(), Vec4::new(1.0, 5.0, 7.0, 0.0), 1e-6));
        assert!((sample_channel(&c, 2.0).unwrap().x - 1.0).abs() < 1e-6);
        // y: v0 = 0, v1 = 5, tangents 0 → smoothstep: 5 · (3u² − 2u³) at u = 0.5 = 2.5.
        assert!((sample_channel(&c, 2.0).unwrap().y - 2.5).abs() < 1e-6);
    }

    #[test]
    fn left_limits_differ_only_where_a_channel_jumps() {
        // STEP: just before key 1 the value of key 0, at key 1 its own.
        let c = chan(
            AnimPath::Scale,
            Interpolation::Step,
            vec![0.0, 1.0, 2.0],
            vec![1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 3.0, 3.0, 3.0],
        );
        assert_eq!(sample_channel_before(&c, 1.0).unwrap().x, 1.0);
        assert_eq!(sample_channel(&c, 1.0).unwrap().x, 2.0);
        assert_eq!(sample_channel_before(&c, 2.0).unwrap().x, 2.0);
        assert_eq!(sample_channel(&c, 2.0).unwrap().x, 3.0);
        // Inside a segment and at or before the first key (constant there): the same.
        assert_eq!(sample_channel_before(&c, 0.5), sample_channel(&c, 0.5));
        assert_eq!(sample_channel_before(&c, 0.0), sample_channel(&c, 0.0));
        assert_eq!(sample_channel_before(&c, -1.0), sample_channel(&c, -1.0));
        // After the last key: constant, so no jump to the left either.
        assert_eq!(sample_channel_before(&c, 2.5).unwrap().x, 3.0);
        // LINEAR: continuous at a key...
        let l = chan(
            AnimPath::Translation,
            Interpolation::Linear,
            vec![0.0, 1.0, 2.0],
            vec![0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        assert_eq!(sample_channel_before(&l, 1.0).unwrap().x, 4.0);
        assert_eq!(sample_channel(&l, 1.0).unwrap().x, 4.0);
        // ...but two keys at one time jump from the first to the second.
        let d = chan(
            AnimPath::Translation,
            Interpolation::Linear,
            vec![0.0, 1.0, 1.0, 2.0],
            vec![0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 8.0, 0.0, 0.0, 8.0, 0.0, 0.0],
        );
        assert_eq!(sample_channel_before(&d, 1.0).unwrap().x, 4.0);
        assert_eq!(sample_channel(&d, 1.0).unwrap().x, 8.0);
        assert!((sample_channel(&d, 0.5).unwrap().x - 2.0).abs() < 1e-6);
        // Hostile key times (NaN, unsorted) give some value, no panic.
        for times in [vec![f32::NAN, 1.0], vec![1.0, f32::NAN], vec![2.0, 1.0]] {
            let h = chan(AnimPath::Translation, Interpolation::Linear, times, vec![0.0; 6]);
            for t in [f32::NAN, -1.0, 0.5, 1.5, 3.0] {
                let _ = (sample_channel(&h, t), sample_channel_before(&h, t));
            }
        }
    }

    #[test]
    fn composition_order_lists_parents_first_and_cuts_cycles() {
        let node = |parent| Node {
            name: String::new(),
            parent,
            translation: [0.0; 3],
            rotation: [0.0, 0.0, 0.0, 1.0],
            scale: [1.0; 3],
        };
        // 0 → 2 → 1 (child lists its parent), 3 ⇄ 4 a cycle, 5's parent out of range.
        let s = Skeleton {
            nodes: vec![node(Some(2)), node(None), node(Some(1)), node(Some(4)), node(Some(3)), node(Some(99))],
            bones: vec![],
            animations: vec![],
        };
        let order = composition_order(&s, 6);
        assert_eq!(order.len(), 6);
        let pos = |n: usize| order.iter().position(|x| x.0 == n).unwrap();
        assert!(pos(1) < pos(2) && pos(2) < pos(0));
        assert_eq!(order[pos(0)].1, Some(2));
        assert_eq!(order[pos(1)].1, None);
        assert_eq!(order[pos(5)].1, None);
        // The cycle is cut once: one of 3, 4 is a root, the other its child.
        let (p3, p4) = (order[pos(3)].1, order[pos(4)].1);
        assert!((p3.is_none() && p4 == Some(3)) || (p4.is_none() && p3 == Some(4)), "{p3:?} {p4:?}");
    }

    fn two_bone_skeleton() -> Skeleton {
        // Node 1 (child) listed before its parent node 0... reversed: parent has the higher index.
        let nodes = vec![
            Node {
                name: "child".into(),
                parent: Some(1),
                translation: [0.0, 1.0, 0.0],
                rotation: [0.0, 0.0, 0.0, 1.0],
                scale: [1.0; 3],
            },
            Node {
                name: "root".into(),
                parent: None,
                translation: [5.0, 0.0, 0.0],
                rotation: [0.0, 0.0, 0.0, 1.0],
                scale: [2.0; 3],
            },
        ];
        let bones = vec![
            Bone {
                name: "root".into(),
                node: 1,
                parent: None,
                inverse_bind: Mat4::from_translation(Vec3::new(-5.0, 0.0, 0.0)),
            },
            Bone { name: "child".into(), node: 0, parent: Some(0), inverse_bind: Mat4::IDENTITY },
        ];
        Skeleton { nodes, bones, animations: vec![] }
    }

    #[test]
    fn world_matrices_compose_parent_first_regardless_of_order() {
        let s = two_bone_skeleton();
        let w = world_matrices(&s, &sample_local(&s, None, 0.0));
        // child world = T(5,0,0)·S(2)·T(0,1,0): origin → (5, 2, 0).
        assert!((w[0].transform_point3(Vec3::ZERO) - Vec3::new(5.0, 2.0, 0.0)).length() < 1e-6);
        let j = joint_matrices(&s, &w);
        // Bone 0: T(5)·S(2)·T(−5): (5,0,0) stays, (6,0,0) → (7,0,0).
        assert!((j[0].transform_point3(Vec3::new(6.0, 0.0, 0.0)) - Vec3::new(7.0, 0.0, 0.0)).length() < 1e-6);
    }

    #[test]
    fn lbs_blends_joint_matrices() {
        let mut s = two_bone_skeleton();
        s.animations.push(Animation {
            name: "a".into(),
            channels: vec![AnimChannel {
                node: 1,
                path: AnimPath::Translation,
                interpolation: Interpolation::Linear,
                times: vec![0.0, 1.0],
                values: vec![5.0, 0.0, 0.0, 7.0, 0.0, 0.0],
            }],
        });
        let mut inf = SkinInfluences::default();
        inf.joints[..2].copy_from_slice(&[0, 1]);
        inf.weights[..2].copy_from_slice(&[0.25, 0.75]);
        let skin = Skin {
            skeleton: s,
            influences: vec![inf, SkinInfluences::default()],
            bind_positions: vec![Vec3::ZERO, Vec3::ONE],
        };
        let w = world_matrices(&skin.skeleton, &sample_local(&skin.skeleton, Some(0), 0.5));
        let v = skin_vertices(&skin, &joint_matrices(&skin.skeleton, &w));
        // Root at (6,0,0), scale 2. Bone 0: p → 6 + 2(p − 5) = (−4, 0, 0); bone 1: child world
        // origin (6, 2, 0). Blend 0.25·(−4,0,0) + 0.75·(6,2,0) = (3.5, 1.5, 0).
        assert!((v[0] - Vec3::new(3.5, 1.5, 0.0)).length() < 1e-5, "{}", v[0]);
        // No influences: stays at its bind position.
        assert_eq!(v[1], Vec3::ONE);
    }
}
