//! Sphere hierarchy bake: the invariants on every shared model (leaves from the k-means
//! baseline of its vertices), an analytic configuration, determinism across thread counts,
//! branching settings and errors.

use glam::DVec3;
use spherebake_fit::baselines::kmeans;
use spherebake_fit::hierarchy::{
    brute_force_min_ball_of_balls, build_hierarchy, hierarchy_stats, HierarchyError, HierarchySettings,
};
use spherebake_format::Hierarchy;
use std::path::PathBuf;

fn model_files() -> Option<Vec<PathBuf>> {
    let dir = spherebake_testkit::shared_models_dir()?;
    let mut files = Vec::new();
    let mut stack = vec![dir];
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else { continue };
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if matches!(p.extension().and_then(|e| e.to_str()), Some("glb" | "gltf" | "obj")) {
                files.push(p);
            }
        }
    }
    files.sort();
    Some(files)
}

fn ball(c: [f32; 3], r: f32) -> (DVec3, f64) {
    (DVec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2])), f64::from(r))
}

/// Checks the invariants; returns (mean branching, node count).
fn check_invariants(name: &str, h: &Hierarchy, leaves: &[[f32; 4]]) -> f64 {
    let n = h.nodes.len();
    assert!(n >= 1 && (h.root as usize) < n, "{name}");
    // Every node and every leaf reached exactly once from the root.
    let mut node_seen = vec![0u32; n];
    let mut leaf_seen = vec![0u32; leaves.len()];
    let mut stack = vec![h.root];
    let lists = h.to_lists();
    while let Some(i) = stack.pop() {
        node_seen[i as usize] += 1;
        assert!(node_seen[i as usize] == 1, "{name}: node {i} reached twice");
        let node = &lists[i as usize];
        assert!(!(node.children.is_empty() && node.leaf_children.is_empty()), "{name}: empty node {i}");
        stack.extend(&node.children);
        for &l in &node.leaf_children {
            leaf_seen[l as usize] += 1;
        }
    }
    assert!(node_seen.iter().all(|&c| c == 1), "{name}: unreachable node");
    assert!(leaf_seen.iter().all(|&c| c == 1), "{name}: leaf not reached exactly once");
    // Containment of the stored f32 values, evaluated in f64.
    for (i, node) in lists.iter().enumerate() {
        assert!(node.radius > 0.0 && node.radius.is_finite(), "{name}: node {i}");
        let (pc, pr) = ball(node.center, node.radius);
        let kids = node.children.iter().map(|&c| ball(h.nodes[c as usize].center, h.nodes[c as usize].radius)).chain(
            node.leaf_children.iter().map(|&l| {
                let s = leaves[l as usize];
                ball([s[0], s[1], s[2]], s[3])
            }),
        );
        for (cc, cr) in kids {
            assert!(pc.distance(cc) + cr <= pr * (1.0 + 1e-12), "{name}: child sticks out of node {i}");
        }
    }
    // The root encloses every leaf.
    let root = &h.nodes[h.root as usize];
    let (rc, rr) = ball(root.center, root.radius);
    for s in leaves {
        let (c, r) = ball([s[0], s[1], s[2]], s[3]);
        assert!(rc.distance(c) + r <= rr * (1.0 + 1e-12), "{name}: leaf outside the root");
    }
    (n + leaves.len() - 1) as f64 / n as f64
}

