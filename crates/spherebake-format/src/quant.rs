//! Quantisation primitives of the compact sections (format minor 1, spec §7.1 and §8.1), written
//! once: the writer encodes with them, the reader decodes with them, and the bake uses the same
//! copies wherever it needs the same rounding.
//!
//! - IEEE 754 binary16 ("f16") ↔ f32, round to nearest, ties to even.
//! - Octahedral unit vectors in two signed 16-bit integers (snorm16, −32767..=32767).
//! - Positions as 16-bit unsigned steps of a per-sphere box: p = origin + step · q.
//!
//! Error bounds (derived in the spec and checked by the tests):
//! - f16: |decode(encode(x)) − x| ≤ 2⁻¹¹·|x| for |x| ≥ 2⁻¹⁴, ≤ 2⁻²⁵ below (half the subnormal spacing).
//! - octahedral: chord |decode(encode(n)) − n/|n|| ≤ √18 / (2·32767) ≈ 6.5e-5 (plus f32 rounding).
//! - positions: |decode − p| ≤ step / 2 per axis (plus the final rounding to f32).

/// Largest position step count: positions are `origin + step · q` with `q` in `0..=Q16_MAX`.
pub const Q16_MAX: u16 = u16::MAX;

/// Largest magnitude of an octahedral component; −32768 is out of range (rule 5011).
pub const OCT_MAX: i16 = i16::MAX;

/// Largest finite f16 value, 65504.
pub const F16_MAX: f32 = 65504.0;

/// Rounds to the nearest integer, ties away from zero, without `std` or a math library (the one rounding of the
/// baker's quantisers and the runtime's argument reduction). NaN and |x| ≥ 4.5e15 (already integers in f64) are
/// returned as they are.
#[must_use]
pub fn round_ties_away(x: f64) -> f64 {
    if x.is_nan() || x.abs() >= 4.5e15 {
        return x;
    }
    // `as i64` truncates towards zero; |x| < 4.5e15 fits.
    let t = x as i64 as f64;
    let frac = x - t;
    if frac >= 0.5 {
        t + 1.0
    } else if frac <= -0.5 {
        t - 1.0
    } else {
        t
    }
}

