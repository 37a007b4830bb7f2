//! Usage: `cargo run --release -p spherebake-fit --example fit_bench -- MODEL.obj [counts] [methods] [runs]`
//! e.g. `... -- bunny.obj 16,32,64,128,256 variational,kmeans,octree 3`.
//! Prints E (exact), the union outside ratio, and wall time (median of `runs`) per stage.
//! Environment overrides: SB_POINTS, SB_VOXEL, SB_ITERS, SB_POLISH, SB_SEED, SB_STARTS,
//! SB_BOTH_THINNINGS (true|false), SB_TRIALS, SB_SEAMS, SB_TELE, SB_SUBDIV,
//! SB_SEAM_TRIALS, SB_BUDGET, SB_SEAM_BUDGET, SB_DGRID (descent_grid_cells), SB_DBLOCK (descent_block), SB_SEAM_SPACING,
//! SB_PCELL, SB_PBUDGET, SB_START_TIE, SB_SPLIT_TIE, SB_SPLIT_OBLIQUE (true|false), SB_BAND_SWEEPS, SB_BAND_WIDTH, SB_PAIR_CUT, SB_GAP_ROUNDS, SB_SWEEPS
//! (descent_sweeps), SB_POWELL (powell_sweeps), SB_PA / SB_PB / SB_PSTOP (search_first_share /
//! search_first_cells / search_stop_cells); SB_PRESET=fast|default|best starts from that plan
//! and its voxel grid (`Preset::voxels`).

#[path = "common/obj.rs"]
mod obj;

use obj::load_obj;
use spherebake_fit::{fit, FitSettings, Method, Preset};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).expect("usage: fit_bench MODEL.obj [counts] [methods] [runs]");
    let counts: Vec<usize> =
        args.get(2).map(|s| s.split(',').map(|x| x.parse().unwrap()).collect()).unwrap_or(vec![16, 32, 64, 128, 256]);
    let methods: Vec<String> = args.get(3).map(|s| s.split(',').map(|x| x.to_string()).collect()).unwrap_or(vec![
        "variational".into(),
        "kmeans".into(),
        "octree".into(),
    ]);
    let runs: usize = args.get(4).map(|s| s.parse().unwrap()).unwrap_or(1);
    let (mut p, mut t) = load_obj(path);
    // SB_SUBDIV=n: n rounds of 4-way midpoint subdivision (shared edge midpoints), e.g. the
    // bunny at n = 2 has 1.1M triangles (the scale target).
    let rounds = std::env::var("SB_SUBDIV").ok().and_then(|v| v.parse::<usize>().ok()).unwrap_or(0);
    for _ in 0..rounds {
        let mut mid: std::collections::HashMap<(u32, u32), u32> = std::collections::HashMap::new();
        let mut nt = Vec::with_capacity(t.len() * 4);
        for tri in &t {
            let mut m = [0u32; 3];
            for e in 0..3 {
                let (a, b) = (tri[e], tri[(e + 1) % 3]);
                let key = (a.min(b), a.max(b));
                m[e] = *mid.entry(key).or_insert_with(|| {
                    p.push((p[a as usize] + p[b as usize]) * 0.5);
                    (p.len() - 1) as u32
                });
            }
            nt.push([tri[0], m[0], m[2]]);
            nt.push([m[0], tri[1], m[1]]);
            nt.push([m[2], m[1], tri[2]]);
            nt.push([m[0], m[1], m[2]]);
        }
        t = nt;
    }
    println!("{path}: {} vertices, {} triangles, {} threads", p.len(), t.len(), rayon::current_num_threads());
    println!("method       k  spheres        E   union    proxyE   iters  wall_s  stages");
    for m in &methods {
        let method = match m.as_str() {
            "variational" => Method::Variational,
            "kmeans" => Method::Kmeans,
            "octree" => Method::Octree,
            other => panic!("unknown method {other}"),
        };
        for &k in &counts {
            let preset = std::env::var("SB_PRESET").ok().and_then(|v| Preset::from_name(&v)).unwrap_or_default();
            // The preset's plan and voxel grid, as `spherebake bake --preset` takes them.
            let mut settings = FitSettings {
                method,
                spheres: k,
                plan: preset.plan(),
                voxel_resolution: preset.voxels(),
                ..Default::default()
            };
            // `set!(field, "SB_NAME")`: the field from the environment when set and parseable.
            macro_rules! set {
                ($($field:ident).+, $name:literal) => {
                    if let Some(v) = std::env::var($name).ok().and_then(|v| v.parse().ok()) {
                        settings.$($field).+ = v;
                    }
                };
            }
            set!(plan.point_resolution, "SB_POINTS");
            set!(voxel_resolution, "SB_VOXEL");
            set!(plan.max_iterations, "SB_ITERS");
            set!(plan.polish_rounds, "SB_POLISH");
            set!(plan.descent_trials, "SB_TRIALS");
            set!(plan.seam_rounds, "SB_SEAMS");
            set!(plan.teleport_attempts, "SB_TELE");
            set!(plan.seam_trials, "SB_SEAM_TRIALS");
            set!(plan.descent_work_budget, "SB_BUDGET");
            set!(plan.seam_work_budget, "SB_SEAM_BUDGET");
            set!(plan.descent_grid_cells, "SB_DGRID");
            set!(plan.descent_block, "SB_DBLOCK");
            set!(plan.seam_spacing_cells, "SB_SEAM_SPACING");
            set!(plan.point_cell, "SB_PCELL");
            set!(plan.point_budget, "SB_PBUDGET");
            set!(plan.starts, "SB_STARTS");
            set!(plan.both_thinnings, "SB_BOTH_THINNINGS");
            set!(plan.band_sweeps, "SB_BAND_SWEEPS");
            set!(plan.band_width_cells, "SB_BAND_WIDTH");
            set!(plan.start_tie, "SB_START_TIE");
            set!(plan.split_start_tie, "SB_SPLIT_TIE");
            set!(plan.split_start_oblique, "SB_SPLIT_OBLIQUE");
            set!(plan.pair_first_cut, "SB_PAIR_CUT");
            set!(plan.gap_rounds, "SB_GAP_ROUNDS");
            set!(plan.descent_sweeps, "SB_SWEEPS");
            set!(plan.powell_sweeps, "SB_POWELL");
            set!(plan.search_first_share, "SB_PA");
            set!(plan.search_first_cells, "SB_PB");
            set!(plan.search_stop_cells, "SB_PSTOP");
            set!(seed, "SB_SEED");
            let mut times = Vec::new();
            let mut last = None;
            for _ in 0..runs {
                let t0 = Instant::now();
                let r = fit(&p, &t, &settings, &|_| {}).expect("fit");
                times.push(t0.elapsed().as_secs_f64());
                last = Some(r);
            }
            times.sort_by(f64::total_cmp);
            let r = last.unwrap();
            let s = &r.stats;
            let stages: Vec<String> = s.timings.iter().map(|(n, t)| format!("{n}={t:.3}")).collect();
            println!(
                "{m:<11} {k:>4} {:>6} {:>9.4} {:>7.4} {:>9.4} {:>6} {:>7.3}  {}  {:?}",
                s.sphere_count,
                s.outside_ratio_e,
                s.union_outside_ratio,
                s.proxy_e,
                s.iterations,
                times[times.len() / 2],
                stages.join(" "),
                s.bound
            );
        }
    }
}
