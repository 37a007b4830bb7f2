//! Every entry point of the C ABI with NULL pointers, short buffers and mutated files: each call
//! returns its documented status and fills the error; nothing panics across the boundary (a
//! panic would abort this test process) and nothing reads out of bounds.

use spherebake::*;
use std::ptr::{null, null_mut};

mod common;
use common::{golden, message, new_err};

fn load_ok(bytes: &[u8]) -> *mut SphbProxy {
    let mut p = null_mut();
    let mut e = new_err();
    assert_eq!(unsafe { sphb_load(bytes.as_ptr(), bytes.len(), &mut p, &mut e) }, SPHB_OK, "{}", message(&e));
    assert_eq!(e.code, SPHB_OK);
    assert!(!p.is_null());
    p
}

#[test]
fn load_checks_pointers_and_reports_the_rule() {
    let bytes = golden("capsule-16.sphb");
    let mut p = null_mut();
    let mut e = new_err();
    assert_eq!(unsafe { sphb_load(null(), 64, &mut p, &mut e) }, SPHB_ERR_NULL);
    assert_eq!((e.code, e.rule_id), (SPHB_ERR_NULL, 0));
    assert!(message(&e).contains("bytes"), "{}", message(&e));
    assert_eq!(unsafe { sphb_load(bytes.as_ptr(), bytes.len(), null_mut(), &mut e) }, SPHB_ERR_NULL);
    // Empty input: rule 1001 (file too small), the error pointer may be NULL.
    assert_eq!(unsafe { sphb_load(null(), 0, &mut p, null_mut()) }, SPHB_ERR_INVALID_FILE);
    assert!(p.is_null());
    assert_eq!(unsafe { sphb_load(bytes.as_ptr(), 10, &mut p, &mut e) }, SPHB_ERR_INVALID_FILE);
    assert_eq!(e.rule_id, 1001);
    // Every truncation and single-byte change the Rust reader rejects gives its rule ID.
    for cut in (0..bytes.len()).step_by(7) {
        let want = spherebake_runtime::load(&bytes[..cut]).unwrap_err();
        assert_eq!(unsafe { sphb_load(bytes.as_ptr(), cut, &mut p, &mut e) }, SPHB_ERR_INVALID_FILE);
        assert_eq!(e.rule_id, u32::from(want.rule.id()));
        assert_eq!(message(&e), want.to_string());
        assert!(p.is_null());
    }
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    for _ in 0..400 {
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        let mut m = bytes.clone();
        let at = (state >> 33) as usize % m.len();
        m[at] ^= 1 << ((state >> 29) % 8);
        if state & 1 == 0 {
            spherebake_format::repair_checksums(&mut m);
        }
        let rust = spherebake_runtime::load(&m);
        let status = unsafe { sphb_load(m.as_ptr(), m.len(), &mut p, &mut e) };
        match rust {
            Ok(_) => {
                assert_eq!(status, SPHB_OK);
                drive_proxy(p);
                unsafe { sphb_proxy_free(p) };
            }
            Err(want) => {
                assert_eq!((status, e.rule_id), (SPHB_ERR_INVALID_FILE, u32::from(want.rule.id())));
                assert!(p.is_null());
            }
        }
    }
    unsafe { sphb_proxy_free(null_mut()) };
}

