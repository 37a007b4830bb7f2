//! spherebake-io: mesh import (glTF 2.0 `.gltf` / `.glb`, OBJ + MTL) into the canonical
//! [`spherebake_geom::Mesh`], texture decoding (sRGB → linear) and input hashing.
//!
//! Architecture invariant: this is the only crate that knows input file formats. Everything it
//! returns is in scene space (glTF node transforms applied, skinned meshes posed at rest), colours
//! are linear, and UVs follow the glTF convention (v = 0 at the top row of the image).
//!
//! Entry points: [`load_mesh`] (reads the file and everything it references) and
//! [`load_mesh_from_bytes`] (the model bytes are given; referenced files are still read relative
//! to the path).
//!
//! # glTF extensions
//!
//! What asset pipelines ship, gltfpack output in particular, imports directly:
//!
//! | extension | handling |
//! |---|---|
//! | `KHR_mesh_quantization` | integer / normalized positions, normals, UVs, colours; the dequantizing node transform, inverse bind matrices or `KHR_texture_transform` are applied as usual |
//! | `EXT_meshopt_compression`, `KHR_meshopt_compression` | buffer views decoded by [`meshopt`] (attribute codec v0 and v1, triangle and index-sequence codecs, all four filters); `fallback` buffers are never read |
//! | `EXT_mesh_gpu_instancing` | one copy of the mesh per instance |
//! | `KHR_texture_transform` | kept on the material's [`spherebake_geom::TextureRef`] |
//! | `EXT_texture_webp` | a fallback PNG / JPEG `source` is used when present, otherwise the WebP image (lossy or lossless, decoded like a PNG) |
//! | `KHR_texture_basisu`, `EXT_texture_avif` | a fallback PNG / JPEG `source` is used when present; otherwise a warning naming the extension and the base colour factor |
//! | `MSFT_texture_dds` (or any texture without `source`, allowed since glTF 2.0.1) | a warning naming the texture and its extensions; the base colour factor |
//! | `KHR_materials_pbrSpecularGlossiness` | its diffuse factor and texture are the base colour |
//! | other `KHR_materials_*`, `KHR_lights_punctual` | ignored (no effect on geometry or base colour) |
//!
//! Any other extension in `extensionsRequired` (for example `KHR_draco_mesh_compression`) is an
//! [`IoError::UnsupportedExtension`] naming it. One listed only in `extensionsUsed` that the
//! importer neither reads nor knows to leave geometry and base colour alone (for example
//! `KHR_node_visibility`, `KHR_materials_variants`, a vendor's) is named in one warning. A malformed compressed view is an
//! [`IoError::CompressedView`] naming the buffer view, the extension and what is wrong.
//!
//! # OBJ
//!
//! An OBJ file's lines are checked first (an error names its line); its geometry is then read by
//! this crate's own parse (`obj_parse`), which reads the checked text exactly as `tobj` 4.0.5
//! does (the same models, vertices, indices, names and materials, bit for bit: a test compares
//! the two on generated and real files) in under half tobj's time; MTL files are read with
//! `tobj`. A face of four or more corners (a polygon) is triangulated in the plane of its Newell
//! normal, keeping its winding (each triangle faces the way the polygon does): a polygon that
//! the fan from its first corner covers exactly, every convex one among them, gets that fan
//! (the triangles tobj gave every face before); any other (concave: an L, a star) is
//! ear-clipped, deterministically and in O(n²) for n corners, so no triangle covers area outside
//! the face. A concave polygon of more than 256 corners, or one where no ear is found
//! (self-intersecting or degenerate), gets the fan, and one warning for the file counts them.
//!
//! One `mtllib` statement may name several libraries (`mtllib a.mtl b.mtl`: each is read, a
//! later library's definition of a material name winning, as with two `mtllib` lines); a name
//! with spaces is one library when such a file exists (`mtllib my lib.mtl`), else one library
//! per word. `mtllib` paths are relative to the OBJ's folder, and a material's texture paths
//! (`map_Kd`, `map_d`) to the folder of the MTL file that defines it (`mtllib t1/a.mtl` then
//! `mtllib t2/b.mtl`: a `map_Kd tex.png` of a.mtl is t1/tex.png), all confined to the model's
//! folder tree as [`ImportOptions`] says. A `usemtl` name is looked up in all the file's
//! libraries, wherever their `mtllib` lines are (a `usemtl` before the `mtllib` that defines
//! it finds it), as Blender reads them.

