//! Empty spheres in the hierarchy. A fit leaves the spheres it finds no use for empty: radius `f32::MIN_POSITIVE`
//! at some centre, and files baked before 2026-12-06 (or by another writer) may still give them samples. A node
//! holding only such leaves got a light of 10⁻⁷⁵ × theirs and a rotation from Σ (r_j / r_N)² R_j ≈ 10⁻⁷⁵ I that
//! the polar iteration did not converge from, so pass 2 read NaN from it and a cut that took the node lit every
//! receiver with 0 (the capsule fixture at 64 spheres: ground irradiance 0 against the path tracer's 0.12). Here two real spheres and two empty ones, each pair under its own node: at a receiver
//! where the cut takes the empty pair's node and splits the real pair, the irradiance must be the leaves-only
//! value (θmax = 0, where pass 2's Ṽ₀ cutoff skips the empty leaves), and every node's light finite.

mod common;

use spherebake_runtime::light::{
    clip_below_horizon, light_spheres, ClusterSpec, IndirectCluster, LightContext, Pass1Settings, PosedProxy,
    SphereLights,
};
use spherebake_runtime::shadow::{uniform_light, ExpMethod};
use spherebake_runtime::{rest_node_spheres, AlbedoSh, Proxy, Samples, SphbFile, Sphere};

#[test]
fn nodes_of_empty_spheres_with_samples_light_like_their_leaves() {
    let order = 4;
    let real = [Sphere { center: [-0.35, 1.0, 0.0], radius: 0.3 }, Sphere { center: [0.35, 1.0, 0.0], radius: 0.3 }];
    let empty = [
        Sphere { center: [0.0, 1.0, 0.25], radius: f32::MIN_POSITIVE },
        Sphere { center: [0.0, 1.0, -0.25], radius: f32::MIN_POSITIVE },
    ];
    let spheres: Vec<Sphere> = real.iter().chain(&empty).copied().collect();
    // Samples on every sphere's surface; the empty ones' on the surface of radius 0.3 about their centre (what a
    // bake sees from there), each standing for a 92nd of that sphere's area.
    let mut per_sphere = Vec::new();
    let mut areas = Vec::new();
    for s in &spheres {
        let seen = Sphere { center: s.center, radius: 0.3 };
        let pts = common::surface_samples(&seen);
        areas.extend(std::iter::repeat_n(4.0 * std::f32::consts::PI * 0.09 / 92.0, pts.len()));
        per_sphere.push(pts);
    }
    let mut samples = Samples::from_per_sphere(per_sphere);
    samples.areas = Some(areas);
    let dc = (4.0 * std::f64::consts::PI).sqrt() as f32;
    let mut coefficients = Vec::new();
    for _ in &spheres {
        coefficients.push([0.8 * dc, 0.5 * dc, 0.3 * dc]);
        coefficients.extend(std::iter::repeat_n([0.0; 3], order * order - 1));
    }
    let file = SphbFile {
        spheres: spheres.clone(),
        hierarchy: Some(common::grouped_hierarchy(&[vec![0, 1], vec![2, 3]], &spheres)),
        samples: Some(samples),
        albedo_sh: Some(AlbedoSh { order: order as u8, coefficients, ..AlbedoSh::default() }),
        ..SphbFile::default()
    };
    let proxy = Proxy::from_file(&file).expect("valid proxy");
    let plan = proxy.hierarchy_plan().unwrap();
    let nodes = rest_node_spheres(proxy.hierarchy().unwrap());
    let ctx = LightContext::new(order, ExpMethod::default()).unwrap();
    let mut l = vec![0.0; order * order];
    uniform_light(order, &mut l);
    let mut env = vec![0.0; order * order];
    clip_below_horizon(&ctx, &l, [0.0, 1.0, 0.0], &mut env).unwrap();
    let posed = PosedProxy { nodes: Some((&plan, &nodes)), ..PosedProxy::at_rest(&proxy) };
    let mut lights = SphereLights::new();
    light_spheres(&ctx, &posed, &env, &[], &Pass1Settings { theta_max_rad: 0.0 }, &mut lights).unwrap();
    for n in 0..nodes.len() {
        assert!(lights.node(n).iter().flatten().all(|v| v.is_finite()), "node {n}: {:?}", lights.node(n));
    }
    let sources = [(posed, &lights)];
    let up = [0.0f32, 1.0, 0.0];
    let mut cl = IndirectCluster::new();
    // Receivers on the ground below the pair: the real pair's node (radius ≈ 0.65 at distance ≈ 1) is split at
    // θmax = 25°, the empty pair's (radius 0.25) is taken whole.
    for x in [[0.0f32, 0.0, 0.0], [0.3, 0.0, 0.2], [-0.4, 0.0, -0.3]] {
        cl.build(&ctx, &sources, &ClusterSpec::new(x, 0.1, Some(up))).unwrap();
        assert_eq!(cl.light_count(), 3, "the cut: two real leaves and the empty pair's node");
        let cut = cl.irradiance(&ctx, &sources, x, up).unwrap();
        let spec = ClusterSpec { theta_max_rad: 0.0, ..ClusterSpec::new(x, 0.1, Some(up)) };
        cl.build(&ctx, &sources, &spec).unwrap();
        assert_eq!(cl.light_count(), 4);
        let leaves = cl.irradiance(&ctx, &sources, x, up).unwrap();
        for c in 0..3 {
            assert!(leaves[c] > 0.01, "receiver {x:?}: the real spheres light it: {leaves:?}");
            assert!((cut[c] / leaves[c] - 1.0).abs() < 1e-3, "receiver {x:?}: cut {cut:?} against leaves {leaves:?}");
        }
    }
}
