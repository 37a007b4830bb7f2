//! `spherebake light`: the proxy's one-bounce indirect light against answers derived without it.
//!
//! - A finely tessellated sphere of one colour on the ground, baked into one sphere: the proxy's
//!   ground irradiance against the deterministic quadrature of `sphere_one_bounce` (no Monte Carlo
//!   in the comparison).
//! - Two spheres of different colours: each colour bleeds on its own side (proxy and reference).
//! - The JSON contract and the picture.
//! - The Duck at 64 spheres against the path-traced reference (uses `../shared/models`: skipped
//!   with a message when absent, a failure when `SPHEREBAKE_REQUIRE_MODELS=1`).

use serde_json::Value;
use spherebake_reference::analytic::{sphere_one_bounce, uv_sphere_mesh, DiffuseSphere};
use spherebake_reference::Sky;
use std::path::Path;
use std::process::{Command, Output};

fn run(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_spherebake")).args(args).current_dir(dir).output().expect("run spherebake")
}

fn ok(o: &Output) {
    assert_eq!(o.status.code(), Some(0), "stderr: {}", String::from_utf8_lossy(&o.stderr));
}

fn json_of(o: &Output) -> Value {
    ok(o);
    serde_json::from_slice(&o.stdout).expect("JSON on stdout")
}

/// OBJ text of UV spheres (centre, radius, material name), one `usemtl` each.
fn spheres_obj(parts: &[([f64; 3], f64, &str)], stacks: usize, slices: usize) -> String {
    let mut s = String::from("mtllib m.mtl\n");
    let mut base = 1;
    for (c, r, mat) in parts {
        let m = uv_sphere_mesh(*c, *r, stacks, slices, [1.0; 3]);
        s += &format!("usemtl {mat}\n");
        for p in &m.positions {
            s += &format!("v {} {} {}\n", p.x, p.y, p.z);
        }
        for t in &m.triangles {
            s += &format!("f {} {} {}\n", t[0] as usize + base, t[1] as usize + base, t[2] as usize + base);
        }
        base += m.positions.len();
    }
    s
}

fn bake(dir: &Path, obj: &str, mtl: &str, spheres: usize) {
    std::fs::write(dir.join("m.obj"), obj).unwrap();
    std::fs::write(dir.join("m.mtl"), mtl).unwrap();
    ok(&run(&["bake", "m.obj", "-o", "m.sphb", "--spheres", &spheres.to_string(), "-q"], dir));
}

fn values(dir: &Path, name: &str) -> Value {
    serde_json::from_slice(&std::fs::read(dir.join(name)).unwrap()).unwrap()
}

fn rgb(v: &Value) -> [f64; 3] {
    [0, 1, 2].map(|k| v[k].as_f64().expect("finite value"))
}

#[test]
fn one_coloured_sphere_matches_the_integrated_one_bounce() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    bake(d, &spheres_obj(&[([0.0, 1.0, 0.0], 1.0, "c")], 64, 128), "newmtl c\nKd 0.8 0.5 0.2\n", 1);
    // The reference is not compared here: one ray keeps it cheap.
    let args = [
        "light",
        "m.sphb",
        "--model",
        "m.obj",
        "--resolution",
        "16",
        "--rays",
        "1",
        "--model-receivers",
        "0",
        "--values-json",
        "v.json",
        "--json",
    ];
    let j = json_of(&run(&args, d));
    assert_eq!(j["spheres"], 1);
    let v = values(d, "v.json");
    let ground = v["ground"].as_array().unwrap();
    assert_eq!(ground.len(), 256);
    let pts: Vec<[f64; 3]> = ground.iter().map(|g| rgb(&g["position"])).collect();
    let proxy: Vec<[f64; 3]> = ground.iter().map(|g| rgb(&g["proxy"])).collect();
    // The mesh's lowest point is the pole at y = 0.
    assert!(pts.iter().all(|p| p[1].abs() < 1e-6));
    let sky = Sky::uniform(1.0).unwrap();
    let sphere = DiffuseSphere { centre: [0.0, 1.0, 0.0], radius: 1.0, albedo: [0.8, 0.5, 0.2] };
    let exact = sphere_one_bounce(&sky, &sphere, 0.0, &pts, 32).unwrap();
    let (mut se, mut sum) = (0.0, 0.0);
    for (p, x) in proxy.iter().zip(&exact) {
        for k in 0..3 {
            se += (p[k] - x[k]).powi(2);
            sum += x[k];
        }
    }
    let n = 3.0 * proxy.len() as f64;
    let rel = (se / n).sqrt() / (sum / n);
    eprintln!("one sphere, order 4, uniform sky: proxy vs integrated one-bounce, relative RMSE {rel:.5}");
    assert!(rel <= 0.02, "relative RMSE {rel}");
    // The direct light of the uniform sky on an open ground is π; under the ball it is darker.
    let far = ground.iter().map(|g| g["direct_reference"].as_f64().unwrap()).fold(0.0, f64::max);
    assert!((far - std::f64::consts::PI).abs() < 0.05, "{far}");
}

