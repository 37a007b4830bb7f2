//! `--pose-margin auto`: radii grown so that every skinned vertex lies inside the union of the
//! posed spheres at *every* time of every animation, not only at sampled ones.
//!
//! # What is proven
//!
//! For every animation `a` with key range `[t₀, t₁]` and every time `t` (times outside the range
//! give the pose at its nearest end, since every channel clamps), and for the rest pose: every
//! welded vertex `v(t)` (linear blend skinning of its bind position) has a sphere `s` with
//! `|v(t) − c_s(t)| ≤ r_s`, where `c_s(t) = Σ_j M_j(t) (q_j, b_j)` is the centre the runtime's
//! `pose` computes from the stored terms and `M_j(t)` the glTF joint matrices of the channels'
//! interpolants at `t` (LINEAR with slerp, STEP, CUBICSPLINE; `spherebake_geom::anim`). In exact
//! arithmetic; the f32 rounding of sampling and posing (≈ 1e-7 relative) is covered by growing
//! to `1 + 1e-5` times the needed radius. Exceptions are reported, never silent: frames whose
//! bound is not finite (non-finite keys) or that need a radius beyond f32 are counted in
//! `MarginResult::unbounded_frames`, and the bake warns.
//!
//! # How
//!
//! 1. Sample times per animation (`schedule`): every distinct key time of its channels, then
//!    intervals bisected (below) while their motion bound exceeds the tolerance
//!    `SkinSettings::margin_tolerance × bounding-box diagonal`.
//! 2. Between two consecutive sample times `τ_i < τ_{i+1}` with midpoint `μ`, the times of
//!    `[τ_i, μ]` are referred to the pose *at* `τ_i` and those of `[μ, τ_{i+1})` to the pose
//!    *just before* `τ_{i+1}` (the left limit: a STEP channel jumps only at its keys, so both
//!    sides of every key time are poses of their own; they are one frame where no channel jumps).
//!    Each frame is such a reference pose with the one or two half-windows it covers.
//! 3. For a frame, `spherebake_geom::motion` bounds per bone how far the joint transform can move
//!    over its windows: `‖ΔA_j‖₂ ≤ α_j`, `|Δt_j| ≤ β_j` for the world transform `W_j` of the
//!    bone's node (path lengths of the channels over the window, including CUBICSPLINE
//!    overshoot, composed down the node hierarchy; the derivation is in that module). Vertex and
//!    centre are both linear in the joint matrices `M_j = W_j B_j` (`B_j` the inverse bind):
//!
//!    ```text
//!    v(t) − c_s(t) = Σ_j M_j(t) x_j,   x_j = w_j (p, 1) − (q_j, b_j)   (xyz part)
//!    ```
//!
//!    over the bones of either (`w_j` the vertex's normalised weight or 0, `p` its bind
//!    position; `(q_j, b_j)` the sphere's term or 0; a vertex without weight stays at `p`, whose
//!    constant drops out of the change). With `B_j x_j = (z_j, h_j)` and
//!    `ΔM_j x_j = ΔA_j z_j + Δt_j h_j`, for any `t` of the windows:
//!
//!    ```text
//!    | |v(t) − c_s(t)| − |v(τ) − c_s(τ)| | ≤ |Δ(v − c_s)| ≤ D(v, s) = Σ_j α_j |z_j| + β_j |h_j|
//!    ```
//!
//!    so a vertex is covered over the whole window when some sphere has
//!    `|v(τ) − c_s(τ)| + D(v, s) ≤ r_s`. The pair bound sees their common motion: for a vertex
//!    and a centre carried by the same bones with the same weights, `h_j = 0` and `|z_j|` is
//!    about their distance, not the lever arm from the joint (`D(v, s) ≤ D_v + D_s`, the bounds
//!    of vertex and centre apart, always).
//! 4. Greedy growth as before, on that inflated distance: frames in order (rest, then per
//!    animation coarse to fine: the key times, then the midpoints of each refinement round; at a
//!    time the left limit first), a vertex no sphere covers grows the sphere whose ball volume
//!    grows least (`need³ − r³`), to `need × (1 + 1e-5)` rounded up to f32. Not minimal;
//!    deterministic. (In time order, a fine schedule let one sphere ratchet up by many small
//!    steps: on CesiumMan at tolerance 0.001 one sphere grew 4.6 cm, 2.4 % of the diagonal,
//!    instead of 0.9 cm coarse to fine.)
//!
//! Refinement: an interval's measure is the largest `D(v, s_v)` over its two halves, `s_v` the
//! sphere vertex `v` is deepest in at rest (bounded from above by grouping vertices with the
//! same bones and rest sphere, coefficient-wise largest terms). Rounds split every interval above
//! the tolerance at its midpoint (largest first while the budget lasts), in parallel; the bounds
//! are first order in the interval length, so a split about halves them. The measure only steers
//! where to sample: coverage rests on the pair bounds of step 3 for whichever sphere covers.
//!
//! # Cost and its bound
//!
//! Per animation at most `max_times_per_animation` (`C`) sample times: when the distinct key
//! times alone exceed `C`, `C` of them evenly spread are kept (windows then contain keys, whose
//! segments and jumps the bounds include) and nothing is split. Bisection stops at the budget, at
//! f32 resolution (an interval with no f32 time inside), or for a non-finite bound (splitting
//! cannot repair a NaN key). At the cap the bound of the unsplit intervals is used as it is —
//! coverage still holds, the margin is only larger than the tolerance; `capped_animations`
//! counts these. Frames with a non-finite bound (NaN or infinite keys) are checked at their
//! sample time only and counted in `unbounded_frames`.
//!
//! Work: per interval measure O(channels · log keys + nodes + bones + groups · (8 + k)), groups
//! at most the welded vertices; per frame O(welded vertices · 8 + spheres · k) to pose, and the
//! coverage check O(vertices · (8 + k)) when each vertex's previous covering sphere still covers
//! it, O(vertices · spheres · (8 + k)) at worst. At most `1 + 2 C × animations` frames. Once:
//! O(vertices · spheres) for the rest spheres. Memory: O(C) per animation for the schedule,
//! O(vertices · (8 + k)) for the pair terms, and frames posed in chunks of at most 64 and about
//! 2²⁰ / (vertices + spheres) sample times (≤ 50 MB of poses), never all frames at once.

