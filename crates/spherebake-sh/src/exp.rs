//! The SH exponential exp*(f) (Ren 2006 §4; math reference §3): the product series 1 + f + f²*/2! + … with truncated
//! SH products, whose exact value is exp(M_f)·1.
//!
//! All methods start with DC isolation, exp*(f) = exp(f_0/√(4π)) · exp*(f̂) with f̂ = f with f_0 = 0 (exact, eq. 20).
//!
//! | method | what | cost (products) |
//! |---|---|---|
//! | [`sh_exp_accurate`] | exp(M_f̂)·1 = (exp(M_f̂/2ᵖ))^(2ᵖ)·1: scaling, then 2ᵖ applications of the operator by its series until terms vanish | ~2ᵖ × 15 |
//! | [`sh_exp_ps_star`] | Ren's PS*-d: scaling, the factored degree-d series (eq. 22), then p SH squarings (eq. 21) | d/2 + 1 + p |
//! | [`sh_exp_ol`] | Ren's OL (eq. 23): exp*(f̂) ≈ a(‖f̂‖)·1 + b(‖f̂‖)·f̂, a, b tabulated offline from circles | 0 |
//! | [`sh_exp_hyb`] | Ren's HYB: scaling until ‖f̂‖/2ᵖ ≤ the OL bound, OL, then p SH squarings | p |
//!
//! Scaling with *squaring* is approximate for SH vectors (truncation makes (x∗x)∗y ≠ x∗(x∗y)), so PS* and HYB differ
//! from exp(M_f)·1 beyond the series error — one squaring already costs most of it, so PS*-4 is as accurate as PS*-8.
//! [`sh_exp_accurate`] applies the operator exp(M_f̂/2ᵖ) repeatedly instead and matches exp(M_f)·1 to rounding.
//!
//! Measured relative error ‖e − exp(M_f)·1‖/‖exp(M_f)·1‖ (`tests/log_exp.rs`, order 4, sums of 1/2/4/8 sphere logs of
//! 3°..43°, ‖f̂‖ ≤ 4.2, 40 inputs each; max over the inputs):
//!
//! | spheres | accurate | PS*-4 | OL | HYB (bound 0.25) |
//! |---|---|---|---|---|
//! | 1 | 9e-16 | 2.1e-4 | 1.5e-2 | 1.4e-3 |
//! | 2 | 1.2e-15 | 5.7e-4 | 0.12 | 1.0e-2 |
//! | 4 | 2.1e-15 | 4.0e-3 | 0.29 | 4.1e-2 |
//! | 8 | 4.4e-15 | 3.8e-3 | 0.49 | 8.8e-2 |
//!
//! OL is fitted on single circles (Ren eq. 24) and only captures the span of {1, f̂}: it is good for one blocker and
//! degrades with several; HYB's squarings recover most of that.

use crate::basis::{MAX_COEFFS, MAX_ORDER};
use crate::tables_data::{OL_2, OL_3, OL_4, OL_5, OL_6, OL_7, OL_8, OL_MAX_NORM};
use crate::triple::SMALL;
use crate::{check_len, check_order, coeff_count, ShError, TripleProduct};
use core::f64::consts::PI;

/// √(4π): the DC coefficient of the SH unit **1**.
const SQRT_4PI: f64 = 3.544_907_701_811_032;

/// Rows of each OL table: ‖f̂‖_k = k · max / (OL_SAMPLES − 1), k = 0..63.
pub const OL_SAMPLES: usize = 64;

/// Largest scaling exponent p of [`sh_exp_accurate`] (2¹² operator applications); larger inputs lose accuracy.
const MAX_ACCURATE_P: i32 = 12;

/// Largest number of series terms per operator application in [`sh_exp_accurate`].
const MAX_SERIES_TERMS: usize = 60;

/// Largest scaling exponent of PS* and HYB (keeps non-finite or absurd inputs bounded in time).
const MAX_SQUARINGS: i32 = 30;

