//! Real spherical harmonics (orthonormal, Condon–Shortley phase), zonal kernels, the 92 geodesic
//! sample directions and cube-map texel geometry / projection, shared by the baker and the runtime.
//!
//! `#![no_std]` + `alloc` (only [`CubeProjector`] and [`TripleProduct`] allocate); maths through `libm`.
//! Every formula and checked value follows `shared/research/math-reference.md` (section numbers below).
//!
//! | convention | value |
//! |---|---|
//! | coordinates | right-handed; direction s = (x, y, z) unit; θ from +z, φ from +x towards +y; angles in radians |
//! | basis (§1) | real SH, orthonormal (∫ y_i y_j ds = δ_ij), **with** Condon–Shortley phase: y_{1,−1} = −c1·y, y_{1,0} = c1·z, y_{1,1} = −c1·x (Sloan / D3DX `SHEval`) |
//! | index | i = l(l+1) + m, 0-based; see [`sh_index`] |
//! | order | order n = bands l = 0..n−1 = n² coefficients ([`coeff_count`]); n ≤ [`MAX_ORDER`] = 8 |
//! | zonal (§2) | g_l = 2π K_l0 ∫ g(t) P_l(t) dt; rotated to axis a: f_lm = √(4π/(2l+1)) g_l y_lm(a) ([`zh_rotate`]) |
//! | geodesic (§5) | icosahedron, frequency 3, class I, flat subdivision then projection; order fixed by §5 ([`GEODESIC_DIRECTIONS`]) |
//! | cube faces (§4) | OpenGL 4.x / Vulkan layer order +X, −X, +Y, −Y, +Z, −Z and (sc, tc) table ([`CubeFace`]) |
//! | cube texels | texel (i, j): i = column along s, j = row along t (row 0 first in memory); centre s = (i+½)/N; buffers face-major, then row j, then column i |
//! | projection | f_i = ∫ f y_i ds; cube estimate (4π/Σw) Σ w_t f(d_t) y_i(d_t) with exact texel solid angles w_t ([`CubeProjector`]) |
//!
//! Functions taking caller-provided output slices write the first `coeff_count(order)` (or `order`)
//! entries, leave the rest untouched, and return [`ShError`] instead of panicking on bad sizes.
#![no_std]
#![warn(missing_docs)]
// Index loops mirror the formulas (i, j, k, l, m) and are clearer than iterator chains here.
#![allow(clippy::needless_range_loop)]

extern crate alloc;
#[cfg(test)]
extern crate std;

mod basis;
mod cube;
mod geodesic;
mod quadrature;
mod triple;
mod zonal;

pub use basis::{coeff_count, eval_sh, eval_sh_f64, sh_index, MAX_COEFFS, MAX_ORDER};
pub use cube::{
    cube_dir_to_face_uv, cube_face_uv_direction, cube_texel_direction, cube_texel_solid_angle, CubeFace, CubeProjector,
};
pub use geodesic::{geodesic_directions_f64, GEODESIC_DIRECTIONS, GEODESIC_DIRECTION_COUNT};
pub use triple::{sh_product, TripleProduct, TripleProductEntry};
pub use zonal::{
    cap_visibility_zh, cap_zh, clamped_cosine_convolution, clamped_cosine_zh, legendre_p, ren_window, zh_rotate,
    zh_rotate_f32,
};

use core::fmt;

/// Error of an `spherebake-sh` call: a bad order, face size or buffer length (all values are counts of elements).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ShError {
    /// The SH order (number of bands) exceeds what the call supports.
    OrderOutOfRange {
        /// Requested order.
        order: usize,
        /// Largest supported order.
        max: usize,
    },
    /// A caller-provided slice is shorter than needed.
    BufferTooShort {
        /// Which argument.
        buffer: &'static str,
        /// Minimum number of elements needed.
        expected: usize,
        /// Number of elements given.
        actual: usize,
    },
    /// An input slice has the wrong number of elements.
    LengthMismatch {
        /// Which argument.
        buffer: &'static str,
        /// Number of elements expected.
        expected: usize,
        /// Number of elements given.
        actual: usize,
    },
    /// A cube-map face size (texels per edge) that is 0 or too large to index.
    InvalidFaceSize {
        /// Requested texels per face edge.
        face_size: usize,
    },
    /// A table could not be allocated.
    AllocationFailed {
        /// Number of `f64` elements requested.
        elements: usize,
    },
}

impl fmt::Display for ShError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ShError::OrderOutOfRange { order, max } => {
                write!(f, "SH order {order} out of range (supported: 0..={max})")
            }
            ShError::BufferTooShort { buffer, expected, actual } => {
                write!(f, "buffer `{buffer}` too short: need {expected} elements, got {actual}")
            }
            ShError::LengthMismatch { buffer, expected, actual } => {
                write!(f, "buffer `{buffer}` has {actual} elements, expected {expected}")
            }
            ShError::InvalidFaceSize { face_size } => {
                write!(f, "invalid cube face size {face_size} texels")
            }
            ShError::AllocationFailed { elements } => {
                write!(f, "could not allocate {elements} f64 elements")
            }
        }
    }
}

impl core::error::Error for ShError {}

/// Returns `Err(BufferTooShort)` unless `len >= expected` (internal length guard).
pub(crate) fn check_len(buffer: &'static str, expected: usize, len: usize) -> Result<(), ShError> {
    if len < expected {
        Err(ShError::BufferTooShort { buffer, expected, actual: len })
    } else {
        Ok(())
    }
}

/// Returns `Err(OrderOutOfRange)` unless `order <= max` (internal order guard).
pub(crate) fn check_order(order: usize, max: usize) -> Result<(), ShError> {
    if order > max {
        Err(ShError::OrderOutOfRange { order, max })
    } else {
        Ok(())
    }
}
