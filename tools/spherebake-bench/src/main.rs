//! Benchmark of the sphere-set fit (issue 4): quality, speed and scale tables in Markdown.
//!
//! `cargo run --release -p spherebake-bench -- [--runs N] [--out FILE] quality|speed|scale|all`
//!
//! Every bake runs through the whole pipeline (`spherebake_bake::bake_path`) in a child process
//! (this binary re-executed with the hidden `child` subcommand), so that each row's peak memory
//! (the child's `VmHWM`) is its own. Wall times are the median of `--runs` bakes.

mod meshops;

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use meshops::TriMesh;
use serde_json::{json, Value};
use spherebake_bake::{bake_path, BakeSettings, Method};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicI32, Ordering};
use std::time::Instant;

#[derive(Parser)]
#[command(about = "Benchmark of the sphere-set fit: prints Markdown tables")]
struct Cli {
    /// Bakes per row; the wall time is their median
    #[arg(long, default_value_t = 5, global = true)]
    runs: usize,
    /// Also write the Markdown to this file
    #[arg(long, global = true)]
    out: Option<PathBuf>,
    /// The shared models directory [default: ../shared/models beside the repository]
    #[arg(long, global = true)]
    models: Option<PathBuf>,
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// E and union outside ratio per model, method and sphere count
    Quality {
        /// Sphere counts
        #[arg(long, value_delimiter = ',', default_values_t = [16, 32, 64, 128, 256])]
        spheres: Vec<usize>,
        /// Methods [default: all three]
        #[arg(long, value_delimiter = ',')]
        methods: Vec<MethodArg>,
        /// Only models whose path contains one of these strings
        #[arg(long, value_delimiter = ',')]
        only: Vec<String>,
    },
    /// Bunny bake time per stage, and its growth with triangle and sphere count
    Speed,
    /// A ~1M-triangle mesh (the bunny subdivided twice) at 64 spheres
    Scale {
        /// Midpoint subdivisions of the bunny (each ×4 triangles)
        #[arg(long, default_value_t = 2)]
        subdivisions: u32,
    },
    /// Quality, speed and scale
    All,
    /// One bake, printed as one JSON line (used by the other subcommands)
    #[command(hide = true)]
    Child {
        model: PathBuf,
        spheres: usize,
        method: MethodArg,
        /// Also run `spherebake_fit::evaluate` (after the peak memory is read)
        #[arg(long)]
        eval: bool,
        /// Print progress to stderr
        #[arg(long)]
        progress: bool,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum MethodArg {
    Variational,
    Kmeans,
    Octree,
}

impl MethodArg {
    const ALL: [MethodArg; 3] = [MethodArg::Variational, MethodArg::Kmeans, MethodArg::Octree];
    fn name(self) -> &'static str {
        match self {
            MethodArg::Variational => "variational",
            MethodArg::Kmeans => "kmeans",
            MethodArg::Octree => "octree",
        }
    }
    fn method(self) -> Method {
        match self {
            MethodArg::Variational => Method::Variational,
            MethodArg::Kmeans => Method::Kmeans,
            MethodArg::Octree => Method::Octree,
        }
    }
}

/// The closed models of `../shared/models` (and the open bunny, baked as is), relative paths.
const MODELS: [&str; 10] = [
    "gltf/CesiumMan.glb",
    "gltf/Fox.glb",
    "gltf/RiggedFigure.glb",
    "gltf/RiggedSimple.glb",
    "gltf/Duck.glb",
    "gltf/BoxTextured.glb",
    "gltf/BoxVertexColors.glb",
    "obj/armadillo.obj",
    "obj/spot/spot.obj",
    "obj/stanford-bunny.obj",
];
const BUNNY: &str = "obj/stanford-bunny.obj";

fn main() -> Result<()> {
    let cli = Cli::parse();
    if let Cmd::Child { model, spheres, method, eval, progress } = &cli.cmd {
        return child(model, *spheres, *method, *eval, *progress);
    }
    if cli.runs == 0 {
        bail!("--runs must be at least 1");
    }
    let models =
        cli.models.clone().unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/models"));
    if !models.join(BUNNY).is_file() {
        bail!("{}: shared models not found (use --models DIR)", models.display());
    }
    let mut md = String::new();
    let load_before = load_average();
    let started = Instant::now();
    match &cli.cmd {
        Cmd::Quality { spheres, methods, only } => quality(&mut md, &models, spheres, methods, only, cli.runs)?,
        Cmd::Speed => speed(&mut md, &models, cli.runs)?,
        Cmd::Scale { subdivisions } => scale(&mut md, &models, *subdivisions, cli.runs)?,
        Cmd::All => {
            quality(&mut md, &models, &[16, 32, 64, 128, 256], &[], &[], cli.runs)?;
            speed(&mut md, &models, cli.runs)?;
            scale(&mut md, &models, 2, cli.runs)?;
        }
        Cmd::Child { .. } => unreachable!("handled above"),
    }
    let header = machine_header(&load_before, &load_average(), started.elapsed().as_secs_f64(), cli.runs);
    let doc = format!("{header}\n{md}");
    print!("{doc}");
    if let Some(out) = &cli.out {
        std::fs::write(out, &doc).with_context(|| format!("writing {}", out.display()))?;
    }
    Ok(())
}

/// The child: one whole bake, its wall time and peak memory, printed as one JSON line.
fn child(model: &Path, spheres: usize, method: MethodArg, eval: bool, progress: bool) -> Result<()> {
    let settings = BakeSettings { spheres, method: method.method(), ..Default::default() };
    let shown = AtomicI32::new(-1);
    let report_progress = |f: f32| {
        let pct = (f.clamp(0.0, 1.0) * 100.0) as i32;
        if progress && shown.fetch_max(pct, Ordering::Relaxed) < pct {
            eprint!("\r  bake {pct:3}%");
        }
    };
    let t0 = Instant::now();
    let out = bake_path(model, &settings, &report_progress)?;
    let wall_s = t0.elapsed().as_secs_f64();
    let peak_kib = vm_hwm_kib()?;
    let cpu_s = cpu_seconds()?;
    if progress {
        eprintln!("\r  bake 100% in {wall_s:.1} s");
    }
    let r = &out.report;
    let stages = |v: &[spherebake_bake::StageTime]| v.iter().map(|s| json!([s.stage, s.seconds])).collect::<Vec<_>>();
    let mut doc = json!({
        "wall_s": wall_s,
        "peak_kib": peak_kib,
        "cpu_s": cpu_s,
        "triangles": r.triangles,
        "spheres": r.sphere_count,
        "closed": r.closed,
        "e": r.outside_ratio_e,
        "union": r.union_outside_ratio,
        "timings": stages(&r.timings),
        "fit_stages": stages(&r.fit_stages),
    });
    if eval {
        let imported = spherebake_io::load_mesh(model)?;
        let mesh = &imported.mesh;
        let spheres: Vec<[f32; 4]> =
            out.file.spheres.iter().map(|s| [s.center[0], s.center[1], s.center[2], s.radius]).collect();
        let ev = spherebake_bake::evaluate_mesh(mesh, &spheres, &spherebake_fit::EvalSettings::default())?;
        doc["eval"] = json!({
            "e": ev.outside_ratio_e,
            "coverage": ev.surface_coverage,
            "samples": spherebake_fit::EvalSettings::default().surface_samples,
            "max_gap_relative": ev.max_gap_relative,
        });
    }
    println!("{doc}");
    Ok(())
}

/// Peak resident set size of this process (`VmHWM` of /proc/self/status), KiB.
fn vm_hwm_kib() -> Result<u64> {
    let status = std::fs::read_to_string("/proc/self/status").context("reading /proc/self/status")?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:")).context("no VmHWM in /proc/self/status")?;
    line.split_whitespace().nth(1).and_then(|v| v.parse().ok()).context("unreadable VmHWM")
}

/// CPU time (user + system, all threads) of this process so far, seconds (`/proc/self/stat`,
/// in clock ticks of 1/100 s, the Linux USER_HZ).
fn cpu_seconds() -> Result<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").context("reading /proc/self/stat")?;
    // Fields after the parenthesised command name: state is field 3, utime 14, stime 15.
    let rest = stat.rsplit_once(')').map(|(_, r)| r).context("unreadable /proc/self/stat")?;
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let tick = |i: usize| fields.get(i).and_then(|v| v.parse::<f64>().ok()).context("unreadable /proc/self/stat");
    Ok((tick(11)? + tick(12)?) / 100.0)
}

