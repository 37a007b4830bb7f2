//! Real SH basis evaluation (math reference §1): pole-free, trig-free recurrence.

use crate::{check_len, check_order, ShError};
use core::ops::{Add, Div, Mul, Neg, Sub};

/// Largest supported SH order (bands l = 0..7, 64 coefficients).
pub const MAX_ORDER: usize = 8;

/// Number of coefficients of the largest supported order, `MAX_ORDER²` = 64.
pub const MAX_COEFFS: usize = MAX_ORDER * MAX_ORDER;

/// Coefficient index i = l(l+1) + m of band `l`, `-l <= m <= l` (0-based; the PRT 2002 paper's 1-based i is this + 1).
///
/// Precondition: `|m| <= l`; other inputs give an index belonging to another band.
#[inline]
pub const fn sh_index(l: usize, m: isize) -> usize {
    ((l * (l + 1)) as isize + m) as usize
}

/// Number of coefficients n² of SH order `order` (order n = bands l = 0..n−1).
#[inline]
pub const fn coeff_count(order: usize) -> usize {
    order * order
}

/// Minimal float abstraction so the f32 and f64 paths share one implementation.
pub(crate) trait Scalar:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self>
{
    const ZERO: Self;
    const ONE: Self;
    fn from_f64(v: f64) -> Self;
}

impl Scalar for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v
    }
}

impl Scalar for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v as f32
    }
}

/// Square root usable in const context (Newton iteration, within 1 ulp for the inputs used here).
pub(crate) const fn const_sqrt(x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let mut g = if x > 1.0 { x } else { 1.0 };
    let mut k = 0;
    while k < 200 {
        g = 0.5 * (g + x / g);
        k += 1;
    }
    g
}

/// `NORM[l(l+1)+m]` for m ≥ 0: K_l0 (m = 0) or √2 K_lm (m > 0), K_lm = √((2l+1)/(4π) · (l−m)!/(l+m)!).
pub(crate) const NORM: [f64; MAX_COEFFS] = {
    let mut t = [0.0f64; MAX_COEFFS];
    let mut l = 0usize;
    while l < MAX_ORDER {
        let mut m = 0usize;
        while m <= l {
            // (l−m)!/(l+m)! = 1 / ((l−m+1)(l−m+2)…(l+m)), exact in f64 for l < 8.
            let mut den = 1.0f64;
            let mut k = l - m + 1;
            while k <= l + m {
                den *= k as f64;
                k += 1;
            }
            let k2 = (2 * l + 1) as f64 / (4.0 * core::f64::consts::PI) / den;
            let scale = if m == 0 { 1.0 } else { 2.0 };
            t[l * (l + 1) + m] = const_sqrt(scale * k2);
            m += 1;
        }
        l += 1;
    }
    t
};

/// Shared recurrence; `out.len() >= order²` and `order <= MAX_ORDER` are checked by the callers.
#[inline(always)]
pub(crate) fn eval_unchecked<T: Scalar>(order: usize, x: T, y: T, z: T, out: &mut [T]) {
    let mut c = T::ONE; // C_m = Re (x + iy)^m
    let mut s = T::ZERO; // S_m = Im (x + iy)^m
    let mut qmm = T::ONE; // Q_m^m = (−1)^m (2m−1)!!
    for m in 0..order {
        if m > 0 {
            let cn = x * c - y * s;
            let sn = x * s + y * c;
            c = cn;
            s = sn;
            qmm = -(T::from_f64((2 * m - 1) as f64) * qmm);
        }
        let mut q_prev2 = T::ZERO;
        let mut q_prev = qmm;
        for l in m..order {
            let q = if l == m {
                qmm
            } else if l == m + 1 {
                T::from_f64((2 * m + 1) as f64) * z * qmm
            } else {
                (T::from_f64((2 * l - 1) as f64) * z * q_prev - T::from_f64((l + m - 1) as f64) * q_prev2)
                    / T::from_f64((l - m) as f64)
            };
            if l > m {
                q_prev2 = q_prev;
                q_prev = q;
            }
            let centre = l * (l + 1);
            let kq = T::from_f64(NORM[centre + m]) * q;
            if m == 0 {
                out[centre] = kq;
            } else {
                out[centre + m] = kq * c;
                out[centre - m] = kq * s;
            }
        }
    }
}

