//! Findings of a review of the C ABI against its header: a build refused by an argument check
//! still leaves its cluster empty and not built (not the previous build's answers); non-finite
//! points, joint matrices and light inputs are refused as their siblings refuse them; the optional
//! scalar outputs are checked for overlap too; an empty metadata value is not NULL; refit and cut
//! refuse spheres the shadow build refuses.

use spherebake::*;
use std::ptr::{null, null_mut};

mod common;
use common::{golden, message, new_err};

fn load_bytes(bytes: &[u8]) -> *mut SphbProxy {
    let (mut p, mut e) = (null_mut(), new_err());
    assert_eq!(unsafe { sphb_load(bytes.as_ptr(), bytes.len(), &mut p, &mut e) }, SPHB_OK, "{}", message(&e));
    p
}

fn load(name: &str) -> *mut SphbProxy {
    load_bytes(&golden(name))
}

fn counts(p: *const SphbProxy) -> SphbCounts {
    let mut c = SphbCounts::default();
    assert_eq!(unsafe { sphb_proxy_counts(p, &mut c, null_mut()) }, SPHB_OK);
    c
}

fn identity_joints(n: usize) -> Vec<f32> {
    (0..n).flat_map(|_| [1.0f32, 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.]).collect()
}

/// The rest spheres of `p` (posed with identity joints).
fn leaves_of(p: *const SphbProxy) -> Vec<SphbSphere> {
    let c = counts(p);
    let n = c.sphere_count as usize;
    let joints = identity_joints(c.bone_count as usize);
    let mut leaves = vec![SphbSphere::default(); n];
    let mut e = new_err();
    let s = unsafe { sphb_pose(p, joints.as_ptr(), c.bone_count as usize, leaves.as_mut_ptr(), n, &mut e) };
    assert_eq!(s, SPHB_OK, "{}", message(&e));
    leaves
}

fn rest_nodes(p: *const SphbProxy) -> Vec<SphbSphere> {
    let m = counts(p).node_count as usize;
    let mut nodes = vec![SphbSphere::default(); m];
    let mut e = new_err();
    assert_eq!(unsafe { sphb_rest_nodes(p, nodes.as_mut_ptr(), m, &mut e) }, SPHB_OK, "{}", message(&e));
    nodes
}

const RECEIVER: [f32; 3] = [0.0, -1.2, 0.0];
const UP: [f32; 3] = [0.0, 1.0, 0.0];

#[test]
fn a_shadow_build_refused_by_any_check_leaves_the_cluster_not_built() {
    let p = load("skinned-arm-16.sphb");
    let leaves = leaves_of(p);
    let n = leaves.len();
    let cl = sphb_shadow_cluster_new();
    let build = |leaf_count: usize, center: *const f32| {
        let mut e = new_err();
        let mut count = 0usize;
        let s = unsafe {
            sphb_shadow_cluster_build(
                cl,
                p,
                4,
                leaves.as_ptr(),
                leaf_count,
                null(),
                0,
                center,
                0.5,
                0.4,
                &mut count,
                &mut e,
            )
        };
        (s, count, message(&e))
    };
    let accumulate = || {
        let mut log = [0.0f32; 16];
        let (mut used, mut e) = (0usize, new_err());
        let s = unsafe {
            sphb_accumulate_log_visibility(cl, RECEIVER.as_ptr(), UP.as_ptr(), log.as_mut_ptr(), 16, &mut used, &mut e)
        };
        (s, message(&e))
    };
    let misaligned_count = {
        let mut words = [0u64; 2];
        unsafe { words.as_mut_ptr().cast::<u8>().add(1).cast::<usize>() }
    };
    for (what, refused) in [
        ("leaf_count - 1", Box::new(|| build(n - 1, RECEIVER.as_ptr()).0) as Box<dyn Fn() -> i32>),
        ("receiver_center NULL", Box::new(|| build(n, null()).0)),
        ("proxy NULL", {
            Box::new(|| unsafe {
                sphb_shadow_cluster_build(
                    cl,
                    null(),
                    4,
                    leaves.as_ptr(),
                    n,
                    null(),
                    0,
                    RECEIVER.as_ptr(),
                    0.5,
                    0.4,
                    null_mut(),
                    null_mut(),
                )
            })
        }),
        ("blocker_count_out misaligned", {
            Box::new(|| unsafe {
                sphb_shadow_cluster_build(
                    cl,
                    p,
                    4,
                    leaves.as_ptr(),
                    n,
                    null(),
                    0,
                    RECEIVER.as_ptr(),
                    0.5,
                    0.4,
                    misaligned_count,
                    null_mut(),
                )
            })
        }),
    ] {
        let (s, count, msg) = build(n, RECEIVER.as_ptr());
        assert_eq!(s, SPHB_OK, "{msg}");
        assert!(count > 0);
        assert_eq!(accumulate().0, SPHB_OK);
        assert_ne!(refused(), SPHB_OK, "{what}");
        let (s, msg) = accumulate();
        assert_eq!(s, SPHB_ERR_INVALID_ARGUMENT, "{what}: the previous build still answers");
        assert!(msg.contains("not built"), "{what}: {msg}");
    }
    unsafe {
        sphb_shadow_cluster_free(cl);
        sphb_proxy_free(p);
    }
}

