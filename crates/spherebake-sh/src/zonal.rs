//! Zonal harmonics (math reference §2): caps, clamped cosine, rotation to an axis, Ren's window.

use crate::basis::{eval_unchecked, sh_index, Scalar, MAX_COEFFS, MAX_ORDER};
use crate::{check_len, check_order, coeff_count, ShError};
use core::f64::consts::PI;

/// Legendre polynomial P_l(x) (no Condon–Shortley factor; P_l(1) = 1) by the three-term recurrence.
pub fn legendre_p(l: usize, x: f64) -> f64 {
    let (mut p0, mut p1) = (1.0, x);
    if l == 0 {
        return p0;
    }
    for k in 1..l {
        let p2 = ((2 * k + 1) as f64 * x * p1 - k as f64 * p0) / (k + 1) as f64;
        p0 = p1;
        p1 = p2;
    }
    p1
}

fn zh_rotate_impl<T: Scalar>(g: &[T], axis: [T; 3], out: &mut [T]) -> Result<(), ShError> {
    let order = g.len();
    check_order(order, MAX_ORDER)?;
    check_len("out", coeff_count(order), out.len())?;
    let mut y = [T::ZERO; MAX_COEFFS];
    eval_unchecked(order, axis[0], axis[1], axis[2], &mut y);
    for (l, &gl) in g.iter().enumerate() {
        let s = T::from_f64(libm::sqrt(4.0 * PI / (2 * l + 1) as f64)) * gl;
        for m in -(l as isize)..=(l as isize) {
            let i = sh_index(l, m);
            out[i] = s * y[i];
        }
    }
    Ok(())
}

/// Rotates zonal coefficients `g` (g_l, l = 0..order−1, order = `g.len()`) to the unit `axis`: f_lm = √(4π/(2l+1)) g_l y_lm(axis).
///
/// f64. Writes `out[0..order²]`. `axis` must be unit length. Errors: `g.len() > MAX_ORDER`, `out` too short.
pub fn zh_rotate(g: &[f64], axis: [f64; 3], out: &mut [f64]) -> Result<(), ShError> {
    zh_rotate_impl(g, axis, out)
}

/// Rotates zonal coefficients `g` to the unit `axis` in f32: f_lm = √(4π/(2l+1)) g_l y_lm(axis) (see [`zh_rotate`]).
///
/// Allocation-free. Errors: `g.len() > MAX_ORDER`, `out.len() < g.len()²`.
pub fn zh_rotate_f32(g: &[f32], axis: [f32; 3], out: &mut [f32]) -> Result<(), ShError> {
    zh_rotate_impl(g, axis, out)
}

/// Zonal coefficients g_l(θ) of the cap χ_θ(s) = 1 if s·z ≥ cos θ (angular radius `theta_rad` in radians) for l < `order`.
///
/// g_0 = √π (1 − cos θ), g_l = √(π/(2l+1)) (P_{l−1}(cos θ) − P_{l+1}(cos θ)); solid angle = √(4π) g_0.
/// Writes `out[0..order]`. Errors: `out` too short.
pub fn cap_zh(theta_rad: f64, order: usize, out: &mut [f64]) -> Result<(), ShError> {
    check_len("out", order, out.len())?;
    let c = libm::cos(theta_rad);
    for (l, o) in out.iter_mut().enumerate().take(order) {
        *o = if l == 0 {
            libm::sqrt(PI) * (1.0 - c)
        } else {
            libm::sqrt(PI / (2 * l + 1) as f64) * (legendre_p(l - 1, c) - legendre_p(l + 1, c))
        };
    }
    Ok(())
}

/// Zonal coefficients of Ren's blocker visibility v = 1 − χ_θ (0 inside the cap of angular radius `theta_rad`) for l < `order`.
///
/// v_0 = √π (1 + cos θ), v_l = −g_l(θ) for l ≥ 1 (see [`cap_zh`]). Writes `out[0..order]`. Errors: `out` too short.
pub fn cap_visibility_zh(theta_rad: f64, order: usize, out: &mut [f64]) -> Result<(), ShError> {
    cap_zh(theta_rad, order, out)?;
    for (l, o) in out.iter_mut().enumerate().take(order) {
        *o = if l == 0 { libm::sqrt(PI) * (1.0 + libm::cos(theta_rad)) } else { -*o };
    }
    Ok(())
}

