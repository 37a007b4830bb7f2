//! Property tests: any bytes give `Ok` or `Err` without panicking; random valid models round trip.

mod common;

use common::*;
use proptest::prelude::*;
use spherebake_format::{read, repair_checksums, write, Hierarchy, NodeLists, SamplePoint, Samples, SphbFile, Sphere};

/// When a (possibly mutated) file reads back, writing it is a fixpoint: write → read → write
/// gives the same bytes and the same model.
fn check_reencode(bytes: &[u8]) {
    if let Ok(file) = read(bytes) {
        let once = write(&file);
        let again = read(&once).expect("a re-encoded valid file is valid");
        assert_eq!(again, file);
        assert_eq!(write(&again), once);
    }
}

#[derive(Clone, Debug)]
enum Mutation {
    Flip { at: usize, mask: u8 },
    Set { at: usize, value: u8 },
    SetU32 { at: usize, value: u32 },
    Truncate { len: usize },
    Extend { bytes: Vec<u8> },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 1u8..=255).prop_map(|(at, mask)| Mutation::Flip { at, mask }),
        (any::<usize>(), any::<u8>()).prop_map(|(at, value)| Mutation::Set { at, value }),
        (any::<usize>(), prop_oneof![Just(0u32), Just(1), Just(2), Just(3), Just(92), Just(u32::MAX), any::<u32>()])
            .prop_map(|(at, value)| Mutation::SetU32 { at, value }),
        any::<usize>().prop_map(|len| Mutation::Truncate { len }),
        proptest::collection::vec(any::<u8>(), 1..64).prop_map(|bytes| Mutation::Extend { bytes }),
    ]
}

fn apply(b: &mut Vec<u8>, m: &Mutation) {
    if b.is_empty() {
        return;
    }
    let n = b.len();
    match m {
        Mutation::Flip { at, mask } => b[at % n] ^= mask,
        Mutation::Set { at, value } => b[at % n] = *value,
        Mutation::SetU32 { at, value } => {
            // Field-aligned, as most fields are 4-byte aligned.
            let at = (at % n) & !3;
            if at + 4 <= n {
                b[at..at + 4].copy_from_slice(&value.to_le_bytes());
            }
        }
        Mutation::Truncate { len } => b.truncate(len % (n + 1)),
        Mutation::Extend { bytes } => b.extend_from_slice(bytes),
    }
}

/// A random valid model: spheres, a random tree over them, sorted samples.
fn valid_model() -> impl Strategy<Value = SphbFile> {
    (1usize..12)
        .prop_flat_map(|n| {
            (
                proptest::collection::vec((-10.0f32..10.0, -10.0f32..10.0, -10.0f32..10.0, 0.01f32..3.0), n),
                1usize..=n,
                proptest::collection::vec(any::<u32>(), n * 3),
                proptest::collection::vec(proptest::collection::btree_set(0u8..92, 0..6), n),
            )
        })
        .prop_map(|(spheres, m, picks, dirs)| {
            let n = spheres.len();
            let spheres: Vec<Sphere> =
                spheres.into_iter().map(|(x, y, z, r)| Sphere { center: [x, y, z], radius: r }).collect();
            // Nodes 0..m; node i > 0 hangs under a random earlier node; sphere i < m is a leaf of
            // node i (so no node is empty), the rest of random nodes.
            let mut nodes: Vec<NodeLists> = (0..m)
                .map(|i| NodeLists { center: spheres[i].center, radius: 20.0, children: vec![], leaf_children: vec![] })
                .collect();
            for (i, &pick) in picks.iter().enumerate().take(m).skip(1) {
                let parent = pick as usize % i;
                nodes[parent].children.push(i as u32);
            }
            for s in 0..n {
                let node = if s < m { s } else { picks[n + s] as usize % m };
                nodes[node].leaf_children.push(s as u32);
            }
            let per_sphere: Vec<Vec<SamplePoint>> = dirs
                .iter()
                .enumerate()
                .map(|(s, set)| {
                    set.iter()
                        .map(|&d| SamplePoint {
                            position: spheres[s].center,
                            normal: [0.0, 0.0, 1.0],
                            direction: d,
                            rule: 1 + (picks[2 * n + s] % 3) as u8,
                        })
                        .collect()
                })
                .collect();
            SphbFile {
                spheres,
                hierarchy: Some(Hierarchy::from_lists(0, nodes)),
                samples: Some(Samples::from_per_sphere(per_sphere)),
                ..SphbFile::default()
            }
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..2048)) {
        let _ = read(&bytes);
        check_reencode(&bytes);
    }

    #[test]
    fn random_bytes_behind_a_valid_header_never_panic(
        tail in proptest::collection::vec(any::<u8>(), 0..1024),
        count in 0u32..16,
    ) {
        let mut b = write(&full_file())[..64].to_vec();
        b.extend_from_slice(&tail);
        while b.len() % 16 != 0 { b.push(0); }
        put_u32(&mut b, 20, count);
        let len = b.len() as u64;
        put_u64(&mut b, 32, len);
        repair_checksums(&mut b);
        let _ = read(&b);
        check_reencode(&b);
    }

    #[test]
    fn mutated_valid_files_never_panic(
        muts in proptest::collection::vec(mutation(), 1..6),
        fix in any::<bool>(),
    ) {
        let mut b = write(&full_file());
        for m in &muts { apply(&mut b, m); }
        if fix { repair_checksums(&mut b); }
        let _ = read(&b);
        check_reencode(&b);
    }

    #[test]
    fn random_valid_models_round_trip(file in valid_model()) {
        let bytes = write(&file);
        let back = read(&bytes).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!(&back, &file);
        prop_assert_eq!(write(&back), bytes);
    }

    #[test]
    fn mutated_random_models_never_panic(
        file in valid_model(),
        muts in proptest::collection::vec(mutation(), 1..4),
    ) {
        let mut b = write(&file);
        for m in &muts { apply(&mut b, m); }
        repair_checksums(&mut b);
        let _ = read(&b);
        check_reencode(&b);
    }
}