#[test]
fn two_colours_bleed_on_their_own_sides() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let obj = spheres_obj(&[([-1.0, 0.5, 0.0], 0.5, "red"), ([1.0, 0.5, 0.0], 0.5, "green")], 24, 48);
    bake(d, &obj, "newmtl red\nKd 0.8 0.1 0.1\nnewmtl green\nKd 0.1 0.8 0.1\n", 2);
    let args = [
        "light",
        "m.sphb",
        "--model",
        "m.obj",
        "--resolution",
        "16",
        "--rays",
        "256",
        "--model-receivers",
        "64",
        "--values-json",
        "v.json",
        "--json",
        "-o",
        "cmp.png",
    ];
    let j = json_of(&run(&args, d));
    let v = values(d, "v.json");
    for side in ["proxy", "reference"] {
        let (mut left, mut right) = ([0.0; 3], [0.0; 3]);
        for g in v["ground"].as_array().unwrap() {
            let x = g["position"][0].as_f64().unwrap();
            let e = rgb(&g[side]);
            let acc = if x < 0.0 { &mut left } else { &mut right };
            for k in 0..3 {
                acc[k] += e[k];
            }
        }
        eprintln!("{side}: left {left:?}, right {right:?}");
        assert!(left[0] > 1.5 * left[1], "{side}: red must dominate at x < 0: {left:?}");
        assert!(right[1] > 1.5 * right[0], "{side}: green must dominate at x > 0: {right:?}");
        assert!(left[0] / left[1] > right[0] / right[1]);
        assert!(right[1] / right[0] > left[1] / left[0]);
    }

    // The JSON contract: keys present and finite.
    for key in ["direct", "indirect", "timings", "receivers"] {
        assert!(j.get(key).is_some(), "missing {key}");
    }
    assert!(j["direct"]["rel_rmse"].as_f64().unwrap().is_finite());
    for part in ["ground", "model"] {
        let s = &j["indirect"][part];
        for key in ["rel_rmse", "bias"] {
            assert!(s[key].as_f64().is_some_and(f64::is_finite), "indirect.{part}.{key}: {s}");
        }
        for key in ["mean_proxy_rgb", "mean_reference_rgb"] {
            let m = rgb(&s[key]);
            assert!(m.iter().all(|v| v.is_finite() && *v > 0.0), "indirect.{part}.{key}: {m:?}");
        }
    }
    assert_eq!(j["spheres"], 2);
    assert_eq!(j["light"], "uniform");
    assert_eq!(j["receivers"]["ground"], 256);
    assert_eq!(j["receivers"]["model"], 64);
    for key in ["pass1_seconds", "pass2_seconds", "reference_seconds"] {
        assert!(j["timings"][key].as_f64().is_some_and(|t| t.is_finite() && t >= 0.0), "timings.{key}");
    }
    let img = image::open(d.join("cmp.png")).expect("cmp.png");
    assert!(img.width() >= 1024, "width {}", img.width());
}

