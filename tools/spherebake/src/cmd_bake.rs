//! `spherebake bake INPUT -o OUTPUT.sphb`: run the pipeline and write the file atomically.

use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use spherebake_bake::{BakeOutput, BakeSettings, Method};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// Variational fit of minimal outside volume (Ren et al. 2006 §6.2)
    Variational,
    /// Baseline: k-means of surface points, bounding ball per cluster
    Kmeans,
    /// Baseline: bounding spheres of adaptive-octree leaf cubes
    Octree,
}

#[derive(Args, Debug)]
pub struct BakeArgs {
    /// Input mesh: .gltf, .glb or .obj
    pub input: PathBuf,
    /// Output file (.sphb); written atomically
    #[arg(short, long, value_name = "OUTPUT.sphb")]
    pub output: PathBuf,
    /// Number of spheres [default: 64, range 1..=4096]
    #[arg(long, default_value_t = 64)]
    pub spheres: usize,
    /// Fitting method
    #[arg(long, value_enum, default_value_t = MethodArg::Variational)]
    pub method: MethodArg,
    /// Find the smallest sphere count whose outside-volume ratio E is at most this (overrides --spheres) [range > 0]
    #[arg(long, value_name = "E")]
    pub max_outside_ratio: Option<f64>,
    /// Voxel cells along the longest bounding-box axis [default: 128, range 16..=1024]
    #[arg(long, default_value_t = 128)]
    pub voxels: u32,
    /// Seed of the random start; same seed + input + settings give byte-identical files
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print the bake report as one JSON document instead of the human summary
    #[arg(long)]
    pub json: bool,
    /// Print nothing but errors
    #[arg(short, long)]
    pub quiet: bool,
}

pub fn run(a: BakeArgs) -> Result<ExitCode> {
    let settings = BakeSettings {
        spheres: a.spheres,
        method: match a.method {
            MethodArg::Variational => Method::Variational,
            MethodArg::Kmeans => Method::Kmeans,
            MethodArg::Octree => Method::Octree,
        },
        max_outside_ratio: a.max_outside_ratio,
        voxels: a.voxels,
        seed: a.seed,
    };
    if let Err(msg) = settings.validate() {
        // A usage error: report like clap does, exit 2, before any work.
        eprintln!("spherebake: error: {msg}");
        return Ok(ExitCode::from(2));
    }
    if a.output.is_dir() {
        bail!("{}: output is a directory", a.output.display());
    }
    // Library errors already name the file and what is wrong with it.
    let out = spherebake_bake::bake_path(&a.input, &settings, &|_| {})?;
    crate::atomic::write_atomic(&a.output, &out.bytes)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&out.report)?);
    } else if !a.quiet {
        print_summary(&a.output, &out);
    }
    Ok(ExitCode::SUCCESS)
}

fn print_summary(output: &std::path::Path, out: &BakeOutput) {
    let r = &out.report;
    let total: f64 = r.timings.iter().map(|t| t.seconds).sum();
    println!("baked {} -> {}", r.input.display(), output.display());
    println!(
        "  mesh      {} triangles, {} welded vertices, {}",
        r.triangles,
        r.vertices_welded,
        if r.closed { "closed" } else { "not closed" }
    );
    match (r.outside_ratio_e, r.union_outside_ratio) {
        (Some(e), Some(u)) => {
            println!("  spheres   {}  outside-volume ratio E = {e:.4}, union outside ratio = {u:.4}", r.sphere_count)
        }
        (Some(e), None) => println!("  spheres   {}  outside-volume ratio E = {e:.4}", r.sphere_count),
        _ => println!("  spheres   {}", r.sphere_count),
    }
    let stages: Vec<String> = r.timings.iter().map(|t| format!("{} {:.3}", t.stage, t.seconds)).collect();
    println!("  time      {total:.3} s ({})", stages.join(", "));
    println!("  file      {} bytes, input hash {}", r.file_bytes, r.input_hash);
    for w in &r.warnings {
        println!("  warning   {w}");
    }
}
