//! The pose + refit benchmark scene shared by `benches/pose.rs` and `examples/pose_timing.rs`:
//! 256 spheres with 4 skin slots each over 32 bones, under a 4-level hierarchy of 85 nodes.

use spherebake_runtime::{BoneRecord, Hierarchy, NodeLists, SkinEntry, SkinTerms, SphbFile, Sphere};

pub const SPHERES: usize = 256;
pub const BONES: usize = 32;
pub const K: usize = 4;

/// One joint matrix per bone (column-major, glTF convention): a rotation about z and a
/// translation growing with the bone index.
pub fn joints() -> Vec<[f32; 16]> {
    (0..BONES)
        .map(|i| {
            let a = i as f32 * 0.1;
            let (s, co) = a.sin_cos();
            [co, s, 0.0, 0.0, -s, co, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.1 * a, 0.0, -0.2 * a, 1.0]
        })
        .collect()
}

pub fn file() -> SphbFile {
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
        nodes.push(NodeLists {
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
            nodes.push(NodeLists { center: [0.5; 3], radius: 2.0, children: ch.to_vec(), leaf_children: vec![] });
            next.push(nodes.len() as u32 - 1);
        }
        level = next;
    }
    let id = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0];
    SphbFile {
        spheres,
        hierarchy: Some(Hierarchy::from_lists(level[0], nodes)),
        skin: Some(SkinTerms { bones_per_sphere: K as u32, entries }),
        bones: Some((0..BONES).map(|i| BoneRecord { name: format!("b{i}"), parent: None, inverse_bind: id }).collect()),
        ..SphbFile::default()
    }
}
