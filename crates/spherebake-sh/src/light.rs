//! Tables of the spherical lights (Guerrero, Jeschke, Wimmer 2008): the Voronoi-cell basis sums of the 92 geodesic
//! directions (§5.2, eq. 9–10) and the average-radiance weights of a sphere seen from a point (§6.1, eq. 15–18).
//! Both are generated offline (`examples/gen_light_tables.rs` → `src/light_tables_data.rs`, f32 data) and
//! regenerated and compared by `tests/light_tables.rs`.
//!
//! # Voronoi-cell basis sums (eq. 10)
//!
//! A sphere light's intensity distribution is the piecewise-constant function L(ω) = L_pj on the Voronoi cell of
//! geodesic direction ω_j (nearest direction by angle, ties to the lowest index) and 0 on cells without a sample
//! (seed rule 2). Its SH projection is L_i = Σ_j L_pj · Y_j,i with Y_j,i = ∫_{cell j} y_i(ω) dω, the paper's
//! (4π/N) Σ_k y_i(ω̂_k) for a dense set of N directions. [`voronoi_cell_basis`] returns the row of direction j.
//! The rows sum to the projection of **1**: Σ_j Y_j = (√(4π), 0, …) up to the lattice's quadrature error.
//!
//! # Average radiance (eq. 15–18)
//!
//! Eq. 15 defines the average radiance of sphere light S (centre c, radius r) at p as the mean of its radiance over
//! the solid angle it covers *at p*: L̃ = (1/Ω) ∫_{cone} L(ω_S(ψ)) dω_p, Ω = 2π(1 − cos θ), sin θ = r/|p − c|. The
//! ray from p at angle ψ to the direction of c hits S at the point whose direction from c makes the angle
//! α(ψ) = γ − ψ with the direction from c to p, where sin γ = sin ψ / sin θ (law of sines in the triangle p, c, hit
//! point; γ ∈ [0, π/2] is the angle between the surface normal there and the ray back to p). The weight is zonal
//! about a = (p − c)/|p − c|, so L̃ = Σ_l W_l(θ) Σ_m L_lm y_lm(a) with
//! W_l(θ) = (1/(1 − cos θ)) ∫_0^θ P_l(cos α(ψ)) sin ψ dψ ([`radiance_weights_f32`]).
//!
//! **Reading taken.** The paper's eq. 16 writes the average as ∫_S L(ω_S) cos γ dω_S / ∫_S cos γ dω_S over the
//! sphere's own directions, with cos γ from eq. 17: that is eq. 15 without the Jacobian r²/|p − x|² between the
//! sphere's surface and p's solid angle. The two agree in the far field (both tend to the normalised clamped cosine
//! A_l/π: W = 1, 2/3, 1/4, 0, −1/24, …) but differ near the sphere (eq. 16's weights vanish at contact, θ → π/2,
//! where the true average concentrates on the touching point: W_l → P_l(1) = 1). We tabulate eq. 15 exactly, the
//! quantity eq. 14's decomposition needs; `tests/light_tables.rs` checks it against rays cast from p and eq. 16's
//! form in the far field.
//!
//! # Cosine-weighted radiance (eq. 13 without eq. 15's approximation)
//!
//! Eq. 14–15 take the receiver's cosine as constant over the sphere. For a sphere near the receiver's horizon —
//! the usual case of a ground point lit by an object standing on it — the cosine runs from 0 to its maximum across
//! the sphere, and where the sphere is brighter (its upper, sky-lit half) the cosine is larger: the constant-cosine
//! product underestimates (by 18 % for a unit sphere on the ground seen from 3 radii away). We keep the cosine
//! inside the average instead. With s the unit direction from p to the centre and n = (n·s) s + n_⊥, the
//! unoccluded cosine-weighted integral is
//! Φ = (1/π) ∫_cap L(ω_S(ω)) (n·ω) dω = sin²θ [ (n·s) Σ_l C_l(θ) L_l(a) + Σ_l D_l(θ) (n_⊥ · ∇L_l(a)) ],
//! where a = −s, L_l(a) = Σ_m L_lm y_lm(a) is band l of the light at a, ∇ the tangential gradient there, and
//! C_l(θ) = ∫ P_l(cos α) cos ψ sin ψ dψ / (sin²θ/2), D_l(θ) = ∫ sin²ψ Q_l(α) dψ / (sin²θ/2) over ψ ∈ [0, θ] with
//! Q_l(α) = sin α P_l'(cos α) / (l(l + 1)) (the circle average of a band-l function weighted by the azimuth's
//! cosine is Q_l(α) times its gradient at the pole; the ray at azimuth φ hits the sphere at the same azimuth about
//! a). The whole cap must lie in front of the receiver's tangent plane, which the self-shadowing rules ensure.
//! [`cosine_weighted_radiance_rgb_f32`] evaluates Φ; the gradient by a central difference of the basis polynomials
//! (exact to O(ε²) on the sphere, since the radial offset of the two points cancels).

