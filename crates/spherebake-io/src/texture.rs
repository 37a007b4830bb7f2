//! Texture decoding (PNG, JPEG) into linear RGBA f32.

use spherebake_geom::Texture;

/// The exact piecewise sRGB EOTF (IEC 61966-2-1): sRGB-encoded value in [0, 1] → linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    let c = f64::from(c);
    let l = if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) };
    l as f32
}

/// Decodes an encoded PNG / JPEG image. Colour channels are treated as sRGB and converted to
/// linear; alpha is kept as is (linear). Row 0 is the top row.
pub(crate) fn decode_srgb_texture(name: String, bytes: &[u8]) -> Result<Texture, String> {
    let img = image::load_from_memory(bytes).map_err(|e| e.to_string())?;
    let (width, height) = (img.width(), img.height());
    let texels_linear = match img {
        image::DynamicImage::ImageLuma16(_)
        | image::DynamicImage::ImageLumaA16(_)
        | image::DynamicImage::ImageRgb16(_)
        | image::DynamicImage::ImageRgba16(_)
        | image::DynamicImage::ImageRgb32F(_)
        | image::DynamicImage::ImageRgba32F(_) => img
            .to_rgba32f()
            .pixels()
            .map(|p| [srgb_to_linear(p[0]), srgb_to_linear(p[1]), srgb_to_linear(p[2]), p[3]])
            .collect(),
        _ => {
            let lut: Vec<f32> = (0..256).map(|i| srgb_to_linear(i as f32 / 255.0)).collect();
            img.to_rgba8()
                .pixels()
                .map(|p| [lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize], f32::from(p[3]) / 255.0])
                .collect()
        }
    };
    Ok(Texture { name, width, height, texels_linear })
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