/// A light context of order 4, `p`'s sphere lights under a uniform sky, and the posed proxy.
struct Lit {
    ctx: *mut SphbLightContext,
    lights: *mut SphbSphereLights,
    leaves: Vec<SphbSphere>,
}

impl Lit {
    fn new(p: *mut SphbProxy) -> Lit {
        let mut e = new_err();
        let mut ctx = null_mut();
        assert_eq!(unsafe { sphb_light_context_new(4, SPHB_EXP_PS_STAR_4, &mut ctx, &mut e) }, SPHB_OK);
        let leaves = leaves_of(p);
        let lit = Lit { ctx, lights: sphb_sphere_lights_new(), leaves };
        let mut env = [0.0f64; 16];
        assert_eq!(unsafe { sphb_uniform_light(4, env.as_mut_ptr(), 16, &mut e) }, SPHB_OK);
        let posed = lit.posed(p);
        let s = unsafe {
            sphb_light_spheres(ctx, &posed, env.as_ptr(), 16, null(), 0, null(), lit.lights, null_mut(), &mut e)
        };
        assert_eq!(s, SPHB_OK, "{}", message(&e));
        lit
    }

    fn posed(&self, p: *mut SphbProxy) -> SphbPosed {
        SphbPosed {
            proxy: p,
            leaves: self.leaves.as_ptr(),
            leaf_count: self.leaves.len(),
            nodes: null(),
            node_count: 0,
            rotations: null(),
        }
    }
}

impl Drop for Lit {
    fn drop(&mut self) {
        unsafe {
            sphb_sphere_lights_free(self.lights);
            sphb_light_context_free(self.ctx);
        }
    }
}

#[test]
fn an_indirect_build_refused_by_any_check_leaves_the_cluster_empty_and_not_built() {
    let p = load("skinned-arm-16.sphb");
    let lit = Lit::new(p);
    let posed = lit.posed(p);
    let lights: [*const SphbSphereLights; 1] = [lit.lights];
    let no_lights: [*const SphbSphereLights; 1] = [null()];
    let mut spec = SphbClusterSpec::default();
    let mut e = new_err();
    assert_eq!(unsafe { sphb_cluster_spec_init(RECEIVER.as_ptr(), 0.5, UP.as_ptr(), &mut spec, &mut e) }, SPHB_OK);
    let mut bad_flag = spec;
    bad_flag.has_normal = 2;
    let ic = sphb_indirect_cluster_new();
    let build = |spec: &SphbClusterSpec, lights: &[*const SphbSphereLights; 1]| {
        let mut e = new_err();
        let s = unsafe { sphb_indirect_cluster_build(ic, lit.ctx, &posed, lights.as_ptr(), 1, spec, &mut e) };
        (s, message(&e))
    };
    let light_count = || {
        let mut n = usize::MAX;
        assert_eq!(unsafe { sphb_indirect_cluster_light_count(ic, &mut n, null_mut()) }, SPHB_OK);
        n
    };
    let irradiance = || {
        let (mut out, mut e) = ([0.0f64; 3], new_err());
        let s = unsafe {
            sphb_indirect_irradiance(
                ic,
                lit.ctx,
                &posed,
                lights.as_ptr(),
                1,
                RECEIVER.as_ptr(),
                UP.as_ptr(),
                out.as_mut_ptr(),
                &mut e,
            )
        };
        (s, message(&e))
    };
    for (what, refused_spec, refused_lights) in
        [("has_normal = 2", &bad_flag, &lights), ("lights[0] NULL", &spec, &no_lights)]
    {
        let (s, msg) = build(&spec, &lights);
        assert_eq!(s, SPHB_OK, "{msg}");
        assert!(light_count() > 0);
        assert_eq!(irradiance().0, SPHB_OK);
        assert_ne!(build(refused_spec, refused_lights).0, SPHB_OK, "{what}");
        assert_eq!(light_count(), 0, "{what}: the cluster keeps the previous build's lights");
        let (s, msg) = irradiance();
        assert_eq!(s, SPHB_ERR_INVALID_ARGUMENT, "{what}: the previous build still answers");
        assert!(msg.contains("not built"), "{what}: {msg}");
    }
    unsafe {
        sphb_indirect_cluster_free(ic);
        sphb_proxy_free(p);
    }
}

