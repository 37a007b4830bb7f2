//! `spherebake pose FILE.sphb --model MODEL [--animation NAME] --time T [--json]`: poses the
//! skeleton from the model's animation at time T, runs the runtime crate's `pose` (and the
//! hierarchy refit), and prints the posed spheres and the share of posed mesh vertices they cover.

use anyhow::{bail, Context, Result};
use clap::Args;
use serde_json::json;
use spherebake_bake::skin::{animation_joint_matrices, posed_welded_vertices, union_coverage};
use spherebake_runtime::Sphere;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Args, Debug)]
pub struct PoseArgs {
    /// The baked file
    pub file: PathBuf,
    #[command(flatten)]
    pub model: crate::cmd_view::ModelArg,
    /// Animation name [default: the model's first animation; the rest pose if it has none]
    #[arg(long)]
    pub animation: Option<String>,
    /// Time in seconds (clamped to each channel's key range, as glTF does)
    #[arg(long, allow_negative_numbers = true)]
    pub time: f32,
    /// Print one JSON document `{spheres: [{center, radius}], coverage, ...}` instead of text
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: PoseArgs) -> Result<ExitCode> {
    if !a.time.is_finite() {
        usage_bail!("--time must be a finite number of seconds, got {}", a.time);
    }
    let proxy = crate::cmd_view::read_sphb(&a.file)?;
    let imported = spherebake_io::load_mesh(&a.model)?;
    crate::cmd_view::warn_other_input(&proxy, &a.file, &imported, &a.model);
    let mesh = &imported.mesh;
    let skel = mesh.skin.as_ref().map(|s| &s.skeleton);
    let (anim_index, anim_name) = match (&a.animation, skel) {
        (Some(name), Some(sk)) => {
            let Some(i) = sk.animations.iter().position(|x| &x.name == name) else {
                let names: Vec<&str> = sk.animations.iter().map(|x| x.name.as_str()).collect();
                bail!("{}: no animation named {name:?} (animations: {names:?})", a.model.display());
            };
            (Some(i), Some(name.clone()))
        }
        (Some(name), None) => bail!("{}: --animation {name:?} given, but the model has no skin", a.model.display()),
        (None, Some(sk)) if !sk.animations.is_empty() => (Some(0), Some(sk.animations[0].name.clone())),
        (None, _) => (None, None),
    };
    let joints = match skel {
        Some(sk) => animation_joint_matrices(sk, anim_index, a.time),
        None => Vec::new(),
    };
    if proxy.skin().is_some() {
        if skel.is_none() {
            bail!("{}: the file has skin terms, but {} has no skin", a.file.display(), a.model.display());
        }
        if joints.len() != proxy.bones().len() {
            bail!(
                "{}: the file has {} bones, {} has {} joints",
                a.file.display(),
                proxy.bones().len(),
                a.model.display(),
                joints.len()
            );
        }
    }
    let cols: Vec<[f32; 16]> = joints.iter().map(|m| m.to_cols_array()).collect();
    let mut posed = vec![Sphere::default(); proxy.sphere_count()];
    let mut root = None;
    match proxy.hierarchy_plan() {
        Some(plan) => {
            let mut nodes = vec![Sphere::default(); plan.node_count()];
            spherebake_runtime::pose_and_refit(&proxy, &plan, &cols, &mut posed, &mut nodes)
                .with_context(|| format!("{}: posing", a.file.display()))?;
            root = proxy.hierarchy().and_then(|h| nodes.get(h.root as usize).copied());
        }
        None => spherebake_runtime::pose(&proxy, &cols, &mut posed)
            .with_context(|| format!("{}: posing", a.file.display()))?,
    }
    let verts = posed_welded_vertices(mesh, &joints).with_context(|| format!("{}: skinning", a.model.display()))?;
    let balls: Vec<[f64; 4]> = posed
        .iter()
        .map(|s| [f64::from(s.center[0]), f64::from(s.center[1]), f64::from(s.center[2]), f64::from(s.radius)])
        .collect();
    let coverage = union_coverage(&verts, &balls);
    if a.json {
        let spheres: Vec<_> = posed.iter().map(|s| json!({"center": s.center, "radius": s.radius})).collect();
        let doc = json!({
            "file": a.file.display().to_string(),
            "model": a.model.display().to_string(),
            "animation": anim_name,
            "time_s": a.time,
            "skinned": proxy.skin().is_some(),
            "spheres": spheres,
            "root": root.map(|s| json!({"center": s.center, "radius": s.radius})),
            "coverage": coverage,
            "vertices": verts.len(),
        });
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(ExitCode::SUCCESS);
    }
    let what = match &anim_name {
        Some(n) => format!("animation {n:?} at {} s", a.time),
        None => "rest pose".to_string(),
    };
    println!("{} posed by {} ({what})", a.file.display(), a.model.display());
    if proxy.skin().is_none() {
        println!("  (no skin section: rest spheres)");
    }
    println!("  coverage  {coverage:.6}   (share of {} posed welded mesh vertices inside the union)", verts.len());
    if let Some(r) = root {
        println!(
            "  root      centre ({:.6}, {:.6}, {:.6}) radius {:.6}",
            r.center[0], r.center[1], r.center[2], r.radius
        );
    }
    for (i, s) in posed.iter().enumerate() {
        println!("  {i:5}  ({:.6}, {:.6}, {:.6})  r {:.6}", s.center[0], s.center[1], s.center[2], s.radius);
    }
    Ok(ExitCode::SUCCESS)
}
