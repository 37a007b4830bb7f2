//! Bounding exactness, determinism and quality checks of the fit. Every check here is made
//! by code independent of the library's own containment logic: plain f64 distance tests on
//! the stored f32 values, recursive triangle subdivision, seeded random points, and E against
//! the Monte Carlo oracle of `spherebake-testkit`.

use glam::{DVec3, Vec3};
use spherebake_fit::{
    evaluate, fit, powell::powell, EvalSettings, FitError, FitPlan, FitSettings, Method, SolidSource,
};
use spherebake_geom::voxel::{voxelize, VoxelSettings};
use spherebake_testkit::oracle::outside_ratio;

#[path = "../examples/common/obj.rs"]
mod obj;

/// `../shared/models/obj/<name>`, or a visible skip (a failure with `SPHEREBAKE_REQUIRE_MODELS=1`).
fn load_obj(name: &str) -> Option<(Vec<Vec3>, Vec<[u32; 3]>)> {
    let path = spherebake_testkit::shared_model(&format!("obj/{name}"))?;
    Some(obj::load_obj(path.to_str().expect("UTF-8 path")))
}

/// Closed outward boundary of a union of unit voxels scaled by `s`, each face split into
/// `n`×`n` quads (so the fixtures have enough vertices to cluster): `spherebake_testkit::mesh::voxel_union`.
fn voxel_union(cells: &[[i32; 3]], s: f32, n: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (p, t) = spherebake_testkit::mesh::voxel_union(cells, n);
    (p.into_iter().map(|p| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) * (s / n as f32)).collect(), t)
}

fn in_some(spheres: &[[f32; 4]], p: DVec3) -> bool {
    spheres.iter().any(|s| {
        let c = DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64);
        p.distance_squared(c) <= (s[3] as f64) * (s[3] as f64)
    })
}

/// Every triangle is partitioned (recursive 4-splits, depth ≤ 12) into pieces each inside one
/// sphere (three corners inside ⇒ piece inside, by convexity).
fn assert_triangles_covered(p: &[Vec3], t: &[[u32; 3]], spheres: &[[f32; 4]]) {
    fn piece_ok(spheres: &[[f32; 4]], tri: [DVec3; 3], depth: u32) -> bool {
        let one = spheres.iter().any(|s| {
            let c = DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64);
            let r2 = (s[3] as f64) * (s[3] as f64);
            tri.iter().all(|q| q.distance_squared(c) <= r2)
        });
        if one {
            return true;
        }
        if depth >= 12 {
            return false;
        }
        let m01 = (tri[0] + tri[1]) * 0.5;
        let m12 = (tri[1] + tri[2]) * 0.5;
        let m20 = (tri[2] + tri[0]) * 0.5;
        [[tri[0], m01, m20], [m01, tri[1], m12], [m20, m12, tri[2]], [m01, m12, m20]]
            .into_iter()
            .all(|q| piece_ok(spheres, q, depth + 1))
    }
    for (i, tri) in t.iter().enumerate() {
        let c = [p[tri[0] as usize].as_dvec3(), p[tri[1] as usize].as_dvec3(), p[tri[2] as usize].as_dvec3()];
        assert!(piece_ok(spheres, c, 0), "triangle {i} not covered by the sphere set");
    }
}

/// A million seeded area-weighted random surface points, all inside the union.
fn assert_random_surface_points_covered(p: &[Vec3], t: &[[u32; 3]], spheres: &[[f32; 4]], n: usize) {
    let mut cum = Vec::new();
    let mut acc = 0.0f64;
    for tri in t {
        let (a, b, c) = (p[tri[0] as usize].as_dvec3(), p[tri[1] as usize].as_dvec3(), p[tri[2] as usize].as_dvec3());
        acc += 0.5 * (b - a).cross(c - a).length();
        cum.push(acc);
    }
    let mut state = 0xDEAD_BEEF_u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut missed = 0;
    for _ in 0..n {
        let x = next() * acc;
        let ti = cum.partition_point(|&v| v <= x).min(t.len() - 1);
        let tri = t[ti];
        let (a, b, c) = (p[tri[0] as usize].as_dvec3(), p[tri[1] as usize].as_dvec3(), p[tri[2] as usize].as_dvec3());
        let (mut u, mut v) = (next(), next());
        if u + v > 1.0 {
            u = 1.0 - u;
            v = 1.0 - v;
        }
        if !in_some(spheres, a + (b - a) * u + (c - a) * v) {
            missed += 1;
        }
    }
    assert_eq!(missed, 0, "{missed} of {n} random surface points outside the union");
}

/// The unit cubes of the L-shaped fixture (a corner and its three neighbours).
const L_CELLS: [[i32; 3]; 4] = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]];

#[test]
fn l_shape_bounds_surface_and_interior_for_all_methods() {
    let (p, t) = voxel_union(&L_CELLS, 1.0, 4);
    for method in [Method::Variational, Method::Kmeans, Method::Octree] {
        let s = FitSettings { method, spheres: 12, voxel_resolution: 48, ..Default::default() };
        let r = fit(&p, &t, &s, &|_| {}).unwrap();
        assert_eq!(r.stats.solid_source, SolidSource::ClosedMesh);
        assert!(r.spheres.len() >= 12 && r.spheres.len() <= 18, "{method:?}: {}", r.spheres.len());
        assert_triangles_covered(&p, &t, &r.spheres);
        assert_random_surface_points_covered(&p, &t, &r.spheres, 100_000);
        // Interior: a dense lattice of points inside the four unit cubes.
        for i in 0..40 {
            for j in 0..40 {
                for k in 0..40 {
                    let q = DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) / 20.0;
                    let cell = [q.x.floor() as i32, q.y.floor() as i32, q.z.floor() as i32];
                    let inside = L_CELLS.contains(&cell);
                    if inside {
                        assert!(in_some(&r.spheres, q), "{method:?}: interior point {q} not covered");
                    }
                }
            }
        }
        // E against an independent Monte Carlo estimate (spherebake_testkit::oracle) with the
        // analytic solid (the four unit cubes, volume 4): the fit's exact E and the evaluator's
        // (what `spherebake eval` prints) both lie within 4 standard errors of it.
        assert!((r.stats.object_volume - 4.0).abs() < 1e-5);
        let mc = outside_ratio(&r.spheres, 4.0, 400_000, 5, |x| {
            let cell = x.map(|v| v.floor() as i32);
            L_CELLS.contains(&cell)
        });
        let tol = 4.0 * mc.standard_error + 1e-9;
        eprintln!("{method:?}: fit E {:.5}, oracle {:.5} ± {:.5}", r.stats.outside_ratio_e, mc.e, mc.standard_error);
        assert!(mc.standard_error < 0.02 * mc.e.max(0.01), "{method:?}: oracle too noisy: {mc:?}");
        assert!(
            (r.stats.outside_ratio_e - mc.e).abs() <= tol,
            "{method:?}: fit E {} vs oracle {mc:?}",
            r.stats.outside_ratio_e
        );
        let ev = evaluate(&p, &t, &r.spheres, &EvalSettings { surface_samples: 10_000, ..Default::default() }).unwrap();
        assert!((ev.outside_ratio_e - mc.e).abs() <= tol, "{method:?}: eval E {} vs oracle {mc:?}", ev.outside_ratio_e);
        assert_eq!(ev.surface_coverage, 1.0);
    }
}

