//! The C ABI's light entry points carry every option of the Rust API: pass 1 with `others` and
//! its settings, pass 2 with every `ClusterSpec` field, node lights, sample radiance, the overlap
//! correction, the horizon clip and the lobe light give the Rust API's results bit for bit, and
//! the options that should change a result do (so an argument the ABI dropped would be caught).

use spherebake::*;
use spherebake_runtime::light::{
    clip_below_horizon, light_spheres, light_spheres_from_radiance, ClusterSpec, IndirectCluster, LightContext,
    Pass1Settings, PosedProxy, SphereLights,
};
use spherebake_runtime::shadow::{accumulate_log_visibility, lobe_light, ClusterBlockers, ExpMethod, ShadowContext};
use spherebake_runtime::{load, pose, refit, HierarchyPlan, Proxy, Sphere};
use std::ptr::{null, null_mut};

mod common;
use common::golden;

const ORDER: usize = 3;

fn check(status: i32, e: &SphbError) {
    let msg: Vec<u8> = e.message.iter().take_while(|&&c| c != 0).map(|&c| c as u8).collect();
    assert_eq!(status, SPHB_OK, "{}", String::from_utf8_lossy(&msg));
}

fn new_err() -> SphbError {
    SphbError { code: -1, rule_id: 0, message: [0; SPHB_MESSAGE_CAPACITY] }
}

/// One proxy in the scene: Rust and C handles, its posed leaves and refitted nodes.
struct Item {
    rust: Proxy,
    plan: HierarchyPlan,
    c: *mut SphbProxy,
    leaves: Vec<Sphere>,
    nodes: Vec<Sphere>,
}

impl Item {
    /// Loads `name` and moves it rigidly by `shift` (identity joints plus a translation).
    fn new(name: &str, shift: [f32; 3]) -> Item {
        let bytes = golden(name);
        let rust = load(&bytes).unwrap();
        let mut c = null_mut();
        let mut e = new_err();
        check(unsafe { sphb_load(bytes.as_ptr(), bytes.len(), &mut c, &mut e) }, &e);
        let joints: Vec<[f32; 16]> = (0..rust.bones().len().max(1))
            .map(|_| {
                let mut m = [0.0f32; 16];
                m[0] = 1.0;
                m[5] = 1.0;
                m[10] = 1.0;
                m[15] = 1.0;
                m
            })
            .collect();
        let mut leaves = vec![Sphere::default(); rust.sphere_count()];
        pose(&rust, &joints, &mut leaves).unwrap();
        for l in &mut leaves {
            for (c, d) in l.center.iter_mut().zip(shift) {
                *c += d;
            }
        }
        let plan = rust.hierarchy_plan().expect("the golden files have a hierarchy");
        let mut nodes = vec![Sphere::default(); plan.node_count()];
        refit(&plan, &leaves, &mut nodes).unwrap();
        Item { rust, plan, c, leaves, nodes }
    }

    fn posed(&self) -> PosedProxy<'_> {
        PosedProxy { proxy: &self.rust, leaves: &self.leaves, nodes: Some((&self.plan, &self.nodes)), rotations: None }
    }

    fn c_posed(&self) -> SphbPosed {
        SphbPosed {
            proxy: self.c,
            leaves: self.leaves.as_ptr().cast(),
            leaf_count: self.leaves.len(),
            nodes: self.nodes.as_ptr().cast(),
            node_count: self.nodes.len(),
            rotations: null(),
        }
    }
}

impl Drop for Item {
    fn drop(&mut self) {
        unsafe { sphb_proxy_free(self.c) };
    }
}

fn sky(ctx: &LightContext) -> Vec<f64> {
    let mut lobe = vec![0.0; ORDER * ORDER];
    lobe_light(ORDER, [0.3, 1.0, 0.2], 0.9, &mut lobe).unwrap();
    let mut env = vec![0.0; ORDER * ORDER];
    clip_below_horizon(ctx, &lobe, [0.0, 1.0, 0.0], &mut env).unwrap();
    env
}