/// Splits f into exp(f_0/√(4π)) and f̂ (f with f_0 = 0) — Ren eq. 20 — and returns (scale, ‖f̂‖).
#[inline]
fn dc_isolate(f: &[f64], nc: usize, fhat: &mut [f64; MAX_COEFFS]) -> (f64, f64) {
    fhat[..nc].copy_from_slice(&f[..nc]);
    fhat[0] = 0.0;
    let norm = libm::sqrt(fhat[1..nc].iter().map(|x| x * x).sum());
    (libm::exp(f[0] / SQRT_4PI), norm)
}

fn check_args(tp: &TripleProduct, f: &[f64], out: &[f64]) -> Result<usize, ShError> {
    let nc = coeff_count(tp.order());
    check_len("f", nc, f.len())?;
    check_len("out", nc, out.len())?;
    Ok(nc)
}

/// Accurate SH exponential exp*(f) = exp(M_f)·1 (f64, the tensor's order), allocation-free.
///
/// DC isolation, then p = the smallest exponent with ρ/2ᵖ ≤ 1, where ρ = ‖f̂‖ · order/√(4π) bounds the spectral radius
/// of M_f̂ (|f̂(s)| ≤ ‖f̂‖ ‖y(s)‖), then v ← exp(M_f̂/2ᵖ) v applied 2ᵖ times to v = **1**, each by the series
/// Σ_k (f̂/2ᵖ)∗(…∗v)/k! until a term is below 1e-17 of the sum (≤ 60 terms). This equals the left-to-right product
/// series of Ren eq. 17 (math reference §3) to rounding (≈1e-14 relative for ‖f̂‖ ≲ 10). Cost grows linearly with
/// ‖f̂‖ (p ≤ 12: beyond ρ ≈ 4096 the result loses accuracy). Writes `out[0..order²]`.
/// Errors: `f` or `out` shorter than order².
pub fn sh_exp_accurate(tp: &TripleProduct, f: &[f64], out: &mut [f64]) -> Result<(), ShError> {
    let nc = check_args(tp, f, out)?;
    if nc == 0 {
        return Ok(());
    }
    let mut x = [0.0; MAX_COEFFS];
    let (scale, norm) = dc_isolate(f, nc, &mut x);
    let rho = norm * tp.order() as f64 / SQRT_4PI;
    let mut p = 0;
    while p < MAX_ACCURATE_P && rho > libm::ldexp(1.0, p) {
        p += 1;
    }
    let s = libm::ldexp(1.0, -p);
    for xi in &mut x[..nc] {
        *xi *= s;
    }
    let mut v = [0.0; MAX_COEFFS];
    v[0] = SQRT_4PI;
    let mut term = [0.0; MAX_COEFFS];
    let mut next = [0.0; MAX_COEFFS];
    for _ in 0..(1u32 << p) {
        term[..nc].copy_from_slice(&v[..nc]);
        let mut sum = v;
        for k in 1..=MAX_SERIES_TERMS {
            tp.product(&x, &term, &mut next)?;
            let inv = 1.0 / k as f64;
            let mut tn = 0.0;
            let mut sn = 0.0;
            for i in 0..nc {
                term[i] = next[i] * inv;
                sum[i] += term[i];
                tn += term[i] * term[i];
                sn += sum[i] * sum[i];
            }
            if tn <= 1e-34 * sn {
                break;
            }
        }
        v = sum;
    }
    for i in 0..nc {
        out[i] = scale * v[i];
    }
    Ok(())
}

/// Squares `r` p times with SH products (r ← r ∗ r).
fn square_p(tp: &TripleProduct, r: &mut [f64; MAX_COEFFS], p: i32) -> Result<(), ShError> {
    let mut tmp = [0.0; MAX_COEFFS];
    for _ in 0..p {
        tp.product(r, r, &mut tmp)?;
        *r = tmp;
    }
    Ok(())
}

/// `p` SH squarings of `r` on arrays of `N` coefficients ([`TripleProduct::square_array`]).
fn square_p_array<const N: usize>(tp: &TripleProduct, r: &mut [f64; N], p: i32) {
    let mut tmp = [0.0; N];
    for _ in 0..p {
        tp.square_array(r, &mut tmp);
        *r = tmp;
    }
}

