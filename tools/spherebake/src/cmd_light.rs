//! `spherebake light FILE.sphb --model MODEL [--light uniform|lobe] [--animation NAME] [--time T]
//! [--no-soft-rotation] [--no-reflection-ratio] [--mean-albedo] [-o cmp.png] [--json] ...`:
//! the end-to-end check of the proxy's one-bounce indirect light (Guerrero et al. 2008, issue 14)
//! against Monte Carlo path tracing of the real mesh (`spherebake-reference`).
//!
//! Scene (the reference crate's, so both sides use the same receivers): the model (posed by
//! `--animation`/`--time`, else at rest) on the ground plane y = its lowest point, +Y up; ground
//! receivers on a `resolution²` grid over a square of side 3 × the larger horizontal extent
//! (the layout of `spherebake shadows`), `model-receivers` area-weighted points on the mesh with
//! outward normals. Light: an order-n SH environment, `uniform` (radiance 1) or `lobe` (a
//! windowed 40° cone from (0.5, 1, 0.3)/|·|, as `shadows`).
//!
//! - Reference: direct E_d and one-bounce indirect E_i by ray tracing the mesh with its textured
//!   linear albedo (the bake's own lookup), the SH light evaluated pointwise, clamped at ≥ 0 and
//!   0 below the horizon. The ground reflects nothing (its own bounce is an engine's business; the
//!   proxy models the light the model reflects).
//! - Proxy: pass 1 (`light_spheres`) once under the SH light with the part below the horizon
//!   removed (`clip_below_horizon`), pass 2 (`IndirectCluster`) per receiver cluster: ground tiles
//!   of `cluster`² receivers, model receivers grouped by their nearest leaf sphere
//!   (smallest |p − c|/r) with a bounding ball around each group. Direct light on the ground: the
//!   shadow query exactly as `spherebake shadows` runs it (tiles, overlap correction,
//!   self-shadowing rules), E_d = π × the shaded value (the shading vector holds 1/π).
//! - Metrics: relative RMSE = RMSE over receivers and the 3 channels / mean reference;
//!   bias = (mean proxy − mean reference) / mean reference.

use crate::cmd_shadows::LightArg;
use anyhow::{bail, Context, Result};
use clap::Args;
use rayon::prelude::*;
use serde_json::json;
use spherebake_bake::skin::{animation_joint_matrices, rest_joint_matrices};
use spherebake_geom::glam::Vec3;
use spherebake_reference::{Receiver, ReferenceSettings, Scene, Sky};
use spherebake_runtime::light::{
    clip_below_horizon, light_spheres, sphere_rotations, ClusterSpec, IndirectCluster, LightContext, LightSource,
    Pass1Settings, PosedProxy, SphereLights,
};
use spherebake_runtime::shadow::{coeff_count, lobe_light, uniform_light, ClusterBlockers, ExpMethod, MAX_COEFFS};
use spherebake_runtime::tile::{voronoi_cells, Cell, SampleTile};
use spherebake_runtime::{rest_node_spheres, HierarchyPlan, Proxy, Sphere};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

