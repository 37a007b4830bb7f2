//! Offline SH logarithm (Ren 2006 eqs. 30–32) and reference SH exponential (eq. 28), with nalgebra.
//!
//! Not part of the library (which stays `no_std` and never links nalgebra): this file is `#[path]`-included by
//! `examples/gen_log_table.rs`, which generates `src/tables_data.rs`, and by the tests, which regenerate the tables
//! through this same code and compare them with the committed data. Math reference §3 and §9.
#![allow(dead_code)]

use nalgebra::{DMatrix, DVector};
use spherebake_sh::{
    cap_visibility_zh, coeff_count, sh_index, TripleProduct, LOG_VIS_THETA_SAMPLES, LOG_VIS_THETA_STEP, OL_SAMPLES,
};
use std::f64::consts::PI;
use std::fmt::Write as _;

/// Eigenvalue clipping threshold of Ren 2006 §5: ε = `CLIP` × the largest eigenvalue of M_g.
pub const CLIP: f64 = 0.02;

/// Which reading of Ren eq. 30 with clipped eigenvalues (math reference §3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogForm {
    /// Paper form P: log g = Rᵀ q'(D̃) R (g − 1), q'(x) = ln x / (x − 1), q'(1) = 1. Used for the shipped tables.
    Paper,
    /// Consistent form C: log g = Rᵀ ln(D̃) R · 1 = ln(M̃_g) · 1.
    Consistent,
}

/// The SH unit **1** = (√(4π), 0, …, 0) of `n` coefficients.
pub fn unit(n: usize) -> DVector<f64> {
    let mut v = DVector::zeros(n);
    v[0] = (4.0 * PI).sqrt();
    v
}

/// Product matrix (M_f)_ij = Σ_k Γ_ijk f_k of the tensor's order (f has order² entries).
pub fn product_matrix(tp: &TripleProduct, f: &[f64]) -> DMatrix<f64> {
    let n = coeff_count(tp.order());
    let mut buf = vec![0.0; n * n];
    tp.product_matrix(f, &mut buf).expect("sizes match the tensor order");
    DMatrix::from_row_slice(n, n, &buf)
}

/// Eigen-decomposition M = V diag(d) Vᵀ of a symmetric matrix by the cyclic Jacobi method (columns of V = eigenvectors).
///
/// nalgebra's `symmetric_eigen()` with its default tolerance reconstructs some of these product matrices only to ~2e-4
/// (the θ = 60° log of math reference §3), too coarse for the 1e-9 reference values; Jacobi rotations converge to
/// rounding (residual ~1e-15 ‖M‖) and are deterministic.
pub fn sym_eigen(m: &DMatrix<f64>) -> (DVector<f64>, DMatrix<f64>) {
    let n = m.nrows();
    let mut a = m.clone();
    let mut v = DMatrix::<f64>::identity(n, n);
    let total: f64 = a.iter().map(|x| x * x).sum();
    for _sweep in 0..100 {
        let mut off = 0.0;
        for p in 0..n {
            for q in p + 1..n {
                off += a[(p, q)] * a[(p, q)];
            }
        }
        if off <= 1e-34 * total || off == 0.0 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[(p, q)];
                if apq == 0.0 {
                    continue;
                }
                let theta = (a[(q, q)] - a[(p, p)]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (akp, akq) = (a[(k, p)], a[(k, q)]);
                    a[(k, p)] = c * akp - s * akq;
                    a[(k, q)] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[(p, k)], a[(q, k)]);
                    a[(p, k)] = c * apk - s * aqk;
                    a[(q, k)] = s * apk + c * aqk;
                }
                for k in 0..n {
                    let (vkp, vkq) = (v[(k, p)], v[(k, q)]);
                    v[(k, p)] = c * vkp - s * vkq;
                    v[(k, q)] = s * vkp + c * vkq;
                }
            }
        }
    }
    (a.diagonal(), v)
}

/// q'(x) = ln x / (x − 1) with q'(1) = 1 (x > 0).
fn q_log(x: f64) -> f64 {
    let u = x - 1.0;
    if u == 0.0 {
        1.0
    } else {
        u.ln_1p() / u
    }
}

/// q(x) = (eˣ − 1)/x with q(0) = 1.
fn q_exp(x: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else {
        x.exp_m1() / x
    }
}

