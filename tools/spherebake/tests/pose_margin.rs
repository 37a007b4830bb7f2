//! `--pose-margin auto` covers every vertex at every time of each animation, not only at sampled
//! ones. Checked at many times strictly between key times (incommensurate with the keys), with
//! the sphere centres posed by the runtime crate (`spherebake_runtime::pose`, f32, from the
//! stored terms and the f32 joint matrices an engine would pass) and the vertices skinned by
//! `anim::skin_vertices`:
//! - CesiumMan baked by the CLI at 64 spheres (`../shared/models`; skips visibly when absent,
//!   fails with `SPHEREBAKE_REQUIRE_MODELS=1`);
//! - a synthetic two-bone bar whose second bone turns 170° between two LINEAR keys: spheres that
//!   cover both key poses (checked here) miss the pose between, and auto covers it; with STEP
//!   keys the same spheres need no growth at all;
//! - a CUBICSPLINE translation whose keys are equal but whose tangents make the curve overshoot
//!   to 0.77 between them;
//! - hostile animations: NaN values and times, decreasing times, two keys at one time, more keys
//!   than the sample cap.

use spherebake_bake::skin::margin::MAX_TIMES_PER_ANIMATION;
use spherebake_bake::{grow_for_animations, PoseMargin, SkinError, SkinSettings};
use spherebake_format::{BoneRecord, SkinEntry, SkinTerms, SphbFile, Sphere};
use spherebake_geom::glam::{Mat4, Quat, Vec3};
use spherebake_geom::{
    anim, AnimChannel, AnimPath, Animation, Bone, Interpolation, Mesh, Node, Skeleton, Skin, SkinInfluences,
};
use std::process::Command;

/// `n` times strictly inside `(t0, t1)`, offset by 1 − 1/φ of a step: never a key time of the
/// evenly keyed animations here, and not a multiple of any power-of-two subdivision.
fn between(t0: f32, t1: f32, n: usize) -> Vec<f32> {
    (0..n)
        .map(|i| (f64::from(t0) + (f64::from(t1) - f64::from(t0)) * (i as f64 + 0.381_966) / n as f64) as f32)
        .collect()
}

/// Key range of animation `a` (first to last key over its channels).
fn key_range(skel: &Skeleton, a: usize) -> (f32, f32) {
    let ch = &skel.animations[a].channels;
    let t0 = ch.iter().filter_map(|c| c.times.first()).copied().fold(f32::INFINITY, f32::min);
    let t1 = ch.iter().filter_map(|c| c.times.last()).copied().fold(f32::NEG_INFINITY, f32::max);
    (t0, t1)
}

/// Per time, the vertices (all mesh vertices, skinned by `anim::skin_vertices`) outside every
/// sphere of `proxy` posed by the runtime at that time of animation `a`, and the largest excess
/// `|v − c| − r` (f64 on the f32 values).
fn uncovered(proxy: &spherebake_runtime::Proxy, mesh: &Mesh, a: usize, times: &[f32]) -> (usize, usize, f64) {
    let skin = mesh.skin.as_ref().unwrap();
    let mut posed = vec![Sphere::default(); proxy.sphere_count()];
    let (mut outside, mut total, mut worst) = (0, 0, 0.0f64);
    for &t in times {
        let j = anim::joint_matrices(
            &skin.skeleton,
            &anim::world_matrices(&skin.skeleton, &anim::sample_local(&skin.skeleton, Some(a), t)),
        );
        let cols: Vec<[f32; 16]> = j.iter().map(Mat4::to_cols_array).collect();
        spherebake_runtime::pose(proxy, &cols, &mut posed).unwrap();
        for v in anim::skin_vertices(skin, &j) {
            let v = v.as_dvec3();
            let excess = posed
                .iter()
                .map(|s| Vec3::from(s.center).as_dvec3().distance(v) - f64::from(s.radius))
                .fold(f64::INFINITY, f64::min);
            total += 1;
            // A NaN excess (a non-finite pose) counts as outside.
            if excess > 0.0 || excess.is_nan() {
                outside += 1;
                worst = worst.max(excess);
            }
        }
    }
    (outside, total, worst)
}

