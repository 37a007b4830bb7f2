//! Texture decoding (PNG, JPEG, WebP) into linear RGBA f32.

use spherebake_geom::texels::{self, MAX_TEXTURE_SIDE};
use spherebake_geom::{LinearRgba, Texture};

/// The exact piecewise sRGB EOTF (IEC 61966-2-1): sRGB-encoded value in [0, 1] → linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    let c = f64::from(c);
    let l = if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) };
    l as f32
}

/// Most bytes the decoded image of one texture may take (the image crate's `max_alloc`): a
/// 16 384² RGBA8 image (1 GiB) and room for the PNG decoder's own buffers. A larger image is
/// refused before it is inflated (the importers then warn and use the base colour factor), so
/// a small file that would inflate to a huge image cannot exhaust memory. The JPEG decoder
/// counts only its output against it: a progressive JPEG also holds its coefficients (i16,
/// about twice the output at 4:4:4) uncounted. The image crate's own default is 512 MiB
/// (8 192² RGBA8).
pub const MAX_DECODE_BYTES: u64 = (1 << 30) + (256 << 20);

/// Texels all the textures of one model may hold once decoded: 4 × 4096² (1 GiB of linear
/// RGBA f32; the albedo bake's mip chains add about as much again). A model with more
/// texture than that shares it evenly ([`texel_share`]): each texture is halved (box-filtered,
/// as [`MAX_TEXTURE_SIDE`] reduces) until it holds at most its share, so a small file naming
/// many huge images cannot exhaust memory, and a model of many 4K textures still bakes (the
/// bake reads them at its cube maps' footprint, a few texels per cube-map texel).
pub const MAX_TOTAL_TEXELS: usize = 1 << 26;

/// The texels each of `textures` textures may hold: [`MAX_TOTAL_TEXELS`] shared evenly
/// (at least 1).
pub(crate) fn texel_share(textures: usize) -> usize {
    (MAX_TOTAL_TEXELS / textures.max(1)).max(1)
}

/// The largest side a `w`×`h` image keeps when read with at most `max_texels` texels:
/// halvings ([`texels::half_size`]) until both sides are at most [`MAX_TEXTURE_SIDE`] and
/// the texels at most `max_texels` (a 1×1 image always fits).
fn kept_side(w: usize, h: usize, max_texels: usize) -> usize {
    let (mut w, mut h) = (w.max(1), h.max(1));
    while w.max(h) > MAX_TEXTURE_SIDE || (w.saturating_mul(h) > max_texels && (w, h) != (1, 1)) {
        (w, h) = texels::half_size(w, h);
    }
    w.max(h)
}

/// A decoded texture, and the size of the source image when it was reduced to `texture`'s size
/// (larger than [`MAX_TEXTURE_SIDE`], or than its share of [`MAX_TOTAL_TEXELS`]).
pub(crate) struct Decoded {
    pub texture: Texture,
    pub reduced_from: Option<(u32, u32)>,
}

impl Decoded {
    /// Whether it was reduced below [`MAX_TEXTURE_SIDE`] for its share of [`MAX_TOTAL_TEXELS`].
    fn reduced_for_share(&self) -> bool {
        let t = &self.texture;
        self.reduced_from
            .is_some_and(|(w, h)| kept_side(w as usize, h as usize, usize::MAX) > t.width.max(t.height) as usize)
    }

    /// The warning the importers give for a texture reduced to [`MAX_TEXTURE_SIDE`], if it was
    /// (a reduction for its share of the texels is reported once for all, [`Self::shared`]).
    pub fn reduction_warning(&self, context: &str) -> Option<String> {
        let (w, h) = self.reduced_from.filter(|_| !self.reduced_for_share())?;
        let t = &self.texture;
        Some(format!(
            "{context}: {} is {w}×{h}; the albedo bake reads it box-filtered to {}×{} (largest side {MAX_TEXTURE_SIDE})",
            t.name, t.width, t.height
        ))
    }

    /// "name W×H → w×h" when it was reduced for its share of [`MAX_TOTAL_TEXELS`], for
    /// [`share_warning`].
    pub fn shared(&self) -> Option<String> {
        let (w, h) = self.reduced_from.filter(|_| self.reduced_for_share())?;
        let t = &self.texture;
        Some(format!("{} {w}×{h} → {}×{}", t.name, t.width, t.height))
    }
}

/// The one warning for the textures of a model reduced for their share of
/// [`MAX_TOTAL_TEXELS`] (`reduced`: [`Decoded::shared`] and the masks' alike, in reading
/// order), naming the first; `None` when there are none.
pub(crate) fn share_warning(reduced: &[String], share: usize) -> Option<String> {
    let first = reduced.first()?;
    let more = match reduced.len() {
        1 => String::new(),
        n => format!(", and {} more", n - 1),
    };
    Some(format!(
        "{} texture(s) read box-filtered to at most {share} texels each, so that all of the model's textures hold at most \
         {MAX_TOTAL_TEXELS} (4 × 4096²): {first}{more}",
        reduced.len()
    ))
}