mod error;
mod gltf_ext;
mod gltf_import;
mod hash;
pub mod meshopt;
mod obj_import;
mod obj_parse;
mod polygon;
mod texture;

use std::ops::Range;
use std::path::{Path, PathBuf};

pub use error::IoError;
pub use hash::Fnv1a64;
pub use spherebake_geom::{Mesh, Warning};
pub use texture::{srgb_to_linear, MAX_DECODED_PIXELS, MAX_TOTAL_TEXELS};

/// Where one primitive (glTF) or model (OBJ) landed in the imported [`Mesh`].
#[derive(Clone, Debug, PartialEq)]
pub struct ImportedPart {
    /// glTF mesh index, or the OBJ model index (object / group / material run).
    pub source_mesh: usize,
    /// Primitive index within the glTF mesh (0 for OBJ).
    pub primitive: usize,
    /// glTF node that instances the mesh (`None` for OBJ).
    pub node: Option<usize>,
    /// World matrix of that node at rest (scene space ← mesh space; identity for OBJ). Rigid parts
    /// were placed with it; skinned parts are placed by their joints instead (glTF ignores the
    /// skinned node's own transform).
    pub node_world: glam::Mat4,
    /// Vertices stored in the file for this part (glTF `POSITION` count; OBJ: the vertices of
    /// this model as tobj's reading keeps them, i.e. unique position/uv/normal corners).
    pub file_vertex_count: usize,
    /// The part's vertices in [`Mesh::positions`].
    pub vertices: Range<u32>,
    /// The part's triangles in [`Mesh::triangles`].
    pub triangles: Range<u32>,
}

/// The result of importing one model file.
#[derive(Clone, Debug)]
pub struct Imported {
    pub mesh: Mesh,
    /// Things the importer coped with (missing texture, skipped primitive, ...).
    pub warnings: Vec<Warning>,
    /// Every file read, in read order: the model, then `.bin` / `.mtl` / image files (for
    /// depfiles). Data URIs and GLB chunks are not files and are not listed.
    pub inputs: Vec<PathBuf>,
    /// Referenced files that did not exist (a missing texture the import warned about): not
    /// inputs, but a bake depends on them appearing (depfiles list them, and the up-to-date check
    /// re-bakes once one exists). In reference order, each once.
    pub missing: Vec<PathBuf>,
    /// FNV-1a 64 of all input bytes in read order (model bytes first, then each referenced file).
    pub content_hash: u64,
    /// One entry per imported primitive instance / OBJ model, in import order.
    pub parts: Vec<ImportedPart>,
}

/// Which importer a path goes to, by its (case-insensitive) extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Gltf,
    Glb,
    Obj,
}

fn kind_of(path: &Path) -> Result<Kind, IoError> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    match ext.as_str() {
        "gltf" => Ok(Kind::Gltf),
        "glb" => Ok(Kind::Glb),
        "obj" => Ok(Kind::Obj),
        _ => Err(IoError::UnknownFileType { path: path.to_path_buf(), extension: ext }),
    }
}

/// Default [`ImportOptions::max_input_bytes`]: 1 GiB read per model, the model file and every
/// file it references together.
pub const DEFAULT_MAX_INPUT_BYTES: u64 = 1 << 30;
/// Largest |coordinate| accepted (scene space): squared distances of bounding spheres must stay
/// finite in f32 (max 3.4e38, so distances up to about 1.8e19).
pub const MAX_COORDINATE: f32 = 1e18;
/// Largest image file read for a texture (256 MiB); a larger one is a warning and the base
/// colour factor is used.
pub const MAX_IMAGE_BYTES: u64 = 256 << 20;
/// Largest `.mtl` file read (16 MiB).
pub const MAX_MTL_BYTES: u64 = 16 << 20;

