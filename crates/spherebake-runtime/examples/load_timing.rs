//! Times `load` on a synthetic file: 4096 spheres in a binary hierarchy, 40 samples per sphere,
//! order-4 albedo SH, 4 skin slots per sphere over 64 bones.
//! `cargo run --release -p spherebake-runtime --example load_timing`

use spherebake_format::{
    write, AlbedoSh, BoneRecord, ColourSpace, Hierarchy, HierarchyNode, SamplePoint, Samples, ShBasis, SkinEntry,
    SkinTerms, SphbFile, Sphere,
};
use std::time::Instant;

fn synthetic(n: usize) -> SphbFile {
    let spheres: Vec<Sphere> = (0..n).map(|i| Sphere { center: [i as f32 * 0.01, 0.0, 0.0], radius: 0.02 }).collect();
    // Heap-ordered binary tree over n leaves: internal nodes 0..n-1, leaves attached to the
    // last level's nodes.
    let internal = n - 1;
    let mut nodes: Vec<HierarchyNode> = (0..internal)
        .map(|_| HierarchyNode { center: [0.0; 3], radius: 100.0, children: vec![], leaf_children: vec![] })
        .collect();
    for (i, node) in nodes.iter_mut().enumerate() {
        for c in [2 * i + 1, 2 * i + 2] {
            if c < internal {
                node.children.push(c as u32);
            } else {
                node.leaf_children.push((c - internal) as u32);
            }
        }
    }
    let per_sphere = (0..n)
        .map(|_| {
            (0..40u8)
                .map(|d| SamplePoint { position: [0.0; 3], normal: [0.0, 1.0, 0.0], direction: 2 * d, rule: 1 })
                .collect()
        })
        .collect();
    let mut identity = [0.0f32; 16];
    for i in 0..4 {
        identity[5 * i] = 1.0;
    }
    SphbFile {
        spheres,
        hierarchy: Some(Hierarchy { root: 0, nodes }),
        samples: Some(Samples { per_sphere }),
        albedo_sh: Some(AlbedoSh {
            order: 4,
            colour_space: ColourSpace::LinearRgb,
            basis: ShBasis::RealOrthonormalCs,
            coefficients: vec![[0.5; 3]; n * 16],
        }),
        skin: Some(SkinTerms {
            bones_per_sphere: 4,
            entries: (0..n * 4).map(|i| SkinEntry { bone: (i % 64) as u32, q: [0.0; 3], b: 0.25 }).collect(),
        }),
        bones: Some(
            (0..64)
                .map(|i| BoneRecord {
                    name: format!("bone{i}"),
                    parent: (i > 0).then(|| i - 1),
                    inverse_bind: identity,
                })
                .collect(),
        ),
        metadata: None,
    }
}

fn main() {
    let bytes = write(&synthetic(4096));
    let mut times = Vec::new();
    for _ in 0..21 {
        let t = Instant::now();
        let proxy = spherebake_runtime::load(&bytes).expect("valid");
        times.push(t.elapsed().as_secs_f64() * 1e3);
        assert_eq!(proxy.sphere_count(), 4096);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "load: {} bytes, median {:.3} ms, min {:.3} ms over {} runs",
        bytes.len(),
        times[times.len() / 2],
        times[0],
        times.len()
    );
}
