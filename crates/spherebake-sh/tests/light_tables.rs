//! The spherical-light tables (Guerrero 2008 eq. 9–10, 15–18) against an in-process regeneration, brute-force
//! Monte Carlo projection of a Voronoi function, and rays cast from a receiver to a sphere.
#![allow(clippy::needless_range_loop)] // index loops mirror the formulas

#[path = "../offline/light_tables.rs"]
mod light_tables;

use light_tables::*;
use spherebake_sh::*;
use std::f64::consts::PI;

fn f32_close(stored: f64, regenerated: f64) -> bool {
    (stored - regenerated).abs() <= 7e-8 * regenerated.abs() + 1e-12
}

#[test]
fn tables_match_generator() {
    let vor = voronoi_basis_table(VORONOI_POINTS);
    for (j, row) in vor.iter().enumerate() {
        let stored = voronoi_cell_basis(j, 8).unwrap();
        for i in 0..64 {
            assert!(f32_close(f64::from(stored[i]), row[i]), "Y[{j}][{i}]: {} vs {}", stored[i], row[i]);
        }
    }
    let [w, _, _] = light_weight_tables();
    let mut got = [0.0f32; 8];
    for (k, row) in w.iter().enumerate() {
        radiance_weights_f32((k as f64 * RADIANCE_WEIGHT_STEP) as f32, 8, &mut got).unwrap();
        for l in 0..8 {
            // At a grid angle the lookup returns the stored row up to the f32 rounding of θ.
            assert!((f64::from(got[l]) - row[l]).abs() < 2e-6, "W row {k} l {l}: {} vs {}", got[l], row[l]);
        }
    }
    // The C and D tables through the public Φ: at grid angles Φ is linear in them, checked by the ray tests below.
}

#[test]
fn voronoi_rows_partition_the_sphere() {
    // Σ_j Y_j = ∫ y = (√(4π), 0, …): the cells tile the sphere once.
    let mut sum = [0.0f64; 64];
    for j in 0..92 {
        for (s, v) in sum.iter_mut().zip(voronoi_cell_basis(j, 8).unwrap()) {
            *s += f64::from(*v);
        }
    }
    assert!((sum[0] - (4.0 * PI).sqrt()).abs() < 1e-5, "DC sum {}", sum[0]);
    for (i, s) in sum.iter().enumerate().skip(1) {
        assert!(s.abs() < 2e-5, "coefficient {i} sums to {s}");
    }
    // Cell areas (DC / y_00) of the frequency-3 geodesic sphere: 12 pentagons and 80 hexagons, 4π in all, each
    // within 30 % of the mean 4π/92.
    let y00 = 0.5 / PI.sqrt();
    for j in 0..92 {
        let area = f64::from(voronoi_cell_basis(j, 1).unwrap()[0]) / y00;
        assert!((area / (4.0 * PI / 92.0) - 1.0).abs() < 0.3, "cell {j} area {area}");
    }
}

use spherebake_testkit::rng::{mix, unit};

