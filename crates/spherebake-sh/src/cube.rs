//! Cube maps (math reference §4): OpenGL/Vulkan face convention, texel geometry, exact solid angles, SH projection.

use crate::basis::{eval_unchecked, MAX_COEFFS, MAX_ORDER};
use crate::{check_len, check_order, coeff_count, ShError};
use alloc::vec::Vec;
use core::f64::consts::PI;

/// Cube-map face in OpenGL 4.x / Vulkan layer order (+X, −X, +Y, −Y, +Z, −Z = layers 0..5).
///
/// Exhaustive on purpose: a cube has six faces. Direction of face coordinates (u, v) ∈ [−1, 1]²
/// (u = 2s − 1, v = 2t − 1) before normalisation: +X (1, −v, −u), −X (−1, −v, u), +Y (u, 1, v),
/// −Y (u, −1, −v), +Z (u, −v, 1), −Z (−u, −v, −1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum CubeFace {
    /// Layer 0, major axis +x; sc = −z, tc = −y.
    PosX = 0,
    /// Layer 1, major axis −x; sc = +z, tc = −y.
    NegX = 1,
    /// Layer 2, major axis +y; sc = +x, tc = +z.
    PosY = 2,
    /// Layer 3, major axis −y; sc = +x, tc = −z.
    NegY = 3,
    /// Layer 4, major axis +z; sc = +x, tc = −y.
    PosZ = 4,
    /// Layer 5, major axis −z; sc = −x, tc = −y.
    NegZ = 5,
}

impl CubeFace {
    /// All six faces in layer order 0..5.
    pub const ALL: [CubeFace; 6] =
        [CubeFace::PosX, CubeFace::NegX, CubeFace::PosY, CubeFace::NegY, CubeFace::PosZ, CubeFace::NegZ];

    /// Layer index 0..5 of this face (OpenGL/Vulkan order).
    #[inline]
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Face of layer index `layer` (0..5, OpenGL/Vulkan order), `None` otherwise.
    #[inline]
    pub const fn from_index(layer: usize) -> Option<CubeFace> {
        if layer < 6 {
            Some(Self::ALL[layer])
        } else {
            None
        }
    }

    /// Face frame `[major, s_axis, t_axis]` (unit vectors): the point on the cube for face coordinates (u, v) is major + u·s_axis + v·t_axis.
    #[inline]
    pub const fn frame(self) -> [[f64; 3]; 3] {
        match self {
            CubeFace::PosX => [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, -1.0, 0.0]],
            CubeFace::NegX => [[-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]],
            CubeFace::PosY => [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
            CubeFace::NegY => [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]],
            CubeFace::PosZ => [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]],
            CubeFace::NegZ => [[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]],
        }
    }
}

/// Unit direction through face coordinates (u, v) ∈ [−1, 1]² of `face` (u = 2s − 1, v = 2t − 1; OpenGL/Vulkan table on [`CubeFace`]).
#[inline]
pub fn cube_face_uv_direction(face: CubeFace, u: f64, v: f64) -> [f64; 3] {
    let [ma, sa, ta] = face.frame();
    let p = [ma[0] + u * sa[0] + v * ta[0], ma[1] + u * sa[1] + v * ta[1], ma[2] + u * sa[2] + v * ta[2]];
    let n = libm::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    [p[0] / n, p[1] / n, p[2] / n]
}

/// Unit direction through the centre of texel (column `i` along s, row `j` along t) of an `n`×`n` face: s = (i+½)/n, t = (j+½)/n.
///
/// Expects `i, j < n`; larger values extrapolate beyond the face, `n = 0` gives NaN (never panics).
#[inline]
pub fn cube_texel_direction(face: CubeFace, i: usize, j: usize, n: usize) -> [f64; 3] {
    let nf = n as f64;
    let u = (2 * i + 1) as f64 / nf - 1.0;
    let v = (2 * j + 1) as f64 / nf - 1.0;
    cube_face_uv_direction(face, u, v)
}

