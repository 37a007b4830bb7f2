//! The log-visibility table of a circle (Ren 2006 §6.1, eq. 34; math reference §3, §9) and ratio vectors (eq. 37).
//!
//! The table F_l(θ) = √(4π/(2l+1)) · f_l0(θ), where f = log(1 − χ_θ) is the eigen-clipped SH logarithm (paper form P,
//! ε = 0.02 × the largest eigenvalue of M_g) of the visibility of a cap of angular radius θ about +z, is generated
//! offline (`examples/gen_log_table.rs`, nalgebra) into `tables_data.rs` and embedded here as f32 data: one table per
//! order 2..=8 (the log of a truncated vector depends on the order), [`LOG_VIS_THETA_SAMPLES`] rows uniform in θ over
//! [0, π/2] (row 0 is θ = 0, F = 0). Lookups interpolate linearly in θ. Order 1 is analytic: F_0 = 4π ln((1 + cos θ)/2).

use crate::basis::{eval_unchecked, sh_index, MAX_COEFFS, MAX_ORDER};
use crate::tables_data::{LOG_VIS_2, LOG_VIS_3, LOG_VIS_4, LOG_VIS_5, LOG_VIS_6, LOG_VIS_7, LOG_VIS_8};
use crate::{check_len, check_order, coeff_count, ShError};
use core::f64::consts::PI;

/// Rows of each log-visibility table: θ_k = k · [`LOG_VIS_THETA_STEP`], k = 0..255, covering [0, π/2] inclusive.
pub const LOG_VIS_THETA_SAMPLES: usize = 256;

/// Spacing of the log-visibility table in θ: π/510 rad (≈ 0.353°).
pub const LOG_VIS_THETA_STEP: f64 = PI / 2.0 / (LOG_VIS_THETA_SAMPLES - 1) as f64;

/// √(4π/(2l+1)) per band: F_l = SCALE[l] · f_l0.
const BAND_SCALE: [f64; MAX_ORDER] = {
    let mut t = [0.0; MAX_ORDER];
    let mut l = 0;
    while l < MAX_ORDER {
        t[l] = crate::basis::const_sqrt(4.0 * PI / (2 * l + 1) as f64);
        l += 1;
    }
    t
};

/// Row `k` of the order-`order` table (2 ≤ order ≤ 8, k < 256; checked by the callers).
#[inline(always)]
fn row(order: usize, k: usize) -> &'static [f32] {
    match order {
        2 => &LOG_VIS_2[k],
        3 => &LOG_VIS_3[k],
        4 => &LOG_VIS_4[k],
        5 => &LOG_VIS_5[k],
        6 => &LOG_VIS_6[k],
        7 => &LOG_VIS_7[k],
        _ => &LOG_VIS_8[k],
    }
}

/// Interpolated F_l(θ) for l < order into `out` (order ≤ 8, `out.len() >= order`; checked by the callers).
#[inline(always)]
fn interp_f32(theta_rad: f32, order: usize, out: &mut [f32]) {
    const MAX_THETA: f32 = core::f32::consts::FRAC_PI_2;
    const INV_STEP: f32 = (1.0 / LOG_VIS_THETA_STEP) as f32;
    // NaN and negative angles map to 0 (no occlusion); angles past π/2 (receiver inside the sphere) clamp to π/2.
    let theta = if theta_rad > 0.0 { theta_rad.min(MAX_THETA) } else { 0.0 };
    if order == 1 {
        out[0] = (4.0 * PI) as f32 * libm::logf(0.5 * (1.0 + libm::cosf(theta)));
        return;
    }
    let t = theta * INV_STEP;
    let k = (t as usize).min(LOG_VIS_THETA_SAMPLES - 2);
    let frac = t - k as f32;
    let (r0, r1) = (row(order, k), row(order, k + 1));
    for l in 0..order {
        out[l] = r0[l] + frac * (r1[l] - r0[l]);
    }
}