/// I_l = ∫_0^1 t P_l(t) dt for l < `order` (1/2, 1/3, then 0 for odd l ≥ 3 and I_{l+2} = −(l−1)/(l+4) I_l for even l ≥ 2).
fn clamped_cosine_moments(order: usize, out: &mut [f64]) {
    let mut even = 1.0 / 8.0; // I_2
    for (l, o) in out.iter_mut().enumerate().take(order) {
        *o = match l {
            0 => 0.5,
            1 => 1.0 / 3.0,
            _ if l % 2 == 1 => 0.0,
            _ => {
                let v = even;
                even *= -((l - 1) as f64) / (l + 4) as f64;
                v
            }
        };
    }
}

/// Zonal coefficients g_l = 2π K_l0 I_l of the clamped cosine max(0, s·z) for l < `order` (0.8862269255, 1.023326708, …).
///
/// Writes `out[0..order]`. Errors: `out` too short.
pub fn clamped_cosine_zh(order: usize, out: &mut [f64]) -> Result<(), ShError> {
    check_len("out", order, out.len())?;
    clamped_cosine_moments(order, out);
    for (l, o) in out.iter_mut().enumerate().take(order) {
        *o *= 2.0 * PI * libm::sqrt((2 * l + 1) as f64 / (4.0 * PI));
    }
    Ok(())
}

/// Ramamoorthi–Hanrahan convolution factors A_l = √(4π/(2l+1)) g_l = 2π I_l of the clamped cosine for l < `order` (π, 2π/3, π/4, 0, −π/24, …).
///
/// Irradiance E(n) = Σ A_l L_lm y_lm(n) for radiance coefficients L. Writes `out[0..order]`. Errors: `out` too short.
pub fn clamped_cosine_convolution(order: usize, out: &mut [f64]) -> Result<(), ShError> {
    check_len("out", order, out.len())?;
    clamped_cosine_moments(order, out);
    for o in out.iter_mut().take(order) {
        *o *= 2.0 * PI;
    }
    Ok(())
}

/// Ren 2006 §7 ringing window a_l = cos(π l / (2h)) with h = 2·`order`, for l < `order` (multiply band l by a_l).
///
/// Writes `out[0..order]`. Errors: `out` too short.
pub fn ren_window(order: usize, out: &mut [f64]) -> Result<(), ShError> {
    check_len("out", order, out.len())?;
    let h = 2.0 * order as f64;
    for (l, o) in out.iter_mut().enumerate().take(order) {
        *o = libm::cos(PI * l as f64 / (2.0 * h));
    }
    Ok(())
}

#[cfg(test)]
// The math reference's quoted 10-digit values are asserted as given, even where they round π.
#[allow(clippy::approx_constant)]
mod tests {
    use super::*;
    use crate::basis::eval_sh8;
    use crate::quadrature::gauss_legendre;

    fn deg(d: f64) -> f64 {
        d * PI / 180.0
    }

    fn assert_close(got: &[f64], want: &[f64], tol: f64, what: &str) {
        assert_eq!(got.len(), want.len());
        for (i, (g, w)) in got.iter().zip(want).enumerate() {
            assert!((g - w).abs() < tol + 1e-9 * w.abs(), "{what}[{i}]: {g} vs {w}");
        }
    }