/// Eigen-clipped SH logarithm of `g` (order² entries, the tensor's order), ε = `clip` × the largest eigenvalue of M_g.
pub fn sh_log(tp: &TripleProduct, g: &[f64], form: LogForm, clip: f64) -> Vec<f64> {
    let n = g.len();
    let (d, v) = sym_eigen(&product_matrix(tp, g)); // M = V D Vᵀ (V = Rᵀ)
    let eps = clip * d.max();
    let one = unit(n);
    let gv = DVector::from_column_slice(g);
    let mut c = match form {
        LogForm::Paper => v.transpose() * (&gv - &one),
        LogForm::Consistent => v.transpose() * &one,
    };
    for (ci, &di) in c.iter_mut().zip(d.iter()) {
        let dt = di.max(eps);
        *ci *= match form {
            LogForm::Paper => q_log(dt),
            LogForm::Consistent => dt.ln(),
        };
    }
    (&v * c).iter().copied().collect()
}

/// Reference SH exponential exp*(f) = exp(M_f)·1 = 1 + Rᵀ q(D) R f (Ren eq. 28; math reference §3), by eigen-decomposition.
pub fn sh_exp_reference(tp: &TripleProduct, f: &[f64]) -> Vec<f64> {
    let n = f.len();
    let (d, v) = sym_eigen(&product_matrix(tp, f));
    let mut c = v.transpose() * DVector::from_column_slice(f);
    for (ci, &di) in c.iter_mut().zip(d.iter()) {
        *ci *= q_exp(di);
    }
    (unit(n) + &v * c).iter().copied().collect()
}

/// Blocker visibility 1 − χ_θ of a cap of angular radius `theta_rad` about +z as a full order² vector (zonal entries only).
pub fn cap_visibility(theta_rad: f64, order: usize) -> Vec<f64> {
    let mut zh = vec![0.0; order];
    cap_visibility_zh(theta_rad, order, &mut zh).expect("buffer sized to order");
    let mut g = vec![0.0; coeff_count(order)];
    for (l, &v) in zh.iter().enumerate() {
        g[sh_index(l, 0)] = v;
    }
    g
}

/// The full log vector f = log(1 − χ_θ) of a cap about +z (zonal, paper or consistent form, ε = 0.02 × max).
pub fn log_cap(tp: &TripleProduct, theta_rad: f64, form: LogForm) -> Vec<f64> {
    sh_log(tp, &cap_visibility(theta_rad, tp.order()), form, CLIP)
}

/// Ren's table entry F_l(θ) = √(4π/(2l+1)) f_l0 of the log of a cap of angular radius `theta_rad`, l < order.
pub fn log_cap_table_row(tp: &TripleProduct, theta_rad: f64, form: LogForm) -> Vec<f64> {
    let f = log_cap(tp, theta_rad, form);
    (0..tp.order()).map(|l| f[sh_index(l, 0)] * (4.0 * PI / (2 * l + 1) as f64).sqrt()).collect()
}

/// The log-visibility table of one order: row k = F_0..F_{order−1} at θ_k = k · [`LOG_VIS_THETA_STEP`] (paper form P).
pub fn log_vis_table(order: usize) -> Vec<Vec<f64>> {
    let tp = TripleProduct::new(order).expect("order ≤ 8");
    (0..LOG_VIS_THETA_SAMPLES).map(|k| log_cap_table_row(&tp, k as f64 * LOG_VIS_THETA_STEP, LogForm::Paper)).collect()
}

/// One least-squares OL sample (Ren eq. 24) of a circle: (‖f̂‖, a, b).
pub fn ol_sample(tp: &TripleProduct, theta_rad: f64) -> (f64, f64, f64) {
    let order = tp.order();
    let g = cap_visibility(theta_rad, order);
    let f = sh_log(tp, &g, LogForm::Paper, CLIP);
    let sq4pi = (4.0 * PI).sqrt();
    let scale = (-f[0] / sq4pi).exp();
    let norm2: f64 = f[1..].iter().map(|x| x * x).sum();
    let a = scale * g[0] / sq4pi;
    let b = scale * g[1..].iter().zip(&f[1..]).map(|(x, y)| x * y).sum::<f64>() / norm2;
    (norm2.sqrt(), a, b)
}

/// Number of circle radii sampled (uniform in θ over (0, π/2]) before resampling the OL curves onto ‖f̂‖.
pub const OL_FIT_CIRCLES: usize = 2048;

