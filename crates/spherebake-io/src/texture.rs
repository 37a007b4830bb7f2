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

/// Texels all the textures of one model may hold together once decoded: 4 × 4096² (1 GiB of
/// linear RGBA f32; the albedo bake's mip chains add about as much again). See [`TexelBudget`].
pub const MAX_TOTAL_TEXELS: usize = 1 << 26;

/// Pixels the images of one model may decode together, counted from their headers before each
/// is decoded: 2³¹, 8 × 16 384² or 128 × 4096². Decoding costs about 25 ns a pixel (a 4096² PNG
/// about 0.4 s), so the pixels decoded take about a minute at most, however many images a
/// model names; past it an image is not decoded (the importers warn once and use the base
/// colour factor). See [`DecodeBudget`].
pub const MAX_DECODED_PIXELS: u64 = 1 << 31;

/// What a model's images may still cost to decode: pixels ([`MAX_DECODED_PIXELS`] unless the
/// import options say otherwise) and encoded bytes examined (the input budget,
/// `ImportOptions::max_input_bytes`: every image's bytes, also those of buffer views, which the
/// input budget counts once as their buffer however many views read them). The texel budget
/// bounds what the decoded textures keep; this bounds the work of decoding them, which a small
/// file naming thousands of large (or highly compressible) images would otherwise make
/// unbounded.
#[derive(Clone, Debug)]
pub(crate) struct DecodeBudget {
    pixels: (u64, u64),
    bytes: (u64, u64),
    /// The images not decoded for it: how many, and the first three described.
    skipped: usize,
    first: Vec<String>,
}

/// The error [`decode_srgb_texture`] and [`decode_mask`] give for an image past the
/// [`DecodeBudget`]: the importers give no warning of their own for it ([`DecodeBudget::warning`]
/// sums them up in one).
pub(crate) const OVER_DECODE_BUDGET: &str = "over the model's decode budget";

impl DecodeBudget {
    /// A budget of `pixels` pixels and `bytes` encoded bytes.
    pub fn new(pixels: u64, bytes: u64) -> Self {
        Self { pixels: (pixels, pixels), bytes: (bytes, bytes), skipped: 0, first: Vec::new() }
    }

    fn skip(&mut self, what: String) -> Result<(), String> {
        self.skipped += 1;
        if self.first.len() < 3 {
            self.first.push(what);
        }
        Err(OVER_DECODE_BUDGET.to_owned())
    }

    /// Charges an image's encoded bytes, before its header is read.
    fn charge_bytes(&mut self, name: &str, n: usize) -> Result<(), String> {
        let n = n as u64;
        if n > self.bytes.1 {
            return self.skip(format!("{name} ({n} bytes)"));
        }
        self.bytes.1 -= n;
        Ok(())
    }

    /// Charges a `w` × `h` image, before it is decoded.
    fn charge_pixels(&mut self, name: &str, w: u32, h: u32) -> Result<(), String> {
        let n = u64::from(w) * u64::from(h);
        if n > self.pixels.1 {
            return self.skip(format!("{name} ({w}×{h})"));
        }
        self.pixels.1 -= n;
        Ok(())
    }

    /// The one warning for the images not decoded, naming the first three; `None` when every
    /// image fitted.
    pub fn warning(&self) -> Option<String> {
        let more = match self.skipped {
            n if n > 3 => format!(", and {} more", n - 3),
            _ => String::new(),
        };
        (self.skipped > 0).then(|| {
            format!(
                "the images would decode more than {} pixels, or {} encoded bytes, together; {} not decoded (the materials that read them use the base colour factor): {}{more}",
                self.pixels.0,
                self.bytes.0,
                self.skipped,
                self.first.join(", ")
            )
        })
    }
}

/// Holds a model's decoded textures to [`MAX_TOTAL_TEXELS`] together: after each texture is
/// added, the largest (the first added of equal size) is halved ([`texels::halve`], the box
/// filter the side cap uses, so the result is the source box-filtered to that size) until
/// they fit. Textures that fit keep their size: four 4096² textures fit exactly, and anything
/// more halves the first of them; a small file naming thousands of large images stays within
/// the bound. Peak memory is the bound plus the one texture being added. O(log n) per
/// halving. Like the side cap's reduction, a halving averages colour without weighting it by
/// alpha, so at a masked texture's cut-out edges the reduced level 0 mixes in the cut-out
/// texels' colour (the albedo's α-weighted mip chain starts from that level).
pub(crate) struct TexelBudget {
    /// The texels the textures may hold together ([`MAX_TOTAL_TEXELS`] unless the import
    /// options say otherwise).
    cap: usize,
    total: usize,
    /// (texels, reversed index) of every texture added; entries whose texels are stale are
    /// skipped when popped.
    heap: std::collections::BinaryHeap<(usize, std::cmp::Reverse<usize>)>,
    /// Each texture halved, with its size when added, in the order first halved.
    reduced: Vec<(usize, (u32, u32))>,
}

