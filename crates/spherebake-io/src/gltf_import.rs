//! glTF 2.0 import (`.gltf` with external or data-URI buffers, `.glb`).
//!
//! The JSON is parsed with serde_json and prepared by [`crate::gltf_ext`] (required extensions,
//! meshopt views, texture-extension sources, instancing); the `gltf` crate then deserializes and
//! validates it. Buffers (meshopt views decoded), images and accessors are read here with checked
//! arithmetic so that no input can make the importer panic.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{DMat3, DMat4, DQuat, DVec3, Mat4, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::{Mode, Semantic};
use spherebake_geom::{
    AnimChannel, AnimPath, Animation, Bone, FilterMode, Interpolation, Material, Mesh, Node, Skeleton, Skin,
    SkinInfluences, TextureRef, UvTransform, WrapMode, NO_UV,
};

use crate::gltf_ext;
use crate::texture::{decode_srgb_texture, DecodeBudget, TexelBudget, OVER_DECODE_BUDGET};
use crate::{Ctx, ImportedPart, IoError, ReadLimit, MAX_IMAGE_BYTES};

/// Most vertices one import may produce (all instances together): bounds memory for files whose
/// instancing multiplies a large mesh, and keeps vertex indices within `u32`.
const MAX_VERTICES: usize = 1 << 27;

/// Vertices one import may produce (all placements together) per byte of the input budget
/// (`ImportOptions::max_input_bytes`, `--max-input-mb`), up to [`MAX_VERTICES`]. The densest
/// honest encoding stores a vertex in 4 bytes (quantized positions), so a file that fits the
/// budget expands this far only through instancing or nodes sharing a mesh; a tiny file whose
/// accessors claim millions of vertices (no buffer view, or placed by many nodes) stops here,
/// before they are read, and `--max-input-mb` raises the limit with the budget.
const VERTICES_PER_BUDGET_BYTE: u64 = 1;

/// Most triangles one import may produce (all placements together), as [`MAX_VERTICES`].
const MAX_TRIANGLES: usize = 1 << 27;

/// Triangles one import may produce per byte of the input budget, up to [`MAX_TRIANGLES`], as
/// [`VERTICES_PER_BUDGET_BYTE`]: checked before a primitive's indices are read.
const TRIANGLES_PER_BUDGET_BYTE: u64 = 1;

/// Triangles a primitive of `corners` indices (or vertices) makes: strips and fans one per
/// corner after the second, lists one per three.
fn triangles_of(mode: Mode, corners: usize) -> usize {
    match mode {
        Mode::TriangleStrip | Mode::TriangleFan => corners.saturating_sub(2),
        _ => corners / 3,
    }
}

/// Largest accessor (in components) accepted without a buffer view (zeros + sparse values).
const MAX_VIEWLESS_VALUES: usize = 1 << 26;

/// Values (components) one import may materialise from accessors without a buffer view, every
/// read counted, per byte of the input budget: nothing in the file bounds such an accessor (a
/// 794-byte file claimed 67 million zeros, read once per node), so the budget does.
const VIEWLESS_VALUES_PER_BUDGET_BYTE: u64 = 1;

/// Values one import may materialise from accessors without a buffer view per byte of the
/// glTF JSON that declares them (zeros with sparse substitutions, which honest files use for
/// small deltas): a 794-byte file claiming 22 million such vertices, placed by 6 nodes, ran for
/// 2 minutes in 10 GB within the default budget; 4096 per byte lets a 1 KB file expand to 4 M
/// values and stops it at once.
const VIEWLESS_VALUES_PER_JSON_BYTE: usize = 4096;

/// `per_byte` × `budget`, at most `cap`, and whether the budget (not `cap`) set it.
fn budget_limit(budget: u64, per_byte: u64, cap: usize) -> (usize, bool) {
    let l = budget.saturating_mul(per_byte);
    if l < cap as u64 {
        (l as usize, true)
    } else {
        (cap, false)
    }
}

/// Most morph-target vertex deltas one import reads (targets × vertices, every instance and
/// both POSITION and NORMAL counted): a few seconds of work at most.
const MAX_MORPH_VALUES: usize = 1 << 28;

const GLB_JSON: u32 = 0x4E4F_534A;
const GLB_BIN: u32 = 0x004E_4942;

/// Splits a `.glb` into its JSON and optional BIN chunk.
pub(crate) fn parse_glb<'b>(path: &Path, bytes: &'b [u8]) -> Result<(&'b [u8], Option<&'b [u8]>), IoError> {
    let p = || path.to_path_buf();
    let trunc = |what, offset, expected, actual| IoError::Truncated { path: p(), what, offset, expected, actual };
    if bytes.len() < 4 {
        return Err(trunc("GLB header", 0, 12, bytes.len()));
    }
    let magic: [u8; 4] = [bytes[0], bytes[1], bytes[2], bytes[3]];
    if &magic != b"glTF" {
        return Err(IoError::WrongMagic { path: p(), found: magic });
    }
    if bytes.len() < 12 {
        return Err(trunc("GLB header", 0, 12, bytes.len()));
    }
    let u32_at = |o: usize| u32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
    let version = u32_at(4);
    if version != 2 {
        return Err(IoError::UnsupportedGlbVersion { path: p(), version });
    }
    let length = u32_at(8) as usize;
    if length > bytes.len() {
        return Err(trunc("GLB file (header length)", 0, length, bytes.len()));
    }
    let bytes = &bytes[..length];
    let mut offset = 12;
    let mut json = None;
    let mut bin = None;
    while offset < bytes.len() {
        if bytes.len() - offset < 8 {
            return Err(trunc("GLB chunk header", offset, 8, bytes.len() - offset));
        }
        let chunk_len = u32_at(offset) as usize;
        let chunk_type = u32_at(offset + 4);
        let start = offset + 8;
        if bytes.len() - start < chunk_len {
            return Err(trunc("GLB chunk", start, chunk_len, bytes.len() - start));
        }
        let data = &bytes[start..start + chunk_len];
        match (chunk_type, json.is_some()) {
            (GLB_JSON, false) => json = Some(data),
            (GLB_JSON, true) => return Err(IoError::BadChunk { path: p(), offset, reason: "second JSON chunk" }),
            (_, false) => {
                return Err(IoError::BadChunk { path: p(), offset, reason: "first chunk is not the JSON chunk" })
            }
            (GLB_BIN, true) if bin.is_none() => bin = Some(data),
            _ => {} // unknown chunk types are skipped (glTF 2.0 §4.4.3)
        }
        offset = start + chunk_len;
    }
    let json = json.ok_or(IoError::BadChunk { path: p(), offset: 12, reason: "no JSON chunk" })?;
    // The chunk is padded to 4 bytes with spaces (glTF 2.0 §4.4.3.2); some writers pad with NULs,
    // which cgltf and gltfpack accept: trailing NULs are dropped before parsing.
    let json = &json[..json.iter().rposition(|&b| b != 0).map_or(0, |i| i + 1)];
    Ok((json, bin))
}

/// Decodes standard base64 (RFC 4648, padding optional, ASCII whitespace ignored).
pub(crate) fn decode_base64(s: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(s.len() / 4 * 3);
    let mut acc = 0u32;
    let mut bits = 0u32;
    let mut seen_pad = false;
    for (i, c) in s.bytes().enumerate() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' => {
                seen_pad = true;
                continue;
            }
            b' ' | b'\n' | b'\r' | b'\t' => continue,
            _ => return Err(format!("invalid base64 character {:?} at offset {i}", c as char)),
        };
        if seen_pad {
            return Err(format!("base64 data after padding at offset {i}"));
        }
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Ok(out)
}

/// Percent-decodes a relative URI reference into a path string.
fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            let hex = |c: u8| (c as char).to_digit(16);
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Where a URI's bytes come from.
enum UriData {
    Inline(Vec<u8>),
    File(PathBuf),
}

fn resolve_uri(dir: &Path, uri: &str) -> Result<UriData, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (meta, data) = rest.split_once(',').ok_or("data URI without ','")?;
        if !meta.ends_with(";base64") {
            return Err("data URI is not base64-encoded".into());
        }
        return decode_base64(data).map(UriData::Inline);
    }
    if uri.contains("://") {
        return Err(format!("URI scheme not supported: {uri}"));
    }
    Ok(UriData::File(dir.join(percent_decode(uri))))
}