/// OL table of one order: (largest tabulated ‖f̂‖, rows (a, b) at ‖f̂‖_k = k · max / (OL_SAMPLES − 1)).
///
/// Ren §4.2: circles of increasing angular radius give (‖f̂‖, a, b) by eq. 24; the curves are tabulated against ‖f̂‖.
/// The circles are sampled over θ ∈ (0, π/2] while ‖f̂‖(θ) increases; the table ends at the first θ where it stops
/// increasing (or at π/2), and each grid ‖f̂‖ is mapped back to θ by linear interpolation of the sampled curve.
pub fn ol_table(order: usize) -> (f64, Vec<[f64; 2]>) {
    let tp = TripleProduct::new(order).expect("order ≤ 8");
    let mut samples = vec![(0.0, 1.0, 1.0)]; // limit θ → 0: exp*(f̂) → 1 + f̂
    for k in 1..=OL_FIT_CIRCLES {
        let s = ol_sample(&tp, k as f64 * (PI / 2.0) / OL_FIT_CIRCLES as f64);
        if s.0 <= samples.last().expect("non-empty").0 {
            break;
        }
        samples.push(s);
    }
    let max = samples.last().expect("non-empty").0;
    let mut rows = Vec::with_capacity(OL_SAMPLES);
    let mut j = 0;
    for k in 0..OL_SAMPLES {
        let x = k as f64 * max / (OL_SAMPLES - 1) as f64;
        while j + 2 < samples.len() && samples[j + 1].0 < x {
            j += 1;
        }
        let (x0, a0, b0) = samples[j];
        let (x1, a1, b1) = samples[j + 1];
        let t = ((x - x0) / (x1 - x0)).clamp(0.0, 1.0);
        rows.push([a0 + t * (a1 - a0), b0 + t * (b1 - b0)]);
    }
    (max, rows)
}

/// First and last order of the shipped tables.
pub const TABLE_ORDERS: std::ops::RangeInclusive<usize> = 2..=8;

/// Renders `src/tables_data.rs` (f32 data, `{:?}` formatting round-trips every value exactly).
pub fn render_tables_rs() -> String {
    let mut s = String::new();
    s.push_str(
        "// @generated by `cargo run -p spherebake-sh --release --example gen_log_table`; do not edit.\n\
         // Regenerated and compared by the `tables_match_generator` test. Values are f32 (stored data);\n\
         // they are computed in f64 by `offline/sh_log.rs` (eigen-clipped SH log, paper form P, ε = 0.02 × max).\n\n",
    );
    for order in TABLE_ORDERS {
        let t = log_vis_table(order);
        writeln!(
            s,
            "/// Order-{order} log-visibility table: row k = F_0..F_{} at θ_k = k·π/510 rad (k = 0..255).",
            order - 1
        )
        .unwrap();
        writeln!(s, "pub(crate) static LOG_VIS_{order}: [[f32; {order}]; {LOG_VIS_THETA_SAMPLES}] = [").unwrap();
        for row in &t {
            let items: Vec<String> = row.iter().map(|&v| format!("{:?}", v as f32)).collect();
            writeln!(s, "    [{}],", items.join(", ")).unwrap();
        }
        s.push_str("];\n\n");
    }
    let mut maxes = Vec::new();
    for order in TABLE_ORDERS {
        let (max, rows) = ol_table(order);
        maxes.push(max);
        writeln!(
            s,
            "/// Order-{order} OL coefficients (a, b) at ‖f̂‖_k = k·OL_MAX_NORM[{order}]/{} (k = 0..{}).",
            OL_SAMPLES - 1,
            OL_SAMPLES - 1
        )
        .unwrap();
        writeln!(s, "pub(crate) static OL_{order}: [[f32; 2]; {OL_SAMPLES}] = [").unwrap();
        for r in &rows {
            writeln!(s, "    [{:?}, {:?}],", r[0] as f32, r[1] as f32).unwrap();
        }
        s.push_str("];\n\n");
    }
    s.push_str("/// Largest tabulated ‖f̂‖ of the OL table, indexed by order (0 and 1: no table).\n");
    let items: Vec<String> = maxes.iter().map(|&m| format!("{:?}", m as f32)).collect();
    writeln!(s, "pub(crate) static OL_MAX_NORM: [f32; 9] = [0.0, 0.0, {}];", items.join(", ")).unwrap();
    s
}