#[test]
fn eq10_matches_monte_carlo_projection_of_the_voronoi_function() {
    // Values per direction, a quarter of them empty (rule 2: no sample, no light).
    let values: Vec<f64> =
        (0..92u64).map(|j| if mix(j) % 4 == 0 { 0.0 } else { 0.2 + unit(mix(j ^ 0xABCD)) }).collect();
    let order = 6;
    let nc = order * order;
    let mut table = vec![0.0f64; nc];
    for j in 0..92 {
        for (t, y) in table.iter_mut().zip(voronoi_cell_basis(j, order).unwrap()) {
            *t += values[j] * f64::from(*y);
        }
    }
    // Brute force: uniform random directions (independent of the Fibonacci lattice), nearest direction by angle.
    let dirs = geodesic_directions_f64();
    let n = 400_000usize;
    let mut sum = vec![0.0f64; nc];
    let mut sum2 = vec![0.0f64; nc];
    let mut y = [0.0f64; 64];
    for k in 0..n as u64 {
        let z = 1.0 - 2.0 * unit(mix(2 * k));
        let phi = 2.0 * PI * unit(mix(2 * k + 1));
        let r = (1.0 - z * z).max(0.0).sqrt();
        let d = [r * phi.cos(), r * phi.sin(), z];
        let mut best = (f64::NEG_INFINITY, 0);
        for (j, g) in dirs.iter().enumerate() {
            let dot = g[0] * d[0] + g[1] * d[1] + g[2] * d[2];
            if dot > best.0 {
                best = (dot, j);
            }
        }
        eval_sh_f64(order, d, &mut y).unwrap();
        for i in 0..nc {
            let v = 4.0 * PI * values[best.1] * y[i];
            sum[i] += v;
            sum2[i] += v * v;
        }
    }
    for i in 0..nc {
        let mean = sum[i] / n as f64;
        let se = ((sum2[i] / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
        assert!((table[i] - mean).abs() <= 5.0 * se + 1e-4, "coefficient {i}: table {} vs MC {mean} ± {se}", table[i]);
    }
}

/// Rays from p = D·a (D = 1/sin θ) to the unit sphere at the origin, stratified over the cone: for each ray the
/// direction ω and the hit point's direction ω_S from the centre, with the ray's solid-angle weight.
fn cone_rays(theta: f64, a: [f64; 3], n: usize, mut f: impl FnMut([f64; 3], [f64; 3], f64)) {
    let dist = 1.0 / theta.sin();
    let p = a.map(|v| v * dist);
    let s = a.map(|v| -v);
    let t = if s[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    let cross =
        |u: [f64; 3], v: [f64; 3]| [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
    let mut u = cross(t, s);
    let un = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
    u = u.map(|v| v / un);
    let v = cross(s, u);
    let cos_t = theta.cos();
    let w = 2.0 * PI * (1.0 - cos_t) / (n * n) as f64;
    for i in 0..n {
        let cz = cos_t + (1.0 - cos_t) * (i as f64 + 0.5) / n as f64;
        let sz = (1.0 - cz * cz).max(0.0).sqrt();
        for k in 0..n {
            let phi = 2.0 * PI * (k as f64 + 0.5) / n as f64;
            let d = [0, 1, 2].map(|q| cz * s[q] + sz * (phi.cos() * u[q] + phi.sin() * v[q]));
            let b = -(d[0] * p[0] + d[1] * p[1] + d[2] * p[2]);
            let disc = b * b - (dist * dist - 1.0);
            let th = b - disc.max(0.0).sqrt();
            let hit = [0, 1, 2].map(|q| p[q] + th * d[q]);
            let hn = (hit[0] * hit[0] + hit[1] * hit[1] + hit[2] * hit[2]).sqrt();
            f(d, hit.map(|x| x / hn), w);
        }
    }
}

#[test]
fn uniform_weights_match_rays_cast_from_the_receiver() {
    // Eq. 15: the mean of y_i(ω_S) over p's cone is W_l(θ) y_i(a).
    let a = {
        let v = [0.3f64, -0.5, 0.81];
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|x| x / n)
    };
    let order = 6;
    let nc = order * order;
    for deg in [3.0f64, 15.0, 30.0, 50.0, 70.0, 85.0] {
        let theta = deg.to_radians();
        let mut mean = vec![0.0f64; nc];
        let mut total = 0.0;
        let mut y = [0.0f64; 64];
        cone_rays(theta, a, 600, |_, ws, w| {
            eval_sh_f64(order, ws, &mut y).unwrap();
            for i in 0..nc {
                mean[i] += w * y[i];
            }
            total += w;
        });
        let mut wl = [0.0f32; 8];
        radiance_weights_f32(theta as f32, order, &mut wl).unwrap();
        let mut ya = [0.0f64; 64];
        eval_sh_f64(order, a, &mut ya).unwrap();
        for l in 0..order {
            for i in l * l..(l + 1) * (l + 1) {
                let want = mean[i] / total;
                let got = f64::from(wl[l]) * ya[i];
                assert!((got - want).abs() < 2e-3, "θ {deg}°, coefficient {i}: table {got} vs rays {want}");
            }
        }
    }
}

#[test]
fn cosine_weighted_radiance_matches_rays_cast_from_the_receiver() {
    let order = 4;
    let nc = order * order;
    // A random RGB light.
    let light: Vec<[f32; 3]> = (0..nc as u64)
        .map(|i| [0, 1, 2].map(|c| (unit(mix(i * 3 + c)) - 0.5) as f32 * if i == 0 { 0.0 } else { 1.0 }))
        .collect();
    let mut light = light;
    light[0] = [3.0, 2.5, 2.0];
    let a = {
        let v = [-0.2f64, 0.9, 0.4];
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|x| x / n)
    };
    let s = a.map(|v| -v);
    for deg in [5.0f64, 20.0, 40.0, 60.0, 80.0] {
        let theta = deg.to_radians();
        // Normals from "facing the light" to "the light at the horizon" (n·s = sin θ).
        for tilt in [0.0f64, 0.5, 1.0] {
            let elev = theta + (PI / 2.0 - theta) * (1.0 - tilt);
            // n = sin(elev) s + cos(elev) u, u ⊥ s.
            let t = [1.0, 0.0, 0.0];
            let mut u = [t[1] * s[2] - t[2] * s[1], t[2] * s[0] - t[0] * s[2], t[0] * s[1] - t[1] * s[0]];
            let un = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
            u = u.map(|x| x / un);
            let n = [0, 1, 2].map(|q| elev.sin() * s[q] + elev.cos() * u[q]);
            let mut want = [0.0f64; 3];
            let mut y = [0.0f64; 64];
            cone_rays(theta, a, 500, |d, ws, w| {
                let cos = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]).max(0.0);
                eval_sh_f64(order, ws, &mut y).unwrap();
                for c in 0..3 {
                    let l: f64 = (0..nc).map(|i| f64::from(light[i][c]) * y[i]).sum();
                    want[c] += w * l * cos / PI;
                }
            });
            let got =
                cosine_weighted_radiance_rgb_f32(theta as f32, a.map(|v| v as f32), n.map(|v| v as f32), &light, order)
                    .unwrap();
            let scale = want.iter().map(|v| v.abs()).fold(0.0f64, f64::max).max(1e-3);
            for c in 0..3 {
                assert!(
                    (f64::from(got[c]) - want[c]).abs() < 3e-3 * scale + 1e-6,
                    "θ {deg}°, tilt {tilt}, channel {c}: Φ {} vs rays {}",
                    got[c],
                    want[c]
                );
            }
        }
    }
}