#[test]
fn human_output_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    bake(d, &spheres_obj(&[([0.0, 1.0, 0.0], 1.0, "c")], 12, 24), "newmtl c\nKd 0.5 0.5 0.5\n", 1);
    let o = run(&["light", "m.sphb", "--model", "m.obj", "--resolution", "4", "--rays", "4", "--light", "lobe"], d);
    ok(&o);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("indirect, ground") && text.contains("lobe light"), "{text}");
    // A missing file: one line naming it, exit 1.
    let o = run(&["light", "nope.sphb", "--model", "m.obj"], d);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.starts_with("spherebake: error: nope.sphb") && err.lines().count() == 1, "{err}");
    // Out-of-range settings are usage errors (exit 2, as clap's own), a pose for a model without
    // a skin is an input error (exit 1); none panics.
    for (bad, code) in [
        (&["--order", "9"][..], 2),
        (&["--resolution", "1"], 2),
        (&["--time", "nan"], 2),
        (&["--time", "0.5"], 1),
        (&["--animation", "Walk"], 1),
    ] {
        let mut args = vec!["light", "m.sphb", "--model", "m.obj"];
        args.extend_from_slice(bad);
        let o = run(&args, d);
        assert_eq!(o.status.code(), Some(code), "{bad:?}: {}", String::from_utf8_lossy(&o.stderr));
    }
}

#[test]
fn posing_moves_both_sides_and_the_soft_rotation_changes_the_proxy() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let arm = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/skinned-arm.gltf");
    let arm = arm.to_str().unwrap();
    ok(&run(&["bake", arm, "-o", "arm.sphb", "--spheres", "8", "-q"], d));
    let base =
        ["light", "arm.sphb", "--model", arm, "--resolution", "8", "--rays", "64", "--model-receivers", "32", "--json"];
    let go = |extra: &[&str]| {
        let mut args = base.to_vec();
        args.extend_from_slice(extra);
        json_of(&run(&args, d))
    };
    let rest = go(&[]);
    let bent = go(&["--animation", "bend", "--time", "0.5"]);
    let rigid = go(&["--animation", "bend", "--time", "0.5", "--no-soft-rotation"]);
    assert_eq!(rest["animation"], Value::Null);
    assert_eq!(bent["animation"], "bend");
    assert_eq!(bent["time_s"].as_f64(), Some(0.5));
    assert_eq!(bent["soft_rotation"], true);
    assert_eq!(rigid["soft_rotation"], false);
    let mean = |j: &Value, side: &str| rgb(&j["indirect"]["ground"][side]);
    // The pose moves the reference; the rotation switch changes the proxy only.
    assert_ne!(mean(&rest, "mean_reference_rgb"), mean(&bent, "mean_reference_rgb"));
    assert_eq!(mean(&bent, "mean_reference_rgb"), mean(&rigid, "mean_reference_rgb"));
    assert_ne!(mean(&bent, "mean_proxy_rgb"), mean(&rigid, "mean_proxy_rgb"));
    // The pass-1 sample check runs at rest only.
    assert!(rest["pass1_samples"]["samples"].as_u64().unwrap() > 0);
    assert_eq!(bent["pass1_samples"]["samples"], 0);
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let obj = spheres_obj(&[([-1.0, 0.5, 0.0], 0.5, "red"), ([0.8, 0.6, 0.3], 0.6, "green")], 12, 24);
    bake(d, &obj, "newmtl red\nKd 0.8 0.1 0.1\nnewmtl green\nKd 0.1 0.8 0.1\n", 4);
    let mut outs = Vec::new();
    for threads in ["1", "2"] {
        let name = format!("v{threads}.json");
        let o = Command::new(env!("CARGO_BIN_EXE_spherebake"))
            .args(["light", "m.sphb", "--model", "m.obj", "--resolution", "12", "--rays", "16"])
            .args(["--model-receivers", "40", "--cluster", "4", "--values-json", &name])
            .env("RAYON_NUM_THREADS", threads)
            .current_dir(d)
            .output()
            .unwrap();
        ok(&o);
        outs.push(std::fs::read(d.join(&name)).unwrap());
    }
    assert!(outs[0] == outs[1], "values differ between 1 and 2 threads");
}

/// `spherebake light FILE --model MODEL` at the real-model tests' settings (24² ground receivers, 2048 rays, 256
/// model receivers) plus `extra`, as JSON.
fn real_model_light(d: &Path, file: &str, model: &str, extra: &[&str]) -> Value {
    light_at(d, file, model, ["24", "2048", "256"], extra)
}