/// What an import may read.
///
/// By default every file a model references (glTF buffer and image `uri`s after
/// percent-decoding, OBJ `mtllib`, `map_Kd` and `map_d`) must resolve, symlinks included, to a regular
/// file inside the model's folder tree (the directory of the model path and its
/// sub-directories); anything else is an error naming the URI, and the file is not opened.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImportOptions {
    /// Allow referenced files outside the model's folder tree (trusted layouts that share
    /// textures between folders). Default false.
    pub allow_outside_paths: bool,
    /// Bytes read per model in total (model + buffers + images + MTL); reading more is an error.
    /// Default [`DEFAULT_MAX_INPUT_BYTES`]. It also bounds what a glTF file may expand to
    /// without bytes to match: one vertex per byte (all placements of its meshes together, at
    /// most 2²⁷) and one value per byte materialised from accessors without a buffer view
    /// (every read counted); past either the import is an [`IoError::OverLimit`].
    pub max_input_bytes: u64,
    /// Texels the decoded textures of a model may hold together; over it, the largest are
    /// halved as they are read (`texture::TexelBudget`), with a warning. Default
    /// [`MAX_TOTAL_TEXELS`] (4 × 4096²).
    pub max_texels: usize,
    /// Pixels the images of a model may decode together, from their headers; past it an image
    /// is not decoded (a warning; the base colour factor is used). Default
    /// [`MAX_DECODED_PIXELS`] (2³¹). The encoded bytes the images are read from are held to
    /// `max_input_bytes` together the same way.
    pub max_decoded_pixels: u64,
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self {
            allow_outside_paths: false,
            max_input_bytes: DEFAULT_MAX_INPUT_BYTES,
            max_texels: MAX_TOTAL_TEXELS,
            max_decoded_pixels: MAX_DECODED_PIXELS,
        }
    }
}

static DEFAULT_OPTIONS: std::sync::OnceLock<ImportOptions> = std::sync::OnceLock::new();

/// Sets the options [`load_mesh`] and [`load_mesh_from_bytes`] use for the rest of the process
/// (the CLI sets them once from its flags). Returns false if they were already set.
pub fn set_default_options(opts: ImportOptions) -> bool {
    DEFAULT_OPTIONS.set(opts).is_ok()
}

/// The options [`load_mesh`] uses: those given to [`set_default_options`], else the defaults.
pub fn default_options() -> ImportOptions {
    DEFAULT_OPTIONS.get().copied().unwrap_or_default()
}

/// Imports a `.gltf`, `.glb` or `.obj` file (dispatch by extension) with everything it
/// references, under the process's default [`ImportOptions`].
pub fn load_mesh(path: &Path) -> Result<Imported, IoError> {
    load_mesh_with(path, &default_options())
}

/// [`load_mesh`] with explicit options.
pub fn load_mesh_with(path: &Path, opts: &ImportOptions) -> Result<Imported, IoError> {
    kind_of(path)?;
    let bytes = read_bounded(path, path, None, opts.max_input_bytes, ReadLimit::Whole)?;
    load_mesh_from_bytes_with(path, &bytes, opts)
}

/// Imports model `bytes` as if read from `path`: the extension of `path` picks the format, and
/// external buffers, images and `.mtl` files are resolved (and read) relative to its directory
/// (an MTL file's textures relative to the MTL file's).
/// `path` is listed first in [`Imported::inputs`] and `bytes` start the content hash.
pub fn load_mesh_from_bytes(path: &Path, bytes: &[u8]) -> Result<Imported, IoError> {
    load_mesh_from_bytes_with(path, bytes, &default_options())
}

/// [`load_mesh_from_bytes`] with explicit options.
pub fn load_mesh_from_bytes_with(path: &Path, bytes: &[u8], opts: &ImportOptions) -> Result<Imported, IoError> {
    import_bytes(path, bytes, opts, None)
}