use crate::basis::eval_unchecked as eval_poly;
use crate::basis::{eval_unchecked, MAX_COEFFS, MAX_ORDER};
use crate::light_tables_data::{COSINE_WEIGHTS, DIPOLE_WEIGHTS, RADIANCE_WEIGHTS, VORONOI_BASIS};
use crate::{check_len, check_order, coeff_count, ShError, GEODESIC_DIRECTION_COUNT};

/// Rows of the radiance-weight table: θ_k = k · [`RADIANCE_WEIGHT_STEP`], k = 0..255, covering [0, π/2].
pub const RADIANCE_WEIGHT_SAMPLES: usize = 256;

/// Spacing of the radiance-weight table in θ: π/510 rad.
pub const RADIANCE_WEIGHT_STEP: f64 = core::f64::consts::FRAC_PI_2 / (RADIANCE_WEIGHT_SAMPLES - 1) as f64;

/// The Voronoi-cell basis sums Y_j,i = ∫_{cell j} y_i(ω) dω of geodesic direction `direction` (0..92), the first
/// `coeff_count(order)` coefficients (order ≤ 8); `None` for a direction ≥ 92 or an order > 8.
#[must_use]
pub fn voronoi_cell_basis(direction: usize, order: usize) -> Option<&'static [f32]> {
    if direction >= GEODESIC_DIRECTION_COUNT || order > MAX_ORDER {
        return None;
    }
    Some(&VORONOI_BASIS[direction][..coeff_count(order)])
}

/// W_l(θ) for l < `order` (f32): the average-radiance weights of a sphere of angular radius `theta_rad` (see the
/// module docs), linearly interpolated in θ; θ is clamped to [0, π/2] (NaN → 0, the far field).
///
/// Writes `out[0..order]`. Allocation-free. Errors: `order > 8`, `out.len() < order`.
pub fn radiance_weights_f32(theta_rad: f32, order: usize, out: &mut [f32]) -> Result<(), ShError> {
    check_order(order, MAX_ORDER)?;
    check_len("out", order, out.len())?;
    interp(theta_rad, order, out);
    Ok(())
}

#[inline(always)]
fn interp(theta_rad: f32, order: usize, out: &mut [f32]) {
    interp_table(&RADIANCE_WEIGHTS, theta_rad, order, out);
}

#[inline(always)]
fn interp_table(table: &[[f32; 8]; RADIANCE_WEIGHT_SAMPLES], theta_rad: f32, order: usize, out: &mut [f32]) {
    const MAX_THETA: f32 = core::f32::consts::FRAC_PI_2;
    const INV_STEP: f32 = (1.0 / RADIANCE_WEIGHT_STEP) as f32;
    let theta = if theta_rad > 0.0 { theta_rad.min(MAX_THETA) } else { 0.0 };
    let t = theta * INV_STEP;
    let k = (t as usize).min(RADIANCE_WEIGHT_SAMPLES - 2);
    let frac = t - k as f32;
    let (r0, r1) = (&table[k], &table[k + 1]);
    for l in 0..order {
        out[l] = r0[l] + frac * (r1[l] - r0[l]);
    }
}

