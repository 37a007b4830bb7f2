//! Offline generator of the two indirect-light tables (Guerrero et al. 2008 §5.2 and §6.1), shared by
//! `examples/gen_light_tables.rs` (writes `src/light_tables_data.rs`) and `tests/light_tables.rs` (regenerates and
//! compares). Deterministic: f64 sums in a fixed order, maths through `libm` (the same bits on every platform).
//!
//! 1. **Voronoi-cell basis sums** (eq. 10): Y_j,i = ∫_{cell j} y_i(ω) dω for the 92 geodesic directions ω_j and the
//!    64 coefficients of order 8, where cell j is the set of directions whose nearest geodesic direction is ω_j
//!    (largest dot product, ties to the lowest index). Estimated as (4π/N) Σ_{k in cell j} y_i(ω̂_k) over a dense,
//!    evenly distributed set of N = [`VORONOI_POINTS`] directions ω̂_k: the spherical Fibonacci lattice
//!    z_k = 1 − (2k + 1)/N, φ_k = k·π(3 − √5) (a low-discrepancy set; the paper uses jittered stratification, whose
//!    error is larger for the same N).
//! 2. **Average-radiance weights** (eq. 15–18, see `src/light.rs` for the derivation): for a sphere of angular
//!    radius θ seen from p, W_l(θ) = (1 / (1 − cos θ)) ∫_0^θ P_l(cos α(ψ)) sin ψ dψ, where ψ is the angle of a ray
//!    from p to the sphere's centre direction and α(ψ) = asin(sin ψ / sin θ) − ψ the angle at the sphere's centre
//!    between its direction to p and the point the ray hits. Substituting ψ = θ(1 − s²) removes the square-root
//!    endpoint singularity at ψ = θ; composite Gauss–Legendre in s ([`RADIANCE_PANELS`] panels ×
//!    [`RADIANCE_NODES`] nodes). Rows θ_k = k·π/510, k = 0..255, like the log-visibility table; row 0 is the
//!    far-field limit A_l/π (the normalised clamped cosine), row 255 the contact limit P_l(1) = 1.

#![allow(dead_code)] // each includer uses a part
#![allow(clippy::needless_range_loop)] // index loops mirror the formulas

use spherebake_sh::{eval_sh_f64, gauss_legendre, geodesic_directions_f64, legendre_p, GEODESIC_DIRECTION_COUNT};

/// Directions of the dense Fibonacci set behind the Voronoi table.
pub const VORONOI_POINTS: usize = 1 << 22;
/// Order of the Voronoi table (all 64 coefficients of order 8).
pub const VORONOI_ORDER: usize = 8;
/// Rows of the radiance-weight table (θ uniform over [0, π/2]).
pub const RADIANCE_ROWS: usize = 256;
/// Gauss–Legendre panels in s ∈ [0, 1].
pub const RADIANCE_PANELS: usize = 64;
/// Nodes per panel.
pub const RADIANCE_NODES: usize = 8;

/// Direction k of the N-point spherical Fibonacci lattice.
pub fn fibonacci_direction(k: usize, n: usize) -> [f64; 3] {
    let golden = core::f64::consts::PI * (3.0 - libm::sqrt(5.0));
    let z = 1.0 - (2.0 * k as f64 + 1.0) / n as f64;
    let r = libm::sqrt((1.0 - z * z).max(0.0));
    let phi = golden * k as f64;
    [r * libm::cos(phi), r * libm::sin(phi), z]
}

/// Index of the geodesic direction nearest to `d` (largest dot product, ties to the lowest index).
pub fn nearest_direction(dirs: &[[f64; 3]; GEODESIC_DIRECTION_COUNT], d: [f64; 3]) -> usize {
    let mut best = (f64::NEG_INFINITY, 0);
    for (j, g) in dirs.iter().enumerate() {
        let dot = g[0] * d[0] + g[1] * d[1] + g[2] * d[2];
        if dot > best.0 {
            best = (dot, j);
        }
    }
    best.1
}

/// The Voronoi-cell basis sums Y_j,i (92 rows × 64 coefficients), estimated with `n` Fibonacci directions.
pub fn voronoi_basis_table(n: usize) -> Vec<[f64; 64]> {
    let dirs = geodesic_directions_f64();
    let mut sums = vec![[0.0f64; 64]; GEODESIC_DIRECTION_COUNT];
    let mut y = [0.0f64; 64];
    for k in 0..n {
        let d = fibonacci_direction(k, n);
        let j = nearest_direction(&dirs, d);
        eval_sh_f64(VORONOI_ORDER, d, &mut y).expect("order 8 fits");
        for (s, v) in sums[j].iter_mut().zip(&y) {
            *s += v;
        }
    }
    let w = 4.0 * core::f64::consts::PI / n as f64;
    for row in &mut sums {
        for v in row.iter_mut() {
            *v *= w;
        }
    }
    sums
}

/// P_l'(x) for l < 8 by P'_{l+1} = P'_{l−1} + (2l + 1) P_l.
fn legendre_derivatives(x: f64) -> [f64; 8] {
    let mut d = [0.0; 8];
    for l in 1..8 {
        d[l] = (2 * l - 1) as f64 * legendre_p(l - 1, x) + if l >= 2 { d[l - 2] } else { 0.0 };
    }
    d
}

