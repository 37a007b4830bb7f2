//! Atomic output: write to a temp file in the destination directory, then rename over the target.
//! A failure at any point leaves no partial file behind.

use anyhow::{Context, Result};
use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` atomically (temp file in the same directory + rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    if !dir.is_dir() {
        std::fs::create_dir_all(&dir).with_context(|| format!("{}: creating output directory", dir.display()))?;
    }
    let mut tmp = tempfile::Builder::new()
        .prefix(".spherebake-")
        .suffix(".tmp")
        .tempfile_in(&dir)
        .with_context(|| format!("{}: creating temporary file", dir.display()))?;
    tmp.write_all(bytes).with_context(|| format!("{}: writing", path.display()))?;
    tmp.as_file().sync_all().with_context(|| format!("{}: syncing", path.display()))?;
    tmp.persist(path)
        .map_err(|e| e.error)
        .with_context(|| format!("{}: renaming temporary file into place", path.display()))?;
    Ok(())
}
