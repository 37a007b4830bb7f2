//! Builders shared by the light tests: in-memory proxies of diffuse spheres and the uniform sky over a ground plane.
#![allow(dead_code)] // each test file uses a part

use spherebake_runtime::light::{clip_below_horizon, LightContext};
use spherebake_runtime::shadow::uniform_light;
use spherebake_runtime::{
    refit, rest_node_spheres, AlbedoSh, Hierarchy, HierarchyPlan, NodeLists, Proxy, SamplePoint, Samples, SphbFile,
    Sphere, GEODESIC_DIRECTIONS,
};

/// Sample j of sphere `s` on its surface in geodesic direction j, outward normal, rule 1.
pub fn surface_samples(s: &Sphere) -> Vec<SamplePoint> {
    GEODESIC_DIRECTIONS
        .iter()
        .enumerate()
        .map(|(j, d)| SamplePoint {
            position: [0, 1, 2].map(|q| s.center[q] + s.radius * d[q]),
            normal: *d,
            direction: j as u8,
            rule: 1,
        })
        .collect()
}

/// A proxy of diffuse spheres: [`surface_samples`] per sphere, constant linear albedo (DC only, order `order`).
pub fn sphere_proxy(spheres: &[(Sphere, [f32; 3])], order: usize) -> Proxy {
    Proxy::from_file(&sphere_file(spheres, order)).expect("valid proxy")
}

/// The file behind [`sphere_proxy`] (to edit before loading).
#[allow(dead_code)] // not every test binary uses it
pub fn sphere_file(spheres: &[(Sphere, [f32; 3])], order: usize) -> SphbFile {
    let nc = order * order;
    let mut per_sphere = Vec::new();
    let mut coefficients = Vec::new();
    for (s, albedo) in spheres {
        per_sphere.push(surface_samples(s));
        let dc = (4.0 * std::f64::consts::PI).sqrt() as f32;
        coefficients.push(albedo.map(|a| a * dc));
        coefficients.extend(std::iter::repeat_n([0.0; 3], nc - 1));
    }
    SphbFile {
        spheres: spheres.iter().map(|(s, _)| *s).collect(),
        samples: Some(Samples::from_per_sphere(per_sphere)),
        albedo_sh: Some(AlbedoSh { order: order as u8, coefficients, ..AlbedoSh::default() }),
        ..SphbFile::default()
    }
}

/// Uniform white sky of radiance 1 above the horizon of +Y (an infinite ground hides the rest), at the context's
/// order.
pub fn uniform_sky(ctx: &LightContext) -> Vec<f64> {
    let nc = ctx.order() * ctx.order();
    let mut l = vec![0.0; nc];
    uniform_light(ctx.order(), &mut l);
    let mut env = vec![0.0; nc];
    clip_below_horizon(ctx, &l, [0.0, 1.0, 0.0], &mut env).expect("order fits");
    env
}

/// A two-level hierarchy over `spheres`: one node per group of leaf indices, all under a root (the last node), node
/// spheres refitted to their leaves.
pub fn grouped_hierarchy(groups: &[Vec<u32>], spheres: &[Sphere]) -> Hierarchy {
    let mut nodes: Vec<NodeLists> = groups
        .iter()
        .map(|g| NodeLists { center: [0.0; 3], radius: 1.0, children: vec![], leaf_children: g.clone() })
        .collect();
    let k = nodes.len() as u32;
    nodes.push(NodeLists { center: [0.0; 3], radius: 1.0, children: (0..k).collect(), leaf_children: vec![] });
    let mut h = Hierarchy::from_lists(k, nodes);
    let plan = HierarchyPlan::new(&h).expect("a valid tree");
    let mut ns = rest_node_spheres(&h);
    refit(&plan, spheres, &mut ns).expect("one sphere per leaf");
    for (n, s) in h.nodes.iter_mut().zip(&ns) {
        n.center = s.center;
        n.radius = s.radius;
    }
    h
}