#[derive(Args, Debug)]
pub struct LightArgs {
    /// The baked file
    pub file: PathBuf,
    #[command(flatten)]
    pub model: crate::cmd_view::ModelArg,
    /// Lighting environment (+Y up; the ground plane is y = the model's lowest y)
    #[arg(long, value_enum, default_value_t = LightArg::Uniform)]
    pub light: LightArg,
    /// Pose from this animation [default: rest pose; with --time alone, the model's first animation]
    #[arg(long)]
    pub animation: Option<String>,
    /// Time in seconds of the animation (clamped to each channel's key range) [default: 0]
    #[arg(long, allow_negative_numbers = true)]
    pub time: Option<f32>,
    /// Do not turn the sphere lights with the skin's average rotation (§7.1)
    #[arg(long)]
    pub no_soft_rotation: bool,
    /// Do not apply the reflection ratios of the hierarchy nodes (eq. 25–26)
    #[arg(long)]
    pub no_reflection_ratio: bool,
    /// Keep only the constant (mean) term of every sphere's albedo SH (baseline)
    #[arg(long)]
    pub mean_albedo: bool,
    /// Write the ground's indirect irradiance, proxy | reference | difference, to this image (.png, or
    /// .jpg / .jpeg for JPEG)
    #[arg(short, long, value_name = "CMP.png")]
    pub output: Option<PathBuf>,
    /// Print one JSON document instead of text
    #[arg(long)]
    pub json: bool,
    /// Write every receiver (position, normal, proxy and reference irradiance) to this JSON file
    #[arg(long, value_name = "VALUES.json")]
    pub values_json: Option<PathBuf>,
    /// Ground receivers per edge [range 2..=1024]
    #[arg(long, default_value_t = 64)]
    pub resolution: usize,
    /// Receivers on the model surface [range 0..=1048576]
    #[arg(long, default_value_t = 1024)]
    pub model_receivers: usize,
    /// Reference rays per receiver, cosine-weighted (rounded up to a square) [range 1..=1048576]
    #[arg(long, default_value_t = 256)]
    pub rays: usize,
    /// Reference shadow rays per indirect hit (rounded up to a square) [range 1..=1024]
    #[arg(long, default_value_t = 4)]
    pub shadow_rays: usize,
    /// Ground receiver tile edge, in receivers [range 1..]
    #[arg(long, default_value_t = 8)]
    pub cluster: usize,
    /// SH order of the light passes [range 2..=8, at most the baked albedo order]
    #[arg(long, default_value_t = 4)]
    pub order: usize,
    /// Cut threshold θmax in degrees (Ren eq. 36) of pass 2 and the direct light [range 0..=90]
    #[arg(long, default_value_t = 25.0)]
    pub theta_max_deg: f32,
    /// Seed of the reference's jitter and of the model receivers
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Development aid: keep the path-traced reference of each (model, pose, light, receivers,
    /// rays, seed) in this folder and reuse it on the next run instead of tracing it again
    #[arg(long, value_name = "DIR", hide = true)]
    pub reference_cache: Option<PathBuf>,
    /// Development aid: run pass 2 on sphere lights projected from the traced sample radiance
    /// (the pass-1 reference) instead of the log-SH pass 1, to separate the two passes' errors
    #[arg(long, hide = true)]
    pub pass1_reference: bool,
    /// Development aid: replace the ground's proxy values by the splat of every sample (its surface
    /// tile with the traced sample radiance and the traced albedo under the sample, ray-traced
    /// visibility of the sample): the error that remains is that of the samples themselves as emitters
    #[arg(long, hide = true)]
    pub splat_oracle: bool,
}

/// Error statistics of one quantity over receivers and channels.
#[derive(Clone, Debug)]
pub struct Stats {
    pub rel_rmse: f64,
    pub rmse: f64,
    pub bias: f64,
    pub mean_proxy_rgb: [f64; 3],
    pub mean_reference_rgb: [f64; 3],
}

/// "rel RMSE … bias …", or the absolute RMSE where the reference's mean is 0 (a convex model
/// reflects nothing onto itself) and the relative errors are not finite.
fn errors(s: &Stats) -> String {
    if s.rel_rmse.is_finite() && s.bias.is_finite() {
        format!("rel RMSE {:.4}  bias {:+.4}", s.rel_rmse, s.bias)
    } else {
        format!("rel RMSE n/a (the reference is 0)  RMSE {:.4e}", s.rmse)
    }
}

/// (receiver index, value) pairs of one cluster.
type Values<T> = Vec<(usize, T)>;

/// Everything one run measured.
pub struct LightResult {
    pub ground: Vec<Receiver>,
    pub model: Vec<Receiver>,
    /// Pass 1's exit radiance per unit albedo of every sample, and the reference's E_d/π there
    /// (empty when posed).
    pub sample_proxy: Vec<f64>,
    pub sample_reference: Vec<f64>,
    pub ground_direct_proxy: Vec<f64>,
    pub ground_direct_reference: Vec<f64>,
    pub ground_proxy: Vec<[f64; 3]>,
    pub ground_reference: Vec<[f64; 3]>,
    pub model_proxy: Vec<[f64; 3]>,
    pub model_reference: Vec<[f64; 3]>,
    pub pass1_seconds: f64,
    pub pass2_seconds: f64,
    pub direct_seconds: f64,
    pub reference_seconds: f64,
    pub hierarchy_nodes: usize,
    pub model_clusters: usize,
    pub pose: Option<(String, f32)>,
}

pub fn run(a: LightArgs) -> Result<ExitCode> {
    // The picture's type from its extension, refused before any work (as `render`).
    if let Some(out) = &a.output {
        crate::cmd_view::image_format(out)?;
    }
    if !(2..=1024).contains(&a.resolution) {
        usage_bail!("--resolution {} is outside 2..=1024", a.resolution);
    }
    if a.model_receivers > 1 << 20 {
        usage_bail!("--model-receivers {} is above 1048576", a.model_receivers);
    }
    if !(1..=1 << 20).contains(&a.rays) {
        usage_bail!("--rays {} is outside 1..=1048576", a.rays);
    }
    if !(1..=1024).contains(&a.shadow_rays) {
        usage_bail!("--shadow-rays {} is outside 1..=1024", a.shadow_rays);
    }
    if a.cluster == 0 {
        usage_bail!("--cluster must be at least 1");
    }
    if !(0.0..=90.0).contains(&a.theta_max_deg) {
        usage_bail!("--theta-max-deg {} is outside 0..=90", a.theta_max_deg);
    }
    if !(2..=8).contains(&a.order) {
        usage_bail!("--order {} is outside 2..=8", a.order);
    }
    if let Some(t) = a.time {
        if !t.is_finite() {
            usage_bail!("--time must be a finite number of seconds, got {t}");
        }
    }
    let mut proxy = crate::cmd_view::read_sphb(&a.file)?;
    if a.mean_albedo {
        proxy = mean_albedo(&proxy).with_context(|| format!("{}: --mean-albedo", a.file.display()))?;
    }
    let imported = spherebake_io::load_mesh(&a.model)?;
    crate::cmd_view::warn_other_input(&proxy, &a.file, &imported, &a.model);
    let r = compute(&a, &proxy, &imported.mesh)
        .with_context(|| format!("{}: light against {}", a.file.display(), a.model.display()))?;
    let res = a.resolution;
    if let Some(out) = &a.output {
        let mut read = imported.inputs.clone();
        read.push(a.file.clone());
        write_image(out, res, &r.ground_proxy, &r.ground_reference, &read)?;
    }
    if let Some(out) = &a.values_json {
        let mut read = imported.inputs.clone();
        read.push(a.file.clone());
        let text = serde_json::to_string(&values_doc(&r))?;
        crate::atomic::write_atomic(out, text.as_bytes(), &read)?;
    }
    let light = match a.light {
        LightArg::Uniform => "uniform",
        LightArg::Lobe => "lobe",
    };
    let direct = scalar_stats(&r.ground_direct_proxy, &r.ground_direct_reference);
    let ground = rgb_stats(&r.ground_proxy, &r.ground_reference);
    let model = rgb_stats(&r.model_proxy, &r.model_reference);
    let samples = scalar_stats(&r.sample_proxy, &r.sample_reference);
    let rays = strata(a.rays).pow(2);
    if a.json {
        let st = |s: &Stats| {
            json!({
                "rel_rmse": finite(s.rel_rmse),
                "rmse": finite(s.rmse),
                "bias": finite(s.bias),
                "mean_proxy_rgb": s.mean_proxy_rgb.map(finite),
                "mean_reference_rgb": s.mean_reference_rgb.map(finite),
            })
        };
        let doc = json!({
            "file": a.file.display().to_string(),
            "model": a.model.display().to_string(),
            "light": light,
            "order": a.order,
            "spheres": proxy.sphere_count(),
            "hierarchy_nodes": r.hierarchy_nodes,
            "animation": r.pose.as_ref().map(|p| p.0.clone()),
            "time_s": r.pose.as_ref().map(|p| p.1),
            "soft_rotation": !a.no_soft_rotation,
            "reflection_ratio": !a.no_reflection_ratio,
            "mean_albedo": a.mean_albedo,
            "receivers": { "ground": res * res, "model": r.model_reference.len() },
            "model_clusters": r.model_clusters,
            "rays_per_receiver": rays,
            "shadow_rays_per_hit": strata(a.shadow_rays).pow(2),
            "cluster": a.cluster,
            "theta_max_deg": a.theta_max_deg,
            "seed": a.seed,
            "direct": {
                "rel_rmse": finite(direct.rel_rmse),
                "rmse": finite(direct.rmse),
                "bias": finite(direct.bias),
                "mean_proxy": finite(direct.mean_proxy_rgb[0]),
                "mean_reference": finite(direct.mean_reference_rgb[0]),
            },
            "indirect": { "ground": st(&ground), "model": st(&model) },
            "pass1_samples": {
                "samples": r.sample_proxy.len(),
                "rel_rmse": finite(samples.rel_rmse),
                "bias": finite(samples.bias),
                "mean_proxy": finite(samples.mean_proxy_rgb[0]),
                "mean_reference": finite(samples.mean_reference_rgb[0]),
            },
            "timings": {
                "pass1_seconds": r.pass1_seconds,
                "pass2_seconds": r.pass2_seconds,
                "direct_seconds": r.direct_seconds,
                "reference_seconds": r.reference_seconds,
            },
        });
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(ExitCode::SUCCESS);
    }
    let pose = match &r.pose {
        Some((n, t)) => format!("animation {n:?} at {t} s"),
        None => "rest pose".to_string(),
    };
    let rgb = rgb_text;
    println!("{} against {} ({light} light, order {}, {pose})", a.file.display(), a.model.display(), a.order);
    println!(
        "  spheres                {} ({} hierarchy nodes){}",
        proxy.sphere_count(),
        r.hierarchy_nodes,
        if a.mean_albedo { ", mean albedo only" } else { "" }
    );
    println!(
        "  receivers              {} ground ({res}²), {} model ({} clusters); reference {rays} rays each",
        res * res,
        r.model_reference.len(),
        r.model_clusters
    );
    println!("  direct, ground         {}", errors(&direct));
    for (name, s) in [("indirect, ground", &ground), ("indirect, model ", &model)] {
        println!("  {name}       {}", errors(s));
        println!("      mean proxy         {}", rgb(s.mean_proxy_rgb));
        println!("      mean reference     {}", rgb(s.mean_reference_rgb));
    }
    if !r.sample_proxy.is_empty() {
        println!(
            "  pass 1, {} samples    exit radiance per unit albedo vs reference E_d/π: {}",
            r.sample_proxy.len(),
            errors(&samples)
        );
    }
    println!(
        "  time pass 1 / pass 2 / direct / reference   {:.4} s / {:.3} s / {:.3} s / {:.2} s",
        r.pass1_seconds, r.pass2_seconds, r.direct_seconds, r.reference_seconds
    );
    Ok(ExitCode::SUCCESS)
}

/// Per receiver: `ground` entries `{position, normal, proxy, reference, direct_proxy,
/// direct_reference}`, `model` entries `{position, normal, proxy, reference}` (irradiance, linear
/// RGB; direct grey), in receiver order.
fn values_doc(r: &LightResult) -> serde_json::Value {
    let ground: Vec<_> = (0..r.ground.len())
        .map(|k| {
            json!({
                "position": r.ground[k].position,
                "normal": r.ground[k].normal,
                "proxy": r.ground_proxy[k].map(finite),
                "reference": r.ground_reference[k].map(finite),
                "direct_proxy": finite(r.ground_direct_proxy[k]),
                "direct_reference": finite(r.ground_direct_reference[k]),
            })
        })
        .collect();
    let model: Vec<_> = (0..r.model.len())
        .map(|k| {
            json!({
                "position": r.model[k].position,
                "normal": r.model[k].normal,
                "proxy": r.model_proxy[k].map(finite),
                "reference": r.model_reference[k].map(finite),
            })
        })
        .collect();
    json!({ "ground": ground, "model": model })
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// ⌈√n⌉ (the reference's strata per axis).
fn strata(n: usize) -> usize {
    let mut s = 1;
    while s * s < n {
        s += 1;
    }
    s
}

/// The proxy with every sphere's albedo SH reduced to its constant term.
fn mean_albedo(proxy: &Proxy) -> Result<Proxy> {
    let mut f = proxy.file().clone();
    let Some(a) = f.albedo_sh.as_mut() else { bail!("the file has no albedo SH") };
    let per = a.coefficients_per_sphere();
    if per > 0 {
        for chunk in a.coefficients.chunks_mut(per) {
            for c in chunk.iter_mut().skip(1) {
                *c = [0.0; 3];
            }
        }
    }
    Ok(Proxy::from_file(&f)?)
}

/// An RGB mean for the summary: five decimals, or four significant digits when every channel
/// is below 0.01 (a near-black model's indirect light, about 1e-5, printed as zeros before).
fn rgb_text(v: [f64; 3]) -> String {
    if v.iter().all(|x| x.abs() < 0.01) && v.iter().any(|&x| x != 0.0) {
        format!("({:.3e}, {:.3e}, {:.3e})", v[0], v[1], v[2])
    } else {
        format!("({:.5}, {:.5}, {:.5})", v[0], v[1], v[2])
    }
}

/// RMSE-based statistics over receivers and channels.
fn rgb_stats(proxy: &[[f64; 3]], reference: &[[f64; 3]]) -> Stats {
    let n = proxy.len().min(reference.len());
    let mut mp = [0.0; 3];
    let mut mr = [0.0; 3];
    let mut se = 0.0;
    for (p, r) in proxy.iter().zip(reference) {
        for c in 0..3 {
            mp[c] += p[c];
            mr[c] += r[c];
            se += (p[c] - r[c]) * (p[c] - r[c]);
        }
    }
    let nf = n as f64;
    let mp = mp.map(|v| v / nf);
    let mr = mr.map(|v| v / nf);
    let mean_p = (mp[0] + mp[1] + mp[2]) / 3.0;
    let mean_r = (mr[0] + mr[1] + mr[2]) / 3.0;
    let rmse = (se / (3.0 * nf)).sqrt();
    Stats {
        rel_rmse: rmse / mean_r,
        rmse,
        bias: (mean_p - mean_r) / mean_r,
        mean_proxy_rgb: mp,
        mean_reference_rgb: mr,
    }
}

fn scalar_stats(proxy: &[f64], reference: &[f64]) -> Stats {
    let p: Vec<[f64; 3]> = proxy.iter().map(|&v| [v; 3]).collect();
    let r: Vec<[f64; 3]> = reference.iter().map(|&v| [v; 3]).collect();
    rgb_stats(&p, &r)
}

/// The skeleton pose a run asks for: `(animation index, name, time)`, or `None` for the rest pose.
fn choose_pose(a: &LightArgs, mesh: &spherebake_geom::Mesh) -> Result<Option<(Option<usize>, String, f32)>> {
    let skel = mesh.skin.as_ref().map(|s| &s.skeleton);
    let time = a.time.unwrap_or(0.0);
    match (&a.animation, skel) {
        (Some(name), Some(sk)) => {
            let Some(i) = sk.animations.iter().position(|x| &x.name == name) else {
                let names: Vec<&str> = sk.animations.iter().map(|x| x.name.as_str()).collect();
                bail!("{}: no animation named {name:?} (animations: {names:?})", a.model.display());
            };
            Ok(Some((Some(i), name.clone(), time)))
        }
        (Some(name), None) => bail!("{}: --animation {name:?} given, but the model has no skin", a.model.display()),
        (None, Some(sk)) if a.time.is_some() => match sk.animations.first() {
            Some(an) => Ok(Some((Some(0), an.name.clone(), time))),
            None => bail!("{}: --time given, but the model has no animation", a.model.display()),
        },
        (None, None) if a.time.is_some() => bail!("{}: --time given, but the model has no skin", a.model.display()),
        (None, _) => Ok(None),
    }
}

fn cols(m: &[spherebake_geom::glam::Mat4]) -> Vec<[f32; 16]> {
    m.iter().map(|m| m.to_cols_array()).collect()
}

/// Runs the reference and the proxy for one baked proxy and its model.
pub fn compute(a: &LightArgs, proxy: &Proxy, mesh: &spherebake_geom::Mesh) -> Result<LightResult> {
    let order = a.order;
    let nc = coeff_count(order);
    let res = a.resolution;

    // Pose.
    let pose = choose_pose(a, mesh)?;
    let mut joints: Vec<[f32; 16]> = Vec::new();
    let mut rest_joints: Vec<[f32; 16]> = Vec::new();
    let scene = match (&pose, mesh.skin.as_ref()) {
        (Some((anim, _, t)), Some(skin)) => {
            if proxy.skin().is_none() {
                bail!("{}: a pose is asked for, but the file has no skin terms", a.file.display());
            }
            let j = animation_joint_matrices(&skin.skeleton, *anim, *t);
            if j.len() != proxy.bones().len() {
                bail!(
                    "{}: the file has {} bones, the model has {} joints",
                    a.file.display(),
                    proxy.bones().len(),
                    j.len()
                );
            }
            let posed = spherebake_geom::anim::skin_vertices(skin, &j);
            joints = cols(&j);
            let rj: Vec<_> = rest_joint_matrices(&skin.skeleton).iter().map(|m| m.as_mat4()).collect();
            rest_joints = cols(&rj);
            Scene::with_positions(mesh, posed)?
        }
        _ => Scene::new(mesh)?,
    };

    // Light: the SH environment; the proxy's is clipped below the horizon.
    let ctx = LightContext::new(order, ExpMethod::default())?;
    let mut light = [0.0f64; MAX_COEFFS];
    match a.light {
        LightArg::Uniform => uniform_light(order, &mut light),
        LightArg::Lobe => {
            let d = [0.5f64, 1.0, 0.3];
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            lobe_light(order, [d[0] / n, d[1] / n, d[2] / n], 40f64.to_radians(), &mut light)?;
        }
    }
    let mut env = [0.0f64; MAX_COEFFS];
    clip_below_horizon(&ctx, &light[..nc], [0.0, 1.0, 0.0], &mut env[..nc])?;
    let sky = Sky::new(order, &light[..nc])?;

    // Receivers (one definition for both sides).
    let ground = scene.ground_receivers(res)?;
    let model = scene.model_receivers(a.model_receivers, a.seed)?;

    // Reference.
    let start = Instant::now();
    let settings = ReferenceSettings { rays: a.rays, shadow_rays: a.shadow_rays, seed: a.seed };
    let cached = a.reference_cache.as_ref().map(|dir| {
        let key = format!(
            "{}|{:?}|{:?}|{}|{}|{}|{}|{}|{}",
            a.model.display(),
            a.light,
            pose.as_ref().map(|(i, n, t)| (i, n, t.to_bits())),
            res,
            a.model_receivers,
            a.rays,
            a.shadow_rays,
            a.seed,
            order
        );
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in key.bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
        dir.join(format!("light-reference-{h:016x}.json"))
    });
    type Cached = (Vec<f64>, Vec<[f64; 3]>, Vec<[f64; 3]>);
    let from_cache: Option<Cached> =
        cached.as_ref().and_then(|p| std::fs::read(p).ok()).and_then(|b| serde_json::from_slice(&b).ok());
    let (ground_direct_reference, ground_reference, model_reference) = match from_cache {
        Some(c) => c,
        None => {
            let c: Cached = (
                scene.direct(&sky, &ground, &settings)?,
                scene.indirect(&sky, &ground, &settings)?,
                scene.indirect(&sky, &model, &ReferenceSettings { seed: a.seed ^ 0x4D4F_4445_4C00, ..settings })?,
            );
            if let Some(p) = &cached {
                std::fs::write(p, serde_json::to_vec(&c)?)?;
            }
            c
        }
    };
    let reference_seconds = start.elapsed().as_secs_f64();

    // Proxy: pose, hierarchy, rotations.
    let start = Instant::now();
    let plan = proxy.hierarchy().map(HierarchyPlan::new).transpose()?;
    let mut leaves: Vec<Sphere> = proxy.spheres().to_vec();
    let mut nodes: Vec<Sphere> = proxy.hierarchy().map(rest_node_spheres).unwrap_or_default();
    let mut rotations = vec![spherebake_runtime::light::IDENTITY_ROTATION; proxy.sphere_count()];
    let posed_any = pose.is_some();
    if posed_any {
        match &plan {
            Some(p) => {
                nodes.resize(p.node_count(), Sphere::default());
                spherebake_runtime::pose_and_refit(proxy, p, &joints, &mut leaves, &mut nodes)?;
            }
            None => spherebake_runtime::pose(proxy, &joints, &mut leaves)?,
        }
        if !a.no_soft_rotation {
            sphere_rotations(proxy, &joints, &rest_joints, &mut rotations)?;
        }
    }
    let hierarchy = plan.as_ref().map(|p| (p, nodes.as_slice()));
    let posed = PosedProxy {
        proxy,
        leaves: &leaves,
        nodes: hierarchy,
        rotations: (posed_any && !a.no_soft_rotation).then_some(rotations.as_slice()),
    };
    let mut lights = SphereLights::new();
    light_spheres(&ctx, &posed, &env[..nc], &[], &Pass1Settings::default(), &mut lights)?;
    let pass1_seconds = start.elapsed().as_secs_f64();

    // Pass 1 against the reference (rest pose only: posed, pass 1 moves the samples rigidly with
    // their spheres, off the skinned surface): each sample's exit radiance per unit albedo L_pj
    // against E_d(p_j)/π traced at the sample.
    let start = Instant::now();
    let mut sample_receivers = Vec::new();
    let check_samples = !posed_any;
    let rest = proxy.spheres();
    for (i, s) in leaves.iter().enumerate().filter(|_| check_samples) {
        let rot =
            posed.rotations.and_then(|r| r.get(i)).copied().unwrap_or(spherebake_runtime::light::IDENTITY_ROTATION);
        let c0 = rest.get(i).map_or(s.center, |r| r.center);
        for sp in proxy.samples_of(i) {
            let rel = [sp.position[0] - c0[0], sp.position[1] - c0[1], sp.position[2] - c0[2]];
            let p = mat3(&rot, rel);
            let n = mat3(&rot, sp.normal);
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt().max(1e-30);
            sample_receivers.push(Receiver {
                position: [0, 1, 2].map(|k| f64::from(p[k] + s.center[k])),
                normal: n.map(|v| f64::from(v / len)),
                surface: None,
            });
        }
    }
    let sample_settings = ReferenceSettings { rays: a.rays.min(256), shadow_rays: 1, seed: a.seed ^ 0x5341_4D50 };
    let sample_reference: Vec<f64> =
        scene.direct(&sky, &sample_receivers, &sample_settings)?.into_iter().map(|e| e / PI).collect();
    let sample_proxy: Vec<f64> =
        if check_samples { lights.sample_radiance().iter().map(|&v| f64::from(v)).collect() } else { Vec::new() };
    let reference_seconds = reference_seconds + start.elapsed().as_secs_f64();
    if a.pass1_reference && check_samples {
        let r: Vec<f32> = sample_reference.iter().map(|&v| v as f32).collect();
        spherebake_runtime::light::light_spheres_from_radiance(&ctx, &posed, &r, &mut lights)?;
    }

    // Pass 2.
    let start = Instant::now();
    let sources: [LightSource<'_, '_>; 1] = [(posed, &lights)];
    let theta_max = a.theta_max_deg.to_radians();
    let reflection = !a.no_reflection_ratio;
    let tiles = res.div_ceil(a.cluster);
    let tile_bounds = |t: usize| {
        let (ti, tj) = (t % tiles, t / tiles);
        let (i0, j0) = (ti * a.cluster, tj * a.cluster);
        let (i1, j1) = ((i0 + a.cluster).min(res), (j0 + a.cluster).min(res));
        (i0, j0, i1, j1)
    };
    let tile_ball = |i0: usize, j0: usize, i1: usize, j1: usize| -> ([f32; 3], f32) {
        let (p0, p1) = (ground[j0 * res + i0].position, ground[(j1 - 1) * res + (i1 - 1)].position);
        let centre = [0.5 * (p0[0] + p1[0]), p0[1], 0.5 * (p0[2] + p1[2])];
        let half = [0.5 * (p1[0] - p0[0]), 0.5 * (p1[2] - p0[2])];
        let radius = (half[0] * half[0] + half[1] * half[1]).sqrt() * (1.0 + 1e-6);
        (centre.map(|v| v as f32), radius as f32)
    };
    let per_tile: Vec<Result<Values<[f64; 3]>>> = (0..tiles * tiles)
        .into_par_iter()
        .map_init(IndirectCluster::new, |cl, t| {
            let (i0, j0, i1, j1) = tile_bounds(t);
            let (centre, radius) = tile_ball(i0, j0, i1, j1);
            let spec = ClusterSpec {
                center: centre,
                radius,
                normal: Some([0.0, 1.0, 0.0]),
                theta_max_rad: theta_max,
                reflection_ratio: reflection,
                overlap_correction: false,
            };
            cl.build(&ctx, &sources, &spec)?;
            let mut out = Vec::with_capacity((i1 - i0) * (j1 - j0));
            for j in j0..j1 {
                for i in i0..i1 {
                    let k = j * res + i;
                    let r = &ground[k];
                    out.push((k, cl.irradiance(&ctx, &sources, f32x3(r.position), f32x3(r.normal))?));
                }
            }
            Ok(out)
        })
        .collect();
    let mut ground_proxy = vec![[0.0; 3]; res * res];
    for t in per_tile {
        for (k, v) in t? {
            ground_proxy[k] = v;
        }
    }
    let groups = model_clusters(&leaves, &model);
    let per_group: Vec<Result<Values<[f64; 3]>>> = groups
        .par_iter()
        .map_init(IndirectCluster::new, |cl, g| {
            let (centre, radius, normal) = receiver_ball(&model, g);
            let spec = ClusterSpec {
                center: centre,
                radius,
                normal,
                theta_max_rad: theta_max,
                reflection_ratio: reflection,
                overlap_correction: false,
            };
            cl.build(&ctx, &sources, &spec)?;
            let mut out = Vec::with_capacity(g.len());
            for &k in g {
                let r = &model[k];
                out.push((k, cl.irradiance(&ctx, &sources, f32x3(r.position), f32x3(r.normal))?));
            }
            Ok(out)
        })
        .collect();
    let mut model_proxy = vec![[0.0; 3]; model.len()];
    for g in per_group {
        for (k, v) in g? {
            model_proxy[k] = v;
        }
    }
    let pass2_seconds = start.elapsed().as_secs_f64();
    if a.splat_oracle && check_samples {
        // Each sample: position, normal, its surface tile (the runtime's near-field emitter), radiance × albedo.
        struct Emitter {
            x: [f64; 3],
            n: [f64; 3],
            rel: [f64; 3],
            centre: [f64; 3],
            radius: f64,
            cell: Cell,
            area: Option<f64>,
            c: [f64; 3],
        }
        let cells = voronoi_cells();
        let mut em: Vec<Emitter> = Vec::new();
        let mut k = 0usize;
        let mut missed = 0usize;
        for (i, s) in leaves.iter().enumerate() {
            let centre = s.center.map(f64::from);
            let areas = proxy.sample_areas_of(i);
            for (q, sp) in proxy.samples_of(i).iter().enumerate() {
                let radiance = sample_reference.get(k).copied().unwrap_or(0.0);
                k += 1;
                let (x, n) = (sp.position.map(f64::from), sp.normal.map(f64::from));
                // The true albedo under the sample (the proxy's albedo SH is what is being checked).
                let (Some(al), Some(cell)) = (scene.albedo_near(x, n), cells.get(usize::from(sp.direction))) else {
                    missed += 1;
                    continue;
                };
                let rel = [0, 1, 2].map(|q| x[q] - centre[q]);
                em.push(Emitter {
                    x,
                    n,
                    rel,
                    centre,
                    radius: f64::from(s.radius),
                    cell: *cell,
                    area: areas.and_then(|a| a.get(q)).map(|&a| f64::from(a)),
                    c: al.map(|a| a * radiance),
                });
            }
        }
        if missed > 0 {
            eline!(
                "splat oracle: {missed} of {} samples found no surface under them and emit nothing",
                missed + em.len()
            );
        }
        ground_proxy.par_iter_mut().zip(ground.par_iter()).for_each(|(out, r)| {
            let mut e = [0.0; 3];
            for t in &em {
                let p = [0, 1, 2].map(|q| r.position[q] - t.centre[q]);
                let tile = SampleTile { cell: &t.cell, radius: t.radius, x: t.rel, normal: t.n, area: t.area };
                let kf = tile.irradiance(p, r.normal);
                if kf <= 0.0 {
                    continue;
                }
                let w = [0, 1, 2].map(|q| r.position[q] - t.x[q]);
                let dl = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt().max(1e-30);
                let xo = [0, 1, 2].map(|q| t.x[q] + t.n[q] * 1e-4 * dl);
                if !scene.segment_clear(r.position, xo) {
                    continue;
                }
                for (e, c) in e.iter_mut().zip(t.c) {
                    *e += kf * c;
                }
            }
            *out = e;
        });
    }

    // Direct light on the ground: the shadow query as `spherebake shadows` runs it.
    let start = Instant::now();
    let sctx = ctx.shadow();
    let mut t_vec = [0.0; MAX_COEFFS];
    sctx.shading_vector(&light[..nc], [0.0, 1.0, 0.0], &mut t_vec)?;
    let t_vec = &t_vec[..nc];
    let per_tile: Vec<Result<Values<f64>>> = (0..tiles * tiles)
        .into_par_iter()
        .map_init(ClusterBlockers::new, |cb, t| {
            let (i0, j0, i1, j1) = tile_bounds(t);
            let (centre, radius) = tile_ball(i0, j0, i1, j1);
            cb.build(order, &leaves, hierarchy, centre, radius, theta_max)?;
            cb.correct_overlap(sctx, centre, [0.0, 1.0, 0.0], 1024)?;
            let mut out = Vec::with_capacity((i1 - i0) * (j1 - j0));
            for j in j0..j1 {
                for i in i0..i1 {
                    let k = j * res + i;
                    let v = sctx.shade_point(cb, f32x3(ground[k].position), [0.0, 1.0, 0.0], t_vec)?;
                    out.push((k, PI * v));
                }
            }
            Ok(out)
        })
        .collect();
    let mut ground_direct_proxy = vec![0.0; res * res];
    for t in per_tile {
        for (k, v) in t? {
            ground_direct_proxy[k] = v;
        }
    }
    let direct_seconds = start.elapsed().as_secs_f64();

    Ok(LightResult {
        ground,
        model,
        sample_proxy,
        sample_reference,
        ground_direct_proxy,
        ground_direct_reference,
        ground_proxy,
        ground_reference,
        model_proxy,
        model_reference,
        pass1_seconds,
        pass2_seconds,
        direct_seconds,
        reference_seconds,
        hierarchy_nodes: plan.as_ref().map_or(0, HierarchyPlan::node_count),
        model_clusters: groups.len(),
        pose: pose.map(|(_, n, t)| (n, t)),
    })
}

/// Column-major 3×3 times a vector.
fn mat3(m: &[f32; 9], v: [f32; 3]) -> [f32; 3] {
    [
        m[0] * v[0] + m[3] * v[1] + m[6] * v[2],
        m[1] * v[0] + m[4] * v[1] + m[7] * v[2],
        m[2] * v[0] + m[5] * v[1] + m[8] * v[2],
    ]
}

fn f32x3(v: [f64; 3]) -> [f32; 3] {
    v.map(|x| x as f32)
}

/// Model receivers grouped by their nearest leaf sphere (smallest |p − c|/r; ties → lowest
/// index; spheres of radius 0 own nothing). Groups in sphere order, receivers in index order.
fn model_clusters(leaves: &[Sphere], receivers: &[Receiver]) -> Vec<Vec<usize>> {
    let mut by_sphere: Vec<Vec<usize>> = vec![Vec::new(); leaves.len()];
    for (k, r) in receivers.iter().enumerate() {
        let p = Vec3::from(f32x3(r.position)).as_dvec3();
        let mut best = (f64::INFINITY, usize::MAX);
        for (i, s) in leaves.iter().enumerate() {
            let rad = f64::from(s.radius);
            if rad.is_nan() || rad <= 0.0 {
                continue;
            }
            let d = (p - Vec3::from(s.center).as_dvec3()).length() / rad;
            if d < best.0 {
                best = (d, i);
            }
        }
        if let Some(g) = by_sphere.get_mut(best.1) {
            g.push(k);
        }
    }
    by_sphere.into_iter().filter(|g| !g.is_empty()).collect()
}

/// Bounding ball (centre of the receivers' box, largest distance) and mean unit normal of a group
/// (`None` when the normals cancel out).
fn receiver_ball(receivers: &[Receiver], group: &[usize]) -> ([f32; 3], f32, Option<[f32; 3]>) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut nsum = [0.0f64; 3];
    for &k in group {
        let r = &receivers[k];
        for c in 0..3 {
            lo[c] = lo[c].min(r.position[c]);
            hi[c] = hi[c].max(r.position[c]);
            nsum[c] += r.normal[c];
        }
    }
    let centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])];
    let mut radius = 0.0f64;
    for &k in group {
        let p = receivers[k].position;
        let d = ((p[0] - centre[0]).powi(2) + (p[1] - centre[1]).powi(2) + (p[2] - centre[2]).powi(2)).sqrt();
        radius = radius.max(d);
    }
    let len = (nsum[0] * nsum[0] + nsum[1] * nsum[1] + nsum[2] * nsum[2]).sqrt();
    let normal = (len > 1e-3 * group.len() as f64).then(|| f32x3(nsum.map(|v| v / len)));
    (f32x3(centre), (radius * (1.0 + 1e-6)) as f32, normal)
}

