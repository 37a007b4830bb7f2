//! Skinning stage: mean value coordinates of every sphere centre on the welded rest mesh, folded
//! with the skin weights into per-bone homogeneous terms (math reference §7), truncated to the `k`
//! largest bones; plus the optional `--pose-margin auto` radius growth ([`margin`]: every
//! vertex covered at every time of every animation, with the proof in its docs).
//!
//! Spaces: sphere centres and [`Mesh::positions`] are the rest pose in model (scene) space; the
//! stored terms `(q_j, b_j)` are in the skin's bind (mesh) space, so the runtime poses a centre as
//! `Σ_j M_j (q_j, b_j)` with glTF joint matrices `M_j = world(joint) × inverse_bind`.
//!
//! Weld: MVC run on [`Mesh::welded_positions`]; a welded vertex takes the bind position and skin
//! influences of the *first* mesh vertex with that weld id (seam copies of a vertex carry the
//! same skin data in every model we know; where they differ, the choice is this fixed one).

use glam::{DMat4, DVec3, Mat4, Vec3};
use rayon::prelude::*;
use spherebake_format::{BoneRecord, SkinEntry, SkinTerms, UNUSED_BONE};
use spherebake_geom::anim;
use spherebake_geom::mvc::{self, BoneTerm, MvcError, MvcLocation, SkinRow};
use spherebake_geom::{Mesh, Skeleton};

pub mod margin;
pub use margin::{grow_for_animations, MarginResult};

/// Largest `bones_per_sphere` the format stores.
pub const MAX_BONES_PER_SPHERE: usize = 64;

/// Radius growth so that animated poses stay covered.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
#[non_exhaustive]
pub enum PoseMargin {
    /// Radii as fitted (bounding at rest only). Default.
    #[default]
    None,
    /// Grow radii so that every skinned vertex is inside the union of posed spheres at every
    /// time of every animation of the model, between sampled times too
    /// ([`grow_for_animations`]).
    Auto,
}

/// Settings of the skinning stage.
#[derive(Clone, Debug, PartialEq)]
pub struct SkinSettings {
    /// Bones kept per sphere, `k` (default 4, range 1..=64; larger than the bone count keeps
    /// every bone, and then 64 bones at most).
    pub bones_per_sphere: usize,
    /// `--pose-margin` (default [`PoseMargin::None`]).
    pub pose_margin: PoseMargin,
    /// [`PoseMargin::Auto`]: largest motion bound left between sample times, relative to the
    /// bounding-box diagonal (default 0.002, range (0, 1]). Intervals between key times are
    /// bisected until the most any vertex–sphere distance can change within one is at most this;
    /// the radii grow by up to that much beyond what the sampled poses need ([`margin`]).
    pub margin_tolerance: f64,
    /// [`PoseMargin::Auto`]: most sample times per animation (default 4096, range
    /// 2..=[`margin::MAX_TIMES_PER_ANIMATION`]); at the cap the unsplit intervals keep their
    /// larger (still covering) bounds.
    pub max_times_per_animation: usize,
}

impl Default for SkinSettings {
    fn default() -> Self {
        Self {
            bones_per_sphere: 4,
            pose_margin: PoseMargin::None,
            margin_tolerance: 0.002,
            max_times_per_animation: 4096,
        }
    }
}

/// What the skinning stage measured.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SkinStats {
    pub sphere_count: usize,
    pub bone_count: usize,
    /// Slots per sphere written (`min(bones_per_sphere, bone_count)`).
    pub bones_per_sphere: usize,
    /// Whether the welded mesh is closed (every edge shared by exactly two triangles); MVC has
    /// linear precision only then.
    pub closed: bool,
    /// max and mean over spheres of `|Σ_v λ_v v − c|`, model units (rounding only on closed
    /// meshes). The remainder is carried by the kept bones, so rest centres stay exact anyway.
    pub linear_residual_max: f64,
    pub linear_residual_mean: f64,
    /// `linear_residual_max` / bounding-box diagonal.
    pub linear_residual_max_relative: f64,
    /// Centres on the surface (snapped to a vertex or face).
    pub centres_on_surface: usize,
    /// Per sphere, `Σ_{j∉K} |b_j|`: weight of the dropped bones; max and mean.
    pub dropped_weight_max: f64,
    pub dropped_weight_mean: f64,
    /// Spheres whose remainder could not be redistributed (no kept bone with an invertible rest
    /// joint matrix); their rest centre is off by the remainder.
    pub remainder_dropped: usize,
    /// Degenerate triangles skipped by MVC (per sphere count, max).
    pub degenerate_triangles: usize,
    /// Centres whose MVC could not be normalised (raw weights summing to about 0: a rest pose
    /// that folds the mesh onto itself, or a point far outside an open mesh) or only into
    /// weights that nearly cancel (Σ |λ| above `MAX_WEIGHT_SUM`), which took the
    /// weights of their nearest surface point instead ([`mvc::nearest_surface_weights`]); the
    /// kept bones carry the offset to it, so their rest centres stay exact.
    pub nearest_surface: usize,
    /// Seconds spent.
    pub seconds: f64,
}