/// Ren's F_l(θ) (eq. 34) for l < `order`, f32: the log visibility of a sphere of angular radius `theta_rad` seen in
/// unit direction s is f_lm = F_l(θ) y_lm(s).
///
/// Table lookup with linear interpolation in θ. θ is clamped to [0, π/2] (NaN → 0: no occlusion; θ > π/2 is treated
/// as π/2). `order` 0..=8 (order 1 is analytic, 0 writes nothing). Writes `out[0..order]`. Allocation-free.
/// Errors: `order > 8`, `out.len() < order`.
pub fn log_visibility_f_f32(theta_rad: f32, order: usize, out: &mut [f32]) -> Result<(), ShError> {
    check_order(order, MAX_ORDER)?;
    check_len("out", order, out.len())?;
    if order > 0 {
        interp_f32(theta_rad, order, out);
    }
    Ok(())
}

/// Ren's F_l(θ) (eq. 34) for l < `order` in f64 (same table and interpolation as [`log_visibility_f_f32`]).
///
/// Errors: `order > 8`, `out.len() < order`.
pub fn log_visibility_f(theta_rad: f64, order: usize, out: &mut [f64]) -> Result<(), ShError> {
    check_order(order, MAX_ORDER)?;
    check_len("out", order, out.len())?;
    if order == 0 {
        return Ok(());
    }
    let theta = if theta_rad > 0.0 { theta_rad.min(PI / 2.0) } else { 0.0 };
    if order == 1 {
        out[0] = 4.0 * PI * libm::log(0.5 * (1.0 + libm::cos(theta)));
        return Ok(());
    }
    let t = theta / LOG_VIS_THETA_STEP;
    let k = (t as usize).min(LOG_VIS_THETA_SAMPLES - 2);
    let frac = t - k as f64;
    let (r0, r1) = (row(order, k), row(order, k + 1));
    for l in 0..order {
        out[l] = r0[l] as f64 + frac * (r1[l] as f64 - r0[l] as f64);
    }
    Ok(())
}

/// Zonal coefficients f_l0(θ) = F_l(θ) / √(4π/(2l+1)) of the log visibility of a cap of angular radius `theta_rad`
/// about +z, l < `order` (f64): the [`zh_rotate`](crate::zh_rotate) convention, like [`cap_visibility_zh`](crate::cap_visibility_zh).
///
/// `zh_rotate(f, s, out)` then gives the log-visibility vector of a sphere in direction s. Same lookup as
/// [`log_visibility_f`]. Errors: `order > 8`, `out.len() < order`.
pub fn log_visibility_zh(theta_rad: f64, order: usize, out: &mut [f64]) -> Result<(), ShError> {
    log_visibility_f(theta_rad, order, out)?;
    for l in 0..order {
        out[l] /= BAND_SCALE[l];
    }
    Ok(())
}

/// f32 [`log_visibility_zh`]: zonal coefficients f_l0(θ) for [`zh_rotate_f32`](crate::zh_rotate_f32).
///
/// Errors: `order > 8`, `out.len() < order`.
pub fn log_visibility_zh_f32(theta_rad: f32, order: usize, out: &mut [f32]) -> Result<(), ShError> {
    log_visibility_f_f32(theta_rad, order, out)?;
    for l in 0..order {
        out[l] /= BAND_SCALE[l] as f32;
    }
    Ok(())
}

