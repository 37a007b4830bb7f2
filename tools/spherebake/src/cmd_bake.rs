//! `spherebake bake INPUT... (-o OUTPUT.sphb | --out-dir DIR)`: run the pipeline on one or many
//! assets (in parallel), skip those that are up to date, write outputs atomically, optionally
//! with Make-style depfiles, and print a summary.

use crate::config::{Config, Overrides};
use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Serialize;
use spherebake_bake::{BakeOutput, BakeSettings, Method, PoseMargin, Preset};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// Variational fit of minimal outside volume (Ren et al. 2006 §6.2)
    Variational,
    /// Baseline: k-means of surface points, bounding ball per cluster
    Kmeans,
    /// Baseline: bounding spheres of adaptive-octree leaf cubes
    Octree,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum PresetArg {
    /// Less work in the fit (fewer Lloyd iterations, no polish, fewer descent trials); higher E
    Fast,
    /// The measured default
    Default,
    /// The default fit from four seeds, keeping the lowest E (never above the default's); ~4x the fit time
    Best,
}

#[derive(Args, Debug)]
pub struct BakeArgs {
    /// Input meshes (.gltf, .glb, .obj) or directories to search for them
    #[arg(required = true, num_args = 1..)]
    pub inputs: Vec<PathBuf>,
    /// Output file for a single input (.sphb); written atomically
    #[arg(short, long, value_name = "OUTPUT.sphb")]
    pub output: Option<PathBuf>,
    /// Output directory: each input becomes <DIR>/<input stem>.sphb
    #[arg(long, value_name = "DIR")]
    pub out_dir: Option<PathBuf>,
    /// Number of spheres [default: 64, range 1..=4096]
    #[arg(long)]
    pub spheres: Option<usize>,
    /// Fitting method [default: variational]
    #[arg(long, value_enum)]
    pub method: Option<MethodArg>,
    /// How much work the variational fit spends [default: default]
    #[arg(long, value_enum)]
    pub preset: Option<PresetArg>,
    /// Find the smallest sphere count whose outside-volume ratio E is at most this (overrides --spheres) [range > 0]
    #[arg(long, value_name = "E")]
    pub max_outside_ratio: Option<f64>,
    /// Voxel cells along the longest bounding-box axis [default: 128; 96 with --preset fast; range 16..=1024]
    #[arg(long)]
    pub voxels: Option<u32>,
    /// Seed of the random start; same seed + input + settings give byte-identical files [default: 1]
    #[arg(long)]
    pub seed: Option<u64>,
    /// Average branching ratio of the sphere hierarchy [default: 4, range 2..=16]
    #[arg(long)]
    pub branching: Option<f64>,
    /// Bones kept per sphere for skinning; more than the model has keeps every bone [default: 4, range 1..=64]
    #[arg(long)]
    pub bones_per_sphere: Option<usize>,
    /// Grow radii so the model's own animations stay covered at every time, between keys too ("auto"), or not ("none") [default: none]
    #[arg(long, value_name = "none|auto")]
    pub pose_margin: Option<String>,
    /// SH order of the albedo per sphere (n² coefficients) [default: 4, range 1..=8]
    #[arg(long)]
    pub sh_order: Option<usize>,
    /// Albedo cube-map face size in texels [default: 32, range 4..=512]
    #[arg(long)]
    pub cubemap_size: Option<usize>,
    /// Write the compact encoding (sections added in format 1.1; a bake's file is 1.2): samples in 12 bytes (16-bit positions in a box per
    /// sphere, octahedral 2x16-bit normals), albedo SH as f16; about half the size. Readers of
    /// format 1.0 load such a file without samples and albedo [default: lossless]
    #[arg(long)]
    pub compact: bool,
    /// Write each sphere's albedo cube map and SH reconstruction as PNG crosses into DIR
    #[arg(long, value_name = "DIR")]
    pub debug_cubemaps: Option<PathBuf>,
    /// Per-asset settings file [default: ./spherebake.toml when present]
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Bake even when the output is up to date (same inputs, settings and tool version)
    #[arg(long)]
    pub force: bool,
    /// Also write a Make-style dependency file <OUTPUT>.d listing every file read
    #[arg(long)]
    pub depfile: bool,
    /// Assets baked at the same time (each uses every core for its own stages) [default: the
    /// number of cores, lowered so the estimated peak memory of the bakes fits in half the
    /// available memory]
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub jobs: Option<u32>,
    /// Print the result as one JSON document instead of the human summary
    #[arg(long)]
    pub json: bool,
    /// Print nothing but errors
    #[arg(short, long, conflicts_with = "verbose")]
    pub quiet: bool,
    /// Print more: one input adds the fit trace (proxy E after each stage); a batch adds each
    /// asset's stage times, fit trace and warnings under its row
    #[arg(short, long)]
    pub verbose: bool,
}