/// Face and texture coordinates (s, t) ∈ [0, 1]² hit by direction `dir` (any length > 0), OpenGL/Vulkan face selection.
///
/// Ties of the major axis go to x before y before z. A zero or non-finite `dir` gives NaN coordinates (never panics).
pub fn cube_dir_to_face_uv(dir: [f64; 3]) -> (CubeFace, f64, f64) {
    let [x, y, z] = dir;
    let (ax, ay, az) = (libm::fabs(x), libm::fabs(y), libm::fabs(z));
    let (face, sc, tc, ma) = if ax >= ay && ax >= az {
        if x > 0.0 {
            (CubeFace::PosX, -z, -y, ax)
        } else {
            (CubeFace::NegX, z, -y, ax)
        }
    } else if ay >= az {
        if y > 0.0 {
            (CubeFace::PosY, x, z, ay)
        } else {
            (CubeFace::NegY, x, -z, ay)
        }
    } else if z > 0.0 {
        (CubeFace::PosZ, x, -y, az)
    } else {
        (CubeFace::NegZ, -x, -y, az)
    };
    (face, 0.5 * (sc / ma + 1.0), 0.5 * (tc / ma + 1.0))
}

/// Antiderivative of du dv / (1+u²+v²)^{3/2}.
#[inline]
fn area_antiderivative(u: f64, v: f64) -> f64 {
    libm::atan2(u * v, libm::sqrt(1.0 + u * u + v * v))
}

/// Exact solid angle (steradians) of texel (`i`, `j`) of an `n`×`n` cube face (the same on all six faces).
///
/// Ω = F(u1,v1) − F(u0,v1) − F(u1,v0) + F(u0,v0), F(u,v) = atan2(uv, √(1+u²+v²)), u0 = 2i/n − 1.
/// The 6n² texels sum to 4π. Expects `i, j < n`; `n = 0` gives NaN (never panics).
pub fn cube_texel_solid_angle(i: usize, j: usize, n: usize) -> f64 {
    let nf = n as f64;
    let u0 = (2 * i) as f64 / nf - 1.0;
    let u1 = (2 * (i + 1)) as f64 / nf - 1.0;
    let v0 = (2 * j) as f64 / nf - 1.0;
    let v1 = (2 * (j + 1)) as f64 / nf - 1.0;
    area_antiderivative(u1, v1) - area_antiderivative(u0, v1) - area_antiderivative(u1, v0)
        + area_antiderivative(u0, v0)
}

/// Precomputed SH projection of one cube-map size: f_i ≈ (4π / Σw) Σ_t w_t f(d_t) y_i(d_t), w_t = exact texel solid angle.
///
/// Texel buffers are face-major (layer order of [`CubeFace`]), then row j, then column i:
/// texel index t = (face·n + j)·n + i, `6·n·n` entries. The per-texel table w_t·y_i(d_t)·4π/Σw is stored in f64;
/// projections accumulate in f64 and allocate nothing.
#[derive(Debug, Clone)]
pub struct CubeProjector {
    order: usize,
    face_size: usize,
    /// `weights[t * coeff_count + i]`.
    weights: Vec<f64>,
}