#[test]
fn variational_beats_kmeans_on_same_count() {
    let (p, t) = voxel_union(&[[0, 0, 0], [1, 0, 0], [2, 0, 0], [2, 1, 0], [2, 2, 0], [0, 0, 1]], 1.0, 4);
    let e = |method| {
        let s = FitSettings { method, spheres: 16, voxel_resolution: 64, ..Default::default() };
        fit(&p, &t, &s, &|_| {}).unwrap().stats.outside_ratio_e
    };
    let (ev, ek) = (e(Method::Variational), e(Method::Kmeans));
    assert!(ev < ek, "variational E {ev} should beat k-means E {ek}");
}

#[test]
fn deterministic_across_thread_counts() {
    let (p, t) = voxel_union(&[[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1]], 0.7, 3);
    let plan = FitPlan { point_resolution: 24, ..FitPlan::default() };
    let s = FitSettings { spheres: 10, voxel_resolution: 32, plan, ..Default::default() };
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| fit(&p, &t, &s, &|_| {}).unwrap())
    };
    let a = run(1);
    let b = run(4);
    let bits =
        |r: &spherebake_fit::FitResult| -> Vec<u32> { r.spheres.iter().flatten().map(|x| x.to_bits()).collect() };
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(a.stats.outside_ratio_e.to_bits(), b.stats.outside_ratio_e.to_bits());
    // The seed reaches the fit: another seed gives the same count but another Lloyd run (its
    // proxy E in the trace, so a seed that is ignored fails here). The spheres themselves can
    // agree: here the seed-free split start ends lowest from either seed.
    let c = fit(&p, &t, &FitSettings { seed: 99, ..s.clone() }, &|_| {}).unwrap();
    assert_eq!(c.spheres.len(), a.spheres.len());
    let lloyd_e = |r: &spherebake_fit::FitResult| r.stats.trace.iter().find(|e| e.stage == "lloyd").and_then(|e| e.e);
    assert_ne!(lloyd_e(&c), lloyd_e(&a), "seed 99 gives the same Lloyd run as seed {}", s.seed);
    // Same seed again, same spheres (the difference above comes from the seed alone).
    assert_eq!(bits(&fit(&p, &t, &s, &|_| {}).unwrap()), bits(&a));
}

#[test]
fn teleportation_accepted_only_when_e_drops() {
    let (p, t) = voxel_union(&[[0, 0, 0], [1, 0, 0], [2, 0, 0], [2, 1, 0], [0, 0, 1], [0, 0, 2]], 1.0, 3);
    let (mut trials, mut chains) = (0, 0);
    for seed in 0..2 {
        let plan = FitPlan { teleport_attempts: 8, ..FitPlan::default() };
        let s = FitSettings { spheres: 12, voxel_resolution: 48, seed, plan, ..Default::default() };
        let r = fit(&p, &t, &s, &|_| {}).unwrap();
        let h = &r.stats.teleport_history;
        // Each record's "before" is measured on the state the fit actually carries on with, so
        // consecutive records check the decisions against what happened next (one part, one
        // Lloyd run: a single chain). The Lloyd steps between trials only keep lower energies.
        for w in h.windows(2) {
            let ((b0, t0, acc0), (b1, _, _)) = (w[0], w[1]);
            // A worse trial was never taken: the carried energy never rises ...
            assert!(b1 <= b0, "seed {seed}: proxy E rose from {b0} to {b1} across a trial");
            // ... and an accepted trial really replaced the state.
            if acc0 {
                assert!(b1 <= t0, "seed {seed}: accepted trial {t0}, but the next trial starts from {b1}");
            }
        }
        for &(before, trial, accepted) in h {
            if accepted {
                assert!(trial < before, "seed {seed}: accepted a trial {trial} not below {before}");
            }
        }
        assert_eq!(r.stats.teleports_tried, h.len());
        assert_eq!(r.stats.teleports_accepted, h.iter().filter(|x| x.2).count());
        trials += h.len();
        chains += usize::from(h.len() >= 2);
    }
    assert!(trials > 0, "no teleportation was tried");
    assert!(chains > 0, "no run tried two teleportations: the chain checks above checked nothing");
}

#[test]
fn powell_finds_known_minimum() {
    // Rotated anisotropic quadratic with minimum 3 at (1, −2, 0.5).
    let mut f = |x: [f64; 3]| {
        let (a, b, c) = (x[0] - 1.0, x[1] + 2.0, x[2] - 0.5);
        let (u, v) = (a + b, a - b);
        3.0 + u * u + 10.0 * v * v + 4.0 * c * c + u * c
    };
    let r = powell(&mut f, [5.0, 5.0, 5.0], 1.0, 30, 1e-12);
    assert!((r.x[0] - 1.0).abs() < 1e-3 && (r.x[1] + 2.0).abs() < 1e-3 && (r.x[2] - 0.5).abs() < 1e-3, "{:?}", r.x);
    assert!((r.f - 3.0).abs() < 1e-6);
    // Rosenbrock-like valley in 3-D: minimum 0 at (1, 1, 1).
    let mut g = |x: [f64; 3]| {
        100.0 * (x[1] - x[0] * x[0]).powi(2)
            + (1.0 - x[0]).powi(2)
            + 100.0 * (x[2] - x[1] * x[1]).powi(2)
            + (1.0 - x[1]).powi(2)
    };
    let r = powell(&mut g, [-1.0, 1.5, 0.0], 0.5, 200, 1e-14);
    assert!(r.f < 1e-4, "{:?}", r);
}

#[test]
fn typed_errors() {
    let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
    assert_eq!(fit(&p, &[], &FitSettings::default(), &|_| {}).unwrap_err(), FitError::NoTriangles);
    assert!(matches!(
        fit(&p, &[[0, 1, 7]], &FitSettings::default(), &|_| {}),
        Err(FitError::IndexOutOfRange { triangle: 0, index: 7, vertex_count: 3 })
    ));
    let q = vec![Vec3::ZERO, Vec3::X, Vec3::new(f32::NAN, 0.0, 0.0)];
    assert!(matches!(
        fit(&q, &[[0, 1, 2]], &FitSettings::default(), &|_| {}),
        Err(FitError::NonFinitePosition { index: 2 })
    ));
    let s = FitSettings { spheres: 0, ..Default::default() };
    assert!(matches!(fit(&p, &[[0, 1, 2]], &s, &|_| {}), Err(FitError::InvalidSetting { name: "spheres", .. })));
}