struct Job {
    input: PathBuf,
    output: PathBuf,
    settings: BakeSettings,
}

#[derive(Serialize)]
struct AssetResult {
    #[serde(serialize_with = "spherebake_bake::json_path::path")]
    input: PathBuf,
    #[serde(serialize_with = "spherebake_bake::json_path::path")]
    output: PathBuf,
    /// "baked", "up-to-date" or "failed".
    status: &'static str,
    triangles: Option<usize>,
    spheres: Option<usize>,
    outside_ratio_e: Option<f64>,
    seconds: f64,
    error: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    report: Option<spherebake_bake::BakeReport>,
}

pub fn run(a: BakeArgs) -> Result<ExitCode> {
    let jobs = match plan(&a) {
        Ok(j) => j,
        Err(Usage(msg)) => {
            eline!("spherebake: error: {msg}");
            return Ok(ExitCode::from(2));
        }
    };
    let show_progress = !a.quiet && !a.json && std::io::stdout().is_terminal();
    let multi = MultiProgress::with_draw_target(if show_progress {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::hidden()
    });
    let style = ProgressStyle::with_template("{prefix:>24} [{bar:30}] {percent:>3}%")
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ");

    let parallel = JobPlan::new(a.jobs, &jobs);
    // `parallel.jobs` worker threads take assets in order; each asset's own stages run on the
    // global rayon pool. Results are kept in input order.
    let next = std::sync::atomic::AtomicUsize::new(0);
    let slots: Vec<std::sync::Mutex<Option<AssetResult>>> = jobs.iter().map(|_| std::sync::Mutex::new(None)).collect();
    std::thread::scope(|scope| {
        for _ in 0..parallel.jobs.min(jobs.len()) {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(job) = jobs.get(i) else { break };
                let bar = multi.add(ProgressBar::new(1000));
                bar.set_style(style.clone());
                bar.set_prefix(job.input.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default());
                let r = run_job(job, &a, &bar);
                bar.finish_and_clear();
                *slots[i].lock().unwrap_or_else(|p| p.into_inner()) = Some(r);
            });
        }
    });
    let results: Vec<AssetResult> =
        slots.into_iter().filter_map(|m| m.into_inner().unwrap_or_else(|p| p.into_inner())).collect();

    let failed = results.iter().filter(|r| r.status == "failed").count();
    if failed > 0 {
        crate::output::note_failure();
    }
    if a.json {
        let doc = serde_json::json!({
            "assets": results,
            "baked": results.iter().filter(|r| r.status == "baked").count(),
            "up_to_date": results.iter().filter(|r| r.status == "up-to-date").count(),
            "failed": failed,
            "jobs": parallel.jobs,
            "jobs_reason": parallel.reason,
        });
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else if !a.quiet {
        print_summary(&results, a.verbose, &parallel);
    }
    Ok(if failed > 0 { ExitCode::from(1) } else { ExitCode::SUCCESS })
}

struct Usage(String);

fn plan(a: &BakeArgs) -> std::result::Result<Vec<Job>, Usage> {
    if a.output.is_some() && a.out_dir.is_some() {
        return Err(Usage("--output and --out-dir cannot be used together".into()));
    }
    let mut inputs = Vec::new();
    for p in &a.inputs {
        if p.is_dir() {
            let mut found = Vec::new();
            collect_meshes(p, &mut found).map_err(|e| Usage(format!("{}: {e}", p.display())))?;
            if found.is_empty() {
                return Err(Usage(format!("{}: directory holds no .gltf, .glb or .obj file", p.display())));
            }
            found.sort();
            inputs.extend(found);
        } else {
            inputs.push(p.clone());
        }
    }
    let outputs: Vec<PathBuf> = match (&a.output, &a.out_dir) {
        (Some(o), None) if inputs.len() == 1 => vec![o.clone()],
        (Some(_), None) => {
            return Err(Usage(format!(
                "--output takes exactly one input, got {}; use --out-dir for several",
                inputs.len()
            )))
        }
        (None, Some(d)) => inputs.iter().map(|i| d.join(sphb_name(i))).collect(),
        _ => return Err(Usage("give --output FILE (one input) or --out-dir DIR".into())),
    };
    let mut seen = std::collections::BTreeMap::new();
    for (i, o) in inputs.iter().zip(&outputs) {
        if let Some(prev) = seen.insert(o.clone(), i.clone()) {
            return Err(Usage(format!("{} and {} would both write {}", prev.display(), i.display(), o.display())));
        }
    }
    let config_path = match &a.config {
        Some(p) => Some(p.clone()),
        None if Path::new("spherebake.toml").is_file() => Some(PathBuf::from("spherebake.toml")),
        None => None,
    };
    let config = match &config_path {
        Some(p) => Config::load(p).map_err(|e| Usage(format!("{e:#}")))?,
        None => Config::default(),
    };
    let cli = Overrides {
        spheres: a.spheres,
        method: a.method.map(|m| format!("{m:?}").to_lowercase()),
        preset: a.preset.map(|p| format!("{p:?}").to_lowercase()),
        max_outside_ratio: a.max_outside_ratio,
        voxels: a.voxels,
        seed: a.seed,
        sh_order: a.sh_order,
        cubemap_size: a.cubemap_size,
        branching: a.branching,
        bones_per_sphere: a.bones_per_sphere,
        pose_margin: a.pose_margin.clone(),
        compact: a.compact.then_some(true),
    };
    let n_inputs = inputs.len();
    inputs
        .into_iter()
        .zip(outputs)
        .map(|(input, output)| {
            let o = config.for_input(&input).merged(&cli);
            let mut settings = to_settings(&o).map_err(|m| {
                // A value the command line alone does not make bad came from the configuration
                // file: name it, since the message names the setting by its flag.
                match config_path.as_ref().filter(|_| to_settings(&cli).is_ok()) {
                    Some(cfg) => Usage(format!("{}: {m} (set in {})", input.display(), cfg.display())),
                    None => Usage(format!("{}: {m}", input.display())),
                }
            })?;
            // Several assets: one sub-directory per asset.
            settings.debug_cubemaps =
                a.debug_cubemaps.as_ref().map(|d| if n_inputs > 1 { d.join(stem(&input)) } else { d.clone() });
            Ok(Job { input, output, settings })
        })
        .collect()
}