/// Queries on a valid proxy with good and bad arguments.
fn drive_proxy(p: *mut SphbProxy) {
    let mut e = new_err();
    let mut counts = SphbCounts::default();
    assert_eq!(unsafe { sphb_proxy_counts(null(), &mut counts, &mut e) }, SPHB_ERR_NULL);
    assert_eq!(unsafe { sphb_proxy_counts(p, null_mut(), &mut e) }, SPHB_ERR_NULL);
    assert_eq!(unsafe { sphb_proxy_counts(p, &mut counts, &mut e) }, SPHB_OK);
    let n = counts.sphere_count as usize;
    let mut views = std::mem::MaybeUninit::<SphbViews>::zeroed();
    assert_eq!(unsafe { sphb_proxy_views(null(), views.as_mut_ptr(), &mut e) }, SPHB_ERR_NULL);
    assert_eq!(unsafe { sphb_proxy_views(p, null_mut(), &mut e) }, SPHB_ERR_NULL);
    assert_eq!(unsafe { sphb_proxy_views(p, views.as_mut_ptr(), &mut e) }, SPHB_OK);
    let v = unsafe { views.assume_init() };
    assert_eq!(v.sphere_count, n);
    assert_eq!(v.node_count, counts.node_count as usize);
    assert_eq!(v.sample_count, counts.sample_count as usize);
    let mut bone = std::mem::MaybeUninit::<SphbBone>::zeroed();
    assert_eq!(unsafe { sphb_proxy_bone(p, counts.bone_count, bone.as_mut_ptr(), &mut e) }, SPHB_ERR_INVALID_ARGUMENT);
    assert_eq!(unsafe { sphb_proxy_bone(p, 0, null_mut(), &mut e) }, SPHB_ERR_NULL);
    let mut meta = std::mem::MaybeUninit::<SphbMetadataEntry>::zeroed();
    assert_eq!(
        unsafe { sphb_proxy_metadata(p, counts.metadata_count, meta.as_mut_ptr(), &mut e) },
        SPHB_ERR_INVALID_ARGUMENT
    );
    // Pose: short output, NULL joints with a count, too few joints for a skinned file.
    let mut leaves = vec![SphbSphere::default(); n];
    assert_eq!(unsafe { sphb_pose(p, null(), 0, leaves.as_mut_ptr(), n - 1, &mut e) }, SPHB_ERR_BUFFER_TOO_SMALL);
    assert_eq!(unsafe { sphb_pose(p, null(), 3, leaves.as_mut_ptr(), n, &mut e) }, SPHB_ERR_NULL);
    assert_eq!(unsafe { sphb_pose(p, null(), usize::MAX, leaves.as_mut_ptr(), n, &mut e) }, SPHB_ERR_INVALID_ARGUMENT);
    let bones = counts.bone_count as usize;
    let mut joints = vec![0.0f32; 16 * bones.max(1)];
    for j in 0..bones {
        for k in [0, 5, 10, 15] {
            joints[16 * j + k] = 1.0;
        }
    }
    if counts.bones_per_sphere > 0 && bones > 0 {
        assert_eq!(
            unsafe { sphb_pose(p, joints.as_ptr(), bones - 1, leaves.as_mut_ptr(), n, &mut e) },
            SPHB_ERR_INVALID_ARGUMENT
        );
    }
    assert_eq!(unsafe { sphb_pose(p, joints.as_ptr(), bones, leaves.as_mut_ptr(), n, &mut e) }, SPHB_OK);
    // Misaligned output.
    let mut raw = vec![0u8; 16 * n + 16];
    let odd = unsafe { raw.as_mut_ptr().add(1) }.cast::<SphbSphere>();
    assert_eq!(unsafe { sphb_pose(p, joints.as_ptr(), bones, odd, n, &mut e) }, SPHB_ERR_INVALID_ARGUMENT);
    let m = counts.node_count as usize;
    let mut nodes = vec![SphbSphere::default(); m.max(1)];
    let mut cut = vec![SphbCutEntry::default(); m + n];
    let mut len = 0usize;
    let c = [0.0f32, -3.0, 0.0];
    if m == 0 {
        assert_eq!(unsafe { sphb_rest_nodes(p, nodes.as_mut_ptr(), 1, &mut e) }, SPHB_ERR_MISSING_DATA);
        assert_eq!(unsafe { sphb_refit(p, leaves.as_ptr(), n, nodes.as_mut_ptr(), 1, &mut e) }, SPHB_ERR_MISSING_DATA);
    } else {
        assert_eq!(unsafe { sphb_rest_nodes(p, nodes.as_mut_ptr(), m - 1, &mut e) }, SPHB_ERR_BUFFER_TOO_SMALL);
        assert_eq!(unsafe { sphb_rest_nodes(p, nodes.as_mut_ptr(), m, &mut e) }, SPHB_OK);
        assert_eq!(
            unsafe { sphb_refit(p, leaves.as_ptr(), n, nodes.as_mut_ptr(), m - 1, &mut e) },
            SPHB_ERR_BUFFER_TOO_SMALL
        );
        assert_eq!(unsafe { sphb_refit(p, null(), n, nodes.as_mut_ptr(), m, &mut e) }, SPHB_ERR_NULL);
        assert_eq!(
            unsafe { sphb_refit(p, leaves.as_ptr(), n - 1, nodes.as_mut_ptr(), m, &mut e) },
            SPHB_ERR_INVALID_ARGUMENT
        );
        assert_eq!(unsafe { sphb_refit(p, leaves.as_ptr(), n, nodes.as_mut_ptr(), m, &mut e) }, SPHB_OK);
        let mut l2 = vec![SphbSphere::default(); n];
        assert_eq!(
            unsafe {
                sphb_pose_and_refit(p, joints.as_ptr(), bones, l2.as_mut_ptr(), n, nodes.as_mut_ptr(), m - 1, &mut e)
            },
            SPHB_ERR_BUFFER_TOO_SMALL
        );
        assert_eq!(
            unsafe {
                sphb_pose_and_refit(p, joints.as_ptr(), bones, l2.as_mut_ptr(), n, nodes.as_mut_ptr(), m, &mut e)
            },
            SPHB_OK
        );
        assert_eq!(l2, leaves);
        let th = SPHB_DEFAULT_THETA_MAX_RAD;
        assert_eq!(
            unsafe { sphb_cut(p, nodes.as_ptr(), m, null(), 0.1, th, cut.as_mut_ptr(), m + n, &mut len, &mut e) },
            SPHB_ERR_NULL
        );
        assert_eq!(
            unsafe { sphb_cut(p, nodes.as_ptr(), m, c.as_ptr(), 0.1, th, cut.as_mut_ptr(), m + n, null_mut(), &mut e) },
            SPHB_ERR_NULL
        );
        assert_eq!(
            unsafe {
                sphb_cut(p, nodes.as_ptr(), m - 1, c.as_ptr(), 0.1, th, cut.as_mut_ptr(), m + n, &mut len, &mut e)
            },
            SPHB_ERR_INVALID_ARGUMENT
        );
        assert_eq!(
            unsafe { sphb_cut(p, nodes.as_ptr(), m, c.as_ptr(), 0.1, th, cut.as_mut_ptr(), 0, &mut len, &mut e) },
            SPHB_ERR_BUFFER_TOO_SMALL
        );
        assert!(len >= 1, "the needed length is reported");
        // A receiver ball or θmax outside the shadow build's rules is an argument error, not a cut.
        let bad_c = [f32::NAN, 0.0, 0.0];
        assert_eq!(
            unsafe {
                sphb_cut(p, nodes.as_ptr(), m, bad_c.as_ptr(), 0.1, th, cut.as_mut_ptr(), m + n, &mut len, &mut e)
            },
            SPHB_ERR_INVALID_ARGUMENT
        );
        for (r, t) in [(-1.0, th), (f32::INFINITY, th), (f32::NAN, th), (0.1, f32::NAN), (0.1, -0.1), (0.1, 4.0)] {
            assert_eq!(
                unsafe { sphb_cut(p, nodes.as_ptr(), m, c.as_ptr(), r, t, cut.as_mut_ptr(), m + n, &mut len, &mut e) },
                SPHB_ERR_INVALID_ARGUMENT,
                "radius {r}, theta {t}"
            );
        }
        assert_eq!(
            unsafe { sphb_cut(p, nodes.as_ptr(), m, c.as_ptr(), 0.1, th, cut.as_mut_ptr(), len, &mut len, &mut e) },
            SPHB_OK
        );
    }
    drive_shadow(p, &leaves, if m > 0 { Some(&nodes[..m]) } else { None });
    drive_light(p, &leaves, &joints[..16 * bones], counts.sh_order > 0 && counts.sample_count > 0);
}

