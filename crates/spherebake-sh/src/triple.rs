//! SH triple products (math reference §3): Γ_ijk = ∫ y_i y_j y_k ds and the truncated product f ∗ g.
//!
//! Both are evaluated by the exact product quadrature of §3: Gauss–Legendre in z with ⌈(3n−2)/2⌉ nodes
//! times 3n−2 uniform φ nodes integrates any product of three order-n harmonics exactly.

use crate::basis::{eval_unchecked, MAX_COEFFS, MAX_ORDER};
use crate::quadrature::gauss_legendre;
use crate::{check_len, check_order, coeff_count, ShError};
use alloc::vec;
use alloc::vec::Vec;
use core::f64::consts::PI;

/// Largest number of Gauss–Legendre nodes needed (order 8: ⌈22/2⌉ = 11).
const MAX_Z_NODES: usize = (3 * MAX_ORDER - 2).div_ceil(2);

/// Entries with |Γ| at or below this are treated as zero (the §3 "numerically non-zero" threshold).
const ZERO_THRESHOLD: f64 = 1e-10;

/// Calls `visit(weight, y)` for every node of the exact order-`order` triple-product quadrature (y = order² basis values).
fn for_each_node(order: usize, mut visit: impl FnMut(f64, &[f64])) {
    if order == 0 {
        return;
    }
    let nz = (3 * order - 2).div_ceil(2);
    let nphi = 3 * order - 2;
    let nc = coeff_count(order);
    let mut zs = [0.0; MAX_Z_NODES];
    let mut ws = [0.0; MAX_Z_NODES];
    gauss_legendre(&mut zs[..nz], &mut ws[..nz]);
    let mut y = [0.0; MAX_COEFFS];
    for (&z, &wz) in zs[..nz].iter().zip(&ws[..nz]) {
        let r = libm::sqrt((1.0 - z * z).max(0.0));
        let w = wz * 2.0 * PI / nphi as f64;
        for k in 0..nphi {
            let phi = 2.0 * PI * k as f64 / nphi as f64;
            eval_unchecked(order, r * libm::cos(phi), r * libm::sin(phi), z, &mut y[..nc]);
            visit(w, &y[..nc]);
        }
    }
}

/// Truncated SH product (f ∗ g)_i = Σ_jk Γ_ijk f_j g_k of two order-`order` coefficient vectors (f64, real CS-phase basis).
///
/// Equals projecting the pointwise product of the two reconstructions back onto order `order`; evaluated by the exact
/// §3 quadrature, allocation-free (order 8: 242 nodes). For many products of one order, [`TripleProduct`] is faster.
/// Writes `out[0..order²]`. Errors: `order > MAX_ORDER`, `f`, `g` or `out` shorter than order².
pub fn sh_product(order: usize, f: &[f64], g: &[f64], out: &mut [f64]) -> Result<(), ShError> {
    check_order(order, MAX_ORDER)?;
    let nc = coeff_count(order);
    check_len("f", nc, f.len())?;
    check_len("g", nc, g.len())?;
    check_len("out", nc, out.len())?;
    let mut acc = [0.0; MAX_COEFFS];
    for_each_node(order, |w, y| {
        let fv: f64 = y.iter().zip(f).map(|(a, b)| a * b).sum();
        let gv: f64 = y.iter().zip(g).map(|(a, b)| a * b).sum();
        let s = w * fv * gv;
        for (a, &yi) in acc.iter_mut().zip(y) {
            *a += s * yi;
        }
    });
    out[..nc].copy_from_slice(&acc[..nc]);
    Ok(())
}

/// One non-zero triple-product coefficient Γ_ijk = ∫ y_i y_j y_k ds (indices l(l+1)+m into the real CS-phase basis).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TripleProductEntry {
    /// Output index i.
    pub i: u8,
    /// Index j of the first factor.
    pub j: u8,
    /// Index k of the second factor.
    pub k: u8,
    /// Γ_ijk.
    pub value: f64,
}

/// Coefficients of the small work arrays (orders up to 4).
pub(crate) const SMALL: usize = 16;

