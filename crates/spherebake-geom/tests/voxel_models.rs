//! Voxelization of the shared real models (skipped when `shared/models` is absent).

mod voxel_support;

use spherebake_geom::voxel::{voxelize, VoxelSettings};
use spherebake_geom::winding::WindingNumber;
use spherebake_testkit::shared_model;
use std::time::Instant;
use voxel_support::{load_obj, surface, volume_bounds, Rng};

/// Sampled cells must be solid exactly when |exact winding| ≥ 0.5 at their centre, except
/// where the exact value is within 0.02 of the threshold.
fn check_against_exact(v: &[glam::Vec3], f: &[[u32; 3]], res: u32, samples: usize) -> usize {
    let grid = voxelize(v, f, &VoxelSettings { resolution: res });
    let w = WindingNumber::new(v, f);
    let mut rng = Rng::new(17);
    let mut wrong = 0;
    let mut checked = 0;
    while checked < samples {
        let i = (rng.next_u64() % grid.dims[0] as u64) as u32;
        let j = (rng.next_u64() % grid.dims[1] as u64) as u32;
        let k = (rng.next_u64() % grid.dims[2] as u64) as u32;
        let idx = grid.index(i, j, k);
        let we = w.eval_exact(grid.cell_center(i, j, k)).abs();
        if (we - 0.5).abs() < 0.02 {
            continue;
        }
        checked += 1;
        if (we >= 0.5) != grid.solid[idx] {
            wrong += 1;
        }
    }
    wrong
}

/// Process CPU time (user + system) from /proc/self/stat, 0 where unavailable. Timings are
/// printed only (no assertions): the machine may be shared.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return 0.0 };
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|s| s.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

#[test]
fn bunny_timings_and_classification() {
    let Some(path) = shared_model("obj/stanford-bunny.obj") else { return };
    let (v, f) = load_obj(&path);
    assert_eq!(f.len(), 69451);
    let (c0, t0) = (cpu_seconds(), Instant::now());
    let bvh = spherebake_geom::bvh::TriangleBvh::new(&v, &f);
    println!(
        "bunny BVH build: {:.1} ms wall, {:.0} ms cpu",
        t0.elapsed().as_secs_f64() * 1e3,
        (cpu_seconds() - c0) * 1e3
    );
    let (c0, t0) = (cpu_seconds(), Instant::now());
    let w = WindingNumber::from_bvh(bvh);
    println!(
        "bunny winding expansions: {:.1} ms wall, {:.0} ms cpu",
        t0.elapsed().as_secs_f64() * 1e3,
        (cpu_seconds() - c0) * 1e3
    );
    drop(w);
    let (lo, hi) = v.iter().fold((glam::Vec3::INFINITY, glam::Vec3::NEG_INFINITY), |(a, b), p| (a.min(*p), b.max(*p)));
    let mid = ((lo + hi) * 0.5).as_dvec3();
    let enclosed: f64 = f
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| v[i as usize].as_dvec3() - mid);
            a.dot(b.cross(c)) / 6.0
        })
        .sum();
    println!("bunny signed volume about the box centre: {enclosed:.6e}");
    for res in [64, 128, 256] {
        let (c0, t0) = (cpu_seconds(), Instant::now());
        let grid = voxelize(&v, &f, &VoxelSettings { resolution: res });
        let dt = t0.elapsed();
        let cpu = cpu_seconds() - c0;
        let cut = surface(&v, &f, &grid);
        let surf = cut.count_ones();
        println!(
            "bunny res {res}: dims {:?}, {} solid, {surf} surface, volume {:.6e}, {:.1} ms wall, {:.0} ms cpu ({} threads)",
            grid.dims,
            grid.solid_count(),
            grid.volume(),
            dt.as_secs_f64() * 1e3,
            cpu * 1e3,
            rayon::current_num_threads()
        );
        assert_eq!(grid.dims.iter().copied().max(), Some(res + 4));
        // The scan has 5 small holes, so its signed volume depends a little on the reference
        // point (models README); about the box centre it approximates the enclosed volume.
        // Certain cells ≤ it ≤ possible cells, with 1% slack for the holes.
        let (certain, possible) = volume_bounds(&grid, &cut);
        assert!(certain < 1.01 * enclosed && possible > 0.99 * enclosed, "{certain} {enclosed} {possible}");
    }
    let wrong = check_against_exact(&v, &f, 64, 400);
    assert_eq!(wrong, 0, "cells disagreeing with the exact winding number");
}

#[test]
fn armadillo_volume_bracketed() {
    let Some(path) = shared_model("obj/armadillo.obj") else { return };
    let (v, f) = load_obj(&path);
    let t0 = Instant::now();
    let grid = voxelize(&v, &f, &VoxelSettings::default());
    println!("armadillo res 128: {:?}, {:.1} ms", grid.dims, t0.elapsed().as_secs_f64() * 1e3);
    let cut = surface(&v, &f, &grid);
    let (certain, possible) = volume_bounds(&grid, &cut);
    // Closed mesh, volume 237843.1 (models README).
    let exact = 237843.1;
    assert!(certain < exact && exact < possible, "{certain} .. {possible}");
    // The centre rule's error is at most the cut cells' volume (only they are in doubt); it is
    // far smaller since the cut cells' errors have both signs. Counting every cut cell as solid
    // instead would add about half of them.
    let cut_volume = cut.count_ones() as f64 * grid.cell_size.powi(3);
    let with_cut = (grid.solid_count() + cut.count_and_not(&grid.solid)) as f64 * grid.cell_size.powi(3);
    println!(
        "armadillo res 128: centre rule {:+.2} %, cut cells solid {:+.2} %, cut cells {:.2} % of the volume",
        (grid.volume() / exact - 1.0) * 100.0,
        (with_cut / exact - 1.0) * 100.0,
        cut_volume / exact * 100.0
    );
    assert!((grid.volume() - exact).abs() <= cut_volume);
    // The boundary mesh encloses exactly the solid volume.
    let (bv, bf, _) = grid.boundary_mesh();
    let vol = voxel_support::signed_volume_f64(&bv, &bf);
    assert!((vol - grid.volume()).abs() < 1e-9 * grid.volume(), "{vol} vs {}", grid.volume());
}

#[test]
fn teapot_open_patches() {
    // Open surface patches (420 boundary edges, 3 parts): many rows pass through gaps, so the
    // winding-number fallback does real work here.
    let Some(path) = shared_model("obj/teapot.obj") else { return };
    let (v, f) = load_obj(&path);
    let (c0, t0) = (cpu_seconds(), Instant::now());
    let grid = voxelize(&v, &f, &VoxelSettings::default());
    println!(
        "teapot res 128: {:?}, {} solid, {:.1} ms wall, {:.0} ms cpu",
        grid.dims,
        grid.solid_count(),
        t0.elapsed().as_secs_f64() * 1e3,
        (cpu_seconds() - c0) * 1e3
    );
    assert_eq!(check_against_exact(&v, &f, 48, 300), 0);
}
