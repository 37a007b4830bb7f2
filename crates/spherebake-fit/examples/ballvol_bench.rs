//! Micro-benchmark of the voxel proxy `Solid::ball_volume` (not a test):
//! `cargo run --release -p spherebake-fit --example ballvol_bench -- MODEL.obj`.
#[path = "common/obj.rs"]
mod obj;

use glam::DVec3;
use std::time::Instant;

fn main() {
    let path = std::env::args().nth(1).expect("MODEL.obj");
    let (p32, t) = obj::load_obj(&path);
    let p: Vec<DVec3> = p32.iter().map(|v| v.as_dvec3()).collect();
    let grid = spherebake_geom::voxel::voxelize(&p32, &t, &spherebake_geom::voxel::VoxelSettings { resolution: 128 });
    let solid = spherebake_fit::solid::Solid::from_grid(grid);
    let lo = p.iter().fold(DVec3::splat(f64::INFINITY), |a, b| a.min(*b));
    let hi = p.iter().fold(DVec3::splat(f64::NEG_INFINITY), |a, b| a.max(*b));
    let mut rng = spherebake_fit::rng::SplitMix64::new(7);
    let n = 20000;
    let q: Vec<(DVec3, f64)> = (0..n)
        .map(|_| {
            let u = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
            (lo + (hi - lo) * u, solid.h * (2.0 + 28.0 * rng.next_f64()))
        })
        .collect();
    for _ in 0..3 {
        let t0 = Instant::now();
        let s: f64 = q.iter().map(|(c, r)| solid.ball_volume(*c, *r)).sum();
        println!("{n} evaluations: {:.3} µs each (checksum {s:.9e})", t0.elapsed().as_secs_f64() * 1e6 / n as f64);
    }
}