/// Sparse SH triple-product tensor Γ_ijk = ∫ y_i y_j y_k ds of one order: all ordered triples with |Γ| > 1e-10, sorted by (i, j, k).
///
/// Counts per order 1..8: 1, 10, 83, 353, 1158, 2907, 6460, 12868 entries. Computed once by exact quadrature (§3).
#[derive(Debug, Clone)]
pub struct TripleProduct {
    order: usize,
    entries: Vec<TripleProductEntry>,
    /// Entries of output row i are `entries[row_start[i]..row_start[i + 1]]` (entries are sorted by i).
    row_start: [u32; MAX_COEFFS + 1],
    /// For squares f ∗ f: the entries with j ≤ k, 2Γ_ijk where j < k (Γ_ijk = Γ_ikj), rows as `row_start`.
    square_entries: Vec<TripleProductEntry>,
    square_row_start: [u32; MAX_COEFFS + 1],
}

impl TripleProduct {
    /// Computes the tensor of SH `order` (≤ [`MAX_ORDER`]). Errors: order too large.
    pub fn new(order: usize) -> Result<Self, ShError> {
        check_order(order, MAX_ORDER)?;
        let nc = coeff_count(order);
        // Dense values for i ≤ j ≤ k, then every ordered triple reads its sorted representative.
        let mut dense = vec![0.0f64; nc * nc * nc];
        for_each_node(order, |w, y| {
            for i in 0..nc {
                let wi = w * y[i];
                for j in i..nc {
                    let wij = wi * y[j];
                    let row = (i * nc + j) * nc;
                    for k in j..nc {
                        dense[row + k] += wij * y[k];
                    }
                }
            }
        });
        let mut entries = Vec::new();
        for i in 0..nc {
            for j in 0..nc {
                for k in 0..nc {
                    let mut s = [i, j, k];
                    s.sort_unstable();
                    let v = dense[(s[0] * nc + s[1]) * nc + s[2]];
                    if libm::fabs(v) > ZERO_THRESHOLD {
                        entries.push(TripleProductEntry { i: i as u8, j: j as u8, k: k as u8, value: v });
                    }
                }
            }
        }
        let rows = |entries: &[TripleProductEntry]| {
            let mut row_start = [0u32; MAX_COEFFS + 1];
            for e in entries {
                row_start[e.i as usize + 1] += 1;
            }
            for i in 0..MAX_COEFFS {
                row_start[i + 1] += row_start[i];
            }
            row_start
        };
        let square_entries: Vec<TripleProductEntry> = entries
            .iter()
            .filter(|e| e.j <= e.k)
            .map(|e| TripleProductEntry { value: if e.j < e.k { 2.0 * e.value } else { e.value }, ..*e })
            .collect();
        let (row_start, square_row_start) = (rows(&entries), rows(&square_entries));
        Ok(TripleProduct { order, entries, row_start, square_entries, square_row_start })
    }

    /// SH order (bands 0..order−1) of the tensor.
    #[inline]
    pub fn order(&self) -> usize {
        self.order
    }

    /// The non-zero entries, sorted by (i, j, k).
    #[inline]
    pub fn entries(&self) -> &[TripleProductEntry] {
        &self.entries
    }

    /// Truncated product (f ∗ g)_i = Σ_jk Γ_ijk f_j g_k; writes `out[0..order²]`. Allocation-free.
    ///
    /// Errors: `f`, `g` or `out` shorter than order².
    pub fn product(&self, f: &[f64], g: &[f64], out: &mut [f64]) -> Result<(), ShError> {
        let nc = coeff_count(self.order);
        check_len("f", nc, f.len())?;
        check_len("g", nc, g.len())?;
        check_len("out", nc, out.len())?;
        // Fixed-size copies let the hot loop run without bounds checks (`product_array`); arrays of 16 up to order 4,
        // so a low order does not pay for clearing and copying 64 coefficients.
        if nc <= SMALL {
            let (mut fa, mut ga) = ([0.0; SMALL], [0.0; SMALL]);
            fa[..nc].copy_from_slice(&f[..nc]);
            ga[..nc].copy_from_slice(&g[..nc]);
            let mut acc = [0.0; SMALL];
            self.product_array(&fa, &ga, &mut acc);
            out[..nc].copy_from_slice(&acc[..nc]);
        } else {
            let (mut fa, mut ga) = ([0.0; MAX_COEFFS], [0.0; MAX_COEFFS]);
            fa[..nc].copy_from_slice(&f[..nc]);
            ga[..nc].copy_from_slice(&g[..nc]);
            let mut acc = [0.0; MAX_COEFFS];
            self.product_array(&fa, &ga, &mut acc);
            out[..nc].copy_from_slice(&acc[..nc]);
        }
        Ok(())
    }