#[test]
fn cesium_man_is_covered_between_sample_times() {
    let Some(model) = spherebake_testkit::shared_model("gltf/CesiumMan.glb") else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cm.sphb");
    let o = Command::new(env!("CARGO_BIN_EXE_spherebake"))
        .args(["bake", model.to_str().unwrap(), "--spheres", "64", "--pose-margin", "auto", "-q", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let proxy = spherebake_runtime::load(&std::fs::read(&out).unwrap()).unwrap();
    let mesh = spherebake_io::load_mesh(&model).unwrap().mesh;
    let skel = &mesh.skin.as_ref().unwrap().skeleton;
    assert!(!skel.animations.is_empty());
    for a in 0..skel.animations.len() {
        let (t0, t1) = key_range(skel, a);
        // 997 times: prime, so none falls on the 1/24 s keys or a bisection point of them.
        let (outside, total, worst) = uncovered(&proxy, &mesh, a, &between(t0, t1, 997));
        eprintln!("CesiumMan animation {a}: {outside} of {total} vertex-times outside (worst {worst:.3e})");
        assert_eq!(outside, 0, "animation {a}: {outside} of {total} vertex-times outside, worst excess {worst:.3e}");
    }
}

// ---- the synthetic two-bone bar ----

/// Root bone 0 (node 0, static) and bone 1 (node 1, child at the origin) driven by `channel`;
/// identity inverse binds, so bind space = scene space.
fn skeleton(channels: Vec<AnimChannel>) -> Skeleton {
    let node = |name: &str, parent| Node {
        name: name.into(),
        parent,
        translation: [0.0; 3],
        rotation: [0.0, 0.0, 0.0, 1.0],
        scale: [1.0; 3],
    };
    Skeleton {
        nodes: vec![node("root", None), node("arm", Some(0))],
        bones: vec![
            Bone { name: "root".into(), node: 0, parent: None, inverse_bind: Mat4::IDENTITY },
            Bone { name: "arm".into(), node: 1, parent: Some(0), inverse_bind: Mat4::IDENTITY },
        ],
        animations: vec![Animation { name: "swing".into(), channels }],
    }
}

/// The bar x ∈ [0, 1], y, z ∈ [−0.05, 0.05] (the test kit's unit cube, scaled), every vertex
/// carried by bone 1 alone.
fn bar(skel: Skeleton) -> Mesh {
    let (p, t) = spherebake_testkit::mesh::unit_cube();
    let positions: Vec<Vec3> =
        p.iter().map(|v| Vec3::new(v[0] as f32, v[1] as f32 * 0.1 - 0.05, v[2] as f32 * 0.1 - 0.05)).collect();
    let mut inf = SkinInfluences::default();
    inf.joints[0] = 1;
    inf.weights[0] = 1.0;
    let mut m = Mesh {
        triangles: t,
        skin: Some(Skin { skeleton: skel, influences: vec![inf; positions.len()], bind_positions: positions.clone() }),
        positions,
        ..Mesh::default()
    };
    m.rebuild_weld();
    m
}

/// One slot per sphere on the static root bone: centres stay where they are.
fn static_terms(spheres: &[[f32; 4]]) -> SkinTerms {
    SkinTerms {
        bones_per_sphere: 1,
        entries: spheres.iter().map(|s| SkinEntry { bone: 0, q: [s[0], s[1], s[2]], b: 1.0 }).collect(),
    }
}

fn proxy(spheres: &[[f32; 4]], terms: &SkinTerms, skel: &Skeleton) -> spherebake_runtime::Proxy {
    let file = SphbFile {
        spheres: spheres.iter().map(|s| Sphere { center: [s[0], s[1], s[2]], radius: s[3] }).collect(),
        skin: Some(terms.clone()),
        bones: Some(
            skel.bones
                .iter()
                .map(|b| BoneRecord {
                    name: b.name.clone(),
                    parent: b.parent,
                    inverse_bind: b.inverse_bind.to_cols_array(),
                })
                .collect(),
        ),
        ..SphbFile::default()
    };
    spherebake_runtime::load(&spherebake_format::write(&file)).expect("valid file")
}

const TURN_DEG: f32 = 170.0;

/// Bone 1's rotation: identity at t = 0, 170° about z at t = 1.
fn turn(interpolation: Interpolation) -> AnimChannel {
    let q = Quat::from_rotation_z(TURN_DEG.to_radians());
    AnimChannel {
        node: 1,
        path: AnimPath::Rotation,
        interpolation,
        times: vec![0.0, 1.0],
        values: vec![0.0, 0.0, 0.0, 1.0, q.x, q.y, q.z, q.w],
    }
}

/// Two static spheres, one around the bar at each key pose (radius 0.52: the bar's corners are
/// √(0.5² + 0.05² + 0.05²) = 0.50498 from its middle).
fn key_spheres() -> Vec<[f32; 4]> {
    let (s, c) = TURN_DEG.to_radians().sin_cos();
    vec![[0.5, 0.0, 0.0, 0.52], [0.5 * c, 0.5 * s, 0.0, 0.52]]
}

fn auto() -> SkinSettings {
    SkinSettings { bones_per_sphere: 1, pose_margin: PoseMargin::Auto, ..SkinSettings::default() }
}

#[test]
fn a_fast_turn_between_two_keys_is_covered() {
    let m = bar(skeleton(vec![turn(Interpolation::Linear)]));
    let skel = &m.skin.as_ref().unwrap().skeleton;
    let s = key_spheres();
    let terms = static_terms(&s);
    let before = proxy(&s, &terms, skel);
    // Keyframe-only sampling finds nothing to grow: both key poses are covered...
    assert_eq!(uncovered(&before, &m, 0, &[0.0, 1.0]).0, 0);
    // ...but halfway the bar points along 85°: its tip (cos 85°, sin 85°) is 1.078 from both
    // centres, so the key-only spheres miss it.
    let (out, _, worst) = uncovered(&before, &m, 0, &[0.5]);
    assert!(out >= 4 && worst > 0.5, "{out} {worst}");
    let r = grow_for_animations(&m, &s, &terms, &auto()).unwrap();
    assert!(r.grown_count > 0 && r.capped_animations == 0 && r.unbounded_frames == 0, "{r:?}");
    let after = proxy(&r.spheres, &terms, skel);
    let (out, total, worst) = uncovered(&after, &m, 0, &between(0.0, 1.0, 997));
    assert_eq!(out, 0, "{out} of {total} outside, worst {worst}");
    // Not larger than needed plus the motion bound: a sphere grows to a vertex's distance at a
    // sample time plus the bound, so its radius is at most the largest distance any vertex has
    // from it over the animation (sampled densely here; 1e-3 for the sampling gap) plus the
    // largest bound used, which refinement held to the tolerance (0.002 of the diagonal).
    let diag = f64::from((Vec3::new(1.0, 0.1, 0.1)).length());
    assert!(r.motion_bound_max_relative <= 0.002 * (1.0 + 1e-9), "{}", r.motion_bound_max_relative);
    for (i, (g, c)) in r.spheres.iter().zip(&s).enumerate() {
        let centre = Vec3::new(c[0], c[1], c[2]).as_dvec3();
        let far = (0..=20_000)
            .flat_map(|k| {
                let t = k as f32 / 20_000.0;
                let j = anim::joint_matrices(skel, &anim::world_matrices(skel, &anim::sample_local(skel, Some(0), t)));
                anim::skin_vertices(m.skin.as_ref().unwrap(), &j)
            })
            .map(|v| v.as_dvec3().distance(centre))
            .fold(0.0, f64::max);
        let bound = far + r.motion_bound_max_relative * diag + 1e-3;
        assert!(f64::from(g[3]) <= bound, "sphere {i}: radius {} > {bound}", g[3]);
    }
    eprintln!(
        "turn: {} frames, radii {:?}, motion bound {:.2e} of the diagonal",
        r.frames, r.spheres, r.motion_bound_max_relative
    );
}

#[test]
fn step_keys_jump_only_at_keys() {
    // Same spheres, STEP keys: the pose is the first key until t = 1, then the second: no pose
    // between is new, so nothing grows; frames: rest, t = 0, and both sides of t = 1.
    let m = bar(skeleton(vec![turn(Interpolation::Step)]));
    let skel = &m.skin.as_ref().unwrap().skeleton;
    let s = key_spheres();
    let terms = static_terms(&s);
    let r = grow_for_animations(&m, &s, &terms, &auto()).unwrap();
    assert_eq!(r.grown_count, 0, "{r:?}");
    assert_eq!(r.frames, 4);
    assert_eq!(r.motion_bound_max_relative, 0.0);
    let mut times = between(0.0, 1.0, 997);
    times.extend([0.0, 1.0, 0.999_999_94, 2.0]);
    assert_eq!(uncovered(&proxy(&r.spheres, &terms, skel), &m, 0, &times).0, 0);
}

#[test]
fn a_step_jump_during_linear_motion_is_covered_on_both_sides() {
    // The bar slides up 2 (LINEAR translation over [0, 1]) and turns 170° at t = 1 (STEP): just
    // before t = 1 it is unturned at height 2, a pose neither key time shows.
    let slide = AnimChannel {
        node: 1,
        path: AnimPath::Translation,
        interpolation: Interpolation::Linear,
        times: vec![0.0, 1.0],
        values: vec![0.0, 0.0, 0.0, 0.0, 2.0, 0.0],
    };
    let m = bar(skeleton(vec![turn(Interpolation::Step), slide]));
    let skel = &m.skin.as_ref().unwrap().skeleton;
    let s = key_spheres();
    let terms = static_terms(&s);
    let before = proxy(&s, &terms, skel);
    let just_before = 0.999_999_94f32;
    assert_eq!(uncovered(&before, &m, 0, &[0.0]).0, 0);
    assert_eq!(uncovered(&before, &m, 0, &[just_before]).0, 8, "the unturned bar at height 2");
    let r = grow_for_animations(&m, &s, &terms, &auto()).unwrap();
    let mut times = between(0.0, 1.0, 997);
    times.extend([just_before, 1.0]);
    let (out, total, worst) = uncovered(&proxy(&r.spheres, &terms, skel), &m, 0, &times);
    assert_eq!(out, 0, "{out} of {total} outside, worst {worst}");
}

#[test]
fn two_keys_at_one_time_are_both_sides_of_a_jump() {
    // LINEAR keys 0, 0.5, 0.5, 1: identity until 0.5, then the turned pose (a jump at 0.5 with
    // no motion on either side). Frames: rest, 0, both sides of 0.5, 1; nothing grows.
    let q = Quat::from_rotation_z(TURN_DEG.to_radians());
    let ch = AnimChannel {
        node: 1,
        path: AnimPath::Rotation,
        interpolation: Interpolation::Linear,
        times: vec![0.0, 0.5, 0.5, 1.0],
        values: vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, q.x, q.y, q.z, q.w, q.x, q.y, q.z, q.w],
    };
    let m = bar(skeleton(vec![ch]));
    let skel = &m.skin.as_ref().unwrap().skeleton;
    let s = key_spheres();
    let terms = static_terms(&s);
    let r = grow_for_animations(&m, &s, &terms, &auto()).unwrap();
    assert_eq!((r.grown_count, r.frames), (0, 5), "{r:?}");
    let mut times = between(0.0, 1.0, 997);
    times.extend([0.499_999_97, 0.5, 0.500_000_06]);
    assert_eq!(uncovered(&proxy(&r.spheres, &terms, skel), &m, 0, &times).0, 0);
}

#[test]
fn cubic_spline_overshoot_between_equal_keys_is_covered() {
    // Bone 1's translation: value 0 at both keys, out-tangent of key 0 and in-tangent of key 1
    // (0, 8, 0). Hermite: y(u) = 8 (u³ − 2u² + u) + 8 (u³ − u²) = 8 (2u³ − 3u² + u), zero at
    // both keys, largest at u = (3 − √3)/6 with y = 8 · √3/18 = 0.7698.
    let values = vec![
        0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 8.0, 0.0, // key 0: in-tangent, value, out-tangent
        0.0, 8.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, // key 1
    ];
    let ch = AnimChannel {
        node: 1,
        path: AnimPath::Translation,
        interpolation: Interpolation::CubicSpline,
        times: vec![0.0, 1.0],
        values,
    };
    let m = bar(skeleton(vec![ch]));
    let skel = &m.skin.as_ref().unwrap().skeleton;
    let s = vec![[0.5, 0.0, 0.0, 0.52]];
    let terms = static_terms(&s);
    let before = proxy(&s, &terms, skel);
    assert_eq!(uncovered(&before, &m, 0, &[0.0, 1.0]).0, 0, "the keys are the rest pose");
    let u = (3.0 - 3f32.sqrt()) / 6.0;
    let peak = anim::sample_local(skel, Some(0), u)[1].0.y;
    assert!((peak - 8.0 * 3f32.sqrt() / 18.0).abs() < 1e-5, "{peak}");
    assert_eq!(uncovered(&before, &m, 0, &[u]).0, 8, "every vertex leaves the sphere at the peak");
    let r = grow_for_animations(&m, &s, &terms, &auto()).unwrap();
    let (out, total, worst) = uncovered(&proxy(&r.spheres, &terms, skel), &m, 0, &between(0.0, 1.0, 997));
    assert_eq!(out, 0, "{out} of {total} outside, worst {worst}");
    // At the peak the far corners (0 or 1, 0.7698 ± 0.05, ±0.05) are √(0.25 + 0.8198² + 0.0025)
    // = 0.9616 from the centre: the sphere must reach that, and not much more.
    assert!(r.spheres[0][3] > 0.9616 && r.spheres[0][3] < 0.99, "{:?}", r.spheres);
}

#[test]
fn deterministic_across_thread_counts() {
    let m = bar(skeleton(vec![turn(Interpolation::Linear)]));
    let s = key_spheres();
    let terms = static_terms(&s);
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| grow_for_animations(&m, &s, &terms, &auto()).unwrap())
    };
    assert_eq!(run(1), run(3));
}

