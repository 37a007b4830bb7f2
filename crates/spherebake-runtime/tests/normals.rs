//! Normals given to the queries need not be unit (an engine's interpolated vertex normals are not): each query
//! scales them to unit length, so a normal and any positive multiple of it give the same answer, and a normal with
//! no direction (zero, NaN, ∞) is an argument error, not a silent 0 or a value ten times too large. Before, the
//! indirect irradiance took |n| = 100 as given (E 100× too large), and a zero normal gave E = 0 with `Ok`.

mod common;

use spherebake_runtime::light::{
    clip_below_horizon, light_spheres, ClusterSpec, IndirectCluster, LightContext, LightError, Pass1Settings,
    PosedProxy, SphereLights,
};
use spherebake_runtime::shadow::{
    accumulate_log_visibility, uniform_light, ClusterBlockers, ExpMethod, ShadowContext, ShadowError,
};
use spherebake_runtime::Sphere;

const SCALES: [f32; 4] = [1e-3, 0.5, 7.0, 100.0];
const NO_DIRECTION: [[f32; 3]; 3] = [[0.0; 3], [f32::NAN, 1.0, 0.0], [0.0, f32::INFINITY, 0.0]];

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-5 * b.abs().max(1e-12)
}

#[test]
fn indirect_irradiance_and_its_cluster_take_any_length_of_normal() {
    let proxy = common::sphere_proxy(&[(Sphere { center: [0.0, 1.0, 0.0], radius: 0.5 }, [0.8, 0.5, 0.3])], 4);
    let ctx = LightContext::new(4, ExpMethod::default()).unwrap();
    let env = common::uniform_sky(&ctx);
    let posed = PosedProxy::at_rest(&proxy);
    let mut lights = SphereLights::new();
    light_spheres(&ctx, &posed, &env, &[], &Pass1Settings::default(), &mut lights).unwrap();
    let sources = [(posed, &lights)];
    let (p, n) = ([0.6f32, 0.0, 0.2], [0.3f32, 0.9, -0.1]);
    let len = n.iter().map(|v| v * v).sum::<f32>().sqrt();
    let unit = n.map(|v| v / len);
    let mut cl = IndirectCluster::new();
    cl.build(&ctx, &sources, &ClusterSpec::new(p, 0.1, Some(unit))).unwrap();
    let want = cl.irradiance(&ctx, &sources, p, unit).unwrap();
    assert!(want[0] > 1e-3, "the sphere lights the receiver: {want:?}");
    for s in SCALES {
        let m = unit.map(|v| v * s);
        cl.build(&ctx, &sources, &ClusterSpec::new(p, 0.1, Some(m))).unwrap();
        let got = cl.irradiance(&ctx, &sources, p, m).unwrap();
        for c in 0..3 {
            assert!(close(got[c], want[c]), "normal scaled by {s}: {got:?} against {want:?}");
        }
    }
    for bad in NO_DIRECTION {
        // A failed build leaves the cluster unbuilt: build it again before each query.
        cl.build(&ctx, &sources, &ClusterSpec::new(p, 0.1, Some(unit))).unwrap();
        let e = cl.irradiance(&ctx, &sources, p, bad);
        assert!(matches!(e, Err(LightError::Shadow(ShadowError::Argument { .. }))), "{bad:?}: {e:?}");
        let e = cl.build(&ctx, &sources, &ClusterSpec::new(p, 0.1, Some(bad)));
        assert!(matches!(e, Err(LightError::Shadow(ShadowError::Argument { .. }))), "{bad:?}: {e:?}");
    }
}