#[test]
fn accumulate_refuses_a_receiver_point_that_is_not_finite() {
    let p = load("skinned-arm-16.sphb");
    let leaves = leaves_of(p);
    let cl = sphb_shadow_cluster_new();
    let mut e = new_err();
    let s = unsafe {
        sphb_shadow_cluster_build(
            cl,
            p,
            4,
            leaves.as_ptr(),
            leaves.len(),
            null(),
            0,
            RECEIVER.as_ptr(),
            0.5,
            0.4,
            null_mut(),
            &mut e,
        )
    };
    assert_eq!(s, SPHB_OK, "{}", message(&e));
    for bad in [[f32::NAN, -1.2, 0.0], [f32::INFINITY, -1.2, 0.0], [0.0, f32::NEG_INFINITY, 0.0]] {
        for normal in [UP.as_ptr(), null()] {
            let mut log = [0.0f32; 16];
            let mut used = 99usize;
            let s = unsafe {
                sphb_accumulate_log_visibility(cl, bad.as_ptr(), normal, log.as_mut_ptr(), 16, &mut used, &mut e)
            };
            assert_eq!(s, SPHB_ERR_INVALID_ARGUMENT, "{bad:?}");
            assert!(message(&e).contains('p'), "{}", message(&e));
        }
    }
    let mut log = [0.0f32; 16];
    let mut used = 0usize;
    let s = unsafe {
        sphb_accumulate_log_visibility(cl, RECEIVER.as_ptr(), UP.as_ptr(), log.as_mut_ptr(), 16, &mut used, &mut e)
    };
    assert_eq!(s, SPHB_OK);
    assert!(used > 0);
    unsafe {
        sphb_shadow_cluster_free(cl);
        sphb_proxy_free(p);
    }
}

#[test]
fn sphere_rotations_refuses_non_finite_matrices_as_pose_does() {
    let p = load("skinned-arm-16.sphb");
    let c = counts(p);
    let (n, bones) = (c.sphere_count as usize, c.bone_count as usize);
    assert!(bones > 0);
    let good = identity_joints(bones);
    let mut rot = vec![0.0f32; 9 * n];
    let mut leaves = vec![SphbSphere::default(); n];
    let mut e = new_err();
    let rotations = |j: &[f32], r: &[f32], rot: &mut [f32], e: &mut SphbError| unsafe {
        sphb_sphere_rotations(p, j.as_ptr(), r.as_ptr(), bones, rot.as_mut_ptr(), rot.len(), e)
    };
    assert_eq!(rotations(&good, &good, &mut rot, &mut e), SPHB_OK, "{}", message(&e));
    for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        for (joint, k) in [(0usize, 0usize), (bones - 1, 5), (bones - 1, 12)] {
            let mut bad = good.clone();
            bad[16 * joint + k] = v;
            let posed = unsafe { sphb_pose(p, bad.as_ptr(), bones, leaves.as_mut_ptr(), n, &mut e) };
            assert_eq!(posed, SPHB_ERR_INVALID_ARGUMENT);
            assert_eq!(rotations(&bad, &good, &mut rot, &mut e), SPHB_ERR_INVALID_ARGUMENT, "joints {v} {joint} {k}");
            assert!(message(&e).contains("joints"), "{}", message(&e));
            assert_eq!(rotations(&good, &bad, &mut rot, &mut e), SPHB_ERR_INVALID_ARGUMENT, "rest {v} {joint} {k}");
            assert!(message(&e).contains("rest_joints"), "{}", message(&e));
        }
    }
    // Extra matrices past the bone table are ignored, as by `sphb_pose`.
    let mut extra = good.clone();
    extra.extend([f32::NAN; 16]);
    let s =
        unsafe { sphb_sphere_rotations(p, extra.as_ptr(), extra.as_ptr(), bones + 1, rot.as_mut_ptr(), 9 * n, &mut e) };
    assert_eq!(s, SPHB_OK, "{}", message(&e));
    unsafe { sphb_proxy_free(p) };
}