#[test]
fn invariants_on_every_shared_model() {
    let Some(files) = model_files() else { return };
    assert!(!files.is_empty());
    let mut worst_mean: f64 = 0.0;
    for path in &files {
        // Every shared model imports (spherebake-io's shared_models test); a failure here is a
        // regression, not a skip.
        let imported = spherebake_io::load_mesh(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let mesh = imported.mesh;
        let mut pts: Vec<DVec3> = mesh.welded_positions.iter().map(|p| p.as_dvec3()).collect();
        if pts.is_empty() {
            pts = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
        }
        for k in [64usize, 200] {
            let leaves: Vec<[f32; 4]> = kmeans(&pts, k, 3, 8)
                .iter()
                .map(|(c, r)| [c.x as f32, c.y as f32, c.z as f32, (*r as f32).max(1e-6 * (c.length() as f32 + 1.0))])
                .collect();
            let h = build_hierarchy(&leaves, &HierarchySettings::default()).unwrap();
            let name = format!("{} ({} leaves)", path.file_name().unwrap().to_string_lossy(), leaves.len());
            let mean = check_invariants(&name, &h, &leaves);
            let stats = hierarchy_stats(&h, &leaves);
            println!(
                "{name}: {} nodes, {} levels, mean branching {:.3}, tightness mean {:.9} max {:.9}",
                h.nodes.len(),
                stats.levels,
                stats.mean_branching,
                stats.tightness_mean,
                stats.tightness_max
            );
            assert!((mean - stats.mean_branching).abs() < 1e-12);
            assert!((3.0..=5.0).contains(&mean), "{name}: mean branching {mean}");
            assert!(stats.tightness_mean <= 1.01, "{name}: tightness mean {}", stats.tightness_mean);
            // Exact enclosing balls: the stored radius exceeds the reference only by f32 rounding.
            assert!(stats.tightness_max <= 1.0 + 1e-6, "{name}: tightness max {}", stats.tightness_max);
            worst_mean = worst_mean.max(stats.tightness_mean);
        }
    }
    println!("worst tightness mean over all models: {worst_mean:.9}");
}

/// 16 leaves: four groups of four equal balls (radius r) on the corners of a square of
/// half-diagonal a, the groups at the vertices of a regular tetrahedron of circumradius L√3.
/// Parents: radius a + r about each group centre; root: L√3 + a + r about the origin.
#[test]
fn analytic_two_level_configuration() {
    let (a, r, l) = (0.5f64, 0.25f64, 10.0f64);
    let groups = [
        DVec3::new(1.0, 1.0, 1.0),
        DVec3::new(1.0, -1.0, -1.0),
        DVec3::new(-1.0, 1.0, -1.0),
        DVec3::new(-1.0, -1.0, 1.0),
    ];
    let offsets =
        [DVec3::new(a, 0.0, 0.0), DVec3::new(-a, 0.0, 0.0), DVec3::new(0.0, a, 0.0), DVec3::new(0.0, -a, 0.0)];
    let mut leaves = Vec::new();
    for g in groups {
        for o in offsets {
            let c = g * l + o;
            leaves.push([c.x as f32, c.y as f32, c.z as f32, r as f32]);
        }
    }
    let h = build_hierarchy(&leaves, &HierarchySettings::default()).unwrap();
    check_invariants("analytic", &h, &leaves);
    assert_eq!(h.nodes.len(), 5);
    let lists = h.to_lists();
    let root = &lists[h.root as usize];
    assert_eq!(root.children.len(), 4);
    let want_root = l * 3f64.sqrt() + a + r;
    assert!((f64::from(root.radius) - want_root).abs() < 1e-5 * want_root, "{}", root.radius);
    assert!(ball(root.center, 0.0).0.length() < 1e-5);
    for &c in &root.children {
        let p = &lists[c as usize];
        assert!((f64::from(p.radius) - (a + r)).abs() < 1e-6, "{}", p.radius);
        let g = groups.iter().map(|g| *g * l).find(|g| g.distance(ball(p.center, 0.0).0) < 1e-5);
        assert!(g.is_some(), "parent at a group centre");
        // Its four leaves are the group's.
        let gc = g.unwrap();
        for &li in &p.leaf_children {
            let s = leaves[li as usize];
            assert!(ball([s[0], s[1], s[2]], 0.0).0.distance(gc) < a + 1e-6);
        }
    }
}

#[test]
fn deterministic_across_thread_counts_and_seeds_matter_only_through_clustering() {
    let mut state = 99u64;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) as f32
    };
    let leaves: Vec<[f32; 4]> = (0..500).map(|_| [next() * 4.0, next() * 2.0, next(), 0.01 + 0.05 * next()]).collect();
    let settings = HierarchySettings::default();
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| build_hierarchy(&leaves, &settings).unwrap())
    };
    let one = run(1);
    assert_eq!(one, run(4));
    check_invariants("random 500", &one, &leaves);
    let other = build_hierarchy(&leaves, &HierarchySettings { seed: 2, ..settings.clone() }).unwrap();
    check_invariants("random 500, seed 2", &other, &leaves);
}

#[test]
fn branching_setting_is_followed() {
    let leaves: Vec<[f32; 4]> = (0..1000)
        .map(|i| [(i % 10) as f32, ((i / 10) % 10) as f32, (i / 100) as f32, 0.3 + 0.01 * (i % 7) as f32])
        .collect();
    for b in [2.0, 3.0, 4.0, 6.0, 8.0, 16.0] {
        let h = build_hierarchy(&leaves, &HierarchySettings { branching: b, seed: 1 }).unwrap();
        let mean = check_invariants(&format!("grid, b = {b}"), &h, &leaves);
        // Internal node count I for mean b is (L − 1)/(b − 1); rounding per level keeps it close.
        assert!((mean - b).abs() <= 0.15 * b, "b = {b}: mean {mean}");
        let stats = hierarchy_stats(&h, &leaves);
        assert!(stats.tightness_max <= 1.0 + 1e-5, "b = {b}: {}", stats.tightness_max);
    }
}