/// Adds the log-visibility vector of one blocker sphere, weighted per band, to `out` (f32; Ren eqs. 34 and 38):
/// out_lm += w_l · F_l(θ) · y_lm(s), with order = `band_weights.len()`.
///
/// `theta_rad` = asin(r / |P − p|) is the sphere's angular radius seen from the receiver p and `dir` = (P − p)/|P − p|
/// (unit length, not normalised here). Pass all-ones weights for a plain sphere, the node's ratio vector w (see
/// [`ratio_vector`]) for an interior node of the hierarchy cut. θ handling as in [`log_visibility_f_f32`].
/// Writes `out[0..order²]`. Allocation-free. Errors: `band_weights.len() > 8`, `out.len() < order²`.
#[inline]
pub fn accumulate_log_visibility_f32(
    theta_rad: f32,
    dir: [f32; 3],
    band_weights: &[f32],
    out: &mut [f32],
) -> Result<(), ShError> {
    let order = band_weights.len();
    check_order(order, MAX_ORDER)?;
    check_len("out", coeff_count(order), out.len())?;
    if order == 0 {
        return Ok(());
    }
    let mut f = [0.0f32; MAX_ORDER];
    interp_f32(theta_rad, order, &mut f);
    let mut y = [0.0f32; MAX_COEFFS];
    eval_unchecked(order, dir[0], dir[1], dir[2], &mut y);
    for l in 0..order {
        let s = f[l] * band_weights[l];
        let (lo, hi) = (l * l, (l + 1) * (l + 1));
        for (o, &yi) in out[lo..hi].iter_mut().zip(&y[lo..hi]) {
            *o += s * yi;
        }
    }
    Ok(())
}

