//! The fit's plan presets and its per-stage trace: the stages run in the documented order,
//! the descent never raises the proxy E where it starts from a covering, the presets do the
//! work they document and still bound, target mode keeps every run's trace and times.

use glam::{DVec3, Vec3};
use spherebake_fit::{fit, FitPlan, FitResult, FitSettings, TraceEntry};

#[path = "../examples/common/obj.rs"]
mod obj;

/// A closed, outward-oriented UV sphere of radius 1 (poles single vertices), `n` rings.
fn uv_sphere(n: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (p, t) = spherebake_testkit::mesh::uv_sphere(n, 1.0);
    (p.into_iter().map(|q| DVec3::from(q).as_vec3()).collect(), t)
}

/// Two UV spheres (radii 1 and 0.7, a gap of 0.1 between them), so the
/// fit has seams and trials to do; one part (their boxes touch), a closed mesh.
fn dumbbell() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (p, t) = uv_sphere(12);
    let mut pos: Vec<Vec3> = p.iter().map(|q| *q - Vec3::X * 0.9).collect();
    let mut tris = t.clone();
    let base = pos.len() as u32;
    pos.extend(p.iter().map(|q| *q * 0.7 + Vec3::X * 0.9));
    tris.extend(t.iter().map(|x| x.map(|v| v + base)));
    (pos, tris)
}

fn stages(r: &FitResult) -> Vec<&'static str> {
    r.stats.trace.iter().map(|e| e.stage).collect()
}

fn covered(p: &[Vec3], r: &FitResult) -> bool {
    p.iter().all(|q| {
        r.spheres.iter().any(|s| {
            let c = glam::DVec3::new(f64::from(s[0]), f64::from(s[1]), f64::from(s[2]));
            q.as_dvec3().distance(c) <= f64::from(s[3])
        })
    })
}

#[test]
fn the_trace_lists_each_stage_once_in_order() {
    let (p, t) = dumbbell();
    let s = FitSettings { spheres: 12, voxel_resolution: 48, ..FitSettings::default() };
    let r = fit(&p, &t, &s, &|_| {}).expect("fits");
    let all = stages(&r);
    // dense_points, lloyd, lattice_start, polish, descent_points, descent, 0..=5 seam rounds
    // numbered 1, 2, ..., band, at most one gap round numbered 1, bound, exact_e (Lloyd's run);
    // split_start, and when it ran (iterations 1) its own descent_points ... exact_e; then
    // enclosing_ball: written out, not derived from the code's list.
    let split_at = all.iter().position(|s| *s == "split_start").expect("the split start is traced");
    let got = &all[..split_at];
    assert_eq!(&got[..6], ["dense_points", "lloyd", "lattice_start", "polish", "descent_points", "descent"], "{all:?}");
    assert_eq!(&got[got.len() - 2..], ["bound", "exact_e"], "{all:?}");
    let gaps = usize::from(got[got.len() - 3] == "gap");
    assert_eq!(got[got.len() - 3 - gaps], "band", "{all:?}");
    if gaps == 1 {
        let g = &r.stats.trace[got.len() - 3];
        assert!(g.round == 1 && g.points > 0 && g.trials == 0, "{g:?}");
    }
    let seams: Vec<&TraceEntry> = r.stats.trace[6..got.len() - 3 - gaps].iter().collect();
    assert!(seams.len() <= 5, "{all:?}");
    for (i, e) in seams.iter().enumerate() {
        assert_eq!((e.stage, e.round), ("seam", i + 1));
    }
    // One or two split starts (trials 0: along x, y and z; 1: with the principal axes), each
    // followed by its own run when it ran, then the enclosing ball.
    let mut at = split_at;
    let mut variants = Vec::new();
    while all[at] == "split_start" {
        let e = &r.stats.trace[at];
        variants.push(e.trials);
        at += 1;
        if e.iterations == 1 {
            assert_eq!(&all[at..at + 2], ["descent_points", "descent"], "{all:?}");
            let end = at + all[at..].iter().position(|s| *s == "exact_e").expect("the run's exact E");
            assert_eq!(all[end - 1], "bound", "{all:?}");
            at = end + 1;
        } else {
            assert_eq!(e.iterations, 0, "{e:?}");
        }
    }
    assert!(variants == [0] || variants == [0, 1], "{variants:?} in {all:?}");
    assert_eq!(at, all.len() - 1, "{all:?}");
    assert_eq!(all.last(), Some(&"enclosing_ball"), "{all:?}");
    for e in &r.stats.trace {
        assert_eq!((e.part, e.spheres), (0, 12));
        assert!(e.seconds >= 0.0 && e.seconds.is_finite());
        // Point stages have no spheres to measure; every other stage has a finite E.
        let point_stage = e.stage.ends_with("_points");
        assert_eq!(e.e.is_none(), point_stage, "{e:?}");
        if point_stage {
            assert!(e.points > 0, "{e:?}");
        } else {
            let x = e.e.expect("E");
            assert!(x.is_finite() && x >= 0.0, "{e:?}");
        }
    }
    // The lowest `exact_e` is the exact E of the result (one part); the enclosing ball after
    // it, one sphere around two spheres' worth of dumbbell, is worse and not kept.
    let exact = r.stats.trace.iter().filter(|e| e.stage == "exact_e").filter_map(|e| e.e).fold(f64::INFINITY, f64::min);
    assert!((exact - r.stats.outside_ratio_e).abs() <= 1e-12 * r.stats.outside_ratio_e);
    let ball = r.stats.trace.last().expect("entries");
    assert!(ball.e.expect("E") > r.stats.outside_ratio_e && ball.iterations == 0, "{ball:?}");
    // Lloyd ran at least one iteration, the descent at least one sweep.
    assert!(r.stats.trace[1].iterations >= 1 && r.stats.trace[5].iterations >= 1);
    // A dumbbell is no box: the descent starts from the polish, not from the octree.
    assert_eq!((r.stats.trace[2].iterations, r.stats.trace[3].iterations), (0, s.plan.polish_rounds));
    // Every stage's time is in the stage timings too.
    for st in [
        "dense_points",
        "lloyd",
        "lattice_start",
        "polish",
        "descent_points",
        "descent",
        "band",
        "bound",
        "exact_e",
        "split_start",
        "enclosing_ball",
    ] {
        assert!(r.stats.timings.iter().any(|(n, _)| *n == st), "{st} missing from {:?}", r.stats.timings);
    }
}