#[test]
fn small_inputs_and_errors() {
    let h = build_hierarchy(&[[1.0, 2.0, 3.0, 0.5]], &HierarchySettings::default()).unwrap();
    assert_eq!(h.nodes.len(), 1);
    assert_eq!(h.leaves_of(0), [0]);
    assert_eq!(h.nodes[0].center, [1.0, 2.0, 3.0]);
    assert!(h.nodes[0].radius >= 0.5 && h.nodes[0].radius < 0.500_001);
    // Math reference §9 pair: the parent is the pair bound R = 1.058276253.
    let pair = [[-0.5, 0.0, 0.0, 0.5], [0.7, 0.2, 0.0, 0.4]];
    let h = build_hierarchy(&pair, &HierarchySettings::default()).unwrap();
    assert_eq!(h.nodes.len(), 1);
    assert!((f64::from(h.nodes[0].radius) - 1.058276253).abs() < 1e-6);
    // Zero radii and coincident leaves.
    let same = [[1.0, 1.0, 1.0, 0.0]; 7];
    let h = build_hierarchy(&same, &HierarchySettings::default()).unwrap();
    check_invariants("coincident", &h, &same);

    assert_eq!(build_hierarchy(&[], &HierarchySettings::default()), Err(HierarchyError::NoLeaves));
    assert!(matches!(
        build_hierarchy(&[[0.0, f32::NAN, 0.0, 1.0]], &HierarchySettings::default()),
        Err(HierarchyError::InvalidLeaf { index: 0, .. })
    ));
    assert!(!HierarchyError::NoLeaves.to_string().is_empty());
    assert!(matches!(
        build_hierarchy(&[[0.0, 0.0, 0.0, -1.0]], &HierarchySettings::default()),
        Err(HierarchyError::InvalidLeaf { index: 0, .. })
    ));
    for b in [1.0, 17.0, f64::NAN] {
        assert!(matches!(
            build_hierarchy(&pair, &HierarchySettings { branching: b, seed: 1 }),
            Err(HierarchyError::InvalidBranching { .. })
        ));
    }
}

/// The geom crate's support-set solver against the brute-force reference on random ball sets.
#[test]
fn exact_enclosing_ball_agrees_with_brute_force() {
    let mut state = 5u64;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut worst: f64 = 1.0;
    for trial in 0..400 {
        let n = 1 + trial % 12;
        let balls: Vec<(DVec3, f64)> =
            (0..n).map(|_| (DVec3::new(next(), next(), next() * 0.3) * 10.0, next() * next() * 3.0)).collect();
        let (_, fast) = spherebake_geom::sphere::min_enclosing_ball_of_balls(&balls);
        let (bc, brute) = brute_force_min_ball_of_balls(&balls);
        for (c, r) in &balls {
            assert!(c.distance(bc) + r <= brute * (1.0 + 1e-9), "reference encloses");
        }
        worst = worst.max(fast / brute);
        assert!(fast >= brute * (1.0 - 1e-9), "nothing smaller than the minimum");
    }
    println!("geom min_enclosing_ball_of_balls / brute force, worst ratio: {worst:.12}");
    assert!(worst <= 1.0 + 1e-9, "{worst}");
}

/// Leaves from the real fitter (variational, 64 spheres) on small shared models.
#[test]
fn hierarchy_over_fitted_sphere_sets() {
    {
        let rel = "obj/spot/spot_triangulated.obj";
        let Some(path) = spherebake_testkit::shared_model(rel) else { return };
        let mesh = spherebake_io::load_mesh(&path).unwrap().mesh;
        let settings = spherebake_fit::FitSettings { spheres: 64, ..Default::default() };
        let t = std::time::Instant::now();
        let fit = spherebake_fit::fit(&mesh.positions, &mesh.triangles, &settings, &|_| {}).unwrap();
        let leaves: Vec<[f32; 4]> = fit.spheres.clone();
        let h = build_hierarchy(&leaves, &HierarchySettings::default()).unwrap();
        let mean = check_invariants(rel, &h, &leaves);
        let stats = hierarchy_stats(&h, &leaves);
        println!(
            "{rel} (fit, {} leaves, {:.1} s): {} nodes, mean branching {mean:.3}, tightness mean {:.9} max {:.9}",
            leaves.len(),
            t.elapsed().as_secs_f64(),
            h.nodes.len(),
            stats.tightness_mean,
            stats.tightness_max
        );
        assert!((3.0..=5.0).contains(&mean));
        assert!(stats.tightness_mean <= 1.01 && stats.tightness_max <= 1.0 + 1e-6);
    }
}