#[test]
fn more_keys_than_the_cap_still_cover() {
    // 4001 keys of a wildly turning bone (up to ±60° per key), at most 16 sample times: windows
    // then hold hundreds of keys, whose segments the bound sums (up to the 2 of any rotation).
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let mut rnd = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f32 / (1u64 << 53) as f32
    };
    let n = 4001;
    let times: Vec<f32> = (0..n).map(|i| i as f32 / 100.0).collect();
    let mut values = Vec::new();
    let mut angle = 0.0f32;
    for _ in 0..n {
        angle += (rnd() - 0.5) * 2.0 * 60f32.to_radians();
        let q = Quat::from_rotation_z(angle);
        values.extend([q.x, q.y, q.z, q.w]);
    }
    let ch = AnimChannel {
        node: 1,
        path: AnimPath::Rotation,
        interpolation: Interpolation::Linear,
        times: times.clone(),
        values,
    };
    let m = bar(skeleton(vec![ch]));
    let skel = &m.skin.as_ref().unwrap().skeleton;
    let s = key_spheres();
    let terms = static_terms(&s);
    let settings = SkinSettings { max_times_per_animation: 16, ..auto() };
    let r = grow_for_animations(&m, &s, &terms, &settings).unwrap();
    assert_eq!(r.capped_animations, 1);
    assert!(r.frames <= 1 + 2 * 16, "{}", r.frames);
    let mut check = between(0.0, 40.0, 9973);
    check.extend(&times);
    let (out, total, worst) = uncovered(&proxy(&r.spheres, &terms, skel), &m, 0, &check);
    assert_eq!(out, 0, "{out} of {total} outside, worst {worst}");
}

