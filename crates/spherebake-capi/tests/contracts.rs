//! Contracts an engine relies on beyond NULLs and lengths (`hostile.rs`): outputs that overlap an
//! input are refused instead of computed from half-written memory; a failed build leaves its
//! cluster not built, so the queries after it fail instead of answering `SPHB_OK` from a
//! half-built one; the ABI version.

use spherebake::*;
use std::ptr::{null, null_mut};

mod common;
use common::{golden, message, new_err};

fn load(name: &str) -> *mut SphbProxy {
    let bytes = golden(name);
    let (mut p, mut e) = (null_mut(), new_err());
    assert_eq!(unsafe { sphb_load(bytes.as_ptr(), bytes.len(), &mut p, &mut e) }, SPHB_OK, "{}", message(&e));
    p
}

fn counts(p: *const SphbProxy) -> SphbCounts {
    let mut c = SphbCounts::default();
    assert_eq!(unsafe { sphb_proxy_counts(p, &mut c, null_mut()) }, SPHB_OK);
    c
}

#[test]
fn the_abi_version_is_the_headers() {
    assert_eq!(sphb_abi_version(), SPHB_ABI_VERSION);
    let header =
        std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../include/spherebake.h"))
            .unwrap();
    assert!(header.contains(&format!("#define SPHB_ABI_VERSION {SPHB_ABI_VERSION}\n")));
}

#[test]
fn outputs_that_overlap_an_input_are_refused() {
    let p = load("skinned-arm-16.sphb");
    let c = counts(p);
    let (n, m) = (c.sphere_count as usize, c.node_count as usize);
    assert!(m > 0);
    let mut e = new_err();
    // One buffer holds the leaves, then room for the nodes: refit reading the leaves and writing
    // nodes over them is refused; the same call on a disjoint range of the same buffer is fine.
    let mut buf = vec![SphbSphere::default(); n + m];
    assert_eq!(unsafe { sphb_rest_nodes(p, buf.as_mut_ptr(), m, &mut e) }, SPHB_OK);
    let mut leaves = vec![SphbSphere::default(); n];
    let joints: Vec<f32> =
        (0..c.bone_count).flat_map(|_| [1.0f32, 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.]).collect();
    assert_eq!(
        unsafe { sphb_pose(p, joints.as_ptr(), c.bone_count as usize, leaves.as_mut_ptr(), n, &mut e) },
        SPHB_OK
    );
    buf[..n].copy_from_slice(&leaves);
    let base = buf.as_mut_ptr();
    assert_eq!(unsafe { sphb_refit(p, base, n, base, m, &mut e) }, SPHB_ERR_INVALID_ARGUMENT);
    assert!(message(&e).contains("overlaps"), "{}", message(&e));
    assert_eq!(unsafe { sphb_refit(p, base, n, base.add(n - 1), m, &mut e) }, SPHB_ERR_INVALID_ARGUMENT);
    assert_eq!(unsafe { sphb_refit(p, base, n, base.add(n), m, &mut e) }, SPHB_OK, "{}", message(&e));
    let mut nodes = vec![SphbSphere::default(); m];
    assert_eq!(unsafe { sphb_refit(p, leaves.as_ptr(), n, nodes.as_mut_ptr(), m, &mut e) }, SPHB_OK);
    assert_eq!(&buf[n..], &nodes[..], "the disjoint call wrote what a separate buffer gets");
    // In-place SH calls: the output over the input is refused.
    let mut ctx = null_mut();
    assert_eq!(unsafe { sphb_light_context_new(4, SPHB_EXP_PS_STAR_4, &mut ctx, &mut e) }, SPHB_OK);
    let mut env = [0.0f64; 16];
    assert_eq!(unsafe { sphb_uniform_light(4, env.as_mut_ptr(), 16, &mut e) }, SPHB_OK);
    let up = [0.0f64, 1.0, 0.0];
    let ep = env.as_mut_ptr();
    assert_eq!(unsafe { sphb_clip_below_horizon(ctx, ep, 16, up.as_ptr(), ep, 16, &mut e) }, SPHB_ERR_INVALID_ARGUMENT);
    let mut clipped = [0.0f64; 16];
    assert_eq!(unsafe { sphb_clip_below_horizon(ctx, ep, 16, up.as_ptr(), clipped.as_mut_ptr(), 16, &mut e) }, SPHB_OK);
    let mut sctx = null_mut();
    assert_eq!(unsafe { sphb_shadow_context_new(4, SPHB_EXP_PS_STAR_4, &mut sctx, &mut e) }, SPHB_OK);
    let normal = [0.0f64, 1.0, 0.0];
    assert_eq!(
        unsafe { sphb_shading_vector(sctx, ep, 16, normal.as_ptr(), ep, 16, &mut e) },
        SPHB_ERR_INVALID_ARGUMENT
    );
    // The normal inside the output's range counts too.
    let mut lobe = [0.0f64; 16];
    lobe[2] = 1.0;
    let lp = lobe.as_mut_ptr();
    assert_eq!(unsafe { sphb_lobe_light(4, lp, 0.5, lp, 16, &mut e) }, SPHB_ERR_INVALID_ARGUMENT);
    unsafe {
        sphb_light_context_free(ctx);
        sphb_shadow_context_free(sctx);
        sphb_proxy_free(p);
    }
}