/// One row: `runs` bakes of the same input in child processes.
struct Row {
    walls: Vec<f64>,
    peak_kib: u64,
    /// The JSON of the run whose wall time is the median.
    median_run: Value,
    /// Every run's JSON (for per-stage medians).
    all: Vec<Value>,
}

impl Row {
    fn wall(&self) -> f64 {
        median(&self.walls)
    }
    /// Median CPU seconds (user + system) of the bakes.
    fn cpu(&self) -> f64 {
        median(&self.all.iter().map(|d| d["cpu_s"].as_f64().unwrap_or(f64::NAN)).collect::<Vec<_>>())
    }
    fn peak_mib(&self) -> f64 {
        self.peak_kib as f64 / 1024.0
    }
    fn num(&self, key: &str) -> Option<f64> {
        self.median_run.get(key).and_then(Value::as_f64)
    }
    /// Median over runs of one stage's seconds (`list` is "timings" or "fit_stages").
    fn stage_medians(&self, list: &str) -> Vec<(String, f64)> {
        let mut order = Vec::new();
        let mut by_stage: BTreeMap<String, Vec<f64>> = BTreeMap::new();
        for run in &self.all {
            for s in run[list].as_array().into_iter().flatten() {
                let name = s[0].as_str().unwrap_or("?").to_string();
                if !by_stage.contains_key(&name) {
                    order.push(name.clone());
                }
                by_stage.entry(name).or_default().push(s[1].as_f64().unwrap_or(0.0));
            }
        }
        order.into_iter().map(|n| (n.clone(), median(&by_stage[&n]))).collect()
    }
}

