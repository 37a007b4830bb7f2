//! Up-to-date checks: an output records its tool version, settings, the list of files the bake
//! read (relative to the model's directory) and the FNV-1a 64 hash of their bytes; re-running a
//! bake can skip it when all four still match.
//!
//! Cost: reading the recorded input files once (no import, no parse).

use crate::BakeSettings;
use spherebake_io::Fnv1a64;
use std::path::{Path, PathBuf};

/// Metadata key holding the input list: one path per line, relative to the model's directory,
/// the model itself first.
pub const INPUTS_KEY: &str = "inputs";

/// The recorded input paths (`inputs` as written by [`inputs_value`]) resolved against `model`'s directory.
pub fn recorded_inputs(output_bytes: &[u8], model: &Path) -> Option<Vec<PathBuf>> {
    let file = spherebake_format::read(output_bytes).ok()?;
    let meta = file.metadata?;
    let list = meta.extra.iter().find(|(k, _)| k == INPUTS_KEY)?.1.clone();
    let dir = model.parent().unwrap_or(Path::new(""));
    Some(list.lines().map(|l| if l.is_empty() { model.to_path_buf() } else { dir.join(l) }).collect())
}

/// Metadata key of the referenced files that did not exist at bake time (same format as
/// [`INPUTS_KEY`]; absent when none was missing).
pub const MISSING_INPUTS_KEY: &str = "missing_inputs";

/// The files recorded under [`MISSING_INPUTS_KEY`] (empty when the key is absent).
pub fn recorded_missing(output_bytes: &[u8], model: &Path) -> Vec<PathBuf> {
    let Ok(file) = spherebake_format::read(output_bytes) else { return Vec::new() };
    let Some(meta) = file.metadata else { return Vec::new() };
    let dir = model.parent().unwrap_or(Path::new(""));
    meta.extra
        .iter()
        .find(|(k, _)| k == MISSING_INPUTS_KEY)
        .map(|(_, v)| v.lines().filter(|l| !l.is_empty()).map(|l| dir.join(l)).collect())
        .unwrap_or_default()
}

/// The value stored under [`INPUTS_KEY`]: paths relative to `model`'s directory, one per line.
pub fn inputs_value(model: &Path, inputs: &[PathBuf]) -> String {
    let dir = model.parent().unwrap_or(Path::new(""));
    inputs
        .iter()
        .map(|p| p.strip_prefix(dir).unwrap_or(p).to_string_lossy().replace('\\', "/"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// `true` when `output` exists, is a valid file written by this tool version with these
/// settings, and the files it records hash to the recorded input hash.
pub fn is_up_to_date(output: &Path, model: &Path, settings: &BakeSettings) -> bool {
    let max = spherebake_io::default_options().max_input_bytes;
    let Some(bytes) = spherebake_io::read_input_file(output, max) else { return false };
    let Ok(file) = spherebake_format::read(&bytes) else { return false };
    let Some(meta) = file.metadata else { return false };
    if meta.tool_version != crate::TOOL_VERSION || meta.settings != settings.to_json() {
        return false;
    }
    let Some(inputs) = recorded_inputs(&bytes, model) else { return false };
    if inputs.first().map(PathBuf::as_path) != Some(model) {
        return false;
    }
    // A texture that was missing and now exists changes the bake.
    if recorded_missing(&bytes, model).iter().any(|p| p.exists()) {
        return false;
    }
    let mut h = Fnv1a64::new();
    for p in &inputs {
        // Regular files within the input budget only: the paths come from the output file.
        match spherebake_io::read_input_file(p, max) {
            Some(b) => h.write(&b),
            None => return false,
        }
    }
    format!("{:016x}", h.finish()) == meta.input_hash
}
