//! Minimum wall time of pose and pose + refit (256 spheres, 4 slots, 32 bones, 85 nodes) over
//! many single calls: on a shared, loaded machine the minimum approximates the uncontended
//! time better than criterion's mean. Run: `cargo run --release -p spherebake-runtime --example pose_timing`.

use spherebake_runtime::{pose, pose_and_refit, rest_node_spheres, HierarchyPlan, Proxy, Sphere};
use std::hint::black_box;
use std::time::Instant;

#[path = "../benches/common/pose_scene.rs"]
mod pose_scene;
use pose_scene::{file, joints, K, SPHERES};

fn main() {
    let proxy = Proxy::from_file(&file()).expect("valid file");
    let plan = HierarchyPlan::new(proxy.hierarchy().expect("hierarchy")).expect("plan");
    let mut nodes = rest_node_spheres(proxy.hierarchy().expect("hierarchy"));
    let joints = joints();
    let mut leaves = vec![Sphere::default(); SPHERES];
    let (mut best_pose, mut best_both) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..20_000 {
        let t = Instant::now();
        pose(black_box(&proxy), black_box(&joints), &mut leaves).expect("pose");
        best_pose = best_pose.min(t.elapsed().as_secs_f64());
        let t = Instant::now();
        pose_and_refit(black_box(&proxy), &plan, black_box(&joints), &mut leaves, &mut nodes).expect("pose");
        best_both = best_both.min(t.elapsed().as_secs_f64());
    }
    println!("pose {SPHERES} spheres x {K} slots: min {:.2} µs", best_pose * 1e6);
    println!("pose + refit ({} nodes): min {:.2} µs", plan.node_count(), best_both * 1e6);
}