/// Ren's PS*-`degree` SH exponential (f64, the tensor's order), allocation-free: DC isolation (eq. 20), scaling by 2ᵖ
/// with p = max(0, ⌊log₂‖f̂‖ + 3⌋) (eq. 21), the degree-`degree` series factored into even and odd powers (eq. 22;
/// f̂²* = f̂∗f̂, f̂⁴* = f̂²*∗f̂²*, f̂⁶* = f̂⁴*∗f̂²*, …), then p SH squarings.
///
/// `degree` 1..=20 (clamped into that range); Ren uses small degrees (PS*-4 … PS*-8). Approximates exp(M_f)·1: the
/// squarings truncate, see the module docs for measured errors. Writes `out[0..order²]`.
/// Errors: `f` or `out` shorter than order².
pub fn sh_exp_ps_star(tp: &TripleProduct, f: &[f64], degree: usize, out: &mut [f64]) -> Result<(), ShError> {
    let nc = check_args(tp, f, out)?;
    if nc == 0 {
        return Ok(());
    }
    // Work arrays of 16 coefficients up to order 4 (the runtime's default), else 64: the same arithmetic either way.
    if nc <= SMALL {
        ps_star_array::<SMALL>(tp, f, nc, degree, out);
    } else {
        ps_star_array::<MAX_COEFFS>(tp, f, nc, degree, out);
    }
    Ok(())
}

/// [`sh_exp_ps_star`] on arrays of `N` ≥ `nc` coefficients (checked arguments).
fn ps_star_array<const N: usize>(tp: &TripleProduct, f: &[f64], nc: usize, degree: usize, out: &mut [f64]) {
    let degree = degree.clamp(1, 20);
    let mut x = [0.0; N];
    x[..nc].copy_from_slice(&f[..nc]);
    x[0] = 0.0;
    let (scale, norm) = (libm::exp(f[0] / SQRT_4PI), libm::sqrt(x[1..nc].iter().map(|v| v * v).sum()));
    let p = if norm > 0.0 { (libm::floor(libm::log2(norm) + 3.0) as i32).clamp(0, MAX_SQUARINGS) } else { 0 };
    let s = libm::ldexp(1.0, -p);
    for xi in &mut x[..nc] {
        *xi *= s;
    }
    // even = Σ_{k even ≤ d} x^k*/k!, odd = Σ_{k odd ≤ d} x^(k−1)*/k!, result = even + x ∗ odd (eq. 22).
    let mut even = [0.0; N];
    let mut odd = [0.0; N];
    even[0] = SQRT_4PI;
    odd[0] = SQRT_4PI;
    let mut x2 = [0.0; N];
    let mut pow = [0.0; N]; // x^(2j)*
    let mut tmp = [0.0; N];
    let mut fact = 1.0; // (2j)!
    let mut j = 1;
    while 2 * j <= degree {
        if j == 1 {
            tp.square_array(&x, &mut x2);
            pow = x2;
        } else if j == 2 {
            // pow = x², so x⁴* is a square.
            tp.square_array(&x2, &mut tmp);
            pow = tmp;
        } else {
            tp.product_array(&pow, &x2, &mut tmp);
            pow = tmp;
        }
        fact *= (2 * j - 1) as f64 * (2 * j) as f64;
        let odd_w = if 2 * j < degree { 1.0 / (fact * (2 * j + 1) as f64) } else { 0.0 };
        for i in 0..nc {
            even[i] += pow[i] / fact;
            odd[i] += pow[i] * odd_w;
        }
        j += 1;
    }
    tp.product_array(&x, &odd, &mut tmp);
    let mut r = even;
    for i in 0..nc {
        r[i] += tmp[i];
    }
    square_p_array(tp, &mut r, p);
    for i in 0..nc {
        out[i] = scale * r[i];
    }
}

/// OL rows and the largest tabulated ‖f̂‖ of an order 2..=8.
#[inline]
fn ol_table(order: usize) -> (&'static [[f32; 2]; OL_SAMPLES], f32) {
    let t = match order {
        2 => &OL_2,
        3 => &OL_3,
        4 => &OL_4,
        5 => &OL_5,
        6 => &OL_6,
        7 => &OL_7,
        _ => &OL_8,
    };
    (t, OL_MAX_NORM[order])
}

