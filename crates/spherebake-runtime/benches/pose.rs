//! Micro-benchmark: pose + hierarchy refit of 256 spheres with 4 skin slots each over 32 bones
//! (target ≤ 5 µs on one core). Run: `cargo bench -p spherebake-runtime --bench pose`.

use criterion::{criterion_group, criterion_main, Criterion};
use spherebake_runtime::{pose, pose_and_refit, rest_node_spheres, HierarchyPlan, Proxy, Sphere};
use std::hint::black_box;

#[path = "common/pose_scene.rs"]
mod pose_scene;
use pose_scene::{file, joints, SPHERES};

fn bench(c: &mut Criterion) {
    let proxy = Proxy::from_file(&file()).expect("valid bench file");
    let plan = HierarchyPlan::new(proxy.hierarchy().expect("hierarchy")).expect("plan");
    let mut nodes = rest_node_spheres(proxy.hierarchy().expect("hierarchy"));
    let joints = joints();
    let mut leaves = vec![Sphere::default(); SPHERES];
    c.bench_function("pose 256 spheres x 4 slots", |b| {
        b.iter(|| pose(black_box(&proxy), black_box(&joints), &mut leaves).expect("pose"))
    });
    c.bench_function("pose + refit 256 spheres (85 nodes)", |b| {
        b.iter(|| pose_and_refit(black_box(&proxy), &plan, black_box(&joints), &mut leaves, &mut nodes).expect("pose"))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
