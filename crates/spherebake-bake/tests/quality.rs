//! Quality ceilings of the default bake (issue 16): E = Σ V(S_i − T) / V(T) at the default 64
//! spheres must not rise above what main measured, plus a small margin stated per case. A fit
//! change that makes any of these worse fails here instead of slipping through a re-blessed
//! golden file.
//!
//! - The path is the product's: `bake_path` with `BakeSettings::default()` (what `spherebake
//!   bake MODEL` runs), and E as the report gives it (exact, for the stored f32 spheres).
//! - Fixtures: always. Their E is also checked against the independent Monte Carlo oracle of
//!   `spherebake-testkit` (the fixtures are convex: inside = behind every face plane), so the
//!   ceiling is not met by a misreported E.
//! - The shared models (bunny, armadillo, spot, Duck): when `../shared/models` is present (a
//!   visible skip otherwise, a failure with `SPHEREBAKE_REQUIRE_MODELS=1`). Each is baked once.
//! - `--preset fast` on the bunny (its own ceiling, below issue 16's E ≤ 0.25).
//! - Every case: 64 spheres stored (the small-count case: its count), every welded vertex
//!   inside a stored sphere (plain f64 distances on the f32 values).
//!
//! Ceilings = the E measured on main when the ceiling was set × 1.05 (rounded up in the 4th
//! decimal). When the fit improves, lower them to the new measurement × 1.05 in the same commit.

use spherebake_bake::{bake_path, BakeOutput, BakeSettings};
use spherebake_testkit::oracle::{closed_mesh_volume, convex_inside, outside_ratio};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A model and its E ceiling at the default settings.
struct Case {
    /// Path under `fixtures/` or `../shared/models/`.
    rel: &'static str,
    /// E measured on main (the whole bake, `bake_path` with the default settings, 64 spheres,
    /// seed 1) when the ceiling was set; a later change may leave E above it but under the
    /// ceiling (each test's comment gives that history), so it is not today's E.
    measured: f64,
    /// Asserted upper bound: `measured` × 1.05, rounded up.
    ceiling: f64,
}

fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures").join(rel)
}

/// Bakes `path` with the defaults and checks what every case must satisfy; returns the output.
fn bake_and_check(path: &Path, case: &Case) -> BakeOutput {
    bake_and_check_at(path, case, BakeSettings::default().spheres)
}

/// [`bake_and_check`] with `spheres` spheres (every other setting the default).
fn bake_and_check_at(path: &Path, case: &Case, spheres: usize) -> BakeOutput {
    bake_and_check_with(path, case, BakeSettings { spheres, ..BakeSettings::default() })
}

/// [`bake_and_check`] with `settings`.
fn bake_and_check_with(path: &Path, case: &Case, settings: BakeSettings) -> BakeOutput {
    assert!(case.ceiling >= case.measured && case.ceiling <= case.measured * 1.05 + 1e-4, "{}: ceiling", case.rel);
    let t = Instant::now();
    let spheres = settings.spheres;
    let out = bake_path(path, &settings, &|_| {}).unwrap_or_else(|e| panic!("{}: {e}", case.rel));
    let e = out.report.outside_ratio_e.expect("the variational fit reports E");
    eprintln!(
        "{}: E {e:.4} (measured {:.4}, ceiling {:.4}), {} spheres, bake {:.2} s",
        case.rel,
        case.measured,
        case.ceiling,
        out.file.spheres.len(),
        t.elapsed().as_secs_f64()
    );
    assert_eq!(out.file.spheres.len(), spheres, "{}", case.rel);
    assert!(e.is_finite() && e > 0.0, "{}: E {e}", case.rel);
    assert!(
        e <= case.ceiling,
        "{}: E {e:.4} above its ceiling {:.4} (measured {:.4})",
        case.rel,
        case.ceiling,
        case.measured
    );
    let mesh = spherebake_io::load_mesh(path).unwrap().mesh;
    for (i, v) in mesh.welded_positions.iter().enumerate() {
        let v = v.as_dvec3();
        let inside = out.file.spheres.iter().any(|s| {
            let c = glam::DVec3::new(s.center[0] as f64, s.center[1] as f64, s.center[2] as f64);
            v.distance_squared(c) <= (s.radius as f64).powi(2)
        });
        assert!(inside, "{}: welded vertex {i} at {v} outside every stored sphere", case.rel);
    }
    out
}

/// The report's E against the Monte Carlo oracle on the fixture's welded mesh (closed and
/// convex, all three: the oracle's plane test, which checks convexity, is exact and fast).
fn check_against_oracle(path: &Path, out: &BakeOutput, rel: &str) {
    let mesh = spherebake_io::load_mesh(path).unwrap().mesh;
    let p: Vec<[f64; 3]> = mesh.welded_positions.iter().map(|v| v.as_dvec3().to_array()).collect();
    let t = mesh.welded_triangles();
    let volume = closed_mesh_volume(&p, &t);
    let spheres: Vec<[f32; 4]> =
        out.file.spheres.iter().map(|s| [s.center[0], s.center[1], s.center[2], s.radius]).collect();
    let mc = outside_ratio(&spheres, volume, 1 << 20, 1, convex_inside(&p, &t));
    let e = out.report.outside_ratio_e.unwrap();
    eprintln!("{rel}: oracle E {:.4} ± {:.4} ({} points)", mc.e, mc.standard_error, mc.samples);
    assert!(mc.standard_error < 0.05 * mc.e, "{rel}: oracle too noisy: {mc:?}");
    assert!((e - mc.e).abs() <= 4.0 * mc.standard_error, "{rel}: reported E {e} vs oracle {mc:?}");
}