/// Why the skinning stage failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SkinError {
    #[error("bones per sphere is {value}, expected 1..={max}")]
    BonesPerSphere { value: usize, max: usize },
    #[error("bones per sphere {bones_per_sphere} with a {bone_count}-bone skin needs {} slots per sphere, the format stores at most {max}", bones_per_sphere.min(bone_count))]
    TooManyBones { bones_per_sphere: usize, bone_count: usize, max: usize },
    #[error("pose margin tolerance is {value}, expected a number in (0, 1]")]
    MarginTolerance { value: f64 },
    #[error("pose margin times per animation is {value}, expected 2..={max}")]
    TimesPerAnimation { value: usize, max: usize },
    #[error("animation {animation}, channel {channel}: key times are not finite and non-decreasing")]
    AnimationKeys { animation: usize, channel: usize },
    #[error("sphere {index} is not finite or has a negative radius")]
    InvalidSphere { index: usize },
    #[error("skin {what} has {actual} entries, expected {expected} (one per vertex)")]
    SkinLength { what: &'static str, expected: usize, actual: usize },
    #[error("mesh weld has {actual} entries, expected {expected}; welded id {id} out of range")]
    Weld { expected: usize, actual: usize, id: u32 },
    #[error("mean value coordinates of sphere {sphere}: {source}")]
    Mvc { sphere: usize, source: MvcError },
    #[error("sphere {sphere}: skin term of bone {bone} is not finite in f32")]
    NonFiniteTerm { sphere: usize, bone: u32 },
    #[error("skin terms hold {actual} spheres, expected {expected}")]
    TermCount { expected: usize, actual: usize },
}

/// Per welded vertex: bind position (f64) and normalised skin row, taken from the first mesh
/// vertex of each weld id.
struct WeldedSkin {
    positions: Vec<DVec3>,
    bind: Vec<DVec3>,
    rows: Vec<SkinRow>,
    triangles: Vec<[u32; 3]>,
}

fn welded_skin(mesh: &Mesh, skin: &spherebake_geom::Skin) -> Result<WeldedSkin, SkinError> {
    let n = mesh.positions.len();
    if skin.influences.len() != n {
        return Err(SkinError::SkinLength { what: "influences", expected: n, actual: skin.influences.len() });
    }
    if skin.bind_positions.len() != n {
        return Err(SkinError::SkinLength { what: "bind_positions", expected: n, actual: skin.bind_positions.len() });
    }
    let wn = mesh.welded_positions.len();
    if mesh.weld.len() != n {
        return Err(SkinError::Weld { expected: n, actual: mesh.weld.len(), id: 0 });
    }
    let mut first = vec![u32::MAX; wn];
    for (v, &id) in mesh.weld.iter().enumerate() {
        let slot = first.get_mut(id as usize).ok_or(SkinError::Weld { expected: n, actual: n, id })?;
        if *slot == u32::MAX {
            *slot = v as u32;
        }
    }
    let mut bind = Vec::with_capacity(wn);
    let mut rows = Vec::with_capacity(wn);
    for &v in &first {
        if v == u32::MAX {
            bind.push(DVec3::ZERO);
            rows.push([(0, 0.0); 8]);
            continue;
        }
        let inf = &skin.influences[v as usize];
        let sum: f64 = inf.weights.iter().map(|&w| f64::from(w.max(0.0))).sum();
        let mut row: SkinRow = [(0, 0.0); 8];
        if sum > 0.0 && sum.is_finite() {
            for (k, slot) in row.iter_mut().enumerate() {
                *slot = (inf.joints[k], f64::from(inf.weights[k].max(0.0)) / sum);
            }
        }
        rows.push(row);
        bind.push(skin.bind_positions[v as usize].as_dvec3());
    }
    Ok(WeldedSkin {
        positions: mesh.welded_positions.iter().map(|p| p.as_dvec3()).collect(),
        bind,
        rows,
        triangles: mesh.welded_triangles(),
    })
}

