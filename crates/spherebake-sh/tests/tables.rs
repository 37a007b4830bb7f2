//! The embedded tables against an in-process regeneration (same code path as `examples/gen_log_table.rs`), the math
//! reference's §3 F values, the interpolation error, and the §9 log vectors and ratio vector.
#![allow(clippy::needless_range_loop)] // index loops mirror the formulas

#[path = "../offline/sh_log.rs"]
mod sh_log;

use sh_log::*;
use spherebake_sh::*;
use std::f64::consts::PI;

/// |stored f32 − regenerated f64| within the f32 rounding (half an ulp, 2⁻²⁴ relative) plus a little slack.
fn f32_close(stored: f64, regenerated: f64) -> bool {
    (stored - regenerated).abs() <= 7e-8 * regenerated.abs() + 1e-12
}

#[test]
fn tables_match_generator() {
    for order in TABLE_ORDERS {
        let table = log_vis_table(order);
        assert_eq!(table.len(), LOG_VIS_THETA_SAMPLES);
        let mut got = vec![0.0; order];
        for (k, row) in table.iter().enumerate() {
            // At a grid angle the lookup returns the stored row (interpolation weight 0 or 1 up to rounding).
            log_visibility_f(k as f64 * LOG_VIS_THETA_STEP, order, &mut got).unwrap();
            for l in 0..order {
                assert!(
                    f32_close(got[l], row[l]),
                    "order {order} row {k} l {l}: stored {} vs regenerated {}",
                    got[l],
                    row[l]
                );
            }
        }
        // OL rows: with f̂ along a fixed unit direction u at norm x_k, sh_exp_ol returns a·1 + b·x_k·u.
        let (max, rows) = ol_table(order);
        assert!(f32_close(ol_max_norm(order), max), "order {order}: OL max {} vs {max}", ol_max_norm(order));
        let nc = order * order;
        let u = 1.0 / 3f64.sqrt();
        for (k, r) in rows.iter().enumerate().skip(1) {
            let x = k as f64 * ol_max_norm(order) / (OL_SAMPLES - 1) as f64;
            let mut f = vec![0.0; nc];
            f[1..4].fill(x * u);
            let mut e = vec![0.0; nc];
            sh_exp_ol(order, &f, &mut e).unwrap();
            let (a, b) = (e[0] / (4.0 * PI).sqrt(), e[1] / (x * u));
            assert!((a - r[0]).abs() < 1e-6 * r[0].abs(), "order {order} OL row {k}: a {a} vs {}", r[0]);
            assert!((b - r[1]).abs() < 1e-6 * r[1].abs() + 1e-7, "order {order} OL row {k}: b {b} vs {}", r[1]);
        }
    }
}

/// §3: order-4 F at 30° and 60° (grid rows 85 and 170) to f32 precision; 10° (between rows) within the linear
/// interpolation error h²/8 · F'' ≈ 3.5e-5 (F ≈ −3.3 θ² there, h = π/510).
#[test]
fn table_reproduces_math_reference() {
    let mut f = [0.0; 4];
    for (deg, want) in [
        (30.0, [-1.291089666, -1.155790187, -0.9813575699, -0.7523364489]),
        (60.0, [-9.57382775, -7.877395781, -5.12627528, -2.473220802]),
    ] {
        log_visibility_f(f64::to_radians(deg), 4, &mut f).unwrap();
        for l in 0..4 {
            assert!((f[l] - want[l]).abs() < 1e-9 + 1e-7 * want[l].abs(), "{deg}° F_{l}: {} vs {}", f[l], want[l]);
        }
    }
    log_visibility_f(10f64.to_radians(), 4, &mut f).unwrap();
    let want = [-0.1012125098, -0.09911228407, -0.09696388632, -0.09379375542];
    for l in 0..4 {
        assert!((f[l] - want[l]).abs() < 5e-5, "10° F_{l}: {} vs {}", f[l], want[l]);
    }
}

/// Linear interpolation in θ against the exact log at the 255 mid-interval angles, per order. F is smooth (≈ −cθ² near
/// 0) except where another eigenvalue starts being clipped, which puts kinks into F(θ) at large θ.
#[test]
fn interpolation_error_is_bounded() {
    // Largest |F| per order is at θ = π/2 (≈ 10–40); bounds are the measured maxima rounded up (absolute, in F units).
    for order in TABLE_ORDERS {
        let tp = TripleProduct::new(order).unwrap();
        let (mut max_small, mut max_all, mut scale) = (0.0f64, 0.0f64, 0.0f64);
        let mut got = vec![0.0; order];
        for k in 0..LOG_VIS_THETA_SAMPLES - 1 {
            let theta = (k as f64 + 0.5) * LOG_VIS_THETA_STEP;
            let exact = log_cap_table_row(&tp, theta, LogForm::Paper);
            log_visibility_f(theta, order, &mut got).unwrap();
            for l in 0..order {
                let e = (got[l] - exact[l]).abs();
                max_all = max_all.max(e);
                scale = scale.max(exact[l].abs());
                if theta < 20f64.to_radians() {
                    max_small = max_small.max(e);
                }
            }
        }
        println!("order {order}: max |ΔF| {max_small:.2e} for θ < 20°, {max_all:.2e} overall (max |F| {scale:.1})");
        assert!(max_small < 1e-3, "order {order}: {max_small}");
        assert!(max_all < 0.01 * scale, "order {order}: {max_all} vs {scale}");
    }
}

