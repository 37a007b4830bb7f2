//! The one box filter of texture images: a 2×2 → 1 step ([`box_texel`], [`halve`]) and its
//! repetition down to a largest side ([`reduce_to_side`]).
//!
//! The albedo bake's mip chain is built from [`halve`], and the importers reduce a texture
//! larger than [`MAX_TEXTURE_SIDE`] with [`reduce_to_side`] as they decode it: the same steps
//! in the same f32 arithmetic, so a reduced texture is bit for bit the level of the chain the
//! full one would have built, and every level above it is too. Only a lookup finer than that
//! level (a footprint below one texel of it) reads a coarser texture than before.
//!
//! Texels are linear (filtering sRGB-encoded values would darken edges); any channel count.

use rayon::prelude::*;

/// Largest side, texels, of a texture as the importers hand it to the bake. Larger images are
/// box-filtered down at decode, so once decoded their memory is that of a 4096² texture
/// (256 MiB of linear RGBA f32, plus its mip chain) whatever the source, and the chain costs
/// what it does for one. The albedo bake reads a texture through the footprint of a cube-map
/// texel and projects the colours onto low-order SH, so it barely sees the difference: spot's
/// texture upscaled to 8192² bakes to the same bits at 64 spheres (a cube-map texel's median
/// footprint is about 10 texels at 8192) and within 6·10⁻⁴ of coefficients up to 3.5 at 1024
/// spheres (`docs/benchmarks.md`).
pub const MAX_TEXTURE_SIDE: usize = 4096;

/// The size of one 2×2 → 1 step below a `w`×`h` image: each side halved (rounded down; an odd
/// last row or column is dropped), at least 1.
pub fn half_size(w: usize, h: usize) -> (usize, usize) {
    ((w / 2).max(1), (h / 2).max(1))
}

/// Texel (`x`, `y`) of the step below a `w`×`h` image read through `get(x, y)`: the mean of
/// texels (2x, 2y), (2x+1, 2y), (2x, 2y+1), (2x+1, 2y+1), each index clamped to the image
/// (which matters only for a side of 1), summed in that order as ¼ t per channel; `get` is
/// called once per distinct texel.
#[inline]
pub fn box_texel<const N: usize>(
    w: usize,
    h: usize,
    x: usize,
    y: usize,
    get: impl Fn(usize, usize) -> [f32; N],
) -> [f32; N] {
    let (y0, y1) = ((2 * y).min(h - 1), (2 * y + 1).min(h - 1));
    let (x0, x1) = ((2 * x).min(w - 1), (2 * x + 1).min(w - 1));
    // Each distinct texel read once: at a side of 1 the clamped reads repeat, and through the
    // nested reads of `reduce_to_side` repeats would multiply per level (a 1 × 2²⁸ image would
    // read each source texel 2¹⁶ times).
    let t00 = get(x0, y0);
    let t10 = if x1 == x0 { t00 } else { get(x1, y0) };
    let t01 = if y1 == y0 { t00 } else { get(x0, y1) };
    let t11 = if x1 == x0 {
        t01
    } else if y1 == y0 {
        t10
    } else {
        get(x1, y1)
    };
    let mut acc = [0.0f32; N];
    for t in [t00, t10, t01, t11] {
        for (a, v) in acc.iter_mut().zip(t) {
            *a += 0.25 * v;
        }
    }
    acc
}

/// The whole step below a `w`×`h` image (`src` row-major, `w * h` texels): its size
/// ([`half_size`]) and texels ([`box_texel`]).
///
/// # Panics
///
/// If `src.len() != w * h` or a side is 0.
pub fn halve<const N: usize>(w: usize, h: usize, src: &[[f32; N]]) -> (usize, usize, Vec<[f32; N]>) {
    assert!(w > 0 && h > 0 && src.len() == w * h, "halve: {w}×{h} image of {} texels", src.len());
    let (nw, nh) = half_size(w, h);
    let texels = (0..nh)
        .into_par_iter()
        .flat_map_iter(|y| (0..nw).map(move |x| box_texel(w, h, x, y, |xx, yy| src[yy * w + xx])))
        .collect();
    (nw, nh, texels)
}