#[test]
fn lobe_light_and_horizon_clip_are_the_rust_ones() {
    let mut e = new_err();
    let dir = [0.3f64, 1.0, 0.2];
    let mut want = vec![0.0; 16];
    lobe_light(4, dir, 0.9, &mut want).unwrap();
    let mut got = vec![0.0; 16];
    check(unsafe { sphb_lobe_light(4, dir.as_ptr(), 0.9, got.as_mut_ptr(), 16, &mut e) }, &e);
    assert_eq!(got, want);
    assert_eq!(
        unsafe { sphb_lobe_light(4, dir.as_ptr(), 0.9, got.as_mut_ptr(), 15, &mut e) },
        SPHB_ERR_BUFFER_TOO_SMALL
    );
    assert_eq!(unsafe { sphb_lobe_light(4, null(), 0.9, got.as_mut_ptr(), 16, &mut e) }, SPHB_ERR_NULL);
    assert_eq!(
        unsafe { sphb_lobe_light(0, dir.as_ptr(), 0.9, got.as_mut_ptr(), 16, &mut e) },
        SPHB_ERR_INVALID_ARGUMENT
    );

    let ctx = LightContext::new(4, ExpMethod::PsStar { degree: 4 }).unwrap();
    let mut cctx = null_mut();
    check(unsafe { sphb_light_context_new(4, SPHB_EXP_PS_STAR_4, &mut cctx, &mut e) }, &e);
    let up = [0.0f64, 1.0, 0.0];
    let mut clipped = vec![0.0; 16];
    clip_below_horizon(&ctx, &want, up, &mut clipped).unwrap();
    let mut c_clipped = vec![0.0; 16];
    check(
        unsafe { sphb_clip_below_horizon(cctx, want.as_ptr(), 16, up.as_ptr(), c_clipped.as_mut_ptr(), 16, &mut e) },
        &e,
    );
    assert_eq!(c_clipped, clipped);
    assert_ne!(clipped, want, "the clip changes a lobe that reaches below the horizon");
    let short =
        unsafe { sphb_clip_below_horizon(cctx, want.as_ptr(), 15, up.as_ptr(), c_clipped.as_mut_ptr(), 16, &mut e) };
    assert_eq!(short, SPHB_ERR_INVALID_ARGUMENT);
    assert_eq!(
        unsafe { sphb_clip_below_horizon(cctx, want.as_ptr(), 16, null(), c_clipped.as_mut_ptr(), 16, &mut e) },
        SPHB_ERR_NULL
    );
    unsafe { sphb_light_context_free(cctx) };
}