/// The three weight sets at angular radius `theta` (radians, 0..=π/2), l < 8 (see `src/light.rs`):
/// W_l = ∫ P_l(cos α) sin ψ dψ / (1 − cos θ) (uniform average over p's cone, eq. 15),
/// C_l = ∫ P_l(cos α) cos ψ sin ψ dψ / (sin²θ / 2) (cosine-weighted about the cone's axis) and
/// D_l = ∫ sin²ψ Q_l(α) dψ / (sin²θ / 2) with Q_l(α) = sin α P_l'(cos α) / (l(l + 1)) (the perpendicular part of the
/// cosine), all over ψ ∈ [0, θ] with α(ψ) = asin(sin ψ / sin θ) − ψ.
pub fn light_weights(theta: f64) -> [[f64; 8]; 3] {
    if theta >= core::f64::consts::FRAC_PI_2 {
        // Contact: every ray from p hits the sphere where it touches p (α = 0).
        return [[1.0; 8], [1.0; 8], [0.0; 8]];
    }
    // The far-field row is the limit θ → 0, evaluated at a tiny angle (every integrand scales smoothly).
    let theta = theta.max(1e-7);
    let mut nodes = [0.0; RADIANCE_NODES];
    let mut weights = [0.0; RADIANCE_NODES];
    gauss_legendre(&mut nodes, &mut weights);
    let sin_t = libm::sin(theta);
    let one_minus_cos = 2.0 * libm::sin(0.5 * theta) * libm::sin(0.5 * theta);
    let half_sin2 = 0.5 * sin_t * sin_t;
    let h = 1.0 / RADIANCE_PANELS as f64;
    let mut out = [[0.0f64; 8]; 3];
    for panel in 0..RADIANCE_PANELS {
        let a = panel as f64 * h;
        for (x, w) in nodes.iter().zip(&weights) {
            let s = a + 0.5 * h * (x + 1.0);
            let psi = theta * (1.0 - s * s);
            let ratio = (libm::sin(psi) / sin_t).min(1.0);
            let alpha = libm::asin(ratio) - psi;
            let (ca, sa) = (libm::cos(alpha), libm::sin(alpha));
            let (cp, sp) = (libm::cos(psi), libm::sin(psi));
            // dψ = 2θ s ds (orientation folded into the limits).
            let jac = 0.5 * h * w * 2.0 * theta * s;
            let dp = legendre_derivatives(ca);
            for l in 0..8 {
                let pl = legendre_p(l, ca);
                out[0][l] += jac * sp * pl;
                out[1][l] += jac * cp * sp * pl;
                if l >= 1 {
                    out[2][l] += jac * sp * sp * sa * dp[l] / (l * (l + 1)) as f64;
                }
            }
        }
    }
    for l in 0..8 {
        out[0][l] /= one_minus_cos;
        out[1][l] /= half_sin2;
        out[2][l] /= half_sin2;
    }
    out
}

/// The three weight tables: [`RADIANCE_ROWS`] rows θ_k = k·π/510 each.
pub fn light_weight_tables() -> [Vec<[f64; 8]>; 3] {
    let step = core::f64::consts::FRAC_PI_2 / (RADIANCE_ROWS - 1) as f64;
    let rows: Vec<[[f64; 8]; 3]> = (0..RADIANCE_ROWS).map(|k| light_weights(k as f64 * step)).collect();
    [0, 1, 2].map(|t| rows.iter().map(|r| r[t]).collect())
}

fn push_row(out: &mut String, row: &[f64]) {
    out.push_str("    [");
    for (i, v) in row.iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        let f = *v as f32;
        // `{:?}` prints the shortest representation that round-trips (always with a decimal point).
        out.push_str(&format!("{f:?}"));
    }
    out.push_str("],\n");
}

/// The text of `src/light_tables_data.rs`.
pub fn render_light_tables_rs() -> String {
    let mut out = String::new();
    out.push_str("// @generated by `cargo run -p spherebake-sh --release --example gen_light_tables`; do not edit.\n");
    out.push_str("// Regenerated and compared by `tests/light_tables.rs`. f32 data computed in f64 by `offline/light_tables.rs`.\n\n");
    out.push_str(&format!(
        "/// Voronoi-cell basis sums Y_j (Guerrero 2008 eq. 10): row j = ∫ over the cell of geodesic direction j of y_i,\n/// i < 64 (order 8), from {VORONOI_POINTS} Fibonacci directions.\n"
    ));
    out.push_str("pub(crate) static VORONOI_BASIS: [[f32; 64]; 92] = [\n");
    for row in voronoi_basis_table(VORONOI_POINTS) {
        push_row(&mut out, &row);
    }
    out.push_str("];\n");
    let [w, c, d] = light_weight_tables();
    for (name, doc, rows) in [
        ("RADIANCE_WEIGHTS", "Uniform average-radiance weights W_l(θ) (eq. 15)", w),
        ("COSINE_WEIGHTS", "Cosine-weighted radiance weights C_l(θ), axial part", c),
        ("DIPOLE_WEIGHTS", "Cosine-weighted radiance weights D_l(θ), perpendicular part", d),
    ] {
        out.push_str(&format!("\n/// {doc}, l < 8, at θ_k = k·π/510 rad (k = 0..255); see `light.rs`.\n"));
        out.push_str(&format!("pub(crate) static {name}: [[f32; 8]; 256] = [\n"));
        for row in rows {
            push_row(&mut out, &row);
        }
        out.push_str("];\n");
    }
    out
}