/// Interpolated (a, b) at ‖f̂‖ = `norm` (clamped to the table: beyond its end the last row is used).
#[inline]
fn ol_coeffs(order: usize, norm: f64) -> (f64, f64) {
    if order < 2 {
        return (1.0, 1.0);
    }
    let (t, max) = ol_table(order);
    let u = norm / max as f64 * (OL_SAMPLES - 1) as f64;
    // NaN maps to 0 (the first row); beyond the table the last row is used.
    let u = if u > 0.0 { u.min((OL_SAMPLES - 1) as f64) } else { 0.0 };
    let k = (u as usize).min(OL_SAMPLES - 2);
    let w = u - k as f64;
    let (r0, r1) = (t[k], t[k + 1]);
    // a(x) = 1 + x²/(8π) + O(x³) (the DC of f̂∗f̂/2 is ‖f̂‖²/(2√(4π))): interpolate a − x²/(8π) and add the quadratic
    // back, so the coarse first interval does not turn the exact second-order term into an O(h·x) error.
    let step = max as f64 / (OL_SAMPLES - 1) as f64;
    let q = |x: f64| x * x / (8.0 * PI);
    let (x0, x1) = (k as f64 * step, (k + 1) as f64 * step);
    let x = u * step;
    let a = (r0[0] as f64 - q(x0)) + w * ((r1[0] as f64 - q(x1)) - (r0[0] as f64 - q(x0))) + q(x);
    (a, r0[1] as f64 + w * (r1[1] - r0[1]) as f64)
}

/// Largest ‖f̂‖ (the norm of f without its DC coefficient) covered by the OL table of `order` (0 for order < 2).
///
/// The table spans the circle logs of angular radius 0..θ_end, where θ_end = π/2 or the first radius at which ‖f̂‖ stops
/// increasing. Inputs beyond it use the last row (Ren §4.2: accurate only below ≈ 4.8 at order 4).
pub fn ol_max_norm(order: usize) -> f64 {
    if (2..=MAX_ORDER).contains(&order) {
        OL_MAX_NORM[order] as f64
    } else {
        0.0
    }
}

/// Ren's optimal linear SH exponential (eq. 23), f64, no SH product: exp*(f) ≈ exp(f_0/√(4π)) (a(‖f̂‖)·1 + b(‖f̂‖)·f̂).
///
/// a, b come from the embedded table of `order` (least squares over circle logs, eq. 24; generated offline), linearly
/// interpolated in ‖f̂‖ and clamped at [`ol_max_norm`]. Orders 0 and 1 are exact (no f̂). Writes `out[0..order²]`.
/// Errors: `order > 8`, `f` or `out` shorter than order².
pub fn sh_exp_ol(order: usize, f: &[f64], out: &mut [f64]) -> Result<(), ShError> {
    check_order(order, MAX_ORDER)?;
    let nc = coeff_count(order);
    check_len("f", nc, f.len())?;
    check_len("out", nc, out.len())?;
    if nc == 0 {
        return Ok(());
    }
    let mut x = [0.0; MAX_COEFFS];
    let (scale, norm) = dc_isolate(f, nc, &mut x);
    let (a, b) = ol_coeffs(order, norm);
    out[0] = scale * a * SQRT_4PI;
    for i in 1..nc {
        out[i] = scale * b * x[i];
    }
    Ok(())
}

/// f32 [`sh_exp_ol`] (the runtime path: no tensor, no allocation, ~order² multiplies).
///
/// Errors: `order > 8`, `f` or `out` shorter than order².
pub fn sh_exp_ol_f32(order: usize, f: &[f32], out: &mut [f32]) -> Result<(), ShError> {
    check_order(order, MAX_ORDER)?;
    let nc = coeff_count(order);
    check_len("f", nc, f.len())?;
    check_len("out", nc, out.len())?;
    if nc == 0 {
        return Ok(());
    }
    let norm = libm::sqrtf(f[1..nc].iter().map(|x| x * x).sum());
    let scale = libm::expf(f[0] / SQRT_4PI as f32);
    let (a, b) = ol_coeffs(order, norm as f64);
    out[0] = scale * a as f32 * SQRT_4PI as f32;
    let sb = scale * b as f32;
    for i in 1..nc {
        out[i] = sb * f[i];
    }
    Ok(())
}