fn to_settings(o: &Overrides) -> std::result::Result<BakeSettings, String> {
    let d = BakeSettings::default();
    let method = match o.method.as_deref() {
        None => d.method,
        Some("variational") => Method::Variational,
        Some("kmeans") => Method::Kmeans,
        Some("octree") => Method::Octree,
        Some(m) => return Err(format!("unknown method {m:?} (variational, kmeans, octree)")),
    };
    let preset = match o.preset.as_deref() {
        None => d.preset,
        Some("fast") => Preset::Fast,
        Some("default") => Preset::Default,
        Some("best") => Preset::Best,
        Some(p) => return Err(format!("unknown preset {p:?} (fast, default, best)")),
    };
    let s = BakeSettings {
        spheres: o.spheres.unwrap_or(d.spheres),
        method,
        preset,
        max_outside_ratio: o.max_outside_ratio.or(d.max_outside_ratio),
        voxels: o.voxels.unwrap_or(preset.voxels()),
        seed: o.seed.unwrap_or(d.seed),
        sh_order: o.sh_order.unwrap_or(d.sh_order),
        cubemap_size: o.cubemap_size.unwrap_or(d.cubemap_size),
        branching: o.branching.unwrap_or(d.branching),
        bones_per_sphere: o.bones_per_sphere.unwrap_or(d.bones_per_sphere),
        pose_margin: match o.pose_margin.as_deref() {
            None => d.pose_margin,
            Some("none") => PoseMargin::None,
            Some("auto") => PoseMargin::Auto,
            Some(m) => return Err(format!("unknown --pose-margin {m:?} (none, auto)")),
        },
        compact: o.compact.unwrap_or(d.compact),
        debug_cubemaps: None,
    };
    s.validate()?;
    Ok(s)
}

/// The model files under `dir`, recursively. Symbolic links to directories are not followed (as
/// `find` without `-L`): a link back up the tree would otherwise make the walk endless; a linked
/// model file is taken.
fn collect_meshes(dir: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
    for e in std::fs::read_dir(dir)? {
        let e = e?;
        let p = e.path();
        if e.file_type()?.is_dir() {
            collect_meshes(&p, out)?;
        } else if crate::cmd_inspect::is_mesh(&p) && !p.is_dir() {
            out.push(p);
        }
    }
    Ok(())
}

/// The input's file stem as the OS gives it (a name that is not UTF-8 keeps its bytes: two such
/// names do not collapse into one U+FFFD name), or `out`.
fn stem(p: &Path) -> std::ffi::OsString {
    p.file_stem().map_or_else(|| "out".into(), std::ffi::OsStr::to_os_string)
}

/// `<stem of p>.sphb`.
fn sphb_name(p: &Path) -> std::ffi::OsString {
    let mut name = stem(p);
    name.push(".sphb");
    name
}