/// Decodes an encoded PNG / JPEG / WebP image. Colour channels are treated as sRGB and converted to
/// linear; alpha is kept as is (linear). Row 0 is the top row. The decoded image may take at
/// most [`MAX_DECODE_BYTES`]; an image with a side over [`MAX_TEXTURE_SIDE`] is box-filtered
/// down ([`texels::reduce_to_side`], in linear values) as it is read, so no converted copy
/// exists at full size: peak memory is the decoded image (in its own layout, 8- or 16-bit or
/// float) plus the result, and for a progressive JPEG its decoder's coefficient buffers.
pub(crate) fn decode_srgb_texture(name: String, bytes: &[u8], max_texels: usize) -> Result<Decoded, String> {
    decode_texture(name, bytes, true, max_texels).map(|(d, _)| d)
}

/// [`decode_srgb_texture`] with the colour channels through the sRGB EOTF when `srgb`, else as
/// stored (normalised to [0, 1]: data such as an MTL `map_d` mask). Also returns whether the
/// image has an alpha channel. Reduced to at most `max_texels` texels ([`texel_share`]).
fn decode_texture(name: String, bytes: &[u8], srgb: bool, max_texels: usize) -> Result<(Decoded, bool), String> {
    let mut reader =
        image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format().map_err(|e| e.to_string())?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(MAX_DECODE_BYTES);
    reader.limits(limits);
    let img = reader.decode().map_err(|e| match e {
        // Say which image and which cap, not only the image crate's "Memory limit exceeded".
        image::ImageError::Limits(_) => {
            let size = image::ImageReader::new(std::io::Cursor::new(bytes))
                .with_guessed_format()
                .ok()
                .and_then(|r| r.into_dimensions().ok())
                .map_or_else(String::new, |(w, h)| format!("its {w}×{h} pixels "));
            format!(
                "decoded, {size}would take more than the {:.2} GiB a texture may (memory limit exceeded)",
                MAX_DECODE_BYTES as f64 / f64::from(1u32 << 30)
            )
        }
        e => e.to_string(),
    })?;
    let (width, height) = (img.width(), img.height());
    let (w, h) = (width as usize, height as usize);
    let curve = |v: f32| if srgb { srgb_to_linear(v) } else { v };
    let lut: Vec<f32> = (0..256).map(|i| curve(i as f32 / 255.0)).collect();
    // Colour channels through the sRGB EOTF (8-bit by table) when `srgb`, alpha as stored; u16
    // and u8 as the image crate normalises them (v / 65535, v / 255). Read in place, no
    // converted copy.
    let u8c = |v: u8| lut[v as usize];
    let u8a = |v: u8| f32::from(v) / 255.0;
    let u16c = |v: u16| curve(f32::from(v) / 65535.0);
    let u16a = |v: u16| f32::from(v) / 65535.0;
    let has_alpha = img.color().has_alpha();
    let side = kept_side(w, h, max_texels);
    let (tw, th, texels_linear) = match &img {
        image::DynamicImage::ImageLuma8(b) => layout(b.as_raw(), w, h, 1, side, u8c, u8a),
        image::DynamicImage::ImageLumaA8(b) => layout(b.as_raw(), w, h, 2, side, u8c, u8a),
        image::DynamicImage::ImageRgb8(b) => layout(b.as_raw(), w, h, 3, side, u8c, u8a),
        image::DynamicImage::ImageRgba8(b) => layout(b.as_raw(), w, h, 4, side, u8c, u8a),
        image::DynamicImage::ImageLuma16(b) => layout(b.as_raw(), w, h, 1, side, u16c, u16a),
        image::DynamicImage::ImageLumaA16(b) => layout(b.as_raw(), w, h, 2, side, u16c, u16a),
        image::DynamicImage::ImageRgb16(b) => layout(b.as_raw(), w, h, 3, side, u16c, u16a),
        image::DynamicImage::ImageRgba16(b) => layout(b.as_raw(), w, h, 4, side, u16c, u16a),
        image::DynamicImage::ImageRgb32F(b) => layout(b.as_raw(), w, h, 3, side, curve, |v| v),
        image::DynamicImage::ImageRgba32F(b) => layout(b.as_raw(), w, h, 4, side, curve, |v| v),
        // A layout this version of the image crate does not have.
        _ => layout(img.to_rgba8().as_raw(), w, h, 4, side, u8c, u8a),
    };
    let reduced_from = (tw != w || th != h).then_some((width, height));
    let texture = Texture { name, width: tw as u32, height: th as u32, texels_linear };
    Ok((Decoded { texture, reduced_from }, has_alpha))
}