/// The image `get` reads (`w`×`h`, both ≥ 1) after as many [`halve`] steps as it takes for
/// both sides to be at most `max_side` (≥ 1): its size and texels, row-major. With no step
/// needed, the texels are `get`'s own.
///
/// Bit-identical to the steps done one by one, without their intermediate images: each output
/// texel averages its 2ᵈ × 2ᵈ source block through the same nested sums. Time O(w h): each
/// source texel is read at most once (a side of 1 is read once per output texel, not once per
/// clamped repeat, see [`box_texel`]). Memory: the output only.
pub fn reduce_to_side<const N: usize>(
    w: usize,
    h: usize,
    max_side: usize,
    get: impl Fn(usize, usize) -> [f32; N] + Sync,
) -> (usize, usize, Vec<[f32; N]>) {
    assert!(w > 0 && h > 0 && max_side > 0, "reduce_to_side: {w}×{h} image, side {max_side}");
    // sizes[l] is the size of level l (level 0 the source).
    let mut sizes = vec![(w, h)];
    while let Some(&(lw, lh)) = sizes.last().filter(|&&(lw, lh)| lw > max_side || lh > max_side) {
        sizes.push(half_size(lw, lh));
    }
    let (ow, oh) = sizes[sizes.len() - 1];
    let top = sizes.len() - 1;
    let texels = (0..oh)
        .into_par_iter()
        .flat_map_iter(|y| {
            let (sizes, get) = (&sizes, &get);
            (0..ow).map(move |x| level_texel(sizes, top, x, y, get))
        })
        .collect();
    (ow, oh, texels)
}