fn run_job(job: &Job, a: &BakeArgs, bar: &ProgressBar) -> AssetResult {
    let t0 = Instant::now();
    let mut r = AssetResult {
        input: job.input.clone(),
        output: job.output.clone(),
        status: "failed",
        triangles: None,
        spheres: None,
        outside_ratio_e: None,
        seconds: 0.0,
        error: None,
        report: None,
    };
    // Refused before the (long) bake; checked again against every file the model references.
    let early = std::slice::from_ref(&job.input);
    let refused = crate::atomic::refuse_input_as_output(&job.output, early)
        .and_then(|_| crate::atomic::refuse_input_as_output(&depfile_path(&job.output), early))
        .and_then(|_| {
            // A depfile sits beside a file: `-o /dev/null --depfile` would create `/dev/null.d`.
            match std::fs::metadata(&job.output) {
                // A directory is refused by the write anyway: say so before the bake, not after.
                Ok(m) if m.is_dir() => anyhow::bail!("{}: is a directory", job.output.display()),
                Ok(m) if a.depfile && !m.is_file() => anyhow::bail!(
                    "{}: --depfile needs a regular output file (this is a device, FIFO or directory)",
                    job.output.display()
                ),
                _ => Ok(()),
            }
        });
    if let Err(e) = refused {
        let msg = format!("{e:#}");
        eline!("spherebake: error: {msg}");
        r.error = Some(msg);
        return r;
    }
    if !a.force && spherebake_bake::is_up_to_date(&job.output, &job.input, &job.settings) {
        let mut kept = Ok(());
        if a.depfile && !depfile_path(&job.output).exists() {
            // Keep the depfile promise even when nothing is baked; a failure fails the asset.
            kept = spherebake_io::read_input_file(&job.output, spherebake_io::default_options().max_input_bytes)
                .and_then(|bytes| {
                    let missing = spherebake_bake::recorded_missing(&bytes, &job.input);
                    spherebake_bake::recorded_inputs(&bytes, &job.input).map(|inputs| (inputs, missing))
                })
                .map_or(Ok(()), |(inputs, missing)| {
                    let text = depfile_text(&job.output, &inputs, &missing);
                    let path = depfile_path(&job.output);
                    crate::atomic::write_atomic(&path, &text, &inputs)
                        .with_context(|| format!("{}: writing depfile", path.display()))
                });
        }
        if kept.is_ok() {
            // The output's content is current, but its time may be older than an input that
            // was touched or checked out again unchanged: Make and Ninja (without `restat`)
            // would then run this edge on every build. Mark it as made now, as a compiler that
            // rewrote the same bytes would; a read-only output stays as it is.
            let _ = std::fs::File::options()
                .append(true)
                .open(&job.output)
                .and_then(|f| f.set_modified(std::time::SystemTime::now()));
        }
        r.seconds = t0.elapsed().as_secs_f64();
        match kept {
            Ok(()) => r.status = "up-to-date",
            Err(e) => {
                let msg = format!("{e:#}");
                eline!("spherebake: error: {msg}");
                r.error = Some(msg);
            }
        }
        return r;
    }
    let progress = |f: f32| bar.set_position((f.clamp(0.0, 1.0) * 1000.0) as u64);
    let outcome: Result<BakeOutput> = (|| {
        let out = spherebake_bake::bake_path(&job.input, &job.settings, &progress)?;
        let inputs = &out.report.inputs;
        if a.depfile {
            // The output and its depfile succeed or fail together: a depfile that cannot be
            // written leaves no new output behind (else the next run would call it up to date).
            let text = depfile_text(&job.output, inputs, &out.report.missing);
            let dep = depfile_path(&job.output);
            crate::atomic::write_together(&[(&job.output, &out.bytes), (&dep, &text)], inputs)
                .with_context(|| format!("{}: writing its output", job.input.display()))?;
        } else {
            crate::atomic::write_atomic(&job.output, &out.bytes, inputs)
                .with_context(|| format!("{}: writing its output", job.input.display()))?;
        }
        Ok(out)
    })();
    r.seconds = t0.elapsed().as_secs_f64();
    match outcome {
        Ok(out) => {
            r.status = "baked";
            r.triangles = Some(out.report.triangles);
            r.spheres = Some(out.report.sphere_count);
            r.outside_ratio_e = out.report.outside_ratio_e;
            r.report = Some(out.report);
        }
        Err(e) => {
            let msg = format!("{e:#}");
            // Printed once, as it happens, so a long batch shows failures early; the table
            // says only "failed" (the JSON report carries it as `error`).
            eline!("spherebake: error: {msg}");
            r.error = Some(msg);
        }
    }
    r
}

fn depfile_path(output: &Path) -> PathBuf {
    let mut s = output.as_os_str().to_owned();
    s.push(".d");
    PathBuf::from(s)
}

/// Make syntax: `target: dep dep ...`, spaces and `#` escaped with a backslash, `$` doubled. The
/// path's own bytes (on Unix a name need not be UTF-8, and Make reads bytes), appended to `out`.
fn make_escape(p: &Path, out: &mut Vec<u8>) {
    #[cfg(unix)]
    let bytes = std::os::unix::ffi::OsStrExt::as_bytes(p.as_os_str()).to_vec();
    #[cfg(not(unix))]
    let bytes = p.to_string_lossy().into_owned().into_bytes();
    for b in bytes {
        match b {
            b' ' | b'#' | b'\\' => out.extend([b'\\', b]),
            b'$' => out.extend(b"$$"),
            _ => out.push(b),
        }
    }
}