use glam::{DMat4, DVec3, DVec4, Mat4};
use rayon::prelude::*;
use spherebake_format::quant::round_up_f32;
use spherebake_format::SkinTerms;
use spherebake_geom::anim::{self, Trs};
use spherebake_geom::motion::{self, AffineMotion};
use spherebake_geom::{Mesh, Skeleton};

use super::{bbox_diagonal, check_spheres, lbs_rows, pose_centre, welded_skin, SkinError, SkinSettings};
use spherebake_geom::mvc::SkinRow;

/// Result of [`grow_for_animations`]; also the bake report's `skin.pose_margin` (serialized
/// without the spheres and the absolute growth, `grown_count` as `grown_spheres`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MarginResult {
    /// The spheres with grown radii (centres unchanged), `[x, y, z, r]`.
    #[serde(skip)]
    pub spheres: Vec<[f32; 4]>,
    /// Poses checked: the rest pose and every frame of every animation (a sample time is two
    /// frames where a channel jumps there).
    pub frames: usize,
    #[serde(rename = "grown_spheres")]
    pub grown_count: usize,
    /// Largest radius increase, model units, and relative to the bounding-box diagonal.
    #[serde(skip)]
    pub max_growth: f64,
    pub max_growth_relative: f64,
    /// Largest pair bound `D(v, s)` a vertex's coverage relied on (the most that vertex–centre
    /// distance can change between a frame's sample time and a time the frame covers), relative
    /// to the bounding-box diagonal. About `margin_tolerance` (refinement steers by the rest
    /// spheres; a vertex covered by another sphere may rely on a larger bound).
    pub motion_bound_max_relative: f64,
    /// Animations whose refinement stopped at `max_times_per_animation` (or at f32 time
    /// resolution) with a bound above the tolerance: still covered, with a larger margin.
    pub capped_animations: usize,
    /// Frames whose motion bound is not finite (non-finite keys; checked at their sample time
    /// only, so coverage between is not proven there) or with a vertex no f32 radius reaches.
    pub unbounded_frames: usize,
    /// Before growing: minimum over the rest pose and the frames at key times of the share of
    /// skinned (welded) vertices inside the union of posed spheres.
    pub coverage_min_before: f64,
    /// Outside-volume ratio E of the rest-pose set before and after growing
    /// (`spherebake_fit::evaluate`, exact for closed meshes), when it could be measured.
    pub outside_ratio_before: Option<f64>,
    pub outside_ratio_after: Option<f64>,
}

/// Largest `max_times_per_animation`.
pub const MAX_TIMES_PER_ANIMATION: usize = 65_536;

