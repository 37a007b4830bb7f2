//! Independent outside-volume oracle: E = Σ_i vol(S_i − T) / vol(T) (Ren et al. 2006 eq. 35,
//! overlaps counted once per sphere), by Monte Carlo over each ball, the method of
//! `../shared/tools/outside_volume.py` re-derived with plain pseudo-random points.
//!
//! - vol(S_i − T) = vol(S_i) · P(x ∉ T) for x uniform in S_i; points mapped into the ball by the
//!   volume-preserving map r = R u₁^(1/3), cos θ = 1 − 2u₂, φ = 2π u₃.
//! - Samples are split over the spheres in proportion to their volume (at least 64 each).
//! - Standard error from the binomial variance of each sphere's estimate, summed over spheres.
//! - Inside tests: the caller's (analytic for a union of boxes), or [`winding_number`] > ½ by
//!   brute force over every triangle (Jacobson et al. 2013; for a closed, consistently oriented
//!   mesh it is 1 inside and 0 outside).
//!
//! Nothing here calls spherebake: it is what the fit's numbers are checked against.

use std::f64::consts::PI;

/// Result of [`outside_ratio`].
#[derive(Clone, Copy, Debug)]
pub struct OutsideEstimate {
    /// Estimated E (dimensionless).
    pub e: f64,
    /// One standard error of `e`.
    pub standard_error: f64,
    /// Points drawn in all.
    pub samples: usize,
}

/// xorshift64* (Vigna 2016): small, seeded, independent of the crates under test.
struct Rng(u64);

