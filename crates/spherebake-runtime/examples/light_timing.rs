//! Per-frame cost of the indirect-light passes on one core (`docs/benchmarks.md`, "Indirect light"):
//!
//! ```text
//! cargo run --release -p spherebake-runtime --example light_timing -- FILE.sphb [FILE.sphb ...]
//! ```
//!
//! For each file: pass 1 (`light_spheres`, the whole proxy at rest, uniform sky above the ground) as the median of 9
//! frames, and pass 2 per receiver (`IndirectCluster::irradiance`, 64 × 64 ground receivers under the model in 8 × 8
//! tiles, cluster builds excluded and reported separately), median of 5 sweeps. Single-threaded.

use spherebake_runtime::light::{
    clip_below_horizon, light_spheres, ClusterSpec, IndirectCluster, LightContext, Pass1Settings, PosedProxy,
    SphereLights,
};
use spherebake_runtime::shadow::{uniform_light, ExpMethod};
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    for path in std::env::args().skip(1) {
        let bytes = std::fs::read(&path).expect("read the file");
        let proxy = spherebake_runtime::load(&bytes).expect("a valid .sphb");
        let plan = proxy.hierarchy_plan();
        let nodes = proxy.hierarchy().map(spherebake_runtime::rest_node_spheres);
        let posed = PosedProxy {
            proxy: &proxy,
            leaves: proxy.spheres(),
            nodes: plan.as_ref().zip(nodes.as_deref()),
            rotations: None,
        };
        let ctx = LightContext::new(4, ExpMethod::default()).expect("order 4");
        let mut l = [0.0; 16];
        uniform_light(4, &mut l);
        let mut env = [0.0; 16];
        clip_below_horizon(&ctx, &l, [0.0, 1.0, 0.0], &mut env).expect("order 4");
        let mut lights = SphereLights::new();
        let mut pass1 = Vec::new();
        for _ in 0..9 {
            let t = Instant::now();
            light_spheres(&ctx, &posed, &env, &[], &Pass1Settings::default(), &mut lights).expect("pass 1");
            pass1.push(t.elapsed().as_secs_f64());
        }
        // Ground receivers: a square of 3 × the larger horizontal extent of the spheres, at their lowest point.
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for s in proxy.spheres() {
            for k in 0..3 {
                lo[k] = lo[k].min(s.center[k] - s.radius);
                hi[k] = hi[k].max(s.center[k] + s.radius);
            }
        }
        let side = 3.0 * (hi[0] - lo[0]).max(hi[2] - lo[2]);
        let (cx, cz) = (0.5 * (lo[0] + hi[0]), 0.5 * (lo[2] + hi[2]));
        let res = 64usize;
        let cell = side / res as f32;
        let at = |i: usize, j: usize| {
            [cx - 0.5 * side + (i as f32 + 0.5) * cell, lo[1], cz - 0.5 * side + (j as f32 + 0.5) * cell]
        };
        let sources = [(posed, &lights)];
        let mut sweeps = Vec::new();
        let mut builds = Vec::new();
        let mut checksum = 0.0;
        let mut lights_per_cluster = 0usize;
        for _ in 0..5 {
            let (mut t_build, mut t_query) = (0.0, 0.0);
            let mut cl = IndirectCluster::new();
            lights_per_cluster = 0;
            for tj in 0..res / 8 {
                for ti in 0..res / 8 {
                    let (a, b) = (at(ti * 8, tj * 8), at(ti * 8 + 7, tj * 8 + 7));
                    let c = [0.5 * (a[0] + b[0]), lo[1], 0.5 * (a[2] + b[2])];
                    let r = 0.5 * ((b[0] - a[0]).powi(2) + (b[2] - a[2]).powi(2)).sqrt();
                    let t = Instant::now();
                    cl.build(&ctx, &sources, &ClusterSpec::new(c, r, Some([0.0, 1.0, 0.0]))).expect("build");
                    t_build += t.elapsed().as_secs_f64();
                    lights_per_cluster += cl.light_count();
                    let t = Instant::now();
                    for j in tj * 8..tj * 8 + 8 {
                        for i in ti * 8..ti * 8 + 8 {
                            let e = cl.irradiance(&ctx, &sources, at(i, j), [0.0, 1.0, 0.0]).expect("query");
                            checksum += e[0];
                        }
                    }
                    t_query += t.elapsed().as_secs_f64();
                }
            }
            sweeps.push(t_query);
            builds.push(t_build);
        }
        let clusters = (res / 8) * (res / 8);
        println!(
            "{path}: {} spheres, {} samples: pass 1 {:.0} µs per frame (median of 9); pass 2 {:.0} ns per receiver, \
             cluster build {:.1} µs ({:.1} lights per cluster; medians of 5 sweeps of {} receivers; checksum {checksum:.3})",
            proxy.sphere_count(),
            lights.sample_radiance().len(),
            median(pass1) * 1e6,
            median(sweeps) / (res * res) as f64 * 1e9,
            median(builds) / clusters as f64 * 1e6,
            lights_per_cluster as f64 / clusters as f64,
            res * res,
        );
    }
}
