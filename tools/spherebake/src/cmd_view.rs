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
    #[command(flatten)]
    pub model: ModelArg,
    /// Output image (.png, or .jpg / .jpeg for JPEG): front, side and top views side by side
    #[arg(short, long, value_name = "VIEW.png")]
    pub output: PathBuf,
    /// Image size in pixels, WIDTHxHEIGHT
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

/// The model a `.sphb` was baked from, for the commands that measure or draw the proxy against
/// it (`eval`, `render`, `shadows`, `pose`, `light`): given after the file (`FILE MODEL`) or as
/// `--model MODEL`, exactly one of the two (clap refuses neither or both: a usage error, exit 2),
/// so every such command takes both spellings.
#[derive(Args, Debug)]
pub struct ModelArg {
    /// The model it was baked from (.gltf, .glb, .obj), here or as --model MODEL
    #[arg(value_name = "MODEL", required_unless_present = "model_option", conflicts_with = "model_option")]
    model_after_file: Option<PathBuf>,
    /// The model it was baked from (.gltf, .glb, .obj)
    #[arg(long = "model", value_name = "MODEL")]
    model_option: Option<PathBuf>,
}

impl std::ops::Deref for ModelArg {
    type Target = Path;

    /// The model's path. clap requires one of the two spellings; were neither
    /// given, this is the empty path, which every loader refuses with an error (never a panic).
    fn deref(&self) -> &Path {
        self.model_after_file.as_deref().or(self.model_option.as_deref()).unwrap_or(Path::new(""))
    }
}

pub fn read_sphb(path: &Path) -> Result<spherebake_runtime::Proxy> {
    let bytes = spherebake_io::read_limited(path, spherebake_io::default_options().max_input_bytes)?;
    spherebake_runtime::load(&bytes).with_context(|| format!("{}: not a valid .sphb file", path.display()))
}

pub fn run_export(a: ExportArgs) -> Result<ExitCode> {
    // Binary glTF only: a `.gltf` (JSON) or any other name would hold mislabelled GLB bytes.
    match a.output.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).as_deref() {
        None | Some("glb") => {}
        Some(e) => bail!("{}: unsupported output type .{e} (export writes binary glTF: use .glb)", a.output.display()),
    }
    let proxy = read_sphb(&a.file)?;
    let (bytes, summary) =
        spherebake_bake::export::export_glb(proxy.file()).map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    crate::atomic::write_atomic(&a.output, &bytes, std::slice::from_ref(&a.file))?;
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

#[derive(Clone, Copy, Debug)]
pub(crate) enum ImageFormat {
    Png,
    Jpeg,
}

/// The image format by the output's extension: `.png` (or none, e.g. `/dev/stdout`) is PNG,
/// `.jpg` / `.jpeg` JPEG; anything else is refused rather than written as mislabelled PNG.
pub(crate) fn image_format(path: &Path) -> Result<ImageFormat> {
    match path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).as_deref() {
        None | Some("png") => Ok(ImageFormat::Png),
        Some("jpg" | "jpeg") => Ok(ImageFormat::Jpeg),
        Some(e) => bail!("{}: unsupported image type .{e} (use .png, .jpg or .jpeg)", path.display()),
    }
}

/// 8-bit RGB pixels (`width` × `height`, rows top down) encoded as `format` (from
/// [`image_format`] of `path`, which names the file in errors).
pub(crate) fn encode_rgb(path: &Path, format: ImageFormat, rgb: &[u8], width: u32, height: u32) -> Result<Vec<u8>> {
    let mut bytes = Vec::new();
    let color = image::ExtendedColorType::Rgb8;
    let encoded = match format {
        ImageFormat::Png => {
            let enc = image::codecs::png::PngEncoder::new(&mut bytes);
            image::ImageEncoder::write_image(enc, rgb, width, height, color)
        }
        ImageFormat::Jpeg => {
            let enc = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, 92);
            image::ImageEncoder::write_image(enc, rgb, width, height, color)
        }
    };
    encoded.with_context(|| format!("{}: encoding {format:?}", path.display()))?;
    if bytes.is_empty() {
        bail!("{}: empty image", path.display());
    }
    Ok(bytes)
}

/// Whether `model` is the input `file` was baked from (the content hash the file records), `None`
/// when the file records none; warns on stderr when it is not: the numbers are still valid for
/// this pair, but rarely what was meant (`eval`, `pose`, `shadows`, `light`, `render`).
pub(crate) fn warn_other_input(
    proxy: &spherebake_runtime::Proxy,
    file: &Path,
    imported: &spherebake_io::Imported,
    model: &Path,
) -> Option<bool> {
    let model_hash = format!("{:016x}", imported.content_hash);
    let recorded = proxy.metadata().map(|m| m.input_hash.as_str());
    let matches = recorded.map(|h| h == model_hash);
    if matches == Some(false) {
        eline!(
            "spherebake: warning: {} was baked from another input (input hash {}); {} hashes to {}",
            file.display(),
            recorded.unwrap_or(""),
            model.display(),
            model_hash
        );
    }
    matches
}

pub fn run_render(a: RenderArgs) -> Result<ExitCode> {
    let format = image_format(&a.output)?;
    let proxy = read_sphb(&a.file)?;
    let imported = spherebake_io::load_mesh(&a.model)?;
    warn_other_input(&proxy, &a.file, &imported, &a.model);
    let m = &imported.mesh;
    let spheres: Vec<[f32; 4]> =
        proxy.spheres().iter().map(|s| [s.center[0], s.center[1], s.center[2], s.radius]).collect();
    let img = spherebake_bake::render::render_views(&m.positions, &m.triangles, &spheres, a.size.0, a.size.1);
    let png = encode_rgb(&a.output, format, &img.rgb, img.width, img.height)?;
    let mut read = imported.inputs.clone();
    read.push(a.file.clone());
    crate::atomic::write_atomic(&a.output, &png, &read)?;
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
