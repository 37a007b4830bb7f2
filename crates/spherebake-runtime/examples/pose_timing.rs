//! Minimum wall time of pose and pose + refit (256 spheres, 4 slots, 32 bones, 85 nodes) over
//! many single calls: on a shared, loaded machine the minimum approximates the uncontended
//! time better than criterion's mean. Run: `cargo run --release -p spherebake-runtime --example pose_timing`.

use spherebake_runtime::{
    pose, pose_and_refit, rest_node_spheres, BoneRecord, Hierarchy, HierarchyNode, HierarchyPlan, Proxy, SkinEntry,
    SkinTerms, SphbFile, Sphere,
};
use std::hint::black_box;
use std::time::Instant;

const SPHERES: usize = 256;
const BONES: usize = 32;
const K: usize = 4;

fn file() -> SphbFile {
    let mut s = 0x9E37_79B9_7F4A_7C15_u64;
    let mut rnd = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    let spheres: Vec<Sphere> =
        (0..SPHERES).map(|_| Sphere { center: [rnd(), rnd(), rnd()], radius: 0.05 + 0.05 * rnd() }).collect();
    let mut entries = Vec::with_capacity(SPHERES * K);
    for sp in &spheres {
        for _ in 0..K {
            let b = 0.25;
            let bone = ((rnd() * BONES as f32) as u32).min(BONES as u32 - 1);
            entries.push(SkinEntry { bone, q: sp.center.map(|c| c * b), b });
        }
    }
    // A 4-level tree: 64 nodes of 4 leaves, 16 of 4 nodes, 4 of 4, one root.
    let mut nodes = Vec::new();
    for i in 0..64u32 {
        nodes.push(HierarchyNode {
            center: [0.5; 3],
            radius: 2.0,
            children: vec![],
            leaf_children: (4 * i..4 * i + 4).collect(),
        });
    }
    let leaf_nodes: Vec<u32> = (0..64).collect();
    let mut level = leaf_nodes;
    while level.len() > 1 {
        let mut next = Vec::new();
        for ch in level.chunks(4) {
            nodes.push(HierarchyNode { center: [0.5; 3], radius: 2.0, children: ch.to_vec(), leaf_children: vec![] });
            next.push(nodes.len() as u32 - 1);
        }
        level = next;
    }
    let id = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0];
    SphbFile {
        spheres,
        hierarchy: Some(Hierarchy { root: level[0], nodes }),
        skin: Some(SkinTerms { bones_per_sphere: K as u32, entries }),
        bones: Some((0..BONES).map(|i| BoneRecord { name: format!("b{i}"), parent: None, inverse_bind: id }).collect()),
        ..SphbFile::default()
    }
}

fn main() {
    let proxy = Proxy::from_file(&file()).expect("valid file");
    let plan = HierarchyPlan::new(proxy.hierarchy().expect("hierarchy")).expect("plan");
    let mut nodes = rest_node_spheres(proxy.hierarchy().expect("hierarchy"));
    let joints: Vec<[f32; 16]> = (0..BONES)
        .map(|i| {
            let a = i as f32 * 0.1;
            let (s, co) = a.sin_cos();
            [co, s, 0.0, 0.0, -s, co, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.1 * a, 0.0, -0.2 * a, 1.0]
        })
        .collect();
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
