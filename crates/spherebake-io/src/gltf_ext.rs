//! glTF extensions handled on the JSON before the `gltf` crate sees the document:
//! `extensionsRequired` (checked and stripped: the crate knows neither `KHR_mesh_quantization`
//! nor the meshopt extensions), `EXT_meshopt_compression` / `KHR_meshopt_compression` buffer
//! views (collected here, decoded in [`decode_views`]) and textures whose only image comes
//! through `KHR_texture_basisu` / `EXT_texture_webp` / `EXT_texture_avif` (their `source` is
//! filled in so that the crate accepts them; a WebP image is decoded like a PNG, a Basis or AVIF
//! one is skipped with a warning naming the extension and the material keeps its base colour
//! factor; a texture with no `source` at all, e.g. one only `MSFT_texture_dds` provides, gets a
//! placeholder image that is never decoded, with the same fallback). `EXT_mesh_gpu_instancing` node
//! attributes are collected here too (the importer places one copy of the mesh per instance).

use std::collections::HashMap;
use std::path::Path;

use serde_json::Value;

use crate::meshopt::{self, Filter};
use crate::IoError;

/// Extensions that may appear in `extensionsRequired`: they either do not change geometry or base
/// colour, or are implemented here.
pub(crate) const SUPPORTED_REQUIRED: &[&str] = &[
    "KHR_mesh_quantization",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
    "KHR_texture_transform",
    "KHR_materials_pbrSpecularGlossiness",
    "KHR_materials_unlit",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_materials_clearcoat",
    "KHR_materials_sheen",
    "KHR_lights_punctual",
    "EXT_mesh_gpu_instancing",
    // Texture sources: WebP is decoded; Basis and AVIF cannot be, and the material falls back
    // to its base colour factor with a warning naming the extension.
    "EXT_texture_webp",
    "KHR_texture_basisu",
    "EXT_texture_avif",
];

/// Extensions that `extensionsUsed` may list without a warning besides [`SUPPORTED_REQUIRED`]:
/// read elsewhere (Draco is refused where no uncompressed data remains; pointer animation channels
/// get their own warning), or known to change neither the geometry nor the base colour (with every
/// `KHR_materials_*` but `KHR_materials_variants`, which picks other materials per variant).
const KNOWN_USED: &[&str] = &[
    "KHR_draco_mesh_compression",
    "KHR_animation_pointer",
    "KHR_xmp",
    "KHR_xmp_json_ld",
    "KHR_techniques_webgl",
    "EXT_lights_image_based",
    "MSFT_lod",
    "MSFT_texture_dds",
    "EXT_mesh_features",
    "EXT_structural_metadata",
    "EXT_instance_features",
    "CESIUM_primitive_outline",
];

/// Whether the importer reads `extension` or knows it leaves geometry and base colour alone.
fn known_used(extension: &str) -> bool {
    SUPPORTED_REQUIRED.contains(&extension)
        || KNOWN_USED.contains(&extension)
        || (extension.starts_with("KHR_materials_") && extension != "KHR_materials_variants")
}

const MESHOPT: [&str; 2] = ["EXT_meshopt_compression", "KHR_meshopt_compression"];
/// In order of preference: the first one the texture offers is its image (WebP, which decodes,
/// before the two that do not).
const TEXTURE_SOURCES: [&str; 3] = ["EXT_texture_webp", "KHR_texture_basisu", "EXT_texture_avif"];

/// Compression mode of a meshopt buffer view.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Mode {
    Attributes,
    Triangles,
    Indices,
}

/// One compressed buffer view as declared by its extension object.
#[derive(Clone, Debug)]
pub(crate) struct CompressedView {
    pub view: usize,
    pub extension: &'static str,
    pub buffer: usize,
    pub offset: usize,
    pub length: usize,
    pub stride: usize,
    pub count: usize,
    pub mode: Mode,
    pub filter: Filter,
}