fn fixture_case(case: &Case) {
    let path = fixture(case.rel);
    let out = bake_and_check(&path, case);
    assert!(out.report.closed, "{}: the fixtures are closed", case.rel);
    check_against_oracle(&path, &out, case.rel);
}

#[test]
fn capsule_stays_under_its_e_ceiling() {
    // 0.0508 since the descent points lay rows on slivers, its cylinder's side triangles
    // (seeds 1–4: mean 0.0500 → 0.0509, for a quarter less CPU), 0.0506 with rows on the seam
    // points' slivers too (mean 0.0508, half the CPU; the ceiling is not raised).
    fixture_case(&Case { rel: "capsule.obj", measured: 0.0501, ceiling: 0.0527 });
}

#[test]
fn skinned_arm_stays_under_its_e_ceiling() {
    // 0.1401 until the pattern search polled its predicted moves (ceiling then 0.1472).
    fixture_case(&Case { rel: "skinned-arm.gltf", measured: 0.1393, ceiling: 0.1463 });
}

#[test]
fn textured_cube_stays_under_its_e_ceiling() {
    // The ceiling was set from 0.2850; with the trial budgets doubled seed 1 gives 0.2904
    // (seeds 1–4: mean 0.2847 → 0.2837), and the ceiling is not raised; 0.2812 with the
    // predicted polls of the pattern search (the ceiling lowered to it).
    fixture_case(&Case { rel: "textured-cube/textured-cube.gltf", measured: 0.2812, ceiling: 0.2953 });
}

fn shared(case: &Case) {
    let Some(path) = spherebake_testkit::shared_model(case.rel) else { return };
    bake_and_check(&path, case);
}

#[test]
fn bunny_stays_under_its_e_ceiling() {
    // Seed 1: 0.2318, then 0.2354 with the two-thinning start (seeds 1–8 mean 0.2426 →
    // 0.2315), 0.2297 with the boundary moves, 0.2286 with the gap round, 0.2227 with the trial
    // budgets doubled (the ceiling set from it), 0.2289 with the predicted polls of the pattern
    // search (seeds 1–8, fit alone: mean 0.2216 → 0.2218; the ceiling is not raised), 0.2307
    // with rows on the descent points' slivers (25 triangles of its base; seeds 1–4: mean
    // 0.2226 → 0.2245, seeds 5–8 0.2167 → 0.2160), 0.2276 with rows on the seam points'
    // slivers too (seeds 1–4: mean 0.2218; the ceiling is not raised).
    shared(&Case { rel: "obj/stanford-bunny.obj", measured: 0.2227, ceiling: 0.2339 });
}

/// `--preset fast` (issue 16: the bunny at 64 spheres bounding with E ≤ 0.25): the CLI's
/// settings for it, its plan and its own voxel grid (`Preset::voxels`, 96 cells).
#[test]
fn fast_bunny_stays_under_its_e_ceiling() {
    // Seed 1: 0.2285 with one seam round (session 55; seeds 1–8 mean 0.2411, every seed at
    // most 0.2450; two rounds gave 0.2268, none 0.2395, above the ceiling). The ceiling is
    // also below the 0.25.
    let Some(path) = spherebake_testkit::shared_model("obj/stanford-bunny.obj") else { return };
    let case = Case { rel: "obj/stanford-bunny.obj", measured: 0.2285, ceiling: 0.2380 };
    let preset = spherebake_bake::Preset::Fast;
    let settings = BakeSettings { preset, voxels: preset.voxels(), ..BakeSettings::default() };
    bake_and_check_with(&path, &case, settings);
}

#[test]
fn armadillo_stays_under_its_e_ceiling() {
    // 0.3932 with the predicted polls of the pattern search (the ceiling is not raised).
    shared(&Case { rel: "obj/armadillo.obj", measured: 0.3895, ceiling: 0.4090 });
}

#[test]
fn spot_stays_under_its_e_ceiling() {
    // 0.1498 with the predicted polls of the pattern search (the ceiling is not raised).
    shared(&Case { rel: "obj/spot/spot.obj", measured: 0.1495, ceiling: 0.1570 });
}

#[test]
fn duck_stays_under_its_e_ceiling() {
    // 0.1058 until the predicted polls of the pattern search (ceiling then 0.1111); 0.1038
    // with rows on the descent points' slivers (seeds 1–4: mean 0.1012 → 0.1021), then on the
    // seam points' too (mean 0.1024).
    shared(&Case { rel: "gltf/Duck.glb", measured: 0.1036, ceiling: 0.1088 });
}

#[test]
fn duck_at_8_spheres_stays_under_its_e_ceiling() {
    // Few spheres: the descent's trial threshold counts mean spheres below 64 spheres
    // (`descent::trial_threshold`). With a fixed 5 % of the total it ranked too few moves:
    // 0.3579 at seed 1 (seeds 1–4: mean 0.3529), now 0.3074 (mean 0.3162).
    let Some(path) = spherebake_testkit::shared_model("gltf/Duck.glb") else { return };
    bake_and_check_at(&path, &Case { rel: "gltf/Duck.glb", measured: 0.3074, ceiling: 0.3228 }, 8);
}
