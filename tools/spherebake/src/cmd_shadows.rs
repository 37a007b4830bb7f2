//! `spherebake shadows FILE.sphb --model MODEL [--light uniform|lobe] [-o cmp.png] [--json]`:
//! the end-to-end check of the soft-shadow query (Ren et al. 2006) against ray tracing.
//!
//! Scene: the model on a ground plane y = min y of the model (+Y up: glTF's convention; OBJ models
//! are taken as +Y up too), a square of side 3 × the model's larger horizontal (x or z) extent,
//! centred under the model's bounding box, sampled by `resolution²` receivers at cell centres
//! with normal +Y. Light: an order-n SH environment (uniform white, or a windowed 40° lobe from
//! direction (0.5, 1, 0.3)/|·|).
//!
//! - Truth per receiver: visibility of the mesh by stratified, seeded Monte Carlo ray casting
//!   (`rays` per receiver over the upper hemisphere; the mesh lies above the plane, so the lower
//!   hemisphere is unoccluded), projected to SH as g = **1** − (4π/K) Σ_blocked y(s_k) (K = rays
//!   over the whole sphere; the **1** term is exact, a control variate).
//! - Proxy per receiver: the runtime query (`spherebake_runtime::shadow`) on the baked file:
//!   receivers clustered in `cluster`×`cluster` tiles, hierarchy cut at θmax and ratio vectors per
//!   tile, self-shadowing rules, exp*, shading.
//! - Both shaded with the same vector T = L ∗ H(+Y); rel_rmse = RMSE(proxy − truth) / mean(truth).

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use rayon::prelude::*;
use serde_json::json;
use spherebake_geom::bvh::TriangleBvh;
use spherebake_geom::glam::Vec3;
use spherebake_runtime::shadow::{
    accumulate_log_visibility, coeff_count, eval_sh_f64, lobe_light, shade, uniform_light, ClusterBlockers, ExpMethod,
    ShadowContext, MAX_COEFFS,
};
use spherebake_runtime::{rest_node_spheres, HierarchyPlan, Sphere};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LightArg {
    /// Uniform white environment (L = 1)
    Uniform,
    /// A 40° cone of light from (0.5, 1, 0.3), windowed
    Lobe,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ExpArg {
    /// PS*-4 (default)
    Ps4,
    /// HYB with the default OL bound
    Hyb,
    /// exp(M_f)·1 to rounding (reference)
    Accurate,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum HierarchyArg {
    /// The file's hierarchy if it has one, else all spheres under one implicit root
    File,
    /// Like `file`, but build one (spherebake-fit, branching 4) when the file has none
    Build,
    /// Ignore any hierarchy: all spheres under one implicit root
    None,
}

#[derive(Args, Debug)]
pub struct ShadowsArgs {
    /// The baked file
    pub file: PathBuf,
    #[command(flatten)]
    pub model: crate::cmd_view::ModelArg,
    /// Lighting environment (+Y up; the ground plane is y = the model's lowest y)
    #[arg(long, value_enum, default_value_t = LightArg::Uniform)]
    pub light: LightArg,
    /// Write truth | proxy | difference side by side to this image (.png, or
    /// .jpg / .jpeg for JPEG)
    #[arg(short, long, value_name = "CMP.png")]
    pub output: Option<PathBuf>,
    /// Print one JSON document instead of text
    #[arg(long)]
    pub json: bool,
    /// Receivers per ground edge [range 2..=2048]
    #[arg(long, default_value_t = 128)]
    pub resolution: usize,
    /// Monte Carlo rays per receiver over the whole sphere (rounded up to a square; half are cast) [range 4..=1048576]
    #[arg(long, default_value_t = 1024)]
    pub rays: usize,
    /// Receiver cluster tile edge, in receivers [range 1..]
    #[arg(long, default_value_t = 8)]
    pub cluster: usize,
    /// Cut threshold θmax in degrees (Ren eq. 36) [range 0..=90]
    #[arg(long, default_value_t = 25.0)]
    pub theta_max_deg: f32,
    /// SH exponential
    #[arg(long, value_enum, default_value_t = ExpArg::Ps4)]
    pub exp: ExpArg,
    /// SH order [range 2..=8]
    #[arg(long, default_value_t = 4)]
    pub order: usize,
    /// Which sphere hierarchy the query cuts
    #[arg(long, value_enum, default_value_t = HierarchyArg::File)]
    pub hierarchy: HierarchyArg,
    /// Skip the self-shadowing rules (every blocker counts whole; for measuring their effect)
    #[arg(long)]
    pub no_self_shadow_rules: bool,
    /// Use Ren et al. 2006's log-SH sum as published, without the per-tile overlap correction.
    /// By default each receiver tile's summed log is scaled so its visibility matches the visible
    /// fraction of the sphere union along 1024 directions: deeply overlapping sphere sets
    /// otherwise count shared volume many times and their shadows wash out as spheres grow.
    #[arg(long)]
    pub no_overlap_correction: bool,
    /// Seed of the ray jitter
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

// SplitMix64 per-stratum jitter (deterministic, independent of thread count): the reference crate's.
use spherebake_reference::{mix, unit};

/// Per tile: (receiver index, shaded value) pairs and the tile's blocker count.
type TileResult = Result<(Vec<(usize, f64)>, usize)>;

/// Results of one run.
pub struct ShadowsResult {
    pub truth: Vec<f64>,
    pub proxy: Vec<f64>,
    pub rel_rmse: f64,
    pub rmse: f64,
    pub mean_truth: f64,
    pub mean_proxy: f64,
    pub mean_blockers: f64,
    pub truth_seconds: f64,
    pub proxy_seconds: f64,
    /// Where the hierarchy came from: "file", "built" or "none".
    pub hierarchy: &'static str,
    pub hierarchy_nodes: usize,
}

pub fn run(a: ShadowsArgs) -> Result<ExitCode> {
    // The picture's type from its extension, refused before any work (as `render`).
    if let Some(out) = &a.output {
        crate::cmd_view::image_format(out)?;
    }
    if !(2..=2048).contains(&a.resolution) {
        usage_bail!("--resolution {} is outside 2..=2048", a.resolution);
    }
    if !(4..=1 << 20).contains(&a.rays) {
        usage_bail!("--rays {} is outside 4..=1048576", a.rays);
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
    let proxy = crate::cmd_view::read_sphb(&a.file)?;
    let imported = spherebake_io::load_mesh(&a.model)?;
    crate::cmd_view::warn_other_input(&proxy, &a.file, &imported, &a.model);
    let mesh = &imported.mesh;
    let r = compute(&a, &proxy, mesh)
        .with_context(|| format!("{}: shadows against {}", a.file.display(), a.model.display()))?;
    if let Some(out) = &a.output {
        let mut read = imported.inputs.clone();
        read.push(a.file.clone());
        write_image(out, a.resolution, &r.truth, &r.proxy, &read)?;
    }
    let hierarchy = r.hierarchy;
    let light = match a.light {
        LightArg::Uniform => "uniform",
        LightArg::Lobe => "lobe",
    };
    let exp = match a.exp {
        ExpArg::Ps4 => "ps4",
        ExpArg::Hyb => "hyb",
        ExpArg::Accurate => "accurate",
    };
    if a.json {
        let doc = json!({
            "file": a.file.display().to_string(),
            "model": a.model.display().to_string(),
            "rel_rmse": r.rel_rmse,
            "rmse": r.rmse,
            "mean_truth": r.mean_truth,
            "mean_proxy": r.mean_proxy,
            "receivers": a.resolution * a.resolution,
            "spheres": proxy.sphere_count(),
            "hierarchy": hierarchy,
            "hierarchy_nodes": r.hierarchy_nodes,
            "light": light,
            "exp": exp,
            "order": a.order,
            "rays_per_receiver": strata(a.rays).pow(2),
            "cluster": a.cluster,
            "theta_max_deg": a.theta_max_deg,
            "mean_blockers_per_cluster": r.mean_blockers,
            "truth_seconds": r.truth_seconds,
            "proxy_seconds": r.proxy_seconds,
        });
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!("{} against {} ({light} light)", a.file.display(), a.model.display());
    println!("  spheres                {} (hierarchy: {hierarchy}, {} nodes)", proxy.sphere_count(), r.hierarchy_nodes);
    println!(
        "  receivers              {} ({}²), {} rays each",
        a.resolution * a.resolution,
        a.resolution,
        strata(a.rays).pow(2)
    );
    println!("  relative RMSE          {:.5}   (RMSE(proxy − truth) / mean(truth))", r.rel_rmse);
    println!("  mean truth / proxy     {:.5} / {:.5}", r.mean_truth, r.mean_proxy);
    println!("  blockers per cluster   {:.1} (mean)", r.mean_blockers);
    println!("  time truth / proxy     {:.2} s / {:.3} s", r.truth_seconds, r.proxy_seconds);
    Ok(ExitCode::SUCCESS)
}

fn strata(rays: usize) -> usize {
    let mut n = 1;
    while n * n < rays {
        n += 1;
    }
    n
}

/// Runs truth and proxy for one baked proxy and mesh (model space, +Y up). The truth's rays pass
/// through the holes of alpha-masked materials (`SurfaceAlbedo::first_opaque_hit`), as the
/// albedo bake and the light reference do.
pub fn compute(
    a: &ShadowsArgs,
    proxy: &spherebake_runtime::Proxy,
    mesh: &spherebake_geom::Mesh,
) -> Result<ShadowsResult> {
    let (positions, triangles) = (&mesh.positions[..], &mesh.triangles[..]);
    let order = a.order;
    let nc = coeff_count(order);
    // Bounds over the corners of the triangles.
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for t in triangles {
        for &i in t {
            let p = *positions.get(i as usize).context("triangle index out of range")?;
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    if !(lo.is_finite() && hi.is_finite()) {
        bail!("the mesh has no finite triangles");
    }
    let side = 3.0 * (hi.x - lo.x).max(hi.z - lo.z);
    if side.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        bail!("the mesh has no horizontal extent");
    }
    let (cx, cz, y0) = (0.5 * (lo.x + hi.x), 0.5 * (lo.z + hi.z), lo.y);
    let res = a.resolution;
    let cell = side / res as f32;
    let receiver = |i: usize, j: usize| -> [f32; 3] {
        [cx - 0.5 * side + (i as f32 + 0.5) * cell, y0, cz - 0.5 * side + (j as f32 + 0.5) * cell]
    };
    let normal = [0.0f32, 1.0, 0.0];

    let exp = match a.exp {
        ExpArg::Ps4 => ExpMethod::PsStar { degree: 4 },
        ExpArg::Hyb => ExpMethod::Hyb { ol_norm_bound: 0.0 },
        ExpArg::Accurate => ExpMethod::Accurate,
    };
    let ctx = ShadowContext::new(order, exp)?;
    let mut light = [0.0; MAX_COEFFS];
    match a.light {
        LightArg::Uniform => uniform_light(order, &mut light),
        LightArg::Lobe => {
            let d = [0.5f64, 1.0, 0.3];
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            lobe_light(order, [d[0] / n, d[1] / n, d[2] / n], 40f64.to_radians(), &mut light)?;
        }
    }
    let mut t_vec = [0.0; MAX_COEFFS];
    ctx.shading_vector(&light[..nc], [0.0, 1.0, 0.0], &mut t_vec)?;
    let t_vec = &t_vec[..nc];

    // Truth.
    let start = Instant::now();
    let bvh = TriangleBvh::new(positions, triangles);
    let diag = (hi - lo).length();
    let t_min = 1e-5 * diag;
    // The colour lookup only where a material is alpha-masked (its mip chains cost time).
    let cutouts = if mesh.materials.iter().any(|m| m.alpha_mask_cutoff.is_some()) {
        Some(spherebake_bake::SurfaceAlbedo::new(mesh).context("the model's materials")?)
    } else {
        None
    };
    let ns = strata(a.rays);
    let k_total = (ns * ns) as f64;
    let seed = a.seed;
    let truth: Vec<f64> = (0..res * res)
        .into_par_iter()
        .map(|idx| {
            let (i, j) = (idx % res, idx / res);
            let p = receiver(i, j);
            let origin = Vec3::from(p);
            let mut g = [0.0f64; MAX_COEFFS];
            let mut y = [0.0f64; MAX_COEFFS];
            let base = mix(seed ^ mix(idx as u64));
            // Strata in (cos from +Y uniform in [−1, 1], azimuth); only the upper half is cast.
            for sa in 0..ns {
                for sb in 0..ns {
                    let h = mix(base ^ ((sa * ns + sb) as u64));
                    let c = 1.0 - 2.0 * (sa as f64 + unit(h)) / ns as f64;
                    if c <= 0.0 {
                        continue;
                    }
                    let phi = std::f64::consts::TAU * (sb as f64 + unit(mix(h))) / ns as f64;
                    let s = (1.0 - c * c).max(0.0).sqrt();
                    let dir = [s * phi.cos(), c, s * phi.sin()];
                    let d32 = Vec3::new(dir[0] as f32, dir[1] as f32, dir[2] as f32);
                    let blocked = match &cutouts {
                        Some(s) => s.first_opaque_hit(&bvh, origin, d32, t_min, f32::INFINITY, t_min).is_some(),
                        None => bvh.closest_hit(origin, d32, t_min, f32::INFINITY).is_some(),
                    };
                    if blocked {
                        let _ = eval_sh_f64(order, dir, &mut y);
                        for (gi, yi) in g.iter_mut().zip(&y[..nc]) {
                            *gi += yi;
                        }
                    }
                }
            }
            let w = 4.0 * std::f64::consts::PI / k_total;
            let mut v = [0.0f64; MAX_COEFFS];
            v[0] = spherebake_runtime::shadow::SQRT_4PI;
            for k in 0..nc {
                v[k] -= w * g[k];
            }
            shade(t_vec, &v[..nc])
        })
        .collect();
    let truth_seconds = start.elapsed().as_secs_f64();

    // Proxy.
    let start = Instant::now();
    let leaves: &[Sphere] = proxy.spheres();
    let (h, source) = match (a.hierarchy, proxy.hierarchy()) {
        (HierarchyArg::None, _) => (None, "none"),
        (_, Some(h)) => (Some(h.clone()), "file"),
        (HierarchyArg::Build, None) => {
            let l: Vec<[f32; 4]> =
                proxy.spheres().iter().map(|s| [s.center[0], s.center[1], s.center[2], s.radius]).collect();
            let settings = spherebake_fit::hierarchy::HierarchySettings::default();
            (Some(spherebake_fit::hierarchy::build_hierarchy(&l, &settings)?), "built")
        }
        (HierarchyArg::File, None) => (None, "none"),
    };
    let hierarchy_nodes = h.as_ref().map_or(0, |h| h.nodes.len());
    let plan = h.as_ref().map(HierarchyPlan::new).transpose()?;
    let nodes = h.as_ref().map(rest_node_spheres);
    let hierarchy = match (&plan, &nodes) {
        (Some(p), Some(n)) => Some((p, n.as_slice())),
        _ => None,
    };
    let tiles = res.div_ceil(a.cluster);
    let theta_max = a.theta_max_deg.to_radians();
    let per_tile: Vec<TileResult> = (0..tiles * tiles)
        .into_par_iter()
        .map_init(ClusterBlockers::new, |cb, t| {
            let (ti, tj) = (t % tiles, t / tiles);
            let (i0, j0) = (ti * a.cluster, tj * a.cluster);
            let (i1, j1) = ((i0 + a.cluster).min(res), (j0 + a.cluster).min(res));
            let (a0, a1) = (receiver(i0, j0), receiver(i1 - 1, j1 - 1));
            let centre = [0.5 * (a0[0] + a1[0]), y0, 0.5 * (a0[2] + a1[2])];
            let half = [0.5 * (a1[0] - a0[0]), 0.5 * (a1[2] - a0[2])];
            let radius = (half[0] * half[0] + half[1] * half[1]).sqrt() * (1.0 + 1e-6);
            cb.build(order, leaves, hierarchy, centre, radius, theta_max)?;
            if !a.no_overlap_correction {
                cb.correct_overlap(&ctx, centre, normal, 1024)?;
            }
            let mut out = Vec::with_capacity((i1 - i0) * (j1 - j0));
            for j in j0..j1 {
                for i in i0..i1 {
                    let v = if a.no_self_shadow_rules {
                        let mut log = [0.0f32; MAX_COEFFS];
                        accumulate_log_visibility(cb.blockers(), order, receiver(i, j), None, &mut log[..nc])?;
                        let mut g = [0.0f64; MAX_COEFFS];
                        ctx.visibility(&log[..nc], &mut g[..nc])?;
                        shade(t_vec, &g[..nc])
                    } else {
                        ctx.shade_point(cb, receiver(i, j), normal, t_vec)?
                    };
                    out.push((j * res + i, v));
                }
            }
            Ok((out, cb.blockers().len()))
        })
        .collect();
    let mut proxy_vals = vec![0.0; res * res];
    let mut blockers_total = 0usize;
    for r in per_tile {
        let (vals, nb) = r?;
        blockers_total += nb;
        for (k, v) in vals {
            proxy_vals[k] = v;
        }
    }
    let proxy_seconds = start.elapsed().as_secs_f64();

    let n = (res * res) as f64;
    let mean_truth = truth.iter().sum::<f64>() / n;
    let mean_proxy = proxy_vals.iter().sum::<f64>() / n;
    let mse = truth.iter().zip(&proxy_vals).map(|(t, p)| (p - t) * (p - t)).sum::<f64>() / n;
    let rmse = mse.sqrt();
    Ok(ShadowsResult {
        rel_rmse: rmse / mean_truth,
        rmse,
        mean_truth,
        mean_proxy,
        mean_blockers: blockers_total as f64 / (tiles * tiles) as f64,
        truth,
        proxy: proxy_vals,
        truth_seconds,
        proxy_seconds,
        hierarchy: source,
        hierarchy_nodes,
    })
}

/// linear [0, 1] → 8-bit sRGB.
fn srgb8(v: f64) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let s = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as u8
}

/// Truth | proxy | difference, each `res`² pixels (row = z, column = x), 4 px gaps. Truth and
/// proxy are scaled by the largest truth value (linear → sRGB grey); the difference is red where
/// the proxy is brighter, blue where darker, at 4× that scale.
fn write_image(path: &std::path::Path, res: usize, truth: &[f64], proxy: &[f64], read: &[PathBuf]) -> Result<()> {
    let gap = 4;
    let w = 3 * res + 2 * gap;
    let mut img = image::RgbImage::from_pixel(w as u32, res as u32, image::Rgb([255, 255, 255]));
    let vmax = truth.iter().cloned().fold(0.0f64, f64::max).max(1e-12);
    for j in 0..res {
        for i in 0..res {
            let k = j * res + i;
            let (t, p) = (truth[k] / vmax, proxy[k] / vmax);
            let gt = srgb8(t);
            let gp = srgb8(p);
            img.put_pixel(i as u32, j as u32, image::Rgb([gt, gt, gt]));
            img.put_pixel((res + gap + i) as u32, j as u32, image::Rgb([gp, gp, gp]));
            let d = (4.0 * (p - t)).clamp(-1.0, 1.0);
            let c =
                if d >= 0.0 { [255, srgb8(1.0 - d), srgb8(1.0 - d)] } else { [srgb8(1.0 + d), srgb8(1.0 + d), 255] };
            img.put_pixel((2 * (res + gap) + i) as u32, j as u32, image::Rgb(c));
        }
    }
    let format = crate::cmd_view::image_format(path)?;
    let bytes = crate::cmd_view::encode_rgb(path, format, img.as_raw(), img.width(), img.height())?;
    crate::atomic::write_atomic(path, &bytes, read)?;
    Ok(())
}
