//! Refit and cut queries: math reference §9 worked example, random poses of random trees
//! (containment, agreement with an f64 sequential pair-bound reference), cut against a
//! brute-force recursion, leaf coverage, and error cases.

use spherebake_format::{write, SphbFile};
use spherebake_runtime::{
    cut, cut_accepts, cut_threshold, load, refit, rest_node_spheres, CutEntry, Hierarchy, HierarchyPlan, NodeLists,
    QueryError, Sphere, DEFAULT_THETA_MAX_RAD,
};
use spherebake_testkit::rng::SplitMix64;

/// SplitMix64 (`spherebake_testkit::rng`) with the helpers these tests draw with.
struct Rng(SplitMix64);
impl Rng {
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        self.0.range(lo, hi)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.0.next_u64() % n as u64) as usize
    }
}

fn leaf(c: [f32; 3], r: f32) -> Sphere {
    Sphere { center: c, radius: r }
}

fn one_node(leaves: Vec<u32>) -> NodeLists {
    NodeLists { center: [0.0; 3], radius: 1.0, children: vec![], leaf_children: leaves }
}

/// Math reference §9: L1 = ((−0.5,0,0), 0.5), L2 = ((0.7,0.2,0), 0.4), parent = their pair bound.
#[test]
fn worked_example_of_math_reference_section_9() {
    let leaves = [leaf([-0.5, 0.0, 0.0], 0.5), leaf([0.7, 0.2, 0.0], 0.4)];
    let h = Hierarchy::from_lists(0, vec![one_node(vec![0, 1])]);
    let plan = HierarchyPlan::new(&h).unwrap();
    let mut nodes = rest_node_spheres(&h);
    refit(&plan, &leaves, &mut nodes).unwrap();
    let p = nodes[0];
    assert!((p.radius - 1.058_276_3).abs() < 1e-6, "{p:?}");
    assert!(f64::from(p.radius) >= 1.058276253, "rounded outwards");
    for (got, want) in p.center.iter().zip([0.05068030381f64, 0.09178005063, 0.0]) {
        assert!((f64::from(*got) - want).abs() < 1e-6, "{p:?}");
    }
    let theta = 25f32.to_radians();
    assert!((theta - DEFAULT_THETA_MAX_RAD).abs() < 1e-7);
    // (cluster centre, cluster radius, [(sphere, threshold, worst angle °, accepted)])
    let table = [
        (
            [0.3f32, -0.2, 5.0],
            0.5f32,
            [
                (p, 1.90799803f64, 13.55663224f64, true),
                (leaves[0], 1.930327414, 6.284650496, true),
                (leaves[1], 1.915262961, 5.063700126, true),
            ],
        ),
        (
            [0.0, 0.0, 2.0],
            0.3,
            [
                (p, 0.7196116107, 38.42659428, false),
                (leaves[0], 0.7444643877, 16.48955111, true),
                (leaves[1], 0.772706636, 12.63697225, true),
            ],
        ),
    ];
    for (pr, rr, rows) in table {
        for (s, thr, worst_deg, accepted) in rows {
            let got = cut_threshold(s.center, pr, rr, DEFAULT_THETA_MAX_RAD);
            assert!((f64::from(got) - thr).abs() < 1e-6, "threshold {got} vs {thr}");
            assert_eq!(cut_accepts(&s, pr, rr, DEFAULT_THETA_MAX_RAD), accepted);
            // Independent form of the test: worst angular radius below θmax.
            let d = (0..3).map(|k| (f64::from(s.center[k]) - f64::from(pr[k])).powi(2)).sum::<f64>().sqrt();
            let worst = (f64::from(s.radius) / (d - f64::from(rr))).asin().to_degrees();
            assert!((worst - worst_deg).abs() < 1e-4, "worst angle {worst} vs {worst_deg}");
            assert_eq!(worst < 25.0, accepted);
        }
    }
    let mut out = Vec::new();
    cut(&plan, &nodes, [0.3, -0.2, 5.0], 0.5, DEFAULT_THETA_MAX_RAD, &mut out).unwrap();
    assert_eq!(out, vec![CutEntry::Node(0)]);
    cut(&plan, &nodes, [0.0, 0.0, 2.0], 0.3, DEFAULT_THETA_MAX_RAD, &mut out).unwrap();
    out.sort();
    assert_eq!(out, vec![CutEntry::Leaf(0), CutEntry::Leaf(1)]);
}

