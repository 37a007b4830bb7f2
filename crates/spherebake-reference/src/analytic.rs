//! Cases with a known answer: a diffuse sphere standing above the ground under a sky.
//!
//! A sphere (centre c, radius r, centre height h = c_y − ground ≥ r, uniform albedo a) is convex,
//! so nothing shadows its own exit radiance but the ground (sky radiance 0 for ω_y ≤ 0):
//!
//! L_out(n) = a/π · E_sky(n),   E_sky(n) = ∫_{ω_y > 0} sky(ω) max(0, n·ω) dω,
//!
//! which for the uniform sky of radiance L is E_sky(n) = πL(1 + n_y)/2 (the clamped cosine lobe
//! about n cut by the horizon: ∫_{ω_y>0} max(0, n·ω) dω = π(1 + n_y)/2), so L_out = aL(1 + n_y)/2.
//! The one-bounce irradiance at a point x with normal +Y outside the sphere is the integral over
//! the part of the sphere visible from x (the cap of points y = c + r m with m·(x − c) ≥ r):
//!
//! E_i(x) = ∫_cap L_out(m) · max(0, ω_y) · m·(x − y)/|x − y| / |x − y|² dA,   ω = (y − x)/|y − x|,
//!
//! by deterministic quadrature: Gauss–Legendre in μ = cos γ over [r/|x − c|, 1] (γ the angle from
//! the cap's axis; dA = r² dμ dψ) × the midpoint rule in ψ (periodic: spectrally accurate). The
//! integrand is smooth on the cap (the cosine at y vanishes linearly at the rim), so the rule
//! converges fast. For a sky that is not constant, E_sky(n) is itself a quadrature over the upper
//! hemisphere (Gauss–Legendre in ω_y × midpoint in azimuth; the kink of max(0, n·ω) limits it to
//! about 1e-4 relative at 32 nodes).

use crate::{ReferenceError, Sky};
use glam::{DVec3, Vec3};
use spherebake_geom::{Material, Mesh};
use spherebake_sh::gauss_legendre;
use std::f64::consts::PI;

/// A diffuse sphere of uniform albedo (linear RGB), model space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffuseSphere {
    pub centre: [f64; 3],
    pub radius: f64,
    pub albedo: [f64; 3],
}

/// E_sky(n) = ∫_{ω_y > 0} sky(ω) max(0, n·ω) dω for a unit normal n: closed form for a constant
/// sky, else a `quadrature`-node Gauss–Legendre × 2·`quadrature` azimuth rule.
pub fn sky_irradiance(sky: &Sky, n: [f64; 3], quadrature: usize) -> f64 {
    if let Some(l) = sky.constant() {
        return PI * l * (1.0 + n[1].clamp(-1.0, 1.0)) / 2.0;
    }
    HemisphereRule::new(sky, quadrature).irradiance(DVec3::from(n))
}

/// The sky sampled at the nodes of a hemisphere rule (weights include the solid angle).
struct HemisphereRule {
    nodes: Vec<(DVec3, f64)>,
}

impl HemisphereRule {
    fn new(sky: &Sky, q: usize) -> Self {
        let q = q.max(1);
        let (mut x, mut w) = (vec![0.0; q], vec![0.0; q]);
        gauss_legendre(&mut x, &mut w);
        let na = 2 * q;
        let mut nodes = Vec::with_capacity(q * na);
        for (xi, wi) in x.iter().zip(&w) {
            // ω_y = (x + 1)/2 ∈ (0, 1), dω_y = dx/2.
            let y = 0.5 * (xi + 1.0);
            let s = (1.0 - y * y).max(0.0).sqrt();
            for k in 0..na {
                let phi = 2.0 * PI * (k as f64 + 0.5) / na as f64;
                let d = DVec3::new(s * phi.cos(), y, s * phi.sin());
                let weight = 0.5 * wi * 2.0 * PI / na as f64 * sky.radiance(d.to_array());
                if weight != 0.0 {
                    nodes.push((d, weight));
                }
            }
        }
        Self { nodes }
    }

    fn irradiance(&self, n: DVec3) -> f64 {
        self.nodes.iter().map(|(d, w)| w * n.dot(*d).max(0.0)).sum()
    }
}

/// One-bounce irradiance (linear RGB) from a diffuse sphere at points with normal +Y (ground
/// receivers): [`sphere_one_bounce_at`] with every normal +Y.
///
/// # Errors
/// As [`sphere_one_bounce_at`].
pub fn sphere_one_bounce(
    sky: &Sky,
    sphere: &DiffuseSphere,
    ground_y: f64,
    points: &[[f64; 3]],
    quadrature: usize,
) -> Result<Vec<[f64; 3]>, ReferenceError> {
    let normals = vec![[0.0, 1.0, 0.0]; points.len()];
    sphere_one_bounce_at(sky, sphere, ground_y, points, &normals, quadrature)
}