/// `output: inputs... missing...`, then an empty rule per missing file (as `gcc -MP` writes for
/// headers): Make then rebuilds while the file is absent instead of stopping with "no rule to
/// make", and once it appears its time stamp counts like any input's.
fn depfile_text(output: &Path, inputs: &[PathBuf], missing: &[PathBuf]) -> Vec<u8> {
    let mut text = Vec::new();
    make_escape(output, &mut text);
    text.push(b':');
    for i in inputs.iter().chain(missing) {
        text.extend(b" \\\n  ");
        make_escape(i, &mut text);
    }
    text.push(b'\n');
    for m in missing {
        text.push(b'\n');
        make_escape(m, &mut text);
        text.extend(b":\n");
    }
    text
}

/// How many assets bake at once, and why.
struct JobPlan {
    jobs: usize,
    reason: String,
}

/// Estimated peak memory of one bake at `voxels` cells along the longest axis, of an asset whose
/// files hold `input_bytes`: the measured ~300 MB of a 1024³ cube (bit-packed solid and marks,
/// run lists), a 256 MiB margin, and [`BYTES_PER_INPUT_BYTE`] per byte of input for the mesh,
/// its point sets and decoded textures.
fn bake_memory_estimate(voxels: u32, input_bytes: u64) -> u64 {
    let cells = (voxels as u64).pow(3);
    (256 << 20) + cells / 2 + input_bytes.saturating_mul(BYTES_PER_INPUT_BYTE)
}

/// Peak memory per byte of input beyond the fixed part of [`bake_memory_estimate`]. Measured
/// at 64 spheres (peak RSS less that part, per input byte; 2026-12-03): the bunny subdivided
/// to 1.1 M triangles (43 MB OBJ) 944 MB, ≈ 16; CesiumMilkTruck (447 kB GLB, JPEG-compressed
/// textures decoded to linear f32 with mips) 203 MB (all of it within the fixed part);
/// GlassHurricaneCandleHolder (3.4 MB GLB) 262 MB. Compressed textures can expand by far more
/// than this, so the estimate bounds meshes better than texture-heavy assets.
const BYTES_PER_INPUT_BYTE: u64 = 24;

/// Bytes of the files an asset reads, as far as can be told before importing it: the file
/// itself, and for `.gltf` the buffers and images its JSON names by a relative URI in its own
/// folder (sizes only, read from the file system's metadata; data URIs are inside the JSON
/// already; a JSON larger than 64 MiB or not parsable counts as itself alone).
fn asset_bytes(input: &Path) -> u64 {
    let own = std::fs::metadata(input).map_or(0, |m| m.len());
    let is_gltf = input.extension().is_some_and(|e| e.eq_ignore_ascii_case("gltf"));
    if !is_gltf || own > 64 << 20 {
        return own;
    }
    let Some(json) = std::fs::read(input).ok().and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
    else {
        return own;
    };
    let dir = input.parent().unwrap_or(Path::new(""));
    let uris = ["buffers", "images"]
        .iter()
        .filter_map(|k| json.get(k).and_then(|v| v.as_array()))
        .flatten()
        .filter_map(|e| e.get("uri").and_then(|u| u.as_str()));
    let mut total = own;
    for uri in uris {
        let rel = Path::new(uri);
        let inside = !uri.contains(':')
            && rel.components().all(|c| matches!(c, std::path::Component::Normal(_) | std::path::Component::CurDir));
        if inside {
            total = total.saturating_add(std::fs::metadata(dir.join(rel)).map_or(0, |m| m.len()));
        }
    }
    total
}

/// Available memory (Linux `MemAvailable`), if known.
fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

impl JobPlan {
    fn new(asked: Option<u32>, jobs: &[Job]) -> JobPlan {
        if let Some(n) = asked {
            return JobPlan { jobs: n as usize, reason: "--jobs".into() };
        }
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let per =
            jobs.iter().map(|j| bake_memory_estimate(j.settings.voxels, asset_bytes(&j.input))).max().unwrap_or(0);
        JobPlan::from_budget(cores, available_memory(), per)
    }

    /// The default: one bake per core, but no more at a time than fit in half the available
    /// memory at `per` bytes each (at least one). The reason names both budgets.
    fn from_budget(cores: usize, available: Option<u64>, per: u64) -> JobPlan {
        let cores = cores.max(1);
        match available {
            Some(avail) if per > 0 => {
                let by_memory = ((avail / 2) / per).max(1) as usize;
                let budget = format!("{} MiB available, ~{} MiB per bake", avail >> 20, per >> 20);
                if by_memory < cores {
                    JobPlan { jobs: by_memory, reason: format!("{cores} cores, limited by memory: {budget}") }
                } else {
                    JobPlan { jobs: cores, reason: format!("{cores} cores, memory: {budget}") }
                }
            }
            _ => JobPlan { jobs: cores, reason: format!("{cores} cores, memory unknown") },
        }
    }
}