#[test]
fn both_passes_mirror_every_rust_option() {
    let arm = Item::new("skinned-arm-16.sphb", [0.0, 0.0, 0.0]);
    // The capsule stands beside the arm's lower half: it hides part of the arm's sky.
    let capsule = Item::new("capsule-16.sphb", [0.6, 0.5, 0.0]);
    let ctx = LightContext::new(ORDER, ExpMethod::PsStar { degree: 4 }).unwrap();
    let env = sky(&ctx);
    let mut e = new_err();
    let mut cctx = null_mut();
    check(unsafe { sphb_light_context_new(ORDER as u32, SPHB_EXP_PS_STAR_4, &mut cctx, &mut e) }, &e);

    // Pass 1 with `others` and a non-default θmax.
    let defaults = sphb_pass1_settings_default();
    assert_eq!(defaults.theta_max_rad, Pass1Settings::default().theta_max_rad);
    let settings = SphbPass1Settings { theta_max_rad: 0.3 };
    let mut rust_lights = Vec::new();
    let mut c_lights = Vec::new();
    for (me, other) in [(&arm, &capsule), (&capsule, &arm)] {
        let mut rl = SphereLights::new();
        let stats =
            light_spheres(&ctx, &me.posed(), &env, &[other.posed()], &Pass1Settings { theta_max_rad: 0.3 }, &mut rl)
                .unwrap();
        // Pass 1 through the C ABI into new sphere lights.
        let c_pass1 = |others: &[SphbPosed], settings: *const SphbPass1Settings, stats: *mut SphbPass1Stats| {
            let lights = sphb_sphere_lights_new();
            let mut e = new_err();
            let st = unsafe {
                sphb_light_spheres(
                    cctx,
                    &me.c_posed(),
                    env.as_ptr(),
                    env.len(),
                    if others.is_empty() { null() } else { others.as_ptr() }, // NULL with 0: none
                    others.len(),
                    settings,
                    lights,
                    stats,
                    &mut e,
                )
            };
            check(st, &e);
            lights
        };
        let mut cstats = SphbPass1Stats::default();
        let cl = c_pass1(&[other.c_posed()], &settings, &mut cstats);
        assert_eq!((cstats.samples, cstats.blocker_accumulations), (stats.samples, stats.blocker_accumulations));
        let nc = ORDER * ORDER;
        let mut buf = vec![0.0f32; 3 * nc];
        for i in 0..me.leaves.len() {
            check(unsafe { sphb_sphere_lights_leaf(cl, i as u32, buf.as_mut_ptr(), buf.len(), &mut e) }, &e);
            assert_eq!(buf, rl.leaf(i).concat(), "leaf {i}");
        }
        for n in 0..me.nodes.len() {
            check(unsafe { sphb_sphere_lights_node(cl, n as u32, buf.as_mut_ptr(), buf.len(), &mut e) }, &e);
            assert_eq!(buf, rl.node(n).concat(), "node {n}");
        }
        let bad_node = me.nodes.len() as u32;
        assert_eq!(
            unsafe { sphb_sphere_lights_node(cl, bad_node, buf.as_mut_ptr(), buf.len(), &mut e) },
            SPHB_ERR_INVALID_ARGUMENT
        );
        assert_eq!(
            unsafe { sphb_sphere_lights_node(cl, 0, buf.as_mut_ptr(), buf.len() - 1, &mut e) },
            SPHB_ERR_BUFFER_TOO_SMALL
        );
        let mut len = 0usize;
        assert_eq!(
            unsafe { sphb_sphere_lights_sample_radiance(cl, null_mut(), 0, &mut len, &mut e) },
            SPHB_ERR_BUFFER_TOO_SMALL
        );
        assert_eq!(len, rl.sample_radiance().len());
        let mut rad = vec![0.0f32; len];
        check(unsafe { sphb_sphere_lights_sample_radiance(cl, rad.as_mut_ptr(), len, &mut len, &mut e) }, &e);
        assert_eq!(rad, rl.sample_radiance());
        // Pass 1 from the same sample radiance gives the same lights (Rust and C alike).
        let given = sphb_sphere_lights_new();
        check(unsafe { sphb_light_spheres_from_radiance(cctx, &me.c_posed(), rad.as_ptr(), len, given, &mut e) }, &e);
        let mut rl_given = SphereLights::new();
        light_spheres_from_radiance(&ctx, &me.posed(), &rad, &mut rl_given).unwrap();
        for i in 0..me.leaves.len() {
            check(unsafe { sphb_sphere_lights_leaf(given, i as u32, buf.as_mut_ptr(), buf.len(), &mut e) }, &e);
            assert_eq!(buf, rl_given.leaf(i).concat(), "leaf {i} from radiance");
            assert_eq!(buf, rl.leaf(i).concat(), "leaf {i}: pass 1 from its own radiance");
        }
        assert_eq!(
            unsafe { sphb_light_spheres_from_radiance(cctx, &me.c_posed(), rad.as_ptr(), len - 1, given, &mut e) },
            SPHB_ERR_INVALID_ARGUMENT,
            "radiance shorter than the sample count"
        );
        unsafe { sphb_sphere_lights_free(given) };
        // Without the other proxy the samples see more sky: `others` reaches pass 1.
        let alone = c_pass1(&[], null(), null_mut());
        let mut rad_alone = vec![0.0f32; len];
        check(unsafe { sphb_sphere_lights_sample_radiance(alone, rad_alone.as_mut_ptr(), len, &mut len, &mut e) }, &e);
        assert_ne!(rad_alone, rad, "the other proxy must shadow some samples");
        let mut rl_alone = SphereLights::new();
        light_spheres(&ctx, &me.posed(), &env, &[], &Pass1Settings::default(), &mut rl_alone).unwrap();
        assert_eq!(rad_alone, rl_alone.sample_radiance(), "NULL settings are the defaults");
        unsafe { sphb_sphere_lights_free(alone) };
        rust_lights.push(rl);
        c_lights.push(cl);
    }

    // Pass 2: every combination of the spec's options.
    let rust_sources = [(arm.posed(), &rust_lights[0]), (capsule.posed(), &rust_lights[1])];
    let c_sources = [arm.c_posed(), capsule.c_posed()];
    let c_light_ptrs: Vec<*const SphbSphereLights> = c_lights.iter().map(|&l| l.cast_const()).collect();
    let centre = [0.3f32, -0.2, 0.4];
    let normal = [0.0f32, 1.0, 0.0];
    let mut spec = SphbClusterSpec::default();
    check(unsafe { sphb_cluster_spec_init(centre.as_ptr(), 0.3, normal.as_ptr(), &mut spec, &mut e) }, &e);
    let rust_default = ClusterSpec::new(centre, 0.3, Some(normal));
    assert_eq!(spec.theta_max_rad, rust_default.theta_max_rad);
    assert_eq!(spec.reflection_ratio, u32::from(rust_default.reflection_ratio));
    assert_eq!(spec.overlap_correction, u32::from(rust_default.overlap_correction));
    assert_eq!((spec.has_normal, spec.normal, spec.center, spec.radius), (1, normal, centre, 0.3));
    let receivers = [[0.3f32, -0.2, 0.4], [0.1, -0.25, 0.6], [0.5, -0.2, 0.2]];
    let mut results = Vec::new();
    let ic = sphb_indirect_cluster_new();
    let mut rust_ic = IndirectCluster::new();
    for has_normal in [0u32, 1] {
        for reflection_ratio in [0u32, 1] {
            for overlap_correction in [0u32, 1] {
                for theta in [SPHB_DEFAULT_THETA_MAX_RAD, 0.15] {
                    let s = SphbClusterSpec {
                        has_normal,
                        reflection_ratio,
                        overlap_correction,
                        theta_max_rad: theta,
                        ..spec
                    };
                    let rs = ClusterSpec {
                        center: centre,
                        radius: 0.3,
                        normal: (has_normal == 1).then_some(normal),
                        theta_max_rad: theta,
                        reflection_ratio: reflection_ratio == 1,
                        overlap_correction: overlap_correction == 1,
                    };
                    rust_ic.build(&ctx, &rust_sources, &rs).unwrap();
                    check(
                        unsafe {
                            sphb_indirect_cluster_build(
                                ic,
                                cctx,
                                c_sources.as_ptr(),
                                c_light_ptrs.as_ptr(),
                                2,
                                &s,
                                &mut e,
                            )
                        },
                        &e,
                    );
                    let mut count = 0usize;
                    check(unsafe { sphb_indirect_cluster_light_count(ic, &mut count, &mut e) }, &e);
                    assert_eq!(count, rust_ic.light_count());
                    let mut row = Vec::new();
                    for p in &receivers {
                        let want = rust_ic.irradiance(&ctx, &rust_sources, *p, normal).unwrap();
                        let mut got = [0.0f64; 3];
                        check(
                            unsafe {
                                sphb_indirect_irradiance(
                                    ic,
                                    cctx,
                                    c_sources.as_ptr(),
                                    c_light_ptrs.as_ptr(),
                                    2,
                                    p.as_ptr(),
                                    normal.as_ptr(),
                                    got.as_mut_ptr(),
                                    &mut e,
                                )
                            },
                            &e,
                        );
                        assert_eq!(got, want, "spec {s:?} receiver {p:?}");
                        row.push(got);
                    }
                    results.push(((has_normal, reflection_ratio, overlap_correction, theta.to_bits()), count, row));
                }
            }
        }
    }
    // The options reach the computation: θmax changes the cut; the reflection ratios change the
    // light when a normal is given (and not without one).
    let find = |k: (u32, u32, u32, u32)| results.iter().find(|r| r.0 == k).unwrap();
    let d = SPHB_DEFAULT_THETA_MAX_RAD.to_bits();
    let fine = 0.15f32.to_bits();
    assert_ne!(find((1, 1, 0, d)).1, find((1, 1, 0, fine)).1, "θmax changes the cut size");
    assert_ne!(find((1, 1, 0, d)).2, find((1, 0, 0, d)).2, "reflection ratios matter with a normal");
    assert_eq!(find((0, 1, 0, d)).2, find((0, 0, 0, d)).2, "without a normal the ratios are 1");
    assert_eq!(find((0, 1, 1, d)).2, find((0, 1, 0, d)).2, "the overlap correction needs a normal");
    // Bad flags are refused, not read as booleans.
    for bad in [
        SphbClusterSpec { has_normal: 2, ..spec },
        SphbClusterSpec { reflection_ratio: 7, ..spec },
        SphbClusterSpec { overlap_correction: u32::MAX, ..spec },
    ] {
        let st = unsafe {
            sphb_indirect_cluster_build(ic, cctx, c_sources.as_ptr(), c_light_ptrs.as_ptr(), 2, &bad, &mut e)
        };
        assert_eq!(st, SPHB_ERR_INVALID_ARGUMENT);
    }
    assert_eq!(
        unsafe { sphb_indirect_cluster_build(ic, cctx, c_sources.as_ptr(), c_light_ptrs.as_ptr(), 2, null(), &mut e) },
        SPHB_ERR_NULL
    );
    assert_eq!(unsafe { sphb_cluster_spec_init(null(), 0.3, null(), &mut spec, &mut e) }, SPHB_ERR_NULL);
    let mut spec_none = SphbClusterSpec::default();
    check(unsafe { sphb_cluster_spec_init(centre.as_ptr(), 0.3, null(), &mut spec_none, &mut e) }, &e);
    assert_eq!((spec_none.has_normal, spec_none.normal), (0, [0.0; 3]));
    unsafe {
        sphb_indirect_cluster_free(ic);
        for l in c_lights {
            sphb_sphere_lights_free(l);
        }
        sphb_light_context_free(cctx);
    }
}