/// Ren's hybrid SH exponential HYB (f64, the tensor's order): DC isolation, scaling f̂ by 2⁻ᵖ with the smallest p ≥ 0
/// such that ‖f̂‖/2ᵖ ≤ `ol_norm_bound`, [`sh_exp_ol`] of the scaled vector, then p SH squarings.
///
/// `ol_norm_bound` is the largest norm trusted to OL; [`HYB_DEFAULT_NORM_BOUND`] is a measured good choice. Values
/// ≤ 0 or NaN are treated as the default. Writes `out[0..order²]`. Allocation-free.
/// Errors: `f` or `out` shorter than order².
pub fn sh_exp_hyb(tp: &TripleProduct, f: &[f64], ol_norm_bound: f64, out: &mut [f64]) -> Result<(), ShError> {
    let nc = check_args(tp, f, out)?;
    if nc == 0 {
        return Ok(());
    }
    let bound = if ol_norm_bound > 0.0 { ol_norm_bound } else { HYB_DEFAULT_NORM_BOUND };
    let mut x = [0.0; MAX_COEFFS];
    let (scale, norm) = dc_isolate(f, nc, &mut x);
    let mut p = 0;
    while p < MAX_SQUARINGS && norm > libm::ldexp(bound, p) {
        p += 1;
    }
    let s = libm::ldexp(1.0, -p);
    let (a, b) = ol_coeffs(tp.order(), norm * s);
    let mut r = [0.0; MAX_COEFFS];
    r[0] = a * SQRT_4PI;
    for i in 1..nc {
        r[i] = b * s * x[i];
    }
    square_p(tp, &mut r, p)?;
    for i in 0..nc {
        out[i] = scale * r[i];
    }
    Ok(())
}

/// Default `ol_norm_bound` of [`sh_exp_hyb`].
pub const HYB_DEFAULT_NORM_BOUND: f64 = 0.25;

#[cfg(test)]
mod tests {
    use super::*;

    /// Order 2: M_f̂ = [[0, f̂ᵀ/√(4π)], [f̂/√(4π), 0]] (band 1 ∗ band 1 has no band-1 part), so
    /// exp*(f̂) = √(4π) cosh(x) e₀ + sinh(x)/x · f̂ with x = ‖f̂‖/√(4π) — exactly of the OL form, and closed under squaring.
    fn order2_exact(f: &[f64; 4]) -> [f64; 4] {
        let x = libm::sqrt(f[1] * f[1] + f[2] * f[2] + f[3] * f[3]) / SQRT_4PI;
        let s = libm::exp(f[0] / SQRT_4PI);
        let sh = if x > 0.0 { libm::sinh(x) / x } else { 1.0 };
        [s * SQRT_4PI * libm::cosh(x), s * sh * f[1], s * sh * f[2], s * sh * f[3]]
    }

    #[test]
    fn order_two_closed_form_all_methods() {
        let tp = TripleProduct::new(2).unwrap();
        // Norms across and past the OL table (OL_MAX_NORM[2] ≈ 4.67 from the 90° cap).
        for (k, scale) in [0.0, 0.05, 0.4, 1.3, 2.9, 4.5].into_iter().enumerate() {
            let f = [-0.7 + 0.2 * k as f64, -0.36 * scale, 0.8 * scale, 0.48 * scale];
            let want = order2_exact(&f);
            let mut out = [0.0; 4];
            let rel = |o: &[f64; 4]| {
                let e: f64 = o.iter().zip(&want).map(|(a, b)| (a - b) * (a - b)).sum();
                libm::sqrt(e / want.iter().map(|v| v * v).sum::<f64>())
            };
            sh_exp_accurate(&tp, &f, &mut out).unwrap();
            assert!(rel(&out) < 1e-14, "accurate {scale}: {}", rel(&out));
            sh_exp_ps_star(&tp, &f, 12, &mut out).unwrap();
            assert!(rel(&out) < 1e-12, "PS* {scale}: {}", rel(&out));
            // OL: (a, b) interpolated from f32 rows 0.074 apart in ‖f̂‖ (error ~ h²/8 · a'').
            sh_exp_ol(2, &f, &mut out).unwrap();
            assert!(rel(&out) < 2e-4, "OL {scale}: {}", rel(&out));
            // HYB: the same interpolation error, roughly doubled by each of the p ≤ 5 squarings.
            sh_exp_hyb(&tp, &f, HYB_DEFAULT_NORM_BOUND, &mut out).unwrap();
            assert!(rel(&out) < 1e-3, "HYB {scale}: {}", rel(&out));
            let f32in = f.map(|v| v as f32);
            let mut o32 = [0.0f32; 4];
            sh_exp_ol_f32(2, &f32in, &mut o32).unwrap();
            assert!(rel(&o32.map(|v| v as f64)) < 3e-4, "OL f32 {scale}");
        }
    }