/// One term of a pair bound: `(bone, c, h)`, adding `α_bone · c + β_bone · h`.
type Row = (usize, f64, f64);

/// Per welded vertex and sphere, the constant parts of the pair bound (module docs, step 3).
struct Slots {
    /// Per welded vertex, its bones (merged, in first-slot order): `(bone, normalised weight
    /// w_j, B_j (p, 1))`; empty for a vertex without weight (it stays at its bind position).
    vertex: Vec<Vec<(usize, f64, DVec4)>>,
    /// Per sphere, its used bones (merged): `(bone, B_j (q_j, b_j))`.
    sphere: Vec<Vec<(usize, DVec4)>>,
    /// Refinement rows (module docs, "Refinement"): per group of vertices with the same bones and
    /// rest sphere, the coefficient-wise largest `(bone, |z_j|, |h_j|)` over the group.
    groups: Vec<Vec<Row>>,
}

impl Slots {
    fn new(skel: &Skeleton, bind: &[DVec3], rows: &[SkinRow], terms: &SkinTerms, spheres: usize) -> Slots {
        let ib: Vec<DMat4> = skel.bones.iter().map(|b| b.inverse_bind.as_dmat4()).collect();
        let vertex = bind
            .iter()
            .zip(rows)
            .map(|(&p, row)| {
                // As lbs_rows: positive weights of joints in range, normalised over those; a bone
                // listed twice is one bone with the summed weight.
                let mut out: Vec<(usize, f64, DVec4)> = Vec::new();
                for &(j, s) in row {
                    let j = j as usize;
                    if s > 0.0 && j < ib.len() {
                        match out.iter_mut().find(|x| x.0 == j) {
                            Some(x) => x.1 += s,
                            None => out.push((j, s, ib[j] * p.extend(1.0))),
                        }
                    }
                }
                let w: f64 = out.iter().map(|x| x.1).sum();
                for x in &mut out {
                    x.1 /= w;
                }
                out
            })
            .collect();
        let sphere = (0..spheres)
            .map(|s| {
                let mut out: Vec<(usize, DVec4)> = Vec::new();
                for e in terms.of(s) {
                    let j = e.bone as usize;
                    if j >= ib.len() {
                        continue; // unused slot: the runtime reads the zero matrix
                    }
                    let y = ib[j] * glam::Vec3::from(e.q).as_dvec3().extend(f64::from(e.b));
                    match out.iter_mut().find(|x| x.0 == j) {
                        Some(x) => x.1 += y,
                        None => out.push((j, y)),
                    }
                }
                out
            })
            .collect();
        Slots { vertex, sphere, groups: Vec::new() }
    }

    /// The pair coefficients of vertex `v` and sphere `s`: per bone of either, `(bone, |z_j|,
    /// |h_j|)` with `(z_j, h_j) = w_j B_j (p, 1) − B_j (q_j, b_j)` (module docs, step 3).
    fn pair_rows(&self, v: usize, s: usize) -> Vec<Row> {
        let (vs, ss) = (&self.vertex[v], &self.sphere[s]);
        let mut out: Vec<Row> = vs
            .iter()
            .map(|&(j, w, p)| {
                let y = ss.iter().find(|x| x.0 == j).map_or(DVec4::ZERO, |x| x.1);
                coefficients(j, p * w - y)
            })
            .collect();
        out.extend(ss.iter().filter(|x| !vs.iter().any(|y| y.0 == x.0)).map(|&(j, y)| coefficients(j, -y)));
        out
    }

    /// The refinement rows, each vertex paired with its rest sphere `rest[v]` (`usize::MAX`:
    /// none; the vertex is left out).
    fn with_groups(mut self, rest: &[usize]) -> Slots {
        let mut groups: std::collections::BTreeMap<(Vec<usize>, usize), Vec<Row>> = std::collections::BTreeMap::new();
        for (v, &s) in rest.iter().enumerate() {
            if s >= self.sphere.len() {
                continue;
            }
            let mut rows = self.pair_rows(v, s);
            rows.sort_by_key(|x| x.0);
            let key = (rows.iter().map(|x| x.0).collect::<Vec<_>>(), s);
            let g = groups.entry(key).or_insert_with(|| rows.clone());
            for (a, b) in g.iter_mut().zip(&rows) {
                a.1 = a.1.max(b.1);
                a.2 = a.2.max(b.2);
            }
        }
        self.groups = groups.into_values().collect();
        self
    }
}

