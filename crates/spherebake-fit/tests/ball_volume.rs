//! The voxel proxy `Solid::ball_volume` against a brute-force evaluation of its definition:
//! Σ over x rows whose centre (j + ½, k + ½) lies strictly inside the ball's cross-section of
//! the solid length of the row within the chord. Random solids (blobs plus noise, so rows have
//! one or several runs) and random balls, many reaching outside the grid on every side.

use glam::DVec3;
use spherebake_fit::rng::SplitMix64;
use spherebake_fit::solid::Solid;

fn brute(s: &Solid, c: DVec3, r: f64) -> f64 {
    let u = (c - s.origin) / s.h;
    let ru = r / s.h;
    let [nx, ny, nz] = s.dims;
    let mut sum = 0.0;
    for k in 0..nz {
        for j in 0..ny {
            let (dy, dz) = (j as f64 + 0.5 - u.y, k as f64 + 0.5 - u.z);
            let rem = ru * ru - dy * dy - dz * dz;
            if rem <= 0.0 {
                continue;
            }
            let half = rem.sqrt();
            for i in 0..nx {
                if s.grid.solid[i + nx * (j + ny * k)] {
                    let len = (u.x + half).min(i as f64 + 1.0) - (u.x - half).max(i as f64);
                    sum += len.max(0.0);
                }
            }
        }
    }
    sum * s.h.powi(3)
}

#[test]
fn ball_volume_matches_brute_force_inside_and_outside_the_grid() {
    let mut rng = SplitMix64::new(11);
    for case in 0..6 {
        let dims = [7 + case * 3, 9 + case * 2, 8 + case];
        let n = dims[0] * dims[1] * dims[2];
        let centre = DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64) * 0.5;
        let solid: spherebake_fit::solid::Bits = (0..n)
            .map(|idx| {
                let (i, j, k) = (idx % dims[0], (idx / dims[0]) % dims[1], idx / (dims[0] * dims[1]));
                let p = DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5);
                (p.distance(centre) < 0.4 * dims[0] as f64) ^ (rng.next_f64() < 0.15)
            })
            .collect();
        let h = 0.25 + 0.1 * case as f64;
        let origin = DVec3::new(-1.0, 2.0, 0.5);
        let s = Solid::from_cells(origin, h, dims, solid);
        let ext = DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64) * h;
        for _ in 0..300 {
            let t = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 1.8 - 0.4;
            let c = origin + ext * t;
            let r = ext.length() * 0.6 * rng.next_f64();
            let (got, want) = (s.ball_volume(c, r), brute(&s, c, r));
            assert!(
                (got - want).abs() <= 1e-5 * (want + h.powi(3)),
                "case {case}: c {c} r {r}: ball_volume {got}, brute force {want}"
            );
        }
    }
}
