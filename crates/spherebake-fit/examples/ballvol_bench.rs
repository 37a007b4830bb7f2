//! Micro-benchmark of the voxel proxy `Solid::ball_volume` (not a test):
//! `cargo run --release -p spherebake-fit --example ballvol_bench -- MODEL.obj`.
use glam::DVec3;
use std::time::Instant;

fn main() {
    let path = std::env::args().nth(1).expect("MODEL.obj");
    let text = std::fs::read_to_string(&path).expect("read");
    let (mut p, mut t) = (Vec::new(), Vec::new());
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let v: Vec<f64> = it.take(3).map(|x| x.parse().unwrap()).collect();
                p.push(DVec3::new(v[0], v[1], v[2]));
            }
            Some("f") => {
                let v: Vec<u32> = it.map(|x| x.split('/').next().unwrap().parse::<u32>().unwrap() - 1).collect();
                for i in 1..v.len() - 1 {
                    t.push([v[0], v[i], v[i + 1]]);
                }
            }
            _ => {}
        }
    }
    let solid = spherebake_fit::solid::voxelize(&p, &t, 128, false);
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
