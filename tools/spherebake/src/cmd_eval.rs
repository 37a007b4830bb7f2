//! `spherebake eval FILE.sphb MODEL [--json]`: measure a sphere set against its model.

use anyhow::{bail, Result};
use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Args, Debug)]
pub struct EvalArgs {
    /// The baked file
    pub file: PathBuf,
    /// The model it was baked from (.gltf, .glb, .obj)
    pub model: PathBuf,
    /// Print one JSON document instead of text
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: EvalArgs) -> Result<ExitCode> {
    bail!("{}: eval is not available yet", a.file.display())
}