#[test]
fn the_descent_does_not_raise_e_when_the_polish_already_covers_its_points() {
    // A fine UV sphere on a coarse grid: every edge (≤ 0.1) is shorter than two voxel cells
    // (2 × 2 / 32 = 0.125), so the descent's points are the vertices and interior lattice
    // points, all of which the polish's last round bounds. From a covering the descent's
    // sweeps and kept trials only lower the proxy E (up to the 1e-12 widening of covering).
    let (p, t) = uv_sphere(48);
    let longest = t
        .iter()
        .flat_map(|x| [(x[0], x[1]), (x[1], x[2]), (x[2], x[0])])
        .map(|(a, b)| p[a as usize].distance(p[b as usize]))
        .fold(0.0f32, f32::max);
    assert!(longest < 0.125, "{longest}");
    // A sphere is a round part: without the bar out of reach its enclosing ball would end the
    // fit after Lloyd (`FitPlan::ball_bar`).
    let plan = FitPlan { ball_bar: f64::INFINITY, ..FitPlan::default() };
    let s = FitSettings { spheres: 10, voxel_resolution: 32, plan, ..FitSettings::default() };
    let r = fit(&p, &t, &s, &|_| {}).expect("fits");
    let e = |stage: &str| r.stats.trace.iter().find(|x| x.stage == stage).and_then(|x| x.e).expect(stage);
    let (polish, descent) = (e("polish"), e("descent"));
    assert!(descent <= polish * (1.0 + 1e-9), "descent E {descent} > polish E {polish}");
    // And the trials did something measurable (else the check above is only the sweeps').
    let d = r.stats.trace.iter().find(|x| x.stage == "descent").expect("descent");
    assert!(d.iterations >= 1, "{d:?}");
}

