//! `spherebake export FILE.sphb -o view.glb` and `spherebake render FILE.sphb --model MODEL -o view.png`.

use anyhow::{bail, Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Args, Debug)]
pub struct ExportArgs {
    /// The baked file
    pub file: PathBuf,
    /// Output glTF binary (.glb): icospheres per hierarchy level, sample markers, SH colours
    #[arg(short, long, value_name = "VIEW.glb")]
    pub output: PathBuf,
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The baked file
    pub file: PathBuf,
    /// The model it was baked from, drawn under the spheres
    #[arg(long)]
    pub model: PathBuf,
    /// Output PNG: front, side and top views side by side
    #[arg(short, long, value_name = "VIEW.png")]
    pub output: PathBuf,
    /// Image size in pixels, WIDTHxHEIGHT [default: 1200x400]
    #[arg(long, default_value = "1200x400", value_parser = parse_size)]
    pub size: (u32, u32),
}

fn parse_size(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("expected WIDTHxHEIGHT, got {s:?}"))?;
    let w: u32 = w.trim().parse().map_err(|_| format!("bad width in {s:?}"))?;
    let h: u32 = h.trim().parse().map_err(|_| format!("bad height in {s:?}"))?;
    if !(3..=16384).contains(&w) || !(1..=16384).contains(&h) {
        return Err(format!("size must be within 3..=16384 x 1..=16384, got {w}x{h}"));
    }
    Ok((w, h))
}

pub fn read_sphb(path: &Path) -> Result<spherebake_runtime::Proxy> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: reading", path.display()))?;
    spherebake_runtime::load(&bytes).with_context(|| format!("{}: not a valid .sphb file", path.display()))
}

pub fn run_export(a: ExportArgs) -> Result<ExitCode> {
    let proxy = read_sphb(&a.file)?;
    let (bytes, summary) = spherebake_bake::export::export_glb(proxy.file());
    crate::atomic::write_atomic(&a.output, &bytes)?;
    println!(
        "exported {} -> {} ({} levels, {} sample markers, {} nodes)",
        a.file.display(),
        a.output.display(),
        summary.levels,
        summary.sample_markers,
        summary.nodes
    );
    Ok(ExitCode::SUCCESS)
}

pub fn run_render(a: RenderArgs) -> Result<ExitCode> {
    let proxy = read_sphb(&a.file)?;
    let imported = spherebake_io::load_mesh(&a.model)?;
    let m = &imported.mesh;
    let spheres: Vec<[f32; 4]> =
        proxy.spheres().iter().map(|s| [s.center[0], s.center[1], s.center[2], s.radius]).collect();
    let img = spherebake_bake::render::render_views(&m.positions, &m.triangles, &spheres, a.size.0, a.size.1);
    let mut png = Vec::new();
    let enc = image::codecs::png::PngEncoder::new(&mut png);
    image::ImageEncoder::write_image(enc, &img.rgb, img.width, img.height, image::ExtendedColorType::Rgb8)
        .with_context(|| format!("{}: encoding PNG", a.output.display()))?;
    if png.is_empty() {
        bail!("{}: empty PNG", a.output.display());
    }
    crate::atomic::write_atomic(&a.output, &png)?;
    println!(
        "rendered {} over {} -> {} ({}x{})",
        a.file.display(),
        a.model.display(),
        a.output.display(),
        img.width,
        img.height
    );
    Ok(ExitCode::SUCCESS)
}