fn print_summary(results: &[AssetResult], verbose: bool, parallel: &JobPlan) {
    if results.len() == 1 && results[0].status == "baked" {
        if let Some(r) = &results[0].report {
            print_single(&results[0].output, r, verbose);
            return;
        }
    }
    if results.len() == 1 && results[0].status == "failed" {
        // The one-line error on stderr says it all.
        return;
    }
    let w = results.iter().map(|r| r.input.display().to_string().chars().count()).max().unwrap_or(0).max(5);
    println!(
        "{:<w$} {:>10} {:>8} {:>8} {:>9} {:>8}  status",
        "asset", "triangles", "spheres", "E", "time (s)", "warnings"
    );
    let opt = |v: Option<String>| v.unwrap_or_else(|| "-".into());
    for r in results {
        let name = r.input.display().to_string();
        println!(
            "{:<w$} {:>10} {:>8} {:>8} {:>9.3} {:>8}  {}",
            name,
            opt(r.triangles.map(|t| t.to_string())),
            opt(r.spheres.map(|t| t.to_string())),
            opt(r.outside_ratio_e.map(|e| format!("{e:.4}"))),
            r.seconds,
            opt(r.report.as_ref().map(|rep| rep.warnings.len().to_string())),
            // The cause was printed once, on stderr, as it happened.
            r.status
        );
        if verbose {
            if let Some(rep) = &r.report {
                let stages: Vec<String> = rep.timings.iter().map(|t| format!("{} {:.3}", t.stage, t.seconds)).collect();
                println!("    stages: {}", stages.join(", "));
                print_trace(&rep.fit_trace);
                for w in &rep.warnings {
                    println!("    warning: {w}");
                }
            }
        }
    }
    let n = |s: &str| results.iter().filter(|r| r.status == s).count();
    if !verbose && results.iter().any(|r| r.report.as_ref().is_some_and(|rep| !rep.warnings.is_empty())) {
        println!("(-v lists each asset's warnings)");
    }
    println!(
        "{} baked, {} up to date, {} failed ({} at a time: {})",
        n("baked"),
        n("up-to-date"),
        n("failed"),
        parallel.jobs,
        parallel.reason
    );
}

fn print_single(output: &Path, r: &spherebake_bake::BakeReport, verbose: bool) {
    let total: f64 = r.timings.iter().map(|t| t.seconds).sum();
    println!("baked {} -> {}", r.input.display(), output.display());
    println!(
        "  mesh      {} triangles, {} welded vertices, {}",
        r.triangles,
        r.vertices_welded,
        if r.closed { "closed" } else { "not closed" }
    );
    let count = match r.empty_spheres {
        0 => r.sphere_count.to_string(),
        // Not "more would only add outside volume": the descent leaves a sphere empty when no
        // split trial within its budget used it, which a larger budget may (beetle-alt at
        // `--preset fast` leaves 3 of 64 empty at E 1.033; the default uses all 64, E 0.862).
        k => format!("{} ({k} left empty by the fit: radius 0)", r.sphere_count),
    };
    match (r.outside_ratio_e, r.union_outside_ratio) {
        (Some(e), Some(u)) => {
            println!("  spheres   {count}  outside-volume ratio E = {e:.4}, union outside ratio = {u:.4}")
        }
        (Some(e), None) => println!("  spheres   {count}  outside-volume ratio E = {e:.4}"),
        _ => println!("  spheres   {count}"),
    }
    let stages: Vec<String> = r.timings.iter().map(|t| format!("{} {:.3}", t.stage, t.seconds)).collect();
    println!("  time      {total:.3} s ({})", stages.join(", "));
    let fit: Vec<String> = r.fit_stages.iter().map(|t| format!("{} {:.3}", t.stage, t.seconds)).collect();
    println!("  fit       {}", fit.join(", "));
    if verbose {
        print_trace(&r.fit_trace);
    }
    if let Some(k) = &r.skin {
        println!(
            "  skin      {} bones, {} kept per sphere (largest dropped weight {:.3}), MVC residual {:.1e} of the diagonal",
            k.bones, k.bones_per_sphere, k.dropped_weight_max, k.linear_residual_max_relative
        );
        if let Some(m) = &k.pose_margin {
            println!(
                "  margin    {} spheres grown (max {:.2e} of the diagonal) over {} frames, motion between frames ≤ {:.2e} of the diagonal{}; coverage before {:.4}; E {} -> {}",
                m.grown_count,
                m.max_growth_relative,
                m.frames,
                m.motion_bound_max_relative,
                if m.capped_animations > 0 { format!(" ({} animations at the sample cap)", m.capped_animations) } else { String::new() },
                m.coverage_min_before,
                m.outside_ratio_before.map_or("-".into(), |e| format!("{e:.4}")),
                m.outside_ratio_after.map_or("-".into(), |e| format!("{e:.4}"))
            );
        }
    }
    let h = &r.hierarchy;
    println!(
        "  hierarchy {} levels, mean branching {:.2}, parent tightness mean {:.6} max {:.6}",
        h.levels, h.mean_branching, h.tightness_mean, h.tightness_max
    );
    println!(
        "  samples   {:.1} per sphere (min {}), empty directions: rule 2 {:.1}%, rule 3 {:.1}%; area {:.4} carried, {:.4} in spheres without samples ({} points)",
        r.samples.per_sphere_mean,
        r.samples.per_sphere_min,
        100.0 * r.samples.share_rule2_empty,
        100.0 * r.samples.share_rule3_empty,
        r.samples.area_assigned,
        r.samples.area_unassigned,
        r.samples.area_points
    );
    println!("  file      {} bytes, input hash {}", r.file_bytes, r.input_hash);
    for w in &r.warnings {
        println!("  warning   {w}");
    }
}