impl TexelBudget {
    /// A budget of `cap` texels.
    pub fn new(cap: usize) -> Self {
        Self { cap, total: 0, heap: Default::default(), reduced: Vec::new() }
    }

    /// Accounts for `textures[index]`, just added, and halves the largest until the textures
    /// hold at most the cap.
    pub fn add(&mut self, textures: &mut [Texture], index: usize) {
        let count = |t: &Texture| t.width as usize * t.height as usize;
        let Some(t) = textures.get(index) else { return };
        self.total += count(t);
        self.heap.push((count(t), std::cmp::Reverse(index)));
        while self.total > self.cap {
            let Some((n, std::cmp::Reverse(i))) = self.heap.pop() else { break };
            let t = &mut textures[i];
            if n != count(t) {
                continue; // stale: halved since
            }
            if n <= 1 {
                break; // every texture is 1×1
            }
            if !self.reduced.iter().any(|r| r.0 == i) {
                self.reduced.push((i, (t.width, t.height)));
            }
            let (w, h, v) = texels::halve(t.width as usize, t.height as usize, &t.texels_linear);
            (t.width, t.height, t.texels_linear) = (w as u32, h as u32, v);
            self.total -= n - count(t);
            self.heap.push((count(t), std::cmp::Reverse(i)));
        }
    }

    /// The one warning for the textures halved, naming the first three; `None` when none was.
    pub fn warning(&self, textures: &[Texture]) -> Option<String> {
        let named: Vec<String> = self
            .reduced
            .iter()
            .take(3)
            .map(|&(i, (w, h))| {
                let t = &textures[i];
                format!("{} {w}×{h} → {}×{}", t.name, t.width, t.height)
            })
            .collect();
        let more = match self.reduced.len() {
            n if n > 3 => format!(", and {} more", n - 3),
            _ => String::new(),
        };
        (!named.is_empty()).then(|| {
            format!(
                "the textures would hold more than {} texels together; the largest are read box-filtered further: {}{more}",
                self.cap,
                named.join(", ")
            )
        })
    }
}

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

/// Decodes an encoded PNG / JPEG / WebP image. Colour channels are treated as sRGB and converted to
/// linear; alpha is kept as is (linear). Row 0 is the top row. The decoded image may take at
/// most [`MAX_DECODE_BYTES`]; an image with a side over [`MAX_TEXTURE_SIDE`] is box-filtered
/// down ([`texels::reduce_to_side`], in linear values) as it is read, so no converted copy
/// exists at full size: peak memory is the decoded image (in its own layout, 8- or 16-bit or
/// float) plus the result, and for a progressive JPEG its decoder's coefficient buffers. Its
/// bytes, then (once its header is read and fits the memory cap) its pixels are charged to
/// `budget`; an image past it is not decoded.
pub(crate) fn decode_srgb_texture(name: String, bytes: &[u8], budget: &mut DecodeBudget) -> Result<Decoded, String> {
    decode_texture(name, bytes, true, budget).map(|(d, _)| d)
}