/// `(bone, |z|, |h|)` of a homogeneous `(z, h)`.
fn coefficients(j: usize, x: DVec4) -> Row {
    (j, x.truncate().length(), x.w.abs())
}

/// `Σ_j α_j c_j + β_j h_j` over `(bone, c, h)` rows (a bone without a motion bound: zero
/// motion); term for term what [`pair_bound`] computes from the slots.
fn rows_bound(rows: &[Row], m: &[AffineMotion]) -> f64 {
    rows.iter()
        .map(|&(j, c, h)| {
            let mj = m.get(j).copied().unwrap_or_default();
            mj.linear * c + mj.translation * h
        })
        .sum()
}

/// The pair bound `D(v, s)` of step 3: how far `|v(t) − c_s(t)|` can change over the frame's
/// windows, for per-bone motions `m`. Allocation-free.
fn pair_bound(vs: &[(usize, f64, DVec4)], ss: &[(usize, DVec4)], m: &[AffineMotion]) -> f64 {
    let term = |j: usize, x: DVec4| {
        let mj = m.get(j).copied().unwrap_or_default();
        mj.linear * x.truncate().length() + mj.translation * x.w.abs()
    };
    let mut sum = 0.0;
    for &(j, w, p) in vs {
        let y = ss.iter().find(|x| x.0 == j).map_or(DVec4::ZERO, |x| x.1);
        sum += term(j, p * w - y);
    }
    for &(j, y) in ss {
        if !vs.iter().any(|x| x.0 == j) {
            sum += term(j, -y);
        }
    }
    sum
}

/// The refinement measure of per-bone motions `m`: the largest pair bound of a vertex and its
/// rest sphere (an upper bound of it, by groups); +∞ when not finite.
fn criterion(slots: &Slots, m: &[AffineMotion]) -> f64 {
    let mut c: f64 = 0.0;
    for g in &slots.groups {
        let x = rows_bound(g, m);
        if !x.is_finite() {
            return f64::INFINITY;
        }
        c = c.max(x);
    }
    c
}

/// A frame's reference pose: local TRS and world matrices of every node.
struct Reference {
    locals: Vec<Trs>,
    worlds: Vec<Mat4>,
}

fn reference(skel: &Skeleton, a: usize, t: f32, before: bool) -> Reference {
    let locals =
        if before { anim::sample_local_before(skel, Some(a), t) } else { anim::sample_local(skel, Some(a), t) };
    let worlds = anim::world_matrices(skel, &locals);
    Reference { locals, worlds }
}

/// A half-window `[lo, hi]` (`closed`: `hi` included) referred to one pose.
#[derive(Clone, Copy, Debug)]
struct Window {
    lo: f32,
    hi: f32,
    closed: bool,
}

fn bone_motion(skel: &Skeleton, a: usize, w: Window, r: &Reference) -> Vec<AffineMotion> {
    let local = motion::local_motion(skel, a, w.lo, w.hi, w.closed);
    let world = motion::world_motion(skel, &r.locals, &r.worlds, &local);
    motion::bone_motion(skel, &world)
}

fn midpoint(lo: f32, hi: f32) -> f32 {
    ((f64::from(lo) + f64::from(hi)) * 0.5) as f32
}

/// Motion bound of the interval `[lo, hi]` between two sample times: the larger of its halves'.
fn interval_bound(skel: &Skeleton, a: usize, lo: f32, hi: f32, slots: &Slots) -> f64 {
    let mid = midpoint(lo, hi);
    let (first, second) = rayon::join(
        || {
            let r = reference(skel, a, lo, false);
            criterion(slots, &bone_motion(skel, a, Window { lo, hi: mid, closed: true }, &r))
        },
        || {
            let r = reference(skel, a, hi, true);
            criterion(slots, &bone_motion(skel, a, Window { lo: mid, hi, closed: false }, &r))
        },
    );
    first.max(second)
}