#[test]
fn real_models_are_bounded() {
    // The bunny's five base holes are small: they are filled and its solid is the filled mesh.
    for (name, holes) in [("armadillo.obj", false), ("stanford-bunny.obj", true)] {
        let Some((p, t)) = load_obj(name) else { continue };
        let s = FitSettings { spheres: 24, ..Default::default() };
        let r = fit(&p, &t, &s, &|_| {}).unwrap();
        assert_eq!(r.stats.solid_source, SolidSource::ClosedMesh, "{name}");
        assert_eq!(
            r.warnings.iter().any(|w| w.contains("5 small hole(s) were filled")),
            holes,
            "{name}: {:?}",
            r.warnings
        );
        if holes {
            // Independent check of V(T): the voxel solid of the open mesh (|w| ≥ ½ at cell
            // centres) at 256 cells agrees with the filled mesh's volume within 1 %.
            let v = voxelize(&p, &t, &VoxelSettings { resolution: 256 }).volume();
            assert!((r.stats.object_volume - v).abs() / v < 0.01, "{} vs voxel {v}", r.stats.object_volume);
        }
        assert_triangles_covered(&p, &t, &r.spheres);
        assert_random_surface_points_covered(&p, &t, &r.spheres, 1_000_000);
        println!("{name}: E = {:.4} with {} spheres", r.stats.outside_ratio_e, r.spheres.len());
        if !holes {
            // Independent check of V(T): the reference volume of the model README.
            assert!((r.stats.object_volume - 237843.1).abs() / 237843.1 < 1e-6);
        }
    }
}

/// A UV sphere (radius 1) without its southern quarter (triangles whose centroid has z < −½:
/// a hole far too large to fill, so T is the voxel solid), outward-wound, then stretched to the
/// ellipsoid of semi-axes 2, 1, 0.7 (so one sphere cannot fit it; volumes scale by 1.4).
fn cut_ellipsoid() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (p, t) = spherebake_testkit::mesh::uv_sphere(16, 1.0);
    let t = t.into_iter().filter(|f| f.iter().map(|&i| p[i as usize][2]).sum::<f64>() / 3.0 >= -0.5).collect();
    let p = p.iter().map(|q| Vec3::new((2.0 * q[0]) as f32, q[1] as f32, (0.7 * q[2]) as f32)).collect();
    (p, t)
}

/// The cut ellipsoid and its inward-wound twin (every triangle reversed) have one solid — the same
/// cells, so the same V(T) to the last bit — and the fit bounds both: every triangle, and every
/// seeded random point that is inside by the oracle's brute-force winding number (|w| ≥ 0.6,
/// a margin off the rim of the hole where w passes ½), which the pocket check must treat as
/// inside for the inward twin too (w ≈ −1 there).
#[test]
fn inward_wound_open_mesh_has_its_twins_solid_and_is_bounded() {
    let (p, out) = cut_ellipsoid();
    let inward: Vec<[u32; 3]> = out.iter().map(|f| [f[0], f[2], f[1]]).collect();
    let settings = FitSettings { spheres: 24, voxel_resolution: 64, ..Default::default() };
    let a = fit(&p, &out, &settings, &|_| {}).unwrap();
    let b = fit(&p, &inward, &settings, &|_| {}).unwrap();
    assert_eq!((a.stats.solid_source, b.stats.solid_source), (SolidSource::VoxelSolid, SolidSource::VoxelSolid));
    assert_eq!(a.stats.object_volume, b.stats.object_volume, "the twins' solids differ");
    // The solid is most of the ellipsoid: the cut removes the cap below z = −½ (of the unit
    // sphere) only in part (w stays above ½ well below the rim), so V(T) lies between the
    // ellipsoid above that plane and the whole ellipsoid (unit-ball volumes × 1.4).
    let cap = 1.4 * std::f64::consts::PI * 0.5f64.powi(2) * (3.0 - 0.5) / 3.0;
    let whole = 1.4 * 4.0 / 3.0 * std::f64::consts::PI;
    assert!(a.stats.object_volume > 0.95 * (whole - cap) && a.stats.object_volume < whole, "{}", a.stats.object_volume);
    let pd: Vec<[f64; 3]> = p.iter().map(|q| q.as_dvec3().to_array()).collect();
    for (r, t) in [(&a, &out), (&b, &inward)] {
        assert_triangles_covered(&p, t, &r.spheres);
        let mut rng = spherebake_testkit::rng::SplitMix64::new(5);
        let mut inside = 0;
        for _ in 0..20_000 {
            let x = [rng.range(-2.0, 2.0), rng.range(-1.0, 1.0), rng.range(-0.7, 0.7)];
            let w = spherebake_testkit::oracle::winding_number(&pd, t, x);
            if w.abs() >= 0.6 {
                inside += 1;
                assert!(in_some(&r.spheres, DVec3::from_array(x)), "{x:?} (w {w}) outside every sphere");
            }
        }
        assert!(inside > 5_000, "{inside} inside points");
    }
}

#[test]
fn flat_sheet_is_bounded() {
    // A single quad encloses no volume; the fit still bounds it (solid = surface cell layer).
    let p = vec![
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(-1.0, 0.0, 1.0),
    ];
    let t = vec![[0, 2, 1], [0, 3, 2]];
    for method in [Method::Variational, Method::Kmeans, Method::Octree] {
        let r = fit(&p, &t, &FitSettings { method, spheres: 8, voxel_resolution: 32, ..Default::default() }, &|_| {})
            .unwrap();
        assert!(r.warnings.iter().any(|w| w.contains("encloses no volume")), "{:?}", r.warnings);
        assert_triangles_covered(&p, &t, &r.spheres);
        assert_random_surface_points_covered(&p, &t, &r.spheres, 50_000);
    }
}

/// Outward-wound faces of a box whose corner i is at (x, y, z) = the bits of i (i = x + 2y + 4z):
/// the unit cube's triangles (`spherebake_testkit::mesh::unit_cube`, the same corner order).
fn box_faces() -> Vec<[u32; 3]> {
    spherebake_testkit::mesh::unit_cube().1
}