#[test]
fn shadows_and_the_horizon_take_any_length_of_normal() {
    let order = 4;
    let ctx = ShadowContext::new(order, ExpMethod::default()).unwrap();
    let mut cb = ClusterBlockers::new();
    let blockers = [Sphere { center: [0.2, 1.0, 0.0], radius: 0.4 }];
    cb.build(order, &blockers, None, [0.0; 3], 0.0, 0.4363323).unwrap();
    let mut light = vec![0.0; order * order];
    uniform_light(order, &mut light);
    let n = [0.2f32, 1.0, 0.1];
    let len = n.iter().map(|v| v * v).sum::<f32>().sqrt();
    let unit = n.map(|v| v / len);
    let t_of = |m: [f32; 3]| {
        let mut t = vec![0.0; order * order];
        ctx.shading_vector(&light, m.map(f64::from), &mut t).map(|()| t)
    };
    let t = t_of(unit).unwrap();
    let want = ctx.shade_point(&cb, [0.0; 3], unit, &t).unwrap();
    assert!(want > 0.1 && want < 0.99, "partly shadowed: {want}");
    for s in SCALES {
        let m = unit.map(|v| v * s);
        let ts = t_of(m).unwrap();
        assert!(ts.iter().zip(&t).all(|(a, b)| (a - b).abs() <= 1e-6), "shading vector, normal scaled by {s}");
        let got = ctx.shade_point(&cb, [0.0; 3], m, &t).unwrap();
        assert!(close(got, want), "shade_point, normal scaled by {s}: {got} against {want}");
    }
    // The log accumulation and the overlap correction (self-shadowing rules about the normal).
    let log_of = |m: [f32; 3]| {
        let mut log = vec![0.0f32; order * order];
        accumulate_log_visibility(cb.blockers(), order, [0.0; 3], Some(m), &mut log).map(|_| log)
    };
    let want_log = log_of(unit).unwrap();
    let scale_of = |m: [f32; 3]| cb.clone().correct_overlap(&ctx, [0.0; 3], m, 64);
    let want_scale = scale_of(unit).unwrap();
    for s in SCALES {
        let m = unit.map(|v| v * s);
        let got = log_of(m).unwrap();
        assert!(got.iter().zip(&want_log).all(|(a, b)| (a - b).abs() <= 1e-5), "log, normal scaled by {s}");
        assert_eq!(scale_of(m).unwrap(), want_scale, "overlap scale, normal scaled by {s}");
    }
    for bad in NO_DIRECTION {
        assert!(matches!(log_of(bad), Err(ShadowError::Argument { .. })), "{bad:?}");
        assert!(matches!(scale_of(bad), Err(ShadowError::Argument { .. })), "{bad:?}");
        assert!(matches!(t_of(bad), Err(ShadowError::Argument { .. })), "{bad:?}");
        assert!(matches!(ctx.shade_point(&cb, [0.0; 3], bad, &t), Err(ShadowError::Argument { .. })), "{bad:?}");
    }
    // The horizon: the up direction at any length gives the same clipped sky.
    let lctx = LightContext::new(order, ExpMethod::default()).unwrap();
    let clip = |up: [f64; 3]| {
        let mut out = vec![0.0; order * order];
        clip_below_horizon(&lctx, &light, up, &mut out).map(|()| out)
    };
    let want = clip([0.0, 1.0, 0.0]).unwrap();
    let got = clip([0.0, 5.0, 0.0]).unwrap();
    assert!(got.iter().zip(&want).all(|(a, b)| (a - b).abs() <= 1e-12));
    for bad in NO_DIRECTION {
        assert!(matches!(clip(bad.map(f64::from)), Err(LightError::Shadow(ShadowError::Argument { .. }))), "{bad:?}");
    }
}

/// Spheres that are not spheres (a NaN centre from a bad joint matrix, a negative or infinite radius) are refused by
/// the shadow cluster's build and by the light passes, instead of giving plausible-looking values.
#[test]
fn builds_refuse_spheres_that_are_not_finite() {
    let good = Sphere { center: [0.0, 1.0, 0.0], radius: 0.5 };
    let bad = [
        Sphere { center: [f32::NAN, 1.0, 0.0], radius: 0.5 },
        Sphere { center: [0.0, f32::INFINITY, 0.0], radius: 0.5 },
        Sphere { center: [0.0, 1.0, 0.0], radius: -1.0 },
        Sphere { center: [0.0, 1.0, 0.0], radius: f32::NAN },
    ];
    let mut cb = ClusterBlockers::new();
    cb.build(4, &[good, good], None, [0.0; 3], 0.0, 0.4363323).unwrap();
    for b in bad {
        let e = cb.build(4, &[good, b], None, [0.0; 3], 0.0, 0.4363323);
        assert!(matches!(e, Err(ShadowError::Argument { argument: "leaves", .. })), "{b:?}: {e:?}");
    }
    let proxy = common::sphere_proxy(&[(good, [0.8, 0.5, 0.3]), (good, [0.8, 0.5, 0.3])], 4);
    let ctx = LightContext::new(4, ExpMethod::default()).unwrap();
    let env = common::uniform_sky(&ctx);
    let mut lights = SphereLights::new();
    for b in bad {
        let leaves = [good, b];
        let posed = PosedProxy { leaves: &leaves, ..PosedProxy::at_rest(&proxy) };
        let e = light_spheres(&ctx, &posed, &env, &[], &Pass1Settings::default(), &mut lights);
        assert!(matches!(e, Err(LightError::Shadow(ShadowError::Argument { argument: "leaves", .. }))), "{b:?}: {e:?}");
    }
}