/// [`decode_srgb_texture`] with the colour channels through the sRGB EOTF when `srgb`, else as
/// stored (normalised to [0, 1]: data such as an MTL `map_d` mask). Also returns whether the
/// image has an alpha channel.
fn decode_texture(
    name: String,
    bytes: &[u8],
    srgb: bool,
    budget: &mut DecodeBudget,
) -> Result<(Decoded, bool), String> {
    budget.charge_bytes(&name, bytes.len())?;
    let bytes = &*without_compressed_png_chunks(bytes);
    let limits = || {
        let mut limits = image::Limits::default();
        limits.max_alloc = Some(MAX_DECODE_BYTES);
        limits
    };
    let mut reader =
        image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format().map_err(|e| e.to_string())?;
    reader.limits(limits());
    // Say which image and which cap, not only the image crate's "Memory limit exceeded".
    let too_large = |size: Option<(u32, u32)>| {
        format!(
            "decoded, {}would take more than the {:.2} GiB a texture may (memory limit exceeded)",
            size.map_or_else(String::new, |(w, h)| format!("its {w}×{h} pixels ")),
            MAX_DECODE_BYTES as f64 / f64::from(1u32 << 30)
        )
    };
    let message = |e: image::ImageError, size| match e {
        image::ImageError::Limits(_) => too_large(size),
        e => e.to_string(),
    };
    // The header, under the decode's limits; the image is charged only once it is known to fit
    // them. Then the decoder's allocations are held to what the image itself leaves of the cap,
    // as `ImageReader::decode` does.
    use image::ImageDecoder;
    let mut decoder = reader.into_decoder().map_err(|e| message(e, None))?;
    let (width, height) = decoder.dimensions();
    let size = Some((width, height));
    let mut rest = limits();
    rest.reserve(decoder.total_bytes()).map_err(|e| message(e, size))?;
    budget.charge_pixels(&name, width, height)?;
    decoder.set_limits(rest).map_err(|e| message(e, size))?;
    let img = image::DynamicImage::from_decoder(decoder).map_err(|e| message(e, size))?;
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
    let (tw, th, texels_linear) = match &img {
        image::DynamicImage::ImageLuma8(b) => layout(b.as_raw(), w, h, 1, u8c, u8a),
        image::DynamicImage::ImageLumaA8(b) => layout(b.as_raw(), w, h, 2, u8c, u8a),
        image::DynamicImage::ImageRgb8(b) => layout(b.as_raw(), w, h, 3, u8c, u8a),
        image::DynamicImage::ImageRgba8(b) => layout(b.as_raw(), w, h, 4, u8c, u8a),
        image::DynamicImage::ImageLuma16(b) => layout(b.as_raw(), w, h, 1, u16c, u16a),
        image::DynamicImage::ImageLumaA16(b) => layout(b.as_raw(), w, h, 2, u16c, u16a),
        image::DynamicImage::ImageRgb16(b) => layout(b.as_raw(), w, h, 3, u16c, u16a),
        image::DynamicImage::ImageRgba16(b) => layout(b.as_raw(), w, h, 4, u16c, u16a),
        image::DynamicImage::ImageRgb32F(b) => layout(b.as_raw(), w, h, 3, curve, |v| v),
        image::DynamicImage::ImageRgba32F(b) => layout(b.as_raw(), w, h, 4, curve, |v| v),
        // A layout this version of the image crate does not have.
        _ => layout(img.to_rgba8().as_raw(), w, h, 4, u8c, u8a),
    };
    let reduced_from = (tw != w || th != h).then_some((width, height));
    let texture = Texture { name, width: tw as u32, height: th as u32, texels_linear };
    Ok((Decoded { texture, reduced_from }, has_alpha))
}

/// A PNG's bytes without its compressed ancillary chunks (iCCP, zTXt, iTXt): the decoder
/// inflates them while it reads the header, up to the per-image memory cap, work that neither
/// the pixels nor the bytes of the image measure (a 0.5 MB colour profile can inflate to
/// 500 MiB), and the texture needs none of them (colour is read as sRGB, text is not read). Any
/// other input, or a PNG whose chunks cannot be walked to the end, is returned as it is (the
/// decoder then reports what is wrong); a PNG without such chunks is not copied.
fn without_compressed_png_chunks(bytes: &[u8]) -> std::borrow::Cow<'_, [u8]> {
    const SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";
    const DROPPED: [&[u8; 4]; 3] = [b"iCCP", b"zTXt", b"iTXt"];
    if !bytes.starts_with(SIGNATURE) {
        return bytes.into();
    }
    // Chunks: length (4, big-endian), type (4), data, CRC (4).
    let mut chunks = Vec::new();
    let mut at = SIGNATURE.len();
    while at < bytes.len() {
        let Some(head) = bytes.get(at..at + 8) else { return bytes.into() };
        let len = u32::from_be_bytes([head[0], head[1], head[2], head[3]]) as usize;
        let Some(end) = at.checked_add(12).and_then(|x| x.checked_add(len)).filter(|&e| e <= bytes.len()) else {
            return bytes.into();
        };
        chunks.push((at, end, DROPPED.iter().any(|t| head[4..8] == t[..])));
        if &head[4..8] == b"IEND" {
            break; // what follows is not part of the image
        }
        at = end;
    }
    if !chunks.iter().any(|c| c.2) {
        return bytes.into();
    }
    let mut out = SIGNATURE.to_vec();
    for (a, b, _) in chunks.into_iter().filter(|c| !c.2) {
        out.extend_from_slice(&bytes[a..b]);
    }
    out.into()
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
    pub reduced_from: Option<(u32, u32)>,
}