fn drive_shadow(p: *mut SphbProxy, leaves: &[SphbSphere], nodes: Option<&[SphbSphere]>) {
    let mut e = new_err();
    let mut ctx = null_mut();
    assert_eq!(unsafe { sphb_shadow_context_new(9, SPHB_EXP_PS_STAR_4, &mut ctx, &mut e) }, SPHB_ERR_INVALID_ARGUMENT);
    assert_eq!(unsafe { sphb_shadow_context_new(4, 17, &mut ctx, &mut e) }, SPHB_ERR_INVALID_ARGUMENT);
    assert_eq!(unsafe { sphb_shadow_context_new(4, SPHB_EXP_HYB, null_mut(), &mut e) }, SPHB_ERR_NULL);
    assert_eq!(unsafe { sphb_shadow_context_new(4, SPHB_EXP_PS_STAR_4, &mut ctx, &mut e) }, SPHB_OK);
    let cl = sphb_shadow_cluster_new();
    let c = [0.0f32, -3.0, 0.0];
    let n = leaves.len();
    let (np, nc) = nodes.map_or((null(), 0), |s| (s.as_ptr(), s.len()));
    let th = SPHB_DEFAULT_THETA_MAX_RAD;
    // Queries on an unbuilt cluster.
    let mut log = [0.0f32; 16];
    assert_eq!(
        unsafe { sphb_accumulate_log_visibility(cl, c.as_ptr(), null(), log.as_mut_ptr(), 16, null_mut(), &mut e) },
        SPHB_ERR_INVALID_ARGUMENT
    );
    // The build with one argument changed at a time: cluster, proxy, order, leaf and node counts.
    let build = |cl: *mut SphbShadowCluster, p: *const SphbProxy, order: u32, leaf_count: usize, node_count: usize| {
        let mut e = new_err();
        let mut count = 0usize;
        let status = unsafe {
            sphb_shadow_cluster_build(
                cl,
                p,
                order,
                leaves.as_ptr(),
                leaf_count,
                np,
                node_count,
                c.as_ptr(),
                0.1,
                th,
                &mut count,
                &mut e,
            )
        };
        (status, count, message(&e))
    };
    assert_eq!(build(null_mut(), p, 4, n, nc).0, SPHB_ERR_NULL);
    assert_eq!(build(cl, null(), 4, n, nc).0, SPHB_ERR_NULL);
    assert_eq!(build(cl, p, 4, n - 1, nc).0, SPHB_ERR_INVALID_ARGUMENT);
    assert_eq!(build(cl, p, 0, n, nc).0, SPHB_ERR_INVALID_ARGUMENT);
    if nc > 0 {
        assert_eq!(build(cl, p, 4, n, nc - 1).0, SPHB_ERR_INVALID_ARGUMENT);
    }
    let (status, count, msg) = build(cl, p, 4, n, nc);
    assert_eq!(status, SPHB_OK, "{msg}");
    // The blocker count is optional.
    assert_eq!(
        unsafe {
            sphb_shadow_cluster_build(cl, p, 4, leaves.as_ptr(), n, np, nc, c.as_ptr(), 0.1, th, null_mut(), &mut e)
        },
        SPHB_OK
    );
    assert!(count >= 1);
    let up = [0.0f32, 1.0, 0.0];
    let mut scale = 0.0f32;
    assert_eq!(
        unsafe { sphb_shadow_cluster_correct_overlap(cl, ctx, c.as_ptr(), null(), 64, &mut scale, &mut e) },
        SPHB_ERR_NULL
    );
    assert_eq!(
        unsafe { sphb_shadow_cluster_correct_overlap(cl, ctx, c.as_ptr(), up.as_ptr(), 64, &mut scale, &mut e) },
        SPHB_OK
    );
    assert!(scale > 0.0 && scale <= 1.0, "{scale}");
    let mut used = 0usize;
    assert_eq!(
        unsafe { sphb_accumulate_log_visibility(cl, c.as_ptr(), up.as_ptr(), log.as_mut_ptr(), 15, &mut used, &mut e) },
        SPHB_ERR_BUFFER_TOO_SMALL
    );
    assert_eq!(
        unsafe { sphb_accumulate_log_visibility(cl, null(), up.as_ptr(), log.as_mut_ptr(), 16, &mut used, &mut e) },
        SPHB_ERR_NULL
    );
    assert_eq!(
        unsafe { sphb_accumulate_log_visibility(cl, c.as_ptr(), up.as_ptr(), log.as_mut_ptr(), 16, &mut used, &mut e) },
        SPHB_OK
    );
    let mut g = [0.0f64; 16];
    assert_eq!(
        unsafe { sphb_visibility(ctx, log.as_ptr(), 15, g.as_mut_ptr(), 16, &mut e) },
        SPHB_ERR_BUFFER_TOO_SMALL
    );
    assert_eq!(
        unsafe { sphb_visibility(ctx, log.as_ptr(), 16, g.as_mut_ptr(), 15, &mut e) },
        SPHB_ERR_BUFFER_TOO_SMALL
    );
    assert_eq!(unsafe { sphb_visibility(null(), log.as_ptr(), 16, g.as_mut_ptr(), 16, &mut e) }, SPHB_ERR_NULL);
    assert_eq!(unsafe { sphb_visibility(ctx, log.as_ptr(), 16, g.as_mut_ptr(), 16, &mut e) }, SPHB_OK);
    for bad in [f32::NAN, f32::INFINITY] {
        let mut l = log;
        l[3] = bad;
        assert_eq!(
            unsafe { sphb_visibility(ctx, l.as_ptr(), 16, g.as_mut_ptr(), 16, &mut e) },
            SPHB_ERR_INVALID_ARGUMENT,
            "a log of {bad}"
        );
    }
    let mut light = [0.0f64; 16];
    assert_eq!(unsafe { sphb_uniform_light(9, light.as_mut_ptr(), 16, &mut e) }, SPHB_ERR_INVALID_ARGUMENT);
    assert_eq!(unsafe { sphb_uniform_light(4, light.as_mut_ptr(), 3, &mut e) }, SPHB_ERR_BUFFER_TOO_SMALL);
    assert_eq!(unsafe { sphb_uniform_light(4, null_mut(), 16, &mut e) }, SPHB_ERR_NULL);
    assert_eq!(unsafe { sphb_uniform_light(4, light.as_mut_ptr(), 16, &mut e) }, SPHB_OK);
    let mut t = [0.0f64; 16];
    let upd = [0.0f64, 1.0, 0.0];
    assert_eq!(
        unsafe { sphb_shading_vector(ctx, light.as_ptr(), 16, null(), t.as_mut_ptr(), 16, &mut e) },
        SPHB_ERR_NULL
    );
    assert_eq!(
        unsafe { sphb_shading_vector(ctx, light.as_ptr(), 4, upd.as_ptr(), t.as_mut_ptr(), 16, &mut e) },
        SPHB_ERR_BUFFER_TOO_SMALL
    );
    assert_eq!(
        unsafe { sphb_shading_vector(ctx, light.as_ptr(), 16, upd.as_ptr(), t.as_mut_ptr(), 16, &mut e) },
        SPHB_OK
    );
    // Without blockers the shade is T·1 = 1 for uniform white light; with them it is in (0, 1].
    let one = {
        let mut o = [0.0f64; 16];
        o[0] = 3.544_907_701_811_032;
        o
    };
    assert!((unsafe { sphb_shade(t.as_ptr(), one.as_ptr(), 16) } - 1.0).abs() < 1e-9);
    assert_eq!(unsafe { sphb_shade(null(), one.as_ptr(), 16) }, 0.0);
    let mut v = 0.0f64;
    assert_eq!(
        unsafe { sphb_shade_point(ctx, cl, c.as_ptr(), up.as_ptr(), t.as_ptr(), 3, &mut v, &mut e) },
        SPHB_ERR_INVALID_ARGUMENT
    );
    assert_eq!(
        unsafe { sphb_shade_point(ctx, cl, c.as_ptr(), up.as_ptr(), t.as_ptr(), 16, null_mut(), &mut e) },
        SPHB_ERR_NULL
    );
    assert_eq!(unsafe { sphb_shade_point(ctx, cl, c.as_ptr(), up.as_ptr(), t.as_ptr(), 16, &mut v, &mut e) }, SPHB_OK);
    assert!(v.is_finite());
    unsafe {
        sphb_shadow_cluster_free(cl);
        sphb_shadow_context_free(ctx);
        sphb_shadow_cluster_free(null_mut());
        sphb_shadow_context_free(null_mut());
    }
}