#[test]
fn presets_do_the_work_they_document_and_all_bound() {
    let (p, t) = dumbbell();
    let run = |plan: FitPlan| {
        let s = FitSettings { spheres: 16, voxel_resolution: 48, plan, ..FitSettings::default() };
        fit(&p, &t, &s, &|_| {}).expect("fits")
    };
    let (fast, default, best) = (run(FitPlan::fast()), run(FitPlan::default()), run(FitPlan::best()));
    // Work counted in the trace: Lloyd iterations + descent and seam trials, and descent work.
    let count = |r: &FitResult| -> (usize, usize, u64) {
        let tr = &r.stats.trace;
        let iters: usize = tr.iter().filter(|e| matches!(e.stage, "lloyd" | "polish")).map(|e| e.iterations).sum();
        let trials: usize = tr.iter().filter(|e| matches!(e.stage, "descent" | "seam")).map(|e| e.trials).sum();
        let work: u64 = tr.iter().map(|e| e.work).sum();
        (iters, trials, work)
    };
    let (f, d, b) = (count(&fast), count(&default), count(&best));
    // Fast's Lloyd follows the default's from the same start but stops sooner (12 iterations,
    // one teleportation at most) and it has no polish rounds: fewer iterations in all.
    assert!(f.0 < d.0, "fast Lloyd + polish iterations {} vs default {}", f.0, d.0);
    let lloyd = |r: &FitResult| r.stats.trace.iter().find(|e| e.stage == "lloyd").map_or(0, |e| e.iterations);
    assert!(lloyd(&fast) <= 12 && lloyd(&fast) <= lloyd(&default));
    // Fast stays within its documented trial caps: 16 rounds in the first descent, 4 in its
    // one seam round, and at most two trials per round (how many the default tries depends on
    // its own trajectory).
    assert!(f.1 <= 2 * (16 + 4), "fast trials {f:?}");
    // Best runs the default's plan from four seeds, the first the fit's own, and keeps the
    // lowest exact E: four runs in the trace, the first one the default's run exactly.
    let ends: Vec<&TraceEntry> = best.stats.trace.iter().filter(|e| e.stage == "exact_e").collect();
    assert_eq!(ends.len(), 4);
    assert_eq!(ends[0].seed, 1);
    assert!(ends.iter().skip(1).all(|e| e.seed != 1));
    assert_eq!(ends[0].e, Some(default.stats.outside_ratio_e), "best's first run is the default's");
    let lowest = ends.iter().filter_map(|e| e.e).fold(f64::INFINITY, f64::min);
    assert_eq!(best.stats.outside_ratio_e, lowest);
    assert!(best.stats.outside_ratio_e <= default.stats.outside_ratio_e);
    assert!(b.0 > d.0 && b.1 >= d.1 && b.2 >= d.2, "best does more work: {b:?} vs {d:?}");
    // Fast runs no polish round (so builds no dense points) and one seam round.
    assert!(fast.stats.trace.iter().any(|e| e.stage == "polish" && e.iterations == 0));
    assert!(fast.stats.trace.iter().any(|e| e.stage == "dense_points" && e.points == 0));
    let seams: Vec<usize> = fast.stats.trace.iter().filter(|e| e.stage == "seam").map(|e| e.round).collect();
    assert_eq!(seams, [1], "fast's seam rounds");
    // Each preset bounds: every vertex inside a stored sphere.
    for (name, r) in [("fast", &fast), ("default", &default), ("best", &best)] {
        assert!(covered(&p, r), "{name}: a vertex is outside every sphere");
        assert_eq!(r.spheres.len(), 16, "{name}");
    }
    // And the fast plan gives another sphere set (the plan reaches the fit).
    assert_ne!(fast.spheres, default.spheres);
}

#[test]
fn target_mode_keeps_every_runs_trace_and_times() {
    let (p, t) = uv_sphere(16);
    // (The descent must run on this round part: the ball's bar out of reach.)
    let plan = FitPlan { descent_trials: 8, seam_rounds: 1, ball_bar: f64::INFINITY, ..FitPlan::default() };
    let target = 0.05;
    let s = FitSettings { max_outside_ratio: Some(target), voxel_resolution: 32, plan, ..FitSettings::default() };
    let r = fit(&p, &t, &s, &|_| {}).expect("fits");
    // The first exact_e of each count tried (a count's split starts add their own): 8
    // spheres give E ≈ 0.096 on this ball, so the search tries more counts (whether it
    // reaches 0.05 on this coarse ball does not matter here).
    let mut runs: Vec<&TraceEntry> = r.stats.trace.iter().filter(|e| e.stage == "exact_e").collect();
    runs.dedup_by_key(|e| e.spheres);
    assert!(runs.len() >= 2, "{:?}", stages(&r));
    assert_eq!(runs[0].spheres, 8);
    assert!(runs[0].e.expect("E") > target, "{:?}", runs[0]);
    // Every count starts with its dense points and runs every stage.
    let starts = r.stats.trace.iter().filter(|e| e.stage == "dense_points").count();
    assert_eq!(starts, runs.len());
    // The stage times of every run are reported (not only the kept run's): each fit stage
    // appears with a positive time.
    for st in ["points", "lloyd", "polish", "descent", "bound", "exact_e"] {
        let secs = r.stats.timings.iter().find(|(n, _)| *n == st).map(|x| x.1);
        assert!(secs.is_some_and(|x| x > 0.0), "{st}: {:?}", r.stats.timings);
    }
    assert!(
        r.stats.outside_ratio_e <= target || r.warnings.iter().any(|w| w.contains("not reached")),
        "{} {:?}",
        r.stats.outside_ratio_e,
        r.warnings
    );
    assert!(covered(&p, &r));
}