// ---------------------------------------------------------------------------------------------
// Picture

/// linear → 8-bit sRGB (clamped to [0, 1]).
fn srgb8(v: f64) -> u8 {
    let v = if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.0 };
    let s = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as u8
}

/// Proxy | reference | difference of the ground's indirect irradiance (row = z, column = x),
/// each panel `res`² receivers enlarged by an integer factor to at least 400 px, labelled.
/// Proxy and reference share one scale (white = the largest reference channel, linear → sRGB);
/// the difference (mean over channels) is red where the proxy is brighter, blue where darker, at
/// 4× that scale.
fn write_image(path: &Path, res: usize, proxy: &[[f64; 3]], reference: &[[f64; 3]], read: &[PathBuf]) -> Result<()> {
    let k = 400usize.div_ceil(res).max(1);
    let panel = res * k;
    let gap = 16;
    let top = 64;
    let w = 3 * panel + 4 * gap;
    let h = top + panel + gap;
    let mut img = image::RgbImage::from_pixel(w as u32, h as u32, image::Rgb([255, 255, 255]));
    let vmax = reference.iter().flat_map(|v| v.iter().copied()).filter(|v| v.is_finite()).fold(0.0f64, f64::max);
    let vmax = if vmax > 0.0 { vmax } else { 1.0 };
    let title = format!("GROUND INDIRECT IRRADIANCE (LINEAR RGB, SRGB SHOWN), WHITE = {vmax:.4}");
    draw_text(&mut img, gap, 8, &title, 2, [0, 0, 0]);
    let labels = ["PROXY", "REFERENCE (PATH TRACED)", "DIFFERENCE X4: RED +, BLUE -"];
    for (p, label) in labels.iter().enumerate() {
        let x0 = gap + p * (panel + gap);
        draw_text(&mut img, x0, top - 22, label, 2, [0, 0, 0]);
        for j in 0..res {
            for i in 0..res {
                let idx = j * res + i;
                let (pv, rv) = (proxy[idx], reference[idx]);
                let c = match p {
                    0 => pv.map(|v| srgb8(v / vmax)),
                    1 => rv.map(|v| srgb8(v / vmax)),
                    _ => {
                        let d = ((pv[0] - rv[0]) + (pv[1] - rv[1]) + (pv[2] - rv[2])) / 3.0;
                        let d = (4.0 * d / vmax).clamp(-1.0, 1.0);
                        if d >= 0.0 {
                            [255, srgb8(1.0 - d), srgb8(1.0 - d)]
                        } else {
                            [srgb8(1.0 + d), srgb8(1.0 + d), 255]
                        }
                    }
                };
                for y in 0..k {
                    for x in 0..k {
                        img.put_pixel((x0 + i * k + x) as u32, (top + j * k + y) as u32, image::Rgb(c));
                    }
                }
            }
        }
    }
    let format = crate::cmd_view::image_format(path)?;
    let bytes = crate::cmd_view::encode_rgb(path, format, img.as_raw(), img.width(), img.height())?;
    crate::atomic::write_atomic(path, &bytes, read)?;
    Ok(())
}