/// One-bounce irradiance (linear RGB) from a diffuse sphere at points (at or above the ground)
/// with unit normals `normals[k]`, by the quadrature of the module docs with `quadrature`
/// Gauss–Legendre nodes in μ (and 2× that in ψ; the same count for E_sky when the sky is not
/// constant). For +Y normals the integrand is smooth and 32 nodes give about 1e-6 relative; a
/// receiver plane that cuts the visible cap puts a kink in it (max(0, n·ω)) and the rule
/// converges more slowly (about 1e-4 at 48 nodes).
///
/// The ground's own bounce is excluded (as in the Monte Carlo reference); the ground at height
/// `ground_y` only blocks the sky.
///
/// # Errors
/// A radius that is not finite and > 0, a centre lower than `radius` above `ground_y`, a point
/// inside the sphere or below the ground, `normals` not one per point or not finite,
/// `quadrature` outside 1..=512.
pub fn sphere_one_bounce_at(
    sky: &Sky,
    sphere: &DiffuseSphere,
    ground_y: f64,
    points: &[[f64; 3]],
    normals: &[[f64; 3]],
    quadrature: usize,
) -> Result<Vec<[f64; 3]>, ReferenceError> {
    let r = sphere.radius;
    if !(r.is_finite() && r > 0.0) {
        return Err(ReferenceError::InvalidSetting { name: "sphere radius", value: r, expected: "finite, > 0" });
    }
    let c = DVec3::from(sphere.centre);
    if !(c.is_finite() && c.y - ground_y >= r) {
        return Err(ReferenceError::InvalidSetting {
            name: "sphere centre height above the ground",
            value: c.y - ground_y,
            expected: "≥ radius",
        });
    }
    if !(1..=512).contains(&quadrature) {
        return Err(ReferenceError::InvalidSetting {
            name: "quadrature",
            value: quadrature as f64,
            expected: "1..=512",
        });
    }
    if normals.len() != points.len() {
        return Err(ReferenceError::InvalidSetting {
            name: "normals (one per point)",
            value: normals.len() as f64,
            expected: "points.len()",
        });
    }
    let rule = if sky.constant().is_some() { None } else { Some(HemisphereRule::new(sky, quadrature)) };
    // L_out(m)/a = E_sky(m)/π.
    let exit = |m: DVec3| -> f64 {
        let e = match (&rule, sky.constant()) {
            (_, Some(l)) => PI * l * (1.0 + m.y) / 2.0,
            (Some(rule), None) => rule.irradiance(m),
            (None, None) => 0.0,
        };
        e / PI
    };
    let q = quadrature;
    let (mut gx, mut gw) = (vec![0.0; q], vec![0.0; q]);
    gauss_legendre(&mut gx, &mut gw);
    let np = 2 * q;
    let mut out = Vec::with_capacity(points.len());
    for (k, p) in points.iter().enumerate() {
        let x = DVec3::from(*p);
        let to_x = x - c;
        let dist = to_x.length();
        if dist.is_nan() || dist <= r {
            return Err(ReferenceError::InvalidSetting {
                name: "receiver distance from the sphere centre",
                value: dist,
                expected: "> radius",
            });
        }
        if p[1] < ground_y - 1e-12 * (1.0 + ground_y.abs()) {
            return Err(ReferenceError::InvalidSetting {
                name: "receiver height above the ground",
                value: p[1] - ground_y,
                expected: "≥ 0",
            });
        }
        let Some(nx) = DVec3::from(normals[k]).try_normalize() else {
            return Err(ReferenceError::InvalidSetting {
                name: "receiver normal length",
                value: DVec3::from(normals[k]).length(),
                expected: "finite, > 0",
            });
        };
        let axis = to_x / dist;
        let (t, b) = crate::basis(axis);
        let mu0 = r / dist;
        let mut e = 0.0;
        for (xi, wi) in gx.iter().zip(&gw) {
            // μ = mu0 + (1 − mu0)(x + 1)/2.
            let mu = mu0 + (1.0 - mu0) * 0.5 * (xi + 1.0);
            let wmu = wi * 0.5 * (1.0 - mu0);
            let s = (1.0 - mu * mu).max(0.0).sqrt();
            for j in 0..np {
                let psi = 2.0 * PI * (j as f64 + 0.5) / np as f64;
                let m = axis * mu + (t * psi.cos() + b * psi.sin()) * s;
                let y = c + m * r;
                let v = x - y;
                let d2 = v.length_squared();
                let d = d2.sqrt();
                let cos_y = m.dot(v) / d;
                if cos_y <= 0.0 {
                    continue;
                }
                let cos_x = (-v.dot(nx) / d).max(0.0);
                e += wmu * (2.0 * PI / np as f64) * r * r * exit(m) * cos_x * cos_y / d2;
            }
        }
        out.push([sphere.albedo[0] * e, sphere.albedo[1] * e, sphere.albedo[2] * e]);
    }
    Ok(out)
}