#[test]
fn light_inputs_that_are_not_finite_are_refused() {
    let p = load("skinned-arm-16.sphb");
    let lit = Lit::new(p);
    let posed = lit.posed(p);
    let mut e = new_err();
    let mut env = [0.0f64; 16];
    assert_eq!(unsafe { sphb_uniform_light(4, env.as_mut_ptr(), 16, &mut e) }, SPHB_OK);
    let mut views = SphbViews {
        spheres: null(),
        sphere_count: 0,
        nodes: null(),
        node_count: 0,
        children: null(),
        child_total: 0,
        leaves: null(),
        leaf_total: 0,
        samples: null(),
        sample_count: 0,
        sample_offsets: null(),
        sample_offset_count: 0,
        sh: null(),
        sh_float_count: 0,
        skin: null(),
        skin_slot_count: 0,
    };
    assert_eq!(unsafe { sphb_proxy_views(p, &mut views, &mut e) }, SPHB_OK);
    assert!(views.sample_count > 0);
    for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        for k in [0, 15] {
            let mut bad = env;
            bad[k] = v;
            let s = unsafe {
                sphb_light_spheres(lit.ctx, &posed, bad.as_ptr(), 16, null(), 0, null(), lit.lights, null_mut(), &mut e)
            };
            assert_eq!(s, SPHB_ERR_INVALID_ARGUMENT, "env[{k}] = {v}");
            assert!(message(&e).contains("env"), "{}", message(&e));
            let mut radiance = vec![1.0f32; views.sample_count];
            radiance[k] = v as f32;
            let s = unsafe {
                sphb_light_spheres_from_radiance(lit.ctx, &posed, radiance.as_ptr(), radiance.len(), lit.lights, &mut e)
            };
            assert_eq!(s, SPHB_ERR_INVALID_ARGUMENT, "radiance[{k}] = {v}");
            assert!(message(&e).contains("radiance"), "{}", message(&e));
        }
    }
    // Values past order² are not read.
    let mut longer = [0.0f64; 17];
    longer[..16].copy_from_slice(&env);
    longer[16] = f64::NAN;
    let s = unsafe {
        sphb_light_spheres(lit.ctx, &posed, longer.as_ptr(), 17, null(), 0, null(), lit.lights, null_mut(), &mut e)
    };
    assert_eq!(s, SPHB_OK, "{}", message(&e));
    // Negative radiance still counts as 0.
    let radiance = vec![-1.0f32; views.sample_count];
    let s = unsafe {
        sphb_light_spheres_from_radiance(lit.ctx, &posed, radiance.as_ptr(), radiance.len(), lit.lights, &mut e)
    };
    assert_eq!(s, SPHB_OK, "{}", message(&e));
    // The shading vector's light.
    let mut sctx = null_mut();
    assert_eq!(unsafe { sphb_shadow_context_new(4, SPHB_EXP_PS_STAR_4, &mut sctx, &mut e) }, SPHB_OK);
    let normal = [0.0f64, 1.0, 0.0];
    let mut t = [0.0f64; 16];
    assert_eq!(
        unsafe { sphb_shading_vector(sctx, env.as_ptr(), 16, normal.as_ptr(), t.as_mut_ptr(), 16, &mut e) },
        SPHB_OK
    );
    for v in [f64::NAN, f64::INFINITY] {
        let mut bad = env;
        bad[3] = v;
        let s = unsafe { sphb_shading_vector(sctx, bad.as_ptr(), 16, normal.as_ptr(), t.as_mut_ptr(), 16, &mut e) };
        assert_eq!(s, SPHB_ERR_INVALID_ARGUMENT, "light[3] = {v}");
        assert!(message(&e).contains("light"), "{}", message(&e));
    }
    unsafe {
        sphb_shadow_context_free(sctx);
        sphb_proxy_free(p);
    }
}

