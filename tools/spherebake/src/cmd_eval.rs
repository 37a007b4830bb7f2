//! `spherebake eval FILE.sphb MODEL [--json]`: measure a sphere set against its model.

use anyhow::{Context, Result};
use clap::Args;
use serde_json::json;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Args, Debug)]
pub struct EvalArgs {
    /// The baked file
    pub file: PathBuf,
    #[command(flatten)]
    pub model: crate::cmd_view::ModelArg,
    /// Voxel cells along the longest axis, for the solid of open meshes and the union estimate [default: the file's bake setting, else 128; range 16..=1024]
    #[arg(long)]
    pub voxels: Option<u32>,
    /// Random surface points tested for coverage [range 1..=268435456]
    #[arg(long, default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(1..=1 << 28))]
    pub surface_samples: u64,
    /// Print one JSON document instead of text
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: EvalArgs) -> Result<ExitCode> {
    let proxy = crate::cmd_view::read_sphb(&a.file)?;
    let imported = spherebake_io::load_mesh(&a.model)?;
    let mesh = &imported.mesh;
    let spheres: Vec<[f32; 4]> =
        proxy.spheres().iter().map(|s| [s.center[0], s.center[1], s.center[2], s.radius]).collect();
    // An open mesh's solid is the voxel solid at the bake's resolution: measure against that
    // one unless told otherwise (`--preset fast` bakes at 96 cells, `--voxels N` at N).
    let voxels = a.voxels.or_else(|| recorded_voxels(proxy.metadata().map(|m| m.settings.as_str()))).unwrap_or(128);
    let settings = spherebake_fit::EvalSettings {
        voxel_resolution: voxels,
        surface_samples: a.surface_samples as usize,
        ..Default::default()
    };
    let e = spherebake_bake::evaluate_mesh(mesh, &spheres, &settings)
        .with_context(|| format!("{}: evaluating against {}", a.file.display(), a.model.display()))?;
    let solid = format!("{:?}", e.solid_source);
    let hash_matches = crate::cmd_view::warn_other_input(&proxy, &a.file, &imported, &a.model);
    if a.json {
        let doc = json!({
            "file": a.file.display().to_string(),
            "model": a.model.display().to_string(),
            "outside_ratio_e": e.outside_ratio_e,
            "union_outside_ratio": e.union_outside_ratio,
            "surface_coverage": e.surface_coverage,
            "surface_samples": a.surface_samples,
            "max_gap": e.max_gap,
            "max_gap_relative": e.max_gap_relative,
            "sphere_count": e.sphere_count,
            "radius": {"min": e.radius_min, "mean": e.radius_mean, "max": e.radius_max},
            "object_volume": e.object_volume,
            "solid": solid,
            "voxels": voxels,
            "input_hash_matches": hash_matches,
        });
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!("{} against {}", a.file.display(), a.model.display());
    println!("  spheres                 {}", e.sphere_count);
    println!("  outside-volume ratio E  {:.5}   (Σ V(S_i − T) / V(T), Ren et al. 2006 eq. 35)", e.outside_ratio_e);
    println!("  union outside ratio     {:.5}   (V(∪S − T) / V(T))", e.union_outside_ratio);
    println!(
        "  surface coverage        {:.6}   ({} random surface points; max gap {:.3e} = {:.3e} of the diagonal)",
        e.surface_coverage, a.surface_samples, e.max_gap, e.max_gap_relative
    );
    println!("  radius min/mean/max     {:.6} / {:.6} / {:.6}", e.radius_min, e.radius_mean, e.radius_max);
    println!("  object volume V(T)      {:.7}   (solid: {solid}; voxel grid {voxels})", e.object_volume);
    Ok(ExitCode::SUCCESS)
}

/// The `voxels` setting a file's metadata records (its settings JSON), when it is there and in
/// range; files from other tools, or without metadata, record none.
fn recorded_voxels(settings: Option<&str>) -> Option<u32> {
    let v: serde_json::Value = serde_json::from_str(settings?).ok()?;
    let n = u32::try_from(v.get("voxels")?.as_u64()?).ok()?;
    (16..=1024).contains(&n).then_some(n)
}

#[cfg(test)]
mod tests {
    use super::recorded_voxels;

    #[test]
    fn the_recorded_voxel_setting_is_read_when_valid() {
        assert_eq!(recorded_voxels(Some(r#"{"spheres":64,"voxels":96}"#)), Some(96));
        assert_eq!(recorded_voxels(Some(r#"{"voxels":4}"#)), None);
        assert_eq!(recorded_voxels(Some(r#"{"voxels":"96"}"#)), None);
        assert_eq!(recorded_voxels(Some(r#"{"voxels":4294967296000}"#)), None);
        assert_eq!(recorded_voxels(Some("not json")), None);
        assert_eq!(recorded_voxels(Some("")), None);
        assert_eq!(recorded_voxels(None), None);
    }
}