/// A random tree over `leaf_count` leaves: repeatedly group 2..=5 random pool items (nodes or
/// leaves) under a new node, then shuffle node indices so that the storage order is arbitrary.
fn random_tree(rng: &mut Rng, leaf_count: usize) -> Hierarchy {
    #[derive(Clone, Copy)]
    enum Item {
        Node(u32),
        Leaf(u32),
    }
    let mut pool: Vec<Item> = (0..leaf_count as u32).map(Item::Leaf).collect();
    let mut nodes: Vec<NodeLists> = Vec::new();
    while !(pool.len() == 1 && matches!(pool[0], Item::Node(_))) {
        let take = (2 + rng.below(4)).min(pool.len());
        let mut node = NodeLists { center: [0.0; 3], radius: 1.0, children: vec![], leaf_children: vec![] };
        for _ in 0..take {
            match pool.swap_remove(rng.below(pool.len())) {
                Item::Node(n) => node.children.push(n),
                Item::Leaf(l) => node.leaf_children.push(l),
            }
        }
        nodes.push(node);
        pool.push(Item::Node(nodes.len() as u32 - 1));
    }
    // Permute node indices.
    let m = nodes.len();
    let mut perm: Vec<u32> = (0..m as u32).collect();
    for i in (1..m).rev() {
        perm.swap(i, rng.below(i + 1));
    }
    let mut out = vec![NodeLists::default(); m];
    for (old, mut n) in nodes.into_iter().enumerate() {
        for c in &mut n.children {
            *c = perm[*c as usize];
        }
        out[perm[old] as usize] = n;
    }
    Hierarchy::from_lists(perm[m - 1], out)
}

fn random_leaves(rng: &mut Rng, n: usize, scale: f64) -> Vec<Sphere> {
    (0..n)
        .map(|_| {
            let c = [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)].map(|v| (v * scale) as f32);
            leaf(c, (rng.range(0.01, 0.3) * scale) as f32)
        })
        .collect()
}

/// Rotation by a random unit quaternion about the origin plus a random translation.
fn rigid_motion(rng: &mut Rng, s: &Sphere, scale: f64) -> Sphere {
    let q = loop {
        let q = [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)];
        let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        if n > 0.1 && n <= 1.0 {
            break q.map(|v| v / n);
        }
    };
    let [w, x, y, z] = q;
    let p = s.center.map(f64::from);
    let r = [
        [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
        [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
        [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)],
    ];
    let t = [rng.range(-0.5, 0.5), rng.range(-0.5, 0.5), rng.range(-0.5, 0.5)];
    let c: [f32; 3] = std::array::from_fn(|i| ((0..3).map(|j| r[i][j] * p[j]).sum::<f64>() + t[i] * scale) as f32);
    leaf(c, s.radius)
}

fn dist(a: [f32; 3], b: [f32; 3]) -> f64 {
    (0..3).map(|k| (f64::from(a[k]) - f64::from(b[k])).powi(2)).sum::<f64>().sqrt()
}