#[test]
fn optional_scalar_outputs_that_overlap_an_input_are_refused() {
    let p = load("skinned-arm-16.sphb");
    let mut leaves = leaves_of(p);
    let n = leaves.len();
    let mut e = new_err();
    let cl = sphb_shadow_cluster_new();
    let build = |leaves: *const SphbSphere, count_out: *mut usize, e: &mut SphbError| unsafe {
        sphb_shadow_cluster_build(cl, p, 4, leaves, n, null(), 0, RECEIVER.as_ptr(), 0.5, 0.4, count_out, e)
    };
    // The blocker count written over the leaves it reads.
    let count_in_leaves = leaves.as_mut_ptr().cast::<usize>();
    assert_eq!(build(leaves.as_ptr(), count_in_leaves, &mut e), SPHB_ERR_INVALID_ARGUMENT);
    assert!(message(&e).contains("blocker_count_out overlaps leaves"), "{}", message(&e));
    assert_eq!(leaves, leaves_of(p), "nothing written over the leaves");
    let mut count = 0usize;
    let s = build(leaves.as_ptr(), &mut count, &mut e);
    assert_eq!(s, SPHB_OK, "{}", message(&e));
    // The overlap scale written over p_star.
    let mut sctx = null_mut();
    assert_eq!(unsafe { sphb_shadow_context_new(4, SPHB_EXP_PS_STAR_4, &mut sctx, &mut e) }, SPHB_OK);
    let mut p_star = [RECEIVER[0], RECEIVER[1], RECEIVER[2], 0.0];
    let pp = p_star.as_mut_ptr();
    let s = unsafe { sphb_shadow_cluster_correct_overlap(cl, sctx, pp, UP.as_ptr(), 64, pp.add(1), &mut e) };
    assert_eq!(s, SPHB_ERR_INVALID_ARGUMENT);
    assert!(message(&e).contains("scale_out overlaps p_star"), "{}", message(&e));
    assert_eq!(p_star[1], RECEIVER[1]);
    let s = unsafe { sphb_shadow_cluster_correct_overlap(cl, sctx, pp, UP.as_ptr(), 64, pp.add(3), &mut e) };
    assert_eq!(s, SPHB_OK, "{}", message(&e));
    // Pass 1's counts written over the environment.
    let lit = Lit::new(p);
    let posed = lit.posed(p);
    let mut words = [0u64; 32];
    let env = words.as_mut_ptr().cast::<f64>();
    assert_eq!(unsafe { sphb_uniform_light(4, env, 16, &mut e) }, SPHB_OK);
    let stats_in_env = unsafe { words.as_mut_ptr().add(2) }.cast::<SphbPass1Stats>();
    let s =
        unsafe { sphb_light_spheres(lit.ctx, &posed, env, 16, null(), 0, null(), lit.lights, stats_in_env, &mut e) };
    assert_eq!(s, SPHB_ERR_INVALID_ARGUMENT);
    assert!(message(&e).contains("stats_out overlaps env"), "{}", message(&e));
    let stats_after_env = unsafe { words.as_mut_ptr().add(16) }.cast::<SphbPass1Stats>();
    let s =
        unsafe { sphb_light_spheres(lit.ctx, &posed, env, 16, null(), 0, null(), lit.lights, stats_after_env, &mut e) };
    assert_eq!(s, SPHB_OK, "{}", message(&e));
    assert!(unsafe { (*stats_after_env).samples } > 0);
    unsafe {
        sphb_shadow_context_free(sctx);
        sphb_shadow_cluster_free(cl);
        sphb_proxy_free(p);
    }
}

#[test]
fn an_empty_metadata_value_is_not_null() {
    let mut file = spherebake_format::read(&golden("capsule-16.sphb")).unwrap();
    let md = file.metadata.get_or_insert_with(Default::default);
    md.units = String::new();
    md.extra.push(("empty".to_string(), String::new()));
    let p = load_bytes(&spherebake_format::write(&file));
    let c = counts(p);
    let mut e = new_err();
    let mut empties = 0;
    for i in 0..c.metadata_count {
        let mut m = SphbMetadataEntry { key: null(), key_len: 0, value: null(), value_len: 0 };
        assert_eq!(unsafe { sphb_proxy_metadata(p, i, &mut m, &mut e) }, SPHB_OK, "{}", message(&e));
        assert!(!m.key.is_null() && !m.value.is_null(), "entry {i}");
        if m.value_len == 0 {
            empties += 1;
        }
    }
    assert_eq!(empties, 2);
    unsafe { sphb_proxy_free(p) };
}