/// `bake -v`: one line per fit stage, with the proxy E after it (exact E after `exact_e`).
fn print_trace(trace: &[spherebake_bake::FitTraceEntry]) {
    let parts = trace.iter().map(|e| e.part).max().map_or(1, |p| p + 1);
    let seeds = trace.iter().any(|e| e.seed != trace[0].seed);
    for e in trace {
        let mut name = e.stage.to_string();
        if e.round > 0 {
            name = format!("{name} {}", e.round);
        }
        let mut who =
            if parts > 1 { format!("part {} k {}", e.part + 1, e.spheres) } else { format!("k {}", e.spheres) };
        if seeds {
            who = format!("{who} seed {}", e.seed);
        }
        let e_txt = e.e.map_or_else(|| "-".to_string(), |x| format!("{x:.4}"));
        println!("  trace     {who:<8} {name:<15} E {e_txt:>7}  {:>7.3} s  {}", e.seconds, trace_work(e));
    }
}

/// What a `bake -v` trace line says after its time: the work of a stage (points, iterations,
/// trials, voxel rows), or in words which start ran and which result was kept, where the
/// trace's counters encode a choice (`spherebake_fit::TraceEntry`).
fn trace_work(e: &spherebake_bake::FitTraceEntry) -> String {
    let kept = if e.iterations == 1 { "kept" } else { "not kept" };
    let said = trace_choice(e, kept);
    // 0 seconds: a run a later restart of `best` took from the first (`FitTraceEntry::seconds`).
    if e.seconds == 0.0 && !said.is_empty() {
        format!("{said} (reused)")
    } else if e.seconds == 0.0 {
        "(reused)".to_string()
    } else {
        said
    }
}

fn trace_choice(e: &spherebake_bake::FitTraceEntry, kept: &str) -> String {
    match e.stage {
        // At one sphere the enclosing ball is the whole fit (no other run to keep it against).
        "enclosing_ball" if e.spheres == 1 => "the fit (one sphere: the minimal enclosing ball)".to_string(),
        "lattice_start" => match e.iterations {
            0 => "not run (Lloyd's start is as low)".to_string(),
            1 => "ran instead of Lloyd's start".to_string(),
            _ => "ran beside Lloyd's start (a near tie)".to_string(),
        },
        "split_start" => {
            let cuts = if e.trials == 1 { "cuts along principal axes too" } else { "cuts along x, y, z" };
            format!("{cuts}, {}", if e.iterations == 1 { "ran" } else { "not run" })
        }
        "start_kept" | "enclosing_ball" => kept.to_string(),
        "polish" if e.iterations == 0 => "none (a lattice start, or a plan without polish)".to_string(),
        _ => {
            let mut work = Vec::new();
            if e.points > 0 {
                work.push(format!("{} points", e.points));
            }
            if e.iterations > 0 {
                work.push(format!("{} iterations", e.iterations));
            }
            if e.trials > 0 {
                work.push(format!("{} trials", e.trials));
            }
            if e.work > 0 {
                work.push(format!("work {:.1}M", e.work as f64 * 1e-6));
            }
            work.join(", ")
        }
    }
}

#[cfg(test)]
mod job_tests {
    use super::*;