/// Joint matrices of the rest pose (every node at its rest TRS), f64.
#[must_use]
pub fn rest_joint_matrices(skel: &Skeleton) -> Vec<DMat4> {
    let locals = anim::sample_local(skel, None, 0.0);
    let worlds = anim::world_matrices(skel, &locals);
    anim::joint_matrices(skel, &worlds).iter().map(Mat4::as_dmat4).collect()
}

/// The bone table of the format from the skeleton (names, parents, column-major inverse binds).
#[must_use]
pub fn bone_records(skel: &Skeleton) -> Vec<BoneRecord> {
    skel.bones
        .iter()
        .map(|b| BoneRecord { name: b.name.clone(), parent: b.parent, inverse_bind: b.inverse_bind.to_cols_array() })
        .collect()
}

fn check_spheres(spheres: &[[f32; 4]]) -> Result<(), SkinError> {
    for (i, s) in spheres.iter().enumerate() {
        if !s.iter().all(|x| x.is_finite()) || s[3] < 0.0 {
            return Err(SkinError::InvalidSphere { index: i });
        }
    }
    Ok(())
}

fn is_closed(triangles: &[[u32; 3]]) -> bool {
    let mut edges: Vec<(u32, u32)> = Vec::with_capacity(triangles.len() * 3);
    for t in triangles {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            continue;
        }
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            edges.push((a.min(b), a.max(b)));
        }
    }
    edges.sort_unstable();
    let mut i = 0;
    while i < edges.len() {
        let mut j = i;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        if j - i != 2 {
            return false;
        }
        i = j;
    }
    !edges.is_empty()
}