/// A closed box thinner than a cell encloses volume, but no cell centre: the warning says so
/// (not "encloses no volume"), E is measured against the box's exact volume, and the box is
/// still bounded; at a resolution that puts cell centres inside it, the warning is gone.
#[test]
fn a_closed_mesh_thinner_than_a_cell_is_named_as_such_and_bounded() {
    let (a, b, c) = (10.0f32, 1.0f32, 0.05f32);
    let p: Vec<Vec3> =
        (0..8).map(|i| Vec3::new(a * (i & 1) as f32, b * ((i >> 1) & 1) as f32, c * (i >> 2) as f32)).collect();
    // The box [0,a]×[0,b]×[0,c].
    let t = box_faces();
    let thin = fit(&p, &t, &FitSettings { spheres: 8, voxel_resolution: 32, ..Default::default() }, &|_| {}).unwrap();
    let w = thin.warnings.iter().find(|w| w.contains("thinner than a voxel cell")).expect("the thin-box warning");
    assert!(!thin.warnings.iter().any(|w| w.contains("encloses no volume")), "{:?}", thin.warnings);
    // The cell is 10/32 = 0.3125 (> 0.05), the volume 0.5: both in the message.
    assert!(w.contains("3.125e-1") && w.contains("5.000e-1"), "{w}");
    assert_triangles_covered(&p, &t, &thin.spheres);
    // E = Σ (V(S_i) − V(S_i ∩ T)) / V(T) against the box's exact volume V(T) = 0.5: the union
    // holds T, so Σ V(S_i ∩ T) ≥ V(T), and each V(S_i ∩ T) ≤ V(T); hence
    // Σ V(S_i)/V(T) − k ≤ E ≤ Σ V(S_i)/V(T) − 1. Against the surface layer's volume (~16× the
    // box's here) E would be far below that range.
    let vol = f64::from(a * b * c);
    let k = thin.spheres.len() as f64;
    let sum_v: f64 = thin.spheres.iter().map(|s| 4.0 / 3.0 * std::f64::consts::PI * f64::from(s[3]).powi(3)).sum();
    let e = thin.stats.outside_ratio_e;
    assert!(
        e >= sum_v / vol - k - 1e-6 && e <= sum_v / vol - 1.0 + 1e-6,
        "E {e}, Σ V(S_i)/V(T) {}, k {k}",
        sum_v / vol
    );
    // At 512 cells along x the cell is 0.0195 < 0.05: centres fall inside, no warning.
    let fine = fit(&p, &t, &FitSettings { spheres: 8, voxel_resolution: 512, ..Default::default() }, &|_| {}).unwrap();
    assert!(!fine.warnings.iter().any(|w| w.contains("thinner") || w.contains("no volume")), "{:?}", fine.warnings);
}

/// A closed hollow box (an outer cube and an inward-wound inner one, walls w thick) at 64
/// cells: with walls of one or two cells its solid is all surface cells, and the warning says
/// E is relative to a thin solid; with walls of 4 or 16 cells it is not thin, and neither is
/// the solid cube. The share itself is tested in `spherebake_geom::voxel`.
#[test]
fn a_thin_walled_solid_is_named_and_a_thick_one_is_not() {
    let hollow = |wall: f32| {
        let cube = |lo: f32, hi: f32| -> Vec<Vec3> {
            (0..8).map(|i| Vec3::new([lo, hi][i & 1], [lo, hi][(i >> 1) & 1], [lo, hi][(i >> 2) & 1])).collect()
        };
        let faces = box_faces();
        let mut p = cube(0.0, 1.0);
        let mut t: Vec<[u32; 3]> = faces.to_vec();
        if wall > 0.0 {
            p.extend(cube(wall, 1.0 - wall));
            t.extend(faces.iter().map(|f| [f[0] + 8, f[2] + 8, f[1] + 8]));
        }
        (p, t)
    };
    let thin_warning = |wall: f32| {
        let (p, t) = hollow(wall);
        let r = fit(&p, &t, &FitSettings { spheres: 8, voxel_resolution: 64, ..Default::default() }, &|_| {}).unwrap();
        r.warnings.iter().any(|w| w.contains("only a few voxel cells thick"))
    };
    // Walls of 1 or 2 cells: every cell on a surface (share 1); of 4 cells about half (2 / 4,
    // below `THIN_SOLID_SHARE`).
    assert!(thin_warning(1.0 / 64.0));
    assert!(thin_warning(2.0 / 64.0));
    assert!(!thin_warning(4.0 / 64.0));
    assert!(!thin_warning(16.0 / 64.0));
    assert!(!thin_warning(0.0));
}

#[test]
fn voxel_proxy_agrees_with_exact_volume() {
    use spherebake_geom::volume::ball_mesh_intersection_volume;
    let (p, t) = voxel_union(&[[0, 0, 0]], 1.0, 1);
    let pd: Vec<DVec3> = p.iter().map(|x| x.as_dvec3()).collect();
    let solid = spherebake_fit::solid::Solid::from_grid(voxelize(&p, &t, &VoxelSettings { resolution: 64 }));
    // Cells are offset from the faces, so the voxel volume is within area × cell of 1.
    assert!((solid.volume() - 1.0).abs() <= 6.0 * solid.h, "voxelization of the unit cube: {}", solid.volume());
    for (c, r) in
        [(DVec3::splat(0.5), 0.6), (DVec3::new(0.9, 0.2, 0.5), 0.4), (DVec3::ZERO, 0.5), (DVec3::splat(0.3), 0.2)]
    {
        let exact = ball_mesh_intersection_volume(c, r, &pd, &t);
        let proxy = solid.ball_volume(c, r);
        // Error bound: the ball's surface area times one cell.
        let tol = 4.0 * std::f64::consts::PI * r * r * solid.h;
        assert!((exact - proxy).abs() <= tol, "c {c}, r {r}: exact {exact}, proxy {proxy}, tol {tol}");
    }
}

#[test]
fn target_mode_reaches_the_ratio() {
    let (p, t) = voxel_union(&[[0, 0, 0], [1, 0, 0], [0, 1, 0]], 1.0, 2);
    let plan = FitPlan { point_resolution: 16, ..FitPlan::default() };
    let s = FitSettings { max_outside_ratio: Some(0.6), voxel_resolution: 32, plan, ..Default::default() };
    let r = fit(&p, &t, &s, &|_| {}).unwrap();
    assert!(r.stats.outside_ratio_e <= 0.6, "E {}", r.stats.outside_ratio_e);
    assert_eq!(r.stats.sphere_count, r.spheres.len());
    assert!(r.warnings.iter().any(|w| w.starts_with("target mode")), "{:?}", r.warnings);
    assert_triangles_covered(&p, &t, &r.spheres);
}

/// A target the first count (8) already meets is bisected down: the count returned meets it and
/// one sphere fewer, fitted alone with the same settings, does not (the bisection is exact
/// below 32 spheres). Before, the search never went below half its first count.
#[test]
fn target_mode_searches_below_its_first_count() {
    let (p, t) = voxel_union(&[[0, 0, 0], [1, 0, 0], [0, 1, 0]], 1.0, 2);
    let plan = FitPlan { point_resolution: 16, descent_trials: 8, seam_rounds: 1, ..FitPlan::default() };
    let base = FitSettings { voxel_resolution: 32, plan, ..Default::default() };
    let at = |k: usize| fit(&p, &t, &FitSettings { spheres: k, ..base.clone() }, &|_| {}).unwrap();
    let e8 = at(8).stats.outside_ratio_e;
    // A target between what 8 spheres and 1 sphere reach.
    let e1 = at(1).stats.outside_ratio_e;
    assert!(e1 > e8, "{e1} {e8}");
    let target = e8 + 0.5 * (e1 - e8);
    let r = fit(&p, &t, &FitSettings { max_outside_ratio: Some(target), ..base.clone() }, &|_| {}).unwrap();
    let k = r.spheres.len();
    assert!(r.stats.outside_ratio_e <= target && k < 8, "k {k}, E {} target {target}", r.stats.outside_ratio_e);
    assert!(k == 1 || at(k - 1).stats.outside_ratio_e > target, "{} spheres already meet {target}", k - 1);
    assert_triangles_covered(&p, &t, &r.spheres);
}