/// Sample times of animation `a` (module docs, "How" 1 and "Cost"): sorted, distinct, each with
/// its refinement level (0: a key time, `r`: added in round `r`); and whether refinement stopped
/// above the tolerance.
fn schedule(skel: &Skeleton, a: usize, slots: &Slots, tolerance: f64, cap: usize) -> (Vec<(f32, u32)>, bool) {
    let mut keys: Vec<f32> = skel.animations[a].channels.iter().flat_map(|c| c.times.iter().copied()).collect();
    keys.sort_by(f32::total_cmp);
    keys.dedup();
    if keys.is_empty() {
        return (vec![(0.0, 0)], false);
    }
    if keys.len() > cap {
        let n = keys.len();
        keys = (0..cap).map(|i| keys[i * (n - 1) / (cap - 1)]).collect();
    }
    // (lo, hi, bound) per interval between consecutive times.
    let mut intervals: Vec<(f32, f32, f64)> = keys
        .windows(2)
        .collect::<Vec<_>>()
        .par_iter()
        .map(|w| (w[0], w[1], interval_bound(skel, a, w[0], w[1], slots)))
        .collect();
    let mut times: Vec<(f32, u32)> = keys.iter().map(|&t| (t, 0)).collect();
    let mut round = 0;
    let splittable = |&(lo, hi, b): &(f32, f32, f64)| {
        let m = midpoint(lo, hi);
        b > tolerance && b.is_finite() && m > lo && m < hi
    };
    loop {
        let mut todo: Vec<usize> = (0..intervals.len()).filter(|&i| splittable(&intervals[i])).collect();
        let budget = cap.saturating_sub(times.len());
        if todo.is_empty() || budget == 0 {
            break;
        }
        // Largest bounds first (ties: earlier interval), as many as the budget allows.
        todo.sort_by(|&x, &y| intervals[y].2.total_cmp(&intervals[x].2).then(x.cmp(&y)));
        todo.truncate(budget);
        todo.sort_unstable();
        round += 1;
        let halves: Vec<[(f32, f32, f64); 2]> = todo
            .par_iter()
            .map(|&i| {
                let (lo, hi, _) = intervals[i];
                let m = midpoint(lo, hi);
                let (x, y) =
                    rayon::join(|| interval_bound(skel, a, lo, m, slots), || interval_bound(skel, a, m, hi, slots));
                [(lo, m, x), (m, hi, y)]
            })
            .collect();
        for (&i, h) in todo.iter().zip(&halves) {
            times.push((h[0].1, round));
            intervals[i] = h[0];
            intervals.push(h[1]);
        }
    }
    times.sort_by(|x, y| x.0.total_cmp(&y.0));
    intervals.sort_by(|x, y| x.0.total_cmp(&y.0));
    let capped = intervals.iter().any(|&(_, _, b)| b > tolerance && b.is_finite());
    (times, capped)
}

/// One pose to check, with the per-bone motion bounds of the windows it covers.
struct Frame {
    verts: Vec<DVec3>,
    centres: Vec<DVec3>,
    /// Per bone (empty for the rest pose: no motion).
    motion: Vec<AffineMotion>,
}

/// What posing a frame needs: the skeleton, the welded skin and the terms.
struct Ctx<'a> {
    skel: &'a Skeleton,
    bind: &'a [DVec3],
    rows: &'a [SkinRow],
    terms: &'a SkinTerms,
    spheres: usize,
}

impl Ctx<'_> {
    /// Poses the welded vertices and sphere centres at `r`, with per-bone motions `m`.
    fn frame(&self, r: &Reference, m: Vec<AffineMotion>) -> Frame {
        let jm: Vec<DMat4> = anim::joint_matrices(self.skel, &r.worlds).iter().map(Mat4::as_dmat4).collect();
        let verts = lbs_rows(self.bind, self.rows, &jm);
        let centres = (0..self.spheres).map(|s| pose_centre(self.terms.of(s), &jm)).collect();
        Frame { verts, centres, motion: m }
    }
}

/// The frames at sample time `times[i]` of animation `a`: the left limit (covering the second
/// half of the interval before) and the pose at the time (covering the first half of the
/// interval after), merged into one when they are the same pose.
fn frames_at(
    skel: &Skeleton,
    a: usize,
    times: &[f32],
    i: usize,
    make: impl Fn(&Reference, Vec<AffineMotion>) -> Frame,
) -> Vec<Frame> {
    let t = times[i];
    let left_w = (i > 0).then(|| Window { lo: midpoint(times[i - 1], t), hi: t, closed: false });
    let right_w = times.get(i + 1).map(|&u| Window { lo: t, hi: midpoint(t, u), closed: true });
    let right = reference(skel, a, t, false);
    let left = reference(skel, a, t, true);
    let zero = vec![AffineMotion::default(); skel.bones.len()];
    let motion_of = |w: Option<Window>, r: &Reference| w.map_or_else(|| zero.clone(), |w| bone_motion(skel, a, w, r));
    if left.locals == right.locals {
        let m: Vec<AffineMotion> =
            motion_of(left_w, &right).iter().zip(motion_of(right_w, &right)).map(|(x, y)| x.max(y)).collect();
        vec![make(&right, m)]
    } else {
        let ml = motion_of(left_w, &left);
        let mr = motion_of(right_w, &right);
        vec![make(&left, ml), make(&right, mr)]
    }
}