/// Decodes an image as an MTL scalar texture (`map_d`): values as stored (no sRGB curve, a
/// mask is data), of the channel `channel` names; luminance is Rec. 709's
/// 0.2126 R + 0.7152 G + 0.0722 B. Reduced and charged as [`decode_srgb_texture`] is.
pub(crate) fn decode_mask(
    name: String,
    bytes: &[u8],
    channel: MaskChannel,
    budget: &mut DecodeBudget,
) -> Result<Mask, String> {
    let (d, has_alpha) = decode_texture(name, bytes, false, budget)?;
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
    Ok(Mask { width: t.width, height: t.height, values, reduced_from: d.reduced_from })
}

/// A `w`×`h` image of `channels` interleaved channels (1 grey, 2 grey + alpha, 3 RGB, 4 RGBA;
/// a missing alpha is 1) as linear RGBA, colour channels through `colour` and alpha through
/// `alpha`, reduced to at most [`MAX_TEXTURE_SIDE`] a side ([`texels::reduce_to_side`]).
fn layout<T: Copy + Sync>(
    raw: &[T],
    w: usize,
    h: usize,
    channels: usize,
    colour: impl Fn(T) -> f32 + Sync,
    alpha: impl Fn(T) -> f32 + Sync,
) -> (usize, usize, Vec<LinearRgba>) {
    texels::reduce_to_side(w, h, MAX_TEXTURE_SIDE, |x, y| {
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
    /// A PNG with a colour profile, compressed and uncompressed text and bytes after IEND: the
    /// compressed chunks go, the rest stays in order, and the pixels are the same.
    #[test]
    fn compressed_png_chunks_are_dropped_before_decoding() {
        let mut png = std::io::Cursor::new(Vec::new());
        image::RgbaImage::from_fn(5, 3, |x, y| image::Rgba([x as u8 * 40, y as u8 * 70, 9, 200 - x as u8]))
            .write_to(&mut png, image::ImageFormat::Png)
            .unwrap();
        let png = png.into_inner();
        use spherebake_testkit::png::chunk;
        let chunks = |b: &[u8]| {
            let (mut at, mut out) = (8, Vec::new());
            while at + 8 <= b.len() {
                let n = u32::from_be_bytes(b[at..at + 4].try_into().unwrap()) as usize;
                out.push(String::from_utf8_lossy(&b[at + 4..at + 8]).into_owned());
                at += 12 + n;
            }
            out
        };
        // A zlib stream (one stored block) of 1000 zeros: a profile's or a text's payload.
        let zeros = {
            let data = vec![0u8; 1000];
            let n = data.len() as u16;
            let mut z = vec![0x78, 0x01, 0x01];
            z.extend(n.to_le_bytes());
            z.extend((!n).to_le_bytes());
            z.extend(&data);
            let (a, b) = data.iter().fold((1u32, 0u32), |(a, b), &x| {
                let a = (a + u32::from(x)) % 65_521;
                (a, (b + a) % 65_521)
            });
            z.extend(((b << 16) | a).to_be_bytes());
            z
        };
        let ihdr_end = 8 + 12 + 13;
        let mut with = png[..ihdr_end].to_vec();
        with.extend(chunk(b"iCCP", &[b"p".as_slice(), &[0, 0], &zeros].concat()));
        with.extend(chunk(b"tEXt", b"Comment\0kept"));
        with.extend(chunk(b"zTXt", &[b"k".as_slice(), &[0, 0], &zeros].concat()));
        with.extend(chunk(b"iTXt", &[b"k".as_slice(), &[0, 1, 0, 0, 0], &zeros].concat()));
        with.extend(&png[ihdr_end..]);
        with.extend(b"trailing");
        let got = super::without_compressed_png_chunks(&with);
        assert_eq!(chunks(&got), ["IHDR", "tEXt", "IDAT", "IEND"]);
        assert!(matches!(super::without_compressed_png_chunks(&png), std::borrow::Cow::Borrowed(_)));
        let truncated = &with[..with.len() - 25]; // into the IDAT chunk
        assert!(matches!(super::without_compressed_png_chunks(truncated), std::borrow::Cow::Borrowed(_)));
        let mut budget = super::DecodeBudget::new(1 << 20, 1 << 20);
        let a = super::decode_srgb_texture("a".into(), &png, &mut budget).unwrap().texture;
        let b = super::decode_srgb_texture("b".into(), &with, &mut budget).unwrap().texture;
        assert_eq!((a.width, a.height, a.texels_linear), (b.width, b.height, b.texels_linear));
    }
    #[test]
    fn the_decode_budget_charges_bytes_then_pixels_and_sums_up_what_it_skipped() {
        let mut b = super::DecodeBudget::new(100, 1000);
        assert!(b.charge_bytes("a", 600).is_ok());
        assert!(b.charge_pixels("a", 10, 10).is_ok(), "exactly the pixels left");
        assert_eq!(b.charge_bytes("b", 401).unwrap_err(), super::OVER_DECODE_BUDGET);
        assert!(b.charge_bytes("c", 400).is_ok(), "exactly the bytes left");
        assert_eq!(b.charge_pixels("c", 1, 1).unwrap_err(), super::OVER_DECODE_BUDGET);
        for name in ["d", "e"] {
            assert!(b.charge_bytes(name, 1).is_err());
        }
        assert_eq!(
            b.warning().unwrap(),
            "the images would decode more than 100 pixels, or 1000 encoded bytes, together; 4 not decoded \
             (the materials that read them use the base colour factor): b (401 bytes), c (1×1), d (1 bytes), and 1 more"
        );
        assert!(super::DecodeBudget::new(1, 1).warning().is_none());
    }
    use super::*;

    fn tex(name: &str, w: u32, h: u32, seed: u32) -> Texture {
        let texels = (0..w * h).map(|i| [((i * 7 + seed) % 11) as f32 / 10.0, 0.5, (i % 3) as f32, 1.0]).collect();
        Texture { name: name.into(), width: w, height: h, texels_linear: texels }
    }

    /// The largest texture (the first of equal size) is halved, box-filtered, until the total
    /// fits; textures that fit are untouched; the warning names the first three halved.
    #[test]
    fn the_texel_budget_halves_the_largest_until_the_textures_fit() {
        let mut b = TexelBudget::new(200);
        let mut t = vec![tex("a", 8, 8, 1), tex("b", 16, 16, 2)];
        b.add(&mut t, 0);
        b.add(&mut t, 1);
        // 64 + 256 = 320 > 200: b (the largest) → 8×8, 128 ≤ 200.
        assert_eq!([(t[0].width, t[0].height), (t[1].width, t[1].height)], [(8, 8), (8, 8)]);
        let src = tex("b", 16, 16, 2);
        for y in 0..8 {
            for x in 0..8 {
                let at = |xx: usize, yy: usize| src.texels_linear[yy * 16 + xx];
                let got = t[1].texels_linear[y * 8 + x];
                for (c, &g) in got.iter().enumerate() {
                    let mean = (at(2 * x, 2 * y)[c]
                        + at(2 * x + 1, 2 * y)[c]
                        + at(2 * x, 2 * y + 1)[c]
                        + at(2 * x + 1, 2 * y + 1)[c]) as f64
                        / 4.0;
                    assert!((f64::from(g) - mean).abs() < 1e-6, "({x}, {y}) {c}");
                }
            }
        }
        assert_eq!(t[0].texels_linear, tex("a", 8, 8, 1).texels_linear, "a fit: untouched");
        // Two more 8×8 (256 > 200): the first of the equal largest (a) is halved → 208, then b.
        t.push(tex("c", 8, 8, 3));
        b.add(&mut t, 2);
        t.push(tex("d", 8, 8, 4));
        b.add(&mut t, 3);
        let sizes: Vec<u32> = t.iter().map(|x| x.width).collect();
        assert_eq!(sizes, [4, 4, 8, 8]);
        let w = b.warning(&t).unwrap();
        assert!(w.contains("more than 200 texels") && w.contains("b 16×16 → 4×4, a 8×8 → 4×4"), "{w}");
        assert!(!w.contains(", and"), "{w}");
        // Nothing halved: no warning. Only 1×1 textures over the cap: the loop ends.
        let mut b = TexelBudget::new(1);
        let mut one = vec![tex("x", 1, 1, 0), tex("y", 1, 1, 0)];
        b.add(&mut one, 0);
        assert!(b.warning(&one).is_none());
        b.add(&mut one, 1);
        assert_eq!((one[1].width, b.warning(&one)), (1, None));
        // More than three halved: the rest are counted.
        let mut b = TexelBudget::new(10);
        let mut many: Vec<Texture> = (0..5).map(|i| tex(&format!("t{i}"), 4, 4, i)).collect();
        for i in 0..5 {
            b.add(&mut many, i);
        }
        assert!(b.total <= 10 && b.warning(&many).unwrap().ends_with(", and 2 more"), "{:?}", b.warning(&many));
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