#[test]
fn small_holes_are_filled_large_ones_are_not() {
    let (p, t) = voxel_union(&[[0, 0, 0], [1, 0, 0], [0, 1, 0]], 1.0, 4);
    let s = FitSettings { spheres: 6, voxel_resolution: 32, ..Default::default() };
    let closed = fit(&p, &t, &s, &|_| {}).unwrap();
    assert_eq!(closed.stats.solid_source, SolidSource::ClosedMesh);
    // One triangle removed: a 3-edge hole, filled by a coplanar fan, same volume.
    let mut t1 = t.clone();
    t1.remove(7);
    let r = fit(&p, &t1, &s, &|_| {}).unwrap();
    assert_eq!(r.stats.solid_source, SolidSource::ClosedMesh);
    assert!(r.warnings.iter().any(|w| w.contains("3 boundary edges") && w.contains("1 small hole(s) were filled")));
    assert!((r.stats.object_volume - closed.stats.object_volume).abs() < 1e-6 * closed.stats.object_volume);
    assert_triangles_covered(&p, &t1, &r.spheres);
    // Every triangle of one unit face (x = 0 plane of the first cube) removed: the hole is 1/14 of
    // the area (> 5 %), so the solid stays the voxel solid.
    let t2: Vec<[u32; 3]> = t
        .iter()
        .copied()
        .filter(|tri| !tri.iter().all(|&v| p[v as usize].x == 0.0 && p[v as usize].y <= 1.0))
        .collect();
    assert!(t.len() - t2.len() >= 2 * 16);
    let r = fit(&p, &t2, &s, &|_| {}).unwrap();
    assert_eq!(r.stats.solid_source, SolidSource::VoxelSolid);
    assert_triangles_covered(&p, &t2, &r.spheres);
}

#[test]
fn unreferenced_vertices_do_not_constrain_the_fit() {
    let (p, t) = voxel_union(&[[0, 0, 0], [1, 0, 0], [0, 1, 0]], 1.0, 4);
    let s = FitSettings { spheres: 6, voxel_resolution: 32, ..Default::default() };
    let a = fit(&p, &t, &s, &|_| {}).unwrap();
    // A vertex no triangle uses, far outside (the bunny has 1113 such): same result.
    let mut p2 = p.clone();
    p2.push(Vec3::new(0.5, 0.5, 3.0));
    let b = fit(&p2, &t, &s, &|_| {}).unwrap();
    assert_eq!(a.spheres, b.spheres);
}

#[test]
fn variational_beats_the_octree_on_the_unit_cube() {
    // Issue 16: a fit that loses to a grid on the simplest solid has a start or move-set
    // problem. 12 triangles; the octree is the baseline of Ren et al. Fig. 4. It may use up to
    // 6 spheres more than asked (asked for 4 it gives the 8 octants, for 16 it gives 22), so
    // the fit is asked for the octree's own count: the claim is at equal sphere counts.
    let (p, t) = voxel_union(&[[0, 0, 0]], 1.0, 1);
    assert_eq!(t.len(), 12);
    for k in [4, 8, 16, 32, 64, 128, 256] {
        let run =
            |method, spheres| fit(&p, &t, &FitSettings { method, spheres, ..Default::default() }, &|_| {}).unwrap();
        let o = run(Method::Octree, k);
        let n = o.spheres.len();
        assert!((k..=k + 6).contains(&n), "k {k}: the octree gave {n} spheres");
        let v = run(Method::Variational, n);
        assert!(v.spheres.len() <= n);
        assert_triangles_covered(&p, &t, &v.spheres);
        let (ev, eo) = (v.stats.outside_ratio_e, o.stats.outside_ratio_e);
        assert!(ev < eo, "{n} spheres: variational E {ev} should beat the octree's {eo}");
        // The box-lattice start (2 × 2 × 3-like cells the octree cannot cut) beats it clearly
        // once the lattice is fine: without it 0.338 against 0.418 at 128, 0.333 against
        // 0.347 at 256; with it 0.279 and 0.199.
        if k >= 128 {
            assert!(ev <= 0.8 * eo, "{n} spheres: variational E {ev} should be at most 0.8 × the octree's {eo}");
        }
    }
}

/// The unit cube's E falls in steps: 8 → 16 spheres barely moves it, so the early stop, judged
/// there, called a target that 64 spheres meet out of reach and returned 16 spheres far above
/// it. It now judges from the default count (64) on.
#[test]
fn target_mode_does_not_stop_before_the_default_count() {
    let (p, t) = voxel_union(&[[0, 0, 0]], 1.0, 1);
    let plan = FitPlan { descent_trials: 8, seam_rounds: 1, ..FitPlan::default() };
    let base = FitSettings { voxel_resolution: 32, plan, ..Default::default() };
    let at =
        |k: usize| fit(&p, &t, &FitSettings { spheres: k, ..base.clone() }, &|_| {}).unwrap().stats.outside_ratio_e;
    let (e8, e16, e64) = (at(8), at(16), at(64));
    // The target: what 64 spheres reach, while 8 → 16 fell by less than the rate that reaches it.
    let target = e64;
    assert!(e16 > target && e8 > target, "{e8} {e16} {e64}");
    let r = fit(&p, &t, &FitSettings { max_outside_ratio: Some(target), ..base.clone() }, &|_| {}).unwrap();
    assert!(
        r.stats.outside_ratio_e <= target,
        "E {} > {target} with {} spheres: {:?}",
        r.stats.outside_ratio_e,
        r.spheres.len(),
        r.warnings
    );
    assert_triangles_covered(&p, &t, &r.spheres);
}

/// Two closed unit cubes, the second moved by `dx` along x: a closed mesh (every edge paired)
/// whose parts overlap when `dx` < 1.
fn two_cubes(dx: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (c, t) = spherebake_testkit::mesh::unit_cube();
    let mut p: Vec<Vec3> = c.iter().map(|q| Vec3::new(q[0] as f32, q[1] as f32, q[2] as f32)).collect();
    p.extend(c.iter().map(|q| Vec3::new(q[0] as f32 + dx, q[1] as f32, q[2] as f32)));
    let mut tris = t.clone();
    tris.extend(t.iter().map(|f| f.map(|v| v + 8)));
    (p, tris)
}