/// What [`prepare`] learnt from the JSON.
#[derive(Debug, Default)]
pub(crate) struct Prepared {
    /// `extensionsRequired` as written in the file (removed from the JSON).
    pub required: Vec<String>,
    /// Names in `extensionsUsed` that the importer neither reads nor knows to be harmless (file
    /// order, each once): the import warns that it reads the file as if they were absent.
    pub unknown_used: Vec<String>,
    pub compressed: Vec<CompressedView>,
    /// Per buffer: marked `fallback` by a meshopt extension (never loaded; no view may read it
    /// except through its compressed data).
    pub fallback: Vec<bool>,
    /// Images reachable only through a texture extension the importer cannot decode.
    pub undecodable_images: HashMap<usize, &'static str>,
    /// Placeholder images added for textures without a `source` (glTF 2.0.1 lets an extension
    /// such as `MSFT_texture_dds` supply it): the texture's index and the extensions it names.
    /// Never decoded; the material keeps its base colour factor.
    pub sourceless_images: HashMap<usize, (usize, Vec<String>)>,
    /// `EXT_mesh_gpu_instancing` per node: accessor of TRANSLATION, ROTATION, SCALE.
    pub instancing: HashMap<usize, [Option<usize>; 3]>,
    /// Animation channels removed because their target names no node (glTF 2.0 allows it, e.g.
    /// `KHR_animation_pointer` targets, which the importer does not read; the gltf crate refuses
    /// such a file).
    pub channels_without_node: usize,
    /// Per animation that lost channels: the file's index of each channel kept, so messages
    /// name the channel as the file numbers it ([`Prepared::file_channel`]).
    pub channel_numbers: HashMap<usize, Vec<usize>>,
}

impl Prepared {
    /// The file's index of channel `ci` (as the gltf crate numbers it) of animation `ai`.
    pub fn file_channel(numbers: &HashMap<usize, Vec<usize>>, ai: usize, ci: usize) -> usize {
        numbers.get(&ai).and_then(|v| v.get(ci).copied()).unwrap_or(ci)
    }
}

fn as_index(v: &Value) -> Option<usize> {
    v.as_u64().and_then(|x| usize::try_from(x).ok())
}