/// The greedy cover (module docs, step 4). Which vertices grow which sphere is decided in frame
/// and vertex order, as one sequential scan would; the search for a covering sphere (each
/// vertex's last one first) runs in parallel under the radii at the start of a frame, which
/// only grow during it.
struct Cover<'a> {
    original: &'a [[f32; 4]],
    slots: &'a Slots,
    radii: Vec<f32>,
    grown: Vec<bool>,
    last: Vec<usize>,
    /// Per vertex, [`Slots::pair_rows`] of it and `last[v]` (the pair bound without the merge).
    last_rows: Vec<Vec<Row>>,
    last_before: Vec<usize>,
    coverage_min_before: f64,
    motion_max: f64,
    unbounded_frames: usize,
    frames: usize,
}

impl Cover<'_> {
    fn set_last(&mut self, v: usize, s: usize) {
        if self.last[v] != s {
            self.last[v] = s;
            self.last_rows[v] = self.slots.pair_rows(v, s);
        }
    }

    /// Share of `f`'s vertices inside the union of the spheres as given (each vertex's last
    /// covering sphere first; parallel, ordered).
    fn measure_before(&mut self, f: &Frame) {
        let n = f.centres.len();
        let (original, last_before) = (self.original, &self.last_before);
        let before: Vec<Option<usize>> = f
            .verts
            .par_iter()
            .enumerate()
            .map(|(v, &p)| {
                let hit = |s: usize| p.distance(f.centres[s]) <= f64::from(original[s][3]);
                let l = last_before[v];
                if l < n && hit(l) {
                    Some(l)
                } else {
                    (0..n).find(|&s| hit(s))
                }
            })
            .collect();
        let mut inside = 0usize;
        for (slot, hit) in self.last_before.iter_mut().zip(&before) {
            if let Some(s) = *hit {
                *slot = s;
                inside += 1;
            }
        }
        if !f.verts.is_empty() {
            self.coverage_min_before = self.coverage_min_before.min(inside as f64 / f.verts.len() as f64);
        }
    }

    /// Visits frame `f`; `key`: a frame at a key time (or the rest pose), whose coverage by the
    /// radii as given is measured too.
    fn visit(&mut self, f: &Frame, key: bool) {
        self.frames += 1;
        let n = f.centres.len();
        if key {
            self.measure_before(f);
        }
        // A covering sphere per vertex under the radii at the start of the frame (parallel; the
        // last one first, then in index order; finite bounds only): radii only grow, so these
        // vertices are covered in the sequential pass too, and it need not look at them.
        let (radii, last, last_rows, slots) = (&self.radii, &self.last, &self.last_rows, self.slots);
        let pre: Vec<Option<(usize, f64)>> = f
            .verts
            .par_iter()
            .enumerate()
            .map(|(v, &p)| {
                let within = |s: usize| {
                    let d = p.distance(f.centres[s]);
                    let r = f64::from(radii[s]);
                    (d <= r).then_some((d, r))
                };
                let l = last[v];
                if let Some((d, r)) = (l < n).then(|| within(l)).flatten() {
                    let b = rows_bound(&last_rows[v], &f.motion);
                    if b.is_finite() && d + b <= r {
                        return Some((l, b));
                    }
                }
                (0..n).find_map(|s| {
                    let (d, r) = within(s)?;
                    let b = pair_bound(&slots.vertex[v], &slots.sphere[s], &f.motion);
                    (b.is_finite() && d + b <= r).then_some((s, b))
                })
            })
            .collect();
        let unbounded = std::cell::Cell::new(false);
        // `(|v(τ) − c_s(τ)| + D(v, s), D(v, s))`: a non-finite bound counts as 0 and marks the
        // frame.
        let need = |v: usize, s: usize, d: f64| {
            let b = pair_bound(&slots.vertex[v], &slots.sphere[s], &f.motion);
            if b.is_finite() {
                (d + b, b)
            } else {
                unbounded.set(true);
                (d, 0.0)
            }
        };
        for (v, &p) in f.verts.iter().enumerate() {
            if let Some((s, b)) = pre[v] {
                self.set_last(v, s);
                self.motion_max = self.motion_max.max(b);
                continue;
            }
            // Sphere s covers v over the windows if |v − c_s| + D(v, s) ≤ r_s; only spheres with
            // |v − c_s| ≤ r_s can (D ≥ 0), so the bound is computed for those alone.
            let radii = &self.radii;
            let covers = |s: usize| {
                let d = p.distance(f.centres[s]);
                let r = f64::from(radii[s]);
                if d > r {
                    return None;
                }
                let (x, b) = need(v, s, d);
                (x <= r).then_some(b)
            };
            let l = self.last[v];
            let hit = if l < n { covers(l).map(|b| (l, b)) } else { None };
            let hit = hit.or_else(|| (0..n).find_map(|s| covers(s).map(|b| (s, b))));
            if let Some((s, b)) = hit {
                self.set_last(v, s);
                self.motion_max = self.motion_max.max(b);
                continue;
            }
            // Uncovered: grow the sphere whose ball volume grows least (∝ need³ − r³: growing a
            // small sphere a little costs less than growing a large one by the same length).
            let mut best = (f64::INFINITY, usize::MAX, 0.0, 0.0);
            for (s, c) in f.centres.iter().enumerate() {
                let (x, b) = need(v, s, p.distance(*c));
                let r = f64::from(self.radii[s]);
                let cost = x * x * x - r * r * r;
                if cost < best.0 {
                    best = (cost, s, x, b);
                }
            }
            let (_, s, x, b) = best;
            if s == usize::MAX {
                continue; // a non-finite pose: nothing to cover it with
            }
            let r = round_up_f32(x * (1.0 + 1e-5));
            if r.is_finite() {
                self.radii[s] = r;
                self.grown[s] = true;
                self.set_last(v, s);
                self.motion_max = self.motion_max.max(b);
            } else {
                unbounded.set(true); // a radius beyond f32: this vertex cannot be covered
            }
        }
        let unbounded = unbounded.get();
        self.unbounded_frames += usize::from(unbounded);
    }
}