    #[test]
    fn the_trace_names_the_starts_choices_in_words() {
        let entry = |stage: &'static str, iterations: usize, trials: usize| spherebake_bake::FitTraceEntry {
            part: 0,
            spheres: 16,
            seed: 1,
            stage,
            round: 0,
            e: Some(0.5),
            points: 0,
            iterations,
            trials,
            work: 0,
            seconds: 0.01,
        };
        // Written out, one per encoded choice.
        let cases = [
            (entry("lattice_start", 0, 0), "not run (Lloyd's start is as low)"),
            (entry("lattice_start", 1, 0), "ran instead of Lloyd's start"),
            (entry("lattice_start", 2, 0), "ran beside Lloyd's start (a near tie)"),
            (entry("split_start", 0, 0), "cuts along x, y, z, not run"),
            (entry("split_start", 1, 1), "cuts along principal axes too, ran"),
            (entry("start_kept", 1, 0), "kept"),
            (entry("enclosing_ball", 0, 0), "not kept"),
            (
                spherebake_bake::FitTraceEntry { points: 4000, work: 2_500_000, ..entry("descent", 3, 12) },
                "4000 points, 3 iterations, 12 trials, work 2.5M",
            ),
            (entry("bound", 0, 0), ""),
            (
                spherebake_bake::FitTraceEntry { spheres: 1, ..entry("enclosing_ball", 0, 0) },
                "the fit (one sphere: the minimal enclosing ball)",
            ),
            (entry("polish", 0, 0), "none (a lattice start, or a plan without polish)"),
            (entry("polish", 4, 0), "4 iterations"),
            // Reused by a later restart: 0 seconds.
            (
                spherebake_bake::FitTraceEntry { seconds: 0.0, ..entry("split_start", 1, 0) },
                "cuts along x, y, z, ran (reused)",
            ),
            (spherebake_bake::FitTraceEntry { seconds: 0.0, ..entry("bound", 0, 0) }, "(reused)"),
        ];
        for (e, want) in cases {
            assert_eq!(trace_work(&e), want, "{} {} {}", e.stage, e.iterations, e.trials);
        }
    }

    #[test]
    fn the_default_is_one_bake_per_core_within_half_the_memory() {
        const MIB: u64 = 1 << 20;
        // 8 cores, 4 GiB free, 768 MiB per bake (--voxels 1024): 2048 / 768 = 2 at a time.
        let p = JobPlan::from_budget(8, Some(4096 * MIB), bake_memory_estimate(1024, 0));
        assert_eq!(bake_memory_estimate(1024, 0), 768 * MIB);
        assert_eq!(p.jobs, 2);
        assert_eq!(p.reason, "8 cores, limited by memory: 4096 MiB available, ~768 MiB per bake");
        // Plenty of memory: the cores decide.
        let p = JobPlan::from_budget(2, Some(64 * 1024 * MIB), bake_memory_estimate(128, 0));
        assert_eq!(p.jobs, 2);
        assert!(p.reason.starts_with("2 cores, memory: 65536 MiB available"), "{}", p.reason);
        // Less than one bake's worth: still one.
        assert_eq!(JobPlan::from_budget(4, Some(100 * MIB), 768 * MIB).jobs, 1);
        assert_eq!(JobPlan::from_budget(3, None, 768 * MIB).reason, "3 cores, memory unknown");
    }

    #[test]
    fn the_estimate_grows_with_the_asset_and_counts_a_gltf_s_own_files_only() {
        const MIB: u64 = 1 << 20;
        // The 1.1 M-triangle bunny (43 MB OBJ) peaked at 944 MB: the estimate must not be below.
        assert!(bake_memory_estimate(128, 43_341_290) >= 944 * MIB);
        // Twice the input, more memory; a large mesh lowers the number of bakes at a time.
        assert!(bake_memory_estimate(128, 2 * MIB) < bake_memory_estimate(128, 4 * MIB));
        let p = JobPlan::from_budget(8, Some(4096 * MIB), bake_memory_estimate(128, 43 * MIB));
        assert!(p.jobs <= 2, "{}", p.reason);

        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().join("asset");
        std::fs::create_dir(&d).unwrap();
        std::fs::write(d.join("mesh.bin"), vec![0u8; 1000]).unwrap();
        std::fs::write(d.join("albedo.png"), vec![0u8; 300]).unwrap();
        // Outside the asset's folder, an absolute path and a data URI: not counted.
        std::fs::write(dir.path().join("outside.bin"), vec![0u8; 5000]).unwrap();
        let abs = dir.path().join("outside.bin");
        let json = format!(
            r#"{{"buffers":[{{"uri":"mesh.bin"}},{{"uri":"../outside.bin"}},{{"uri":{abs:?}}},{{"uri":"data:application/octet-stream;base64,AAAA"}},{{"byteLength":4}}],
               "images":[{{"uri":"./albedo.png"}},{{"uri":"missing.png"}}]}}"#
        );
        std::fs::write(d.join("a.gltf"), &json).unwrap();
        assert_eq!(asset_bytes(&d.join("a.gltf")), json.len() as u64 + 1000 + 300);
        // Not JSON: the file alone. An OBJ: the file alone. Missing: 0.
        std::fs::write(d.join("b.gltf"), "not json").unwrap();
        assert_eq!(asset_bytes(&d.join("b.gltf")), 8);
        assert_eq!(asset_bytes(&d.join("mesh.bin")), 1000);
        assert_eq!(asset_bytes(&d.join("none.obj")), 0);
    }
}