/// Checks and strips `extensionsRequired`, collects meshopt views and fallback buffers, and fills
/// in texture sources that only an extension provides.
pub(crate) fn prepare(path: &Path, root: &mut Value) -> Result<Prepared, IoError> {
    let mut prep = Prepared::default();
    let Some(obj) = root.as_object_mut() else {
        return Err(IoError::Json { path: path.to_path_buf(), message: "top level is not a JSON object".into() });
    };
    if let Some(req) = obj.remove("extensionsRequired") {
        let list = req.as_array().ok_or_else(|| IoError::Invalid {
            path: path.to_path_buf(),
            message: "extensionsRequired is not an array".into(),
        })?;
        for ext in list {
            let ext = ext.as_str().ok_or_else(|| IoError::Invalid {
                path: path.to_path_buf(),
                message: "extensionsRequired holds a non-string".into(),
            })?;
            if !SUPPORTED_REQUIRED.contains(&ext) {
                return Err(IoError::UnsupportedExtension { path: path.to_path_buf(), extension: ext.to_owned() });
            }
            prep.required.push(ext.to_owned());
        }
    }
    if let Some(used) = obj.get("extensionsUsed").and_then(Value::as_array) {
        for ext in used.iter().filter_map(Value::as_str) {
            if !known_used(ext) && !prep.unknown_used.iter().any(|u| u == ext) {
                prep.unknown_used.push(ext.to_owned());
            }
        }
    }
    // A scene's `nodes` is optional in glTF 2.0 (scene.schema.json); gltf-json requires it, so
    // a scene without it gets an empty list (an empty scene: nothing to import if it is the one
    // used, see `gltf_import`; harmless otherwise).
    if let Some(scenes) = obj.get_mut("scenes").and_then(Value::as_array_mut) {
        for scene in scenes.iter_mut().filter_map(Value::as_object_mut) {
            scene.entry("nodes").or_insert_with(|| Value::Array(Vec::new()));
        }
    }
    // Channels whose target has no node (optional in glTF 2.0) are removed before the gltf crate,
    // which requires one, sees them.
    if let Some(anims) = obj.get_mut("animations").and_then(Value::as_array_mut) {
        for (ai, anim) in anims.iter_mut().enumerate() {
            if let Some(channels) = anim.get_mut("channels").and_then(Value::as_array_mut) {
                let kept: Vec<usize> =
                    (0..channels.len()).filter(|&ci| channels[ci].pointer("/target/node").is_some()).collect();
                if kept.len() < channels.len() {
                    prep.channels_without_node += channels.len() - kept.len();
                    channels.retain(|c| c.pointer("/target/node").is_some());
                    prep.channel_numbers.insert(ai, kept);
                }
            }
        }
    }
    // Draco only listed in extensionsUsed (optional): a primitive that carries it and whose
    // POSITION accessor has no data can only be read through Draco, so name it.
    const DRACO: &str = "KHR_draco_mesh_compression";
    if let Some(meshes) = obj.get("meshes").and_then(Value::as_array) {
        let accessors = obj.get("accessors").and_then(Value::as_array);
        for m in meshes {
            for prim in m.get("primitives").and_then(Value::as_array).into_iter().flatten() {
                if prim.pointer(&format!("/extensions/{DRACO}")).is_none() {
                    continue;
                }
                let pos = prim.pointer("/attributes/POSITION").and_then(as_index);
                let has_data =
                    pos.and_then(|i| accessors.and_then(|a| a.get(i))).is_some_and(|a| a.get("bufferView").is_some());
                if !has_data {
                    return Err(IoError::UnsupportedExtension { path: path.to_path_buf(), extension: DRACO.into() });
                }
            }
        }
    }
    if let Some(buffers) = obj.get("buffers").and_then(Value::as_array) {
        prep.fallback = buffers
            .iter()
            .map(|b| {
                MESHOPT
                    .iter()
                    .any(|e| b.pointer(&format!("/extensions/{e}/fallback")).and_then(Value::as_bool) == Some(true))
            })
            .collect();
    }
    if let Some(views) = obj.get("bufferViews").and_then(Value::as_array) {
        for (vi, v) in views.iter().enumerate() {
            for ext in MESHOPT {
                let Some(e) = v.pointer(&format!("/extensions/{ext}")) else { continue };
                let err = |reason: String| IoError::CompressedView {
                    path: path.to_path_buf(),
                    view: vi,
                    extension: ext.to_owned(),
                    reason,
                };
                let field = |name: &str, default: Option<usize>| -> Result<usize, IoError> {
                    match e.get(name) {
                        Some(x) => as_index(x).ok_or_else(|| err(format!("{name} is not a non-negative integer"))),
                        None => default.ok_or_else(|| err(format!("{name} is missing"))),
                    }
                };
                let mode = match e.get("mode").and_then(Value::as_str) {
                    Some("ATTRIBUTES") => Mode::Attributes,
                    Some("TRIANGLES") => Mode::Triangles,
                    Some("INDICES") => Mode::Indices,
                    Some(m) => return Err(err(format!("unknown mode {m:?}"))),
                    None => return Err(err("mode is missing".into())),
                };
                let filter = match e.get("filter") {
                    None => Filter::None,
                    Some(f) => {
                        let name = f.as_str().unwrap_or("");
                        Filter::from_name(name).ok_or_else(|| err(format!("unknown filter {f}")))?
                    }
                };
                if mode != Mode::Attributes && filter != Filter::None {
                    return Err(err(format!("filter {filter:?} is only allowed with mode ATTRIBUTES")));
                }
                prep.compressed.push(CompressedView {
                    view: vi,
                    extension: ext,
                    buffer: field("buffer", None)?,
                    offset: field("byteOffset", Some(0))?,
                    length: field("byteLength", None)?,
                    stride: field("byteStride", None)?,
                    count: field("count", None)?,
                    mode,
                    filter,
                });
                break;
            }
        }
    }
    if let Some(nodes) = obj.get("nodes").and_then(Value::as_array) {
        for (ni, n) in nodes.iter().enumerate() {
            let Some(attrs) = n.pointer("/extensions/EXT_mesh_gpu_instancing/attributes") else { continue };
            let mut acc = [None; 3];
            for (k, name) in ["TRANSLATION", "ROTATION", "SCALE"].iter().enumerate() {
                if let Some(a) = attrs.get(*name) {
                    acc[k] = Some(as_index(a).ok_or_else(|| IoError::Invalid {
                        path: path.to_path_buf(),
                        message: format!("nodes[{ni}]: EXT_mesh_gpu_instancing {name} is not an accessor index"),
                    })?);
                }
            }
            prep.instancing.insert(ni, acc);
        }
    }
    // Textures left without a source (optional since glTF 2.0.1 when an extension such as
    // MSFT_texture_dds supplies the image), by index, with the extensions they name.
    let mut sourceless: Vec<(usize, Vec<String>)> = Vec::new();
    if let Some(textures) = obj.get_mut("textures").and_then(Value::as_array_mut) {
        for (ti, t) in textures.iter_mut().enumerate() {
            let Some(t) = t.as_object_mut() else { continue };
            if t.contains_key("source") {
                continue; // a fallback image the importer may be able to decode
            }
            let mut found = false;
            for ext in TEXTURE_SOURCES {
                let src = t.get("extensions").and_then(|e| e.get(ext)).and_then(|e| e.get("source")).and_then(as_index);
                if let Some(src) = src {
                    t.insert("source".into(), Value::from(src));
                    if ext != "EXT_texture_webp" {
                        prep.undecodable_images.insert(src, ext); // WebP is decoded (image crate)
                    }
                    found = true;
                    break;
                }
            }
            if !found {
                let exts = t.get("extensions").and_then(Value::as_object).map(|e| e.keys().cloned().collect());
                sourceless.push((ti, exts.unwrap_or_default()));
            }
        }
    }
    // The gltf crate requires a source: each such texture gets an empty placeholder image of its
    // own, which the importer never decodes (a warning, the base colour factor is used).
    if !sourceless.is_empty() {
        let images = obj.entry("images").or_insert_with(|| Value::Array(Vec::new()));
        let Some(images) = images.as_array_mut() else {
            return Err(IoError::Invalid { path: path.to_path_buf(), message: "images is not an array".into() });
        };
        let mut placeholders = Vec::with_capacity(sourceless.len());
        for (ti, exts) in sourceless {
            let ii = images.len();
            images.push(serde_json::json!({ "uri": "data:application/octet-stream;base64," }));
            placeholders.push((ti, ii));
            prep.sourceless_images.insert(ii, (ti, exts));
        }
        if let Some(textures) = obj.get_mut("textures").and_then(Value::as_array_mut) {
            for (ti, ii) in placeholders {
                if let Some(t) = textures[ti].as_object_mut() {
                    t.insert("source".into(), Value::from(ii));
                }
            }
        }
    }
    Ok(prep)
}