/// ⌊x⌋ without `std` or a library call (the baseline x86-64 target has no rounding
/// instruction; the fit's volume proxy calls it per slab of every ball): through an integer for
/// |x| < 2⁵², where the cast and the −1 are exact. NaN, ±∞ and |x| ≥ 2⁵² (already integers) are
/// returned as they are. The value of `libm::floor` (a zero may lose its sign).
#[must_use]
#[inline(always)]
pub fn floor_f64(x: f64) -> f64 {
    if x.is_nan() || x.abs() >= TWO_POW_52 {
        return x;
    }
    let t = x as i64 as f64;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

/// ⌈x⌉ = −⌊−x⌋ through [`floor_f64`] (negation is exact): the value of `libm::ceil`.
#[must_use]
#[inline(always)]
pub fn ceil_f64(x: f64) -> f64 {
    -floor_f64(-x)
}

/// 2⁵²: from here on every f64 is an integer.
const TWO_POW_52: f64 = 4_503_599_627_370_496.0;

/// The next f32 towards +∞ (`f32::next_up`, which needs Rust 1.86): the smallest f32 greater
/// than `f`. ±0 → the smallest positive subnormal, the largest negative subnormal → −0, −∞ → −`f32::MAX`;
/// NaN and +∞ are returned as they are.
#[must_use]
pub fn next_up_f32(f: f32) -> f32 {
    if f.is_nan() || f == f32::INFINITY {
        return f;
    }
    if f == 0.0 {
        return f32::from_bits(1);
    }
    let bits = f.to_bits();
    f32::from_bits(if f > 0.0 { bits + 1 } else { bits - 1 })
}

/// The next f32 towards −∞: `−next_up_f32(−f)`. NaN and −∞ are returned as they are.
#[must_use]
pub fn next_down_f32(f: f32) -> f32 {
    -next_up_f32(-f)
}

/// The smallest f32 at or above `x` (the one f64 → f32 rounding of stored bounding radii: the
/// baker's bounding pass and hierarchy and the runtime's refit round the same way). Negative
/// values, subnormals and ±0 are handled; `x` above `f32::MAX` gives +∞, `x` below −`f32::MAX`
/// gives −`f32::MAX`; NaN stays NaN. An `x` that is an f32 is returned unchanged.
#[must_use]
pub fn round_up_f32(x: f64) -> f32 {
    let f = x as f32;
    if f.is_nan() || f64::from(f) >= x {
        f
    } else {
        next_up_f32(f)
    }
}

/// f32 → binary16 bits, round to nearest, ties to even; `None` when `x` is not finite or
/// rounds past the largest f16 (|x| ≥ 65520).
#[must_use]
pub fn f16_from_f32(x: f32) -> Option<u16> {
    let b = x.to_bits();
    let sign = ((b >> 16) & 0x8000) as u16;
    let a = b & 0x7fff_ffff;
    // 65520 = 0x477F_F000 is the midpoint between 65504 and 2^16 and rounds (to even) to infinity.
    if a >= 0x477f_f000 {
        return None;
    }
    if a >= 0x3880_0000 {
        // Normal f16: re-bias the exponent (127 → 15) and round the mantissa 23 → 10 bits.
        let exp = (a >> 23) - 112;
        let mant = a & 0x007f_ffff;
        let mut h = (exp << 10) | (mant >> 13);
        let rem = mant & 0x1fff;
        if rem > 0x1000 || (rem == 0x1000 && h & 1 == 1) {
            h += 1; // a carry into the exponent is the correct rounding
        }
        return Some(sign | h as u16);
    }
    // Subnormal f16 (or zero): units of 2^-24; the scaling by a power of two is exact.
    let v = f32::from_bits(a) * 16_777_216.0;
    let t = v as u32;
    let frac = v - t as f32;
    let h = if frac > 0.5 || (frac == 0.5 && t & 1 == 1) { t + 1 } else { t };
    Some(sign | h as u16)
}

/// binary16 bits → f32 (exact; infinities and NaN decode as such, the reader rejects them).
#[must_use]
pub fn f32_from_f16(bits: u16) -> f32 {
    let sign = u32::from(bits & 0x8000) << 16;
    let exp = u32::from((bits >> 10) & 0x1f);
    let mant = u32::from(bits & 0x03ff);
    let magnitude = match exp {
        0 => mant as f32 / 16_777_216.0,
        31 if mant == 0 => f32::INFINITY,
        31 => f32::NAN,
        _ => f32::from_bits(((exp + 112) << 23) | (mant << 13)),
    };
    f32::from_bits(magnitude.to_bits() | sign)
}

/// Whether binary16 `bits` is finite (exponent field not 31).
#[must_use]
pub const fn f16_is_finite(bits: u16) -> bool {
    bits & 0x7c00 != 0x7c00
}

fn sign_nonneg(x: f64) -> f64 {
    if x < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// A non-zero finite vector → octahedral snorm16 components (u, v), each in −32767..=32767;
/// `None` for a zero or non-finite vector. The vector need not be unit length.
#[must_use]
pub fn oct_encode(n: [f32; 3]) -> Option<[i16; 2]> {
    let [x, y, z] = n.map(f64::from);
    let s = x.abs() + y.abs() + z.abs();
    if !(s.is_finite() && s > 0.0) {
        return None;
    }
    let (mut u, mut v) = (x / s, y / s);
    if z < 0.0 {
        let (u0, v0) = (u, v);
        u = (1.0 - v0.abs()) * sign_nonneg(u0);
        v = (1.0 - u0.abs()) * sign_nonneg(v0);
    }
    let q = |c: f64| round_ties_away(c * f64::from(OCT_MAX)).clamp(-f64::from(OCT_MAX), f64::from(OCT_MAX)) as i16;
    Some([q(u), q(v)])
}

/// Octahedral snorm16 components → unit vector, computed in f64 and rounded to f32 (spec §7.1).
///
/// Components are clamped to −32767..=32767 (the reader rejects −32768 before calling this).
#[must_use]
pub fn oct_decode(q: [i16; 2]) -> [f32; 3] {
    let m = f64::from(OCT_MAX);
    let u = f64::from(q[0]).clamp(-m, m) / m;
    let v = f64::from(q[1]).clamp(-m, m) / m;
    let z = 1.0 - u.abs() - v.abs();
    let (x, y) = if z < 0.0 { ((1.0 - v.abs()) * sign_nonneg(u), (1.0 - u.abs()) * sign_nonneg(v)) } else { (u, v) };
    // |(x, y, z)|₁ = 1, so the length is in [1/√3, 1]: never zero.
    let len = libm::sqrt(x * x + y * y + z * z);
    [(x / len) as f32, (y / len) as f32, (z / len) as f32]
}

/// The quantisation box of one sphere's sample positions: p = origin + step · q per axis.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct SampleBox {
    /// Position of q = 0 (x, y, z), model space.
    pub origin: [f32; 3],
    /// Length of one step per axis, model units, ≥ 0.
    pub step: [f32; 3],
}

impl SampleBox {
    /// The box the writer uses: origin = the per-axis minimum of `positions`, step = the
    /// smallest f32 with origin + 65535 · step ≥ the maximum (0 when all coordinates are equal).
    /// `None` when a coordinate is not finite or a step overflows f32. An empty slice gives the zero box.
    #[must_use]
    pub fn enclosing(positions: impl Iterator<Item = [f32; 3]> + Clone) -> Option<SampleBox> {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        let mut any = false;
        for p in positions {
            any = true;
            for k in 0..3 {
                if !p[k].is_finite() {
                    return None;
                }
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        if !any {
            return Some(SampleBox::default());
        }
        let mut step = [0.0f32; 3];
        for k in 0..3 {
            let span = f64::from(hi[k]) - f64::from(lo[k]);
            let mut s = (span / f64::from(Q16_MAX)) as f32;
            // Rounding to f32 may land below the span: take the next f32 up until it covers it.
            while f64::from(lo[k]) + f64::from(s) * f64::from(Q16_MAX) < f64::from(hi[k]) {
                s = f32::from_bits(s.to_bits() + 1);
            }
            if !s.is_finite() {
                return None;
            }
            step[k] = s;
        }
        Some(SampleBox { origin: lo, step })
    }

    /// Whether the box is valid (rule 5010): origin and step finite, step ≥ 0, and
    /// origin + 65535 · step finite in f32.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        (0..3).all(|k| {
            let (o, s) = (self.origin[k], self.step[k]);
            o.is_finite() && s.is_finite() && s >= 0.0 && self.decode_axis(k, Q16_MAX).is_finite()
        })
    }

    /// The nearest step count of coordinate `x` on axis `k`, clamped to 0..=65535.
    #[must_use]
    pub fn quantise_axis(&self, k: usize, x: f32) -> u16 {
        let (o, s) = (f64::from(self.origin[k]), f64::from(self.step[k]));
        if s <= 0.0 {
            return 0;
        }
        round_ties_away((f64::from(x) - o) / s).clamp(0.0, f64::from(Q16_MAX)) as u16
    }

    /// origin + step · q on axis `k`, in f64 (the product is exact), rounded once to f32.
    #[must_use]
    pub fn decode_axis(&self, k: usize, q: u16) -> f32 {
        (f64::from(self.origin[k]) + f64::from(self.step[k]) * f64::from(q)) as f32
    }

    /// The step counts of `p`.
    #[must_use]
    pub fn quantise(&self, p: [f32; 3]) -> [u16; 3] {
        [self.quantise_axis(0, p[0]), self.quantise_axis(1, p[1]), self.quantise_axis(2, p[2])]
    }

    /// The position of step counts `q`.
    #[must_use]
    pub fn decode(&self, q: [u16; 3]) -> [f32; 3] {
        [self.decode_axis(0, q[0]), self.decode_axis(1, q[1]), self.decode_axis(2, q[2])]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 2^e as f64, built from its bits (independent of the functions under test).
    fn pow2(e: i32) -> f64 {
        f64::from_bits(((1023 + e) as u64) << 52)
    }

    #[test]
    fn floor_and_ceil_without_a_library_call_agree_with_libm() {
        let edge = [0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 2.5, -2.5, 1e-300, -1e-300, 4.4e15, -4.4e15, 4.6e15];
        let far = [1e300, -1e300, f64::INFINITY, f64::NEG_INFINITY, f64::MAX, f64::MIN, 9.3e18, -9.3e18];
        let near = [pow2(52) - 0.5, -(pow2(52) - 0.5), pow2(52) - 1.0, pow2(51) + 0.5, 1.5e16, 1.5e17, 1.5e20];
        for x in edge.into_iter().chain(far).chain(near) {
            // Equal as values (a zero may lose its sign).
            assert!(floor_f64(x) == libm::floor(x), "floor({x}) = {}", floor_f64(x));
            assert!(ceil_f64(x) == libm::ceil(x), "ceil({x}) = {}", ceil_f64(x));
        }
        assert!(floor_f64(f64::NAN).is_nan() && ceil_f64(f64::NAN).is_nan());
    }

    proptest::proptest! {
        #[test]
        fn floor_and_ceil_agree_with_libm_anywhere(m in -1.0f64..1.0, e in 0i32..60, k in -1000i64..1000) {
            for x in [m * pow2(e), k as f64, k as f64 + 0.5, m * pow2(e) + 0.5] {
                proptest::prop_assert!(floor_f64(x) == libm::floor(x), "floor({})", x);
                proptest::prop_assert!(ceil_f64(x) == libm::ceil(x), "ceil({})", x);
            }
        }
    }

    #[test]
    fn next_up_and_down_step_one_f32() {
        assert_eq!(next_up_f32(0.0), f32::from_bits(1));
        assert_eq!(next_up_f32(-0.0), f32::from_bits(1));
        assert_eq!(next_up_f32(1.0), f32::from_bits(0x3F80_0001));
        assert_eq!(next_up_f32(-1.0), -0.999_999_94);
        assert_eq!(next_up_f32(-f32::from_bits(1)), -0.0);
        assert_eq!(next_up_f32(f32::MAX), f32::INFINITY);
        assert_eq!(next_up_f32(f32::NEG_INFINITY), f32::MIN);
        assert_eq!(next_up_f32(f32::INFINITY), f32::INFINITY);
        assert!(next_up_f32(f32::NAN).is_nan());
        assert_eq!(next_down_f32(1.0), 0.999_999_94);
        assert_eq!(next_down_f32(0.0), -f32::from_bits(1));
        for t in [0.0f32, -0.0, 1.0, -1.0, 3.5e-20, -3.5e-20, f32::MIN_POSITIVE, -f32::MIN_POSITIVE, 1e30, -1e30] {
            let u = next_up_f32(t);
            assert!(u > t, "{t}");
            // Nothing representable in between: the midpoint rounds to one of the two.
            let mid = (f64::from(t) + f64::from(u)) / 2.0;
            assert!(mid as f32 == t || mid as f32 == u, "{t}");
            assert_eq!(next_down_f32(u), if t == 0.0 { 0.0 } else { t });
        }
    }

    #[test]
    fn round_up_is_the_smallest_f32_at_or_above() {
        // (x, expected) with expected derived by hand from the f32 grid.
        let cases: [(f64, f32); 14] = [
            (1.0, 1.0),                                     // exact
            (-3.0, -3.0),                                   // exact, negative
            (0.1, 0.1),                                     // nearest f32 of 0.1 is above it
            (1.0 + pow2(-30), f32::from_bits(0x3F80_0001)), // just above 1: the next f32
            (-1.0 - pow2(-30), -1.0),                       // just below −1: −1 is above
            (-1.0 + pow2(-30), -0.999_999_94),              // just above −1
            (pow2(-160), f32::from_bits(1)),                // below the smallest subnormal
            (1.5 * pow2(-149), f32::from_bits(2)),          // between two subnormals
            (pow2(-149), f32::from_bits(1)),                // the smallest subnormal itself
            (-pow2(-160), -0.0),                            // tiny negative: −0 is above
            (f64::from(f32::MIN_POSITIVE) * (1.0 + pow2(-40)), f32::from_bits(0x0080_0001)),
            (f64::from(f32::MAX), f32::MAX), // huge, exact
            (1e39, f32::INFINITY),           // above every finite f32
            (-1e39, f32::MIN),               // below every finite f32
        ];
        for (x, want) in cases {
            let r = round_up_f32(x);
            assert_eq!(r.to_bits(), want.to_bits(), "{x:e}");
            assert!(f64::from(r) >= x, "{x:e}");
            let below = next_down_f32(r);
            assert!(f64::from(below) < x, "{x:e}");
        }
        assert_eq!(round_up_f32(0.0), 0.0);
        assert!(round_up_f32(f64::NAN).is_nan());
        assert_eq!(round_up_f32(f64::INFINITY), f32::INFINITY);
    }
}
