//! Golden files: baking a fixture must reproduce `fixtures/golden/<name>.sphb` byte for byte, and
//! its summary `fixtures/golden/<name>.json` (counts, E, radii, sample and SH statistics) text
//! for text.
//!
//! Regenerate both with `UPDATE_GOLDEN=1 cargo test -p spherebake-bake --test golden` and review
//! the diff before committing: a change here changes what users get, and the `.json` diff shows
//! what changed (E, counts, radii) where the `.sphb` diff is only "binary files differ".
//!
//! The summary is deterministic: fixed key order, fixed float formatting (`{:.6}`; E and radii
//! to 1e-6), no timings, no paths.

use spherebake_bake::{bake_path, BakeOutput, BakeSettings};
use std::fmt::Write as _;
use std::path::Path;

/// FNV-1a 64 of `bytes` (ties the summary to the exact `.sphb`).
fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3))
}

/// (min, mean, max) of `v`, in f64.
fn stats(v: impl Iterator<Item = f64>) -> (f64, f64, f64) {
    let (mut lo, mut hi, mut sum, mut n) = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0usize);
    for x in v {
        lo = lo.min(x);
        hi = hi.max(x);
        sum += x;
        n += 1;
    }
    (lo, sum / n.max(1) as f64, hi)
}

/// The reviewable summary of a golden bake, one key per line.
fn summary(fixture: &str, out: &BakeOutput) -> String {
    let f = &out.file;
    let r = &out.report;
    let opt = |x: Option<f64>| x.map_or_else(|| "null".to_string(), |v| format!("{v:.6}"));
    let (rmin, rmean, rmax) = stats(f.spheres.iter().map(|s| f64::from(s.radius)));
    let per_sphere: Vec<usize> =
        f.samples.as_ref().map(|s| s.offsets.windows(2).map(|w| (w[1] - w[0]) as usize).collect()).unwrap_or_default();
    let (smin, smean, smax) = stats(per_sphere.iter().map(|&n| n as f64));
    let sh = f.albedo_sh.as_ref();
    // Mean of the DC (band 0) albedo coefficient over the spheres, per channel.
    let dc: [f64; 3] = sh.map_or([0.0; 3], |sh| {
        let n2 = usize::from(sh.order) * usize::from(sh.order);
        let k = f.spheres.len().max(1) as f64;
        [0, 1, 2].map(|c| sh.coefficients.iter().step_by(n2.max(1)).map(|x| f64::from(x[c])).sum::<f64>() / k)
    });
    let mut j = String::new();
    let mut line = |k: &str, v: String| writeln!(j, "  \"{k}\": {v},").unwrap();
    line("fixture", format!("\"{fixture}\""));
    // The settings as the file's metadata stores them (serde field order: stable).
    line("settings", f.metadata.as_ref().map_or_else(|| "null".to_string(), |m| m.settings.clone()));
    line("sphb_bytes", out.bytes.len().to_string());
    line("sphb_fnv1a64", format!("\"{:016x}\"", fnv1a64(&out.bytes)));
    line("triangles", r.triangles.to_string());
    line("vertices_welded", r.vertices_welded.to_string());
    line("closed", r.closed.to_string());
    line("spheres", f.spheres.len().to_string());
    line("outside_ratio_e", opt(r.outside_ratio_e));
    line("union_outside_ratio", opt(r.union_outside_ratio));
    line("radius_min", format!("{rmin:.6}"));
    line("radius_mean", format!("{rmean:.6}"));
    line("radius_max", format!("{rmax:.6}"));
    line("hierarchy_nodes", f.hierarchy.as_ref().map_or(0, |h| h.nodes.len()).to_string());
    line("hierarchy_levels", r.hierarchy.levels.to_string());
    line("samples", per_sphere.iter().sum::<usize>().to_string());
    line("samples_per_sphere_min", format!("{smin:.0}"));
    line("samples_per_sphere_mean", format!("{smean:.6}"));
    line("samples_per_sphere_max", format!("{smax:.0}"));
    let area_sum: f64 =
        f.samples.as_ref().and_then(|s| s.areas.as_ref()).map_or(0.0, |a| a.iter().map(|&v| f64::from(v)).sum());
    line("sample_area_sum", format!("{area_sum:.6}"));
    line("albedo_sh_order", sh.map_or(0, |s| s.order).to_string());
    line("albedo_dc_mean", format!("[{:.6}, {:.6}, {:.6}]", dc[0], dc[1], dc[2]));
    line("bones", f.bones.as_ref().map_or(0, Vec::len).to_string());
    line("skin_bones_per_sphere", f.skin.as_ref().map_or(0, |s| s.bones_per_sphere).to_string());
    line("warnings", r.warnings.len().to_string());
    // Last key without the trailing comma.
    let body = j.trim_end().trim_end_matches(',');
    format!("{{\n{body}\n}}\n")
}

/// The lines of `new` that are not in `old` and vice versa, for the failure message.
fn line_diff(old: &str, new: &str) -> String {
    let mut d = String::new();
    for l in old.lines().filter(|l| !new.lines().any(|m| m == *l)) {
        writeln!(d, "- {l}").unwrap();
    }
    for l in new.lines().filter(|l| !old.lines().any(|m| m == *l)) {
        writeln!(d, "+ {l}").unwrap();
    }
    d
}

fn check(fixture: &str, golden: &str, settings: &BakeSettings) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures");
    let out = bake_path(&root.join(fixture), settings, &|_| {}).expect("bake");
    let golden_path = root.join("golden").join(golden);
    let json_path = golden_path.with_extension("json");
    let json = summary(fixture, &out);
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        std::fs::create_dir_all(golden_path.parent().unwrap()).unwrap();
        std::fs::write(&golden_path, &out.bytes).unwrap();
        std::fs::write(&json_path, &json).unwrap();
        return;
    }
    let want = std::fs::read(&golden_path).unwrap_or_else(|e| panic!("{}: {e}", golden_path.display()));
    let want_json = std::fs::read_to_string(&json_path).unwrap_or_else(|e| panic!("{}: {e}", json_path.display()));
    if out.bytes != want {
        let got = spherebake_format::read(&out.bytes).expect("new bytes are valid");
        let old = spherebake_format::read(&want).expect("golden bytes are valid");
        panic!(
            "{fixture}: output differs from {} ({} vs {} bytes; spheres equal: {}, samples equal: {}, SH equal: {}). \
             Summary changes (- golden, + now):\n{}\
             If intended, regenerate with UPDATE_GOLDEN=1 and review.",
            golden_path.display(),
            out.bytes.len(),
            want.len(),
            got.spheres == old.spheres,
            got.samples == old.samples,
            got.albedo_sh == old.albedo_sh,
            line_diff(&want_json, &json)
        );
    }
    assert!(
        json == want_json,
        "{fixture}: same bytes, but the summary differs from {} (- golden, + now):\n{}",
        json_path.display(),
        line_diff(&want_json, &json)
    );
}

#[test]
fn capsule_16_spheres() {
    check("capsule.obj", "capsule-16.sphb", &BakeSettings { spheres: 16, ..Default::default() });
}

#[test]
fn skinned_arm_16_spheres() {
    check("skinned-arm.gltf", "skinned-arm-16.sphb", &BakeSettings { spheres: 16, ..Default::default() });
}
