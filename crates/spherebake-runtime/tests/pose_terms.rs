//! `pose` on hand-assembled files: matrix layout (column-major, glTF), rest and rigid motion,
//! unused slots, argument errors, and random terms against an f64 evaluation of the formula.
//! (End-to-end tests with baked MVC terms of real meshes live in `tools/spherebake/tests/pose.rs`.)

#![allow(clippy::needless_range_loop)] // xyz components side by side read clearer indexed

use proptest::prelude::*;
use spherebake_runtime::{pose, BoneRecord, PoseError, Proxy, SkinEntry, SkinTerms, SphbFile, Sphere, UNUSED_BONE};

const ID: [f32; 16] = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0];

fn bone(name: &str) -> BoneRecord {
    BoneRecord { name: name.into(), parent: None, inverse_bind: ID }
}

fn proxy(spheres: Vec<Sphere>, k: u32, entries: Vec<SkinEntry>, bones: usize) -> Proxy {
    let file = SphbFile {
        spheres,
        skin: Some(SkinTerms { bones_per_sphere: k, entries }),
        bones: Some((0..bones).map(|i| bone(&format!("b{i}"))).collect()),
        ..SphbFile::default()
    };
    Proxy::from_file(&file).expect("valid file")
}

/// Rotation by `angle` about unit `axis` followed by translation `t`, column-major.
fn rigid(axis: [f32; 3], angle: f32, t: [f32; 3]) -> [f32; 16] {
    let (s, c) = angle.sin_cos();
    let [x, y, z] = axis;
    let r = [
        [c + x * x * (1.0 - c), x * y * (1.0 - c) - z * s, x * z * (1.0 - c) + y * s],
        [y * x * (1.0 - c) + z * s, c + y * y * (1.0 - c), y * z * (1.0 - c) - x * s],
        [z * x * (1.0 - c) - y * s, z * y * (1.0 - c) + x * s, c + z * z * (1.0 - c)],
    ];
    let mut m = [0.0; 16];
    for row in 0..3 {
        for col in 0..3 {
            m[4 * col + row] = r[row][col];
        }
        m[12 + row] = t[row];
    }
    m[15] = 1.0;
    m
}

fn apply(m: &[f32; 16], p: [f32; 3], w: f32) -> [f64; 3] {
    let m: Vec<f64> = m.iter().map(|&v| f64::from(v)).collect();
    let (x, y, z, w) = (f64::from(p[0]), f64::from(p[1]), f64::from(p[2]), f64::from(w));
    [
        m[0] * x + m[4] * y + m[8] * z + m[12] * w,
        m[1] * x + m[5] * y + m[9] * z + m[13] * w,
        m[2] * x + m[6] * y + m[10] * z + m[14] * w,
    ]
}

#[test]
fn translation_is_in_the_last_column() {
    // One bone, q = centre, b = 1: a translation (column-major: elements 12..14) moves the centre.
    let p = proxy(
        vec![Sphere { center: [1.0, 2.0, 3.0], radius: 0.5 }],
        1,
        vec![SkinEntry { bone: 0, q: [1.0, 2.0, 3.0], b: 1.0 }],
        1,
    );
    let mut out = [Sphere::default()];
    pose(&p, &[ID], &mut out).unwrap();
    assert_eq!(out[0], Sphere { center: [1.0, 2.0, 3.0], radius: 0.5 });
    let mut t = ID;
    t[12] = 10.0;
    t[13] = -1.0;
    t[14] = 0.5;
    pose(&p, &[t], &mut out).unwrap();
    assert_eq!(out[0].center, [11.0, 1.0, 3.5]);
    assert_eq!(out[0].radius, 0.5);
}

#[test]
fn rest_and_common_rigid_motion() {
    // Two spheres over three bones with mixed-sign weights; rest joints = identity, so Σ q = c and Σ b = 1.
    let c0 = [0.3f32, -0.2, 1.0];
    let c1 = [2.0f32, 0.5, -1.0];
    let entries = vec![
        SkinEntry { bone: 0, q: [0.6, -0.1, 0.4], b: 0.7 },
        SkinEntry { bone: 2, q: [-0.5, 0.2, 0.25], b: -0.2 },
        SkinEntry { bone: 1, q: [0.2, -0.3, 0.35], b: 0.5 },
        SkinEntry { bone: 1, q: c1, b: 1.0 },
        SkinEntry { bone: UNUSED_BONE, q: [0.0; 3], b: 0.0 },
        SkinEntry { bone: UNUSED_BONE, q: [0.0; 3], b: 0.0 },
    ];
    let p = proxy(vec![Sphere { center: c0, radius: 1.0 }, Sphere { center: c1, radius: 2.0 }], 3, entries, 3);
    let mut out = [Sphere::default(); 2];
    pose(&p, &[ID; 3], &mut out).unwrap();
    for (o, c) in out.iter().zip([c0, c1]) {
        for a in 0..3 {
            assert!((o.center[a] - c[a]).abs() < 1e-6);
        }
    }
    let g = rigid([0.0, 0.6, 0.8], 1.3, [4.0, -2.0, 0.5]);
    pose(&p, &[g; 3], &mut out).unwrap();
    for (o, c) in out.iter().zip([c0, c1]) {
        let e = apply(&g, c, 1.0);
        for a in 0..3 {
            assert!((f64::from(o.center[a]) - e[a]).abs() < 1e-5, "{o:?} vs {e:?}");
        }
    }
    assert_eq!([out[0].radius, out[1].radius], [1.0, 2.0]);
}