impl CubeProjector {
    /// Builds the table for SH `order` (≤ [`MAX_ORDER`]) and faces of `face_size`×`face_size` texels.
    ///
    /// Memory: 6·face_size²·order² f64 (3 MiB at face_size 32, order 8).
    /// Errors: order too large, `face_size` 0 or too large to index, allocation failure.
    pub fn new(order: usize, face_size: usize) -> Result<Self, ShError> {
        check_order(order, MAX_ORDER)?;
        let texels = face_size
            .checked_mul(face_size)
            .and_then(|v| v.checked_mul(6))
            .filter(|_| face_size > 0 && face_size <= u32::MAX as usize)
            .ok_or(ShError::InvalidFaceSize { face_size })?;
        let nc = coeff_count(order);
        let elements = texels.checked_mul(nc).ok_or(ShError::InvalidFaceSize { face_size })?;
        let mut weights = Vec::new();
        weights.try_reserve_exact(elements).map_err(|_| ShError::AllocationFailed { elements })?;

        // Per-face solid angles (identical on all faces) and their total, summed in texel order.
        let mut omega_total = 0.0;
        for _face in 0..6 {
            for j in 0..face_size {
                for i in 0..face_size {
                    omega_total += cube_texel_solid_angle(i, j, face_size);
                }
            }
        }
        let norm = 4.0 * PI / omega_total;
        let mut y = [0.0f64; MAX_COEFFS];
        for face in CubeFace::ALL {
            for j in 0..face_size {
                for i in 0..face_size {
                    let d = cube_texel_direction(face, i, j, face_size);
                    let w = cube_texel_solid_angle(i, j, face_size) * norm;
                    eval_unchecked(order, d[0], d[1], d[2], &mut y);
                    weights.extend(y[..nc].iter().map(|&yi| w * yi));
                }
            }
        }
        Ok(CubeProjector { order, face_size, weights })
    }

    /// SH order (bands 0..order−1) of the projection.
    #[inline]
    pub fn order(&self) -> usize {
        self.order
    }

    /// Texels per face edge n.
    #[inline]
    pub fn face_size(&self) -> usize {
        self.face_size
    }

    /// Number of texels 6·n² a texel buffer must hold.
    #[inline]
    pub fn texel_count(&self) -> usize {
        6 * self.face_size * self.face_size
    }

    /// The weight table: entry `t * order² + i` = (4π/Σw)·w_t·y_i(d_t) for texel t (face-major, row j, column i).
    #[inline]
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    fn check_io(&self, texels: usize, out: usize) -> Result<(), ShError> {
        if texels != self.texel_count() {
            return Err(ShError::LengthMismatch {
                buffer: "face_texels",
                expected: self.texel_count(),
                actual: texels,
            });
        }
        check_len("out", coeff_count(self.order), out)
    }

    fn accumulate<const C: usize>(&self, texel: impl Fn(usize) -> [f64; C]) -> [[f64; C]; MAX_COEFFS] {
        let nc = coeff_count(self.order);
        let mut acc = [[0.0f64; C]; MAX_COEFFS];
        if nc == 0 {
            return acc;
        }
        for (t, w) in self.weights.chunks_exact(nc).enumerate() {
            let v = texel(t);
            for (a, &wi) in acc.iter_mut().zip(w) {
                for c in 0..C {
                    a[c] += wi * v[c];
                }
            }
        }
        acc
    }

    /// Projects an RGB cube map (f32, `6·n·n` texels, face-major, row j, column i) onto SH; writes `out[0..order²]` (per channel).
    ///
    /// Accumulates in f64, rounds the result to f32. Allocation-free.
    /// Errors: `face_texels.len() != 6·n²`, `out.len() < order²`.
    pub fn project(&self, face_texels: &[[f32; 3]], out: &mut [[f32; 3]]) -> Result<(), ShError> {
        self.check_io(face_texels.len(), out.len())?;
        let acc = self.accumulate(|t| {
            let p = face_texels[t];
            [p[0] as f64, p[1] as f64, p[2] as f64]
        });
        for (o, a) in out.iter_mut().zip(&acc[..coeff_count(self.order)]) {
            *o = [a[0] as f32, a[1] as f32, a[2] as f32];
        }
        Ok(())
    }

    /// Projects an RGB cube map in f64 (`6·n·n` texels, face-major, row j, column i) onto SH; writes `out[0..order²]`.
    ///
    /// Allocation-free. Errors: `face_texels.len() != 6·n²`, `out.len() < order²`.
    pub fn project_rgb_f64(&self, face_texels: &[[f64; 3]], out: &mut [[f64; 3]]) -> Result<(), ShError> {
        self.check_io(face_texels.len(), out.len())?;
        let acc = self.accumulate(|t| face_texels[t]);
        out[..coeff_count(self.order)].copy_from_slice(&acc[..coeff_count(self.order)]);
        Ok(())
    }