/// The descent point set's size for a fit, from its trace.
fn descent_points(r: &FitResult) -> usize {
    r.stats
        .trace
        .iter()
        .find(|e| e.stage == "descent_points")
        .unwrap_or_else(|| panic!("descent points traced: {:?}", stages(r)))
        .points
}

#[test]
fn a_mesh_finer_than_the_grid_is_thinned_to_it_and_still_bound() {
    // 256 rings: about 130 000 vertices, some 40 per voxel cell of the sphere's surface at
    // resolution 32.
    let (p, t) = uv_sphere(256);
    // The default cube (one voxel cell) with a budget this mesh exceeds (the default budget,
    // 400 000 points, is for meshes of a million triangles; the cost is what is tested).
    // (The descent must run on this round part: the ball's bar out of reach.)
    let plan = FitPlan { point_budget: 100_000, ball_bar: f64::INFINITY, ..FitPlan::default() };
    assert_eq!(plan.point_cell, 1.0, "the default this test measures");
    let s = FitSettings { spheres: 8, voxel_resolution: 32, plan, ..FitSettings::default() };
    let thin = fit(&p, &t, &s, &|_| {}).expect("fits");
    let all = FitSettings { plan: FitPlan { point_cell: 0.0, ..s.plan.clone() }, ..s.clone() };
    let full = fit(&p, &t, &all, &|_| {}).expect("fits");
    let (n_thin, n_full) = (descent_points(&thin), descent_points(&full));
    // Without thinning every vertex is a descent point.
    assert!(n_full >= p.len(), "{n_full} descent points for {} vertices", p.len());
    // Voxel-cell cubes (edge at least 1/16: 32 cells over a box 2 wide) that a unit sphere's
    // surface meets: at most its shell of half-width √3·c over c³, 4π·2√3/c² ≈ 11 100 for
    // c = 1/16, plus the interior lattice (the point resolution 40 over a width of 2: at most
    // (4/3)π·20³ ≈ 33 500).
    eprintln!(
        "descent points: {n_thin} thinned, {n_full} all; E {} / {}",
        thin.stats.outside_ratio_e, full.stats.outside_ratio_e
    );
    let c = 1.0 / 16.0;
    let bound = 4.0 * std::f64::consts::PI * 2.0 * 3f64.sqrt() / (c * c) + 4.0 / 3.0 * std::f64::consts::PI * 8000.0;
    assert!((n_thin as f64) <= bound && 2 * n_thin < n_full, "thinned {n_thin} (bound {bound:.0}), all {n_full}");
    assert!(covered(&p, &thin), "every vertex bound after thinning");
    let (e_thin, e_full) = (thin.stats.outside_ratio_e, full.stats.outside_ratio_e);
    assert!(e_thin <= 1.1 * e_full, "E thinned {e_thin} vs all points {e_full}");
}

#[test]
fn a_point_set_within_the_budget_is_not_thinned() {
    // 96 rings: 18 200 vertices, 36 500 triangles.
    let (p, t) = uv_sphere(96);
    // (The descent must run on this round part: the ball's bar out of reach.)
    let plan = FitPlan { ball_bar: f64::INFINITY, ..FitPlan::default() };
    let s = FitSettings { spheres: 8, voxel_resolution: 32, plan, ..FitSettings::default() };
    let all = FitSettings { plan: FitPlan { point_cell: 0.0, ..s.plan.clone() }, ..s.clone() };
    let (a, b) = (fit(&p, &t, &s, &|_| {}).expect("fits"), fit(&p, &t, &all, &|_| {}).expect("fits"));
    let dense = |r: &FitResult| r.stats.trace.iter().find(|e| e.stage == "dense_points").expect("traced").points;
    assert!(
        dense(&b) < s.plan.point_budget && descent_points(&b) < s.plan.point_budget,
        "{} {}",
        dense(&b),
        descent_points(&b)
    );
    // Thinned to voxel-cell cubes, this mesh's sets would lose points (some 18 200 vertices
    // on about 3 200 cubes of the surface).
    assert_eq!((dense(&a), descent_points(&a)), (dense(&b), descent_points(&b)));
    assert_eq!(a.spheres, b.spheres);
}

