//! The error type of the importer: every variant names the file it concerns.

use std::path::PathBuf;

/// Why an input could not be imported. Problems the pipeline can cope with (a missing texture,
/// a skipped line primitive) are [`spherebake_geom::Warning`]s instead.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IoError {
    /// The file does not exist.
    #[error("{}: file not found", path.display())]
    NotFound { path: PathBuf },
    /// The file exists but could not be read.
    /// The OS error is part of the message and deliberately not a `source`, so a printed
    /// error chain (`{:#}`) names it once.
    #[error("{}: cannot read: {cause}", path.display())]
    Read { path: PathBuf, cause: std::io::Error },
    /// A file the model references (glTF buffer / image `uri`, OBJ `mtllib` / `map_Kd`) does
    /// not exist; `path` is the model, `resolved` where the reference was looked for.
    #[error("{}: referenced file {uri:?} not found (looked for {})", path.display(), resolved.display())]
    ReferenceNotFound { path: PathBuf, uri: String, resolved: PathBuf },
    /// A file the model references exists but could not be read (OS error in the message
    /// only, as for [`IoError::Read`]).
    #[error("{}: cannot read referenced file {uri:?}: {cause}", path.display())]
    ReferenceRead { path: PathBuf, uri: String, cause: std::io::Error },
    /// A referenced file (glTF buffer / image `uri`, OBJ `mtllib` / `map_Kd` / `map_d`) resolves outside
    /// the model's folder tree and [`crate::ImportOptions::allow_outside_paths`] is off.
    #[error("{}: {uri:?} is outside the model's folder; refused (--allow-outside-paths allows it)", path.display())]
    OutsideAsset { path: PathBuf, uri: String },
    /// A referenced file (or the model) is not a regular file (a device, FIFO, directory).
    #[error("{}: {}not a regular file; refused", path.display(), uri.as_ref().map(|u| format!("{u:?} is ")).unwrap_or_default())]
    NotRegularFile { path: PathBuf, uri: Option<String> },
    /// Reading `what` would exceed a size limit (`budget`: the input budget of the whole model).
    #[error("{}: {}exceeds {}{limit} bytes{}", path.display(), what.as_ref().map(|u| format!("{u:?} ")).unwrap_or_default(), if *budget { "the input budget of " } else { "the limit of " }, if *budget { " (--max-input-mb raises it)" } else { "" })]
    TooLarge { path: PathBuf, what: Option<String>, limit: u64, budget: bool },
    /// The file name extension is not one the importer handles.
    #[error("{}: unknown file type {extension:?} (expected .gltf, .glb or .obj)", path.display())]
    UnknownFileType { path: PathBuf, extension: String },
    /// A `.glb` file does not start with the `glTF` magic.
    #[error("{}: not a binary glTF file: magic is {found:02x?}, expected \"glTF\"", path.display())]
    WrongMagic { path: PathBuf, found: [u8; 4] },
    /// A `.glb` container version other than 2.
    #[error("{}: binary glTF container version {version}, only version 2 is supported", path.display())]
    UnsupportedGlbVersion { path: PathBuf, version: u32 },
    /// A `.glb` file (or one of its chunks) is shorter than its header says.
    #[error("{}: truncated binary glTF: {what} needs {expected} bytes at offset {offset}, file has {actual}", path.display())]
    Truncated { path: PathBuf, what: &'static str, offset: usize, expected: usize, actual: usize },
    /// A `.glb` chunk layout problem other than truncation.
    #[error("{}: bad binary glTF chunk at offset {offset}: {reason}", path.display())]
    BadChunk { path: PathBuf, offset: usize, reason: &'static str },
    /// The glTF JSON does not parse.
    #[error("{}: invalid glTF JSON: {message}", path.display())]
    Json { path: PathBuf, message: String },
    /// The glTF JSON parses but breaks the schema (bad indices, missing fields).
    #[error("{}: invalid glTF: {message}", path.display())]
    Invalid { path: PathBuf, message: String },
    /// `extensionsRequired` names an extension this importer does not implement.
    #[error("{}: glTF requires extension {extension}, which is not supported", path.display())]
    UnsupportedExtension { path: PathBuf, extension: String },
    /// A compressed buffer view (`EXT_meshopt_compression` / `KHR_meshopt_compression`) is
    /// malformed or cannot be decoded.
    #[error("{}: buffer view {view}: {extension}: {reason}", path.display())]
    CompressedView { path: PathBuf, view: usize, extension: String, reason: String },
    /// A buffer could not be loaded (missing `.bin`, bad data URI, too short).
    #[error("{}: buffer {buffer}: {reason}", path.display())]
    Buffer { path: PathBuf, buffer: usize, reason: String },
    /// An accessor's data does not fit its buffer view / buffer or has an unexpected type.
    #[error("{}: accessor {accessor}: {reason}", path.display())]
    Accessor { path: PathBuf, accessor: usize, reason: String },
    /// A triangle refers to a vertex that does not exist.
    #[error("{}: mesh {mesh} primitive {primitive}: index {index} at position {position} is out of range (vertex count {vertex_count})", path.display())]
    IndexOutOfRange { path: PathBuf, mesh: usize, primitive: usize, position: usize, index: u64, vertex_count: usize },
    /// A vertex position is NaN or infinite.
    #[error("{}: mesh {mesh} ({mesh_name:?}) primitive {primitive}: vertex {vertex} has a non-finite position {value:?}", path.display())]
    NonFinitePosition {
        path: PathBuf,
        mesh: usize,
        mesh_name: String,
        primitive: usize,
        vertex: usize,
        value: [f32; 3],
    },
    /// A vertex names a joint its skin does not have.
    #[error("{}: mesh {mesh} primitive {primitive}: vertex {vertex} uses joint {joint}, skin {skin} has {joint_count}", path.display())]
    JointOutOfRange {
        path: PathBuf,
        mesh: usize,
        primitive: usize,
        vertex: usize,
        skin: usize,
        joint: u32,
        joint_count: usize,
    },
    /// The node hierarchy is not a forest (a node with two parents, or a cycle).
    #[error("{}: node {node}: {reason}", path.display())]
    NodeGraph { path: PathBuf, node: usize, reason: &'static str },
    /// An animation sampler is inconsistent.
    #[error("{}: animation {animation} channel {channel}: {reason}", path.display())]
    Animation { path: PathBuf, animation: usize, channel: usize, reason: String },
    /// The OBJ parser failed.
    #[error("{}: cannot parse OBJ: {message}", path.display())]
    Obj { path: PathBuf, message: String },
    /// An OBJ file that is not text this importer reads: UTF-16, binary, or bytes that are
    /// not UTF-8 and read as no triangle (`why` says which).
    #[error("{}: is not UTF-8 text ({why})", path.display())]
    NotText { path: PathBuf, why: String },
    /// A position is beyond what f32 bounding spheres can bound.
    #[error("{}: coordinate {value:e} is beyond the supported range ±{limit:e} (f32 spheres could not bound the model)", path.display())]
    CoordinateRange { path: PathBuf, value: f32, limit: f32 },
    /// The model expands past a limit that no input size bounds (`what`: vertices placed, values
    /// of accessors without a buffer view). `per_budget_byte`: the limit is that many per byte of
    /// the input budget ([`crate::ImportOptions::max_input_bytes`], `--max-input-mb`), which
    /// raises it; `None`: a fixed cap.
    #[error("{}: {what}, over the limit of {limit}{}", path.display(), match per_budget_byte { Some(k) => format!(" ({k} per byte of the input budget; --max-input-mb raises it)"), None => " (a fixed cap)".into() })]
    OverLimit { path: PathBuf, what: String, limit: u64, per_budget_byte: Option<u64> },
    /// Values of glTF accessors without a buffer view past `per_json_byte` per byte of the
    /// file's JSON (nothing else in the file bounds them); the input budget does not raise it.
    #[error("{}: {what}, over the limit of {limit} ({per_json_byte} per byte of its {json_bytes} bytes of glTF JSON; --max-input-mb does not raise it)", path.display())]
    OverJsonLimit { path: PathBuf, what: String, limit: u64, per_json_byte: u64, json_bytes: u64 },
    /// The file imports but holds no triangles; `reason` says why when the importer knows (the
    /// scene used has no nodes, every primitive was points or lines).
    #[error("{}: no triangles to import{}", path.display(), reason.as_ref().map(|r| format!(": {r}")).unwrap_or_default())]
    EmptyMesh { path: PathBuf, reason: Option<String> },
}

impl IoError {
    /// A file the model references was refused (outside the folder tree, not a regular file,
    /// over the input budget): always an error, never downgraded to a warning.
    pub fn is_refusal(&self) -> bool {
        matches!(
            self,
            IoError::OutsideAsset { .. } | IoError::NotRegularFile { .. } | IoError::TooLarge { budget: true, .. }
        )
    }
}