    /// [`TripleProduct::product`] on fixed-size arrays of `N` ≥ order² coefficients (`N` a power of two: indices are
    /// masked by `N − 1`, so the loop has no bounds checks); writes `out[..order²]` and leaves the rest. Each output
    /// row is summed with four independent partial sums (entries sorted by i), so the loop is not latency-bound; the
    /// sums run in the same order for every `N`, so every `N` gives the same bits.
    #[inline]
    pub(crate) fn product_array<const N: usize>(&self, f: &[f64; N], g: &[f64; N], out: &mut [f64; N]) {
        Self::rows_array(&self.entries, &self.row_start, coeff_count(self.order), f, g, out);
    }

    /// The square f ∗ f on fixed-size arrays, as [`TripleProduct::product_array`]`(f, f)` with about half the
    /// terms (Γ_ijk = Γ_ikj: each pair j < k once, doubled); equal to rounding, not bit for bit.
    #[inline]
    pub(crate) fn square_array<const N: usize>(&self, f: &[f64; N], out: &mut [f64; N]) {
        Self::rows_array(&self.square_entries, &self.square_row_start, coeff_count(self.order), f, f, out);
    }

    #[inline(always)]
    fn rows_array<const N: usize>(
        entries: &[TripleProductEntry],
        row_start: &[u32; MAX_COEFFS + 1],
        nc: usize,
        f: &[f64; N],
        g: &[f64; N],
        out: &mut [f64; N],
    ) {
        debug_assert!(N.is_power_of_two() && nc <= N);
        let nc = nc.min(N);
        let term = |e: &TripleProductEntry| e.value * f[e.j as usize & (N - 1)] * g[e.k as usize & (N - 1)];
        for (i, a) in out.iter_mut().enumerate().take(nc) {
            let row = &entries[row_start[i] as usize..row_start[i + 1] as usize];
            let mut s = [0.0; 4];
            let mut chunks = row.chunks_exact(4);
            for c in &mut chunks {
                s[0] += term(&c[0]);
                s[1] += term(&c[1]);
                s[2] += term(&c[2]);
                s[3] += term(&c[3]);
            }
            for e in chunks.remainder() {
                s[0] += term(e);
            }
            *a = (s[0] + s[1]) + (s[2] + s[3]);
        }
    }

