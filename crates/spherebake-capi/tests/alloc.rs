//! The per-receiver query of pass 2 through the C ABI allocates nothing once the cluster's
//! buffers (or the scratch of `sphb_indirect_irradiance_with`) have grown (before, the C layer built a heap array of the sources on every call).
//! The counting allocator is the runtime tests' one (per thread).

#[path = "../../spherebake-runtime/tests/counting_alloc/mod.rs"]
mod counting_alloc;
use counting_alloc::allocs;
mod common;
use common::{golden, new_err};

use spherebake::*;
use std::ptr::{null, null_mut};

#[test]
fn the_indirect_query_allocates_nothing_per_receiver() {
    let bytes = golden("capsule-16.sphb");
    let mut e = new_err();
    let mut p = null_mut();
    assert_eq!(unsafe { sphb_load(bytes.as_ptr(), bytes.len(), &mut p, &mut e) }, SPHB_OK);
    let mut c = SphbCounts::default();
    assert_eq!(unsafe { sphb_proxy_counts(p, &mut c, &mut e) }, SPHB_OK);
    let n = c.sphere_count as usize;
    let mut leaves = vec![SphbSphere::default(); n];
    assert_eq!(unsafe { sphb_pose(p, null(), 0, leaves.as_mut_ptr(), n, &mut e) }, SPHB_OK);
    let mut ctx = null_mut();
    assert_eq!(unsafe { sphb_light_context_new(4, SPHB_EXP_PS_STAR_4, &mut ctx, &mut e) }, SPHB_OK);
    let mut env = [0.0f64; 16];
    assert_eq!(unsafe { sphb_uniform_light(4, env.as_mut_ptr(), 16, &mut e) }, SPHB_OK);
    let lights = sphb_sphere_lights_new();
    let posed =
        SphbPosed { proxy: p, leaves: leaves.as_ptr(), leaf_count: n, nodes: null(), node_count: 0, rotations: null() };
    let settings = sphb_pass1_settings_default();
    let status =
        unsafe { sphb_light_spheres(ctx, &posed, env.as_ptr(), 16, null(), 0, &settings, lights, null_mut(), &mut e) };
    assert_eq!(status, SPHB_OK);
    let cl = sphb_indirect_cluster_new();
    let up = [0.0f32, 1.0, 0.0];
    let mut spec = SphbClusterSpec::default();
    let centre = [0.0f32, -1.5, 0.0];
    assert_eq!(unsafe { sphb_cluster_spec_init(centre.as_ptr(), 1.0, up.as_ptr(), &mut spec, &mut e) }, SPHB_OK);
    let lp: [*const SphbSphereLights; 1] = [lights];
    assert_eq!(unsafe { sphb_indirect_cluster_build(cl, ctx, &posed, lp.as_ptr(), 1, &spec, &mut e) }, SPHB_OK);
    let mut out = [0.0f64; 3];
    let query = |x: f32, out: &mut [f64; 3]| {
        let pt = [x, -1.5, 0.0];
        let mut e = new_err();
        unsafe {
            sphb_indirect_irradiance(
                cl,
                ctx,
                &posed,
                lp.as_ptr(),
                1,
                pt.as_ptr(),
                up.as_ptr(),
                out.as_mut_ptr(),
                &mut e,
            )
        }
    };
    assert_eq!(query(0.0, &mut out), SPHB_OK);
    let before = allocs();
    for k in 0..32 {
        assert_eq!(query(-0.8 + 0.05 * k as f32, &mut out), SPHB_OK);
        assert!(out.iter().all(|v| v.is_finite()));
    }
    assert_eq!(allocs() - before, 0, "allocations in 32 queries");
    // The shared-cluster query, with a scratch grown by its first call: the same values, no allocation.
    let scratch = sphb_indirect_scratch_new();
    let shared = |x: f32, out: &mut [f64; 3]| {
        let pt = [x, -1.5, 0.0];
        let mut e = new_err();
        unsafe {
            sphb_indirect_irradiance_with(
                cl,
                scratch,
                ctx,
                &posed,
                lp.as_ptr(),
                1,
                pt.as_ptr(),
                up.as_ptr(),
                out.as_mut_ptr(),
                &mut e,
            )
        }
    };
    assert_eq!(shared(0.0, &mut out), SPHB_OK);
    let before = allocs();
    let mut same = [0.0f64; 3];
    for k in 0..32 {
        let x = -0.8 + 0.05 * k as f32;
        assert_eq!(shared(x, &mut same), SPHB_OK);
        assert_eq!(query(x, &mut out), SPHB_OK);
        assert_eq!(same.map(f64::to_bits), out.map(f64::to_bits), "receiver {k}");
    }
    assert_eq!(allocs() - before, 0, "allocations in 32 shared queries");
    unsafe {
        sphb_indirect_scratch_free(scratch);
        sphb_indirect_scratch_free(null_mut());
        sphb_indirect_cluster_free(cl);
        sphb_sphere_lights_free(lights);
        sphb_light_context_free(ctx);
        sphb_proxy_free(p);
    }
}