/// Closed parts that overlap are solid once (the union), not twice: two unit cubes overlapping
/// by half are the 1.5 × 1 × 1 box. The mesh's signed volume (2.0) and its exact ball volumes
/// count the overlap twice, so the fit says so and measures on the voxel solid: V(T) near 1.5
/// and E within a few per cent of a Monte Carlo E against the analytic union (before, V(T) was
/// 2.0 and E was off by a factor of two). Apart, the same two cubes stay an exact closed mesh.
#[test]
fn overlapping_closed_parts_are_measured_as_their_union() {
    let s = FitSettings { spheres: 8, voxel_resolution: 64, ..Default::default() };
    let (p, t) = two_cubes(0.5);
    let r = fit(&p, &t, &s, &|_| {}).unwrap();
    assert!(r.warnings.iter().any(|w| w.starts_with("closed parts overlap")), "{:?}", r.warnings);
    assert_eq!(r.stats.solid_source, SolidSource::VoxelSolid);
    assert!((r.stats.object_volume - 1.5).abs() < 0.02 * 1.5, "V(T) {}", r.stats.object_volume);
    assert_triangles_covered(&p, &t, &r.spheres);
    let mc = outside_ratio(&r.spheres, 1.5, 400_000, 7, |x| {
        (0.0..=1.5).contains(&x[0]) && (0.0..=1.0).contains(&x[1]) && (0.0..=1.0).contains(&x[2])
    });
    let tol = 4.0 * mc.standard_error + 0.03 * mc.e;
    assert!((r.stats.outside_ratio_e - mc.e).abs() <= tol, "fit E {} vs oracle {mc:?}", r.stats.outside_ratio_e);

    let (p, t) = two_cubes(2.0);
    let r = fit(&p, &t, &s, &|_| {}).unwrap();
    assert!(!r.warnings.iter().any(|w| w.starts_with("closed parts overlap")), "{:?}", r.warnings);
    assert_eq!(r.stats.solid_source, SolidSource::ClosedMesh);
    assert!((r.stats.object_volume - 2.0).abs() < 1e-9, "V(T) {}", r.stats.object_volume);
}

/// A part pushed wholly into another (a kitbashed model; a voxel model exported one cube per
/// voxel) leaves faces inside the solid. They bound nothing, so the fit's point sets leave them
/// out once they carry a tenth of the surface's area: a unit cube with a cube of edge 0.6
/// inside it (26 % of the area) gets exactly the clustering and dense points of the unit cube
/// alone (same voxel solid, same outer triangles first), and its spheres still cover every
/// triangle, the inner ones included, with E against the unit cube's Monte Carlo oracle.
#[test]
fn faces_inside_the_solid_leave_the_point_sets_and_are_still_covered() {
    let s = FitSettings { spheres: 16, voxel_resolution: 64, ..Default::default() };
    let (c, t) = spherebake_testkit::mesh::unit_cube();
    let outer: Vec<Vec3> = c.iter().map(|q| Vec3::new(q[0] as f32, q[1] as f32, q[2] as f32)).collect();
    let mut p = outer.clone();
    p.extend(c.iter().map(|q| Vec3::new(0.2 + 0.6 * q[0] as f32, 0.2 + 0.6 * q[1] as f32, 0.2 + 0.6 * q[2] as f32)));
    let mut tris = t.clone();
    tris.extend(t.iter().map(|f| f.map(|v| v + 8)));
    let points = |r: &spherebake_fit::FitResult, stage: &str| {
        r.stats.trace.iter().find(|e| e.stage == stage).map(|e| e.points).expect("traced")
    };
    let alone = fit(&outer, &t, &s, &|_| {}).unwrap();
    let nested = fit(&p, &tris, &s, &|_| {}).unwrap();
    assert_eq!(nested.stats.parts.len(), 1, "one solid");
    for stage in ["lloyd", "dense_points"] {
        assert_eq!(points(&nested, stage), points(&alone, stage), "{stage} points");
    }
    assert_triangles_covered(&p, &tris, &nested.spheres);
    let mc = outside_ratio(&nested.spheres, 1.0, 400_000, 11, |x| (0..3).all(|a| (0.0..=1.0).contains(&x[a])));
    let tol = 4.0 * mc.standard_error + 0.03 * mc.e;
    assert!(
        (nested.stats.outside_ratio_e - mc.e).abs() <= tol,
        "fit E {} vs oracle {mc:?}",
        nested.stats.outside_ratio_e
    );
}

/// One bounding sphere of least outside volume is the minimal ball around the vertices, so at
/// one sphere the fit returns it: the unit cube's circumsphere (radius √3/2, E = π√3/2 − 1)
/// and a UV sphere's circumsphere (radius 1 about the origin, E = V(ball) / V(T) − 1 with the
/// polyhedron's volume by the divergence theorem). With more spheres the fit never ends above
/// that ball: on the UV sphere, where the voxel proxy's half-cell errors cost more than more
/// spheres gain, 32 spheres give at most the one ball's E.
#[test]
fn one_sphere_is_the_enclosing_ball_and_no_fit_ends_above_it() {
    let s1 = FitSettings { spheres: 1, voxel_resolution: 64, ..Default::default() };
    let (c, t) = spherebake_testkit::mesh::unit_cube();
    let p: Vec<Vec3> = c.iter().map(|q| Vec3::new(q[0] as f32, q[1] as f32, q[2] as f32)).collect();
    let r = fit(&p, &t, &s1, &|_| {}).unwrap();
    let want = std::f64::consts::PI * 3f64.sqrt() / 2.0 - 1.0;
    assert_eq!(r.spheres.len(), 1);
    assert!((r.spheres[0][3] as f64 - 3f64.sqrt() / 2.0).abs() < 1e-6, "{:?}", r.spheres);
    assert!((r.stats.outside_ratio_e - want).abs() < 1e-5, "E {} vs {want}", r.stats.outside_ratio_e);

    let (q, t) = spherebake_testkit::mesh::uv_sphere(24, 1.0);
    let p: Vec<Vec3> = q.iter().map(|v| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)).collect();
    let vol: f64 = t
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|i| DVec3::from(q[i as usize]));
            a.dot(b.cross(c)) / 6.0
        })
        .sum();
    let ball_e = 4.0 / 3.0 * std::f64::consts::PI / vol - 1.0;
    let r = fit(&p, &t, &s1, &|_| {}).unwrap();
    let s = r.spheres[0];
    assert!(DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64).length() < 1e-6, "{s:?}");
    assert!((s[3] as f64 - 1.0).abs() < 1e-6, "{s:?}");
    assert!((r.stats.outside_ratio_e - ball_e).abs() < 1e-5, "E {} vs {ball_e}", r.stats.outside_ratio_e);
    let r = fit(&p, &t, &FitSettings { spheres: 32, ..s1 }, &|_| {}).unwrap();
    assert!(r.stats.outside_ratio_e <= ball_e + 1e-5, "E {} above the ball's {ball_e}", r.stats.outside_ratio_e);
    assert_triangles_covered(&p, &t, &r.spheres);
}