fn bbox_diagonal(p: &[DVec3]) -> f64 {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for &v in p {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if p.is_empty() {
        0.0
    } else {
        (hi - lo).length()
    }
}

/// The largest Σ |λ_v| of a centre's normalised mean value coordinates the bake keeps. Beyond
/// it the raw weights nearly cancel (a stored pose that folds the mesh onto itself: the folded
/// arm of `tests/skin_fixture.rs` gave terms of 10¹¹), the f32 terms would lose the centre, and
/// the centre takes its nearest surface point's weights instead. The shared skinned models'
/// centres reach at most 3.8 (CesiumMan, the Fox, RiggedFigure, RiggedSimple and the arm at 16,
/// 64 and 256 spheres); 1 inside a convex mesh.
const MAX_WEIGHT_SUM: f64 = 64.0;

/// Bakes the skin section: per sphere the `k` bones of largest `|b_j|` with their terms
/// (see [`spherebake_geom::mvc::truncate_terms`]), and the bone table. `spheres` are
/// `[x, y, z, radius]`, rest pose, model space. `Ok(None)` when the mesh has no skin (or a skin
/// without bones): the file then has no skin section. `settings.pose_margin` is not applied here:
/// call [`grow_for_animations`] with the result.
///
/// Parallel over spheres, deterministic (ordered collect; each sphere's sums run in vertex order).
///
/// # Errors
///
/// Invalid settings or spheres, inconsistent skin arrays, or a centre whose MVC cannot be
/// normalised.
pub fn bake_skin(
    mesh: &Mesh,
    spheres: &[[f32; 4]],
    settings: &SkinSettings,
) -> Result<Option<(SkinTerms, Vec<BoneRecord>, SkinStats)>, SkinError> {
    let t0 = std::time::Instant::now();
    if settings.bones_per_sphere == 0 {
        return Err(SkinError::BonesPerSphere { value: 0, max: MAX_BONES_PER_SPHERE });
    }
    check_spheres(spheres)?;
    let Some(skin) = mesh.skin.as_ref() else { return Ok(None) };
    let bone_count = skin.skeleton.bones.len();
    if bone_count == 0 {
        return Ok(None);
    }
    // Larger than the bone count keeps every bone; the format stores at most 64 slots.
    let k = settings.bones_per_sphere.min(bone_count);
    if k > MAX_BONES_PER_SPHERE {
        return Err(SkinError::TooManyBones {
            bones_per_sphere: settings.bones_per_sphere,
            bone_count,
            max: MAX_BONES_PER_SPHERE,
        });
    }
    let ws = welded_skin(mesh, skin)?;
    let rest = rest_joint_matrices(&skin.skeleton);
    struct PerSphere {
        terms: Vec<BoneTerm>,
        residual: f64,
        on_surface: bool,
        dropped: f64,
        remainder_dropped: bool,
        degenerate: usize,
        nearest: bool,
    }
    let per: Vec<Result<PerSphere, SkinError>> = spheres
        .par_iter()
        .enumerate()
        .map(|(i, s)| {
            let c = DVec3::new(f64::from(s[0]), f64::from(s[1]), f64::from(s[2]));
            // A centre whose MVC cannot be normalised, or only into weights that cancel
            // (`MAX_WEIGHT_SUM`), takes its nearest surface point's weights.
            let ill = |m: &mvc::Mvc| m.weights.iter().map(|w| w.abs()).sum::<f64>() > MAX_WEIGHT_SUM;
            let (m, nearest) = match mvc::mean_value_coordinates(c, &ws.positions, &ws.triangles) {
                Ok(m) if !ill(&m) => (m, false),
                Ok(mvc::Mvc { raw_sum: sum, .. }) | Err(MvcError::DegenerateSum { sum }) => {
                    let (weights, distance) = mvc::nearest_surface_weights(c, &ws.positions, &ws.triangles)
                        .ok_or(SkinError::Mvc { sphere: i, source: MvcError::DegenerateSum { sum } })?;
                    let m = mvc::Mvc {
                        weights,
                        raw_sum: sum,
                        linear_residual: distance,
                        location: MvcLocation::OffSurface,
                        degenerate_triangles: 0,
                    };
                    (m, true)
                }
                Err(source) => return Err(SkinError::Mvc { sphere: i, source }),
            };
            let full = mvc::fold_into_bones(&m.weights, &ws.bind, &ws.rows, bone_count);
            let kept_idx = mvc::largest_terms(&full, k);
            let dropped: f64 =
                full.iter().enumerate().filter(|(j, _)| !kept_idx.contains(j)).map(|(_, t)| t.b.abs()).sum();
            let tr = mvc::truncate_terms(&full, k, c, &rest);
            Ok(PerSphere {
                terms: tr.terms,
                residual: m.linear_residual,
                on_surface: m.location != MvcLocation::OffSurface,
                dropped,
                remainder_dropped: tr.remainder_dropped,
                degenerate: m.degenerate_triangles,
                nearest,
            })
        })
        .collect();
    let mut entries = Vec::with_capacity(spheres.len() * k);
    let diag = bbox_diagonal(&ws.positions);
    let mut stats = SkinStats {
        sphere_count: spheres.len(),
        bone_count,
        bones_per_sphere: k,
        closed: is_closed(&ws.triangles),
        linear_residual_max: 0.0,
        linear_residual_mean: 0.0,
        linear_residual_max_relative: 0.0,
        centres_on_surface: 0,
        dropped_weight_max: 0.0,
        dropped_weight_mean: 0.0,
        remainder_dropped: 0,
        degenerate_triangles: 0,
        nearest_surface: 0,
        seconds: 0.0,
    };
    for (i, r) in per.into_iter().enumerate() {
        let p = r?;
        for t in &p.terms {
            let q = t.q.as_vec3();
            let b = t.b as f32;
            if !q.is_finite() || !b.is_finite() {
                return Err(SkinError::NonFiniteTerm { sphere: i, bone: t.bone });
            }
            entries.push(SkinEntry { bone: t.bone, q: q.to_array(), b });
        }
        entries.extend((p.terms.len()..k).map(|_| SkinEntry { bone: UNUSED_BONE, q: [0.0; 3], b: 0.0 }));
        stats.linear_residual_max = stats.linear_residual_max.max(p.residual);
        stats.linear_residual_mean += p.residual;
        stats.centres_on_surface += usize::from(p.on_surface);
        stats.dropped_weight_max = stats.dropped_weight_max.max(p.dropped);
        stats.dropped_weight_mean += p.dropped;
        stats.remainder_dropped += usize::from(p.remainder_dropped);
        stats.degenerate_triangles = stats.degenerate_triangles.max(p.degenerate);
        stats.nearest_surface += usize::from(p.nearest);
    }
    let n = spheres.len().max(1) as f64;
    stats.linear_residual_mean /= n;
    stats.dropped_weight_mean /= n;
    stats.linear_residual_max_relative = if diag > 0.0 { stats.linear_residual_max / diag } else { 0.0 };
    stats.seconds = t0.elapsed().as_secs_f64();
    Ok(Some((SkinTerms { bones_per_sphere: k as u32, entries }, bone_records(&skin.skeleton), stats)))
}

/// Posed centre of one sphere from its stored (f32) slots, in f64: `Σ_j M_j (q_j, b_j)`.
#[must_use]
pub fn pose_centre(slots: &[SkinEntry], joints: &[DMat4]) -> DVec3 {
    let mut acc = DVec3::ZERO;
    for e in slots {
        if let Some(m) = joints.get(e.bone as usize) {
            acc += m.transform_vector3(Vec3::from(e.q).as_dvec3()) + m.w_axis.truncate() * f64::from(e.b);
        }
    }
    acc
}

/// `(animation index, time in seconds)` of `samples` evenly spaced times over each animation's
/// key range (first to last key over all its channels), both ends included (one sample: the
/// start). For measurements and tests; [`grow_for_animations`] samples by [`margin`]'s schedule.
#[must_use]
pub fn animation_frames(skel: &Skeleton, samples: usize) -> Vec<(usize, f32)> {
    let mut out = Vec::new();
    for (a, anim) in skel.animations.iter().enumerate() {
        let (mut t0, mut t1) = (f32::INFINITY, f32::NEG_INFINITY);
        for ch in &anim.channels {
            if let (Some(&f), Some(&l)) = (ch.times.first(), ch.times.last()) {
                t0 = t0.min(f);
                t1 = t1.max(l);
            }
        }
        if !t0.is_finite() {
            (t0, t1) = (0.0, 0.0);
        }
        for i in 0..samples {
            let u = if samples > 1 { i as f64 / (samples - 1) as f64 } else { 0.0 };
            out.push((a, (f64::from(t0) + (f64::from(t1) - f64::from(t0)) * u) as f32));
        }
    }
    out
}

/// Joint matrices (f64) of animation `anim` at `time_s`.
#[must_use]
pub fn animation_joint_matrices(skel: &Skeleton, anim: Option<usize>, time_s: f32) -> Vec<Mat4> {
    let locals = anim::sample_local(skel, anim, time_s);
    let worlds = anim::world_matrices(skel, &locals);
    anim::joint_matrices(skel, &worlds)
}

/// Share (0..=1) of `points` inside the union of `spheres` (`[x, y, z, r]`, distance ≤ r in f64).
#[must_use]
pub fn union_coverage(points: &[DVec3], spheres: &[[f64; 4]]) -> f64 {
    if points.is_empty() {
        return 1.0;
    }
    let inside = points
        .par_chunks(1024)
        .map(|ch| {
            ch.iter()
                .filter(|p| spheres.iter().any(|s| p.distance_squared(DVec3::new(s[0], s[1], s[2])) <= s[3] * s[3]))
                .count()
        })
        .collect::<Vec<usize>>()
        .iter()
        .sum::<usize>();
    inside as f64 / points.len() as f64
}

/// Linear blend skinning of welded vertices (rows already normalised; a row without weight keeps
/// its bind position, as `anim::skin_vertices` does).
fn lbs_rows(bind: &[DVec3], rows: &[SkinRow], joints: &[DMat4]) -> Vec<DVec3> {
    bind.iter()
        .zip(rows)
        .map(|(&p, row)| {
            let mut acc = DVec3::ZERO;
            let mut w = 0.0;
            for &(j, s) in row {
                if s > 0.0 {
                    if let Some(m) = joints.get(j as usize) {
                        acc += m.transform_point3(p) * s;
                        w += s;
                    }
                }
            }
            if w > 0.0 {
                acc / w
            } else {
                p
            }
        })
        .collect()
}

/// Skinned welded vertices (first vertex of each weld id) at the given joint matrices, for
/// coverage checks.
///
/// # Errors
///
/// Inconsistent skin arrays. A mesh without skin gives its welded rest positions.
pub fn posed_welded_vertices(mesh: &Mesh, joints: &[Mat4]) -> Result<Vec<DVec3>, SkinError> {
    let Some(skin) = mesh.skin.as_ref() else {
        return Ok(mesh.welded_positions.iter().map(|p| p.as_dvec3()).collect());
    };
    let ws = welded_skin(mesh, skin)?;
    let jm: Vec<DMat4> = joints.iter().map(Mat4::as_dmat4).collect();
    Ok(lbs_rows(&ws.bind, &ws.rows, &jm))
}