impl Rng {
    fn new(seed: u64, stream: u64) -> Self {
        // Any non-zero state works; mix seed and stream so neighbouring streams differ.
        let s = (seed ^ 0x9E37_79B9_7F4A_7C15).wrapping_mul(0xBF58_476D_1CE4_E5B9)
            ^ stream.wrapping_mul(0x94D0_49BB_1331_11EB);
        let mut r = Rng(s | 1);
        for _ in 0..8 {
            r.next_u64();
        }
        r
    }
    fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// E of `spheres` (centre xyz, radius; f32 as stored, widened exactly to f64) against the solid
/// `inside`, whose volume is `volume` (units³), from about `samples` random points.
/// Deterministic for a given `seed`; the spheres run on up to `available_parallelism` threads,
/// each with its own stream, so the result does not depend on the thread count.
///
/// # Panics
/// When `volume` is not positive.
pub fn outside_ratio<F>(spheres: &[[f32; 4]], volume: f64, samples: usize, seed: u64, inside: F) -> OutsideEstimate
where
    F: Fn([f64; 3]) -> bool + Sync,
{
    assert!(volume > 0.0, "object volume {volume} must be positive");
    let vols: Vec<f64> = spheres.iter().map(|s| 4.0 / 3.0 * PI * (s[3] as f64).powi(3)).collect();
    let total: f64 = vols.iter().sum();
    let counts: Vec<usize> =
        vols.iter().map(|v| ((samples as f64 * v / total.max(f64::MIN_POSITIVE)) as usize).max(64)).collect();
    // (outside volume, its variance) per sphere.
    let per_sphere = |i: usize| -> (f64, f64) {
        let s = spheres[i];
        let c = [s[0] as f64, s[1] as f64, s[2] as f64];
        let r = s[3] as f64;
        let n = counts[i];
        let mut rng = Rng::new(seed, i as u64);
        let mut out = 0usize;
        for _ in 0..n {
            let rho = r * rng.unit().cbrt();
            let cos_t = 1.0 - 2.0 * rng.unit();
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            let phi = 2.0 * PI * rng.unit();
            let x = [c[0] + rho * sin_t * phi.cos(), c[1] + rho * sin_t * phi.sin(), c[2] + rho * cos_t];
            if !inside(x) {
                out += 1;
            }
        }
        let p = out as f64 / n as f64;
        (vols[i] * p, vols[i] * vols[i] * p * (1.0 - p) / n as f64)
    };
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(spheres.len().max(1));
    let mut results = vec![(0.0, 0.0); spheres.len()];
    std::thread::scope(|scope| {
        let chunk = spheres.len().div_ceil(threads).max(1);
        for (k, slot) in results.chunks_mut(chunk).enumerate() {
            let per_sphere = &per_sphere;
            scope.spawn(move || {
                for (j, r) in slot.iter_mut().enumerate() {
                    *r = per_sphere(k * chunk + j);
                }
            });
        }
    });
    // Summed in sphere order: the same bits for any thread count.
    let (outside, var) = results.iter().fold((0.0, 0.0), |a, r| (a.0 + r.0, a.1 + r.1));
    OutsideEstimate { e: outside / volume, standard_error: var.sqrt() / volume, samples: counts.iter().sum() }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn corners(p: &[[f64; 3]], t: [u32; 3]) -> [[f64; 3]; 3] {
    t.map(|v| p[v as usize])
}

/// Enclosed volume of a closed, outward-oriented mesh by the divergence theorem:
/// Σ a · (b × c) / 6 over the triangles (units³).
pub fn closed_mesh_volume(p: &[[f64; 3]], t: &[[u32; 3]]) -> f64 {
    t.iter()
        .map(|&tri| {
            let [a, b, c] = corners(p, tri);
            dot(a, cross(b, c)) / 6.0
        })
        .sum()
}

/// Signed solid angle of triangle (a, b, c) seen from the origin, in steradians, in [−2π, 2π]
/// (Van Oosterom and Strackee 1983): positive when the origin sees the side the normal
/// (b − a) × (c − a) points away from. The tests' copy (this crate shares no code with the
/// library's `spherebake_geom::volume::signed_triangle_solid_angle`): the winding number below,
/// spherebake-sh's cube texels and the runtime's tiles are checked with it.
#[must_use]
pub fn triangle_solid_angle(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let (la, lb, lc) = (dot(a, a).sqrt(), dot(b, b).sqrt(), dot(c, c).sqrt());
    let num = dot(a, cross(b, c));
    let den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
    2.0 * num.atan2(den)
}

/// Generalized winding number of the mesh at `x`: Σ over triangles of the signed solid angle
/// ([`triangle_solid_angle`]) / 4π, brute force over every triangle.
pub fn winding_number(p: &[[f64; 3]], t: &[[u32; 3]], x: [f64; 3]) -> f64 {
    let mut sum = 0.0;
    for &tri in t {
        let [a, b, c] = corners(p, tri).map(|q| sub(q, x));
        sum += triangle_solid_angle(a, b, c);
    }
    sum / (4.0 * PI)
}

/// Inside test of a closed convex mesh: x is inside when it lies behind every face plane
/// (outward faces). Cheap (no trigonometry), for the convex fixtures.
///
/// Files store rounded coordinates, so a convex shape is convex only up to that rounding: a
/// vertex may stand in front of a neighbouring face plane by up to 1e-6 of the box diagonal.
/// The solid tested is then the intersection of the half-spaces, which differs from the mesh
/// solid only within that distance of the surface (a volume below area × 1e-6 × diagonal).
///
/// # Panics
/// When some vertex lies in front of some face plane by more than 1e-6 of the box diagonal
/// (the mesh is not convex or not outward-oriented), or a face is degenerate.
pub fn convex_inside(p: &[[f64; 3]], t: &[[u32; 3]]) -> impl Fn([f64; 3]) -> bool + Sync {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for v in p {
        for k in 0..3 {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
    }
    let diag = dot(sub(hi, lo), sub(hi, lo)).sqrt();
    let planes: Vec<([f64; 3], f64)> = t
        .iter()
        .map(|&tri| {
            let [a, b, c] = corners(p, tri);
            let n = cross(sub(b, a), sub(c, a));
            let len = dot(n, n).sqrt();
            assert!(len > 0.0, "degenerate face {tri:?}");
            let n = n.map(|x| x / len);
            (n, dot(n, a))
        })
        .collect();
    for (n, d) in &planes {
        for v in p {
            assert!(dot(*n, *v) - d <= 1e-6 * diag, "not convex: vertex {v:?} in front of a face plane");
        }
    }
    move |x| planes.iter().all(|(n, d)| dot(*n, x) <= *d)
}

/// The sRGB EOTF (IEC 61966-2-1) of a value in [0, 1], written out here independently of the
/// importer: linear = c / 12.92 up to 0.04045, else ((c + 0.055) / 1.055)^2.4.
pub fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// [`srgb_to_linear`] of an 8-bit code value.
pub fn srgb8_to_linear(v: u8) -> f64 {
    srgb_to_linear(f64::from(v) / 255.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::mesh::unit_cube as cube;

    #[test]
    fn octant_triangle_subtends_pi_over_two() {
        let (x, y, z) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
        assert!((triangle_solid_angle(x, y, z) - PI / 2.0).abs() < 1e-15);
        assert!((triangle_solid_angle(x, z, y) + PI / 2.0).abs() < 1e-15);
    }

    #[test]
    fn cube_volume_and_winding() {
        let (p, t) = cube();
        assert!((closed_mesh_volume(&p, &t) - 1.0).abs() < 1e-12);
        assert!((winding_number(&p, &t, [0.3, 0.6, 0.2]) - 1.0).abs() < 1e-9);
        assert!(winding_number(&p, &t, [1.3, 0.6, 0.2]).abs() < 1e-9);
        assert!(winding_number(&p, &t, [-4.0, 9.0, 0.5]).abs() < 1e-9);
    }

    #[test]
    fn ball_around_the_unit_cube_has_the_analytic_outside_volume() {
        // A ball of radius 2 at the cube's centre contains the cube: outside = 32π/3 − 1.
        let (p, t) = cube();
        let inside = |x: [f64; 3]| winding_number(&p, &t, x) > 0.5;
        let est = outside_ratio(&[[0.5, 0.5, 0.5, 2.0]], 1.0, 20_000, 3, inside);
        let want = 32.0 * PI / 3.0 - 1.0;
        assert!((est.e - want).abs() < 4.0 * est.standard_error, "{est:?} vs {want}");
        // The convex test agrees with the winding number on a grid through and around the cube.
        let convex = convex_inside(&p, &t);
        for i in 0..11 {
            for j in 0..11 {
                let x = [-0.25 + 0.15 * i as f64, -0.25 + 0.15 * j as f64, 0.45 + 0.1 * (i % 3) as f64];
                assert_eq!(convex(x), winding_number(&p, &t, x) > 0.5, "{x:?}");
            }
        }
        // A ball inside the cube: nothing outside, no error.
        let est =
            outside_ratio(&[[0.5, 0.5, 0.5, 0.4]], 1.0, 5_000, 3, |x| x.iter().all(|&v| (0.0..=1.0).contains(&v)));
        assert_eq!((est.e, est.standard_error), (0.0, 0.0));
    }

    #[test]
    fn half_space_cuts_half_of_each_ball() {
        // Balls centred on the plane z = 0, T = {z < 0} (volume 1 by fiat): outside = half of each.
        let s = [[0.0, 0.0, 0.0, 1.0], [5.0, 1.0, 0.0, 0.5], [-3.0, 2.0, 0.0, 0.25]];
        let want: f64 = s.iter().map(|b| 2.0 / 3.0 * PI * (b[3] as f64).powi(3)).sum();
        let est = outside_ratio(&s, 1.0, 200_000, 11, |x| x[2] < 0.0);
        assert!((est.e - want).abs() < 4.0 * est.standard_error, "{est:?} vs {want}");
        assert!(est.standard_error < 0.01 * want, "{est:?}");
        // Deterministic.
        let again = outside_ratio(&s, 1.0, 200_000, 11, |x| x[2] < 0.0);
        assert_eq!(est.e.to_bits(), again.e.to_bits());
    }
}