/// Imports model `bytes` as if read from `path`, with every referenced file taken from `files`
/// (keys: paths as the model would resolve them, i.e. joined onto `path`'s directory; `..` and
/// `.` are normalised) instead of the file system: nothing is opened. The folder, byte-length
/// and budget rules of [`ImportOptions`] apply as for files. For fuzzing and for callers that
/// hold assets in memory.
pub fn load_mesh_from_memory(
    path: &Path,
    bytes: &[u8],
    files: std::collections::BTreeMap<PathBuf, Vec<u8>>,
    opts: &ImportOptions,
) -> Result<Imported, IoError> {
    let files: std::collections::BTreeMap<PathBuf, Vec<u8>> =
        files.into_iter().map(|(k, v)| (normalise(&k), v)).collect();
    let resolver: Resolver = std::sync::Arc::new(move |p: &Path| files.get(&normalise(p)).cloned());
    import_bytes(path, bytes, opts, Some(resolver))
}

/// Referenced-file bytes by resolved path (in-memory imports).
pub(crate) type Resolver = std::sync::Arc<ResolveFn>;
/// What a [`Resolver`] calls: resolved path → bytes, `None` when there is no such file.
pub(crate) type ResolveFn = dyn Fn(&Path) -> Option<Vec<u8>> + Send + Sync;

fn import_bytes(
    path: &Path,
    bytes: &[u8],
    opts: &ImportOptions,
    resolver: Option<Resolver>,
) -> Result<Imported, IoError> {
    let kind = kind_of(path)?;
    if bytes.len() as u64 > opts.max_input_bytes {
        return Err(IoError::TooLarge {
            path: path.to_path_buf(),
            what: None,
            limit: opts.max_input_bytes,
            budget: true,
        });
    }
    let mut ctx = Ctx::new(path, *opts);
    ctx.resolver = resolver;
    ctx.record(path, bytes);
    // A glTF file is read by its content, as cgltf does: the GLB magic means binary whatever the
    // extension (a `.gltf` holding GLB bytes, a `.glb` holding JSON text).
    let kind = match kind {
        Kind::Gltf | Kind::Glb if bytes.starts_with(b"glTF") => Kind::Glb,
        Kind::Glb
            if bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes).iter().find(|b| !b.is_ascii_whitespace())
                == Some(&b'{') =>
        {
            Kind::Gltf // JSON text, after a byte-order mark if any (skipped by the glTF reader)
        }
        k => k,
    };
    let (mut mesh, mut parts) = match kind {
        Kind::Gltf => gltf_import::import(&mut ctx, bytes, false)?,
        Kind::Glb => gltf_import::import(&mut ctx, bytes, true)?,
        Kind::Obj => obj_import::import(&mut ctx, bytes)?,
    };
    if mesh.triangles.is_empty() {
        return Err(IoError::EmptyMesh { path: path.to_path_buf(), reason: None });
    }
    // Stacked copies of a face are one surface (`Mesh::remove_duplicate_triangles`): removed
    // here, so every command (bake, eval, inspect, the light checks) reads the same mesh.
    // A face kept that was there as often in one winding as in the other encloses nothing:
    // surface only (`Mesh::surface_only`), left out of the solid but covered.
    let (removed, balanced) = mesh.duplicate_triangles_balanced();
    if removed.contains(&true) {
        let surface_only = mesh.set_surface_only(&removed, &balanced);
        // Each part's triangle range, in the triangles kept.
        let mut kept_before = Vec::with_capacity(removed.len() + 1);
        kept_before.push(0u32);
        for &r in &removed {
            kept_before.push(kept_before[kept_before.len() - 1] + u32::from(!r));
        }
        let at = |i: u32| kept_before.get(i as usize).copied().unwrap_or(kept_before[removed.len()]);
        for p in &mut parts {
            p.triangles = at(p.triangles.start)..at(p.triangles.end);
        }
        let count = mesh.remove_triangles(&removed);
        ctx.warn(format!(
            "{count} duplicate triangles (the same three vertices as an earlier one, in either orientation) removed{}",
            if surface_only > 0 {
                format!("; {surface_only} face(s) kept were there as often in each winding (double-sided, enclosing nothing): surface only, covered by the spheres but left out of the solid and the closed check")
            } else {
                String::new()
            }
        ));
    }
    if let Some(v) = mesh.positions.iter().flat_map(|p| p.to_array()).find(|c| c.abs() > MAX_COORDINATE) {
        return Err(IoError::CoordinateRange { path: path.to_path_buf(), value: v, limit: MAX_COORDINATE });
    }
    let (materials, vertices) = clamp_colours(&mut mesh);
    if materials + vertices > 0 {
        ctx.warn(format!(
            "colours outside [0, 1] clamped: {materials} material colour(s) (base colour factor, OBJ Kd / d), {vertices} vertex colour(s); an albedo above 1 would reflect more light than it receives, a NaN is read as 0"
        ));
    }
    Ok(Imported {
        mesh,
        warnings: ctx.warnings,
        inputs: ctx.inputs,
        missing: ctx.missing,
        content_hash: ctx.hash.finish(),
        parts,
    })
}