    #[test]
    fn cap_table() {
        let t30 = [
            0.237463789,
            0.3837475155,
            0.4290427654,
            0.4030015086,
            0.3237869662,
            0.2124090646,
            0.09188110487,
            -0.01613100241,
        ];
        let t60 = [
            0.8862269255,
            1.151242546,
            0.7431238683,
            0.1099095023,
            -0.3115641535,
            -0.3272247752,
            -0.06552936431,
            0.1816308973,
        ];
        let t90 = [1.772453851, 1.534990062, 0.0, -0.5861840125, 0.0, 0.3674102739, 0.0, -0.2681517284];
        let mut g = [0.0; 8];
        for (theta, table, solid, vis0) in [
            (30.0, t30, 0.8417872145, 3.307443913),
            (60.0, t60, 3.141592654, 2.658680776),
            (90.0, t90, 6.283185307, 1.772453851),
        ] {
            cap_zh(deg(theta), 8, &mut g).unwrap();
            assert_close(&g, &table, 1e-9, "cap");
            let sa = libm::sqrt(4.0 * PI) * g[0];
            assert!((sa - solid).abs() < 1e-9);
            assert!((sa - 2.0 * PI * (1.0 - libm::cos(deg(theta)))).abs() < 1e-13);
            let mut v = [0.0; 8];
            cap_visibility_zh(deg(theta), 8, &mut v).unwrap();
            assert!((v[0] - vis0).abs() < 1e-9);
            for l in 1..8 {
                assert_eq!(v[l], -g[l]);
            }
        }
    }

    /// Independent route: g_l = 2π K_l0 ∫_{cos θ}^1 P_l(t) dt by Gauss–Legendre on [cos θ, 1] (exact for P_l).
    #[test]
    fn cap_matches_quadrature() {
        let mut x = [0.0; 8];
        let mut w = [0.0; 8];
        gauss_legendre(&mut x, &mut w);
        for theta in [0.1, 0.7, 1.3, 2.0, 3.0] {
            let c = libm::cos(theta);
            let mut g = [0.0; 8];
            cap_zh(theta, 8, &mut g).unwrap();
            for (l, &gl) in g.iter().enumerate() {
                let half = (1.0 - c) / 2.0;
                let mut integ = 0.0;
                for k in 0..8 {
                    let t = c + half * (x[k] + 1.0);
                    integ += half * w[k] * legendre_p(l, t);
                }
                let k0 = libm::sqrt((2 * l + 1) as f64 / (4.0 * PI));
                assert!((gl - 2.0 * PI * k0 * integ).abs() < 1e-13);
            }
        }
    }

    #[test]
    fn clamped_cosine_tables() {
        let g_want = [0.8862269255, 1.023326708, 0.4954159122, 0.0, -0.1107783657, 0.0, 0.04992713471, 0.0];
        let a_want = [3.141592654, 2.094395102, 0.7853981634, 0.0, -0.1308996939, 0.0, 0.04908738521, 0.0];
        let mut g = [0.0; 8];
        let mut a = [0.0; 8];
        clamped_cosine_zh(8, &mut g).unwrap();
        clamped_cosine_convolution(8, &mut a).unwrap();
        assert_close(&g, &g_want, 1e-9, "g");
        assert_close(&a, &a_want, 1e-9, "A");
        // Closed forms π, 2π/3, π/4, 0, −π/24, 0, π/64, 0.
        let closed = [PI, 2.0 * PI / 3.0, PI / 4.0, 0.0, -PI / 24.0, 0.0, PI / 64.0, 0.0];
        assert_close(&a, &closed, 1e-15, "A closed");
        // Factorial formula for I_l, even l ≥ 2.
        let fact = |n: usize| (1..=n).fold(1.0, |p, k| p * k as f64);
        for l in (2..8).step_by(2) {
            let sign = if (l / 2 - 1) % 2 == 0 { 1.0 } else { -1.0 };
            let il = sign * fact(l - 2) / (libm::pow(2.0, l as f64) * fact(l / 2 - 1) * fact(l / 2 + 1));
            assert!((a[l] - 2.0 * PI * il).abs() < 1e-15);
        }
    }