#[test]
fn the_band_stage_and_the_gap_round_narrow_what_the_bounding_pass_adds_on_the_bunny() {
    // The bunny at 64 spheres, the default plan without the gap round, with and without the
    // band stage (the same run up to the seam rounds). Without the band the last seam round's
    // moves leave gaps between descent points that the bounding pass closes by growing whole
    // spheres; measured (seed 1, this loader): the bound added 0.0071 to E without the band
    // and 0.0051 with it, and exact E fell 0.2383 → 0.2367 (seeds 2–4: 0.2424 → 0.2398,
    // 0.2497 → 0.2471, 0.2437 → 0.2391). The default's gap round then covers the points the
    // band's spheres miss and re-fits the pairs around them: E lower again (measured below).
    let Some(path) = spherebake_testkit::shared_model("obj/stanford-bunny.obj") else { return };
    let (p, t) = obj::load_obj(path.to_str().expect("UTF-8 path"));
    let run = |band_sweeps: usize, gap_rounds: usize| {
        let plan = FitPlan { band_sweeps, gap_rounds, ..FitPlan::default() };
        fit(&p, &t, &FitSettings { plan, ..FitSettings::default() }, &|_| {}).expect("fits")
    };
    let (gap, with, without) =
        (run(FitPlan::default().band_sweeps, FitPlan::default().gap_rounds), run(8, 0), run(0, 0));
    // What the bounding pass added: exact E minus the proxy E of the stage before it.
    let added = |r: &FitResult, before: &str| {
        let tr = &r.stats.trace;
        let i = tr.iter().position(|e| e.stage == "bound").expect("bound");
        assert_eq!(tr[i - 1].stage, before);
        r.stats.outside_ratio_e - tr[i - 1].e.expect("E")
    };
    let (a_with, a_without) = (added(&with, "band"), added(&without, "seam"));
    assert!(a_with < 0.85 * a_without, "bound added {a_with:.4} after the band, {a_without:.4} without");
    let (e_with, e_without) = (with.stats.outside_ratio_e, without.stats.outside_ratio_e);
    assert!(e_with < e_without, "E {e_with:.4} with the band, {e_without:.4} without");
    assert!(e_with <= 0.2367 * 1.01, "E {e_with:.4}");
    // The band stage added points and swept; it ran no trial.
    let b = with.stats.trace.iter().find(|e| e.stage == "band").expect("band traced");
    assert!(b.points > 0 && b.iterations >= 1 && b.trials == 0, "{b:?}");
    // The gap round: after the band, points found and no sweep or trial of its own; the
    // bound adds no more after it (within 0.0002 of E) and E ends lower (measured: the
    // bound added 0.0044 after the gap round, 0.0047 after the band alone; E 0.22585
    // against 0.22606 without the round;
    // with the trial budgets before they were doubled: 0.0046 / 0.0055, E 0.2283 / 0.2301).
    // Since the pattern search polls only its predicted moves, seed 1 gives 0.0046 / 0.0045,
    // E 0.2277 / 0.2279: the bound's share is level, and E still falls on every seed 1–4
    // (fit alone, mean 0.2237 → 0.2231; 0.2280 with neither the band nor the gap round).
    // Since the descent and seam points lay rows on slivers (the bunny's base has some), seed 1
    // gives E 0.2313 with the gap round and 0.2319 without (whole bakes, seeds 1–4: mean
    // 0.2226 → 0.2218). Since the descent reads blocks of two cells (`FitPlan::descent_block`),
    // 0.2325 and 0.2341 (whole bakes, seeds 1–4: mean 0.2218 → 0.2212). Since the band is a
    // quarter of a cell wide, not one (`FitPlan::band_width_cells`), 0.2339 and 0.2347.
    const GAP_E: f64 = 0.2339;
    let g = gap.stats.trace.iter().find(|e| e.stage == "gap").expect("gap traced");
    assert!(g.round == 1 && g.points > 0 && g.iterations == 0 && g.trials == 0, "{g:?}");
    let a_gap = added(&gap, "gap");
    assert!(a_gap < a_with + 2e-4, "bound added {a_gap:.4} after the gap round, {a_with:.4} after the band");
    let e_gap = gap.stats.outside_ratio_e;
    assert!(e_gap < e_with && e_gap <= GAP_E * 1.001, "E {e_gap:.4} with the gap round, {e_with:.4} without");
    // Every vertex a triangle uses is inside a stored sphere (the bunny has 1113 unused ones).
    let used: Vec<Vec3> = t.iter().flatten().map(|&i| p[i as usize]).collect();
    assert!(covered(&used, &with) && covered(&used, &gap));
}