/// Decodes every compressed view from the loaded `buffers` (fallback buffers are empty).
/// `views[i]` is the declared `(byteLength, buffer)` of buffer view `i`.
pub(crate) fn decode_views(
    path: &Path,
    prep: &Prepared,
    views: &[(usize, usize)],
    buffers: &[Vec<u8>],
) -> Result<HashMap<usize, Vec<u8>>, IoError> {
    let mut out = HashMap::new();
    for cv in &prep.compressed {
        let err = |reason: String| IoError::CompressedView {
            path: path.to_path_buf(),
            view: cv.view,
            extension: cv.extension.into(),
            reason,
        };
        let Some(&(view_len, _)) = views.get(cv.view) else {
            return Err(err("buffer view does not exist".into()));
        };
        if cv.stride.checked_mul(cv.count) != Some(view_len) {
            return Err(err(format!(
                "byteStride {} × count {} does not equal the buffer view's byteLength {view_len}",
                cv.stride, cv.count
            )));
        }
        if prep.fallback.get(cv.buffer).copied().unwrap_or(false) {
            return Err(err(format!("compressed data in buffer {}, which is a fallback buffer", cv.buffer)));
        }
        let buf = buffers.get(cv.buffer).ok_or_else(|| err(format!("buffer {} does not exist", cv.buffer)))?;
        let src = cv
            .offset
            .checked_add(cv.length)
            .filter(|&end| end <= buf.len())
            .map(|end| &buf[cv.offset..end])
            .ok_or_else(|| {
                err(format!(
                    "compressed range {}..+{} exceeds buffer {} of {} bytes",
                    cv.offset,
                    cv.length,
                    cv.buffer,
                    buf.len()
                ))
            })?;
        let what = |m: &str, e: meshopt::MeshoptError| err(format!("{m}: {e}"));
        let data = match cv.mode {
            Mode::Attributes => {
                let mut d =
                    meshopt::decode_vertex_buffer(cv.count, cv.stride, src).map_err(|e| what("ATTRIBUTES", e))?;
                meshopt::apply_filter(cv.filter, cv.stride, &mut d).map_err(|e| what("filter", e))?;
                d
            }
            Mode::Triangles | Mode::Indices => {
                let indices = if cv.mode == Mode::Triangles {
                    meshopt::decode_index_buffer(cv.count, src).map_err(|e| what("TRIANGLES", e))?
                } else {
                    meshopt::decode_index_sequence(cv.count, src).map_err(|e| what("INDICES", e))?
                };
                match cv.stride {
                    2 => {
                        let mut d = Vec::with_capacity(indices.len() * 2);
                        for (k, &i) in indices.iter().enumerate() {
                            let i = u16::try_from(i)
                                .map_err(|_| err(format!("index {i} at position {k} does not fit byteStride 2")))?;
                            d.extend_from_slice(&i.to_le_bytes());
                        }
                        d
                    }
                    4 => indices.iter().flat_map(|i| i.to_le_bytes()).collect(),
                    s => return Err(err(format!("byteStride {s} for index data (expected 2 or 4)"))),
                }
            }
        };
        out.insert(cv.view, data);
    }
    Ok(out)
}