/// A UV sphere mesh (`stacks` ≥ 2 latitude bands, `slices` ≥ 3 longitudes), outward
/// counter-clockwise triangles, exact radial vertex normals, one material of base colour
/// `colour` (linear RGB), welded. For the analytic comparisons and tests.
pub fn uv_sphere_mesh(centre: [f64; 3], radius: f64, stacks: usize, slices: usize, colour: [f32; 3]) -> Mesh {
    let (stacks, slices) = (stacks.max(2), slices.max(3));
    let c = DVec3::from(centre);
    let mut dirs = vec![DVec3::Y];
    for j in 1..stacks {
        let th = PI * j as f64 / stacks as f64;
        for i in 0..slices {
            let ph = 2.0 * PI * i as f64 / slices as f64;
            dirs.push(DVec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()));
        }
    }
    dirs.push(-DVec3::Y);
    let bottom = (dirs.len() - 1) as u32;
    let ring = |j: usize, i: usize| -> u32 { (1 + (j - 1) * slices + i % slices) as u32 };
    let mut tris = Vec::new();
    for i in 0..slices {
        tris.push([0, ring(1, i), ring(1, i + 1)]);
        tris.push([bottom, ring(stacks - 1, i + 1), ring(stacks - 1, i)]);
    }
    for j in 1..stacks - 1 {
        for i in 0..slices {
            let (a, b, cc, d) = (ring(j, i), ring(j, i + 1), ring(j + 1, i), ring(j + 1, i + 1));
            tris.push([a, cc, b]);
            tris.push([b, cc, d]);
        }
    }
    let positions: Vec<Vec3> = dirs.iter().map(|d| (c + *d * radius).as_vec3()).collect();
    // Make every triangle counter-clockwise seen from outside.
    for t in &mut tris {
        let [a, b, cc] = t.map(|v| positions[v as usize].as_dvec3());
        if (b - a).cross(cc - a).dot((a + b + cc) / 3.0 - c) < 0.0 {
            t.swap(1, 2);
        }
    }
    let mut mesh = Mesh {
        positions,
        normals: dirs.iter().map(|d| d.as_vec3()).collect(),
        triangle_materials: vec![0; tris.len()],
        triangles: tris,
        materials: vec![Material {
            base_color_factor_linear: [colour[0], colour[1], colour[2], 1.0],
            ..Default::default()
        }],
        ..Default::default()
    };
    mesh.rebuild_weld();
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sky_irradiance_quadrature_matches_the_closed_form() {
        // A sky that is uniform but given with a (tiny) higher coefficient takes the quadrature
        // path; compare with the closed form of the uniform part.
        let mut c = [0.0; 4];
        c[0] = (4.0 * PI).sqrt();
        c[1] = 1e-12;
        let sky = Sky::new(2, &c).unwrap();
        assert!(sky.constant().is_none());
        for n in [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.6, -0.8, 0.0], [0.0, 0.6, 0.8]] {
            let q = sky_irradiance(&sky, n, 64);
            let exact = PI * (1.0 + n[1]) / 2.0;
            assert!((q - exact).abs() < 2e-3, "{n:?}: {q} vs {exact}");
        }
    }

    #[test]
    fn far_point_sees_a_small_sphere_as_a_point_source() {
        // Far away, E_i ≈ I(w)·cos_x/d² with the sphere's radiant intensity towards x (unit w):
        // L_out(m) = a(1 + m_y)/2 and ∫_{m·w>0} m mᵀ dm = (2π/3)·Id give
        // I(w) = r² ∫_{m·w>0} L_out(m) m·w dm = r² a π/2 · (1 + 2w_y/3).
        let sky = Sky::uniform(1.0).unwrap();
        let s = DiffuseSphere { centre: [0.0, 1.0, 0.0], radius: 1e-4, albedo: [1.0, 1.0, 1.0] };
        // x at distance d, slightly below the centre so that cos_x is tiny but known.
        let d = 10.0;
        let x = [d, 0.0, 0.0];
        let e = sphere_one_bounce(&sky, &s, 0.0, &[x], 48).unwrap()[0][0];
        let v = DVec3::new(-d, 1.0, 0.0);
        let dist = v.length();
        let w = -v / dist; // from the sphere towards x
        let intensity = s.radius * s.radius * PI / 2.0 * (1.0 + 2.0 / 3.0 * w.y);
        let cos_x = 1.0 / dist;
        let expect = intensity * cos_x / (dist * dist);
        assert!((e - expect).abs() < 1e-3 * expect, "{e} vs {expect}");
    }

    #[test]
    fn uv_sphere_is_closed_outward_and_the_right_size() {
        let m = uv_sphere_mesh([0.0, 1.0, 0.0], 1.0, 16, 32, [0.5, 0.5, 0.5]);
        let vol: f64 = m
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| m.positions[v as usize].as_dvec3());
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        // Inscribed polyhedron: a little below 4π/3.
        assert!(vol > 0.95 * 4.0 * PI / 3.0 && vol < 4.0 * PI / 3.0, "{vol}");
        assert_eq!(m.triangles.len(), 2 * 32 * 15);
    }
}