fn run_row(model: &Path, spheres: usize, method: MethodArg, runs: usize, eval: bool, progress: bool) -> Result<Row> {
    let exe = std::env::current_exe().context("locating this executable")?;
    let mut all = Vec::new();
    for run in 0..runs {
        let mut cmd = Command::new(&exe);
        cmd.arg("child").arg(model).arg(spheres.to_string()).arg(method.name());
        if eval && run == 0 {
            cmd.arg("--eval");
        }
        if progress {
            cmd.arg("--progress");
        }
        let out = cmd.stderr(if progress { Stdio::inherit() } else { Stdio::piped() }).output()?;
        if !out.status.success() {
            bail!(
                "bake of {} ({} spheres, {}) failed: {}",
                model.display(),
                spheres,
                method.name(),
                String::from_utf8_lossy(&out.stderr).trim()
            );
        }
        let line = String::from_utf8_lossy(&out.stdout);
        let doc: Value = serde_json::from_str(line.lines().last().unwrap_or_default())
            .with_context(|| format!("child output of {}: {line}", model.display()))?;
        all.push(doc);
    }
    let walls: Vec<f64> = all.iter().map(|d| d["wall_s"].as_f64().unwrap_or(f64::NAN)).collect();
    let mut order: Vec<usize> = (0..all.len()).collect();
    order.sort_by(|&a, &b| walls[a].total_cmp(&walls[b]));
    let mut median_run = all[order[order.len() / 2]].clone();
    if let Some(ev) = all[0].get("eval") {
        median_run["eval"] = ev.clone();
    }
    let peak_kib = all.iter().filter_map(|d| d["peak_kib"].as_u64()).max().unwrap_or(0);
    Ok(Row { walls, peak_kib, median_run, all })
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or("–".into(), |x| format!("{x:.digits$}"))
}