/// `light --json` of `file` against `model` at [ground receivers per edge, rays, model receivers].
fn light_at(d: &Path, file: &str, model: &str, [resolution, rays, receivers]: [&str; 3], extra: &[&str]) -> Value {
    let mut args = vec![
        "light",
        file,
        "--model",
        model,
        "--resolution",
        resolution,
        "--rays",
        rays,
        "--model-receivers",
        receivers,
        "--json",
    ];
    args.extend_from_slice(extra);
    json_of(&run(&args, d))
}

#[test]
fn duck_at_64_spheres_keeps_its_measured_ground_error_under_the_uniform_sky() {
    let Some(duck) = spherebake_testkit::shared_model("gltf/Duck.glb") else { return };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let model = duck.to_str().unwrap();
    ok(&run(&["bake", model, "-o", "duck.sphb", "--spheres", "64", "-q"], d));
    let j = light_at(d, "duck.sphb", model, ["24", "2048", "1024"], &[]);
    let g = &j["indirect"]["ground"];
    let rel = g["rel_rmse"].as_f64().unwrap();
    eprintln!(
        "Duck, 64 spheres, uniform sky: ground indirect rel RMSE {rel:.4}, bias {:.4}; model rel RMSE {:.4}, bias {:.4}; direct rel RMSE {:.4}",
        g["bias"].as_f64().unwrap(),
        j["indirect"]["model"]["rel_rmse"].as_f64().unwrap_or(f64::NAN),
        j["indirect"]["model"]["bias"].as_f64().unwrap_or(f64::NAN),
        j["direct"]["rel_rmse"].as_f64().unwrap(),
    );
    // Issue 14's target is 0.20 (at 64² receivers and 4096 rays: 0.196, docs/benchmarks.md); here, at coarser
    // ground settings, the proxy measures ground 0.186, model 0.842 (the reference is seeded, so these repeat). The
    // model error is read at 1024 model receivers: at the 256 of the other real-model tests it jumps with the sphere
    // layout (the fit's doubled trial budgets took it 0.884 → 0.973 while at 1024 it went 0.828 → 0.842, and at 64²
    // ground receivers and 4096 rays ground 0.194 → 0.196). The model ceiling is the measured 0.842 × 1.05; without
    // the sample areas (format minor 2) the values were 0.252 / 0.936 (256 receivers), before the surface tiles
    // 0.314 / 1.05.
    assert!(rel <= 0.23, "Duck ground indirect relative RMSE {rel}");
    let model_rel = j["indirect"]["model"]["rel_rmse"].as_f64().unwrap();
    assert!(model_rel <= 0.884, "Duck model indirect relative RMSE {model_rel}");
    // Yellow bleeding, on both sides: the ground light is redder and greener than it is blue.
    for side in ["mean_reference_rgb", "mean_proxy_rgb"] {
        let m = rgb(&g[side]);
        assert!(m[0] > 10.0 * m[2] && m[1] > 10.0 * m[2], "{side}: {m:?}");
    }
}