/// f64 sequential pair bound over a node's children (child nodes, then leaves), from the f64
/// reference values of the children.
fn reference_refit(
    h: &Hierarchy,
    leaves: &[Sphere],
    node: u32,
    memo: &mut Vec<Option<([f64; 3], f64)>>,
) -> ([f64; 3], f64) {
    if let Some(b) = memo[node as usize] {
        return b;
    }
    let n = node as usize;
    let mut balls: Vec<([f64; 3], f64)> =
        h.children_of(n).iter().map(|&c| reference_refit(h, leaves, c, memo)).collect();
    balls.extend(
        h.leaves_of(n)
            .iter()
            .map(|&l| (leaves[l as usize].center.map(f64::from), f64::from(leaves[l as usize].radius))),
    );
    let mut acc = balls[0];
    for &(c2, r2) in &balls[1..] {
        let (c1, r1) = acc;
        let d = (0..3).map(|k| (c2[k] - c1[k]).powi(2)).sum::<f64>().sqrt();
        acc = if d + r2 <= r1 {
            (c1, r1)
        } else if d + r1 <= r2 {
            (c2, r2)
        } else {
            let r = (d + r1 + r2) / 2.0;
            (std::array::from_fn(|k| c1[k] + (c2[k] - c1[k]) * (r - r1) / d), r)
        };
    }
    memo[node as usize] = Some(acc);
    acc
}

#[test]
fn refitted_parents_contain_children_for_random_poses() {
    let mut rng = Rng(SplitMix64::new(7));
    for trial in 0..60 {
        let leaf_count = 1 + rng.below(300);
        let scale = [1.0, 1e-3, 250.0][trial % 3];
        let h = random_tree(&mut rng, leaf_count);
        let plan = HierarchyPlan::new(&h).unwrap();
        let rest = random_leaves(&mut rng, leaf_count, scale);
        let mut nodes = rest_node_spheres(&h);
        for _pose in 0..4 {
            let posed: Vec<Sphere> = rest.iter().map(|s| rigid_motion(&mut rng, s, scale)).collect();
            refit(&plan, &posed, &mut nodes).unwrap();
            let mut memo = vec![None; h.nodes.len()];
            for i in 0..h.nodes.len() {
                let p = nodes[i];
                for &c in h.children_of(i) {
                    let cs = nodes[c as usize];
                    assert!(
                        dist(p.center, cs.center) + f64::from(cs.radius) <= f64::from(p.radius),
                        "trial {trial}: node {c} sticks out of {i}"
                    );
                }
                for &l in h.leaves_of(i) {
                    let ls = posed[l as usize];
                    assert!(
                        dist(p.center, ls.center) + f64::from(ls.radius) <= f64::from(p.radius),
                        "trial {trial}: leaf {l} sticks out of {i}"
                    );
                }
                let (rc, rr) = reference_refit(&h, &posed, i as u32, &mut memo);
                // Same merge order; f32 storage between levels: agree to f32 precision.
                let tol = 1e-5 * (rr + rc.iter().fold(0.0f64, |m, v| m.max(v.abs())));
                assert!((f64::from(p.radius) - rr).abs() <= tol, "trial {trial} node {i}: {} vs {rr}", p.radius);
                assert!(dist(p.center, rc.map(|v| v as f32)) <= tol);
            }
        }
    }
}

/// Brute-force recursion of the cut (f64, std maths).
fn brute_cut(h: &Hierarchy, nodes: &[Sphere], node: u32, pr: [f32; 3], rr: f32, theta: f64, out: &mut Vec<CutEntry>) {
    let s = nodes[node as usize];
    if f64::from(s.radius) < theta.sin() * (dist(s.center, pr) - f64::from(rr)) {
        out.push(CutEntry::Node(node));
        return;
    }
    for &c in h.children_of(node as usize) {
        brute_cut(h, nodes, c, pr, rr, theta, out);
    }
    out.extend(h.leaves_of(node as usize).iter().map(|&l| CutEntry::Leaf(l)));
}

fn leaves_below(h: &Hierarchy, node: u32, out: &mut Vec<u32>) {
    out.extend(h.leaves_of(node as usize));
    for &c in h.children_of(node as usize) {
        leaves_below(h, c, out);
    }
}