/// The union outside ratio V(∪S − T) / V(T) of a rod thinner than a voxel cell (10 × 0.1 ×
/// 0.1 at 64 cells), against a Monte Carlo count over the spheres' box with the analytic rod:
/// within 10 %, and never above E (V(∪S − T) ≤ Σ V(S_i − T) holds for any spheres). Measured
/// against the voxel solid, whose cells stand in for a rod no cell centre is inside, it was
/// 2.03 for a true 6.66 (and above E on other rods).
#[test]
fn the_union_outside_ratio_of_a_thin_rod_is_measured_against_the_rod() {
    let (c, t) = spherebake_testkit::mesh::unit_cube();
    let d = 0.1;
    let p: Vec<Vec3> = c.iter().map(|q| Vec3::new(10.0 * q[0] as f32, (d * q[1]) as f32, (d * q[2]) as f32)).collect();
    let r = fit(&p, &t, &FitSettings { spheres: 32, voxel_resolution: 64, ..Default::default() }, &|_| {}).unwrap();
    let (e, u) = (r.stats.outside_ratio_e, r.stats.union_outside_ratio);
    let live: Vec<[f32; 4]> = r.spheres.iter().copied().filter(|s| s[3] > 0.0).collect();
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for s in &live {
        let c = DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64);
        lo = lo.min(c - s[3] as f64);
        hi = hi.max(c + s[3] as f64);
    }
    let mut rng = spherebake_geom::rng::SplitMix64::new(3);
    let n = 400_000;
    let hits = (0..n)
        .filter(|_| {
            let x = lo + (hi - lo) * DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
            let in_rod = (0.0..=10.0).contains(&x.x) && (0.0..=d).contains(&x.y) && (0.0..=d).contains(&x.z);
            !in_rod && in_some(&live, x)
        })
        .count();
    let mc = hits as f64 / n as f64 * (hi - lo).element_product() / (10.0 * d * d);
    assert!((u - mc).abs() <= 0.1 * mc && u <= e, "union {u} vs Monte Carlo {mc}, E {e}");
    let ev = evaluate(&p, &t, &r.spheres, &EvalSettings { voxel_resolution: 64, ..Default::default() }).unwrap();
    assert!((ev.union_outside_ratio - mc).abs() <= 0.1 * mc, "{ev:?} vs {mc}");
}

/// A closed cylinder of radius `a` and length `len` along x, `n` segments: 4n triangles, the
/// sides slivers of aspect len : 2πa/n.
fn cylinder(a: f64, len: f64, n: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut p = Vec::new();
    for x in [0.0, len] {
        for i in 0..n {
            let t = std::f64::consts::TAU * i as f64 / n as f64;
            p.push(Vec3::new(x as f32, (a * t.cos()) as f32, (a * t.sin()) as f32));
        }
    }
    p.push(Vec3::new(0.0, 0.0, 0.0));
    p.push(Vec3::new(len as f32, 0.0, 0.0));
    let (c0, c1) = (2 * n, 2 * n + 1);
    let mut t = Vec::new();
    for i in 0..n {
        let j = (i + 1) % n;
        t.push([i, j, n + j]);
        t.push([i, n + j, n + i]);
        t.push([c0, j, i]);
        t.push([c1, n + i, n + j]);
    }
    (p, t)
}

/// A 100 : 1 rod at a fine voxel grid (no lattice point inside it): its sliver sides get points
/// along their length, so the fit uses every sphere asked for and stays within 1.5 × a chain of
/// equal spheres, each the circumsphere of one of k equal slices (E of the chain ≤ Σ V(S_i) /
/// V(T) − 1, since the slices' spheres hold the whole rod). Before, the slivers' grids were held
/// to 8 divisions, the clustering set had 11 points, and 11 spheres gave E 61.6.
#[test]
fn a_thin_rod_at_a_fine_grid_gets_every_sphere_asked_for() {
    let (a, len, n, k) = (0.05, 10.0, 32, 32);
    let (p, t) = cylinder(a, len, n);
    let r = fit(&p, &t, &FitSettings { spheres: k, voxel_resolution: 512, ..Default::default() }, &|_| {}).unwrap();
    assert_eq!(r.spheres.iter().filter(|s| s[3] > 0.0).count(), k, "{:?}", r.warnings);
    let v_rod = 0.5 * n as f64 * a * a * (std::f64::consts::TAU / n as f64).sin() * len;
    let rc = (a * a + (len / (2.0 * k as f64)).powi(2)).sqrt();
    let chain = k as f64 * 4.0 / 3.0 * std::f64::consts::PI * rc.powi(3) / v_rod - 1.0;
    assert!(r.stats.outside_ratio_e <= 1.5 * chain, "E {} vs chain {chain}", r.stats.outside_ratio_e);
    assert_triangles_covered(&p, &t, &r.spheres);
}

/// Triangles with a repeated corner (a quad collapsed at a pole, corners that rounding merged)
/// enclose nothing and their edges cancel: a closed UV sphere with such a triangle beside each
/// pole-fan triangle stays a closed mesh, with the exact volume of the sphere without them, and
/// is bounded. Before, one of them made the mesh "not closed" and E came from the voxel solid.
#[test]
fn collapsed_triangles_leave_a_closed_mesh_closed() {
    let (q, t) = spherebake_testkit::mesh::uv_sphere(12, 1.0);
    let p: Vec<Vec3> = q.iter().map(|v| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)).collect();
    let s = FitSettings { spheres: 8, voxel_resolution: 48, ..Default::default() };
    let plain = fit(&p, &t, &s, &|_| {}).unwrap();
    assert_eq!(plain.stats.solid_source, SolidSource::ClosedMesh);
    let poles = [0u32, q.len() as u32 - 1];
    let mut with: Vec<[u32; 3]> = t.clone();
    for f in &t {
        if let Some(&pole) = f.iter().find(|v| poles.contains(v)) {
            let other = *f.iter().find(|&&v| v != pole).unwrap();
            with.push([pole, pole, other]);
        }
    }
    assert_eq!(with.len() - t.len(), 2 * 2 * 12, "one per pole-fan triangle");
    let r = fit(&p, &with, &s, &|_| {}).unwrap();
    assert_eq!(r.stats.solid_source, SolidSource::ClosedMesh, "{:?}", r.warnings);
    assert!((r.stats.object_volume - plain.stats.object_volume).abs() < 1e-12, "{}", r.stats.object_volume);
    assert!(!r.warnings.iter().any(|w| w.contains("not closed")), "{:?}", r.warnings);
    assert_triangles_covered(&p, &with, &r.spheres);
}

/// E of the chain of `k` equal spheres along the axis of a round rod (radius `a`, length `l`),
/// each holding a slab of length 2h = l / k (radius R = √(a² + h²)): a sphere meets the
/// infinite cylinder in (4π/3)(R³ − h³), and each end sphere loses the part beyond the rod's
/// end, (2π/3)(R³ − h³) − π a² h; so E = Σ (4π/3 R³ − inside) / (π a² l).
fn chain_e(a: f64, l: f64, k: usize) -> f64 {
    let pi = std::f64::consts::PI;
    let h = l / (2.0 * k as f64);
    let r = (a * a + h * h).sqrt();
    let inner = 4.0 * pi / 3.0 * (r.powi(3) - h.powi(3));
    let beyond_end = 2.0 * pi / 3.0 * (r.powi(3) - h.powi(3)) - pi * a * a * h;
    let inside = k as f64 * inner - 2.0 * beyond_end;
    (k as f64 * 4.0 * pi / 3.0 * r.powi(3) - inside) / (pi * a * a * l)
}

