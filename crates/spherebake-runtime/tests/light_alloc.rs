//! The light passes do not allocate per receiver: a counting global allocator around many
//! `IndirectCluster::irradiance` and `irradiance_with` calls (after a first call has grown the buffers) for a proxy of 40 spheres with and
//! without a hierarchy, around a second `light_spheres` frame of the same size, and around the rebuild of a cluster
//! of the same size. The counter (`counting_alloc`) is per thread, so the parallel tests do not see each other's allocations.

mod common;
use common::uniform_sky as sky;

use spherebake_runtime::light::{
    light_spheres, ClusterSpec, IndirectCluster, IndirectScratch, LightContext, Pass1Settings, PosedProxy, SphereLights,
};
use spherebake_runtime::shadow::ExpMethod;
use spherebake_runtime::{
    refit, rest_node_spheres, AlbedoSh, Proxy, SamplePoint, Samples, SphbFile, Sphere, GEODESIC_DIRECTIONS,
};
mod counting_alloc;
use counting_alloc::allocs;

/// 40 spheres in 8 groups of 5 standing around the origin, samples on every other geodesic direction, albedo
/// with a band-1 tilt; with `hierarchy`, one node per group under a root (node spheres refitted to the leaves).
fn proxy40(hierarchy: bool) -> Proxy {
    let mut spheres = Vec::new();
    for g in 0..8 {
        let a = g as f32 * std::f32::consts::TAU / 8.0;
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
        let t = i as f32 / 40.0;
        coefficients.push([2.0 + t, 1.5, 2.5 - t]);
        coefficients.push([0.1, -0.2, 0.05]);
        coefficients.push([0.3 * t, 0.1, -0.1]);
        coefficients.push([-0.05, 0.2 * t, 0.0]);
        coefficients.extend(std::iter::repeat_n([0.01; 3], order * order - 4));
    }
    let groups: Vec<Vec<u32>> = (0..8u32).map(|g| (5 * g..5 * g + 5).collect()).collect();
    let hierarchy = hierarchy.then(|| common::grouped_hierarchy(&groups, &spheres));
    let file = SphbFile {
        spheres,
        hierarchy,
        samples: Some(Samples::from_per_sphere(per_sphere)),
        albedo_sh: Some(AlbedoSh { order: order as u8, coefficients, ..AlbedoSh::default() }),
        ..SphbFile::default()
    };
    Proxy::from_file(&file).expect("valid proxy")
}

/// Ground receivers of a 2 × 2 tile centred at (x0, 0, z0).
fn receivers(x0: f32, z0: f32) -> Vec<[f32; 3]> {
    (0..256).map(|k| [x0 - 1.0 + (k % 16) as f32 / 7.5, 0.0, z0 - 1.0 + (k / 16) as f32 / 7.5]).collect()
}

fn check_irradiance_is_allocation_free(hierarchy: bool) {
    let proxy = proxy40(hierarchy);
    let plan = proxy.hierarchy_plan();
    assert_eq!(plan.is_some(), hierarchy);
    let nodes = proxy.hierarchy().map(rest_node_spheres);
    let ctx = LightContext::new(4, ExpMethod::default()).unwrap();
    let env = sky(&ctx);
    let posed = PosedProxy { nodes: plan.as_ref().zip(nodes.as_deref()), ..PosedProxy::at_rest(&proxy) };
    let mut lights = SphereLights::new();
    light_spheres(&ctx, &posed, &env, &[], &Pass1Settings::default(), &mut lights).unwrap();
    let sources = [(posed, &lights)];
    let up = [0.0f32, 1.0, 0.0];
    let mut cl = IndirectCluster::new();
    // Tiles near the group (a cut of leaves and nodes, nearer blockers: every branch of eq. 23) and far out (the
    // root alone, or all lights when no node is accepted).
    for (x0, z0, theta) in
        [(2.2f32, 0.3f32, 0.4363323f32), (0.0, 0.0, 0.4363323), (9.0, 4.0, 0.4363323), (2.0, 1.0, 0.0)]
    {
        let spec = ClusterSpec { theta_max_rad: theta, ..ClusterSpec::new([x0, 0.0, z0], 1.5, Some(up)) };
        cl.build(&ctx, &sources, &spec).unwrap();
        let xs = receivers(x0, z0);
        let first = cl.irradiance(&ctx, &sources, xs[0], up).unwrap();
        let before = allocs();
        let mut sum = [0.0f64; 3];
        for &x in &xs {
            let e = cl.irradiance(&ctx, &sources, x, up).unwrap();
            for c in 0..3 {
                sum[c] += e[c];
            }
        }
        let after = allocs();
        println!(
            "hierarchy {hierarchy}, tile ({x0}, {z0}), θmax {theta}: {} lights, {} allocations over {} receivers",
            cl.light_count(),
            after - before,
            xs.len()
        );
        assert_eq!(after, before, "irradiance allocated (hierarchy {hierarchy}, tile ({x0}, {z0}))");
        // The shared-cluster query, with a scratch grown by its first call.
        let mut scratch = IndirectScratch::new();
        cl.irradiance_with(&mut scratch, &ctx, &sources, xs[0], up).unwrap();
        let before = allocs();
        for &x in &xs {
            cl.irradiance_with(&mut scratch, &ctx, &sources, x, up).unwrap();
        }
        assert_eq!(allocs(), before, "irradiance_with allocated (hierarchy {hierarchy}, tile ({x0}, {z0}))");
        assert!(first.iter().all(|v| v.is_finite()) && sum.iter().all(|&v| v > 0.0), "{sum:?}");
    }
}

#[test]
fn irradiance_does_not_allocate_per_receiver_without_hierarchy() {
    check_irradiance_is_allocation_free(false);
}