#[test]
fn hostile_animations_error_or_stay_bounded() {
    let s = key_spheres();
    let terms = static_terms(&s);
    let mk = |times: Vec<f32>, values: Vec<f32>| {
        bar(skeleton(vec![AnimChannel {
            node: 1,
            path: AnimPath::Translation,
            interpolation: Interpolation::Linear,
            times,
            values,
        }]))
    };
    // Key times not finite, or decreasing: the importer's rule, as an error.
    for times in [vec![0.0, f32::NAN], vec![0.0, f32::INFINITY], vec![1.0, 0.0]] {
        let m = mk(times, vec![0.0; 6]);
        assert!(matches!(
            grow_for_animations(&m, &s, &terms, &auto()),
            Err(SkinError::AnimationKeys { animation: 0, channel: 0 })
        ));
    }
    // A NaN value: no panic; the frames next to it have no finite bound and say so.
    let m = mk(vec![0.0, 1.0, 2.0], vec![0.0, 0.0, 0.0, f32::NAN, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let r = grow_for_animations(&m, &s, &terms, &auto()).unwrap();
    assert!(r.unbounded_frames > 0, "{r:?}");
    assert!(r.spheres.iter().all(|x| x.iter().all(|v| v.is_finite())));
    // Huge values: finite bounds beyond f32 radii are refused, not stored as infinity.
    let m = mk(vec![0.0, 1.0], vec![0.0, 0.0, 0.0, 3e38, 0.0, 0.0]);
    let r = grow_for_animations(&m, &s, &terms, &auto()).unwrap();
    assert!(r.spheres.iter().all(|x| x[3].is_finite()));
    // Settings out of range.
    let m = bar(skeleton(vec![turn(Interpolation::Linear)]));
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 1.5] {
        let e = grow_for_animations(&m, &s, &terms, &SkinSettings { margin_tolerance: bad, ..auto() });
        assert!(matches!(e, Err(SkinError::MarginTolerance { .. })), "{bad}");
    }
    for bad in [0, 1, MAX_TIMES_PER_ANIMATION + 1] {
        let e = grow_for_animations(&m, &s, &terms, &SkinSettings { max_times_per_animation: bad, ..auto() });
        assert!(matches!(e, Err(SkinError::TimesPerAnimation { .. })), "{bad}");
    }
}

#[test]
fn random_rigs_are_covered_between_sample_times() {
    // Chains of three nodes with random rest TRS (non-uniform scales), every path driven by a
    // random LINEAR / STEP / CUBICSPLINE channel with its own key range; the cube's vertices
    // weighted over all three bones at random; three spheres with random terms (weights not
    // summing to 1). Whatever the greedy grows, the runtime's posing must cover every vertex.
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    let mut r = move |lo: f32, hi: f32| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        lo + (hi - lo) * ((seed >> 40) as f32 / (1u64 << 24) as f32)
    };
    let modes = [Interpolation::Linear, Interpolation::Step, Interpolation::CubicSpline];
    for case in 0..12 {
        let nodes: Vec<Node> = (0..3)
            .map(|i| Node {
                name: format!("n{i}"),
                parent: if i == 0 { None } else { Some(i - 1) },
                translation: [r(-0.5, 0.5), r(-0.5, 0.5), r(-0.5, 0.5)],
                rotation: Quat::from_axis_angle(
                    Vec3::new(r(-1.0, 1.0), r(-1.0, 1.0), r(0.1, 1.0)).normalize(),
                    r(-3.0, 3.0),
                )
                .to_array(),
                scale: [r(0.7, 1.4), r(0.7, 1.4), r(0.7, 1.4)],
            })
            .collect();
        let mut channels = Vec::new();
        for node in 0..3 {
            for path in [AnimPath::Translation, AnimPath::Rotation, AnimPath::Scale] {
                let interpolation = modes[(case + 2 * node + path as usize) % 3];
                let keys = 2 + (r(0.0, 4.0) as usize);
                let mut times: Vec<f32> = (0..keys).map(|_| r(0.0, 2.0)).collect();
                times.sort_by(f32::total_cmp);
                let comps = if path == AnimPath::Rotation { 4 } else { 3 };
                let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
                let values = (0..keys * per_key * comps)
                    .map(|_| if path == AnimPath::Scale { r(0.7, 1.4) } else { r(-0.6, 0.6) })
                    .collect();
                channels.push(AnimChannel { node, path, interpolation, times, values });
            }
        }
        let bones = (0..3)
            .map(|i| Bone {
                name: format!("b{i}"),
                node: i,
                parent: i.checked_sub(1).map(|p| p as u32),
                inverse_bind: Mat4::from_scale_rotation_translation(
                    Vec3::splat(r(0.8, 1.2)),
                    Quat::from_rotation_y(r(-1.0, 1.0)),
                    Vec3::new(r(-0.3, 0.3), r(-0.3, 0.3), r(-0.3, 0.3)),
                ),
            })
            .collect();
        let skel = Skeleton { nodes, bones, animations: vec![Animation { name: "a".into(), channels }] };
        let mut m = bar(skel);
        let skin = m.skin.as_mut().unwrap();
        for inf in &mut skin.influences {
            let w = [r(0.0, 1.0), r(0.0, 1.0), r(0.0, 1.0)];
            inf.joints[..3].copy_from_slice(&[0, 1, 2]);
            inf.weights[..3].copy_from_slice(&w.map(|x| x / (w[0] + w[1] + w[2])));
        }
        let s: Vec<[f32; 4]> = (0..3).map(|i| [0.5 * i as f32, 0.0, 0.0, 0.3]).collect();
        let terms = SkinTerms {
            bones_per_sphere: 3,
            entries: (0..9)
                .map(|e| SkinEntry {
                    bone: (e % 3) as u32,
                    q: [r(-0.5, 0.5), r(-0.5, 0.5), r(-0.5, 0.5)],
                    b: r(0.0, 0.6),
                })
                .collect(),
        };
        let settings = SkinSettings { margin_tolerance: 0.01, ..auto() };
        let r0 = grow_for_animations(&m, &s, &terms, &settings).unwrap();
        assert_eq!(r0.unbounded_frames, 0, "case {case}");
        let skel = &m.skin.as_ref().unwrap().skeleton;
        let mut times = between(-0.1, 2.1, 3001);
        times.extend(skel.animations[0].channels.iter().flat_map(|c| c.times.clone()));
        let (out, total, worst) = uncovered(&proxy(&r0.spheres, &terms, skel), &m, 0, &times);
        assert_eq!(out, 0, "case {case}: {out} of {total} outside, worst {worst}");
    }
}