/// §9 example at p* = (0.3, −0.2, 5): log vectors f = F(θ) y(s) of the parent and the two leaves, and the ratio vector.
#[test]
fn section9_log_vectors_and_ratio_vector() {
    let tp = TripleProduct::new(4).unwrap();
    let pstar = [0.3, -0.2, 5.0];
    let parent = ([0.05068030381, 0.09178005063, 0.0], 1.058276253);
    let leaves = [([-0.5, 0.0, 0.0], 0.5), ([0.7, 0.2, 0.0], 0.4)];
    let geometry = |c: [f64; 3], r: f64| {
        let v = [c[0] - pstar[0], c[1] - pstar[1], c[2] - pstar[2]];
        let d = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        ((r / d).asin(), [v[0] / d, v[1] / d, v[2] / d])
    };
    // Exact route (offline log at the exact angle): f_lm = F_l(θ) y_lm(s).
    let exact_log = |c: [f64; 3], r: f64| {
        let (theta, s) = geometry(c, r);
        let big_f = log_cap_table_row(&tp, theta, LogForm::Paper);
        let mut y = [0.0; 16];
        eval_sh_f64(4, s, &mut y).unwrap();
        let mut f = [0.0; 16];
        for l in 0..4 {
            for i in l * l..(l + 1) * (l + 1) {
                f[i] = big_f[l] * y[i];
            }
        }
        f
    };
    let (theta_b, s_b) = geometry(parent.0, parent.1);
    assert!((theta_b.to_degrees() - 12.18298191).abs() < 1e-8);
    let fb = exact_log(parent.0, parent.1);
    let mut fd = [0.0; 16];
    for (c, r) in leaves {
        let f = exact_log(c, r);
        for i in 0..16 {
            fd[i] += f[i];
        }
    }
    let fb_want = [-0.04347612014, 0.07286932167, -0.09056430177, 0.1011332929];
    let fd_want = [-0.01449698329, 0.02469117618, -0.03100860058, 0.03518849414];
    for (j, i) in [0, 2, 6, 12].into_iter().enumerate() {
        assert!((fb[i] - fb_want[j]).abs() < 1e-9, "f_b[{i}] = {}", fb[i]);
        assert!((fd[i] - fd_want[j]).abs() < 1e-9, "f_d[{i}] = {}", fd[i]);
    }
    let w_want = [0.3334470334, 0.3390522262, 0.3430485598, 0.3493294482];
    let mut w = [0.0; 4];
    ratio_vector(&fb, &fd, 4, &mut w).unwrap();
    for l in 0..4 {
        assert!((w[l] - w_want[l]).abs() < 1e-9, "w_{l} = {}", w[l]);
    }
    // Independent route B of §9: project the world-frame cap visibility, then take the log in the world frame
    // (the eigen-clipped log is rotation-equivariant), equal to F(θ) y(s).
    let mut cap = [0.0; 4];
    cap_visibility_zh(theta_b, 4, &mut cap).unwrap();
    let mut g = vec![0.0; 16];
    zh_rotate(&cap, s_b, &mut g).unwrap();
    let fb_world = sh_log(&tp, &g, LogForm::Paper, CLIP);
    for i in 0..16 {
        assert!((fb_world[i] - fb[i]).abs() < 1e-9, "world-frame log [{i}]: {} vs {}", fb_world[i], fb[i]);
    }
    // Band energy: Σ_m f_lm² = F_l² (2l+1)/(4π).
    let big_f = log_cap_table_row(&tp, theta_b, LogForm::Paper);
    for l in 0..4 {
        let e: f64 = (l * l..(l + 1) * (l + 1)).map(|i| fb[i] * fb[i]).sum();
        assert!((e - big_f[l] * big_f[l] * (2 * l + 1) as f64 / (4.0 * PI)).abs() < 1e-13);
    }
    // Runtime route: f32 table lookup and fused accumulation; the ratio vector then agrees to the table accuracy.
    let runtime_log = |c: [f64; 3], r: f64, out: &mut [f32; 16]| {
        let (theta, s) = geometry(c, r);
        accumulate_log_visibility_f32(theta as f32, s.map(|v| v as f32), &[1.0; 4], out).unwrap();
    };
    let (mut fb32, mut fd32) = ([0.0f32; 16], [0.0f32; 16]);
    runtime_log(parent.0, parent.1, &mut fb32);
    for (c, r) in leaves {
        runtime_log(c, r, &mut fd32);
    }
    let mut w_rt = [0.0; 4];
    ratio_vector(&fb32.map(|v| v as f64), &fd32.map(|v| v as f64), 4, &mut w_rt).unwrap();
    let mut worst: f64 = 0.0;
    for l in 0..4 {
        worst = worst.max((w_rt[l] - w_want[l]).abs());
    }
    println!("§9 ratio vector from the f32 table: {w_rt:?} (max |Δw| {worst:.2e})");
    assert!(worst < 2e-3, "{worst}");
}