#[test]
fn a_near_tie_of_the_starts_runs_from_both_and_keeps_the_lower_exact_e() {
    // On a box the lattice start and Lloyd's come within a few per cent of each other (issue
    // 16: the proxies before the descent do not tell which ends lower). Then both runs are in
    // the trace (Lloyd's `exact_e`, the lattice's `exact_e` and `start_kept`) and the fit
    // returns the lowest; with `start_tie` 0 only the start of lower proxy E runs. The unit
    // cube at 16 spheres ends lower from Lloyd's start (measured 0.8113 against the lattice's
    // 0.8353, its start made bounding 0.8455), at 20 from the lattice's (0.6631 against
    // Lloyd's 0.7710). (Before the cover start's two thinnings, the cases were the unit cube
    // at 16 and the 3 × 1 × 1 box at 12; before the boundary moves, the unit cube at 12 and
    // 20: each change of the local search moves which start ends lower at a given count.)
    let (p, t) = spherebake_testkit::mesh::unit_cube();
    let mut lattice_won = Vec::new();
    for (sx, k) in [(1.0f32, 16), (1.0, 20)] {
        let p: Vec<Vec3> = p.iter().map(|q| Vec3::new(q[0] as f32 * sx, q[1] as f32, q[2] as f32)).collect();
        let run = |start_tie| {
            let plan = FitPlan { start_tie, ..FitPlan::default() };
            fit(&p, &t, &FitSettings { spheres: k, plan, ..FitSettings::default() }, &|_| {}).expect("fits")
        };
        let (both, one) = (run(0.05), run(0.0));
        let tr = &both.stats.trace;
        let ls = tr.iter().find(|e| e.stage == "lattice_start").expect("traced");
        assert_eq!(ls.iterations, 2, "box {sx}: the starts should tie: {:?}", stages(&both));
        let e_of = |stage: &str| -> Vec<f64> { tr.iter().filter(|e| e.stage == stage).filter_map(|e| e.e).collect() };
        let (ends, kept) = (e_of("exact_e"), e_of("start_kept"));
        assert_eq!((ends.len(), kept.len()), (2, 1), "box {sx}: {:?}", stages(&both));
        let (from_lloyd, from_lattice) = (ends[0], ends[1].min(kept[0]));
        let e = both.stats.outside_ratio_e;
        assert!(
            (e - from_lloyd.min(from_lattice)).abs() <= 1e-9 * e,
            "box {sx}: E {e}, Lloyd's run {from_lloyd}, the lattice's {from_lattice}"
        );
        assert!(
            e <= one.stats.outside_ratio_e + 1e-12,
            "box {sx}: both starts {e}, one start {}",
            one.stats.outside_ratio_e
        );
        assert!(covered(&p, &both), "box {sx}: a vertex is outside every sphere");
        lattice_won.push(from_lattice < from_lloyd);
    }
    // One case of each: a fit that always kept one side fails one of them.
    assert_eq!(lattice_won, [false, true]);
}