fn quality(
    md: &mut String,
    models: &Path,
    counts: &[usize],
    methods: &[MethodArg],
    only: &[String],
    runs: usize,
) -> Result<()> {
    let methods = if methods.is_empty() { &MethodArg::ALL[..] } else { methods };
    let list: Vec<&str> =
        MODELS.iter().copied().filter(|m| only.is_empty() || only.iter().any(|o| m.contains(o))).collect();
    writeln!(md, "## Sphere-set fit (issue 4): quality\n")?;
    writeln!(
        md,
        "E = Σ V(S_i − T) / V(T) (Ren et al. 2006 eq. 35) and the union's outside ratio V(∪S − T) / V(T), as \
         `bake_path` reports them; wall time of the whole bake (median of {runs}), its CPU time (user + system, \
         all threads), peak memory of the baking process. Coverage: share of 1,000,000 random surface points inside the union (`spherebake_fit::evaluate`, \
         run at 64 spheres).\n"
    )?;
    writeln!(md, "| model | tris | method | spheres | E | union | bake s | cpu s | peak MiB | coverage |")?;
    writeln!(md, "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|")?;
    let mut summary: BTreeMap<(usize, usize), Vec<String>> = BTreeMap::new();
    for (mi, model) in list.iter().enumerate() {
        for (hi, &method) in methods.iter().enumerate() {
            for &k in counts {
                eprintln!("quality: {model} {} {k}", method.name());
                let row = run_row(&models.join(model), k, method, runs, k == 64, false)?;
                let coverage = row.median_run.get("eval").map(|ev| {
                    format!(
                        "{:.6} (gap {:.1e})",
                        ev["coverage"].as_f64().unwrap_or(f64::NAN),
                        ev["max_gap_relative"].as_f64().unwrap_or(f64::NAN)
                    )
                });
                writeln!(
                    md,
                    "| {model} | {} | {} | {k} | {} | {} | {:.2} | {:.2} | {:.0} | {} |",
                    row.median_run["triangles"],
                    method.name(),
                    opt(row.num("e"), 3),
                    opt(row.num("union"), 3),
                    row.wall(),
                    row.cpu(),
                    row.peak_mib(),
                    coverage.unwrap_or_else(|| "–".into())
                )?;
                summary.entry((mi, hi)).or_default().push(opt(row.num("e"), 3));
            }
        }
    }
    writeln!(md, "\nE by sphere count:\n")?;
    let heads: Vec<String> = counts.iter().map(|k| k.to_string()).collect();
    writeln!(md, "| model | method | {} |", heads.join(" | "))?;
    writeln!(md, "|---|---|{}", "---:|".repeat(counts.len()))?;
    for ((mi, hi), es) in &summary {
        writeln!(md, "| {} | {} | {} |", list[*mi], methods[*hi].name(), es.join(" | "))?;
    }
    writeln!(md)?;
    Ok(())
}

/// The bunny as an indexed mesh (welded positions, used vertices only as the importer welds them).
fn load_bunny(models: &Path) -> Result<TriMesh> {
    let imported = spherebake_io::load_mesh(&models.join(BUNNY))?;
    Ok(TriMesh { positions: imported.mesh.welded_positions.clone(), triangles: imported.mesh.welded_triangles() })
}