#[test]
fn a_failed_shadow_build_leaves_the_cluster_not_built() {
    let p = load("capsule-16.sphb");
    let c = counts(p);
    let n = c.sphere_count as usize;
    let mut e = new_err();
    let mut leaves = vec![SphbSphere::default(); n];
    assert_eq!(unsafe { sphb_pose(p, null(), 0, leaves.as_mut_ptr(), n, &mut e) }, SPHB_OK, "{}", message(&e));
    let mut ctx = null_mut();
    assert_eq!(unsafe { sphb_shadow_context_new(4, SPHB_EXP_PS_STAR_4, &mut ctx, &mut e) }, SPHB_OK);
    let mut light = [0.0f64; 16];
    assert_eq!(unsafe { sphb_uniform_light(4, light.as_mut_ptr(), 16, &mut e) }, SPHB_OK);
    // A receiver below the capsule, facing up at it.
    let (pt, up) = ([0.0f32, -1.2, 0.0], [0.0f32, 1.0, 0.0]);
    let up64 = [0.0f64, 1.0, 0.0];
    let mut t = [0.0f64; 16];
    assert_eq!(
        unsafe { sphb_shading_vector(ctx, light.as_ptr(), 16, up64.as_ptr(), t.as_mut_ptr(), 16, &mut e) },
        SPHB_OK
    );
    let cl = sphb_shadow_cluster_new();
    let build = |radius: f32, theta: f32| {
        let mut e = new_err();
        let s = unsafe {
            sphb_shadow_cluster_build(
                cl,
                p,
                4,
                leaves.as_ptr(),
                n,
                null(),
                0,
                pt.as_ptr(),
                radius,
                theta,
                null_mut(),
                &mut e,
            )
        };
        (s, message(&e))
    };
    let shade = || {
        let (mut out, mut e) = (-1.0f64, new_err());
        let s = unsafe { sphb_shade_point(ctx, cl, pt.as_ptr(), up.as_ptr(), t.as_ptr(), 16, &mut out, &mut e) };
        (s, out, message(&e))
    };
    assert!(shade().2.contains("not built"), "{}", shade().2);
    // The count written over the log vector it accumulates into is refused (8-byte aligned, so
    // only the overlap can refuse it).
    assert_eq!(build(0.1, SPHB_DEFAULT_THETA_MAX_RAD).0, SPHB_OK);
    let mut words = [0u64; 8];
    let log = words.as_mut_ptr().cast::<f32>();
    let mut e = new_err();
    let status = unsafe {
        sphb_accumulate_log_visibility(cl, pt.as_ptr(), up.as_ptr(), log, 16, words.as_mut_ptr().add(1).cast(), &mut e)
    };
    assert_eq!(status, SPHB_ERR_INVALID_ARGUMENT);
    assert!(message(&e).contains("used_out overlaps log_inout"), "{}", message(&e));
    let mut used = 0usize;
    assert_eq!(
        unsafe { sphb_accumulate_log_visibility(cl, pt.as_ptr(), up.as_ptr(), log, 16, &mut used, &mut e) },
        SPHB_OK
    );
    assert!(used > 0);
    for (radius, theta) in [(f32::NAN, 0.4), (-1.0, 0.4), (0.1, f32::NAN), (0.1, 4.0), (f32::INFINITY, 0.4)] {
        let (s, msg) = build(0.1, SPHB_DEFAULT_THETA_MAX_RAD);
        assert_eq!(s, SPHB_OK, "{msg}");
        let (s, shaded, msg) = shade();
        assert_eq!(s, SPHB_OK, "{msg}");
        assert!(shaded < 0.9, "the capsule above darkens the receiver: {shaded}");
        let (s, msg) = build(radius, theta);
        assert_eq!(s, SPHB_ERR_INVALID_ARGUMENT, "{radius} {theta}: {msg}");
        let (s, _, msg) = shade();
        assert_eq!(s, SPHB_ERR_INVALID_ARGUMENT, "{radius} {theta}: a failed build must not leave a lit receiver");
        assert!(msg.contains("not built"), "{msg}");
    }
    unsafe {
        sphb_shadow_cluster_free(cl);
        sphb_shadow_context_free(ctx);
        sphb_proxy_free(p);
    }
}
