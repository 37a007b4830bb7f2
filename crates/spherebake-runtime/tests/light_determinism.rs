//! Determinism of the light passes: the same inputs give bit-identical results across repeated calls, across
//! fresh `LightContext` / `SphereLights` / `IndirectCluster` objects, after the objects served a proxy or a cluster
//! of another size, and whatever receivers were evaluated before (no state carries from one receiver to the next).

mod common;
use common::uniform_sky as sky;

use spherebake_runtime::light::{
    light_spheres, ClusterSpec, IndirectCluster, IndirectScratch, LightContext, Pass1Settings, PosedProxy, SphereLights,
};
use spherebake_runtime::shadow::ExpMethod;
use spherebake_runtime::{
    rest_node_spheres, AlbedoSh, HierarchyPlan, Proxy, SamplePoint, Samples, SphbFile, Sphere, GEODESIC_DIRECTIONS,
};

/// 5 × `groups` spheres in groups of 5 standing around the origin, samples on every other geodesic direction, albedo
/// with a band-1 tilt; with `hierarchy`, one node per group under a root (node spheres refitted to the leaves).
fn proxy_n(groups: usize, hierarchy: bool) -> Proxy {
    let mut spheres = Vec::new();
    for g in 0..groups {
        let a = g as f32 * std::f32::consts::TAU / groups as f32;
        for k in 0..5 {
            let r = 0.15 + 0.03 * k as f32;
            let rad = 1.5 + 0.35 * k as f32;
            spheres.push(Sphere { center: [rad * a.cos(), r + 0.2 * (k % 2) as f32, rad * a.sin()], radius: r });
        }
    }
    let order = 4;
    let mut per_sphere = Vec::new();
    let mut coefficients = Vec::new();
    for (i, s) in spheres.iter().enumerate() {
        per_sphere.push(
            GEODESIC_DIRECTIONS
                .iter()
                .enumerate()
                .filter(|(j, _)| (j + i) % 2 == 0)
                .map(|(j, d)| SamplePoint {
                    position: [0, 1, 2].map(|q| s.center[q] + s.radius * d[q]),
                    normal: *d,
                    direction: j as u8,
                    rule: 1,
                })
                .collect(),
        );
        let t = i as f32 / (5 * groups) as f32;
        coefficients.push([2.0 + t, 1.5, 2.5 - t]);
        coefficients.push([0.1, -0.2, 0.05]);
        coefficients.push([0.3 * t, 0.1, -0.1]);
        coefficients.push([-0.05, 0.2 * t, 0.0]);
        coefficients.extend(std::iter::repeat_n([0.01; 3], order * order - 4));
    }
    let leaf_groups: Vec<Vec<u32>> = (0..groups as u32).map(|g| (5 * g..5 * g + 5).collect()).collect();
    let hierarchy = hierarchy.then(|| common::grouped_hierarchy(&leaf_groups, &spheres));
    let file = SphbFile {
        spheres,
        hierarchy,
        samples: Some(Samples::from_per_sphere(per_sphere)),
        albedo_sh: Some(AlbedoSh { order: order as u8, coefficients, ..AlbedoSh::default() }),
        ..SphbFile::default()
    };
    Proxy::from_file(&file).expect("valid proxy")
}

/// A rotation about +Y by `a` radians, column-major.
fn rot_y(a: f32) -> [f32; 9] {
    let (s, c) = a.sin_cos();
    [c, 0.0, -s, 0.0, 1.0, 0.0, s, 0.0, c]
}

/// The pose `run` lights a proxy in: the rest node spheres of its hierarchy and a rotation about +Y of 0.05 i
/// radians for sphere i.
struct Pose {
    plan: Option<HierarchyPlan>,
    nodes: Option<Vec<Sphere>>,
    rotations: Vec<[f32; 9]>,
}

impl Pose {
    fn of(proxy: &Proxy) -> Pose {
        Pose {
            plan: proxy.hierarchy_plan(),
            nodes: proxy.hierarchy().map(rest_node_spheres),
            rotations: (0..proxy.sphere_count()).map(|i| rot_y(0.05 * i as f32)).collect(),
        }
    }

    fn posed<'a>(&'a self, proxy: &'a Proxy) -> PosedProxy<'a> {
        PosedProxy {
            nodes: self.plan.as_ref().zip(self.nodes.as_deref()),
            rotations: Some(&self.rotations),
            ..PosedProxy::at_rest(proxy)
        }
    }
}

