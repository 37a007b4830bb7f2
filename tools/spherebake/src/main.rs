//! `spherebake`: bake sphere proxies from meshes, inspect and evaluate `.sphb` files.
//!
//! Exit codes: 0 success, 1 an input failed (bad or unsupported input, failed validation, IO),
//! 2 usage error. Errors print once as `spherebake: error: <file>: <what>`.

/// `eprintln!` that never panics: a closed or broken standard error (`2>&-`, `2>&1 | true`) loses the
/// line but not the command's work or its exit status.
macro_rules! eline {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

/// Returns a usage error (exit status 2, like clap's own): a flag's value outside its range.
macro_rules! usage_bail {
    ($($t:tt)*) => {
        return Err(anyhow::Error::new(crate::UsageError(format!($($t)*))))
    };
}

mod atomic;
mod cmd_bake;
mod cmd_eval;
mod cmd_inspect;
mod cmd_light;
mod cmd_pose;
mod cmd_shadows;
mod cmd_view;
mod config;
mod json;
mod output;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// A usage error found after parsing (a flag's value out of its range): exit status 2.
#[derive(Debug)]
pub struct UsageError(pub String);

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UsageError {}

/// Bake bounding sphere proxies (soft shadows, indirect light) from glTF and OBJ meshes.
#[derive(Parser, Debug)]
#[command(name = "spherebake", version, about, long_about = None,
    after_help = "Exit status: 0 success, 1 an input failed (bad input, validation, IO), 2 usage error.")]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Let models reference files outside their own folder tree (trusted layouts only)
    #[arg(long, global = true)]
    allow_outside_paths: bool,
    /// Bytes read per model (model + buffers + images + MTL), in MiB [default: 1024]
    #[arg(long, global = true, value_name = "MIB", value_parser = clap::value_parser!(u64).range(1..=1 << 20))]
    max_input_mb: Option<u64>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Bake a mesh (.gltf, .glb, .obj) into a .sphb sphere proxy.
    Bake(cmd_bake::BakeArgs),
    /// Print a mesh's topology report, or a .sphb file's header, sections and contents.
    Inspect(cmd_inspect::InspectArgs),
    /// Measure a baked sphere set against its model: outside-volume ratio E, coverage, radii.
    Eval(cmd_eval::EvalArgs),
    /// Write the proxy as glTF (.glb) for any viewer: icospheres per hierarchy level, sample markers.
    Export(cmd_view::ExportArgs),
    /// Draw the mesh with its sphere set from three views into a PNG or JPEG, headless.
    Render(cmd_view::RenderArgs),
    /// Ground-plane soft shadows of the proxy (runtime log-SH query) against ray-traced truth; +Y is up.
    ///
    /// The model stands on the ground plane y = its lowest y, with normal +Y: +Y is up (glTF's
    /// convention), for OBJ models too, so a Z-up model is checked lying on its side. The ground is
    /// a square of 3 × the model's larger horizontal (x or z) extent, centred under it.
    Shadows(cmd_shadows::ShadowsArgs),
    /// Pose a skinned proxy from its model's animation at a time; print the spheres and their vertex coverage.
    Pose(cmd_pose::PoseArgs),
    /// One-bounce indirect light of the proxy (runtime passes 1 and 2) on the ground and the model against path tracing; +Y is up.
    ///
    /// The model (posed by --animation / --time, else at rest) stands on the ground plane y = its
    /// lowest y, with normal +Y: +Y is up (glTF's convention), for OBJ models too, so a Z-up model
    /// is checked lying on its side. The ground is a square of 3 × the model's larger horizontal
    /// (x or z) extent, centred under it; it reflects nothing, and the sky below it is removed.
    Light(cmd_light::LightArgs),
}

fn main() -> ExitCode {
    atomic::init();
    output::install();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            // clap prints help/version to stdout (exit 0) and usage errors to stderr (exit 2).
            let code = e.exit_code();
            let _ = e.print();
            return ExitCode::from(code as u8);
        }
    };
    spherebake_io::set_default_options(spherebake_io::ImportOptions {
        allow_outside_paths: cli.allow_outside_paths,
        max_input_bytes: cli.max_input_mb.map_or(spherebake_io::DEFAULT_MAX_INPUT_BYTES, |m| m << 20),
        ..Default::default()
    });
    let result = match cli.command {
        Command::Bake(a) => cmd_bake::run(a),
        Command::Inspect(a) => cmd_inspect::run(a),
        Command::Eval(a) => cmd_eval::run(a),
        Command::Export(a) => cmd_view::run_export(a),
        Command::Render(a) => cmd_view::run_render(a),
        Command::Shadows(a) => cmd_shadows::run(a),
        Command::Pose(a) => cmd_pose::run(a),
        Command::Light(a) => cmd_light::run(a),
    };
    match result {
        Ok(code) => output::flush(code),
        Err(e) => {
            if is_broken_pipe(&e) {
                return output::closed_pipe_status();
            }
            eline!("spherebake: error: {e:#}");
            if e.downcast_ref::<UsageError>().is_some() {
                ExitCode::from(2)
            } else {
                ExitCode::from(1)
            }
        }
    }
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe))
}