#[test]
fn cut_matches_brute_force_and_covers_every_leaf_once() {
    let mut rng = Rng(SplitMix64::new(11));
    let mut out = Vec::new();
    let mut sizes = Vec::new();
    for _trial in 0..40 {
        let leaf_count = 1 + rng.below(400);
        let h = random_tree(&mut rng, leaf_count);
        let plan = HierarchyPlan::new(&h).unwrap();
        let leaves = random_leaves(&mut rng, leaf_count, 1.0);
        let mut nodes = rest_node_spheres(&h);
        refit(&plan, &leaves, &mut nodes).unwrap();
        for _q in 0..25 {
            let dir = [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)];
            let dist_r = rng.range(0.0, 12.0);
            let pr = dir.map(|v| (v * dist_r) as f32);
            let rr = rng.range(0.0, 1.0) as f32;
            let theta = [DEFAULT_THETA_MAX_RAD, 0.2, 0.6, 0.0, 1.5][rng.below(5)];
            cut(&plan, &nodes, pr, rr, theta, &mut out).unwrap();
            let mut want = Vec::new();
            brute_cut(&h, &nodes, plan.root(), pr, rr, f64::from(theta), &mut want);
            let mut got = out.clone();
            got.sort();
            want.sort();
            assert_eq!(got, want);
            let mut covered = vec![0u32; leaf_count];
            for e in &out {
                match *e {
                    CutEntry::Leaf(l) => covered[l as usize] += 1,
                    CutEntry::Node(n) => {
                        let mut ls = Vec::new();
                        leaves_below(&h, n, &mut ls);
                        for l in ls {
                            covered[l as usize] += 1;
                        }
                    }
                    _ => unreachable!(),
                }
            }
            assert!(covered.iter().all(|&c| c == 1), "every leaf exactly once");
            sizes.push(out.len());
        }
    }
    // The queries are not degenerate: some cuts stop at the root, some go to many entries.
    assert!(sizes.contains(&1) && sizes.iter().any(|&s| s > 20));
}

#[test]
fn plan_rejects_malformed_trees_and_queries_check_lengths() {
    let mk = |root: u32, nodes: Vec<(Vec<u32>, Vec<u32>)>| {
        Hierarchy::from_lists(
            root,
            nodes.into_iter().map(|(children, leaf_children)| NodeLists {
                center: [0.0; 3],
                radius: 1.0,
                children,
                leaf_children,
            }),
        )
    };
    assert_eq!(HierarchyPlan::new(&Hierarchy::default()), Err(QueryError::Empty));
    assert_eq!(
        HierarchyPlan::new(&mk(1, vec![(vec![], vec![0])])),
        Err(QueryError::RootOutOfRange { root: 1, node_count: 1 })
    );
    assert_eq!(
        HierarchyPlan::new(&mk(0, vec![(vec![5], vec![0])])),
        Err(QueryError::ChildOutOfRange { node: 0, child: 5, node_count: 1 })
    );
    assert_eq!(
        HierarchyPlan::new(&mk(0, vec![(vec![1], vec![]), (vec![0], vec![0])])),
        Err(QueryError::NodeReachedTwice { node: 0 })
    );
    assert_eq!(
        HierarchyPlan::new(&mk(0, vec![(vec![1, 1], vec![]), (vec![], vec![0])])),
        Err(QueryError::NodeReachedTwice { node: 1 })
    );
    assert_eq!(
        HierarchyPlan::new(&mk(0, vec![(vec![], vec![0]), (vec![], vec![1])])),
        Err(QueryError::NodeUnreachable { node: 1 })
    );
    assert_eq!(
        HierarchyPlan::new(&mk(0, vec![(vec![1], vec![]), (vec![], vec![])])),
        Err(QueryError::NodeEmpty { node: 1 })
    );
    assert_eq!(
        HierarchyPlan::new(&mk(0, vec![(vec![], vec![u32::MAX])])),
        Err(QueryError::IndexTooLarge { node: 0, index: u32::MAX })
    );

    let h = mk(0, vec![(vec![1], vec![2]), (vec![], vec![0, 1])]);
    let plan = HierarchyPlan::new(&h).unwrap();
    assert_eq!(plan.bottom_up_order(), &[1, 0]);
    assert_eq!(plan.leaf_bound(), 3);
    let leaves = [leaf([0.0; 3], 1.0); 3];
    let mut nodes = vec![leaf([9.0; 3], 9.0); 2];
    let before = nodes.clone();
    assert_eq!(
        refit(&plan, &leaves[..2], &mut nodes),
        Err(QueryError::SliceLength { argument: "posed_leaves", expected: 3, actual: 2 })
    );
    assert_eq!(nodes, before, "nothing written on error");
    assert_eq!(
        refit(&plan, &leaves, &mut nodes[..1]),
        Err(QueryError::SliceLength { argument: "nodes_out", expected: 2, actual: 1 })
    );
    let mut out = vec![CutEntry::Leaf(7)];
    assert_eq!(
        cut(&plan, &nodes[..1], [0.0; 3], 0.0, 0.4, &mut out),
        Err(QueryError::SliceLength { argument: "nodes", expected: 2, actual: 1 })
    );
    assert!(!QueryError::NodeEmpty { node: 3 }.to_string().is_empty());
}