/// The fitter's largest sphere count (4096 leaves): invariants hold and the build stays quick.
#[test]
fn largest_sphere_count() {
    let mut state = 17u64;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) as f32
    };
    // Points on a torus-like shell, radii 0.01..0.05.
    let leaves: Vec<[f32; 4]> = (0..4096)
        .map(|_| {
            let (u, v) = (next() * std::f32::consts::TAU, next() * std::f32::consts::TAU);
            let ring = 2.0 + 0.5 * v.cos();
            [ring * u.cos(), ring * u.sin(), 0.5 * v.sin(), 0.01 + 0.04 * next()]
        })
        .collect();
    let t = std::time::Instant::now();
    let h = build_hierarchy(&leaves, &HierarchySettings::default()).unwrap();
    let build_s = t.elapsed().as_secs_f64();
    let mean = check_invariants("4096 leaves", &h, &leaves);
    let stats = hierarchy_stats(&h, &leaves);
    println!(
        "4096 leaves: {} nodes, {} levels, mean branching {mean:.3}, tightness mean {:.9} max {:.9}, build {build_s:.2} s",
        h.nodes.len(),
        stats.levels,
        stats.tightness_mean,
        stats.tightness_max
    );
    assert!((3.0..=5.0).contains(&mean));
    assert!(stats.tightness_mean <= 1.0 + 1e-6);
    // Per node: inflation over the reference within 1e-6 of the radius, or within the f32
    // spacing at the centre (small parents far from the origin cannot do better in f32).
    for (i, n) in h.to_lists().iter().enumerate() {
        let kids: Vec<(DVec3, f64)> = n
            .children
            .iter()
            .map(|&c| ball(h.nodes[c as usize].center, h.nodes[c as usize].radius))
            .chain(n.leaf_children.iter().map(|&l| {
                ball([leaves[l as usize][0], leaves[l as usize][1], leaves[l as usize][2]], leaves[l as usize][3])
            }))
            .collect();
        let (_, reference) = brute_force_min_ball_of_balls(&kids);
        let spacing = f64::from(f32::EPSILON) * (n.center.iter().fold(0.0f32, |m, v| m.max(v.abs())) + n.radius) as f64;
        let inflation = f64::from(n.radius) - reference;
        assert!(inflation <= (1e-6 * reference).max(2.0 * spacing), "node {i}: {inflation} over {reference}");
    }
}

/// Baked hierarchies pass the file format's validation, and the runtime's refit of the rest pose
/// (sequential pair bounds) gives parents containing their children, and on the lowest level no
/// smaller than the baked exact balls (higher up the children themselves differ).
#[test]
fn baked_hierarchies_load_and_refit_in_the_runtime() {
    use spherebake_runtime::{refit, rest_node_spheres, Proxy, SphbFile, Sphere};
    let Some(files) = model_files() else { return };
    for path in files.iter().filter(|p| p.extension().is_some_and(|e| e == "glb" || e == "obj")) {
        let Ok(imported) = spherebake_io::load_mesh(path) else { continue };
        let pts: Vec<DVec3> = imported.mesh.welded_positions.iter().map(|p| p.as_dvec3()).collect();
        let leaves: Vec<[f32; 4]> = kmeans(&pts, 128, 5, 8)
            .iter()
            .map(|(c, r)| [c.x as f32, c.y as f32, c.z as f32, (*r as f32).max(1e-6 * (c.length() as f32 + 1.0))])
            .collect();
        let h = build_hierarchy(&leaves, &HierarchySettings::default()).unwrap();
        let spheres: Vec<Sphere> = leaves.iter().map(|s| Sphere { center: [s[0], s[1], s[2]], radius: s[3] }).collect();
        let file = SphbFile { spheres, hierarchy: Some(h.clone()), ..SphbFile::default() };
        let proxy = Proxy::from_file(&file).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let plan = proxy.hierarchy_plan().unwrap();
        let mut nodes = rest_node_spheres(&h);
        refit(&plan, proxy.spheres(), &mut nodes).unwrap();
        let mut growth: f64 = 1.0;
        let mut growth_sum = 0.0;
        for (i, (n, r)) in h.to_lists().iter().zip(&nodes).enumerate() {
            if n.children.is_empty() {
                // Same children as the bake: a sequential pair bound is never below the exact ball.
                assert!(f64::from(r.radius) >= f64::from(n.radius) * (1.0 - 1e-6), "{}: node {i}", path.display());
                for &l in &n.leaf_children {
                    let s = proxy.spheres()[l as usize];
                    let d = ball(r.center, 0.0).0.distance(ball(s.center, 0.0).0);
                    assert!(d + f64::from(s.radius) <= f64::from(r.radius));
                }
            }
            growth = growth.max(f64::from(r.radius) / f64::from(n.radius));
            growth_sum += f64::from(r.radius) / f64::from(n.radius);
            for &c in &n.children {
                let k = nodes[c as usize];
                let d = ball(r.center, 0.0).0.distance(ball(k.center, 0.0).0);
                assert!(d + f64::from(k.radius) <= f64::from(r.radius));
            }
        }
        println!(
            "{}: runtime refit of the rest pose, radius / baked radius: mean {:.4}, max {growth:.4}",
            path.display(),
            growth_sum / h.nodes.len() as f64
        );
    }
}