#[test]
fn refit_and_cut_refuse_what_the_shadow_build_refuses() {
    let p = load("skinned-arm-16.sphb");
    let leaves = leaves_of(p);
    let nodes = rest_nodes(p);
    let (n, m) = (leaves.len(), nodes.len());
    let mut e = new_err();
    let mut out = vec![SphbSphere::default(); m];
    let refit = |l: &[SphbSphere], out: &mut [SphbSphere], e: &mut SphbError| unsafe {
        sphb_refit(p, l.as_ptr(), l.len(), out.as_mut_ptr(), out.len(), e)
    };
    assert_eq!(refit(&leaves, &mut out, &mut e), SPHB_OK, "{}", message(&e));
    // More leaves than spheres.
    let mut more = leaves.clone();
    more.push(leaves[0]);
    assert_eq!(refit(&more, &mut out, &mut e), SPHB_ERR_INVALID_ARGUMENT);
    assert!(message(&e).contains("leaf_count"), "{}", message(&e));
    let bad_spheres = |s: &[SphbSphere], i: usize| {
        [f32::NAN, -1.0, f32::INFINITY]
            .into_iter()
            .map(|r| {
                let mut v = s.to_vec();
                v[i].radius = r;
                v
            })
            .chain([{
                let mut v = s.to_vec();
                v[i].center[1] = f32::NAN;
                v
            }])
            .collect::<Vec<_>>()
    };
    for bad in bad_spheres(&leaves, n - 1) {
        assert_eq!(refit(&bad, &mut out, &mut e), SPHB_ERR_INVALID_ARGUMENT, "{:?}", bad[n - 1]);
        assert!(message(&e).contains("leaves"), "{}", message(&e));
    }
    // A point sphere (radius FLT_MIN) and a radius of 0 are spheres.
    let mut points = leaves.clone();
    points[0].radius = f32::MIN_POSITIVE;
    points[1].radius = 0.0;
    assert_eq!(refit(&points, &mut out, &mut e), SPHB_OK, "{}", message(&e));
    let cut = |nodes: &[SphbSphere], e: &mut SphbError| {
        let mut entries = vec![SphbCutEntry::default(); n + m];
        let mut len = 0usize;
        unsafe {
            sphb_cut(
                p,
                nodes.as_ptr(),
                nodes.len(),
                RECEIVER.as_ptr(),
                0.5,
                0.4,
                entries.as_mut_ptr(),
                entries.len(),
                &mut len,
                e,
            )
        }
    };
    assert_eq!(cut(&nodes, &mut e), SPHB_OK, "{}", message(&e));
    for i in [0, m - 1] {
        for bad in bad_spheres(&nodes, i) {
            assert_eq!(cut(&bad, &mut e), SPHB_ERR_INVALID_ARGUMENT, "node {i}: {:?}", bad[i]);
            assert!(message(&e).contains("nodes"), "{}", message(&e));
        }
    }
    unsafe { sphb_proxy_free(p) };
}

/// A pass 1 that fails leaves its sphere lights empty, as a failed cluster build leaves its
/// cluster: reading a leaf light afterwards is an error, not the previous pass's light.
#[test]
fn a_failed_pass_one_leaves_the_lights_empty() {
    let p = load("skinned-arm-16.sphb");
    let lit = Lit::new(p);
    let posed = lit.posed(p);
    let mut e = new_err();
    let mut out = [0.0f32; 48];
    let leaf = |e: &mut SphbError, out: &mut [f32; 48]| unsafe {
        sphb_sphere_lights_leaf(lit.lights, 0, out.as_mut_ptr(), 48, e)
    };
    let mut env = [0.0f64; 16];
    assert_eq!(unsafe { sphb_uniform_light(4, env.as_mut_ptr(), 16, &mut e) }, SPHB_OK);
    for from_radiance in [false, true] {
        let s = unsafe {
            sphb_light_spheres(lit.ctx, &posed, env.as_ptr(), 16, null(), 0, null(), lit.lights, null_mut(), &mut e)
        };
        assert_eq!(s, SPHB_OK, "{}", message(&e));
        assert_eq!(leaf(&mut e, &mut out), SPHB_OK, "{}", message(&e));
        assert!(out.iter().any(|&v| v != 0.0));
        let s = if from_radiance {
            let radiance = [f32::NAN];
            unsafe { sphb_light_spheres_from_radiance(lit.ctx, &posed, radiance.as_ptr(), 1, lit.lights, &mut e) }
        } else {
            let mut bad = env;
            bad[3] = f64::NAN;
            unsafe {
                sphb_light_spheres(lit.ctx, &posed, bad.as_ptr(), 16, null(), 0, null(), lit.lights, null_mut(), &mut e)
            }
        };
        assert_ne!(s, SPHB_OK);
        assert_ne!(leaf(&mut e, &mut out), SPHB_OK, "from_radiance {from_radiance}: the previous lights answered");
    }
}