/// Everything pass 1 produces, as bits: sample radiance, leaf and node lights.
fn pass1_bits(lights: &SphereLights, leaves: usize, nodes: usize) -> Vec<u32> {
    let mut out: Vec<u32> = lights.sample_radiance().iter().map(|v| v.to_bits()).collect();
    for i in 0..leaves {
        out.extend(lights.leaf(i).iter().flatten().map(|v| v.to_bits()));
    }
    for n in 0..nodes {
        out.extend(lights.node(n).iter().flatten().map(|v| v.to_bits()));
    }
    out
}

/// The tiles of the ground (centre x, z; θmax): a cut of nodes and leaves, all leaves, and a far one.
const TILES: [(f32, f32, f32); 3] = [(4.0, 1.0, 0.4363323), (0.5, 0.0, 0.0), (9.0, -3.0, 0.4363323)];

fn receivers(x0: f32, z0: f32) -> Vec<[f32; 3]> {
    (0..64).map(|k| [x0 - 1.0 + (k % 8) as f32 / 3.5, 0.0, z0 - 1.0 + (k / 8) as f32 / 3.5]).collect()
}

/// Pass 1 into `lights`, then pass 2 over the tiles through `cl`, receivers in order or reversed; all results as
/// bits (pass 1's first).
fn run(
    ctx: &LightContext,
    proxy: &Proxy,
    lights: &mut SphereLights,
    cl: &mut IndirectCluster,
    reversed: bool,
) -> (Vec<u32>, Vec<u64>) {
    let pose = Pose::of(proxy);
    let plan = &pose.plan;
    let posed = pose.posed(proxy);
    let env = sky(ctx);
    light_spheres(ctx, &posed, &env, &[], &Pass1Settings::default(), lights).unwrap();
    let p1 = pass1_bits(lights, proxy.sphere_count(), plan.as_ref().map_or(0, HierarchyPlan::node_count));
    let sources = [(posed, &*lights)];
    let up = [0.0f32, 1.0, 0.0];
    let mut p2 = Vec::new();
    for (x0, z0, theta) in TILES {
        let spec = ClusterSpec { theta_max_rad: theta, ..ClusterSpec::new([x0, 0.0, z0], 1.5, Some(up)) };
        cl.build(ctx, &sources, &spec).unwrap();
        let mut xs = receivers(x0, z0);
        if reversed {
            xs.reverse();
        }
        let mut vals: Vec<[u64; 3]> =
            xs.iter().map(|&x| cl.irradiance(ctx, &sources, x, up).unwrap().map(f64::to_bits)).collect();
        if reversed {
            vals.reverse();
        }
        p2.extend(vals.into_iter().flatten());
    }
    (p1, p2)
}

fn check(hierarchy: bool) {
    let proxy = proxy_n(8, hierarchy);
    let ctx = LightContext::new(4, ExpMethod::default()).unwrap();
    let mut lights = SphereLights::new();
    let mut cl = IndirectCluster::new();
    let first = run(&ctx, &proxy, &mut lights, &mut cl, false);
    assert!(first.1.iter().any(|&b| f64::from_bits(b) > 0.0), "something is lit");
    // Repeated with the same objects.
    let again = run(&ctx, &proxy, &mut lights, &mut cl, false);
    assert!(first == again, "repeated call differs (hierarchy {hierarchy})");
    // Receivers in reverse order.
    let rev = run(&ctx, &proxy, &mut lights, &mut cl, true);
    assert!(first == rev, "receiver order changes the values (hierarchy {hierarchy})");
    // Fresh context and buffers.
    let ctx2 = LightContext::new(4, ExpMethod::default()).unwrap();
    let fresh = run(&ctx2, &proxy, &mut SphereLights::new(), &mut IndirectCluster::new(), false);
    assert!(first == fresh, "fresh objects differ (hierarchy {hierarchy})");
    // Reuse after a larger and after a smaller proxy (other sphere and sample counts, other cuts).
    for groups in [12, 3] {
        let other = proxy_n(groups, !hierarchy);
        let mut l2 = SphereLights::new();
        let mut c2 = IndirectCluster::new();
        let o = run(&ctx, &other, &mut l2, &mut c2, false);
        assert!(o.0.len() != first.0.len(), "the other proxy has another size");
        let reused = run(&ctx, &proxy, &mut l2, &mut c2, false);
        assert!(first == reused, "reuse after a {groups}-group proxy differs (hierarchy {hierarchy})");
    }
    // A cluster built larger (all leaves of a bigger proxy) and then smaller, interleaved in one object.
    let big = proxy_n(12, hierarchy);
    let mut lb = SphereLights::new();
    let mut cb = IndirectCluster::new();
    run(&ctx, &big, &mut lb, &mut cb, false);
    let reused = run(&ctx, &proxy, &mut lights, &mut cb, false);
    assert!(first == reused, "cluster reuse after a larger build differs (hierarchy {hierarchy})");
}