#[test]
fn overlap_correction_is_the_rust_one() {
    let arm = Item::new("skinned-arm-16.sphb", [0.0, 0.0, 0.0]);
    let mut e = new_err();
    let ctx = ShadowContext::new(4, ExpMethod::PsStar { degree: 4 }).unwrap();
    let mut cctx = null_mut();
    check(unsafe { sphb_shadow_context_new(4, SPHB_EXP_PS_STAR_4, &mut cctx, &mut e) }, &e);
    // A receiver next to the arm's base, where its spheres overlap most.
    let p = [0.3f32, 0.2, 0.0];
    let n = [-1.0f32, 0.0, 0.0];
    let mut cb = ClusterBlockers::new();
    cb.build(4, &arm.leaves, Some((&arm.plan, &arm.nodes)), p, 0.05, SPHB_DEFAULT_THETA_MAX_RAD).unwrap();
    let cl = sphb_shadow_cluster_new();
    let leaves: &[SphbSphere] = unsafe { std::slice::from_raw_parts(arm.leaves.as_ptr().cast(), arm.leaves.len()) };
    let nodes: &[SphbSphere] = unsafe { std::slice::from_raw_parts(arm.nodes.as_ptr().cast(), arm.nodes.len()) };
    let mut scale = 0.0f32;
    assert_eq!(
        unsafe { sphb_shadow_cluster_correct_overlap(cl, cctx, p.as_ptr(), n.as_ptr(), 256, &mut scale, &mut e) },
        SPHB_ERR_INVALID_ARGUMENT,
        "an unbuilt cluster"
    );
    check(
        unsafe {
            sphb_shadow_cluster_build(
                cl,
                arm.c,
                4,
                leaves.as_ptr(),
                leaves.len(),
                nodes.as_ptr(),
                nodes.len(),
                p.as_ptr(),
                0.05,
                SPHB_DEFAULT_THETA_MAX_RAD,
                null_mut(),
                &mut e,
            )
        },
        &e,
    );
    let want = cb.correct_overlap(&ctx, p, n, 256).unwrap();
    check(
        unsafe { sphb_shadow_cluster_correct_overlap(cl, cctx, p.as_ptr(), n.as_ptr(), 256, &mut scale, &mut e) },
        &e,
    );
    assert_eq!(scale.to_bits(), want.to_bits());
    // The corrected blockers give the Rust log visibility.
    let mut want_log = [0.0f32; 16];
    accumulate_log_visibility(cb.blockers(), 4, p, Some(n), &mut want_log).unwrap();
    let mut got_log = [0.0f32; 16];
    check(
        unsafe {
            sphb_accumulate_log_visibility(cl, p.as_ptr(), n.as_ptr(), got_log.as_mut_ptr(), 16, null_mut(), &mut e)
        },
        &e,
    );
    assert_eq!(got_log, want_log);
    assert_eq!(
        unsafe { sphb_shadow_cluster_correct_overlap(cl, cctx, null(), n.as_ptr(), 256, null_mut(), &mut e) },
        SPHB_ERR_NULL
    );
    let mut ctx8 = null_mut();
    check(unsafe { sphb_shadow_context_new(5, SPHB_EXP_PS_STAR_4, &mut ctx8, &mut e) }, &e);
    assert_eq!(
        unsafe { sphb_shadow_cluster_correct_overlap(cl, ctx8, p.as_ptr(), n.as_ptr(), 256, null_mut(), &mut e) },
        SPHB_ERR_INVALID_ARGUMENT,
        "a context of another order"
    );
    unsafe {
        sphb_shadow_cluster_free(cl);
        sphb_shadow_context_free(cctx);
        sphb_shadow_context_free(ctx8);
    }
}