/// A scratch directory for generated OBJ files, removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new() -> Result<Self> {
        let dir = std::env::temp_dir().join(format!("spherebake-bench-{}", std::process::id()));
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        Ok(Self(dir))
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn speed(md: &mut String, models: &Path, runs: usize) -> Result<()> {
    let bunny = models.join(BUNNY);
    writeln!(md, "## Sphere-set fit (issue 4): speed\n")?;
    eprintln!("speed: bunny 64 spheres");
    let row = run_row(&bunny, 64, MethodArg::Variational, runs, false, false)?;
    let mut walls = row.walls.clone();
    walls.sort_by(f64::total_cmp);
    writeln!(
        md,
        "Whole `bake` of the bunny ({} triangles), variational, 64 spheres: median **{:.2} s** of {runs} \
         (min {:.2}, max {:.2}), CPU time {:.2} s (median), peak {:.0} MiB, E = {}.\n",
        row.median_run["triangles"],
        row.wall(),
        walls[0],
        walls[walls.len() - 1],
        row.cpu(),
        row.peak_mib(),
        opt(row.num("e"), 3)
    )?;
    writeln!(md, "| stage | median s | share of bake |")?;
    writeln!(md, "|---|---:|---:|")?;
    let total = row.wall();
    for (list, prefix) in [("timings", ""), ("fit_stages", "fit › ")] {
        for (stage, s) in row.stage_medians(list) {
            writeln!(md, "| {prefix}{stage} | {s:.3} | {:.1}% |", 100.0 * s / total)?;
        }
    }
    writeln!(md, "\nThe `fit ›` rows are the fitter's own timers (`FitStats::timings`); they may nest.")?;

    let scratch = Scratch::new()?;
    let mesh = load_bunny(models)?;
    let small = meshops::decimate_to(&mesh, mesh.triangles.len() / 4);
    let big = meshops::subdivide(&mesh);
    let small_path = scratch.0.join("bunny-decimated.obj");
    let big_path = scratch.0.join("bunny-subdivided.obj");
    meshops::write_obj(&small, &small_path)?;
    meshops::write_obj(&big, &big_path)?;
    writeln!(md, "\nGrowth with triangle count (variational, 64 spheres; vertex-clustering decimation and midpoint subdivision of the bunny):\n")?;
    writeln!(md, "| mesh | tris | bake s (median) | cpu s | fit s | E | peak MiB |")?;
    writeln!(md, "|---|---:|---:|---:|---:|---:|---:|")?;
    for (name, path) in [("bunny decimated", &small_path), ("bunny", &bunny), ("bunny subdivided ×1", &big_path)] {
        eprintln!("speed: {name}");
        let r =
            if path == &bunny { None } else { Some(run_row(path, 64, MethodArg::Variational, runs, false, false)?) };
        let r = r.as_ref().unwrap_or(&row);
        let fit = r.stage_medians("timings").into_iter().find(|(s, _)| s == "fit").map(|(_, s)| s);
        writeln!(
            md,
            "| {name} | {} | {:.2} | {:.2} | {} | {} | {:.0} |",
            r.median_run["triangles"],
            r.wall(),
            r.cpu(),
            opt(fit, 2),
            opt(r.num("e"), 3),
            r.peak_mib()
        )?;
    }
    writeln!(md, "\nGrowth with sphere count (bunny, variational):\n")?;
    writeln!(md, "| spheres | bake s (median) | cpu s | fit s | E | peak MiB |")?;
    writeln!(md, "|---:|---:|---:|---:|---:|---:|")?;
    for k in [16, 64, 256] {
        eprintln!("speed: bunny {k} spheres");
        let r = if k == 64 { None } else { Some(run_row(&bunny, k, MethodArg::Variational, runs, false, false)?) };
        let r = r.as_ref().unwrap_or(&row);
        let fit = r.stage_medians("timings").into_iter().find(|(s, _)| s == "fit").map(|(_, s)| s);
        writeln!(
            md,
            "| {k} | {:.2} | {:.2} | {} | {} | {:.0} |",
            r.wall(),
            r.cpu(),
            opt(fit, 2),
            opt(r.num("e"), 3),
            r.peak_mib()
        )?;
    }
    writeln!(md)?;
    Ok(())
}