/// CesiumMan at 64 spheres, at rest and mid-walk (t = 1 s), with and without the soft-deformation rotation
/// (seed 000 §7.1). Issue 14: ground ≤ 0.20 at 64² receivers and 4096 rays, asserted at those settings (0.191;
/// before the fit's boundary moves 0.183). The posed comparison runs at coarser settings (24² receivers, 2048
/// rays): mid-walk ground / model 0.234 / 0.357 with the rotation, 0.265 / 0.511 without.
///
/// At rest on the coarse grids whose middle 8² tile is centred between the feet (24² and 40² receivers: 3 × 3 and
/// 5 × 5 tiles), the reflection ratios taken at that centre alone, where the head's nodes are hidden by the body,
/// reached 6–16 and lit the whole tile 2× too bright: ground 0.502 and 0.434, against 0.223 / 0.262 / 0.236 at 16²
/// / 32² / 48². Taken over the tile (its centre and four points on its disc, `light::RATIO_PROBE_RADIUS`) they give
/// 0.292 and 0.242. One receiver under a sole (reference 0; the spheres' contact with the ground differs) is most of
/// what is left at 24². Ceilings: the measured values × 1.1; at 40² since the fit's seam points lay rows on slivers
/// 0.271 × 1.1 (that fit lowered CesiumMan's E on seeds 1–4 and its ground error at 32², 48² and 64²: 0.260 / 0.234
/// / 0.178 → 0.252 / 0.225 / 0.179, but at 40² it went 0.244 → 0.271: this grid's value moves with the sphere
/// layout; the centre-only ratios gave 0.434 here). (Without reflection ratios the tile is right too,
/// 0.289 / 0.238: that the ratios close the seams between tiles is `light_hierarchy.rs`'s to show.)
#[test]
fn cesium_man_at_64_spheres_and_the_soft_rotation_reduces_the_posed_error() {
    let Some(man) = spherebake_testkit::shared_model("gltf/CesiumMan.glb") else { return };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let model = man.to_str().unwrap();
    ok(&run(&["bake", model, "-o", "man.sphb", "--spheres", "64", "-q"], d));
    let errors = |extra: &[&str]| {
        let j = real_model_light(d, "man.sphb", model, extra);
        let g = j["indirect"]["ground"]["rel_rmse"].as_f64().unwrap();
        let m = j["indirect"]["model"]["rel_rmse"].as_f64().unwrap();
        eprintln!("CesiumMan, 64 spheres {extra:?}: ground {g:.4}, model {m:.4}");
        (g, m)
    };
    let fine = light_at(d, "man.sphb", model, ["64", "4096", "16"], &[]);
    let rest = fine["indirect"]["ground"]["rel_rmse"].as_f64().unwrap();
    assert!(rest <= 0.20, "CesiumMan ground indirect relative RMSE at 64² receivers, 4096 rays: {rest}");
    for (res, ceiling) in [("24", 0.32), ("40", 0.298)] {
        let j = light_at(d, "man.sphb", model, [res, "2048", "16"], &[]);
        let g = j["indirect"]["ground"]["rel_rmse"].as_f64().unwrap();
        eprintln!("CesiumMan, 64 spheres, {res}² ground receivers: {g:.4}");
        assert!(g <= ceiling, "CesiumMan ground indirect relative RMSE at {res}² receivers: {g} (ceiling {ceiling})");
    }
    let (g_rot, m_rot) = errors(&["--time", "1.0"]);
    let (g_no, m_no) = errors(&["--time", "1.0", "--no-soft-rotation"]);
    assert!(g_rot < g_no, "the rotation must reduce the ground error: {g_rot} vs {g_no}");
    assert!(m_rot < m_no, "the rotation must reduce the model error: {m_rot} vs {m_no}");
}

/// A fit leaves the spheres it finds no use for empty (radius the least positive normal f32), and the
/// bake may give them samples; the hierarchy holds them like any leaf. The capsule fixture at the
/// default 64 spheres leaves most of them empty (the README's quick start): through the
/// hierarchy's cut its ground was lit with 0 (a node of empty leaves turned NaN, clamped), while
/// every leaf as its own light (θmax = 0) gave the path tracer's value. Both must agree with it.
#[test]
fn empty_spheres_do_not_darken_the_light_through_the_hierarchy() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures");
    for f in ["capsule.obj", "capsule.mtl"] {
        std::fs::copy(fixtures.join(f), d.join(f)).unwrap();
    }
    let baked = json_of(&run(&["bake", "capsule.obj", "-o", "c.sphb", "--json"], d));
    let empty = baked["assets"][0]["report"]["empty_spheres"].as_u64().unwrap();
    assert!(empty >= 8, "the case needs empty spheres: {empty}");
    let light = |theta: &str| {
        let args = [
            "light",
            "c.sphb",
            "capsule.obj",
            "--resolution",
            "16",
            "--rays",
            "64",
            "--model-receivers",
            "0",
            "--theta-max-deg",
            theta,
            "--json",
        ];
        let j = json_of(&run(&args, d));
        let g = &j["indirect"]["ground"];
        (g["bias"].as_f64().unwrap(), rgb(&g["mean_proxy_rgb"]))
    };
    let (bias_cut, cut) = light("25");
    let (bias_leaves, leaves) = light("0");
    eprintln!("capsule, {empty} empty spheres: ground bias {bias_cut:+.4} (cut), {bias_leaves:+.4} (leaves only)");
    assert!(bias_cut.abs() < 0.15 && bias_leaves.abs() < 0.15, "{bias_cut} {bias_leaves}");
    for k in 0..3 {
        assert!((cut[k] / leaves[k] - 1.0).abs() < 0.02, "channel {k}: {cut:?} against {leaves:?}");
    }
}