#[test]
fn irradiance_does_not_allocate_per_receiver_with_hierarchy() {
    check_irradiance_is_allocation_free(true);
}

#[test]
fn second_pass1_frame_of_the_same_size_does_not_allocate() {
    for hierarchy in [false, true] {
        let proxy = proxy40(hierarchy);
        let plan = proxy.hierarchy_plan();
        let nodes = proxy.hierarchy().map(rest_node_spheres);
        let ctx = LightContext::new(4, ExpMethod::default()).unwrap();
        let env = sky(&ctx);
        // A second proxy, shifted, as `others`.
        let shifted: Vec<Sphere> = proxy
            .spheres()
            .iter()
            .map(|s| Sphere { center: [s.center[0] + 6.0, s.center[1], s.center[2]], radius: s.radius })
            .collect();
        let other = PosedProxy { leaves: &shifted, ..PosedProxy::at_rest(&proxy) };
        let posed = PosedProxy { nodes: plan.as_ref().zip(nodes.as_deref()), ..PosedProxy::at_rest(&proxy) };
        let mut lights = SphereLights::new();
        light_spheres(&ctx, &posed, &env, &[other], &Pass1Settings::default(), &mut lights).unwrap();
        // The next frame: the leaves moved a little (same sizes everywhere).
        let moved: Vec<Sphere> = proxy
            .spheres()
            .iter()
            .map(|s| Sphere { center: [s.center[0] + 0.1, s.center[1], s.center[2] - 0.05], radius: s.radius })
            .collect();
        let mut moved_nodes = nodes.clone();
        if let (Some(p), Some(n)) = (plan.as_ref(), moved_nodes.as_mut()) {
            refit(p, &moved, n).unwrap();
        }
        let posed2 = PosedProxy {
            leaves: &moved,
            nodes: plan.as_ref().zip(moved_nodes.as_deref()),
            ..PosedProxy::at_rest(&proxy)
        };
        let before = allocs();
        let stats = light_spheres(&ctx, &posed2, &env, &[other], &Pass1Settings::default(), &mut lights).unwrap();
        let after = allocs();
        println!("hierarchy {hierarchy}: second frame, {} samples, {} allocations", stats.samples, after - before);
        assert_eq!(after, before, "light_spheres allocated on a frame of the same size (hierarchy {hierarchy})");
        assert_eq!(stats.samples, 40 * 46);
        assert!(lights.leaf(0).iter().all(|c| c.iter().all(|v| v.is_finite())));
    }
}

/// Allocations of the second of two identical builds of a tile whose cut accepts nodes (reflection ratios computed
/// for each): the group nodes in the hierarchy, the implicit root without one.
fn rebuild_allocations(hierarchy: bool) -> (usize, usize) {
    let proxy = proxy40(hierarchy);
    let plan = proxy.hierarchy_plan();
    let nodes = proxy.hierarchy().map(rest_node_spheres);
    let ctx = LightContext::new(4, ExpMethod::default()).unwrap();
    let env = sky(&ctx);
    let posed = PosedProxy { nodes: plan.as_ref().zip(nodes.as_deref()), ..PosedProxy::at_rest(&proxy) };
    let mut lights = SphereLights::new();
    light_spheres(&ctx, &posed, &env, &[], &Pass1Settings::default(), &mut lights).unwrap();
    let sources = [(posed, &lights)];
    let up = [0.0f32, 1.0, 0.0];
    let x0 = if hierarchy { 6.0 } else { 12.0 };
    let spec = ClusterSpec::new([x0, 0.0, 2.0], 1.0, Some(up));
    let mut cl = IndirectCluster::new();
    cl.build(&ctx, &sources, &spec).unwrap();
    let n = cl.light_count();
    assert!(n < 40, "the cut must accept nodes: {n} lights");
    let before = allocs();
    cl.build(&ctx, &sources, &spec).unwrap();
    let after = allocs();
    println!("hierarchy {hierarchy}: rebuild of a {n}-light cluster, {} allocations", after - before);
    (n, after - before)
}

#[test]
fn rebuilding_a_cluster_of_the_same_size_does_not_allocate() {
    // Module docs: "builds allocate only while buffers grow". A second build of the same cluster (the implicit
    // root accepted, its reflection ratio computed) must find every buffer large enough.
    let (n, allocations) = rebuild_allocations(false);
    assert_eq!(n, 1);
    assert_eq!(allocations, 0, "rebuilding a cluster of the same size allocated");
}

#[test]
fn the_counter_sees_allocations() {
    // The zero counts above mean something: a build into fresh buffers is seen (plain allocations:
    // `counting_alloc`'s own test).
    let (_, fresh) = {
        let proxy = proxy40(false);
        let ctx = LightContext::new(4, ExpMethod::default()).unwrap();
        let env = sky(&ctx);
        let posed = PosedProxy::at_rest(&proxy);
        let mut lights = SphereLights::new();
        light_spheres(&ctx, &posed, &env, &[], &Pass1Settings::default(), &mut lights).unwrap();
        let sources = [(posed, &lights)];
        let mut cl = IndirectCluster::new();
        let before = allocs();
        cl.build(&ctx, &sources, &ClusterSpec::new([0.0; 3], 1.0, Some([0.0, 1.0, 0.0]))).unwrap();
        (cl.light_count(), allocs() - before)
    };
    assert!(fresh > 0, "a first build grows its buffers");
}

#[test]
fn rebuilding_a_hierarchy_cluster_of_the_same_size_does_not_allocate() {
    let (n, allocations) = rebuild_allocations(true);
    assert_eq!(n, 8);
    assert_eq!(allocations, 0);
}