#[test]
fn argument_errors_and_static_files() {
    let p =
        proxy(vec![Sphere { center: [0.0; 3], radius: 1.0 }], 1, vec![SkinEntry { bone: 1, q: [0.0; 3], b: 1.0 }], 2);
    let mut out = [Sphere::default()];
    assert_eq!(pose(&p, &[ID], &mut out), Err(PoseError::JointCount { expected: 2, actual: 1 }));
    assert_eq!(pose(&p, &[ID; 2], &mut []), Err(PoseError::OutputLength { expected: 1, actual: 0 }));
    assert_eq!(out[0], Sphere::default(), "nothing written on error");
    // A NaN or an infinity in a matrix the bone table uses is an error (it would pose a NaN centre).
    for bad in [f32::NAN, f32::INFINITY] {
        let mut m = [ID; 2];
        m[1][13] = bad;
        assert_eq!(pose(&p, &m, &mut out), Err(PoseError::NonFinite { joint: 1 }));
        assert_eq!(out[0], Sphere::default(), "nothing written on error");
    }
    // One beyond the bone table is not read.
    let mut m = [ID; 3];
    m[2][0] = f32::NAN;
    pose(&p, &m, &mut out).unwrap();
    assert!(out[0].center.iter().all(|v| v.is_finite()));
    // No skin: the rest spheres, whatever the matrices.
    let s = Sphere { center: [1.0, 2.0, 3.0], radius: 4.0 };
    let p = Proxy::from_file(&SphbFile { spheres: vec![s], ..SphbFile::default() }).unwrap();
    pose(&p, &[], &mut out).unwrap();
    assert_eq!(out[0], s);
}

proptest! {
    #[test]
    fn matches_f64_formula(
        mats in proptest::collection::vec(proptest::collection::vec(-2.0f32..2.0, 12), 4),
        slots in proptest::collection::vec((0u32..5, proptest::array::uniform3(-3.0f32..3.0), -1.0f32..1.0), 12),
    ) {
        let joints: Vec<[f32; 16]> = mats
            .iter()
            .map(|v| {
                let mut m = [0.0; 16];
                for c in 0..4 {
                    for r in 0..3 {
                        m[4 * c + r] = v[3 * c + r];
                    }
                }
                m[15] = 1.0;
                m
            })
            .collect();
        // Bone 4 stands for an unused slot.
        let entries: Vec<SkinEntry> = slots
            .iter()
            .map(|&(b, q, w)| if b == 4 { SkinEntry { bone: UNUSED_BONE, q: [0.0; 3], b: 0.0 } } else { SkinEntry { bone: b, q, b: w } })
            .collect();
        let spheres = vec![Sphere { center: [0.0; 3], radius: 1.0 }; 3];
        let p = proxy(spheres, 4, entries.clone(), 4);
        let mut out = [Sphere::default(); 3];
        pose(&p, &joints, &mut out).unwrap();
        for s in 0..3 {
            let mut e = [0.0f64; 3];
            for slot in &entries[4 * s..4 * s + 4] {
                if slot.bone != UNUSED_BONE {
                    let v = apply(&joints[slot.bone as usize], slot.q, slot.b);
                    for a in 0..3 { e[a] += v[a]; }
                }
            }
            for a in 0..3 {
                prop_assert!((f64::from(out[s].center[a]) - e[a]).abs() < 1e-4);
            }
        }
    }
}

#[test]
fn pose_and_refit_updates_the_hierarchy() {
    use spherebake_runtime::{pose_and_refit, Hierarchy, NodeLists};
    // Two leaves under one root; bone 1 moves the second sphere by +3 in x.
    let mut file = SphbFile {
        spheres: vec![Sphere { center: [0.0; 3], radius: 1.0 }, Sphere { center: [2.0, 0.0, 0.0], radius: 1.0 }],
        hierarchy: Some(Hierarchy::from_lists(
            0,
            vec![NodeLists { center: [1.0, 0.0, 0.0], radius: 2.0, children: vec![], leaf_children: vec![0, 1] }],
        )),
        skin: Some(SkinTerms {
            bones_per_sphere: 1,
            entries: vec![
                SkinEntry { bone: 0, q: [0.0; 3], b: 1.0 },
                SkinEntry { bone: 1, q: [2.0, 0.0, 0.0], b: 1.0 },
            ],
        }),
        bones: Some(vec![bone("a"), bone("b")]),
        ..SphbFile::default()
    };
    file.metadata = None;
    let p = Proxy::from_file(&file).unwrap();
    let plan = p.hierarchy_plan().unwrap();
    let mut t = ID;
    t[12] = 3.0;
    let mut leaves = [Sphere::default(); 2];
    let mut nodes = vec![Sphere::default(); plan.node_count()];
    pose_and_refit(&p, &plan, &[ID, t], &mut leaves, &mut nodes).unwrap();
    assert_eq!(leaves[1].center, [5.0, 0.0, 0.0]);
    // The enclosing ball of the two unit balls at x = 0 and x = 5: centre 2.5, radius 3.5.
    assert!((nodes[0].center[0] - 2.5).abs() < 1e-5 && nodes[0].center[1].abs() < 1e-6);
    assert!(nodes[0].radius >= 3.5 && nodes[0].radius < 3.5 + 1e-4, "{:?}", nodes[0]);
    assert!(pose_and_refit(&p, &plan, &[ID, t], &mut leaves, &mut []).is_err());
}