/// A closed round rod (radius a = 0.5, length L = 10, 64 sides) against the chain of k equal
/// spheres along its axis, each holding a slab of length 2h = L / k (radius R = √(a² + h²)).
/// The chain's E is [`chain_e`]. The cover start spent 8 spheres on each end's rim and
/// ended at 0.487 (16 spheres) and 0.292 (32) against the chain's 0.291 and 0.109; from the
/// split start 0.316 and 0.131. Ceilings: the chain × 1.25 (the bounding pass's margin on a
/// 64-gon, measured 1.08 and 1.21).
#[test]
fn a_long_round_rod_is_fitted_about_as_well_as_a_chain() {
    let (a, l, n) = (0.5f64, 10.0f64, 64usize);
    let mut p = Vec::new();
    for z in [0.0, l] {
        for i in 0..n {
            let t = std::f64::consts::TAU * i as f64 / n as f64;
            p.push(Vec3::new((a * t.cos()) as f32, (a * t.sin()) as f32, z as f32));
        }
    }
    p.push(Vec3::new(0.0, 0.0, 0.0));
    p.push(Vec3::new(0.0, 0.0, l as f32));
    let n32 = n as u32;
    let mut t = Vec::new();
    for i in 0..n32 {
        let j = (i + 1) % n32;
        t.extend([[i, j, n32 + j], [i, n32 + j, n32 + i], [2 * n32, j, i], [2 * n32 + 1, n32 + i, n32 + j]]);
    }
    let chain = |k: usize| chain_e(a, l, k);
    for k in [16, 32] {
        let r = fit(&p, &t, &FitSettings { spheres: k, ..Default::default() }, &|_| {}).unwrap();
        let e = r.stats.outside_ratio_e;
        assert!(e <= 1.25 * chain(k), "{k} spheres: E {e} against the chain's {}", chain(k));
        let split = r.stats.trace.iter().find(|x| x.stage == "split_start").expect("traced");
        assert_eq!(split.iterations, 1, "{k} spheres: the split start should run: {split:?}");
        assert_triangles_covered(&p, &t, &r.spheres);
    }
    // The same rod turned oblique (its axis along (1, 2, 2) / 3). Cut along x, y and z its
    // slabs are slanted and their balls larger; the second split start, with the cells'
    // principal axes, cuts it across its own axis. Its voxel solid is a staircase, and its
    // points' lattice is not aligned with it, so it ends above the aligned rod: measured E
    // 0.323 at 16 spheres and 0.189 at 32 (with cuts along x, y and z alone 0.328 and 0.268),
    // asserted against the chain's 0.291 and 0.108: the 32-sphere ceiling (0.217) is the one
    // the second split start is needed for; the 16-sphere one guards the fit as a whole.
    let rot = glam::Quat::from_rotation_arc(Vec3::Z, Vec3::new(1.0, 2.0, 2.0) / 3.0);
    let turned: Vec<Vec3> = p.iter().map(|q| rot * *q).collect();
    for (k, ceiling) in [(16, 1.25), (32, 2.0)] {
        let r = fit(&turned, &t, &FitSettings { spheres: k, ..Default::default() }, &|_| {}).unwrap();
        let e = r.stats.outside_ratio_e;
        assert!(e <= ceiling * chain(k), "oblique, {k} spheres: E {e} against the chain's {}", chain(k));
        assert_triangles_covered(&turned, &t, &r.spheres);
    }
}

/// A short round cylinder (radius 0.5, length 2, 64 sides, along z) at 16 spheres. Lloyd's
/// start rings the rims; the split start (slabs across the axis, each slab's smallest ball)
/// is a chain. Their proxies before the descent are close (here the split's is 6.8 % above
/// Lloyd's: 0.545 against 0.510), and only the chain ends low, so the default plan runs the
/// split start at such a near tie (`FitPlan::split_start_tie`, 25 %). Asserted against the
/// chain of 16 equal spheres along the axis, its E from [`chain_e`]
/// (0.288): measured E 0.25 with the near tie taken, 0.411 without.
#[test]
fn a_short_cylinder_takes_the_split_start_at_a_near_tie() {
    let (a, l, k) = (0.5f64, 2.0f64, 16usize);
    // Along z, centred at the origin (a cyclic permutation of the axes keeps the winding).
    let (p, t) = cylinder(a, l, 64);
    let p: Vec<Vec3> = p.iter().map(|q| Vec3::new(q.y, q.z, q.x - 1.0)).collect();
    let chain = chain_e(a, l, k);
    assert!((chain - 0.2884).abs() < 1e-3, "{chain}");
    let out = fit(&p, &t, &FitSettings { spheres: k, ..Default::default() }, &|_| {}).unwrap();
    let e = out.stats.outside_ratio_e;
    let split = out.stats.trace.iter().find(|x| x.stage == "split_start").expect("traced");
    assert_eq!(split.iterations, 1, "the split start should run: {split:?}");
    assert!(e <= chain, "E {e} above the chain's {chain}");
    assert_triangles_covered(&p, &t, &out.spheres);
}

/// The same short cylinder at 24 spheres. A chain of more equal spheres fits a short rod worse
/// ([`chain_e`] is least at 8–9 spheres, 0.2765, and 0.2996 at 24), so Lloyd's rim rings
/// (proxy 0.337) are far below the 24-slab split start (0.934) and that start does not run;
/// the run from Lloyd's ended at E 0.313, above the fit at 16 spheres (0.253) and above the
/// best chain of at most 24. The split start's cuts stopped at their best count (proxy 0.280,
/// padded with empty spheres) run instead. Asserted: E at most the best chain of ≤ 24
/// spheres (measured 0.2725), from that start.
#[test]
fn a_short_cylinder_at_more_spheres_than_its_best_chain_takes_the_split_starts_best_count() {
    let (a, l, k) = (0.5f64, 2.0f64, 24usize);
    let (p, t) = cylinder(a, l, 64);
    let p: Vec<Vec3> = p.iter().map(|q| Vec3::new(q.y, q.z, q.x - 1.0)).collect();
    let best_chain = (1..=k).map(|j| chain_e(a, l, j)).fold(f64::INFINITY, f64::min);
    assert!((best_chain - 0.2765).abs() < 1e-3, "{best_chain}");
    let out = fit(&p, &t, &FitSettings { spheres: k, ..Default::default() }, &|_| {}).unwrap();
    let e = out.stats.outside_ratio_e;
    let split = out.stats.trace.iter().find(|x| x.stage == "split_start").expect("traced");
    assert!(split.iterations == 1 && split.round == 1, "the best count should run: {split:?}");
    assert!(e <= best_chain, "E {e} above the best chain's {best_chain}");
    assert_eq!(out.spheres.len(), k);
    assert_triangles_covered(&p, &t, &out.spheres);
}