#[test]
fn same_inputs_same_bits_without_hierarchy() {
    check(false);
}

#[test]
fn same_inputs_same_bits_with_hierarchy() {
    check(true);
}

/// A built cluster is shared by several threads, each querying its own receivers with its own scratch: every value
/// equals, bit for bit, the one the single-threaded `irradiance` gives, and one scratch carries nothing from a
/// cluster of other lights (or another proxy) to the next query.
#[test]
fn a_shared_cluster_answers_several_threads_as_one() {
    fn shared<T: Sync>(_: &T) {}
    let ctx = LightContext::new(4, ExpMethod::default()).unwrap();
    let up = [0.0f32, 1.0, 0.0];
    for hierarchy in [false, true] {
        let proxy = proxy_n(8, hierarchy);
        let mut lights = SphereLights::new();
        let mut cl = IndirectCluster::new();
        // The single-threaded values, tile after tile (pass 1 included; the posed proxy is rebuilt below as `run`
        // builds it).
        let (_, serial) = run(&ctx, &proxy, &mut lights, &mut cl, false);
        let pose = Pose::of(&proxy);
        let sources = [(pose.posed(&proxy), &lights)];
        // One scratch per thread, first used on another proxy's cluster (other lights, another count).
        let other = proxy_n(12, !hierarchy);
        let mut other_lights = SphereLights::new();
        let mut other_cl = IndirectCluster::new();
        run(&ctx, &other, &mut other_lights, &mut other_cl, false);
        let other_sources = [(PosedProxy::at_rest(&other), &other_lights)];
        let mut scratches = [IndirectScratch::new(), IndirectScratch::new(), IndirectScratch::new()];
        other_cl.build(&ctx, &other_sources, &ClusterSpec::new([1.0, 0.0, 0.5], 1.5, Some(up))).unwrap();
        assert!(other_cl.light_count() > 0);
        for s in &mut scratches {
            other_cl.irradiance_with(s, &ctx, &other_sources, [0.3, 0.0, 0.2], up).unwrap();
        }
        let mut parallel = Vec::new();
        for (x0, z0, theta) in TILES {
            let spec = ClusterSpec { theta_max_rad: theta, ..ClusterSpec::new([x0, 0.0, z0], 1.5, Some(up)) };
            cl.build(&ctx, &sources, &spec).unwrap();
            let xs = receivers(x0, z0);
            let (cl, ctx, sources) = (&cl, &ctx, &sources);
            shared(cl);
            // Thread t takes receivers t, t + 3, …; all run at once on the one cluster.
            let parts: Vec<Vec<(usize, [u64; 3])>> = std::thread::scope(|scope| {
                let handles: Vec<_> = scratches
                    .iter_mut()
                    .enumerate()
                    .map(|(t, scratch)| {
                        let xs = &xs;
                        scope.spawn(move || {
                            (t..xs.len())
                                .step_by(3)
                                .map(|i| {
                                    let e = cl.irradiance_with(scratch, ctx, sources, xs[i], up).unwrap();
                                    (i, e.map(f64::to_bits))
                                })
                                .collect()
                        })
                    })
                    .collect();
                handles.into_iter().map(|h| h.join().unwrap()).collect()
            });
            let mut vals = vec![[0u64; 3]; xs.len()];
            for (i, v) in parts.into_iter().flatten() {
                vals[i] = v;
            }
            parallel.extend(vals.into_iter().flatten());
        }
        assert_eq!(parallel.len(), serial.len());
        let differ = parallel.iter().zip(&serial).filter(|(a, b)| a != b).count();
        assert_eq!(
            differ,
            0,
            "{differ} of {} values differ from the single-threaded ones (hierarchy {hierarchy})",
            serial.len()
        );
    }
}