/// Parsed document plus loaded buffer data.
struct Source<'c> {
    ctx: &'c mut Ctx,
    doc: gltf::Document,
    buffers: Vec<Vec<u8>>,
    /// Decoded meshopt buffer views by index (they replace the view's range of its buffer).
    decoded: HashMap<usize, Vec<u8>>,
    /// Images only an undecodable texture extension provides, with that extension's name.
    undecodable_images: HashMap<usize, &'static str>,
    /// Placeholder images of textures without a `source` (`gltf_ext::Prepared::sourceless_images`).
    sourceless_images: HashMap<usize, (usize, Vec<String>)>,
    /// `EXT_mesh_gpu_instancing` accessors (TRANSLATION, ROTATION, SCALE) by node.
    instancing: HashMap<usize, [Option<usize>; 3]>,
    /// The file's channel indices of animations that lost channels (`gltf_ext::Prepared`).
    channel_numbers: HashMap<usize, Vec<usize>>,
    /// A referenced image that must not be read (outside the folder, not a regular file, over
    /// the input budget): the import fails with it.
    refused: Option<IoError>,
    /// Morph-target vertex deltas read so far (capped by [`MAX_MORPH_VALUES`]).
    morph_values_read: usize,
    /// Values materialised from accessors without a buffer view so far, against
    /// [`VIEWLESS_VALUES_PER_BUDGET_BYTE`] × the input budget.
    viewless_values_read: std::cell::Cell<usize>,
    /// Bytes of the glTF JSON (for [`VIEWLESS_VALUES_PER_JSON_BYTE`]).
    json_len: usize,
    /// Holds the decoded textures to [`crate::texture::MAX_TOTAL_TEXELS`] together.
    texel_budget: TexelBudget,
    /// Bounds the pixels the images decode together ([`crate::texture::MAX_DECODED_PIXELS`]).
    decode_budget: DecodeBudget,
}

/// What a base-colour image is decoded from, so that images with the same source are decoded
/// once: a range of a buffer (thousands of images, or of views, may name one), a meshopt-decoded
/// buffer view (its bytes are not its buffer's range), a file URI (the same file named by
/// several images), or, for a data URI or an image only an undecodable extension provides, its
/// index.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
enum ImageKey {
    Range { buffer: usize, offset: usize, length: usize },
    View(usize),
    Uri(String),
    Image(usize),
}

/// The decoded base-colour images (their index in `Mesh::textures`, `None`: not decoded), by
/// image index, and by source ([`ImageKey`]), which is worked out once per image.
#[derive(Default)]
struct ImageMaps {
    by_image: HashMap<usize, Option<usize>>,
    by_source: HashMap<ImageKey, Option<usize>>,
}

pub(crate) fn import(ctx: &mut Ctx, bytes: &[u8], glb: bool) -> Result<(Mesh, Vec<ImportedPart>), IoError> {
    let path = ctx.path.clone();
    let (json, bin) = if glb { parse_glb(&path, bytes)? } else { (bytes, None) };
    // A UTF-8 byte-order mark before the JSON is skipped: glTF 2.0 §3.2 forbids writers to add
    // one but lets readers ignore it, as RFC 8259 §8.1 does (Windows tools write it; serde_json
    // refused it as "expected value at line 1 column 1").
    let json = json.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(json);
    let json_len = json.len();
    let mut value: serde_json::Value =
        serde_json::from_slice(json).map_err(|e| IoError::Json { path: path.clone(), message: e.to_string() })?;
    let prep = gltf_ext::prepare(&path, &mut value)?;
    let mut root: gltf::json::Root =
        serde_json::from_value(value).map_err(|e| IoError::Json { path: path.clone(), message: e.to_string() })?;
    // Checked and removed by `prepare`; the gltf crate would refuse extensions it has no feature for.
    root.extensions_required.clear();
    // gltf-json's validation indexes `accessors[POSITION]` unchecked: check those indices first.
    for (mi, mesh) in root.meshes.iter().enumerate() {
        for (pi, prim) in mesh.primitives.iter().enumerate() {
            for (sem, acc) in &prim.attributes {
                if acc.value() >= root.accessors.len() {
                    return Err(IoError::Invalid {
                        path,
                        message: format!(
                            "meshes[{mi}].primitives[{pi}].attributes[{sem:?}]: accessor {} does not exist ({} accessors)",
                            acc.value(),
                            root.accessors.len()
                        ),
                    });
                }
            }
        }
    }
    // gltf-json does not validate animation channel targets; the gltf crate unwraps them.
    for (ai, anim) in root.animations.iter().enumerate() {
        for (ci, ch) in anim.channels.iter().enumerate() {
            let ci = gltf_ext::Prepared::file_channel(&prep.channel_numbers, ai, ci);
            if ch.target.node.value() >= root.nodes.len() {
                return Err(IoError::Animation {
                    path,
                    animation: ai,
                    channel: ci,
                    reason: format!(
                        "target node {} does not exist ({} nodes)",
                        ch.target.node.value(),
                        root.nodes.len()
                    ),
                });
            }
            if matches!(ch.target.path, gltf::json::validation::Checked::Invalid) {
                return Err(IoError::Animation {
                    path,
                    animation: ai,
                    channel: ci,
                    reason: "invalid target path".into(),
                });
            }
        }
    }
    // The gltf crate unwraps an image's source: it needs a uri or a bufferView with a MIME type.
    for (ii, img) in root.images.iter_mut().enumerate() {
        if img.buffer_view.is_none() && img.uri.is_none() {
            return Err(IoError::Invalid { path, message: format!("images[{ii}]: neither uri nor bufferView") });
        }
        if img.buffer_view.is_some() && img.mime_type.is_none() {
            // The decoder sniffs the format from the bytes; the MIME type is not needed.
            img.mime_type = Some(gltf::json::image::MimeType("application/octet-stream".into()));
        }
    }
    let doc = gltf::Document::from_json_without_validation(root.clone());
    let mut errors = Vec::new();
    // Last line of defence: the gltf crate's validation must not take the process down.
    let validated = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        use gltf::json::validation::Validate;
        root.validate(&root, gltf::json::Path::new, &mut |p, e| errors.push((p(), e)));
    }));
    if validated.is_err() {
        return Err(IoError::Invalid { path, message: "glTF validation failed on malformed data".into() });
    }
    // POSITION accessors without min / max break the letter of the spec but are harmless here.
    errors.retain(|(p, e)| {
        let s = p.as_str();
        !(matches!(e, gltf::json::validation::Error::Missing) && (s.ends_with(".min") || s.ends_with(".max")))
    });
    if !errors.is_empty() {
        let message = errors.iter().take(5).map(|(p, e)| format!("{}: {e}", p.as_str())).collect::<Vec<_>>().join("; ");
        return Err(IoError::Invalid { path, message });
    }

    let mut buffers = Vec::new();
    for buffer in doc.buffers() {
        let i = buffer.index();
        if prep.fallback.get(i).copied().unwrap_or(false) {
            // Meshopt fallback: its views are decoded from their compressed data instead.
            buffers.push(Vec::new());
            continue;
        }
        let berr = |reason: String| IoError::Buffer { path: path.clone(), buffer: i, reason };
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => match bin {
                Some(b) => b.to_vec(),
                None => return Err(berr("refers to the GLB BIN chunk, which is absent".into())),
            },
            gltf::buffer::Source::Uri(uri) => match resolve_uri(&ctx.dir, uri).map_err(berr)? {
                UriData::Inline(d) => d,
                // At most the declared byteLength is read (`/dev/zero` is refused anyway).
                UriData::File(p) => ctx.read_referenced(uri, &p, ReadLimit::Prefix(buffer.length() as u64))?,
            },
        };
        if data.len() < buffer.length() {
            return Err(berr(format!("holds {} bytes, byteLength says {}", data.len(), buffer.length())));
        }
        buffers.push(data);
    }
    let views: Vec<(usize, usize)> = doc.views().map(|v| (v.length(), v.buffer().index())).collect();
    let decoded = gltf_ext::decode_views(&path, &prep, &views, &buffers)?;
    for (vi, &(_, bi)) in views.iter().enumerate() {
        if prep.fallback.get(bi).copied().unwrap_or(false) && !decoded.contains_key(&vi) {
            return Err(IoError::Buffer {
                path,
                buffer: bi,
                reason: format!("fallback buffer (no data) is read by buffer view {vi}, which is not compressed"),
            });
        }
    }
    if !prep.unknown_used.is_empty() {
        ctx.warn(format!(
            "extension(s) used by the file but not read: {} (the bake reads it as if they were absent; e.g. nodes hidden by KHR_node_visibility are baked, KHR_materials_variants keeps the default materials)",
            prep.unknown_used.join(", ")
        ));
    }
    if prep.channels_without_node > 0 {
        ctx.warn(format!(
            "{} animation channel(s) without a target node skipped (e.g. KHR_animation_pointer, which is not read): the pose margin and `pose` do not see what they animate",
            prep.channels_without_node
        ));
    }
    let texel_budget = TexelBudget::new(ctx.opts.max_texels);
    let decode_caps = (ctx.opts.max_decoded_pixels, ctx.opts.max_input_bytes);
    let mut src = Source {
        ctx,
        doc,
        buffers,
        decoded,
        undecodable_images: prep.undecodable_images,
        sourceless_images: prep.sourceless_images,
        instancing: prep.instancing,
        channel_numbers: prep.channel_numbers,
        refused: None,
        morph_values_read: 0,
        viewless_values_read: std::cell::Cell::new(0),
        json_len,
        texel_budget,
        decode_budget: DecodeBudget::new(decode_caps.0, decode_caps.1),
    };
    let built = src.build();
    if let Ok((mesh, _)) = &built {
        if let Some(w) = src.decode_budget.warning() {
            src.ctx.warn(w);
        }
        if let Some(w) = src.texel_budget.warning(&mesh.textures) {
            src.ctx.warn(w);
        }
    }
    match src.refused.take() {
        Some(e) => Err(e),
        None => built,
    }
}

