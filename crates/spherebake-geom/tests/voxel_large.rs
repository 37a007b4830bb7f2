//! A 1.3M-triangle mesh stays feasible (timings printed, not asserted).

mod voxel_support;

use glam::Vec3;
use spherebake_geom::voxel::{voxelize, VoxelSettings};
use std::time::Instant;
use voxel_support::{icosphere, signed_volume};

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
    let surf = g.surface.iter().filter(|&&s| s).count();
    let interior = (g.solid_count() - surf) as f64 * g.cell_size.powi(3);
    assert!(interior < volume && volume < g.volume(), "{interior} {volume} {}", g.volume());
}
