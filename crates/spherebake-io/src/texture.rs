//! Texture decoding (PNG, JPEG) into linear RGBA f32.

use spherebake_geom::texels::{self, MAX_TEXTURE_SIDE};
use spherebake_geom::{LinearRgba, Texture};

/// The exact piecewise sRGB EOTF (IEC 61966-2-1): sRGB-encoded value in [0, 1] → linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    let c = f64::from(c);
    let l = if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) };
    l as f32
}

/// Most bytes the image decoder may allocate for one texture: a 16 384² RGBA8 image (1 GiB)
/// and room for its decoder's own buffers. A larger image is refused by the decoder (the
/// importers then warn and use the base colour factor), so a small file that inflates to a
/// huge image cannot exhaust memory. The image crate's own default is 512 MiB (8 192² RGBA8).
pub const MAX_DECODE_BYTES: u64 = (1 << 30) + (256 << 20);

/// A decoded texture, and the size of the source image when it was larger than
/// [`MAX_TEXTURE_SIDE`] and was reduced to `texture`'s size.
pub(crate) struct Decoded {
    pub texture: Texture,
    pub reduced_from: Option<(u32, u32)>,
}

impl Decoded {
    /// The warning the importers give for a reduced texture, if it was reduced.
    pub fn reduction_warning(&self, context: &str) -> Option<String> {
        let (w, h) = self.reduced_from?;
        let t = &self.texture;
        Some(format!(
            "{context}: {} is {w}×{h}; the albedo bake reads it box-filtered to {}×{} (largest side {MAX_TEXTURE_SIDE})",
            t.name, t.width, t.height
        ))
    }
}

/// Decodes an encoded PNG / JPEG image. Colour channels are treated as sRGB and converted to
/// linear; alpha is kept as is (linear). Row 0 is the top row. The decoder may allocate at
/// most [`MAX_DECODE_BYTES`]; an image with a side over [`MAX_TEXTURE_SIDE`] is box-filtered
/// down ([`texels::reduce_to_side`], in linear values) as it is converted, so the linear
/// texture never exists at full size: peak memory is the decoded 8-bit image plus the result.
pub(crate) fn decode_srgb_texture(name: String, bytes: &[u8]) -> Result<Decoded, String> {
    let mut reader =
        image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format().map_err(|e| e.to_string())?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(MAX_DECODE_BYTES);
    reader.limits(limits);
    let img = reader.decode().map_err(|e| e.to_string())?;
    let (width, height) = (img.width(), img.height());
    let (w, h) = (width as usize, height as usize);
    let lut: Vec<f32> = (0..256).map(|i| srgb_to_linear(i as f32 / 255.0)).collect();
    let rgba8 = |p: [u8; 4]| [lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize], f32::from(p[3]) / 255.0];
    // Generic, not `dyn`: one call per source texel.
    fn reduce(w: usize, h: usize, get: impl Fn(usize, usize) -> LinearRgba + Sync) -> (usize, usize, Vec<LinearRgba>) {
        texels::reduce_to_side(w, h, MAX_TEXTURE_SIDE, get)
    }
    let (tw, th, texels_linear) = match &img {
        image::DynamicImage::ImageRgba8(b) => {
            let raw = b.as_raw();
            reduce(w, h, |x, y| {
                let i = 4 * (y * w + x);
                rgba8([raw[i], raw[i + 1], raw[i + 2], raw[i + 3]])
            })
        }
        image::DynamicImage::ImageRgb8(b) => {
            let raw = b.as_raw();
            reduce(w, h, |x, y| {
                let i = 3 * (y * w + x);
                rgba8([raw[i], raw[i + 1], raw[i + 2], 255])
            })
        }
        image::DynamicImage::ImageLuma8(b) => {
            let raw = b.as_raw();
            reduce(w, h, |x, y| {
                let l = raw[y * w + x];
                rgba8([l, l, l, 255])
            })
        }
        image::DynamicImage::ImageLumaA8(b) => {
            let raw = b.as_raw();
            reduce(w, h, |x, y| {
                let i = 2 * (y * w + x);
                rgba8([raw[i], raw[i], raw[i], raw[i + 1]])
            })
        }
        image::DynamicImage::ImageLuma16(_)
        | image::DynamicImage::ImageLumaA16(_)
        | image::DynamicImage::ImageRgb16(_)
        | image::DynamicImage::ImageRgba16(_)
        | image::DynamicImage::ImageRgb32F(_)
        | image::DynamicImage::ImageRgba32F(_) => {
            let f = img.to_rgba32f();
            let raw = f.as_raw();
            reduce(w, h, |x, y| {
                let i = 4 * (y * w + x);
                [srgb_to_linear(raw[i]), srgb_to_linear(raw[i + 1]), srgb_to_linear(raw[i + 2]), raw[i + 3]]
            })
        }
        _ => {
            let b = img.to_rgba8();
            let raw = b.as_raw();
            reduce(w, h, |x, y| {
                let i = 4 * (y * w + x);
                rgba8([raw[i], raw[i + 1], raw[i + 2], raw[i + 3]])
            })
        }
    };
    let reduced_from = (tw != w || th != h).then_some((width, height));
    Ok(Decoded { texture: Texture { name, width: tw as u32, height: th as u32, texels_linear }, reduced_from })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_eotf_known_values() {
        // Endpoints, the linear segment, and 0.5 -> 0.214041 (((0.5 + 0.055) / 1.055)^2.4).
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-7);
        assert!((srgb_to_linear(0.04) - 0.04 / 12.92).abs() < 1e-9);
        assert!((srgb_to_linear(0.5) - 0.214_041_14).abs() < 1e-6);
        // 188/255 -> 0.50289 (the usual "sRGB 188 is half linear" value).
        assert!((srgb_to_linear(188.0 / 255.0) - 0.502_886).abs() < 1e-5);
    }
}