fn data_type_size(t: DataType) -> usize {
    match t {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

fn dims_count(d: Dimensions) -> usize {
    match d {
        Dimensions::Scalar => 1,
        Dimensions::Vec2 => 2,
        Dimensions::Vec3 => 3,
        Dimensions::Vec4 => 4,
        Dimensions::Mat2 => 4,
        Dimensions::Mat3 => 9,
        Dimensions::Mat4 => 16,
    }
}

fn read_component(bytes: &[u8], t: DataType, normalized: bool) -> f64 {
    let b = |i: usize| bytes[i];
    match t {
        DataType::I8 => {
            let v = f64::from(b(0) as i8);
            if normalized {
                (v / 127.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U8 => {
            let v = f64::from(b(0));
            if normalized {
                v / 255.0
            } else {
                v
            }
        }
        DataType::I16 => {
            let v = f64::from(i16::from_le_bytes([b(0), b(1)]));
            if normalized {
                (v / 32767.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U16 => {
            let v = f64::from(u16::from_le_bytes([b(0), b(1)]));
            if normalized {
                v / 65535.0
            } else {
                v
            }
        }
        DataType::U32 => f64::from(u32::from_le_bytes([b(0), b(1), b(2), b(3)])),
        DataType::F32 => f64::from(f32::from_le_bytes([b(0), b(1), b(2), b(3)])),
    }
}

/// Accessor data decoded to f64 (exact for every glTF component type), `comps` values per element.
struct AccessorData {
    comps: usize,
    values: Vec<f64>,
}

impl AccessorData {
    fn count(&self) -> usize {
        self.values.len() / self.comps.max(1)
    }
    fn get<const N: usize>(&self, i: usize) -> [f64; N] {
        let mut out = [0.0; N];
        for (k, o) in out.iter_mut().enumerate().take(self.comps.min(N)) {
            *o = self.values[i * self.comps + k];
        }
        out
    }
}

impl Source<'_> {
    fn path(&self) -> PathBuf {
        self.ctx.path.clone()
    }

    /// The bytes of a buffer view, bounds-checked.
    fn view_bytes(&self, view: &gltf::buffer::View, accessor: usize) -> Result<&[u8], IoError> {
        if let Some(d) = self.decoded.get(&view.index()) {
            return Ok(d);
        }
        let buf = &self.buffers[view.buffer().index()];
        let end = view.offset().checked_add(view.length());
        match end {
            Some(end) if end <= buf.len() => Ok(&buf[view.offset()..end]),
            _ => Err(IoError::Accessor {
                path: self.path(),
                accessor,
                reason: format!(
                    "buffer view {} (offset {}, length {}) exceeds buffer {} of {} bytes",
                    view.index(),
                    view.offset(),
                    view.length(),
                    view.buffer().index(),
                    buf.len()
                ),
            }),
        }
    }

    /// Reads `count` elements of `elem` bytes from `bytes` at `offset` with `stride`.
    fn strided<'b>(
        &self,
        accessor: usize,
        bytes: &'b [u8],
        offset: usize,
        stride: usize,
        elem: usize,
        count: usize,
    ) -> Result<impl Iterator<Item = &'b [u8]> + 'b, IoError> {
        let need = stride
            .checked_mul(count.saturating_sub(1))
            .and_then(|x| x.checked_add(elem))
            .and_then(|x| x.checked_add(offset));
        match need {
            Some(n) if n <= bytes.len() || count == 0 => {}
            _ => {
                return Err(IoError::Accessor {
                    path: self.path(),
                    accessor,
                    reason: format!(
                        "{count} elements of {elem} bytes (stride {stride}) at offset {offset} exceed the {} bytes of the buffer view",
                        bytes.len()
                    ),
                })
            }
        }
        Ok((0..count).map(move |i| &bytes[offset + i * stride..offset + i * stride + elem]))
    }

    fn read_accessor(&self, acc: &gltf::Accessor) -> Result<AccessorData, IoError> {
        self.read_accessor_as(acc, acc.normalized())
    }

    /// [`Self::read_accessor`] with the `normalized` flag given (indices ignore it, as cgltf does:
    /// a flagged index accessor would otherwise read every index as a fraction, i.e. 0).
    fn read_accessor_as(&self, acc: &gltf::Accessor, norm: bool) -> Result<AccessorData, IoError> {
        let ai = acc.index();
        let t = acc.data_type();
        let csize = data_type_size(t);
        let comps = dims_count(acc.dimensions());
        if matches!(acc.dimensions(), Dimensions::Mat2 | Dimensions::Mat3) && csize < 4 {
            return Err(IoError::Accessor {
                path: self.path(),
                accessor: ai,
                reason: "padded matrix layout not supported".into(),
            });
        }
        let elem = csize * comps;
        let count = acc.count();
        let mut values = Vec::new();
        match acc.view() {
            Some(view) => {
                let bytes = self.view_bytes(&view, ai)?;
                let stride = view.stride().unwrap_or(elem);
                if stride < elem {
                    return Err(IoError::Accessor {
                        path: self.path(),
                        accessor: ai,
                        reason: format!("byte stride {stride} is smaller than the element size {elem}"),
                    });
                }
                // `strided` checks the range first, so the allocation is bounded by the buffer.
                let items = self.strided(ai, bytes, acc.offset(), stride, elem, count)?;
                values.reserve_exact(count * comps);
                for e in items {
                    for k in 0..comps {
                        values.push(read_component(&e[k * csize..], t, norm));
                    }
                }
            }
            None => {
                // No buffer bounds the size of an all-zeros accessor: refuse absurd counts, and
                // hold what all such reads materialise to the input budget.
                let n = count.saturating_mul(comps);
                if n > MAX_VIEWLESS_VALUES {
                    return Err(IoError::Accessor {
                        path: self.path(),
                        accessor: ai,
                        reason: format!("{count} elements without a buffer view (limit {MAX_VIEWLESS_VALUES} values)"),
                    });
                }
                let total = self.viewless_values_read.get().saturating_add(n);
                let (limit, budget) =
                    budget_limit(self.ctx.opts.max_input_bytes, VIEWLESS_VALUES_PER_BUDGET_BYTE, usize::MAX);
                let by_json = self.json_len.saturating_mul(VIEWLESS_VALUES_PER_JSON_BYTE);
                let what = format!(
                    "accessor {ai}: {count} elements without a buffer view make {total} such values read in all"
                );
                if total > by_json && by_json < limit {
                    return Err(IoError::OverJsonLimit {
                        path: self.path(),
                        what,
                        limit: by_json as u64,
                        per_json_byte: VIEWLESS_VALUES_PER_JSON_BYTE as u64,
                        json_bytes: self.json_len as u64,
                    });
                }
                if total > limit {
                    return Err(IoError::OverLimit {
                        path: self.path(),
                        what,
                        limit: limit as u64,
                        per_budget_byte: budget.then_some(VIEWLESS_VALUES_PER_BUDGET_BYTE),
                    });
                }
                self.viewless_values_read.set(total);
                values.resize(n, 0.0)
            }
        }
        if let Some(sparse) = acc.sparse() {
            let n = sparse.count();
            let idx = sparse.indices();
            let it = match idx.index_type() {
                gltf::accessor::sparse::IndexType::U8 => DataType::U8,
                gltf::accessor::sparse::IndexType::U16 => DataType::U16,
                gltf::accessor::sparse::IndexType::U32 => DataType::U32,
            };
            let isize = data_type_size(it);
            let ib = self.view_bytes(&idx.view(), ai)?;
            let indices: Vec<usize> = self
                .strided(ai, ib, idx.offset(), isize, isize, n)?
                .map(|e| read_component(e, it, false) as usize)
                .collect();
            let vals = sparse.values();
            let vb = self.view_bytes(&vals.view(), ai)?;
            let sv: Vec<&[u8]> = self.strided(ai, vb, vals.offset(), elem, elem, n)?.collect();
            for (&i, e) in indices.iter().zip(sv) {
                if i >= count {
                    return Err(IoError::Accessor {
                        path: self.path(),
                        accessor: ai,
                        reason: format!("sparse index {i} out of range (count {count})"),
                    });
                }
                for k in 0..comps {
                    values[i * comps + k] = read_component(&e[k * csize..], t, norm);
                }
            }
        }
        Ok(AccessorData { comps, values })
    }

    /// Adds Σ wᵢ·Δᵢ of the primitive's morph targets' `semantic` (POSITION or NORMAL) to `base`
    /// (one VEC3 per vertex). Targets sharing an accessor read it once, their weights summed; the
    /// values read over the whole import are capped ([`MAX_MORPH_VALUES`]), so a small file
    /// naming one large sparse accessor from many targets cannot make the import run for hours.
    fn add_morph_deltas(
        &mut self,
        prim: &gltf::Primitive,
        weights: &[f32],
        semantic: Semantic,
        base: &mut [DVec3],
    ) -> Result<(), IoError> {
        let n = base.len();
        let mut by_accessor: Vec<(gltf::Accessor, f64, usize)> = Vec::new();
        for (ti, (target, &w)) in prim.morph_targets().zip(weights).enumerate() {
            let acc = match semantic {
                Semantic::Positions => target.positions(),
                _ => target.normals(),
            };
            let Some(acc) = acc.filter(|_| w != 0.0) else { continue };
            match by_accessor.iter_mut().find(|(a, _, _)| a.index() == acc.index()) {
                Some(entry) => entry.1 += f64::from(w),
                None => by_accessor.push((acc, f64::from(w), ti)),
            }
        }
        let what = if matches!(semantic, Semantic::Positions) { "POSITION" } else { "NORMAL" };
        for (acc, w, ti) in by_accessor {
            self.morph_values_read = self.morph_values_read.saturating_add(acc.count());
            if self.morph_values_read > MAX_MORPH_VALUES {
                return Err(IoError::Invalid {
                    path: self.path(),
                    message: format!(
                        "morph targets: more than {MAX_MORPH_VALUES} vertex deltas to read (targets × vertices, instances included)"
                    ),
                });
            }
            let d = self.read_vec(&acc, &[3], &format!("morph target {what}"))?;
            if d.count() != n {
                return Err(IoError::Accessor {
                    path: self.path(),
                    accessor: acc.index(),
                    reason: format!("morph target {ti} {what} count {} differs from {what} count {n}", d.count()),
                });
            }
            for (v, p) in base.iter_mut().enumerate() {
                *p += DVec3::from(d.get::<3>(v)) * w;
            }
        }
        Ok(())
    }

    /// Reads an accessor that must be float-like with `comps` components (or one of `alt`).
    fn read_vec(&self, acc: &gltf::Accessor, allowed: &[usize], what: &str) -> Result<AccessorData, IoError> {
        let d = self.read_accessor(acc)?;
        if !allowed.contains(&d.comps) {
            return Err(IoError::Accessor {
                path: self.path(),
                accessor: acc.index(),
                reason: format!("{what} has {} components, expected {allowed:?}", d.comps),
            });
        }
        Ok(d)
    }

    fn build(&mut self) -> Result<(Mesh, Vec<ImportedPart>), IoError> {
        let path = self.path();
        let doc = self.doc.clone();
        let nodes: Vec<gltf::Node> = doc.nodes().collect();
        let node_count = nodes.len();

        // Node hierarchy: parents, local and world matrices (f64).
        let mut parent: Vec<Option<usize>> = vec![None; node_count];
        for node in doc.nodes() {
            for c in node.children() {
                if c.index() == node.index() {
                    return Err(IoError::NodeGraph {
                        path,
                        node: c.index(),
                        reason: "node is its own child (a cycle)",
                    });
                }
                if parent[c.index()].is_some() {
                    return Err(IoError::NodeGraph { path, node: c.index(), reason: "node has more than one parent" });
                }
                parent[c.index()] = Some(node.index());
            }
        }
        let mut local = Vec::with_capacity(node_count);
        let mut rest_nodes = Vec::with_capacity(node_count);
        for node in doc.nodes() {
            let m = match node.transform() {
                gltf::scene::Transform::Matrix { matrix } => {
                    let mut a = [0.0f64; 16];
                    for (c, col) in matrix.iter().enumerate() {
                        for (r, v) in col.iter().enumerate() {
                            a[c * 4 + r] = f64::from(*v);
                        }
                    }
                    DMat4::from_cols_array(&a)
                }
                gltf::scene::Transform::Decomposed { translation, rotation, scale } => {
                    let q = DQuat::from_xyzw(
                        f64::from(rotation[0]),
                        f64::from(rotation[1]),
                        f64::from(rotation[2]),
                        f64::from(rotation[3]),
                    );
                    let q = if q.length() > 1e-12 { q.normalize() } else { DQuat::IDENTITY };
                    DMat4::from_scale_rotation_translation(
                        DVec3::from(scale.map(f64::from)),
                        q,
                        DVec3::from(translation.map(f64::from)),
                    )
                }
            };
            let (s, r, t) = match node.transform() {
                gltf::scene::Transform::Decomposed { translation, rotation, scale } => (scale, rotation, translation),
                gltf::scene::Transform::Matrix { .. } => {
                    let (s, r, t) = m.as_mat4().to_scale_rotation_translation();
                    (s.to_array(), r.to_array(), t.to_array())
                }
            };
            rest_nodes.push(Node {
                name: node.name().map(str::to_owned).unwrap_or_else(|| format!("node{}", node.index())),
                parent: parent[node.index()],
                translation: t,
                rotation: r,
                scale: s,
            });
            local.push(m);
        }
        // World matrices in parent-before-child order; nodes never reached sit on a cycle.
        let mut world: Vec<Option<DMat4>> = vec![None; node_count];
        let mut stack: Vec<usize> = (0..node_count).filter(|&i| parent[i].is_none()).rev().collect();
        while let Some(i) = stack.pop() {
            world[i] = Some(match parent[i] {
                Some(p) => world[p].unwrap_or(DMat4::IDENTITY) * local[i],
                None => local[i],
            });
            let node = nodes[i].clone();
            stack.extend(node.children().map(|c| c.index()).collect::<Vec<_>>().into_iter().rev());
        }
        if let Some(i) = world.iter().position(Option::is_none) {
            return Err(IoError::NodeGraph { path, node: i, reason: "node is part of a cycle" });
        }
        let world: Vec<DMat4> = world.into_iter().map(|m| m.unwrap_or(DMat4::IDENTITY)).collect();

        // Mesh instances of the default scene, depth first in document order.
        let roots: Vec<usize> = match doc.default_scene().or_else(|| doc.scenes().next()) {
            // An empty scene is valid glTF (`nodes` is optional) but shows nothing: said so
            // rather than "no triangles". Other, unused scenes may be empty.
            Some(scene) if scene.nodes().len() == 0 => {
                return Err(IoError::EmptyMesh {
                    path,
                    reason: Some(format!("scene {} (the scene imported) has no nodes", scene.index())),
                });
            }
            Some(scene) => scene.nodes().map(|n| n.index()).collect(),
            None => {
                self.ctx.warn("glTF has no scene: importing every root node".into());
                (0..node_count).filter(|&i| parent[i].is_none()).collect()
            }
        };
        let mut instances = Vec::new();
        let mut stack: Vec<usize> = roots.into_iter().rev().collect();
        while let Some(i) = stack.pop() {
            let node = nodes[i].clone();
            if node.mesh().is_some() {
                instances.push(i);
            }
            stack.extend(node.children().map(|c| c.index()).collect::<Vec<_>>().into_iter().rev());
        }

        // Bones: union of the joints of every skin an instance uses.
        let mut bones: Vec<Bone> = Vec::new();
        let mut bone_of_key: HashMap<(usize, [u32; 16]), u32> = HashMap::new();
        let mut skin_joint_bones: HashMap<usize, (Vec<u32>, Vec<DMat4>)> = HashMap::new();
        let mut node_bone: Vec<Option<u32>> = vec![None; node_count];
        for &i in &instances {
            let node = nodes[i].clone();
            let Some(skin) = node.skin() else { continue };
            if skin_joint_bones.contains_key(&skin.index()) {
                continue;
            }
            let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
            let ibms: Vec<Mat4> = match skin.inverse_bind_matrices() {
                Some(acc) => {
                    let d = self.read_vec(&acc, &[16], "inverseBindMatrices")?;
                    if d.count() < joints.len() {
                        return Err(IoError::Accessor {
                            path,
                            accessor: acc.index(),
                            reason: format!("{} inverse bind matrices for {} joints", d.count(), joints.len()),
                        });
                    }
                    (0..joints.len()).map(|k| Mat4::from_cols_array(&d.get::<16>(k).map(|v| v as f32))).collect()
                }
                None => vec![Mat4::IDENTITY; joints.len()],
            };
            let mut jb = Vec::with_capacity(joints.len());
            let mut jm = Vec::with_capacity(joints.len());
            for (&j, ibm) in joints.iter().zip(&ibms) {
                let key = (j, ibm.to_cols_array().map(f32::to_bits));
                let b = *bone_of_key.entry(key).or_insert_with(|| {
                    let jn = nodes[j].clone();
                    bones.push(Bone {
                        name: jn.name().map(str::to_owned).unwrap_or_else(|| format!("node{j}")),
                        node: j,
                        parent: None,
                        inverse_bind: *ibm,
                    });
                    (bones.len() - 1) as u32
                });
                node_bone[j].get_or_insert(b);
                jb.push(b);
                jm.push(world[j] * ibm.as_dmat4());
            }
            skin_joint_bones.insert(skin.index(), (jb, jm));
        }
        for b in &mut bones {
            let mut p = parent[b.node];
            while let Some(n) = p {
                if let Some(pb) = node_bone[n] {
                    b.parent = Some(pb);
                    break;
                }
                p = parent[n];
            }
        }
        let has_skin = !bones.is_empty();
        // Nearest bone at or above each node.
        let bone_above = |mut n: usize| -> Option<u32> {
            loop {
                if let Some(b) = node_bone[n] {
                    return Some(b);
                }
                n = parent[n]?;
            }
        };

        let mut b = Builder::default();
        let mut parts = Vec::new();
        let mut material_map: HashMap<Option<usize>, u32> = HashMap::new();
        let mut image_map = ImageMaps::default();
        let mut warned_unattached = false;
        // The primitives of each mesh placed that can give triangles, worked out once per mesh
        // (not per placement): points and lines are skipped, and so are primitives without
        // POSITION or with none (count 0; they add nothing). The skipped ones are counted per
        // kind, each primitive once however often it is placed, for one warning per kind.
        let mut live: HashMap<usize, Vec<gltf::Primitive>> = HashMap::new();
        let mut skipped: Vec<(String, usize, String)> = Vec::new();
        for &ni in &instances {
            let mesh = nodes[ni].mesh().expect("instances have meshes");
            let mi = mesh.index();
            if live.contains_key(&mi) {
                continue;
            }
            let mut kept = Vec::new();
            for prim in mesh.primitives() {
                let kind = match prim.mode() {
                    m @ (Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip) => format!("{m:?}"),
                    _ => match prim.get(&Semantic::Positions) {
                        None => "without POSITION".to_owned(),
                        Some(a) if a.count() == 0 => continue,
                        Some(_) => {
                            kept.push(prim);
                            continue;
                        }
                    },
                };
                match skipped.iter_mut().find(|(k, _, _)| *k == kind) {
                    Some(entry) => entry.1 += 1,
                    None => {
                        let first = format!("mesh {mi} ({:?}) primitive {}", mesh.name().unwrap_or(""), prim.index());
                        skipped.push((kind, 1, first));
                    }
                }
            }
            live.insert(mi, kept);
        }
        for (kind, n, first) in &skipped {
            let (what, why) = match kind.starts_with("without") {
                true => (format!("primitive{} {kind}", if *n > 1 { "s" } else { "" }), ""),
                false => {
                    (format!("{kind} primitive{}", if *n > 1 { "s" } else { "" }), " (only triangles are imported)")
                }
            };
            self.ctx.warn(match n {
                1 => format!("{first}: {what} skipped{why}"),
                _ => format!("{n} {what} skipped{why}, the first {first}"),
            });
        }
        // Nothing but points and lines: said so, rather than "no triangles to import" alone.
        let lines: usize = skipped.iter().filter(|(k, _, _)| !k.starts_with("without")).map(|(_, n, _)| n).sum();
        if lines > 0 && live.values().all(Vec::is_empty) {
            return Err(IoError::EmptyMesh {
                path,
                reason: Some(format!(
                    "the model has only POINTS / LINES primitives ({lines} skipped; only triangles are imported)"
                )),
            });
        }
        // Mesh placements: one per node, or one per EXT_mesh_gpu_instancing instance (scene ←
        // node ← instance), for meshes with primitives to import. Skinned nodes ignore
        // instancing (the extension excludes skins). The vertices and triangles ([`triangles_of`]
        // the corners) the placements will make are counted as they are listed, each node's
        // instance count taken from its accessors before the matrices are built, and held to
        // the input budget: a 5 KB file placing a short index list millions of times asked for
        // billions of triangles, past u32 indices.
        let limits = [
            ("vertices", budget_limit(self.ctx.opts.max_input_bytes, VERTICES_PER_BUDGET_BYTE, MAX_VERTICES)),
            ("triangles", budget_limit(self.ctx.opts.max_input_bytes, TRIANGLES_PER_BUDGET_BYTE, MAX_TRIANGLES)),
        ];
        let over = |ni: usize, k: usize, total: usize| IoError::OverLimit {
            path: path.clone(),
            what: format!("node {ni}: the scene expands to {total} {} or more (every placement counted)", limits[k].0),
            limit: limits[k].1 .0 as u64,
            per_budget_byte: limits[k].1 .1.then_some([VERTICES_PER_BUDGET_BYTE, TRIANGLES_PER_BUDGET_BYTE][k]),
        };
        let (mut planned, mut planned_tris) = (0usize, 0usize);
        let mut placements: Vec<(usize, DMat4)> = Vec::with_capacity(instances.len());
        for &ni in &instances {
            let Some(prims) = live.get(&nodes[ni].mesh().expect("instances have meshes").index()) else { continue };
            if prims.is_empty() {
                continue;
            }
            let per_placement: usize = prims
                .iter()
                .filter_map(|p| p.get(&Semantic::Positions))
                .map(|a| a.count())
                .fold(0, usize::saturating_add);
            let tris_per_placement: usize = prims
                .iter()
                .map(|p| {
                    let corners = p.indices().or_else(|| p.get(&Semantic::Positions)).map_or(0, |a| a.count());
                    triangles_of(p.mode(), corners)
                })
                .fold(0, usize::saturating_add);
            let mut plan = |ni: usize, copies: usize| {
                planned = planned.saturating_add(copies.saturating_mul(per_placement));
                planned_tris = planned_tris.saturating_add(copies.saturating_mul(tris_per_placement));
                if planned > limits[0].1 .0 {
                    Err(over(ni, 0, planned))
                } else if planned_tris > limits[1].1 .0 {
                    Err(over(ni, 1, planned_tris))
                } else {
                    Ok(())
                }
            };
            match self.instancing.get(&ni).copied() {
                Some(attrs) if nodes[ni].skin().is_none() => {
                    let count =
                        attrs.iter().flatten().find_map(|&ai| self.doc.accessors().nth(ai)).map_or(1, |a| a.count());
                    plan(ni, count)?;
                    for m in self.instance_matrices(ni, attrs)? {
                        placements.push((ni, world[ni] * m));
                    }
                }
                _ => {
                    plan(ni, 1)?;
                    placements.push((ni, world[ni]));
                }
            }
        }

        for &(ni, node_world) in &placements {
            let node = nodes[ni].clone();
            let mesh = node.mesh().expect("instances have meshes");
            let mi = mesh.index();
            for prim in live.get(&mi).into_iter().flatten() {
                let pi = prim.index();
                let ctx_name = format!("mesh {mi} ({:?}) primitive {pi}", mesh.name().unwrap_or(""));
                let mode = prim.mode();
                let Some(pos_acc) = prim.get(&Semantic::Positions) else { continue };
                // The placements' vertices and triangles were counted against the limits above.
                let pos = self.read_vec(&pos_acc, &[3], "POSITION")?;
                let n = pos.count();
                let mut raw: Vec<Vec3> = (0..n).map(|v| Vec3::from(pos.get::<3>(v).map(|x| x as f32))).collect();
                // Morph targets at their default weights (the node's, else the mesh's): the shape
                // every viewer shows at rest (positions here, normals below); animated weights
                // are not followed.
                let weights = node.weights().or(mesh.weights()).unwrap_or(&[]);
                let morphed = weights.iter().any(|&w| w != 0.0);
                if morphed {
                    let mut sum: Vec<DVec3> = (0..n).map(|v| DVec3::from(pos.get::<3>(v))).collect();
                    self.add_morph_deltas(prim, weights, Semantic::Positions, &mut sum)?;
                    raw = sum.iter().map(|p| p.as_vec3()).collect();
                }
                if let Some((v, p)) = raw.iter().enumerate().find(|(_, p)| !p.is_finite()) {
                    return Err(IoError::NonFinitePosition {
                        path,
                        mesh: mi,
                        mesh_name: mesh.name().unwrap_or("").to_owned(),
                        primitive: pi,
                        vertex: v,
                        value: p.to_array(),
                    });
                }
                let indices: Vec<u32> = match prim.indices() {
                    Some(acc) => {
                        let d = self.read_accessor_as(&acc, false)?;
                        if d.comps != 1 {
                            return Err(IoError::Accessor {
                                path,
                                accessor: acc.index(),
                                reason: format!("indices has {} components, expected [1]", d.comps),
                            });
                        }
                        if acc.data_type() == DataType::F32
                            || acc.data_type() == DataType::I8
                            || acc.data_type() == DataType::I16
                        {
                            return Err(IoError::Accessor {
                                path,
                                accessor: acc.index(),
                                reason: format!("index component type {:?} is not unsigned", acc.data_type()),
                            });
                        }
                        let mut out = Vec::with_capacity(d.values.len());
                        for (k, &x) in d.values.iter().enumerate() {
                            if x >= n as f64 {
                                return Err(IoError::IndexOutOfRange {
                                    path,
                                    mesh: mi,
                                    primitive: pi,
                                    position: k,
                                    index: x as u64,
                                    vertex_count: n,
                                });
                            }
                            out.push(x as u32);
                        }
                        out
                    }
                    None => (0..n as u32).collect(),
                };
                let mut tris: Vec<[u32; 3]> = match mode {
                    Mode::TriangleStrip => (0..indices.len().saturating_sub(2))
                        .map(|i| {
                            if i % 2 == 0 {
                                [indices[i], indices[i + 1], indices[i + 2]]
                            } else {
                                [indices[i + 1], indices[i], indices[i + 2]]
                            }
                        })
                        .collect(),
                    Mode::TriangleFan => {
                        (1..indices.len().saturating_sub(1)).map(|i| [indices[i], indices[i + 1], indices[0]]).collect()
                    }
                    _ => {
                        if indices.len() % 3 != 0 {
                            return Err(IoError::Invalid {
                                path,
                                message: format!(
                                    "{ctx_name}: TRIANGLES with {} indices, not a multiple of 3",
                                    indices.len()
                                ),
                            });
                        }
                        indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
                    }
                };

                // Attributes. Each must have POSITION's count (glTF §3.7.2.1 "MUST", and cgltf's
                // validation): one that differs is an error, checked before it is read, as for
                // JOINTS / WEIGHTS and morph targets. Dropping it (as was done, silently) baked
                // the model without its normals, UVs (its texture) or colours.
                let same_count = |acc: &gltf::Accessor, what: &str| {
                    if acc.count() == n {
                        return Ok(());
                    }
                    Err(IoError::Accessor {
                        path: path.clone(),
                        accessor: acc.index(),
                        reason: format!(
                            "{ctx_name}: {what} has {} elements, POSITION {n} (the attributes of a primitive have one count, glTF §3.7.2.1)",
                            acc.count()
                        ),
                    })
                };
                let mut normals = match prim.get(&Semantic::Normals) {
                    Some(acc) => {
                        same_count(&acc, "NORMAL")?;
                        let d = self.read_vec(&acc, &[3], "NORMAL")?;
                        Some((0..n).map(|v| DVec3::from(d.get::<3>(v))).collect::<Vec<_>>())
                    }
                    None => None,
                };
                if let (true, Some(ns)) = (morphed, normals.as_mut()) {
                    // The morphed normal is normalize(n + Σ wᵢ·Δnᵢ) (glTF §3.7.2.2).
                    self.add_morph_deltas(prim, weights, Semantic::Normals, ns)?;
                    for nv in ns.iter_mut() {
                        *nv = nv.try_normalize().unwrap_or(*nv);
                    }
                }
                let mut uv_sets: Vec<Option<Vec<[f32; 2]>>> = Vec::new();
                for set in 0..8u32 {
                    let Some(acc) = prim.get(&Semantic::TexCoords(set)) else {
                        if set >= 1 {
                            break;
                        }
                        uv_sets.push(None);
                        continue;
                    };
                    same_count(&acc, &format!("TEXCOORD_{set}"))?;
                    let d = self.read_vec(&acc, &[2], "TEXCOORD")?;
                    uv_sets.push(Some((0..n).map(|v| d.get::<2>(v).map(|x| x as f32)).collect()));
                }
                let colors = match prim.get(&Semantic::Colors(0)) {
                    Some(acc) => {
                        same_count(&acc, "COLOR_0")?;
                        let d = self.read_vec(&acc, &[3, 4], "COLOR_0")?;
                        let c3 = d.comps == 3;
                        Some(
                            (0..n)
                                .map(|v| {
                                    let c = d.get::<4>(v).map(|x| x as f32);
                                    if c3 {
                                        [c[0], c[1], c[2], 1.0]
                                    } else {
                                        c
                                    }
                                })
                                .collect::<Vec<_>>(),
                        )
                    }
                    None => None,
                };

                // Placement: skinned (LBS at rest) or rigid (node world matrix).
                let skin_data = node.skin().and_then(|s| skin_joint_bones.get(&s.index()).map(|d| (s.index(), d)));
                let mut joint_sets = Vec::new();
                if skin_data.is_some() {
                    for set in 0..2u32 {
                        match (prim.get(&Semantic::Joints(set)), prim.get(&Semantic::Weights(set))) {
                            (Some(j), Some(w)) => {
                                let jd = self.read_vec(&j, &[4], "JOINTS")?;
                                let wd = self.read_vec(&w, &[4], "WEIGHTS")?;
                                if jd.count() != n || wd.count() != n {
                                    return Err(IoError::Accessor {
                                        path,
                                        accessor: j.index(),
                                        reason: format!("JOINTS/WEIGHTS count differs from POSITION count {n}"),
                                    });
                                }
                                joint_sets.push((jd, wd));
                            }
                            _ => break,
                        }
                    }
                }
                let mut scene = Vec::with_capacity(n);
                let mut scene_normals = Vec::with_capacity(n);
                let mut infl = Vec::with_capacity(n);
                let mut bind = Vec::with_capacity(n);
                let mut negative = Vec::with_capacity(n);
                let mut zero_weight = 0usize;
                match (skin_data, joint_sets.is_empty()) {
                    (Some((si, (jb, jm))), false) => {
                        for v in 0..n {
                            let mut inf = SkinInfluences::default();
                            let mut sum = 0.0f64;
                            for (s, (jd, wd)) in joint_sets.iter().enumerate() {
                                let j = jd.get::<4>(v);
                                let w = wd.get::<4>(v);
                                for k in 0..4 {
                                    let joint = j[k] as u32;
                                    let wk = w[k].max(0.0);
                                    if wk > 0.0 && joint as usize >= jb.len() {
                                        return Err(IoError::JointOutOfRange {
                                            path,
                                            mesh: mi,
                                            primitive: pi,
                                            vertex: v,
                                            skin: si,
                                            joint,
                                            joint_count: jb.len(),
                                        });
                                    }
                                    if wk > 0.0 {
                                        inf.joints[s * 4 + k] = joint;
                                        inf.weights[s * 4 + k] = wk as f32;
                                        sum += wk;
                                    }
                                }
                            }
                            let mut m = DMat4::ZERO;
                            if sum > 0.0 {
                                for k in 0..8 {
                                    if inf.weights[k] > 0.0 {
                                        let w = f64::from(inf.weights[k]) / sum;
                                        m += jm[inf.joints[k] as usize] * w;
                                        inf.weights[k] = w as f32;
                                        inf.joints[k] = jb[inf.joints[k] as usize];
                                    }
                                }
                            } else {
                                zero_weight += 1;
                                m = DMat4::IDENTITY;
                            }
                            let p = raw[v].as_dvec3();
                            scene.push(m.transform_point3(p));
                            let m3 = DMat3::from_mat4(m);
                            negative.push(m3.determinant() < 0.0);
                            if let Some(nr) = &normals {
                                let nm = m3.inverse().transpose();
                                scene_normals.push(nm * nr[v]);
                            }
                            infl.push(inf);
                            bind.push(raw[v]);
                        }
                    }
                    _ => {
                        let m = node_world;
                        let m3 = DMat3::from_mat4(m);
                        let nm = m3.inverse().transpose();
                        let neg = m3.determinant() < 0.0;
                        let attach = if has_skin { bone_above(ni) } else { None };
                        if has_skin && attach.is_none() && !warned_unattached {
                            warned_unattached = true;
                            self.ctx.warn(format!(
                                "{ctx_name} (node {ni}): unskinned mesh not under any joint; it is attached to no bone and will not move"
                            ));
                        }
                        let to_bind = attach.map(|b| {
                            let bone = &bones[b as usize];
                            (world[bone.node] * bone.inverse_bind.as_dmat4()).inverse()
                        });
                        for v in 0..n {
                            let p = m.transform_point3(raw[v].as_dvec3());
                            scene.push(p);
                            negative.push(neg);
                            if let Some(nr) = &normals {
                                scene_normals.push(nm * nr[v]);
                            }
                            if has_skin {
                                let mut inf = SkinInfluences::default();
                                match (attach, to_bind) {
                                    (Some(b), Some(tb)) => {
                                        inf.joints[0] = b;
                                        inf.weights[0] = 1.0;
                                        bind.push(tb.transform_point3(p.as_vec3().as_dvec3()).as_vec3());
                                    }
                                    _ => bind.push(p.as_vec3()),
                                }
                                infl.push(inf);
                            }
                        }
                    }
                }
                if zero_weight > 0 {
                    self.ctx.warn(format!(
                        "{ctx_name}: {zero_weight} vertices have all skin weights zero; left at their bind position"
                    ));
                }
                let scene: Vec<Vec3> = scene.into_iter().map(|p| p.as_vec3()).collect();
                if let Some((v, p)) = scene.iter().enumerate().find(|(_, p)| !p.is_finite()) {
                    return Err(IoError::NonFinitePosition {
                        path,
                        mesh: mi,
                        mesh_name: mesh.name().unwrap_or("").to_owned(),
                        primitive: pi,
                        vertex: v,
                        value: p.to_array(),
                    });
                }
                for t in &mut tris {
                    let neg = [t[0], t[1], t[2]].iter().filter(|&&i| negative[i as usize]).count();
                    if neg >= 2 {
                        t.swap(1, 2);
                    }
                }
                // No NORMAL: flat shading, as §3.7.2.1 requires ("client implementations MUST
                // calculate flat normals"): each triangle shades with its geometric normal. A corner
                // whose normal has no direction (zero, NaN) is no normal either: it drops out of
                // the interpolation (a triangle with none at any corner shades flat).
                let normals: Vec<Vec3> = if normals.is_some() {
                    scene_normals
                        .into_iter()
                        .map(|x| x.as_vec3().try_normalize().unwrap_or(spherebake_geom::normals::NO_NORMAL))
                        .collect()
                } else {
                    vec![spherebake_geom::normals::NO_NORMAL; scene.len()]
                };

                // Material.
                let mat_key = prim.material().index();
                let material = match material_map.get(&mat_key) {
                    Some(&m) => m,
                    None => {
                        let m = self.material(&prim.material(), &mut b.mesh, &mut image_map);
                        b.mesh.materials.push(m);
                        let id = (b.mesh.materials.len() - 1) as u32;
                        material_map.insert(mat_key, id);
                        id
                    }
                };

                let v0 = b.mesh.positions.len() as u32;
                let t0 = b.mesh.triangles.len() as u32;
                b.push(scene, normals, uv_sets, colors, &tris, material);
                if has_skin {
                    b.influences.extend(infl);
                    b.bind.extend(bind);
                }
                parts.push(ImportedPart {
                    source_mesh: mi,
                    primitive: pi,
                    node: Some(ni),
                    node_world: node_world.as_mat4(),
                    file_vertex_count: n,
                    vertices: v0..b.mesh.positions.len() as u32,
                    triangles: t0..b.mesh.triangles.len() as u32,
                });
            }
        }

        let mut mesh = b.finish();
        for m in &mesh.materials {
            if let Some(t) = &m.base_color_texture {
                if mesh.uvs.get(t.uv_set as usize).is_none_or(Vec::is_empty) {
                    self.ctx.warn(format!(
                        "material {:?}: base colour texture reads TEXCOORD_{}, which no primitive has",
                        m.name, t.uv_set
                    ));
                }
            }
        }
        if has_skin {
            let animations = self.animations(&doc)?;
            mesh.skin = Some(Skin {
                skeleton: Skeleton { nodes: rest_nodes, bones, animations },
                influences: std::mem::take(&mut b.influences),
                bind_positions: std::mem::take(&mut b.bind),
            });
        } else if doc.animations().len() > 0 {
            self.ctx.warn(format!(
                "{} animation(s) ignored: no skinned mesh in the scene (node and morph-weight animations are not baked; an engine moves a rigid proxy with its node)",
                doc.animations().len()
            ));
        }
        Ok((mesh, parts))
    }

    /// Instance transforms (T·R·S) of an `EXT_mesh_gpu_instancing` node.
    fn instance_matrices(&self, ni: usize, attrs: [Option<usize>; 3]) -> Result<Vec<DMat4>, IoError> {
        let mut data: [Option<AccessorData>; 3] = [None, None, None];
        let mut count: Option<usize> = None;
        for (k, (acc, comps)) in attrs.iter().zip([3usize, 4, 3]).enumerate() {
            let Some(ai) = *acc else { continue };
            let Some(a) = self.doc.accessors().nth(ai) else {
                return Err(IoError::Invalid {
                    path: self.path(),
                    message: format!("nodes[{ni}]: EXT_mesh_gpu_instancing accessor {ai} does not exist"),
                });
            };
            let d = self.read_vec(&a, &[comps], "EXT_mesh_gpu_instancing attribute")?;
            if count.is_some_and(|c| c != d.count()) {
                return Err(IoError::Accessor {
                    path: self.path(),
                    accessor: ai,
                    reason: format!(
                        "{} instances, other attributes of node {ni} have {}",
                        d.count(),
                        count.unwrap_or(0)
                    ),
                });
            }
            count = Some(d.count());
            data[k] = Some(d);
        }
        let n = count.unwrap_or(1);
        Ok((0..n)
            .map(|i| {
                let t = data[0].as_ref().map_or(DVec3::ZERO, |d| DVec3::from(d.get::<3>(i)));
                let r = data[1].as_ref().map_or(DQuat::IDENTITY, |d| {
                    let q = DQuat::from_array(d.get::<4>(i));
                    if q.length() > 1e-12 {
                        q.normalize()
                    } else {
                        DQuat::IDENTITY
                    }
                });
                let s = data[2].as_ref().map_or(DVec3::ONE, |d| DVec3::from(d.get::<3>(i)));
                DMat4::from_scale_rotation_translation(s, r, t)
            })
            .collect())
    }

    fn material(&mut self, m: &gltf::Material, mesh: &mut Mesh, image_map: &mut ImageMaps) -> Material {
        let pbr = m.pbr_metallic_roughness();
        // KHR_materials_pbrSpecularGlossiness (older exporters): when present it is the
        // material, metallic-roughness being the fallback for viewers without it; its diffuse
        // factor and texture (linear and sRGB, as the base colour's) are the albedo.
        let (factor, colour_texture) = match m.pbr_specular_glossiness() {
            Some(sg) => (sg.diffuse_factor(), sg.diffuse_texture()),
            None => (pbr.base_color_factor(), pbr.base_color_texture()),
        };
        let name = m.name().map(str::to_owned).unwrap_or_else(|| match m.index() {
            Some(i) => format!("material{i}"),
            None => "default".into(),
        });
        // KHR_materials_transmission (glass, thin plastic): the spheres are opaque occluders,
        // so such a material blocks light as its base colour would; said once per material.
        let transmission = m
            .extension_value("KHR_materials_transmission")
            .and_then(|t| t.get("transmissionFactor"))
            .and_then(serde_json::Value::as_f64)
            .unwrap_or(0.0);
        if transmission > 0.0 {
            self.ctx.warn(format!(
                "material {name:?}: KHR_materials_transmission (transmission {transmission}) is baked as opaque: its spheres block light fully in shadows and indirect light, and it reflects its base colour"
            ));
        }
        let mut out = Material {
            name,
            base_color_factor_linear: factor,
            base_color_texture: None,
            double_sided: m.double_sided(),
            // The document is validated before this (an unknown alphaMode is an error).
            alpha_mask_cutoff: match m.alpha_mode() {
                gltf::material::AlphaMode::Mask => Some(m.alpha_cutoff().unwrap_or(0.5)),
                gltf::material::AlphaMode::Opaque | gltf::material::AlphaMode::Blend => None,
            },
        };
        if let Some(info) = colour_texture {
            let tex = info.texture();
            let img = tex.source();
            let ii = img.index();
            let slot = match image_map.by_image.get(&ii) {
                Some(s) => *s,
                None => {
                    let key = match img.source() {
                        _ if self.undecodable_images.contains_key(&ii) || self.sourceless_images.contains_key(&ii) => {
                            ImageKey::Image(ii)
                        }
                        gltf::image::Source::View { view, .. } if self.decoded.contains_key(&view.index()) => {
                            ImageKey::View(view.index())
                        }
                        gltf::image::Source::View { view, .. } => ImageKey::Range {
                            buffer: view.buffer().index(),
                            offset: view.offset(),
                            length: view.length(),
                        },
                        gltf::image::Source::Uri { uri, .. } if uri.starts_with("data:") => ImageKey::Image(ii),
                        gltf::image::Source::Uri { uri, .. } => ImageKey::Uri(uri.to_owned()),
                    };
                    let s = match image_map.by_source.get(&key) {
                        Some(s) => *s,
                        None => {
                            let s = self.load_image(&img, &out.name).map(|t| {
                                mesh.textures.push(t);
                                mesh.textures.len() - 1
                            });
                            if let Some(i) = s {
                                self.texel_budget.add(&mut mesh.textures, i);
                            }
                            image_map.by_source.insert(key, s);
                            s
                        }
                    };
                    image_map.by_image.insert(ii, s);
                    s
                }
            };
            if let Some(texture) = slot {
                let sampler = tex.sampler();
                let wrap = |w: gltf::texture::WrappingMode| match w {
                    gltf::texture::WrappingMode::ClampToEdge => WrapMode::ClampToEdge,
                    gltf::texture::WrappingMode::MirroredRepeat => WrapMode::MirroredRepeat,
                    gltf::texture::WrappingMode::Repeat => WrapMode::Repeat,
                };
                let (transform, uv_set) = match info.texture_transform() {
                    Some(tt) => (
                        UvTransform { offset: tt.offset(), rotation_rad: tt.rotation(), scale: tt.scale() },
                        tt.tex_coord().unwrap_or(info.tex_coord()),
                    ),
                    None => (UvTransform::default(), info.tex_coord()),
                };
                out.base_color_texture = Some(TextureRef {
                    texture,
                    uv_set,
                    wrap_s: wrap(sampler.wrap_s()),
                    wrap_t: wrap(sampler.wrap_t()),
                    mag_filter: match sampler.mag_filter() {
                        Some(gltf::texture::MagFilter::Nearest) => FilterMode::Nearest,
                        _ => FilterMode::Linear,
                    },
                    transform,
                });
            }
        }
        out
    }

    /// Loads and decodes an image; on failure warns and returns `None` (base colour factor used).
    fn load_image(&mut self, img: &gltf::Image, material: &str) -> Option<spherebake_geom::Texture> {
        let ii = img.index();
        if let Some((ti, exts)) = self.sourceless_images.get(&ii) {
            let through = match exts.len() {
                0 => String::new(),
                _ => format!(" (its image comes through {}, which spherebake does not read)", exts.join(", ")),
            };
            self.ctx.warn(format!(
                "material {material:?}: texture {ti} has no source image{through}; using the base colour factor"
            ));
            return None;
        }
        if let Some(ext) = self.undecodable_images.get(&ii) {
            let what = match *ext {
                "KHR_texture_basisu" => "KTX2 / Basis Universal",
                _ => "AVIF",
            };
            self.ctx.warn(format!(
                "material {material:?}: image {ii} is a {what} texture ({ext}), which spherebake cannot decode; using the base colour factor"
            ));
            return None;
        }
        let (name, bytes) = match img.source() {
            gltf::image::Source::View { view, .. } => {
                let name = format!("image[{ii}]{}", img.name().map(|n| format!(" {n}")).unwrap_or_default());
                match self.view_bytes(&view, usize::MAX) {
                    Ok(b) => (name, b.to_vec()),
                    Err(_) => {
                        self.ctx.warn(format!(
                            "material {material:?}: image {ii} buffer view out of range; using the base colour factor"
                        ));
                        return None;
                    }
                }
            }
            // An empty URI names no file (it would resolve to the model's folder itself, which
            // the folder rule refused, failing the import): a texture that cannot be read.
            gltf::image::Source::Uri { uri, .. } if uri.trim().is_empty() => {
                self.ctx.warn(format!(
                    "material {material:?}: image {ii} has an empty uri (no file); using the base colour factor"
                ));
                return None;
            }
            gltf::image::Source::Uri { uri, .. } => match resolve_uri(&self.ctx.dir, uri) {
                Ok(UriData::Inline(b)) => (format!("image[{ii}] (data URI)"), b),
                Ok(UriData::File(p)) => match self.ctx.read_referenced(uri, &p, ReadLimit::AtMost(MAX_IMAGE_BYTES)) {
                    Ok(b) => (p.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default(), b),
                    Err(e) if e.is_refusal() => {
                        self.refused.get_or_insert(e);
                        return None;
                    }
                    Err(e) => {
                        self.ctx.warn(format!("material {material:?}: texture {e}; using the base colour factor"));
                        return None;
                    }
                },
                Err(e) => {
                    self.ctx.warn(format!("material {material:?}: image {ii}: {e}; using the base colour factor"));
                    return None;
                }
            },
        };
        match decode_srgb_texture(name.clone(), &bytes, &mut self.decode_budget) {
            Ok(d) => {
                if let Some(w) = d.reduction_warning(&format!("material {material:?}")) {
                    self.ctx.warn(w);
                }
                Some(d.texture)
            }
            Err(e) if e == OVER_DECODE_BUDGET => None, // one warning for all (`DecodeBudget::warning`)
            Err(e) => {
                self.ctx
                    .warn(format!("material {material:?}: cannot decode {name}: {e}; using the base colour factor"));
                None
            }
        }
    }

    fn animations(&mut self, doc: &gltf::Document) -> Result<Vec<Animation>, IoError> {
        let mut out = Vec::new();
        for anim in doc.animations() {
            let ai = anim.index();
            let mut channels = Vec::new();
            for (ci, ch) in anim.channels().enumerate() {
                let ci = gltf_ext::Prepared::file_channel(&self.channel_numbers, ai, ci);
                let aerr =
                    |reason: String| IoError::Animation { path: self.path(), animation: ai, channel: ci, reason };
                let (path, comps) = match ch.target().property() {
                    gltf::animation::Property::Translation => (AnimPath::Translation, 3),
                    gltf::animation::Property::Rotation => (AnimPath::Rotation, 4),
                    gltf::animation::Property::Scale => (AnimPath::Scale, 3),
                    gltf::animation::Property::MorphTargetWeights => {
                        self.ctx.warn(format!("animation {ai} channel {ci}: morph target weights skipped"));
                        continue;
                    }
                };
                let s = ch.sampler();
                let interpolation = match s.interpolation() {
                    gltf::animation::Interpolation::Linear => Interpolation::Linear,
                    gltf::animation::Interpolation::Step => Interpolation::Step,
                    gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
                };
                let times = self.read_vec(&s.input(), &[1], "animation input")?;
                let values = self.read_vec(&s.output(), &[comps], "animation output")?;
                let times: Vec<f32> = times.values.iter().map(|&t| t as f32).collect();
                if times.is_empty() {
                    self.ctx.warn(format!("animation {ai} channel {ci}: no keys, skipped"));
                    continue;
                }
                if times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[1] < w[0]) {
                    return Err(aerr("key times are not finite and non-decreasing".into()));
                }
                let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
                if values.count() != times.len() * per_key {
                    return Err(aerr(format!(
                        "{} output values for {} keys ({per_key} per key expected)",
                        values.count(),
                        times.len()
                    )));
                }
                let values: Vec<f32> = values.values.iter().map(|&v| v as f32).collect();
                if values.iter().any(|v| !v.is_finite()) {
                    return Err(aerr("non-finite output value".into()));
                }
                channels.push(AnimChannel { node: ch.target().node().index(), path, interpolation, times, values });
            }
            out.push(Animation {
                name: anim.name().map(str::to_owned).unwrap_or_else(|| format!("animation{ai}")),
                channels,
            });
        }
        Ok(out)
    }
}

/// Accumulates primitives into one [`Mesh`], padding optional attributes.
#[derive(Default)]
struct Builder {
    mesh: Mesh,
    uv_present: Vec<bool>,
    colors_present: bool,
    influences: Vec<SkinInfluences>,
    bind: Vec<Vec3>,
}

impl Builder {
    fn push(
        &mut self,
        positions: Vec<Vec3>,
        normals: Vec<Vec3>,
        uv_sets: Vec<Option<Vec<[f32; 2]>>>,
        colors: Option<Vec<[f32; 4]>>,
        tris: &[[u32; 3]],
        material: u32,
    ) {
        let m = &mut self.mesh;
        let v0 = m.positions.len();
        let n = positions.len();
        let sets = m.uvs.len().max(uv_sets.len());
        m.uvs.resize(sets, Vec::new());
        self.uv_present.resize(sets, false);
        for (s, set) in m.uvs.iter_mut().enumerate() {
            set.resize(v0, NO_UV);
            match uv_sets.get(s) {
                Some(Some(uv)) => {
                    set.extend_from_slice(uv);
                    self.uv_present[s] = true;
                }
                _ => set.resize(v0 + n, NO_UV),
            }
        }
        m.colors_linear.resize(v0, [1.0; 4]);
        match colors {
            Some(c) => {
                m.colors_linear.extend_from_slice(&c);
                self.colors_present = true;
            }
            None => m.colors_linear.resize(v0 + n, [1.0; 4]),
        }
        m.positions.extend(positions);
        m.normals.extend(normals);
        let base = v0 as u32;
        m.triangles.extend(tris.iter().map(|t| [t[0] + base, t[1] + base, t[2] + base]));
        m.triangle_materials.extend(std::iter::repeat_n(material, tris.len()));
    }

    fn finish(&mut self) -> Mesh {
        let mut m = std::mem::take(&mut self.mesh);
        // Drop trailing UV sets no primitive had; empty earlier absent ones so that uvs[k] stays
        // TEXCOORD_k. A set some primitives have holds NO_UV at the others' vertices.
        while self.uv_present.last() == Some(&false) {
            self.uv_present.pop();
            m.uvs.pop();
        }
        for (s, present) in self.uv_present.iter().enumerate() {
            if !present {
                m.uvs[s].clear();
            }
        }
        if !self.colors_present {
            m.colors_linear.clear();
        }
        m.rebuild_weld();
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_rfc4648_vectors() {
        // RFC 4648 §10 test vectors.
        for (enc, dec) in [("", ""), ("Zg==", "f"), ("Zm8=", "fo"), ("Zm9v", "foo"), ("Zm9vYmFy", "foobar")] {
            assert_eq!(decode_base64(enc).unwrap(), dec.as_bytes(), "{enc}");
        }
        assert!(decode_base64("Zm9v!").is_err());
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b.bin"), "a b.bin");
        assert_eq!(percent_decode("100%"), "100%");
    }
}