/// Texel (`x`, `y`) of level `level` of the chain whose level sizes are `sizes`, computed from
/// level 0 (`get`) by nested [`box_texel`]s.
fn level_texel<const N: usize>(
    sizes: &[(usize, usize)],
    level: usize,
    x: usize,
    y: usize,
    get: &impl Fn(usize, usize) -> [f32; N],
) -> [f32; N] {
    if level == 0 {
        return get(x, y);
    }
    let (w, h) = sizes[level - 1];
    box_texel(w, h, x, y, |xx, yy| level_texel(sizes, level - 1, xx, yy, get))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    fn image(w: usize, h: usize, seed: u64) -> Vec<[f32; 2]> {
        let mut rng = SplitMix64::new(seed);
        (0..w * h).map(|_| [rng.next_f64() as f32, rng.next_f64() as f32 * 4.0]).collect()
    }

    #[test]
    fn one_step_is_the_mean_of_each_two_by_two_block() {
        // Independent: the block mean in f64, against the f32 step (4 terms, so within a few
        // ulps). An odd side drops its last row or column; a side of 1 reads its row twice.
        for (w, h) in [(8, 6), (7, 5), (1, 6), (9, 1), (1, 1), (2, 3)] {
            let src = image(w, h, (w * 31 + h) as u64);
            let (nw, nh, out) = halve(w, h, &src);
            assert_eq!((nw, nh), ((w / 2).max(1), (h / 2).max(1)));
            for y in 0..nh {
                for x in 0..nw {
                    let xs = if w == 1 { [0, 0] } else { [2 * x, 2 * x + 1] };
                    let ys = if h == 1 { [0, 0] } else { [2 * y, 2 * y + 1] };
                    let src = &src;
                    for c in 0..2 {
                        let mean: f64 = ys
                            .iter()
                            .flat_map(|&yy| xs.iter().map(move |&xx| f64::from(src[yy * w + xx][c])))
                            .sum::<f64>()
                            / 4.0;
                        let got = f64::from(out[y * nw + x][c]);
                        assert!((got - mean).abs() <= 1e-6 * (1.0 + mean.abs()), "{w}×{h} ({x}, {y}) {c}");
                    }
                }
            }
        }
    }

    #[test]
    fn reducing_equals_the_steps_one_by_one_and_stops_at_the_largest_side() {
        for (w, h, side) in [(37, 20, 4), (64, 64, 8), (64, 64, 64), (5, 300, 16), (33, 1, 2), (3, 3, 1)] {
            let src = image(w, h, (w * 7 + h * 3 + side) as u64);
            let (mut cw, mut ch, mut cur) = (w, h, src.clone());
            let mut steps = 0;
            while cw > side || ch > side {
                (cw, ch, cur) = halve(cw, ch, &cur);
                steps += 1;
            }
            let (rw, rh, got) = reduce_to_side(w, h, side, |x, y| src[y * w + x]);
            assert_eq!((rw, rh), (cw, ch), "{w}×{h} to {side}");
            assert!(rw <= side && rh <= side);
            // Bit for bit, and not trivially: at least one step was taken where one was due.
            assert_eq!(got, cur, "{w}×{h} to {side}");
            assert_eq!(steps == 0, w <= side && h <= side);
        }
    }

    /// The albedo bake's mip step as it was written before this module (`MipChain::new`),
    /// kept here verbatim as the reference the files' bits depend on: another order of the four
    /// terms (say the two of a column first) would change baked files. (Scaling the sum by ¼
    /// instead of each term would not: a power of two rounds the same either way.)
    fn legacy_step(w: usize, h: usize, src: &[[f32; 3]]) -> Vec<[f32; 3]> {
        let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
        let mut dst = Vec::with_capacity(nw * nh);
        for y in 0..nh {
            let (y0, y1) = ((2 * y).min(h - 1), (2 * y + 1).min(h - 1));
            for x in 0..nw {
                let (x0, x1) = ((2 * x).min(w - 1), (2 * x + 1).min(w - 1));
                let mut acc = [0.0f32; 3];
                for &(xx, yy) in &[(x0, y0), (x1, y0), (x0, y1), (x1, y1)] {
                    let t = src[yy * w + xx];
                    for c in 0..3 {
                        acc[c] += 0.25 * t[c];
                    }
                }
                dst.push(acc);
            }
        }
        dst
    }

    #[test]
    fn the_steps_give_the_bits_of_the_earlier_mip_chain() {
        let mut rng = SplitMix64::new(9);
        for (w, h) in [(37, 20), (64, 64), (1, 9), (9, 1), (1, 1), (6, 3)] {
            let src: Vec<[f32; 3]> =
                (0..w * h).map(|_| [rng.next_f64() as f32, rng.next_f64() as f32 * 3.0, 1e-3]).collect();
            let (mut cw, mut ch, mut want) = (w, h, src.clone());
            while cw > 1 || ch > 1 {
                want = legacy_step(cw, ch, &want);
                (cw, ch) = ((cw / 2).max(1), (ch / 2).max(1));
                let (rw, rh, got) = reduce_to_side(w, h, cw.max(ch), |x, y| src[y * w + x]);
                assert_eq!((rw, rh), (cw, ch));
                assert!(
                    got.iter().zip(&want).all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits)),
                    "{w}×{h} at {cw}×{ch}"
                );
            }
        }
    }

    #[test]
    fn a_thin_image_is_read_once_per_texel() {
        // 1 × 65 536 to side 16: twelve steps; each step's side of 1 is clamped, and nested
        // repeats would read each source texel 2¹² times.
        use std::sync::atomic::{AtomicUsize, Ordering};
        let (w, h) = (1usize, 1usize << 16);
        let reads = AtomicUsize::new(0);
        let (rw, rh, got) = reduce_to_side(w, h, 16, |_, y| {
            reads.fetch_add(1, Ordering::Relaxed);
            [y as f32]
        });
        assert_eq!((rw, rh), (1, 16));
        assert_eq!(reads.load(Ordering::Relaxed), h);
        // The mean of 4096 consecutive indices: 4096 y + 2047.5 (exact in f32 sums of ¼ steps).
        for (y, t) in got.iter().enumerate() {
            assert_eq!(t[0], (4096 * y) as f32 + 2047.5);
        }
    }

    #[test]
    fn a_reduced_power_of_two_image_is_the_mean_of_its_blocks() {
        // 64×32 to side 8: three steps, each output texel the mean of an 8×8 block (f64).
        let (w, h) = (64, 32);
        let src = image(w, h, 5);
        let (rw, rh, got) = reduce_to_side(w, h, 8, |x, y| src[y * w + x]);
        assert_eq!((rw, rh), (8, 4));
        for y in 0..rh {
            for x in 0..rw {
                for c in 0..2 {
                    let mut s = 0.0;
                    for yy in 8 * y..8 * y + 8 {
                        for xx in 8 * x..8 * x + 8 {
                            s += f64::from(src[yy * w + xx][c]);
                        }
                    }
                    let mean = s / 64.0;
                    assert!((f64::from(got[y * rw + x][c]) - mean).abs() < 1e-5 * (1.0 + mean));
                }
            }
        }
    }
}