/// Evaluates the real orthonormal SH basis (Condon–Shortley phase, index l(l+1)+m) in f64 at unit direction `dir`.
///
/// Writes `out[0..order²]`; `dir` must be unit length (not normalised here: the polynomials are evaluated as given).
/// Allocation-free. Errors: `order > MAX_ORDER`, `out.len() < order²`.
pub fn eval_sh_f64(order: usize, dir: [f64; 3], out: &mut [f64]) -> Result<(), ShError> {
    check_order(order, MAX_ORDER)?;
    check_len("out", coeff_count(order), out.len())?;
    eval_unchecked(order, dir[0], dir[1], dir[2], out);
    Ok(())
}

/// Evaluates the real orthonormal SH basis (Condon–Shortley phase, index l(l+1)+m) in f32 at unit direction `dir`.
///
/// Same as [`eval_sh_f64`] with f32 arithmetic (absolute error ~1e-6 up to order 8); `dir` must be unit length.
/// Allocation-free. Errors: `order > MAX_ORDER`, `out.len() < order²`.
pub fn eval_sh(order: usize, dir: [f32; 3], out: &mut [f32]) -> Result<(), ShError> {
    check_order(order, MAX_ORDER)?;
    check_len("out", coeff_count(order), out.len())?;
    eval_unchecked(order, dir[0], dir[1], dir[2], out);
    Ok(())
}

