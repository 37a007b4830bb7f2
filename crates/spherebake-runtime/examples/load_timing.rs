//! Times `load` on a synthetic file: 4096 spheres in a binary hierarchy, 40 samples per sphere,
//! order-4 albedo SH, 4 skin slots per sphere over 64 bones.
//! With file arguments it times those files instead (bytes/s, median of 201 runs each).
//! `cargo run --release -p spherebake-runtime --example load_timing [FILE.sphb ...]`

use spherebake_format::{
    write, AlbedoSh, BoneRecord, ColourSpace, Hierarchy, NodeLists, SamplePoint, Samples, ShBasis, SkinEntry,
    SkinTerms, SphbFile, Sphere,
};
use std::time::Instant;

fn synthetic(n: usize) -> SphbFile {
    let spheres: Vec<Sphere> = (0..n).map(|i| Sphere { center: [i as f32 * 0.01, 0.0, 0.0], radius: 0.02 }).collect();
    // Heap-ordered binary tree over n leaves: internal nodes 0..n-1, leaves attached to the
    // last level's nodes.
    let internal = n - 1;
    let mut nodes: Vec<NodeLists> = (0..internal)
        .map(|_| NodeLists { center: [0.0; 3], radius: 100.0, children: vec![], leaf_children: vec![] })
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
    let per_sphere: Vec<Vec<SamplePoint>> = (0..n)
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
        hierarchy: Some(Hierarchy::from_lists(0, nodes)),
        samples: Some(Samples::from_per_sphere(per_sphere)),
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

fn time_load(name: &str, bytes: &[u8]) {
    let mut times = Vec::new();
    for _ in 0..201 {
        let t = Instant::now();
        let proxy = spherebake_runtime::load(bytes).expect("valid");
        times.push(t.elapsed().as_secs_f64());
        assert!(proxy.sphere_count() >= 1);
    }
    times.sort_by(f64::total_cmp);
    let median = times[times.len() / 2];
    println!(
        "load {name}: {} bytes, median {:.3} ms ({:.0} MB/s), min {:.3} ms over {} runs",
        bytes.len(),
        median * 1e3,
        bytes.len() as f64 / median / 1e6,
        times[0] * 1e3,
        times.len()
    );
}

fn main() {
    let files: Vec<String> = std::env::args().skip(1).collect();
    if files.is_empty() {
        time_load("synthetic 4096 spheres", &write(&synthetic(4096)));
    }
    for f in files {
        let bytes = std::fs::read(&f).unwrap_or_else(|e| panic!("{f}: {e}"));
        time_load(&f, &bytes);
    }
}