    /// Projects a scalar cube map in f64 (`6·n·n` texels, face-major, row j, column i) onto SH; writes `out[0..order²]`.
    ///
    /// Allocation-free. Errors: `values.len() != 6·n²`, `out.len() < order²`.
    pub fn project_f64(&self, values: &[f64], out: &mut [f64]) -> Result<(), ShError> {
        self.check_io(values.len(), out.len())?;
        let acc = self.accumulate(|t| [values[t]]);
        for (o, a) in out.iter_mut().zip(&acc[..coeff_count(self.order)]) {
            *o = a[0];
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::{eval_sh8, sh_index};
    use std::vec;
    use std::vec::Vec;

    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }
    fn normalize(v: [f64; 3]) -> [f64; 3] {
        let n = libm::sqrt(dot(v, v));
        [v[0] / n, v[1] / n, v[2] / n]
    }

    /// The §4 table's "texel centre direction from (u, v)" column, written out literally.
    fn table_direction(face: usize, u: f64, v: f64) -> [f64; 3] {
        normalize(match face {
            0 => [1.0, -v, -u],
            1 => [-1.0, -v, u],
            2 => [u, 1.0, v],
            3 => [u, -1.0, -v],
            4 => [u, -v, 1.0],
            _ => [-u, -v, -1.0],
        })
    }

    #[test]
    fn directions_match_table_and_quoted() {
        for n in [1usize, 2, 7, 8] {
            for f in 0..6 {
                for j in 0..n {
                    for i in 0..n {
                        let u = (2 * i + 1) as f64 / n as f64 - 1.0;
                        let v = (2 * j + 1) as f64 / n as f64 - 1.0;
                        let face = CubeFace::from_index(f).unwrap();
                        let d = cube_texel_direction(face, i, j, n);
                        let e = table_direction(f, u, v);
                        for c in 0..3 {
                            assert!((d[c] - e[c]).abs() < 1e-15);
                        }
                        // Round trip through face selection.
                        let (ff, s, t) = cube_dir_to_face_uv(d);
                        assert_eq!(ff, face);
                        assert!((s - (i as f64 + 0.5) / n as f64).abs() < 1e-12);
                        assert!((t - (j as f64 + 0.5) / n as f64).abs() < 1e-12);
                    }
                }
            }
        }
        let quoted: [(CubeFace, usize, usize, [f64; 3]); 3] = [
            (CubeFace::PosX, 0, 0, [0.6285393611, 0.5499719409, 0.5499719409]),
            (CubeFace::PosZ, 5, 2, [0.3312945782, 0.3312945782, 0.8834522086]),
            (CubeFace::NegY, 1, 6, [-0.4682929058, -0.7492686493, -0.4682929058]),
        ];
        for (face, i, j, e) in quoted {
            let d = cube_texel_direction(face, i, j, 8);
            for c in 0..3 {
                assert!((d[c] - e[c]).abs() < 1e-12 + 1e-10, "{face:?} {i} {j}");
            }
        }
        assert_eq!(CubeFace::from_index(6), None);
        for (k, f) in CubeFace::ALL.iter().enumerate() {
            assert_eq!(f.index(), k);
        }
    }

    /// Solid angle of a spherical triangle (Van Oosterom–Strackee, the tests' copy), unsigned.
    fn tri_solid_angle(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
        spherebake_testkit::oracle::triangle_solid_angle(a, b, c).abs()
    }

    #[test]
    fn solid_angles() {
        let q = [
            (8, 0, 0, 0.01556860787),
            (8, 3, 3, 0.05885750595),
            (8, 0, 3, 0.02631065308),
            (32, 0, 0, 0.0008006706076),
            (128, 0, 0, 4.772640257e-5),
            (128, 63, 63, 0.0002440810373),
        ];
        for (n, i, j, e) in q {
            let o = cube_texel_solid_angle(i, j, n);
            assert!((o - e).abs() < 1e-12 + 1e-9 * e, "N={n} ({i},{j}): {o}");
        }
        for n in [1usize, 3, 8, 32, 100, 128] {
            let mut s = 0.0;
            for _ in 0..6 {
                for j in 0..n {
                    for i in 0..n {
                        s += cube_texel_solid_angle(i, j, n);
                    }
                }
            }
            assert!((s - 4.0 * core::f64::consts::PI).abs() < 1e-11, "N={n}: {s}");
        }
        // Independent route: two spherical triangles on the texel's corner points, every face and texel at N = 8.
        let n = 8;
        for face in CubeFace::ALL {
            let [ma, sa, ta] = face.frame();
            let corner = |i: usize, j: usize| {
                let u = 2.0 * i as f64 / n as f64 - 1.0;
                let v = 2.0 * j as f64 / n as f64 - 1.0;
                [ma[0] + u * sa[0] + v * ta[0], ma[1] + u * sa[1] + v * ta[1], ma[2] + u * sa[2] + v * ta[2]]
            };
            for j in 0..n {
                for i in 0..n {
                    let (c00, c10, c11, c01) = (corner(i, j), corner(i + 1, j), corner(i + 1, j + 1), corner(i, j + 1));
                    let b = tri_solid_angle(c00, c10, c11) + tri_solid_angle(c00, c11, c01);
                    assert!((cube_texel_solid_angle(i, j, n) - b).abs() < 1e-14);
                }
            }
        }
        // The centre-point approximation total quoted in §4.
        let mut approx = 0.0;
        for j in 0..8 {
            for i in 0..8 {
                let u = (2 * i + 1) as f64 / 8.0 - 1.0;
                let v = (2 * j + 1) as f64 / 8.0 - 1.0;
                approx += 6.0 * (2.0f64 / 8.0).powi(2) / libm::pow(1.0 + u * u + v * v, 1.5);
            }
        }
        assert!((approx - 12.61449335).abs() < 1e-8);
    }

    fn sample(n: usize, f: impl Fn([f64; 3]) -> f64) -> Vec<f64> {
        let mut v = Vec::with_capacity(6 * n * n);
        for face in CubeFace::ALL {
            for j in 0..n {
                for i in 0..n {
                    v.push(f(cube_texel_direction(face, i, j, n)));
                }
            }
        }
        v
    }

    #[test]
    fn projection_errors_const_and_z() {
        let rows: [(usize, [f64; 4], [f64; 5]); 3] = [
            (
                8,
                [-0.02639446064, -0.02230739071, 0.002399887675, -0.006349505962],
                [-0.01330155788, -0.01205958339, -0.009100511963, 0.007327111228, 0.0002085122164],
            ),
            (
                32,
                [-0.001634501724, -0.001381406086, 0.0001414665501, -0.0003742853105],
                [-0.0008237114436, -0.0007503878574, -0.0005564843763, 0.0004089129027, 1.698429839e-6],
            ),
            (
                128,
                [-0.0001020968709, -8.62876048e-5, 8.807766146e-6, -2.330315877e-5],
                [-5.145198666e-5, -4.688635359e-5, -3.4731579e-5, 2.536905459e-5, 6.4279052e-8],
            ),
        ];
        let sq4pi = libm::sqrt(4.0 * core::f64::consts::PI);
        for (n, econst, ez) in rows {
            let p = CubeProjector::new(8, n).unwrap();
            let mut c = [0.0; 64];
            p.project_f64(&sample(n, |_| 1.0), &mut c).unwrap();
            c[0] -= sq4pi;
            let listed = [(4, 0), (4, 4), (6, 0), (6, 4)];
            for (k, &(l, m)) in listed.iter().enumerate() {
                let e = econst[k];
                let got = c[sh_index(l, m)];
                assert!((got - e).abs() < 1e-12 + 1e-9 * e.abs(), "N={n} const e({l},{m}) = {got}");
            }
            for i in 0..64 {
                if !listed.iter().any(|&(l, m)| sh_index(l, m) == i) {
                    assert!(c[i].abs() < 1e-13, "N={n} const e[{i}] = {}", c[i]);
                }
            }
            if n == 32 {
                let r = c[sh_index(4, 4)] / c[sh_index(4, 0)];
                assert!((r - libm::sqrt(5.0 / 7.0)).abs() < 1e-12);
                assert!((r - 0.8451542547).abs() < 1e-9);
            }
            let mut z = [0.0; 64];
            p.project_f64(&sample(n, |d| d[2]), &mut z).unwrap();
            z[2] -= libm::sqrt(4.0 * core::f64::consts::PI / 3.0);
            let listed = [(3, 0), (5, 0), (5, 4), (7, 0), (7, 4)];
            for (k, &(l, m)) in listed.iter().enumerate() {
                let e = ez[k];
                let got = z[sh_index(l, m)];
                assert!((got - e).abs() < 1e-12 + 1e-9 * e.abs(), "N={n} z e({l},{m}) = {got}");
            }
            for i in 0..64 {
                if !listed.iter().any(|&(l, m)| sh_index(l, m) == i) {
                    assert!(z[i].abs() < 1e-13, "N={n} z e[{i}] = {}", z[i]);
                }
            }
        }
    }

    #[test]
    fn f32_rgb_path_matches_f64() {
        let n = 16;
        let p = CubeProjector::new(6, n).unwrap();
        let f =
            |d: [f64; 3], c: usize| 0.3 + 0.2 * c as f64 + d[0] * d[1] - 0.4 * d[2] * (c as f64 - 1.0) + d[1].max(0.0);
        let mut rgb32 = Vec::new();
        let mut rgb64 = Vec::new();
        for face in CubeFace::ALL {
            for j in 0..n {
                for i in 0..n {
                    let d = cube_texel_direction(face, i, j, n);
                    let v = [f(d, 0), f(d, 1), f(d, 2)];
                    rgb64.push(v);
                    rgb32.push([v[0] as f32, v[1] as f32, v[2] as f32]);
                }
            }
        }
        let mut o32 = [[0.0f32; 3]; 36];
        let mut o64 = [[0.0f64; 3]; 36];
        p.project(&rgb32, &mut o32).unwrap();
        p.project_rgb_f64(&rgb64, &mut o64).unwrap();
        let mut single = [0.0; 36];
        for c in 0..3 {
            let ch: Vec<f64> = rgb64.iter().map(|v| v[c]).collect();
            p.project_f64(&ch, &mut single).unwrap();
            for i in 0..36 {
                assert!((single[i] - o64[i][c]).abs() < 1e-15);
                assert!((o32[i][c] as f64 - o64[i][c]).abs() < 1e-6);
            }
        }
        // Band-0 coefficient: the weighted mean times √(4π), computed directly.
        let mean: f64 = (0..rgb64.len())
            .map(|t| {
                let rest = t % (n * n);
                cube_texel_solid_angle(rest % n, rest / n, n) * rgb64[t][1]
            })
            .sum::<f64>();
        assert!((o64[0][1] - mean * 0.5 / libm::sqrt(core::f64::consts::PI)).abs() < 1e-12);
    }

    /// Largest eigenvalue of a symmetric positive semi-definite matrix by cyclic Jacobi rotations.
    fn max_eigenvalue(mut a: Vec<f64>, n: usize) -> f64 {
        for _sweep in 0..100 {
            let mut off = 0.0;
            for p in 0..n {
                for q in (p + 1)..n {
                    off += a[p * n + q] * a[p * n + q];
                }
            }
            if off < 1e-30 {
                break;
            }
            for p in 0..n {
                for q in (p + 1)..n {
                    let apq = a[p * n + q];
                    if apq.abs() < 1e-300 {
                        continue;
                    }
                    let theta = (a[q * n + q] - a[p * n + p]) / (2.0 * apq);
                    let t = theta.signum() / (theta.abs() + libm::sqrt(theta * theta + 1.0));
                    let t = if theta == 0.0 { 1.0 } else { t };
                    let c = 1.0 / libm::sqrt(t * t + 1.0);
                    let s = t * c;
                    for k in 0..n {
                        let (akp, akq) = (a[k * n + p], a[k * n + q]);
                        a[k * n + p] = c * akp - s * akq;
                        a[k * n + q] = s * akp + c * akq;
                    }
                    for k in 0..n {
                        let (apk, aqk) = (a[p * n + k], a[q * n + k]);
                        a[p * n + k] = c * apk - s * aqk;
                        a[q * n + k] = s * apk + c * aqk;
                    }
                }
            }
        }
        (0..n).map(|i| a[i * n + i]).fold(f64::MIN, f64::max)
    }

    /// PRT 2002 §6.2: order-6 band-limited unit-power signals; mean and worst squared error of the cube projection.
    #[test]
    fn prt_2002_section_6_2() {
        for (n, mean_want, worst_want) in [(4usize, 0.00261, 0.00935), (8, 5.8e-5, 0.000179)] {
            let nc = 36;
            let p = CubeProjector::new(6, n).unwrap();
            // Column k of P = projection of the basis function y_k sampled at texel centres.
            let mut pm = vec![0.0; nc * nc];
            let mut col = [0.0; 36];
            for k in 0..nc {
                p.project_f64(&sample(n, |d| eval_sh8(d)[k]), &mut col).unwrap();
                for i in 0..nc {
                    pm[i * nc + k] = col[i] - if i == k { 1.0 } else { 0.0 };
                }
            }
            let mut ee = vec![0.0; nc * nc];
            for i in 0..nc {
                for j in 0..nc {
                    ee[i * nc + j] = (0..nc).map(|k| pm[k * nc + i] * pm[k * nc + j]).sum();
                }
            }
            let mean = (0..nc).map(|i| ee[i * nc + i]).sum::<f64>() / nc as f64;
            let worst = max_eigenvalue(ee, nc);
            // Quoted to 3 significant digits.
            assert!((mean / mean_want - 1.0).abs() < 5e-3, "N={n} mean {mean}");
            assert!((worst / worst_want - 1.0).abs() < 5e-3, "N={n} worst {worst}");
        }
    }

    #[test]
    fn errors_not_panics() {
        assert_eq!(CubeProjector::new(4, 0).unwrap_err(), ShError::InvalidFaceSize { face_size: 0 });
        assert_eq!(CubeProjector::new(4, usize::MAX).unwrap_err(), ShError::InvalidFaceSize { face_size: usize::MAX });
        assert!(matches!(CubeProjector::new(9, 4), Err(ShError::OrderOutOfRange { order: 9, .. })));
        let p = CubeProjector::new(3, 2).unwrap();
        assert_eq!(p.texel_count(), 24);
        assert_eq!(p.weights().len(), 24 * 9);
        let mut out = [[0.0f32; 3]; 9];
        assert!(matches!(
            p.project(&[[0.0; 3]; 23], &mut out),
            Err(ShError::LengthMismatch { expected: 24, actual: 23, .. })
        ));
        assert!(matches!(
            p.project(&[[0.0; 3]; 24], &mut out[..8]),
            Err(ShError::BufferTooShort { expected: 9, actual: 8, .. })
        ));
        // Order 0 projects to nothing.
        let p0 = CubeProjector::new(0, 2).unwrap();
        p0.project_f64(&[1.0; 24], &mut []).unwrap();
        // Degenerate directions do not panic.
        let (_, s, _) = cube_dir_to_face_uv([0.0, 0.0, 0.0]);
        assert!(s.is_nan());
        assert!(cube_texel_direction(CubeFace::PosX, 0, 0, 0)[0].is_nan());
    }
}