/// The paper's eq. 16 weights: the zonal coefficients of cos γ(α) (eq. 17) over the sphere's own directions,
/// normalised, as √(4π/(2l+1)) × ZH (the W convention), by the midpoint rule in α.
fn paper_eq16_weights(theta: f64) -> [f64; 8] {
    let st = theta.sin();
    let n = 20_000;
    let mut num = [0.0f64; 8];
    let mut den = 0.0;
    for k in 0..n {
        let alpha = PI * (k as f64 + 0.5) / n as f64;
        let (sa, ca) = (alpha.sin(), alpha.cos());
        let g = if sa > 0.0 { (((1.0 - st * ca) / (st * sa)).atan() - alpha).sin().max(0.0) } else { 0.0 };
        den += g * sa;
        for l in 0..8 {
            num[l] += g * sa * legendre_p(l, ca);
        }
    }
    num.map(|v| v / den)
}

#[test]
fn eq15_reading_agrees_with_eq16_far_away_and_departs_near_the_sphere() {
    let mut w = [0.0f32; 8];
    radiance_weights_f32(1f32.to_radians(), 8, &mut w).unwrap();
    let p = paper_eq16_weights(1f64.to_radians());
    for l in 0..8 {
        assert!((f64::from(w[l]) - p[l]).abs() < 5e-3, "1°, l {l}: eq. 15 {} vs eq. 16 {}", w[l], p[l]);
    }
    // Far-field limit (row 0): the normalised clamped cosine A_l / π = 1, 2/3, 1/4, 0, −1/24.
    radiance_weights_f32(0.0, 8, &mut w).unwrap();
    for (l, want) in [1.0, 2.0 / 3.0, 0.25, 0.0, -1.0 / 24.0].iter().enumerate() {
        assert!((f64::from(w[l]) - want).abs() < 1e-6, "0°, l {l}: {} vs {want}", w[l]);
    }
    // Measured at 60°: W_2 0.945 (eq. 15) against 0.898 (eq. 16), W_4 0.829 against 0.695.
    radiance_weights_f32(60f32.to_radians(), 8, &mut w).unwrap();
    let p = paper_eq16_weights(60f64.to_radians());
    assert!((f64::from(w[2]) - p[2]).abs() > 0.03, "60°: eq. 15 {} and eq. 16 {} should differ", w[2], p[2]);
    // Contact: the weight concentrates on the touching point, W_l → P_l(1) = 1.
    radiance_weights_f32(std::f32::consts::FRAC_PI_2, 8, &mut w).unwrap();
    assert!(w.iter().all(|v| (v - 1.0).abs() < 1e-6), "π/2: {w:?}");
}