/// Draws `text` (upper case, digits and a few signs of a 5×7 font; anything else is a blank) with
/// its top-left at (x, y), each font pixel `scale`² image pixels, clipped to the image.
fn draw_text(img: &mut image::RgbImage, x: usize, y: usize, text: &str, scale: usize, colour: [u8; 3]) {
    let (w, h) = (img.width() as usize, img.height() as usize);
    for (n, ch) in text.chars().enumerate() {
        let g = glyph(ch.to_ascii_uppercase());
        let gx = x + n * 6 * scale;
        for (row, bits) in g.iter().enumerate() {
            for col in 0..5 {
                if bits & (0x10 >> col) == 0 {
                    continue;
                }
                for dy in 0..scale {
                    for dx in 0..scale {
                        let (px, py) = (gx + col * scale + dx, y + row * scale + dy);
                        if px < w && py < h {
                            img.put_pixel(px as u32, py as u32, image::Rgb(colour));
                        }
                    }
                }
            }
        }
    }
}

/// 5×7 glyph rows, bit 4 = leftmost column.
fn glyph(c: char) -> [u8; 7] {
    match c {
        'A' => [0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'B' => [0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E],
        'C' => [0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E],
        'D' => [0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C],
        'E' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F],
        'F' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10],
        'G' => [0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F],
        'H' => [0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'I' => [0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'J' => [0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C],
        'K' => [0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11],
        'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F],
        'M' => [0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11],
        'N' => [0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11],
        'O' => [0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'P' => [0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10],
        'Q' => [0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D],
        'R' => [0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11],
        'S' => [0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E],
        'T' => [0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
        'U' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'V' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'W' => [0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A],
        'X' => [0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11],
        'Y' => [0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04],
        'Z' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F],
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        '+' => [0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00],
        '=' => [0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        ',' => [0x00, 0x00, 0x00, 0x00, 0x0C, 0x04, 0x08],
        ':' => [0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00],
        '(' => [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02],
        ')' => [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08],
        '/' => [0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00],
        '%' => [0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03],
        '|' => [0x04; 7],
        _ => [0; 7],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiny_means_keep_their_digits() {
        assert_eq!(rgb_text([0.5, 0.25, 1.0]), "(0.50000, 0.25000, 1.00000)");
        assert_eq!(rgb_text([0.0; 3]), "(0.00000, 0.00000, 0.00000)");
        assert_eq!(rgb_text([2.1e-5, 1.5e-5, 0.0]), "(2.100e-5, 1.500e-5, 0.000e0)");
        // One channel at 0.01 or more keeps the fixed form for all three.
        assert_eq!(rgb_text([0.02, 1e-5, 0.0]), "(0.02000, 0.00001, 0.00000)");
    }

    #[test]
    fn a_zero_reference_prints_the_absolute_error() {
        // A convex model reflects nothing onto itself: reference 0, proxy 0.02 in every channel.
        let s = rgb_stats(&[[0.02; 3], [0.02; 3]], &[[0.0; 3], [0.0; 3]]);
        assert!(!s.rel_rmse.is_finite());
        assert_eq!(errors(&s), "rel RMSE n/a (the reference is 0)  RMSE 2.0000e-2");
        let s = rgb_stats(&[[1.1; 3]], &[[1.0; 3]]);
        assert_eq!(errors(&s), "rel RMSE 0.1000  bias +0.1000");
    }

    #[test]
    fn stats_of_known_values() {
        // proxy = 1.1 × reference everywhere: bias 0.1, rel RMSE = 0.1 · rms(ref)/mean(ref).
        let r = vec![[1.0, 2.0, 3.0], [3.0, 2.0, 1.0]];
        let p: Vec<[f64; 3]> = r.iter().map(|v| v.map(|x| 1.1 * x)).collect();
        let s = rgb_stats(&p, &r);
        assert!((s.bias - 0.1).abs() < 1e-12);
        let rms = ((1.0 + 4.0 + 9.0) * 2.0 / 6.0f64).sqrt();
        assert!((s.rel_rmse - 0.1 * rms / 2.0).abs() < 1e-12);
        assert_eq!(s.mean_reference_rgb, [2.0, 2.0, 2.0]);
    }

    #[test]
    fn every_label_character_has_a_glyph() {
        for ch in "GROUND INDIRECT IRRADIANCE (LINEAR RGB, SRGB SHOWN), WHITE = 0.123456789 PROXY REFERENCE PATH TRACED DIFFERENCE X4: RED +, BLUE - JKQVZ%/|".chars() {
            assert!(ch == ' ' || glyph(ch) != [0; 7], "{ch}");
        }
    }
}