/// The average radiance L̃ = Σ_l W_l(θ) Σ_m L_lm y_lm(`axis`) of an RGB sphere light with coefficients `light`
/// (order = `order`, `light.len() >= order²`) seen from a point at angular radius `theta_rad`; `axis` is the unit
/// direction from the light's centre to the point, in the frame of the light's coefficients (eq. 18).
///
/// Allocation-free. Errors: `order > 8`, `light` shorter than order².
pub fn average_radiance_rgb_f32(
    theta_rad: f32,
    axis: [f32; 3],
    light: &[[f32; 3]],
    order: usize,
) -> Result<[f32; 3], ShError> {
    check_order(order, MAX_ORDER)?;
    check_len("light", coeff_count(order), light.len())?;
    let mut w = [0.0f32; MAX_ORDER];
    interp(theta_rad, order, &mut w);
    let mut y = [0.0f32; MAX_COEFFS];
    eval_unchecked(order, axis[0], axis[1], axis[2], &mut y);
    let mut out = [0.0f32; 3];
    for l in 0..order {
        let mut acc = [0.0f32; 3];
        for i in l * l..(l + 1) * (l + 1) {
            for c in 0..3 {
                acc[c] += light[i][c] * y[i];
            }
        }
        for c in 0..3 {
            out[c] += w[l] * acc[c];
        }
    }
    Ok(out)
}

/// Φ = (1/π) ∫_cap L(ω_S(ω)) (n · ω) dω (RGB; see the module docs) of an RGB sphere light with coefficients `light`
/// (order `order`) seen from a point at angular radius `theta_rad`: `axis` is the unit direction from the light's
/// centre to the point and `normal` the point's unit normal, both in the frame of the light's coefficients. The
/// cap must lie in front of the normal's tangent plane (n · s ≥ sin θ, s = −`axis`). Under an unoccluded light the
/// irradiance is π Φ; Φ / ((n·s) sin²θ) is the cosine-weighted average radiance.
///
/// Allocation-free. Errors: `order > 8`, `light` shorter than order².
pub fn cosine_weighted_radiance_rgb_f32(
    theta_rad: f32,
    axis: [f32; 3],
    normal: [f32; 3],
    light: &[[f32; 3]],
    order: usize,
) -> Result<[f32; 3], ShError> {
    check_order(order, MAX_ORDER)?;
    check_len("light", coeff_count(order), light.len())?;
    let mut c = [0.0f32; MAX_ORDER];
    let mut d = [0.0f32; MAX_ORDER];
    interp_table(&COSINE_WEIGHTS, theta_rad, order, &mut c);
    interp_table(&DIPOLE_WEIGHTS, theta_rad, order, &mut d);
    let a = [f64::from(axis[0]), f64::from(axis[1]), f64::from(axis[2])];
    let n = [f64::from(normal[0]), f64::from(normal[1]), f64::from(normal[2])];
    let na = n[0] * a[0] + n[1] * a[1] + n[2] * a[2];
    let ns = -na;
    let perp = [n[0] - na * a[0], n[1] - na * a[1], n[2] - na * a[2]];
    const EPS: f64 = 1e-4;
    let mut y = [0.0f64; MAX_COEFFS];
    let mut yp = [0.0f64; MAX_COEFFS];
    let mut ym = [0.0f64; MAX_COEFFS];
    eval_poly(order, a[0], a[1], a[2], &mut y);
    eval_poly(order, a[0] + EPS * perp[0], a[1] + EPS * perp[1], a[2] + EPS * perp[2], &mut yp);
    eval_poly(order, a[0] - EPS * perp[0], a[1] - EPS * perp[1], a[2] - EPS * perp[2], &mut ym);
    let t = f64::from(theta_rad.clamp(0.0, core::f32::consts::FRAC_PI_2));
    let sin_t = libm::sin(t);
    let mut out = [0.0f64; 3];
    for l in 0..order {
        let mut band = [0.0f64; 3];
        let mut grad = [0.0f64; 3];
        for i in l * l..(l + 1) * (l + 1) {
            let dy = (yp[i] - ym[i]) / (2.0 * EPS);
            for ch in 0..3 {
                band[ch] += f64::from(light[i][ch]) * y[i];
                grad[ch] += f64::from(light[i][ch]) * dy;
            }
        }
        for ch in 0..3 {
            out[ch] += ns * f64::from(c[l]) * band[ch] + f64::from(d[l]) * grad[ch];
        }
    }
    Ok(out.map(|v| (v * sin_t * sin_t) as f32))
}
