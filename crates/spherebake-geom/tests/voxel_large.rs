//! A 1.3M-triangle mesh stays feasible (timings printed, not asserted).

mod voxel_support;

use glam::Vec3;
use spherebake_geom::voxel::{voxelize, VoxelSettings};
use std::time::Instant;
use voxel_support::{icosphere, signed_volume, surface, volume_bounds};

#[test]
fn million_triangle_icosphere() {
    let (v, mut f) = icosphere(8, Vec3::new(0.2, 0.1, -0.3), 2.0);
    assert_eq!(f.len(), 20 * 4usize.pow(8));
    let volume = signed_volume(&v, &f);
    // Punch a hole too, so that the winding-number fallback is exercised.
    f.truncate(f.len() - 2000);
    let t0 = Instant::now();
    let g = voxelize(&v, &f, &VoxelSettings::default());
    println!(
        "icosphere {} triangles, res 128: {:.0} ms ({} threads)",
        f.len(),
        t0.elapsed().as_secs_f64() * 1e3,
        rayon::current_num_threads()
    );
    let (certain, possible) = volume_bounds(&g, &surface(&v, &f, &g));
    assert!(certain < volume && volume < possible, "{certain} {volume} {possible}");
}