fn scale(md: &mut String, models: &Path, subdivisions: u32, runs: usize) -> Result<()> {
    let scratch = Scratch::new()?;
    let mut mesh = load_bunny(models)?;
    for _ in 0..subdivisions {
        mesh = meshops::subdivide(&mesh);
    }
    let path = scratch.0.join("bunny-scale.obj");
    eprintln!("scale: writing {} triangles to {}", mesh.triangles.len(), path.display());
    meshops::write_obj(&mesh, &path)?;
    drop(mesh);
    let row = run_row(&path, 64, MethodArg::Variational, runs, false, true)?;
    writeln!(md, "## Sphere-set fit (issue 4): scale\n")?;
    writeln!(
        md,
        "The bunny subdivided {subdivisions}× (midpoint 1→4), written as a temporary OBJ and baked through \
         `bake_path`, variational, 64 spheres (median of {runs}).\n"
    )?;
    writeln!(md, "| tris | bake s | target | cpu s | peak MiB | target | E |")?;
    writeln!(md, "|---:|---:|---|---:|---:|---|---:|")?;
    let (wall, peak) = (row.wall(), row.peak_mib());
    writeln!(
        md,
        "| {} | {wall:.1} | ≤ 60 s: {} | {:.1} | {peak:.0} | ≤ 4096 MiB: {} | {} |",
        row.median_run["triangles"],
        if wall <= 60.0 { "met" } else { "not met" },
        row.cpu(),
        if peak <= 4096.0 { "met" } else { "not met" },
        opt(row.num("e"), 3)
    )?;
    writeln!(md, "\n| stage | median s |")?;
    writeln!(md, "|---|---:|")?;
    for (list, prefix) in [("timings", ""), ("fit_stages", "fit › ")] {
        for (stage, s) in row.stage_medians(list) {
            writeln!(md, "| {prefix}{stage} | {s:.2} |")?;
        }
    }
    writeln!(md)?;
    Ok(())
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "?".into())
}

fn command_output(program: &str, args: &[&str]) -> String {
    Command::new(program)
        .args(args)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "?".into())
}

fn machine_header(load_before: &str, load_after: &str, seconds: f64, runs: usize) -> String {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let cpu = cpuinfo
        .lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split(':').nth(1))
        .map_or("?".to_string(), |s| s.trim().to_string());
    let meminfo = std::fs::read_to_string("/proc/meminfo").unwrap_or_default();
    let mem_gib = meminfo
        .lines()
        .find(|l| l.starts_with("MemTotal:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse::<f64>().ok())
        .map_or("?".to_string(), |kib| format!("{:.1} GiB", kib / 1024.0 / 1024.0));
    let nproc = std::thread::available_parallelism().map_or(0, |n| n.get());
    let threads = std::env::var("RAYON_NUM_THREADS").unwrap_or_else(|_| format!("{nproc} (rayon default)"));
    // Outside a git checkout (e.g. a `git archive` of a commit) the commit comes from the environment.
    let mut commit = command_output("git", &["rev-parse", "--short", "HEAD"]);
    let mut dirty = "";
    if commit == "?" {
        commit = std::env::var("SPHEREBAKE_BENCH_COMMIT").unwrap_or(commit);
    } else if !matches!(command_output("git", &["status", "--porcelain", "--untracked-files=no"]).as_str(), "" | "?") {
        dirty = " (with uncommitted changes)";
    }
    format!(
        "<!-- spherebake-bench output -->\n\
         - date: {}\n- commit: {commit}{dirty}\n- machine: {nproc} CPUs ({cpu}), {mem_gib}\n- threads: {threads}\n\
         - runs per row: {runs}\n- load average (1, 5, 15 min) before: {load_before}; after: {load_after}\n\
         - total bench time: {seconds:.0} s\n",
        command_output("date", &["-u", "+%Y-%m-%d %H:%M UTC"]),
    )
}