/// Import state shared by the format importers: the model path, inputs read, hash, warnings.
pub(crate) struct Ctx {
    pub path: PathBuf,
    pub dir: PathBuf,
    pub inputs: Vec<PathBuf>,
    /// Referenced files not found ([`Imported::missing`]).
    pub missing: Vec<PathBuf>,
    pub hash: Fnv1a64,
    pub warnings: Vec<Warning>,
    pub opts: ImportOptions,
    /// Bytes read so far (model included), against `opts.max_input_bytes`.
    pub read_total: u64,
    /// In-memory referenced files instead of the file system ([`load_mesh_from_memory`]).
    pub resolver: Option<Resolver>,
}

/// How much of a referenced file to read.
#[derive(Clone, Copy, Debug)]
pub(crate) enum ReadLimit {
    /// The whole file (up to the input budget).
    Whole,
    /// At most this many bytes, the rest is not read (a glTF buffer's declared `byteLength`).
    Prefix(u64),
    /// The whole file, which must not be longer than this (images, MTL).
    AtMost(u64),
}

impl Ctx {
    fn new(path: &Path, opts: ImportOptions) -> Self {
        Self {
            path: path.to_path_buf(),
            dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
            inputs: Vec::new(),
            missing: Vec::new(),
            hash: Fnv1a64::new(),
            warnings: Vec::new(),
            opts,
            read_total: 0,
            resolver: None,
        }
    }

    fn record(&mut self, path: &Path, bytes: &[u8]) {
        self.inputs.push(path.to_path_buf());
        self.hash.write(bytes);
        self.read_total += bytes.len() as u64;
    }

    pub fn warn(&mut self, msg: String) {
        self.warnings.push(Warning(msg));
    }

    /// Reads the file `uri` (as written in the model) names, resolved to `path`, after checking
    /// it is a regular file inside the model's folder tree (unless allowed); records it as an
    /// input.
    pub fn read_referenced(&mut self, uri: &str, path: &Path, limit: ReadLimit) -> Result<Vec<u8>, IoError> {
        let budget = self.opts.max_input_bytes.saturating_sub(self.read_total);
        let r = self.resolver.as_deref();
        let bytes = read_confined(&self.path, &self.dir, &self.opts, uri, path, budget, limit, r).inspect_err(|e| {
            if matches!(e, IoError::ReferenceNotFound { .. }) && !self.missing.iter().any(|m| m == path) {
                self.missing.push(path.to_path_buf());
            }
        })?;
        self.record(path, &bytes);
        Ok(bytes)
    }
}

/// Lexically normalised `p`: `.` dropped, `..` removes the previous component (leading `..`
/// kept).
fn normalise(p: &Path) -> PathBuf {
    use std::path::Component;
    let mut out: Vec<Component> = Vec::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => match out.last() {
                Some(Component::Normal(_)) => {
                    out.pop();
                }
                Some(Component::RootDir | Component::Prefix(_)) => {}
                _ => out.push(c),
            },
            c => out.push(c),
        }
    }
    out.iter().map(|c| c.as_os_str()).collect()
}

/// Whether `path` lies inside `dir` lexically (after [`normalise`]).
fn lexically_inside(dir: &Path, path: &Path) -> bool {
    use std::path::Component;
    let (nd, nf) = (normalise(dir), normalise(path));
    match nf.strip_prefix(&nd) {
        Ok(rest) => !rest.is_absolute() && !matches!(rest.components().next(), Some(Component::ParentDir) | None),
        Err(_) => false,
    }
}

