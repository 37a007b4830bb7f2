//! Micro-benchmarks of the animation-time hierarchy queries on a 256-leaf, branching-4 tree
//! (256 leaves → 64 → 16 → 4 → 1 nodes, leaves grouped in Morton order): one refit, and one cut
//! for a receiver ball at a few distances.
//!
//! ```text
//! cargo bench -p spherebake-runtime --bench refit_cut
//! ```

use criterion::{criterion_group, criterion_main, Criterion};
use spherebake_runtime::{
    cut, refit, rest_node_spheres, Hierarchy, HierarchyPlan, NodeLists, Sphere, DEFAULT_THETA_MAX_RAD,
};
use std::hint::black_box;

const LEAVES: usize = 256;

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) as f32
    }
}

fn morton(c: [f32; 3]) -> u32 {
    let q = |v: f32| ((v + 1.0) * 511.5).clamp(0.0, 1023.0) as u32;
    let mut code = 0;
    for bit in 0..10 {
        for (k, v) in c.iter().enumerate() {
            code |= ((q(*v) >> bit) & 1) << (3 * bit + k as u32);
        }
    }
    code
}

/// Leaves in [−1, 1]³ with radii 0.02..0.12, and a 4-ary tree over them in Morton order.
fn setup() -> (Hierarchy, Vec<Sphere>) {
    let mut rng = Rng(0x1234_5678_9ABC_DEF1);
    let mut leaves: Vec<Sphere> = (0..LEAVES)
        .map(|_| Sphere {
            center: [rng.next() * 2.0 - 1.0, rng.next() * 2.0 - 1.0, rng.next() * 2.0 - 1.0],
            radius: 0.02 + 0.1 * rng.next(),
        })
        .collect();
    leaves.sort_by_key(|s| morton(s.center));
    let mut nodes = Vec::new();
    let mut level: Vec<u32> = (0..LEAVES as u32).collect();
    let mut is_leaf = true;
    while level.len() > 1 || is_leaf {
        let first = nodes.len() as u32;
        for group in level.chunks(4) {
            let (children, leaf_children) = if is_leaf { (vec![], group.to_vec()) } else { (group.to_vec(), vec![]) };
            nodes.push(NodeLists { center: [0.0; 3], radius: 1.0, children, leaf_children });
        }
        level = (first..nodes.len() as u32).collect();
        is_leaf = false;
    }
    (Hierarchy::from_lists(nodes.len() as u32 - 1, nodes), leaves)
}

fn bench(c: &mut Criterion) {
    let (h, leaves) = setup();
    let plan = HierarchyPlan::new(&h).unwrap();
    let mut nodes = rest_node_spheres(&h);
    c.bench_function("refit_256_leaves", |b| {
        b.iter(|| refit(&plan, black_box(&leaves), black_box(&mut nodes)).unwrap());
    });
    refit(&plan, &leaves, &mut nodes).unwrap();
    let mut out = Vec::with_capacity(LEAVES);
    for dist in [2.0f32, 4.0, 10.0] {
        cut(&plan, &nodes, [0.0, 0.3, dist], 0.25, DEFAULT_THETA_MAX_RAD, &mut out).unwrap();
        let size = out.len();
        c.bench_function(&format!("cut_256_leaves_receiver_at_{dist}_({size}_entries)"), |b| {
            b.iter(|| {
                cut(&plan, black_box(&nodes), black_box([0.0, 0.3, dist]), 0.25, DEFAULT_THETA_MAX_RAD, &mut out)
                    .unwrap();
                out.len()
            });
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
