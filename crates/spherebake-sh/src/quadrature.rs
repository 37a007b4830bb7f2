//! Gauss–Legendre nodes on [−1, 1] (used for exact sphere quadrature: Gauss–Legendre in z × uniform φ).

/// Fills `nodes` / `weights` (same length n) with the n-point Gauss–Legendre rule on [−1, 1], nodes descending.
///
/// Exact for polynomials of degree ≤ 2n − 1. Newton iteration on P_n from the Tricomi initial guess.
pub fn gauss_legendre(nodes: &mut [f64], weights: &mut [f64]) {
    let n = nodes.len().min(weights.len());
    let nf = n as f64;
    for k in 0..n {
        let mut x = libm::cos(core::f64::consts::PI * (k as f64 + 0.75) / (nf + 0.5));
        let mut dp = 1.0;
        for _ in 0..100 {
            let (p, d) = legendre_and_derivative(n, x);
            dp = d;
            let dx = p / d;
            x -= dx;
            if libm::fabs(dx) < 1e-16 {
                break;
            }
        }
        let (_, d) = legendre_and_derivative(n, x);
        if d.is_finite() {
            dp = d;
        }
        nodes[k] = x;
        weights[k] = 2.0 / ((1.0 - x * x) * dp * dp);
    }
}

/// P_n(x) and P_n'(x) by the three-term recurrence (|x| < 1).
fn legendre_and_derivative(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 1..n {
        let p2 = ((2 * k + 1) as f64 * x * p1 - k as f64 * p0) / (k + 1) as f64;
        p0 = p1;
        p1 = p2;
    }
    let d = n as f64 * (x * p1 - p0) / (x * x - 1.0);
    (p1, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrates_monomials_exactly() {
        for n in 1..16 {
            let mut x = [0.0; 16];
            let mut w = [0.0; 16];
            gauss_legendre(&mut x[..n], &mut w[..n]);
            for deg in 0..(2 * n) {
                let s: f64 = (0..n).map(|k| w[k] * libm::pow(x[k], deg as f64)).sum();
                let exact = if deg % 2 == 1 { 0.0 } else { 2.0 / (deg + 1) as f64 };
                assert!((s - exact).abs() < 1e-14, "n={n} deg={deg}: {s}");
            }
        }
    }
}