/// `--pose-margin auto`: grows radii as little as the greedy finds so that every skinned (welded)
/// vertex lies inside the union of the posed spheres at every time of every animation of the
/// model and at rest (module docs: what is proven, how, and the cost bound). Centres are posed
/// from the stored f32 terms, as the runtime does.
///
/// Only vertices are checked: a triangle between covered vertices can still poke out of the
/// union by its sagitta.
///
/// Parallel over intervals and frames, deterministic for any thread count (ordered collects, the
/// greedy runs in frame order).
///
/// # Errors
///
/// Invalid spheres or settings, inconsistent skin arrays, `terms` not matching `spheres`, or an
/// animation channel whose key times are not finite and non-decreasing.
pub fn grow_for_animations(
    mesh: &Mesh,
    spheres: &[[f32; 4]],
    terms: &SkinTerms,
    settings: &SkinSettings,
) -> Result<MarginResult, SkinError> {
    check_spheres(spheres)?;
    let tol_rel = settings.margin_tolerance;
    if !(tol_rel.is_finite() && tol_rel > 0.0 && tol_rel <= 1.0) {
        return Err(SkinError::MarginTolerance { value: tol_rel });
    }
    let cap = settings.max_times_per_animation;
    if !(2..=MAX_TIMES_PER_ANIMATION).contains(&cap) {
        return Err(SkinError::TimesPerAnimation { value: cap, max: MAX_TIMES_PER_ANIMATION });
    }
    let k = terms.bones_per_sphere as usize;
    if k == 0 || terms.entries.len() != spheres.len() * k {
        return Err(SkinError::TermCount { expected: spheres.len(), actual: terms.entries.len() / k.max(1) });
    }
    let Some(skin) = mesh.skin.as_ref() else {
        return Ok(MarginResult {
            spheres: spheres.to_vec(),
            frames: 0,
            grown_count: 0,
            max_growth: 0.0,
            max_growth_relative: 0.0,
            motion_bound_max_relative: 0.0,
            capped_animations: 0,
            unbounded_frames: 0,
            coverage_min_before: 1.0,
            outside_ratio_before: None,
            outside_ratio_after: None,
        });
    };
    let skel = &skin.skeleton;
    for (a, an) in skel.animations.iter().enumerate() {
        for (c, ch) in an.channels.iter().enumerate() {
            if ch.times.iter().any(|t| !t.is_finite()) || ch.times.windows(2).any(|w| w[1] < w[0]) {
                return Err(SkinError::AnimationKeys { animation: a, channel: c });
            }
        }
    }
    let ws = welded_skin(mesh, skin)?;
    let diag = bbox_diagonal(&ws.positions);
    let tolerance = tol_rel * diag;
    let n = spheres.len();
    let nv = ws.bind.len();
    let ctx = Ctx { skel, bind: &ws.bind, rows: &ws.rows, terms, spheres: n };
    // The rest pose, and each vertex's rest sphere for the refinement rows: the one it is
    // deepest inside (or nearest outside), relative to the radius.
    let rest_locals = anim::sample_local(skel, None, 0.0);
    let rest =
        ctx.frame(&Reference { worlds: anim::world_matrices(skel, &rest_locals), locals: rest_locals }, Vec::new());
    let rest_sphere: Vec<usize> = rest
        .verts
        .par_iter()
        .map(|p| {
            let mut best = (f64::INFINITY, usize::MAX);
            for (s, c) in rest.centres.iter().enumerate() {
                let e = p.distance(*c) - f64::from(spheres[s][3]);
                if e < best.0 {
                    best = (e, s);
                }
            }
            best.1
        })
        .collect();
    let slots = Slots::new(skel, &ws.bind, &ws.rows, terms, n).with_groups(&rest_sphere);
    let mut cover = Cover {
        original: spheres,
        slots: &slots,
        radii: spheres.iter().map(|s| s[3]).collect(),
        grown: vec![false; n],
        last_rows: rest_sphere
            .par_iter()
            .enumerate()
            .map(|(v, &s)| if s < n { slots.pair_rows(v, s) } else { Vec::new() })
            .collect(),
        last: rest_sphere.clone(),
        last_before: rest_sphere,
        coverage_min_before: 1.0,
        motion_max: 0.0,
        unbounded_frames: 0,
        frames: 0,
    };
    cover.visit(&rest, true);
    let mut capped_animations = 0;
    // Sample times per chunk posed at once: bounds the memory of posed frames.
    let chunk = ((1usize << 20) / (nv + n + 1)).clamp(1, 64);
    for a in 0..skel.animations.len() {
        let (sched, capped) = schedule(skel, a, &slots, tolerance, cap);
        capped_animations += usize::from(capped);
        let times: Vec<f32> = sched.iter().map(|x| x.0).collect();
        // Coarse to fine: the key times first, then each refinement round's midpoints. The
        // greedy then meets the extreme poses early and later frames need small corrections,
        // instead of one sphere ratcheting up by many small steps.
        let mut order: Vec<usize> = (0..times.len()).collect();
        order.sort_by_key(|&i| (sched[i].1, i));
        for part in order.chunks(chunk) {
            let posed: Vec<Vec<Frame>> =
                part.par_iter().map(|&i| frames_at(skel, a, &times, i, |r, m| ctx.frame(r, m))).collect();
            for (&i, frames) in part.iter().zip(&posed) {
                for f in frames {
                    cover.visit(f, sched[i].1 == 0);
                }
            }
        }
    }
    let out: Vec<[f32; 4]> = spheres.iter().zip(&cover.radii).map(|(s, &r)| [s[0], s[1], s[2], r]).collect();
    let max_growth = out.iter().zip(spheres).map(|(a, b)| f64::from(a[3]) - f64::from(b[3])).fold(0.0, f64::max);
    // Measured as the bake measures its E: on the triangles turned outward.
    let (outward, surface_only) = crate::outward_triangles(mesh);
    let eval = |set: &[[f32; 4]]| {
        let es = spherebake_fit::EvalSettings { surface_samples: 2000, ..Default::default() };
        spherebake_fit::evaluate_with_surface(&mesh.welded_positions, &outward, &surface_only, set, &es)
            .ok()
            .map(|e| e.outside_ratio_e)
    };
    let grown_count = cover.grown.iter().filter(|&&g| g).count();
    let outside_ratio_before = eval(spheres);
    let outside_ratio_after = if grown_count == 0 { outside_ratio_before } else { eval(&out) };
    let rel = |x: f64| if diag > 0.0 { x / diag } else { 0.0 };
    Ok(MarginResult {
        spheres: out,
        frames: cover.frames,
        grown_count,
        max_growth,
        max_growth_relative: rel(max_growth),
        motion_bound_max_relative: rel(cover.motion_max),
        capped_animations,
        unbounded_frames: cover.unbounded_frames,
        coverage_min_before: cover.coverage_min_before,
        outside_ratio_before,
        outside_ratio_after,
    })
}