    /// f̂ = 0: every method returns exp(f_0/√(4π)) · **1** exactly (DC isolation, eq. 20).
    #[test]
    fn dc_only_input() {
        for order in 1..=MAX_ORDER {
            let tp = TripleProduct::new(order).unwrap();
            let mut f = [0.0; MAX_COEFFS];
            f[0] = -1.7;
            let want = libm::exp(-1.7 / SQRT_4PI) * SQRT_4PI;
            let mut out = [9.0; MAX_COEFFS];
            let nc = order * order;
            type Method = fn(&TripleProduct, &[f64], &mut [f64]) -> Result<(), ShError>;
            let methods: [Method; 4] = [
                sh_exp_accurate,
                |tp, f, o| sh_exp_ps_star(tp, f, 4, o),
                |tp, f, o| sh_exp_ol(tp.order(), f, o),
                |tp, f, o| sh_exp_hyb(tp, f, HYB_DEFAULT_NORM_BOUND, o),
            ];
            for m in methods {
                m(&tp, &f, &mut out).unwrap();
                assert!((out[0] - want).abs() < 1e-14 * want, "order {order}");
                assert!(out[1..nc].iter().all(|&v| v == 0.0));
                assert!(out[nc..].iter().all(|&v| v == 9.0), "entries past order² untouched");
            }
        }
    }

    #[test]
    fn errors_not_panics() {
        let tp = TripleProduct::new(4).unwrap();
        let mut out = [0.0; 16];
        assert!(matches!(
            sh_exp_accurate(&tp, &[0.0; 15], &mut out),
            Err(ShError::BufferTooShort { buffer: "f", expected: 16, actual: 15 })
        ));
        assert!(matches!(
            sh_exp_ps_star(&tp, &[0.0; 16], 4, &mut [0.0; 9]),
            Err(ShError::BufferTooShort { buffer: "out", expected: 16, actual: 9 })
        ));
        assert!(matches!(sh_exp_ol(9, &[0.0; 81], &mut [0.0; 81]), Err(ShError::OrderOutOfRange { order: 9, .. })));
        assert!(matches!(sh_exp_ol_f32(3, &[0.0; 8], &mut [0.0; 9]), Err(ShError::BufferTooShort { .. })));
        // Non-finite input: no panic, bounded work.
        let mut f = [0.0; 16];
        f[3] = f64::INFINITY;
        assert!(sh_exp_ps_star(&tp, &f, 4, &mut out).is_ok());
        assert!(sh_exp_hyb(&tp, &f, HYB_DEFAULT_NORM_BOUND, &mut out).is_ok());
        assert!(sh_exp_accurate(&tp, &f, &mut out).is_ok());
        f[3] = f64::NAN;
        assert!(sh_exp_ol(4, &f, &mut out).is_ok());
        // Order 0: nothing to write.
        let tp0 = TripleProduct::new(0).unwrap();
        assert!(sh_exp_accurate(&tp0, &[], &mut []).is_ok());
        assert!(sh_exp_ps_star(&tp0, &[], 4, &mut []).is_ok());
        assert!(sh_exp_hyb(&tp0, &[], 0.25, &mut []).is_ok());
        assert!(sh_exp_ol(0, &[], &mut []).is_ok());
    }
}