/// The checks of [`Ctx::read_referenced`], usable without a `Ctx` (the OBJ `mtllib` callback).
/// `model` is the model path (errors name it), `dir` its directory, `budget` what may still be
/// read.
#[allow(clippy::too_many_arguments)]
pub(crate) fn read_confined(
    model: &Path,
    dir: &Path,
    opts: &ImportOptions,
    uri: &str,
    path: &Path,
    budget: u64,
    limit: ReadLimit,
    resolver: Option<&ResolveFn>,
) -> Result<Vec<u8>, IoError> {
    let outside = || IoError::OutsideAsset { path: model.to_path_buf(), uri: uri.to_owned() };
    if !opts.allow_outside_paths && !lexically_inside(dir, path) {
        // Lexically first: an absolute URI or `../` is refused without touching the file system.
        return Err(outside());
    }
    if let Some(resolve) = resolver {
        let mut bytes = resolve(path).ok_or_else(|| IoError::ReferenceNotFound {
            path: model.to_path_buf(),
            uri: uri.to_owned(),
            resolved: path.to_path_buf(),
        })?;
        let (cap, prefix) = match limit {
            ReadLimit::Whole => (budget, false),
            ReadLimit::Prefix(n) => (n.min(budget), n <= budget),
            ReadLimit::AtMost(n) => (n.min(budget), false),
        };
        if bytes.len() as u64 > cap {
            if !prefix {
                let budget_hit = !matches!(limit, ReadLimit::AtMost(n) if n <= budget);
                let limit = if budget_hit { budget } else { cap };
                return Err(IoError::TooLarge {
                    path: model.to_path_buf(),
                    what: Some(uri.to_owned()),
                    limit,
                    budget: budget_hit,
                });
            }
            bytes.truncate(cap as usize);
        }
        return Ok(bytes);
    }
    if !opts.allow_outside_paths {
        // Then after symlink resolution.
        let root = std::fs::canonicalize(if dir.as_os_str().is_empty() { Path::new(".") } else { dir })
            .map_err(|e| IoError::Read { path: model.to_path_buf(), cause: e })?;
        match std::fs::canonicalize(path) {
            Ok(c) if c.starts_with(&root) => {}
            Ok(_) => return Err(outside()),
            Err(e) => return Err(read_error(model, path, Some(uri), e)),
        }
    }
    read_bounded(model, path, Some(uri), budget, limit)
}

/// The error for an OS error reading `path`: naming the file itself, or for a file the model
/// references (`uri` given) naming the model and the reference.
fn read_error(model: &Path, path: &Path, uri: Option<&str>, e: std::io::Error) -> IoError {
    match (uri, e.kind()) {
        (None, std::io::ErrorKind::NotFound) => IoError::NotFound { path: path.to_path_buf() },
        (None, _) => IoError::Read { path: path.to_path_buf(), cause: e },
        (Some(u), std::io::ErrorKind::NotFound) => {
            IoError::ReferenceNotFound { path: model.to_path_buf(), uri: u.to_owned(), resolved: path.to_path_buf() }
        }
        (Some(u), _) => IoError::ReferenceRead { path: model.to_path_buf(), uri: u.to_owned(), cause: e },
    }
}

/// Reads a regular file under `limit` and the input `budget`, never more than one byte past
/// either: a device (`/dev/zero`), FIFO or directory is refused before it is read.
pub(crate) fn read_bounded(
    model: &Path,
    path: &Path,
    what: Option<&str>,
    budget: u64,
    limit: ReadLimit,
) -> Result<Vec<u8>, IoError> {
    use std::io::Read;
    let io = |e: std::io::Error| read_error(model, path, what, e);
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(IoError::NotRegularFile { path: model.to_path_buf(), uri: what.map(str::to_owned) });
    }
    let (cap, prefix) = match limit {
        ReadLimit::Whole => (budget, false),
        ReadLimit::Prefix(n) => (n.min(budget), n <= budget),
        ReadLimit::AtMost(n) => (n.min(budget), false),
    };
    let f = std::fs::File::open(path).map_err(io)?;
    let mut bytes = Vec::with_capacity(meta.len().min(cap) as usize);
    f.take(cap.saturating_add(1)).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > cap {
        if prefix {
            bytes.truncate(cap as usize);
        } else {
            let (limit, budget_hit) = match limit {
                ReadLimit::AtMost(n) if n <= budget => (n, false),
                _ => (budget, true),
            };
            let what = what.map(str::to_owned);
            return Err(IoError::TooLarge { path: model.to_path_buf(), what, limit, budget: budget_hit });
        }
    }
    Ok(bytes)
}