#[test]
fn different_inputs_different_bits() {
    // The comparison above can see a difference: move one sphere by 1e-3 and the values change.
    let proxy = proxy_n(8, true);
    let mut file = proxy.file().clone();
    file.spheres[3].center[0] += 1e-3;
    let moved = Proxy::from_file(&file).unwrap();
    let ctx = LightContext::new(4, ExpMethod::default()).unwrap();
    let a = run(&ctx, &proxy, &mut SphereLights::new(), &mut IndirectCluster::new(), false);
    let b = run(&ctx, &moved, &mut SphereLights::new(), &mut IndirectCluster::new(), false);
    assert!(a.1 != b.1, "moving a sphere must change pass 2");
}

/// A failed build leaves the cluster not built, never half-built: its queries refuse instead of answering from the
/// lights of the build before or from the part the failed one assembled; and a query with other sources than the
/// build's is refused.
#[test]
fn a_failed_build_leaves_no_lights_and_queries_check_their_sources() {
    use spherebake_runtime::light::LightError;
    use spherebake_runtime::shadow::ShadowError;
    let ctx = LightContext::new(4, ExpMethod::default()).unwrap();
    let (a, b) = (proxy_n(8, true), proxy_n(4, false));
    let env = sky(&ctx);
    let (mut la, mut lb) = (SphereLights::new(), SphereLights::new());
    let (pa, pb) = (PosedProxy::at_rest(&a), PosedProxy::at_rest(&b));
    light_spheres(&ctx, &pa, &env, &[], &Pass1Settings::default(), &mut la).unwrap();
    light_spheres(&ctx, &pb, &env, &[], &Pass1Settings::default(), &mut lb).unwrap();
    let up = [0.0f32, 1.0, 0.0];
    let spec = ClusterSpec::new([0.0, 0.0, 0.0], 1.5, Some(up));
    let mut cl = IndirectCluster::new();
    let not_built = |r: Result<[f64; 3], LightError>| matches!(r, Err(LightError::Shadow(ShadowError::NotBuilt)));
    assert!(not_built(cl.irradiance(&ctx, &[(pa, &la)], [0.0; 3], up)));
    cl.build(&ctx, &[(pa, &la)], &spec).unwrap();
    let lit = cl.irradiance(&ctx, &[(pa, &la)], [0.0; 3], up).unwrap();
    assert!(lit.iter().all(|&v| v > 0.0), "{lit:?}");
    // Other sources than the build's: the other proxy, two sources, none.
    // The build's proxy with another proxy's lights, too (as build refuses that pairing).
    for other in [&[(pb, &lb)][..], &[(pa, &la), (pb, &lb)][..], &[][..], &[(pa, &lb)][..]] {
        assert!(
            matches!(cl.irradiance(&ctx, other, [0.0; 3], up), Err(LightError::Mismatch { .. })),
            "{} sources",
            other.len()
        );
    }
    // The second source's lights are another proxy's: the build fails after the first source's lights went in.
    assert!(cl.build(&ctx, &[(pa, &la), (pb, &la)], &spec).is_err());
    assert_eq!(cl.light_count(), 0);
    assert!(not_built(cl.irradiance(&ctx, &[(pa, &la)], [0.0; 3], up)));
    assert!(not_built(cl.irradiance(&ctx, &[(pa, &la), (pb, &la)], [0.0; 3], up)));
    // A radius or θmax out of range fails the build the same way.
    for bad in [
        ClusterSpec { radius: f32::NAN, ..spec },
        ClusterSpec { radius: -1.0, ..spec },
        ClusterSpec { theta_max_rad: f32::NAN, ..spec },
        ClusterSpec { theta_max_rad: 4.0, ..spec },
        ClusterSpec { center: [f32::INFINITY, 0.0, 0.0], ..spec },
    ] {
        cl.build(&ctx, &[(pa, &la)], &spec).unwrap();
        assert!(cl.build(&ctx, &[(pa, &la)], &bad).is_err(), "{bad:?}");
        assert!(not_built(cl.irradiance(&ctx, &[(pa, &la)], [0.0; 3], up)), "{bad:?}");
    }
    // Rebuilt, it answers as before; a receiver that is not finite is refused.
    cl.build(&ctx, &[(pa, &la)], &spec).unwrap();
    assert_eq!(cl.irradiance(&ctx, &[(pa, &la)], [0.0; 3], up).unwrap(), lit);
    assert!(cl.irradiance(&ctx, &[(pa, &la)], [f32::NAN, 0.0, 0.0], up).is_err());
}