#[test]
fn degenerate_inputs_still_cover_every_leaf() {
    let h = Hierarchy::from_lists(
        0,
        vec![
            NodeLists { center: [0.0; 3], radius: 1.0, children: vec![1], leaf_children: vec![0] },
            NodeLists { center: [0.0; 3], radius: 1.0, children: vec![], leaf_children: vec![1, 2] },
        ],
    );
    let plan = HierarchyPlan::new(&h).unwrap();
    // Identical leaves (pair bound of coincident spheres), a NaN leaf.
    let leaves = [leaf([1.0; 3], 0.5), leaf([1.0; 3], 0.5), leaf([f32::NAN, 0.0, 0.0], 0.5)];
    let mut nodes = rest_node_spheres(&h);
    refit(&plan, &leaves[..2].iter().chain(&leaves[..1]).copied().collect::<Vec<_>>(), &mut nodes).unwrap();
    assert_eq!(nodes[1].center, [1.0; 3]);
    assert!(nodes[1].radius >= 0.5 && nodes[1].radius < 0.500_001);
    refit(&plan, &leaves, &mut nodes).unwrap();
    let mut out = Vec::new();
    for (pr, rr, theta) in [([0.0f32; 3], 0.0f32, f32::NAN), ([f32::NAN; 3], 1.0, 0.4), ([100.0, 0.0, 0.0], -1.0, 10.0)]
    {
        cut(&plan, &nodes, pr, rr, theta, &mut out).unwrap();
        let mut leaves_seen: Vec<u32> = Vec::new();
        for e in &out {
            match *e {
                CutEntry::Leaf(l) => leaves_seen.push(l),
                CutEntry::Node(n) => leaves_below(&h, n, &mut leaves_seen),
                _ => unreachable!(),
            }
        }
        leaves_seen.sort();
        assert_eq!(leaves_seen, vec![0, 1, 2]);
    }
}

#[test]
fn proxy_gives_a_plan_for_its_hierarchy() {
    let spheres = vec![leaf([-0.5, 0.0, 0.0], 0.5), leaf([0.7, 0.2, 0.0], 0.4)];
    let file = SphbFile {
        spheres: spheres.clone(),
        hierarchy: Some(Hierarchy::from_lists(
            0,
            vec![NodeLists { center: [0.05, 0.09, 0.0], radius: 1.06, children: vec![], leaf_children: vec![0, 1] }],
        )),
        ..SphbFile::default()
    };
    let proxy = load(&write(&file)).unwrap();
    let plan = proxy.hierarchy_plan().unwrap();
    let mut nodes = rest_node_spheres(proxy.hierarchy().unwrap());
    refit(&plan, proxy.spheres(), &mut nodes).unwrap();
    assert!((nodes[0].radius - 1.058_276_3).abs() < 1e-6);
    let no_h = load(&write(&SphbFile { spheres, ..SphbFile::default() })).unwrap();
    assert!(no_h.hierarchy_plan().is_none());
}