/// Reads any file a command takes (a `.sphb`, a recorded input): a regular file of at most
/// `max` bytes, else an error naming it (never blocks on a FIFO nor reads a device).
pub fn read_limited(path: &Path, max: u64) -> Result<Vec<u8>, IoError> {
    read_bounded(path, path, None, max, ReadLimit::AtMost(max))
}

/// [`read_limited`] for the up-to-date check: `None` on any failure.
pub fn read_input_file(path: &Path, max: u64) -> Option<Vec<u8>> {
    read_limited(path, max).ok()
}

/// Clamps every material base colour factor and vertex colour component (RGBA, linear) into
/// [0, 1], NaN to 0 (glTF bounds `baseColorFactor` to [0, 1]; OBJ `Kd` and float `COLOR_0` are not
/// checked by their readers). Returns how many material and vertex colours changed; vertices
/// count once per position and colour (the copies an OBJ vertex on a sharp edge gets,
/// `spherebake_geom::normals::crease_normals`, are one colour of the file).
fn clamp_colours(mesh: &mut Mesh) -> (usize, usize) {
    fn clamp(c: &mut [f32; 4]) -> bool {
        let before = *c;
        for v in c.iter_mut() {
            *v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        }
        before.map(f32::to_bits) != c.map(f32::to_bits)
    }
    let materials = mesh.materials.iter_mut().map(|m| clamp(&mut m.base_color_factor_linear)).filter(|&b| b).count();
    let mut changed = std::collections::HashSet::new();
    for (v, c) in mesh.colors_linear.iter_mut().enumerate() {
        let before = c.map(f32::to_bits);
        if clamp(c) {
            changed.insert((mesh.weld.get(v).map_or(v, |&w| w as usize), before));
        }
    }
    (materials, changed.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn in_memory_imports_open_no_file_and_keep_the_folder_rule() {
        let obj = b"mtllib m.mtl\nusemtl red\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        let mut files = std::collections::BTreeMap::new();
        files.insert(PathBuf::from("/virtual/dir/./m.mtl"), b"newmtl red\nKd 1 0 0\n".to_vec());
        let opts = ImportOptions::default();
        let imp = load_mesh_from_memory(Path::new("/virtual/dir/a.obj"), obj, files.clone(), &opts).unwrap();
        assert_eq!(imp.mesh.materials[0].base_color_factor_linear[..3], [1.0, 0.0, 0.0]);
        assert_eq!(imp.inputs.len(), 2, "{:?}", imp.inputs);
        let outside = b"mtllib ../m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        files.insert(PathBuf::from("/virtual/m.mtl"), b"newmtl x\n".to_vec());
        let e = load_mesh_from_memory(Path::new("/virtual/dir/a.obj"), outside, files, &opts).unwrap_err();
        assert!(matches!(e, IoError::OutsideAsset { .. }), "{e}");
    }

    #[test]
    fn dispatch_rejects_unknown_extension() {
        let e = load_mesh_from_bytes(Path::new("a.stl"), b"solid").unwrap_err();
        assert!(matches!(e, IoError::UnknownFileType { ref extension, .. } if extension == "stl"), "{e}");
        let e = load_mesh(Path::new("/nonexistent/dir/x.glb")).unwrap_err();
        assert!(matches!(e, IoError::NotFound { .. }), "{e}");
        assert!(e.to_string().contains("/nonexistent/dir/x.glb"));
    }
}