    #[test]
    fn rotation_check_cap60_dc() {
        let want = [
            0.8862269255,
            -0.6907455279,
            -0.7367952297,
            0.5525964223,
            -0.3706929493,
            0.4942572657,
            0.08501337053,
            -0.3954058126,
            -0.08340591359,
            -0.0172669976,
            0.07846090853,
            -0.04232172962,
            0.03348283079,
            0.0338573837,
            0.01765370442,
            -0.03543488203,
        ];
        let mut g = [0.0; 4];
        cap_zh(deg(60.0), 4, &mut g).unwrap();
        let mut f = [0.0; 16];
        zh_rotate(&g, [-0.48, 0.6, -0.64], &mut f).unwrap();
        assert_close(&f, &want, 1e-9, "rotated cap");
        let g32: [f32; 4] = [g[0] as f32, g[1] as f32, g[2] as f32, g[3] as f32];
        let mut f32o = [0.0f32; 16];
        zh_rotate_f32(&g32, [-0.48, 0.6, -0.64], &mut f32o).unwrap();
        for i in 0..16 {
            assert!((f32o[i] as f64 - want[i]).abs() < 2e-6);
        }
        // The rotation about +z reproduces the zonal input on m = 0.
        zh_rotate(&g, [0.0, 0.0, 1.0], &mut f).unwrap();
        for l in 0..4 {
            assert!((f[sh_index(l, 0)] - g[l]).abs() < 1e-15);
        }
    }

    /// Independent route for the rotation rule: quadrature of the world-frame y_i over a cap about an arbitrary axis.
    #[test]
    fn rotation_matches_cap_quadrature() {
        let axis = {
            let v = [0.3f64, -0.5, 0.8];
            let n = libm::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
            [v[0] / n, v[1] / n, v[2] / n]
        };
        // Orthonormal frame (e1, e2, axis).
        let e1 = {
            let v = [axis[1], -axis[0], 0.0];
            let n = libm::sqrt(v[0] * v[0] + v[1] * v[1]);
            [v[0] / n, v[1] / n, 0.0]
        };
        let e2 =
            [axis[1] * e1[2] - axis[2] * e1[1], axis[2] * e1[0] - axis[0] * e1[2], axis[0] * e1[1] - axis[1] * e1[0]];
        let theta = 1.1;
        let c = libm::cos(theta);
        let (mut x, mut w) = ([0.0; 10], [0.0; 10]);
        gauss_legendre(&mut x, &mut w);
        let nphi = 20;
        let mut direct = [0.0; MAX_COEFFS];
        for k in 0..10 {
            let half = (1.0 - c) / 2.0;
            let t = c + half * (x[k] + 1.0);
            let r = libm::sqrt(1.0 - t * t);
            for j in 0..nphi {
                let phi = 2.0 * PI * j as f64 / nphi as f64;
                let (a, b) = (r * libm::cos(phi), r * libm::sin(phi));
                let s = [
                    a * e1[0] + b * e2[0] + t * axis[0],
                    a * e1[1] + b * e2[1] + t * axis[1],
                    a * e1[2] + b * e2[2] + t * axis[2],
                ];
                let y = eval_sh8(s);
                let wt = half * w[k] * 2.0 * PI / nphi as f64;
                for i in 0..MAX_COEFFS {
                    direct[i] += wt * y[i];
                }
            }
        }
        let mut g = [0.0; 8];
        cap_zh(theta, 8, &mut g).unwrap();
        let mut f = [0.0; MAX_COEFFS];
        zh_rotate(&g, axis, &mut f).unwrap();
        for i in 0..MAX_COEFFS {
            assert!((f[i] - direct[i]).abs() < 1e-13, "{i}: {} vs {}", f[i], direct[i]);
        }
    }

    #[test]
    fn window_n4() {
        let mut a = [0.0; 4];
        ren_window(4, &mut a).unwrap();
        assert_close(&a, &[1.0, 0.9807852804, 0.9238795325, 0.8314696123], 1e-9, "window");
    }

    #[test]
    fn errors() {
        let mut o = [0.0; 2];
        assert!(matches!(cap_zh(0.5, 3, &mut o), Err(ShError::BufferTooShort { expected: 3, actual: 2, .. })));
        assert!(matches!(
            zh_rotate(&[0.0; 9], [0.0, 0.0, 1.0], &mut [0.0; 81]),
            Err(ShError::OrderOutOfRange { order: 9, .. })
        ));
    }
}