/// Which channel of an image an MTL scalar texture (`map_d`) reads: `-imfchan r|g|b|m|l`
/// (`m`, matte, is alpha; `l` luminance), or by default the alpha channel when the image has
/// one that is not opaque everywhere (an exporter that points `map_d` at the RGBA diffuse
/// texture, as Blender's does), else the luminance (a grey mask, as in the Sponza OBJ).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum MaskChannel {
    R,
    G,
    B,
    Alpha,
    Luminance,
    Auto,
}

/// A scalar texture: `width` × `height` values in [0, 1], row-major, row 0 the top row.
pub(crate) struct Mask {
    pub width: u32,
    pub height: u32,
    pub values: Vec<f32>,
    /// The source's size when it was reduced to [`MAX_TEXTURE_SIDE`].
    pub reduced_from: Option<(u32, u32)>,
    /// [`Decoded::shared`].
    pub shared: Option<String>,
}

/// Decodes an image as an MTL scalar texture (`map_d`): values as stored (no sRGB curve, a
/// mask is data), of the channel `channel` names; luminance is Rec. 709's
/// 0.2126 R + 0.7152 G + 0.0722 B. Reduced as [`decode_srgb_texture`] reduces, to at most
/// `max_texels` texels.
pub(crate) fn decode_mask(name: String, bytes: &[u8], channel: MaskChannel, max_texels: usize) -> Result<Mask, String> {
    let (d, has_alpha) = decode_texture(name, bytes, false, max_texels)?;
    let (reduced_from, shared) = match d.shared() {
        Some(note) => (None, Some(note)),
        None => (d.reduced_from, None),
    };
    let t = d.texture;
    let channel = match channel {
        MaskChannel::Auto if has_alpha && t.texels_linear.iter().any(|p| p[3] < 1.0) => MaskChannel::Alpha,
        MaskChannel::Auto => MaskChannel::Luminance,
        c => c,
    };
    let values = t
        .texels_linear
        .iter()
        .map(|p| match channel {
            MaskChannel::R => p[0],
            MaskChannel::G => p[1],
            MaskChannel::B => p[2],
            MaskChannel::Alpha => p[3],
            _ => 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2],
        })
        .collect();
    Ok(Mask { width: t.width, height: t.height, values, reduced_from, shared })
}

/// A `w`×`h` image of `channels` interleaved channels (1 grey, 2 grey + alpha, 3 RGB, 4 RGBA;
/// a missing alpha is 1) as linear RGBA, colour channels through `colour` and alpha through
/// `alpha`, reduced to at most `side` a side ([`texels::reduce_to_side`]).
fn layout<T: Copy + Sync>(
    raw: &[T],
    w: usize,
    h: usize,
    channels: usize,
    side: usize,
    colour: impl Fn(T) -> f32 + Sync,
    alpha: impl Fn(T) -> f32 + Sync,
) -> (usize, usize, Vec<LinearRgba>) {
    texels::reduce_to_side(w, h, side, |x, y| {
        let p = &raw[channels * (y * w + x)..][..channels];
        match *p {
            [l] => {
                let l = colour(l);
                [l, l, l, 1.0]
            }
            [l, a] => {
                let l = colour(l);
                [l, l, l, alpha(a)]
            }
            [r, g, b] => [colour(r), colour(g), colour(b), 1.0],
            [r, g, b, a, ..] => [colour(r), colour(g), colour(b), alpha(a)],
            [] => [0.0; 4],
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The side kept: halvings (floor, at least 1) until the side cap and the texel share hold.
    #[test]
    fn the_kept_side_halves_until_both_caps_hold() {
        assert_eq!(kept_side(4096, 4096, usize::MAX), 4096);
        assert_eq!(kept_side(8192, 1, usize::MAX), 4096);
        assert_eq!(kept_side(4096, 4096, (1 << 24) - 1), 2048);
        assert_eq!(kept_side(4096, 4096, 1 << 24), 4096);
        // 5000 × 3000 → 2500 × 1500 (3.75 M) → 1250 × 750 (0.94 M ≤ 1 M).
        assert_eq!(kept_side(5000, 3000, 1_000_000), 1250);
        assert_eq!(kept_side(3, 1, 1), 1);
        assert_eq!(kept_side(1, 1, 0), 1);
        assert_eq!(texel_share(0), MAX_TOTAL_TEXELS);
        assert_eq!(texel_share(3), MAX_TOTAL_TEXELS / 3);
        assert_eq!(texel_share(usize::MAX), 1);
    }

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