fn drive_light(p: *mut SphbProxy, leaves: &[SphbSphere], joints: &[f32], lit: bool) {
    let mut e = new_err();
    let n = leaves.len();
    let bones = joints.len() / 16;
    let mut rot = vec![0.0f32; 9 * n];
    assert_eq!(
        unsafe {
            sphb_sphere_rotations(p, joints.as_ptr(), joints.as_ptr(), bones, rot.as_mut_ptr(), 9 * n - 1, &mut e)
        },
        SPHB_ERR_BUFFER_TOO_SMALL
    );
    assert_eq!(
        unsafe { sphb_sphere_rotations(p, joints.as_ptr(), joints.as_ptr(), bones, rot.as_mut_ptr(), 9 * n, &mut e) },
        SPHB_OK
    );
    let mut ctx = null_mut();
    assert_eq!(unsafe { sphb_light_context_new(0, SPHB_EXP_PS_STAR_4, &mut ctx, &mut e) }, SPHB_ERR_INVALID_ARGUMENT);
    assert_eq!(unsafe { sphb_light_context_new(2, SPHB_EXP_PS_STAR_4, &mut ctx, &mut e) }, SPHB_OK);
    let lights = sphb_sphere_lights_new();
    let env = {
        let mut l = [0.0f64; 4];
        l[0] = 3.544_907_701_811_032;
        l
    };
    let posed = SphbPosed {
        proxy: p,
        leaves: leaves.as_ptr(),
        leaf_count: n,
        nodes: null(),
        node_count: 0,
        rotations: rot.as_ptr(),
    };
    let bad = SphbPosed { leaf_count: n - 1, ..posed };
    let th = SPHB_DEFAULT_THETA_MAX_RAD;
    let set = SphbPass1Settings { theta_max_rad: th };
    let pass1 = |posed: *const SphbPosed, env_len: usize, others: &[SphbPosed], e: &mut SphbError| unsafe {
        sphb_light_spheres(
            ctx,
            posed,
            env.as_ptr(),
            env_len,
            others.as_ptr(),
            others.len(),
            &set,
            lights,
            null_mut(),
            e,
        )
    };
    assert_eq!(pass1(null(), 4, &[], &mut e), SPHB_ERR_NULL);
    assert_eq!(pass1(&bad, 4, &[], &mut e), SPHB_ERR_INVALID_ARGUMENT);
    assert_eq!(pass1(&posed, 4, &[bad], &mut e), SPHB_ERR_INVALID_ARGUMENT, "a bad other proxy");
    assert_eq!(pass1(&posed, 3, &[], &mut e), if lit { SPHB_ERR_INVALID_ARGUMENT } else { SPHB_ERR_MISSING_DATA });
    assert_eq!(
        unsafe { sphb_light_spheres(ctx, &posed, env.as_ptr(), 4, null(), 2, &set, lights, null_mut(), &mut e) },
        SPHB_ERR_NULL,
        "NULL others with a count"
    );
    let status = pass1(&posed, 4, &[posed], &mut e);
    let mut leaf = [0.0f32; 12];
    if lit {
        assert_eq!(status, SPHB_OK, "{}", message(&e));
        assert_eq!(
            unsafe { sphb_sphere_lights_leaf(lights, 0, leaf.as_mut_ptr(), 11, &mut e) },
            SPHB_ERR_BUFFER_TOO_SMALL
        );
        assert_eq!(
            unsafe { sphb_sphere_lights_leaf(lights, n as u32, leaf.as_mut_ptr(), 12, &mut e) },
            SPHB_ERR_INVALID_ARGUMENT
        );
        assert_eq!(unsafe { sphb_sphere_lights_leaf(lights, 0, leaf.as_mut_ptr(), 12, &mut e) }, SPHB_OK);
        let ic = sphb_indirect_cluster_new();
        let c = [0.0f32, -3.0, 0.0];
        let up = [0.0f32, 1.0, 0.0];
        let lp = [lights.cast_const()];
        let srcs = [posed];
        let mut spec = SphbClusterSpec::default();
        assert_eq!(unsafe { sphb_cluster_spec_init(c.as_ptr(), 0.5, up.as_ptr(), &mut spec, &mut e) }, SPHB_OK);
        assert_eq!(unsafe { sphb_cluster_spec_init(c.as_ptr(), 0.5, up.as_ptr(), null_mut(), &mut e) }, SPHB_ERR_NULL);
        assert_eq!(
            unsafe { sphb_indirect_cluster_build(ic, ctx, srcs.as_ptr(), null(), 1, &spec, &mut e) },
            SPHB_ERR_NULL
        );
        let bad_srcs = [bad];
        assert_eq!(
            unsafe { sphb_indirect_cluster_build(ic, ctx, bad_srcs.as_ptr(), lp.as_ptr(), 1, &spec, &mut e) },
            SPHB_ERR_INVALID_ARGUMENT
        );
        assert_eq!(
            unsafe { sphb_indirect_cluster_build(ic, ctx, srcs.as_ptr(), lp.as_ptr(), 1, &spec, &mut e) },
            SPHB_OK,
            "{}",
            message(&e)
        );
        let mut count = 0usize;
        assert_eq!(unsafe { sphb_indirect_cluster_light_count(ic, null_mut(), &mut e) }, SPHB_ERR_NULL);
        assert_eq!(unsafe { sphb_indirect_cluster_light_count(ic, &mut count, &mut e) }, SPHB_OK);
        assert!(count >= 1);
        let mut node = [0.0f32; 12];
        let has_nodes = unsafe { sphb_sphere_lights_node(lights, 0, node.as_mut_ptr(), 12, &mut e) };
        assert!(has_nodes == SPHB_OK || has_nodes == SPHB_ERR_INVALID_ARGUMENT, "{has_nodes}");
        let mut len = 0usize;
        assert_eq!(
            unsafe { sphb_sphere_lights_sample_radiance(lights, null_mut(), 0, null_mut(), &mut e) },
            SPHB_ERR_NULL
        );
        let short = unsafe { sphb_sphere_lights_sample_radiance(lights, null_mut(), 0, &mut len, &mut e) };
        assert_eq!(short, if len == 0 { SPHB_OK } else { SPHB_ERR_BUFFER_TOO_SMALL });
        let mut out = [0.0f64; 3];
        let mut irradiance = |normal: *const f32, out: &mut [f64; 3]| unsafe {
            sphb_indirect_irradiance(
                ic,
                ctx,
                srcs.as_ptr(),
                lp.as_ptr(),
                1,
                c.as_ptr(),
                normal,
                out.as_mut_ptr(),
                &mut e,
            )
        };
        assert_eq!(irradiance(null(), &mut out), SPHB_ERR_NULL);
        assert_eq!(irradiance(up.as_ptr(), &mut out), SPHB_OK);
        assert!(out.iter().all(|v| v.is_finite() && *v >= 0.0), "{out:?}");
        // The shared-cluster query: NULL cluster or scratch, a cluster never built, then the value above.
        let scratch = sphb_indirect_scratch_new();
        let unbuilt = sphb_indirect_cluster_new();
        let shared = |cluster: *const SphbIndirectCluster,
                      scratch: *mut SphbIndirectScratch,
                      out: &mut [f64; 3],
                      e: &mut SphbError| unsafe {
            sphb_indirect_irradiance_with(
                cluster,
                scratch,
                ctx,
                srcs.as_ptr(),
                lp.as_ptr(),
                1,
                c.as_ptr(),
                up.as_ptr(),
                out.as_mut_ptr(),
                e,
            )
        };
        let mut same = [0.0f64; 3];
        let mut e2 = new_err();
        assert_eq!(shared(null(), scratch, &mut same, &mut e2), SPHB_ERR_NULL);
        assert_eq!(shared(ic, null_mut(), &mut same, &mut e2), SPHB_ERR_NULL);
        assert_eq!(shared(unbuilt, scratch, &mut same, &mut e2), SPHB_ERR_INVALID_ARGUMENT);
        assert!(message(&e2).contains("not built"), "{}", message(&e2));
        assert_eq!(shared(ic, scratch, &mut same, &mut e2), SPHB_OK);
        assert_eq!(same.map(f64::to_bits), out.map(f64::to_bits));
        unsafe {
            sphb_indirect_cluster_free(unbuilt);
            sphb_indirect_scratch_free(scratch);
            sphb_indirect_cluster_free(ic);
        }
    } else {
        assert_eq!(status, SPHB_ERR_MISSING_DATA);
    }
    unsafe {
        sphb_sphere_lights_free(lights);
        sphb_light_context_free(ctx);
        sphb_indirect_cluster_free(null_mut());
        sphb_sphere_lights_free(null_mut());
        sphb_light_context_free(null_mut());
    }
}

#[test]
fn every_entry_point_on_the_golden_files() {
    for name in ["capsule-16.sphb", "skinned-arm-16.sphb"] {
        let p = load_ok(&golden(name));
        drive_proxy(p);
        unsafe { sphb_proxy_free(p) };
    }
    assert!(!sphb_version().is_null());
}