/// A round part: Lloyd's proxy E is several times its enclosing ball's exact E, so the stages
/// after Lloyd are skipped (`FitPlan::ball_bar`) and the ball is returned. With the bar out of
/// reach every stage runs, and the ball is still returned: the skipped stages could not have
/// beaten it (the fit's own end is above twice the ball's E either way).
#[test]
fn a_round_part_skips_the_stages_its_enclosing_ball_beats() {
    let (p, t) = uv_sphere(24);
    let run = |ball_bar: f64| {
        let plan = FitPlan { ball_bar, ..FitPlan::default() };
        fit(&p, &t, &FitSettings { spheres: 32, voxel_resolution: 64, plan, ..FitSettings::default() }, &|_| {})
            .expect("fits")
    };
    let (skipped, full) = (run(2.0), run(f64::INFINITY));
    let has = |r: &FitResult, st: &str| stages(r).contains(&st);
    assert!(!has(&skipped, "descent") && !has(&skipped, "polish"), "{:?}", stages(&skipped));
    assert!(has(&full, "descent") && has(&full, "seam"), "{:?}", stages(&full));
    let e_of = |r: &FitResult, st: &str| {
        r.stats.trace.iter().filter(|e| e.stage == st).filter_map(|e| e.e).collect::<Vec<f64>>()
    };
    let ball = e_of(&full, "enclosing_ball")[0];
    for r in [&skipped, &full] {
        assert_eq!(r.stats.outside_ratio_e.to_bits(), ball.to_bits(), "the ball is returned");
        assert!(
            e_of(r, "exact_e").iter().all(|&e| e > 2.0 * ball),
            "{:?} against the ball's {ball}",
            e_of(r, "exact_e")
        );
    }
}

/// Closed ellipsoids (UV spheres of 24 rings, scaled): a thick one of semi-axes 1, 0.55, 0.35
/// and a disc of semi-axes 1, 1, 0.06.
fn ellipsoid_and_disc() -> [(Vec<Vec3>, Vec<[u32; 3]>); 2] {
    let (p, t) = uv_sphere(24);
    let scaled = |s: Vec3| (p.iter().map(|q| *q * s).collect(), t.clone());
    [scaled(Vec3::new(1.0, 0.55, 0.35)), scaled(Vec3::new(1.0, 1.0, 0.06))]
}

/// The descent and the seam rounds read blocks of 2³ cells (`FitPlan::descent_block`) on a
/// thick solid, and the cells on a thin one. On the ellipsoid (a few per cent of its cells on
/// its boundary) the default's first descent and seam rounds read at most 60 % of the rows they
/// read with `descent_block: 1` (each ball a quarter as many rows, each half as long; measured
/// 0.21), the spheres differ, and E stays within 3 % of the cells' (measured 0.1510 against
/// 0.1492). The disc is at most 8 cells thick, so most of its cells are on its boundary
/// (`DESCENT_BLOCK_MAX_SHARE`), and both plans give the same spheres (on blocks they would
/// differ). Both bound their surfaces.
#[test]
fn the_descent_reads_blocks_on_a_thick_solid_and_cells_on_a_thin_one() {
    let cells = FitPlan { descent_block: 1, ..FitPlan::default() };
    let [(pe, te), (pr, tr)] = ellipsoid_and_disc();
    let run = |p: &[Vec3], t: &[[u32; 3]], plan: &FitPlan| {
        let s = FitSettings { spheres: 32, plan: plan.clone(), ..FitSettings::default() };
        fit(p, t, &s, &|_| {}).expect("fits")
    };
    let work = |r: &FitResult| -> u64 {
        r.stats.trace.iter().filter(|e| matches!(e.stage, "descent" | "seam")).map(|e| e.work).sum()
    };
    let (blocks, on_cells) = (run(&pe, &te, &FitPlan::default()), run(&pe, &te, &cells));
    let (wb, wc) = (work(&blocks), work(&on_cells));
    assert!(wc > 0 && (wb as f64) < 0.6 * wc as f64, "rows read: {wb} on blocks, {wc} on cells");
    assert_ne!(blocks.spheres, on_cells.spheres);
    let (eb, ec) = (blocks.stats.outside_ratio_e, on_cells.stats.outside_ratio_e);
    assert!(eb <= 1.03 * ec, "E {eb} on blocks against {ec} on cells");
    let (disc, disc_cells) = (run(&pr, &tr, &FitPlan::default()), run(&pr, &tr, &cells));
    assert_eq!(disc.spheres, disc_cells.spheres, "the disc's descent reads the cells");
    for (r, p, t) in [(&blocks, &pe, &te), (&disc, &pr, &tr)] {
        let settings = spherebake_fit::EvalSettings { surface_samples: 100_000, ..Default::default() };
        let e = spherebake_fit::evaluate(p, t, &r.spheres, &settings).expect("evaluates");
        assert_eq!(e.surface_coverage, 1.0, "bounding");
    }
}
