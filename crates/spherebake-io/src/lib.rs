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
//! | `KHR_texture_basisu`, `EXT_texture_webp`, `EXT_texture_avif` | a fallback PNG / JPEG `source` is used when present; otherwise a warning naming the extension and the base colour factor |
//! | `KHR_materials_*`, `KHR_lights_punctual` | ignored (no effect on geometry or base colour) |
//!
//! Any other extension in `extensionsRequired` (for example `KHR_draco_mesh_compression`) is an
//! [`IoError::UnsupportedExtension`] naming it. A malformed compressed view is an
//! [`IoError::CompressedView`] naming the buffer view, the extension and what is wrong.

mod error;
mod gltf_ext;
mod gltf_import;
mod hash;
pub mod meshopt;
mod obj_import;
mod texture;

use std::ops::Range;
use std::path::{Path, PathBuf};

pub use error::IoError;
pub use hash::Fnv1a64;
pub use spherebake_geom::{Mesh, Warning};
pub use texture::srgb_to_linear;

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
    /// Vertices stored in the file for this part (glTF `POSITION` count; OBJ: vertices tobj
    /// kept for this model, i.e. unique position/uv/normal corners).
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

/// Imports a `.gltf`, `.glb` or `.obj` file (dispatch by extension) with everything it references.
pub fn load_mesh(path: &Path) -> Result<Imported, IoError> {
    kind_of(path)?;
    let bytes = read_file(path)?;
    load_mesh_from_bytes(path, &bytes)
}

/// Imports model `bytes` as if read from `path`: the extension of `path` picks the format, and
/// external buffers, images and `.mtl` files are resolved (and read) relative to its directory.
/// `path` is listed first in [`Imported::inputs`] and `bytes` start the content hash.
pub fn load_mesh_from_bytes(path: &Path, bytes: &[u8]) -> Result<Imported, IoError> {
    let kind = kind_of(path)?;
    let mut ctx = Ctx::new(path);
    ctx.record(path, bytes);
    let (mesh, parts) = match kind {
        Kind::Gltf => gltf_import::import(&mut ctx, bytes, false)?,
        Kind::Glb => gltf_import::import(&mut ctx, bytes, true)?,
        Kind::Obj => obj_import::import(&mut ctx, bytes)?,
    };
    if mesh.triangles.is_empty() {
        return Err(IoError::EmptyMesh { path: path.to_path_buf() });
    }
    Ok(Imported { mesh, warnings: ctx.warnings, inputs: ctx.inputs, content_hash: ctx.hash.finish(), parts })
}

/// Import state shared by the format importers: the model path, inputs read, hash, warnings.
pub(crate) struct Ctx {
    pub path: PathBuf,
    pub dir: PathBuf,
    pub inputs: Vec<PathBuf>,
    pub hash: Fnv1a64,
    pub warnings: Vec<Warning>,
}

impl Ctx {
    fn new(path: &Path) -> Self {
        Self {
            path: path.to_path_buf(),
            dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
            inputs: Vec::new(),
            hash: Fnv1a64::new(),
            warnings: Vec::new(),
        }
    }

    fn record(&mut self, path: &Path, bytes: &[u8]) {
        self.inputs.push(path.to_path_buf());
        self.hash.write(bytes);
    }

    pub fn warn(&mut self, msg: String) {
        self.warnings.push(Warning(msg));
    }

    /// Reads a file referenced by the model, recording it as an input.
    pub fn read_referenced(&mut self, path: &Path) -> Result<Vec<u8>, IoError> {
        let bytes = read_file(path)?;
        self.record(path, &bytes);
        Ok(bytes)
    }
}

fn read_file(path: &Path) -> Result<Vec<u8>, IoError> {
    std::fs::read(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => IoError::NotFound { path: path.to_path_buf() },
        _ => IoError::Read { path: path.to_path_buf(), source: e },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dispatch_rejects_unknown_extension() {
        let e = load_mesh_from_bytes(Path::new("a.stl"), b"solid").unwrap_err();
        assert!(matches!(e, IoError::UnknownFileType { ref extension, .. } if extension == "stl"), "{e}");
        let e = load_mesh(Path::new("/nonexistent/dir/x.glb")).unwrap_err();
        assert!(matches!(e, IoError::NotFound { .. }), "{e}");
        assert!(e.to_string().contains("/nonexistent/dir/x.glb"));
    }
}