/// Per-band least-squares ratio vector of Ren eq. 37: w_l = Σ_m (f_b)_lm (f_d)_lm / Σ_m (f_b)_lm², l < `order` (f64).
///
/// `f_b` is the log vector of a hierarchy node at the cluster point p*, `f_d` the sum of the log vectors of the node's
/// leaves there; W = diag(w_l repeated 2l + 1 times) then minimises ‖W f_b − f_d‖ band by band. A band where f_b is
/// zero carries no information and gets w_l = 1. Writes `out[0..order]`.
/// Errors: `order > 8`, `f_b` or `f_d` shorter than order², `out` shorter than order.
pub fn ratio_vector(f_b: &[f64], f_d: &[f64], order: usize, out: &mut [f64]) -> Result<(), ShError> {
    check_order(order, MAX_ORDER)?;
    let nc = coeff_count(order);
    check_len("f_b", nc, f_b.len())?;
    check_len("f_d", nc, f_d.len())?;
    check_len("out", order, out.len())?;
    for l in 0..order {
        let (mut num, mut den) = (0.0, 0.0);
        for m in -(l as isize)..=(l as isize) {
            let i = sh_index(l, m);
            num += f_b[i] * f_d[i];
            den += f_b[i] * f_b[i];
        }
        out[l] = if den > 0.0 { num / den } else { 1.0 };
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{cap_visibility_zh, eval_sh_f64, zh_rotate};

    /// Order 1: M_g = (v_0/√(4π)) I is scalar, so the clipped log is exactly √(4π) ln(v_0/√(4π)) (v_0 from §2's cap formula).
    #[test]
    fn order_one_is_the_scalar_log() {
        for theta in [0.0, 0.2, 0.9, 1.5, core::f64::consts::FRAC_PI_2] {
            let mut v = [0.0; 1];
            cap_visibility_zh(theta, 1, &mut v).unwrap();
            let sq = libm::sqrt(4.0 * PI);
            let f0 = sq * libm::log(v[0] / sq);
            let mut f = [0.0; 1];
            log_visibility_zh(theta, 1, &mut f).unwrap();
            assert!((f[0] - f0).abs() < 1e-12, "{theta}: {} vs {f0}", f[0]);
            let mut f32v = [0.0f32; 1];
            log_visibility_zh_f32(theta as f32, 1, &mut f32v).unwrap();
            assert!((f32v[0] as f64 - f0).abs() < 1e-5 * (1.0 + f0.abs()));
        }
    }

    #[test]
    fn theta_is_clamped_and_nan_means_no_occlusion() {
        for order in 1..=MAX_ORDER {
            let mut a = [1.0; MAX_ORDER];
            let mut b = [1.0; MAX_ORDER];
            log_visibility_f(f64::NAN, order, &mut a).unwrap();
            log_visibility_f(-0.3, order, &mut b).unwrap();
            for l in 0..order {
                assert!(a[l].abs() < 1e-12 && b[l].abs() < 1e-12, "order {order}: θ ≤ 0 must give F = 0");
            }
            log_visibility_f(PI / 2.0, order, &mut a).unwrap();
            log_visibility_f(3.0, order, &mut b).unwrap();
            assert_eq!(a[..order], b[..order]);
            let mut c = [0.0f32; MAX_ORDER];
            log_visibility_f_f32(f32::NAN, order, &mut c).unwrap();
            assert!(c[..order].iter().all(|x| x.abs() < 1e-12));
        }
    }

    #[test]
    fn f32_and_f64_lookups_agree_and_zh_scaling() {
        for order in 1..=MAX_ORDER {
            for k in 0..200 {
                let theta = k as f64 * 0.0079;
                let (mut a, mut b) = ([0.0; MAX_ORDER], [0.0f32; MAX_ORDER]);
                log_visibility_f(theta, order, &mut a).unwrap();
                log_visibility_f_f32(theta as f32, order, &mut b).unwrap();
                let (mut za, mut zb) = ([0.0; MAX_ORDER], [0.0f32; MAX_ORDER]);
                log_visibility_zh(theta, order, &mut za).unwrap();
                log_visibility_zh_f32(theta as f32, order, &mut zb).unwrap();
                for l in 0..order {
                    assert!((a[l] - b[l] as f64).abs() < 2e-5 * (1.0 + a[l].abs()), "order {order} θ {theta} l {l}");
                    let scale = libm::sqrt(4.0 * PI / (2 * l + 1) as f64);
                    assert!((za[l] * scale - a[l]).abs() < 1e-12 * (1.0 + a[l].abs()));
                    assert!((zb[l] as f64 - za[l]).abs() < 2e-5 * (1.0 + za[l].abs()));
                }
            }
        }
    }

    /// The fused accumulation equals zh_rotate of the zonal log (both routes of the rotation rule), with band weights.
    #[test]
    fn accumulate_matches_zh_rotate() {
        let dirs = [[0.0, 0.0, 1.0], [-0.48, 0.6, -0.64], [0.6, 0.0, 0.8], [0.0, -1.0, 0.0]];
        for order in 1..=MAX_ORDER {
            let w: [f32; MAX_ORDER] = core::array::from_fn(|l| 1.0 - 0.07 * l as f32);
            let mut acc = [0.25f32; MAX_COEFFS];
            let mut want = [0.25f64; MAX_COEFFS];
            for (j, d) in dirs.iter().enumerate() {
                let theta = 0.1 + 0.3 * j as f64;
                let mut z = [0.0; MAX_ORDER];
                log_visibility_zh(theta, order, &mut z).unwrap();
                let mut v = [0.0; MAX_COEFFS];
                zh_rotate(&z[..order], *d, &mut v).unwrap();
                for l in 0..order {
                    for i in l * l..(l + 1) * (l + 1) {
                        want[i] += w[l] as f64 * v[i];
                    }
                }
                let d32 = [d[0] as f32, d[1] as f32, d[2] as f32];
                accumulate_log_visibility_f32(theta as f32, d32, &w[..order], &mut acc).unwrap();
            }
            for i in 0..coeff_count(order) {
                assert!((acc[i] as f64 - want[i]).abs() < 2e-5 * (1.0 + want[i].abs()), "order {order} i {i}");
            }
            for i in coeff_count(order)..MAX_COEFFS {
                assert_eq!(acc[i], 0.25, "entries past order² untouched");
            }
        }
    }

    /// §9 band energy: Σ_m f_lm² = F_l² (2l+1)/(4π) for f_lm = F_l y_lm(s) (addition theorem).
    #[test]
    fn band_energy_identity() {
        let s = [0.36, -0.48, 0.8];
        for order in 2..=MAX_ORDER {
            let mut f = [0.0f32; MAX_COEFFS];
            accumulate_log_visibility_f32(
                0.6,
                [s[0] as f32, s[1] as f32, s[2] as f32],
                &[1.0; MAX_ORDER][..order],
                &mut f,
            )
            .unwrap();
            let mut big_f = [0.0; MAX_ORDER];
            log_visibility_f(0.6, order, &mut big_f).unwrap();
            let mut y = [0.0; MAX_COEFFS];
            eval_sh_f64(order, s, &mut y).unwrap();
            for l in 0..order {
                let e: f64 = (l * l..(l + 1) * (l + 1)).map(|i| (f[i] as f64).powi(2)).sum();
                let want = big_f[l] * big_f[l] * (2 * l + 1) as f64 / (4.0 * PI);
                assert!((e - want).abs() < 1e-5 * (1.0 + want), "order {order} l {l}: {e} vs {want}");
            }
        }
    }

    #[test]
    fn ratio_vector_least_squares() {
        let fb: [f64; 16] = core::array::from_fn(|i| 0.1 + 0.05 * i as f64 * if i % 3 == 0 { -1.0 } else { 1.0 });
        // f_d = c_l f_b + (a component orthogonal to f_b within band 1) → w_l = c_l exactly.
        let c = [2.0, -0.5, 0.25, 3.0];
        let mut fd = [0.0; 16];
        for l in 0..4 {
            for i in l * l..(l + 1) * (l + 1) {
                fd[i] = c[l] * fb[i];
            }
        }
        let (b1, b2, b3) = (fb[1], fb[2], fb[3]);
        let ortho = [b2, -b1, 0.0]; // ⟂ (b1, b2, b3)
        assert!((ortho[0] * b1 + ortho[1] * b2 + ortho[2] * b3).abs() < 1e-15);
        for k in 0..3 {
            fd[1 + k] += 0.7 * ortho[k];
        }
        let mut w = [0.0; 4];
        ratio_vector(&fb, &fd, 4, &mut w).unwrap();
        for l in 0..4 {
            assert!((w[l] - c[l]).abs() < 1e-14, "l {l}: {}", w[l]);
        }
        // A zero band of f_b gets w = 1.
        let mut fb0 = fb;
        fb0[4..9].fill(0.0);
        ratio_vector(&fb0, &fd, 4, &mut w).unwrap();
        assert_eq!(w[2], 1.0);
    }

    #[test]
    fn errors_not_panics() {
        let mut o = [0.0; 3];
        assert!(matches!(
            log_visibility_f(0.5, 4, &mut o),
            Err(ShError::BufferTooShort { expected: 4, actual: 3, .. })
        ));
        assert!(matches!(log_visibility_zh(0.5, 9, &mut [0.0; 9]), Err(ShError::OrderOutOfRange { order: 9, max: 8 })));
        assert!(matches!(
            accumulate_log_visibility_f32(0.5, [0.0, 0.0, 1.0], &[1.0; 3], &mut [0.0f32; 8]),
            Err(ShError::BufferTooShort { expected: 9, actual: 8, .. })
        ));
        assert!(matches!(
            accumulate_log_visibility_f32(0.5, [0.0, 0.0, 1.0], &[1.0; 9], &mut [0.0f32; 81]),
            Err(ShError::OrderOutOfRange { order: 9, .. })
        ));
        assert!(matches!(
            ratio_vector(&[0.0; 15], &[0.0; 16], 4, &mut [0.0; 4]),
            Err(ShError::BufferTooShort { buffer: "f_b", expected: 16, actual: 15 })
        ));
        // Order 0 writes nothing and succeeds.
        assert!(log_visibility_f(0.5, 0, &mut []).is_ok());
        assert!(accumulate_log_visibility_f32(0.5, [0.0, 0.0, 1.0], &[], &mut []).is_ok());
    }
}