    /// Product matrix (M_f)_ij = Σ_k Γ_ijk f_k, row-major order²×order² into `out` (so f ∗ g = M_f g, M_1 = I). Allocation-free.
    ///
    /// Errors: `f` shorter than order², `out` shorter than order⁴.
    pub fn product_matrix(&self, f: &[f64], out: &mut [f64]) -> Result<(), ShError> {
        let nc = coeff_count(self.order);
        check_len("f", nc, f.len())?;
        check_len("out", nc * nc, out.len())?;
        out[..nc * nc].fill(0.0);
        for e in &self.entries {
            out[e.i as usize * nc + e.j as usize] += e.value * f[e.k as usize];
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::sh_index;
    use crate::zonal::{cap_visibility_zh, zh_rotate};
    use std::vec::Vec;

    fn lm(i: usize) -> (isize, isize) {
        let l = libm::floor(libm::sqrt(i as f64)) as isize;
        (l, i as isize - l * (l + 1))
    }

    /// §3 selection rules for the real basis.
    fn allowed(i: usize, j: usize, k: usize) -> bool {
        let ((l1, m1), (l2, m2), (l3, m3)) = (lm(i), lm(j), lm(k));
        if (l1 + l2 + l3) % 2 != 0 || l3 < (l1 - l2).abs() || l3 > l1 + l2 {
            return false;
        }
        let mut a = [m1.abs(), m2.abs(), m3.abs()];
        a.sort_unstable();
        let negatives = [m1, m2, m3].iter().filter(|&&m| m < 0).count();
        a[2] == a[0] + a[1] && negatives % 2 == 0
    }

    /// The square path (pairs j < k once, doubled) equals the general product of f with itself to rounding, on every
    /// order, and the small (16) and full (64) work arrays give the same bits.
    #[test]
    fn square_equals_product_with_itself() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for order in 1..=MAX_ORDER {
            let tp = TripleProduct::new(order).unwrap();
            let nc = coeff_count(order);
            for _ in 0..20 {
                let mut f = [0.0; MAX_COEFFS];
                for v in &mut f[..nc] {
                    *v = 3.0 * next();
                }
                let (mut full, mut square) = ([0.0; MAX_COEFFS], [0.0; MAX_COEFFS]);
                tp.product_array(&f, &f, &mut full);
                tp.square_array(&f, &mut square);
                let scale: f64 = full[..nc].iter().map(|v| v.abs()).fold(1.0, f64::max);
                for i in 0..nc {
                    assert!(
                        (full[i] - square[i]).abs() <= 1e-13 * scale,
                        "order {order}, i {i}: {} vs {}",
                        full[i],
                        square[i]
                    );
                }
                assert!(full[nc..].iter().chain(&square[nc..]).all(|&v| v == 0.0), "only order² outputs written");
                if nc <= SMALL {
                    let mut small = [0.0; SMALL];
                    small.copy_from_slice(&f[..SMALL]);
                    let (mut a, mut b) = ([0.0; SMALL], [0.0; SMALL]);
                    tp.product_array(&small, &small, &mut a);
                    tp.square_array(&small, &mut b);
                    assert_eq!(a.map(f64::to_bits)[..nc], full.map(f64::to_bits)[..nc]);
                    assert_eq!(b.map(f64::to_bits)[..nc], square.map(f64::to_bits)[..nc]);
                }
            }
        }
    }

    #[test]
    fn counts_and_selection_rules() {
        let nonzero = [1, 10, 83, 353, 1158, 2907, 6460, 12868];
        let rules = [1, 10, 83, 359, 1164, 2961, 6586, 13018];
        for order in 1..=8 {
            let t = TripleProduct::new(order).unwrap();
            assert_eq!(t.entries().len(), nonzero[order - 1], "order {order}");
            let nc = order * order;
            let mut n_allowed = 0;
            for i in 0..nc {
                for j in 0..nc {
                    for k in 0..nc {
                        n_allowed += allowed(i, j, k) as usize;
                    }
                }
            }
            assert_eq!(n_allowed, rules[order - 1]);
            for e in t.entries() {
                assert!(allowed(e.i as usize, e.j as usize, e.k as usize), "{e:?}");
            }
        }
    }

    fn gamma(t: &TripleProduct, i: u8, j: u8, k: u8) -> f64 {
        t.entries().iter().find(|e| (e.i, e.j, e.k) == (i, j, k)).map_or(0.0, |e| e.value)
    }

    #[test]
    fn quoted_values_and_symmetry() {
        let t = TripleProduct::new(8).unwrap();
        let quoted: [((u8, u8, u8), f64); 14] = [
            ((0, 0, 0), 0.2820947918),
            ((2, 2, 6), 0.2523132522),
            ((1, 1, 6), -0.1261566261),
            ((1, 3, 4), 0.2185096861),
            ((1, 1, 8), -0.2185096861),
            ((3, 3, 8), 0.2185096861),
            ((6, 6, 6), 0.1802237516),
            ((2, 6, 12), 0.2477666951),
            ((1, 4, 15), -0.2261790132),
            ((3, 8, 15), 0.2261790132),
            ((5, 10, 13), 0.1151647165),
            ((4, 11, 13), 0.1456731241),
            ((12, 12, 6), 0.1682088348),
            ((6, 14, 14), 0.0),
        ];
        for ((i, j, k), v) in quoted {
            for (a, b, c) in [(i, j, k), (j, k, i), (k, i, j), (j, i, k), (i, k, j), (k, j, i)] {
                let g = gamma(&t, a, b, c);
                assert!((g - v).abs() < 1e-9 + 1e-9 * v.abs(), "Γ{a},{b},{c} = {g}");
            }
        }
        // Γ_ij0 = δ_ij / √(4π).
        let c0 = 1.0 / libm::sqrt(4.0 * PI);
        for i in 0..64u8 {
            for j in 0..64u8 {
                let e = if i == j { c0 } else { 0.0 };
                assert!((gamma(&t, i, j, 0) - e).abs() < 1e-14);
            }
        }
        // Sorted by (i, j, k).
        assert!(t.entries().windows(2).all(|w| (w[0].i, w[0].j, w[0].k) < (w[1].i, w[1].j, w[1].k)));
    }

    #[test]
    fn product_example_two_caps() {
        let deg30 = 30.0 * PI / 180.0;
        let mut v = [0.0; 4];
        cap_visibility_zh(deg30, 4, &mut v).unwrap();
        let mut v1 = [0.0; 16];
        let mut v2 = [0.0; 16];
        zh_rotate(&v, [0.0, 0.0, 1.0], &mut v1).unwrap();
        let n = libm::sqrt(14.0);
        zh_rotate(&v, [1.0 / n, 2.0 / n, 3.0 / n], &mut v2).unwrap();
        let t = TripleProduct::new(4).unwrap();
        let mut p = [0.0; 16];
        let mut q = [0.0; 16];
        t.product(&v1, &v2, &mut p).unwrap();
        sh_product(4, &v1, &v2, &mut q).unwrap();
        let want = [
            (0, 3.147239684),
            (1, 0.1687857528),
            (2, -0.5689478586),
            (3, 0.0843928764),
            (6, -0.5046023147),
            (12, -0.340657422),
        ];
        for (i, w) in want {
            assert!((p[i] - w).abs() < 1e-9 + 1e-9 * w.abs(), "[{i}] {}", p[i]);
        }
        for i in 0..16 {
            assert!((p[i] - q[i]).abs() < 1e-14);
        }
        // M_f g = f ∗ g.
        let mut m = [0.0; 256];
        t.product_matrix(&v1, &mut m).unwrap();
        for i in 0..16 {
            let s: f64 = (0..16).map(|j| m[i * 16 + j] * v2[j]).sum();
            assert!((s - p[i]).abs() < 1e-14);
        }
    }

    #[test]
    fn unit_is_identity_and_product_commutes() {
        let mut one = [0.0; 64];
        one[0] = libm::sqrt(4.0 * PI);
        let f: Vec<f64> = (0..64).map(|i| libm::sin(1.7 * i as f64 + 0.3) / (1 + i) as f64).collect();
        let g: Vec<f64> = (0..64).map(|i| libm::cos(0.9 * i as f64)).collect();
        let t = TripleProduct::new(8).unwrap();
        let mut out = [0.0; 64];
        t.product(&one, &f, &mut out).unwrap();
        for i in 0..64 {
            assert!((out[i] - f[i]).abs() < 1e-14);
        }
        let mut m = std::vec![0.0; 64 * 64];
        t.product_matrix(&one, &mut m).unwrap();
        for i in 0..64 {
            for j in 0..64 {
                let e = if i == j { 1.0 } else { 0.0 };
                assert!((m[i * 64 + j] - e).abs() < 1e-14);
            }
        }
        let mut a = [0.0; 64];
        let mut b = [0.0; 64];
        sh_product(8, &f, &g, &mut a).unwrap();
        sh_product(8, &g, &f, &mut b).unwrap();
        t.product(&f, &g, &mut out).unwrap();
        for i in 0..64 {
            assert!((a[i] - b[i]).abs() < 1e-13);
            assert!((a[i] - out[i]).abs() < 1e-13);
        }
        // A product of two band-1 functions: (z)·(z) = z², exactly representable at order 3.
        let mut zc = [0.0; 9];
        zc[sh_index(1, 0)] = libm::sqrt(4.0 * PI / 3.0);
        let mut z2 = [0.0; 9];
        sh_product(3, &zc, &zc, &mut z2).unwrap();
        // z² = 1/3 + (2/3) P_2(z): coefficients √(4π)/3 and (2/3)·√(4π/5).
        assert!((z2[0] - libm::sqrt(4.0 * PI) / 3.0).abs() < 1e-14);
        assert!((z2[sh_index(2, 0)] - 2.0 / 3.0 * libm::sqrt(4.0 * PI / 5.0)).abs() < 1e-14);
    }

    #[test]
    fn errors() {
        assert!(matches!(TripleProduct::new(9), Err(ShError::OrderOutOfRange { order: 9, .. })));
        let t = TripleProduct::new(2).unwrap();
        assert!(matches!(
            t.product(&[0.0; 3], &[0.0; 4], &mut [0.0; 4]),
            Err(ShError::BufferTooShort { buffer: "f", expected: 4, actual: 3 })
        ));
        assert!(matches!(
            sh_product(2, &[0.0; 4], &[0.0; 4], &mut [0.0; 3]),
            Err(ShError::BufferTooShort { buffer: "out", .. })
        ));
        let t0 = TripleProduct::new(0).unwrap();
        assert!(t0.entries().is_empty());
        sh_product(0, &[], &[], &mut []).unwrap();
    }
}