/// Evaluates all 64 coefficients (order 8) in f64 into a fixed array (internal helper).
#[cfg_attr(not(test), allow(dead_code))]
#[inline]
pub(crate) fn eval_sh8(dir: [f64; 3]) -> [f64; MAX_COEFFS] {
    let mut y = [0.0; MAX_COEFFS];
    eval_unchecked(MAX_ORDER, dir[0], dir[1], dir[2], &mut y);
    y
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::gauss_legendre;
    use core::f64::consts::PI;
    use std::vec;
    use std::vec::Vec;

    fn normalize(v: [f64; 3]) -> [f64; 3] {
        let n = libm::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        [v[0] / n, v[1] / n, v[2] / n]
    }

    fn d_b() -> [f64; 3] {
        normalize([1.0, 2.0, 3.0])
    }
    const D_C: [f64; 3] = [-0.48, 0.6, -0.64];

    /// Checks the f64 and f32 evaluations against reference values (indices into the order-8 output).
    fn check(dir: [f64; 3], expected: &[(usize, f64)]) {
        let y = eval_sh8(dir);
        let mut y32 = [0.0f32; MAX_COEFFS];
        eval_sh(8, [dir[0] as f32, dir[1] as f32, dir[2] as f32], &mut y32).unwrap();
        for &(i, e) in expected {
            // Quoted values have 10 significant digits.
            let tol = 1e-9 + 1e-9 * e.abs();
            assert!((y[i] - e).abs() < tol, "y[{i}] = {} expected {e}", y[i]);
            assert!((y32[i] as f64 - e).abs() < 2e-6, "f32 y[{i}] = {} expected {e}", y32[i]);
        }
    }

    #[test]
    fn norm_table_matches_libm() {
        for l in 0..MAX_ORDER {
            for m in 0..=l {
                let mut ratio = 1.0;
                for k in (l - m + 1)..=(l + m) {
                    ratio /= k as f64;
                }
                let k = libm::sqrt((2 * l + 1) as f64 / (4.0 * PI) * ratio);
                let want = if m == 0 { k } else { libm::sqrt(2.0) * k };
                let got = NORM[sh_index(l, m as isize)];
                assert!((got - want).abs() <= 4.0 * f64::EPSILON * want, "{l} {m}");
            }
        }
    }

    #[test]
    fn pole_values() {
        let y = eval_sh8([0.0, 0.0, 1.0]);
        let want = [0.2820947918, 0.4886025119, 0.6307831305, 0.7463526652];
        for l in 0..MAX_ORDER {
            for m in -(l as isize)..=(l as isize) {
                let v = y[sh_index(l, m)];
                if m == 0 {
                    let e = libm::sqrt((2 * l + 1) as f64 / (4.0 * PI));
                    assert!((v - e).abs() < 1e-14);
                    if l < 4 {
                        assert!((v - want[l]).abs() < 1e-9);
                    }
                } else {
                    assert_eq!(v, 0.0, "l={l} m={m}");
                }
            }
        }
    }

    #[test]
    fn table_db_dc() {
        let db = [
            0.2820947918,
            -0.2611690283,
            0.3917535424,
            -0.1305845141,
            0.1560783472,
            -0.4682350417,
            0.2928635963,
            -0.2341175208,
            -0.1170587604,
            0.02252796895,
            0.3310921732,
            -0.540952781,
            0.06411572364,
            -0.2704763905,
            -0.2483191299,
            0.1239038292,
        ];
        let dc = [
            0.2820947918,
            -0.2931615071,
            -0.3127056076,
            0.2345292057,
            -0.314653948,
            0.4195385973,
            0.07216159013,
            -0.3356308779,
            -0.0707971383,
            -0.1172534622,
            0.5327975011,
            -0.2873903987,
            0.2273688759,
            0.229912319,
            0.1198794377,
            -0.2406244963,
        ];
        let e: Vec<(usize, f64)> = db.iter().copied().enumerate().collect();
        check(d_b(), &e);
        let e: Vec<(usize, f64)> = dc.iter().copied().enumerate().collect();
        check(D_C, &e);
    }

    #[test]
    fn explicit_polynomials_l3() {
        // §1 explicit table with the quoted constants, at an arbitrary direction.
        let [x, y, z] = normalize([0.3, -0.7, 0.2]);
        let (c0, c1, c2a, c2b, c2c) = (
            0.5 / libm::sqrt(PI),
            libm::sqrt(3.0 / (4.0 * PI)),
            0.5 * libm::sqrt(15.0 / PI),
            0.25 * libm::sqrt(5.0 / PI),
            0.25 * libm::sqrt(15.0 / PI),
        );
        let (c3a, c3b, c3c, c3d, c3e) = (
            0.25 * libm::sqrt(35.0 / (2.0 * PI)),
            0.5 * libm::sqrt(105.0 / PI),
            0.25 * libm::sqrt(21.0 / (2.0 * PI)),
            0.25 * libm::sqrt(7.0 / PI),
            0.25 * libm::sqrt(105.0 / PI),
        );
        let want = [
            c0,
            -c1 * y,
            c1 * z,
            -c1 * x,
            c2a * x * y,
            -c2a * y * z,
            c2b * (3.0 * z * z - 1.0),
            -c2a * x * z,
            c2c * (x * x - y * y),
            -c3a * y * (3.0 * x * x - y * y),
            c3b * x * y * z,
            -c3c * y * (5.0 * z * z - 1.0),
            c3d * z * (5.0 * z * z - 3.0),
            -c3c * x * (5.0 * z * z - 1.0),
            c3e * z * (x * x - y * y),
            -c3a * x * (x * x - 3.0 * y * y),
        ];
        let e: Vec<(usize, f64)> = want.iter().copied().enumerate().collect();
        check([x, y, z], &e);
        // The quoted rounded constants.
        for (v, q) in [
            (c0, 0.2820947918),
            (c1, 0.4886025119),
            (c2a, 1.092548431),
            (c2b, 0.3153915653),
            (c2c, 0.5462742153),
            (c3a, 0.5900435899),
            (c3b, 2.890611443),
            (c3c, 0.4570457995),
            (c3d, 0.3731763326),
            (c3e, 1.445305721),
        ] {
            assert!((v - q).abs() < 1e-9);
        }
    }

    #[test]
    fn higher_bands_db() {
        let rows: [(usize, [f64; 5]); 4] = [
            (4, [-0.0766329472, -0.4301013494, -0.1926808176, -0.2150506747, -0.02235127627]),
            (5, [0.03401106316, -0.1642890433, -0.371726573, -0.08214452164, -0.0366961471]),
            (6, [0.01095484717, 0.1617920839, -0.4010373398, 0.08089604195, 0.02912993451]),
            (7, [-0.01914767451, 0.4252852218, -0.2693765472, 0.2126426109, -0.001997419283]),
        ];
        let mut e = Vec::new();
        for (l, v) in rows {
            let li = l as isize;
            for (m, val) in [-li, -1, 0, 1, li].into_iter().zip(v) {
                e.push((sh_index(l, m), val));
            }
        }
        check(d_b(), &e);
    }

    /// Gram matrix over the exact product quadrature: Gauss–Legendre in z × uniform φ.
    #[test]
    fn gram_is_identity_order8() {
        // Products of two order-8 harmonics have degree ≤ 14: 8 Gauss nodes and 15 φ nodes suffice;
        // use the §3 triple-product counts (11 × 22), which are also exact here.
        let nz = 11;
        let nphi = 22;
        let (mut zs, mut ws) = (vec![0.0; nz], vec![0.0; nz]);
        gauss_legendre(&mut zs, &mut ws);
        let mut g = vec![0.0f64; MAX_COEFFS * MAX_COEFFS];
        for (&z, &wz) in zs.iter().zip(&ws) {
            let r = libm::sqrt(1.0 - z * z);
            for k in 0..nphi {
                let phi = 2.0 * PI * (k as f64 + 0.3) / nphi as f64;
                let y = eval_sh8([r * libm::cos(phi), r * libm::sin(phi), z]);
                let w = wz * 2.0 * PI / nphi as f64;
                for i in 0..MAX_COEFFS {
                    for j in 0..MAX_COEFFS {
                        g[i * MAX_COEFFS + j] += w * y[i] * y[j];
                    }
                }
            }
        }
        for i in 0..MAX_COEFFS {
            for j in 0..MAX_COEFFS {
                let e = if i == j { 1.0 } else { 0.0 };
                assert!((g[i * MAX_COEFFS + j] - e).abs() < 1e-12, "G[{i}][{j}] = {}", g[i * MAX_COEFFS + j]);
            }
        }
    }

    /// Legendre P_l by the three-term recurrence (independent of the crate's implementation).
    fn p_l(l: usize, t: f64) -> f64 {
        let (mut a, mut b) = (1.0, t);
        if l == 0 {
            return a;
        }
        for k in 1..l {
            let c = ((2 * k + 1) as f64 * t * b - k as f64 * a) / (k + 1) as f64;
            a = b;
            b = c;
        }
        b
    }

    #[test]
    fn addition_theorem() {
        let dirs =
            [d_b(), D_C, normalize([0.1, -0.9, 0.05]), normalize([-3.0, 0.2, 1.0]), [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]];
        for a in dirs {
            for b in dirs {
                let (ya, yb) = (eval_sh8(a), eval_sh8(b));
                let t = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
                for l in 0..MAX_ORDER {
                    let mut s = 0.0;
                    for m in -(l as isize)..=(l as isize) {
                        s += ya[sh_index(l, m)] * yb[sh_index(l, m)];
                    }
                    let e = (2 * l + 1) as f64 / (4.0 * PI) * p_l(l, t);
                    assert!((s - e).abs() < 1e-13, "l={l}: {s} vs {e}");
                }
            }
        }
    }

    #[test]
    fn errors_not_panics() {
        let mut out = [0.0f64; 4];
        assert_eq!(
            eval_sh_f64(3, [0.0, 0.0, 1.0], &mut out),
            Err(ShError::BufferTooShort { buffer: "out", expected: 9, actual: 4 })
        );
        assert_eq!(eval_sh_f64(9, [0.0, 0.0, 1.0], &mut [0.0; 81]), Err(ShError::OrderOutOfRange { order: 9, max: 8 }));
        // order 0 writes nothing, extra entries untouched.
        let mut out = [7.0f32; 5];
        eval_sh(0, [0.0, 0.0, 1.0], &mut out).unwrap();
        assert_eq!(out, [7.0; 5]);
        eval_sh(2, [0.0, 0.0, 1.0], &mut out).unwrap();
        assert_eq!(out[4], 7.0);
    }

    #[test]
    fn index_and_count() {
        assert_eq!(sh_index(0, 0), 0);
        assert_eq!(sh_index(1, -1), 1);
        assert_eq!(sh_index(3, 3), 15);
        assert_eq!(sh_index(7, 7), 63);
        assert_eq!(coeff_count(8), MAX_COEFFS);
    }
}
