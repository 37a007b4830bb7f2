//! Runs the built `spherebake` binary in a fresh temp directory per test (ripgrep style) and checks
//! exit codes, that stderr names the file, and that no output file is left behind on failure.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_spherebake"))
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn run(args: &[&str], dir: &Path) -> Output {
    bin().args(args).current_dir(dir).output().expect("run spherebake")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Asserts a failed bake: exit 1, one-line error naming `named`, no output nor temp file left.
fn assert_bake_fails(dir: &Path, input: &str, named: &str, what: &str) {
    let o = run(&["bake", input, "-o", "out.sphb"], dir);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{input}: expected exit 1, stderr: {err}");
    assert!(err.starts_with("spherebake: error: "), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line expected: {err}");
    assert!(err.contains(named), "stderr must name {named}: {err}");
    assert!(err.to_lowercase().contains(what), "stderr must say {what:?}: {err}");
    let left: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".sphb") || n.ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "output left behind: {left:?}");
}

fn glb(json: &str, bin_chunk: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    let mut b = bin_chunk.to_vec();
    while b.len() % 4 != 0 {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + if b.is_empty() { 0 } else { 8 + b.len() };
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    if !b.is_empty() {
        out.extend_from_slice(&(b.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&b);
    }
    out
}

/// A one-triangle glTF whose positions and indices are given.
fn triangle_glb(positions: [[f32; 3]; 3], indices: [u16; 3]) -> Vec<u8> {
    let mut bin = Vec::new();
    for p in positions {
        for c in p {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in indices {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let json = r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
      "meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],
      "buffers":[{"byteLength":42}],
      "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":6}],
      "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
                   {"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}]}"#;
    glb(json, &bin)
}

const OK_TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

#[test]
fn readme_quick_start_bakes_the_fixture_and_prints_a_summary() {
    let dir = tempfile::tempdir().unwrap();
    let input = repo().join("fixtures/capsule.obj");
    let o = run(&["bake", input.to_str().unwrap(), "-o", "capsule.sphb"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("spheres"), "{out}");
    let bytes = std::fs::read(dir.path().join("capsule.sphb")).unwrap();
    let file = spherebake_format::read(&bytes).expect("the reader accepts what bake wrote");
    assert!(!file.spheres.is_empty());
    // The capsule at 64 spheres leaves some empty (a sphere off its axis would stick out): the
    // summary says how many, counted here from the file.
    let empty = file.spheres.iter().filter(|s| s.radius <= f32::MIN_POSITIVE).count();
    assert!(empty > 0 && empty < file.spheres.len(), "{empty}");
    // The line states the count only: an empty sphere is not proof that no sphere could help
    // (a fast preset's trial budget can run out first).
    let line = format!("spheres   {} ({empty} left empty by the fit: radius 0)", file.spheres.len());
    assert!(out.contains(&line), "{out}");
}

#[test]
fn inspect_json_has_the_contract_keys() {
    let dir = tempfile::tempdir().unwrap();
    let input = repo().join("fixtures/capsule.obj");
    assert_eq!(run(&["bake", input.to_str().unwrap(), "-o", "c.sphb"], dir.path()).status.code(), Some(0));
    let o = run(&["inspect", "c.sphb", "--json"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for k in [
        "format_version",
        "header",
        "spheres",
        "hierarchy",
        "hierarchy_root",
        "samples",
        "sample_areas_encoding",
        "albedo_sh",
        "albedo_sh_format",
        "skin",
        "bones_per_sphere",
        "bones",
        "metadata",
        "sections",
    ] {
        assert!(v.get(k).is_some(), "missing key {k}");
    }
    assert_eq!(v["sample_areas_encoding"], "f32 (model units squared)", "a lossless bake");
    let s = &v["spheres"][0];
    assert_eq!(s["center"].as_array().unwrap().len(), 3);
    assert!(s["radius"].as_f64().unwrap() > 0.0);
    // Minor 2: the samples carry their surface areas (spec §7.2), which sum to the capsule's area
    // (r = 0.5 around a segment of length 1: 2πr·1 + 4πr² = 2π ≈ 6.28; the 384-triangle mesh has less).
    assert_eq!(v["format_version"], "1.2");
    let area: f64 = v["samples"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|l| l.as_array().unwrap().iter().map(|p| p["area"].as_f64().unwrap()))
        .sum();
    assert!((6.0..6.3).contains(&area), "{area}");

    let o = run(&["inspect", input.to_str().unwrap(), "--json"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["topology"]["closed"], true);
}

#[test]
fn bake_is_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    let input = repo().join("fixtures/capsule.obj");
    for name in ["a.sphb", "b.sphb"] {
        assert_eq!(run(&["bake", input.to_str().unwrap(), "-o", name], dir.path()).status.code(), Some(0));
    }
    assert_eq!(std::fs::read(dir.path().join("a.sphb")).unwrap(), std::fs::read(dir.path().join("b.sphb")).unwrap());
}

#[test]
fn missing_file() {
    let dir = tempfile::tempdir().unwrap();
    assert_bake_fails(dir.path(), "nope.glb", "nope.glb", "not found");
}

#[test]
fn truncated_glb() {
    let dir = tempfile::tempdir().unwrap();
    let full = triangle_glb(OK_TRI, [0, 1, 2]);
    std::fs::write(dir.path().join("cut.glb"), &full[..full.len() - 20]).unwrap();
    assert_bake_fails(dir.path(), "cut.glb", "cut.glb", "truncated");
}

#[test]
fn wrong_magic() {
    let dir = tempfile::tempdir().unwrap();
    let mut full = triangle_glb(OK_TRI, [0, 1, 2]);
    full[0..4].copy_from_slice(b"gLTF");
    std::fs::write(dir.path().join("magic.glb"), &full).unwrap();
    assert_bake_fails(dir.path(), "magic.glb", "magic.glb", "magic");
}

#[test]
fn index_out_of_range() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("idx.glb"), triangle_glb(OK_TRI, [0, 1, 7])).unwrap();
    assert_bake_fails(dir.path(), "idx.glb", "idx.glb", "index");
}

#[test]
fn nan_positions() {
    let dir = tempfile::tempdir().unwrap();
    let mut p = OK_TRI;
    p[1][1] = f32::NAN;
    std::fs::write(dir.path().join("nan.glb"), triangle_glb(p, [0, 1, 2])).unwrap();
    assert_bake_fails(dir.path(), "nan.glb", "nan.glb", "nan");
    std::fs::write(dir.path().join("nan.obj"), "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    assert_bake_fails(dir.path(), "nan.obj", "nan.obj", "nan");
}

#[test]
fn empty_mesh() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("empty.obj"), "# nothing\nv 0 0 0\n").unwrap();
    assert_bake_fails(dir.path(), "empty.obj", "empty.obj", "no triangles");
}

#[test]
fn missing_texture_warns_and_bakes() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("t.obj"),
        "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nusemtl m\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("t.mtl"), "newmtl m\nKd 0.5 0.25 1\nmap_Kd gone.png\n").unwrap();
    let o = run(&["bake", "t.obj", "-o", "t.sphb"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("gone.png"), "the warning must name the missing texture: {out}");
    assert!(dir.path().join("t.sphb").exists());
}

#[test]
fn unknown_major_version_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let input = repo().join("fixtures/capsule.obj");
    assert_eq!(run(&["bake", input.to_str().unwrap(), "-o", "v.sphb"], dir.path()).status.code(), Some(0));
    let mut bytes = std::fs::read(dir.path().join("v.sphb")).unwrap();
    bytes[8..10].copy_from_slice(&2u16.to_le_bytes()); // major version field follows the 8-byte magic
    spherebake_format::repair_checksums(&mut bytes);
    std::fs::write(dir.path().join("v2.sphb"), &bytes).unwrap();
    let o = run(&["inspect", "v2.sphb"], dir.path());
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("v2.sphb") && err.contains("version"), "{err}");
}

#[test]
fn usage_errors_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    assert_eq!(run(&["bake"], dir.path()).status.code(), Some(2));
    assert_eq!(run(&["frobnicate"], dir.path()).status.code(), Some(2));
    let input = repo().join("fixtures/capsule.obj");
    let o = run(&["bake", input.to_str().unwrap(), "-o", "x.sphb", "--spheres", "0"], dir.path());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!dir.path().join("x.sphb").exists());
}

/// Every command that reads a model beside its `.sphb` takes it after the file (`FILE MODEL`,
/// as `eval` always did) or as `--model MODEL` (as the others did): both spellings give the
/// same output, and neither or both is a usage error (exit 2).
#[test]
fn every_model_command_takes_the_model_after_the_file_or_as_an_option() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let input = repo().join("fixtures/capsule.obj");
    std::fs::copy(&input, d.join("capsule.obj")).unwrap();
    let o = run(&["bake", "capsule.obj", "-o", "c.sphb", "-q", "--spheres", "8", "--voxels", "32"], d);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // Small settings per command (each is seeded, so deterministic), with --json where it exists.
    let commands: [(&str, &[&str]); 5] = [
        ("eval", &["--json", "--surface-samples", "500"]),
        ("shadows", &["--json", "--resolution", "4", "--rays", "16"]),
        ("light", &["--json", "--resolution", "4", "--model-receivers", "8", "--rays", "16"]),
        ("pose", &["--json", "--time", "0"]),
        ("render", &["--size", "30x10"]),
    ];
    // What a run printed (or, for render, drew), without the timings (`*_seconds`).
    let result = |cmd: &str, model: &[&str], extra: &[&str], tag: &str| -> (Option<i32>, String) {
        let png = format!("{cmd}-{tag}.png");
        let mut args = vec![cmd, "c.sphb"];
        args.extend_from_slice(model);
        args.extend_from_slice(extra);
        if cmd == "render" {
            args.extend(["-o", png.as_str()]);
        }
        let o = run(&args, d);
        if cmd == "render" {
            let bytes = std::fs::read(d.join(&png)).unwrap_or_default();
            return (o.status.code(), format!("{bytes:?}"));
        }
        let kept: Vec<&str> =
            std::str::from_utf8(&o.stdout).unwrap().lines().filter(|l| !l.contains("_seconds\"")).collect();
        (o.status.code(), kept.join("\n") + &stderr(&o))
    };
    for (cmd, extra) in commands {
        let after_file = result(cmd, &["capsule.obj"], extra, "a");
        let option = result(cmd, &["--model", "capsule.obj"], extra, "b");
        let want = Some(0);
        assert_eq!(after_file.0, want, "{cmd} FILE MODEL");
        assert_eq!(option.0, want, "{cmd} FILE --model MODEL");
        assert_eq!(after_file.1, option.1, "{cmd}: the two spellings differ");
        assert!(after_file.1.len() > 20, "{cmd} wrote nothing: {}", after_file.1);
        // The command's other required arguments are given, so only the model can be wrong.
        let required: &[&str] = match cmd {
            "render" => &["-o", "x.png"],
            "pose" => &["--time", "0"],
            _ => &[],
        };
        let neither = run(&[&[cmd, "c.sphb"], required].concat(), d);
        assert_eq!(neither.status.code(), Some(2), "{cmd} without a model: {}", stderr(&neither));
        assert!(stderr(&neither).contains("required arguments were not provided:\n  <MODEL>"), "{}", stderr(&neither));
        let both = run(&[&[cmd, "c.sphb", "capsule.obj", "--model", "capsule.obj"], required].concat(), d);
        assert_eq!(both.status.code(), Some(2), "{cmd} with the model twice: {}", stderr(&both));
        assert!(stderr(&both).contains("cannot be used with '--model"), "{}", stderr(&both));
    }
}

/// clap appends `[default: …]` to an option's help itself: a help text that also states the
/// default printed it twice (`eval --voxels`, `render --size`).
#[test]
fn no_help_line_states_its_default_twice() {
    let dir = tempfile::tempdir().unwrap();
    for cmd in ["bake", "inspect", "eval", "export", "render", "shadows", "pose", "light"] {
        let o = run(&[cmd, "--help"], dir.path());
        assert_eq!(o.status.code(), Some(0));
        let help = String::from_utf8_lossy(&o.stdout).into_owned();
        // One entry per argument: it starts at its name (`-x`, `--long`, `<ARG>`, `[ARG]`,
        // indented by at most 6 columns) and runs on over the lines of its text (long help puts
        // the text, and clap its `[default: …]`, on lines of their own, indented by 10).
        let mut entries: Vec<String> = Vec::new();
        for line in help.lines() {
            let indent = line.len() - line.trim_start().len();
            if (indent <= 6 && line.trim_start().starts_with(['-', '<', '['])) || entries.is_empty() {
                entries.push(String::new());
            }
            entries.last_mut().unwrap().push_str(line);
        }
        for e in &entries {
            assert!(e.matches("[default:").count() <= 1, "{cmd} --help states a default twice: {e}");
        }
    }
}

#[test]
fn export_reimports_with_the_right_nodes_and_render_writes_a_nonblank_png() {
    let dir = tempfile::tempdir().unwrap();
    let input = repo().join("fixtures/capsule.obj");
    assert_eq!(run(&["bake", input.to_str().unwrap(), "-o", "c.sphb"], dir.path()).status.code(), Some(0));
    let file = spherebake_format::read(&std::fs::read(dir.path().join("c.sphb")).unwrap()).unwrap();
    let o = run(&["export", "c.sphb", "-o", "c.glb"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let g = gltf::Gltf::from_slice(&std::fs::read(dir.path().join("c.glb")).unwrap()).expect("valid glb");
    let levels = spherebake_bake::export::hierarchy_levels(&file).len();
    let has_samples = file.samples.as_ref().is_some_and(|s| s.total() > 0);
    assert_eq!(g.nodes().count(), 1 + levels + usize::from(has_samples));
    // The leaf level holds one icosphere (42 vertices) per sphere.
    let leaf = g.meshes().find(|m| m.name() == Some("level 0 (leaves)")).expect("leaf level mesh");
    let count = leaf.primitives().next().unwrap().get(&gltf::Semantic::Positions).unwrap().count();
    assert_eq!(count, 42 * file.spheres.len());

    let o =
        run(&["render", "c.sphb", "--model", input.to_str().unwrap(), "-o", "c.png", "--size", "240x90"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let img = image::open(dir.path().join("c.png")).unwrap().to_rgb8();
    assert_eq!((img.width(), img.height()), (240, 90));
    let distinct: std::collections::BTreeSet<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    assert!(distinct.len() > 10, "picture looks blank: {} colours", distinct.len());
    assert_eq!(
        run(&["render", "c.sphb", "--model", "x.obj", "-o", "d.png", "--size", "12"], dir.path()).status.code(),
        Some(2)
    );
}

#[test]
fn batch_keeps_going_skips_up_to_date_and_writes_depfiles() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Two good assets (one textured, with a texture beside it) and one broken one.
    std::fs::write(d.join("tet.obj"), "mtllib tet.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl m\nf 1/1 3/3 2/2\nf 1/1 2/2 4/3\nf 1/1 4/3 3/2\nf 2/1 3/2 4/3\n").unwrap();
    std::fs::write(d.join("tet.mtl"), "newmtl m\nKd 1 1 1\nmap_Kd tex.png\n").unwrap();
    image::RgbImage::from_pixel(2, 2, image::Rgb([200, 10, 10])).save(d.join("tex.png")).unwrap();
    std::fs::copy(repo().join("fixtures/capsule.obj"), d.join("capsule.obj")).unwrap();
    let _ = std::fs::copy(repo().join("fixtures/capsule.mtl"), d.join("capsule.mtl"));
    std::fs::write(d.join("broken.obj"), "v 0 0 0\nf 1 2 3\n").unwrap();

    let o = run(&["bake", "tet.obj", "capsule.obj", "broken.obj", "--out-dir", "out", "--depfile", "--json"], d);
    assert_eq!(o.status.code(), Some(1), "one asset failed: exit 1");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["baked"], 2);
    assert_eq!(v["failed"], 1);
    assert!(d.join("out/tet.sphb").exists() && d.join("out/capsule.sphb").exists());
    assert!(!d.join("out/broken.sphb").exists());
    let dep = std::fs::read_to_string(d.join("out/tet.sphb.d")).unwrap();
    assert!(dep.starts_with("out/tet.sphb:"), "{dep}");
    for f in ["tet.obj", "tet.mtl", "tex.png"] {
        assert!(dep.contains(f), "depfile lists {f}: {dep}");
    }

    // Second run: nothing to bake.
    let o = run(&["bake", "tet.obj", "capsule.obj", "--out-dir", "out", "--json"], d);
    assert_eq!(o.status.code(), Some(0));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!((v["baked"].as_u64(), v["up_to_date"].as_u64()), (Some(0), Some(2)), "{v}");

    // Touching (changing) the texture re-bakes that asset only; other settings re-bake too.
    image::RgbImage::from_pixel(2, 2, image::Rgb([10, 200, 10])).save(d.join("tex.png")).unwrap();
    let o = run(&["bake", "tet.obj", "capsule.obj", "--out-dir", "out", "--json"], d);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!((v["baked"].as_u64(), v["up_to_date"].as_u64()), (Some(1), Some(1)), "{v}");
    assert_eq!(v["assets"][0]["status"], "baked");
    let o = run(&["bake", "capsule.obj", "--out-dir", "out", "--json", "--spheres", "9"], d);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["baked"], 1, "changed settings re-bake");
    let o = run(&["bake", "capsule.obj", "--out-dir", "out", "--json", "--spheres", "9", "--force"], d);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["baked"], 1, "--force re-bakes");
}

#[test]
fn config_file_sets_per_asset_settings_and_flags_override() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(repo().join("fixtures/capsule.obj"), d.join("capsule.obj")).unwrap();
    let _ = std::fs::copy(repo().join("fixtures/capsule.mtl"), d.join("capsule.mtl"));
    std::fs::write(d.join("spherebake.toml"), "[defaults]\nspheres = 5\n[[asset]]\nglob = \"caps*.obj\"\nseed = 7\n")
        .unwrap();
    let settings = |args: &[&str]| {
        let o = run(args, d);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let o = run(&["inspect", "c.sphb", "--json"], d);
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        v["metadata"]["settings"].clone()
    };
    let s = settings(&["bake", "capsule.obj", "-o", "c.sphb"]);
    assert_eq!((s["spheres"].as_u64(), s["seed"].as_u64()), (Some(5), Some(7)), "{s}");
    let s = settings(&["bake", "capsule.obj", "-o", "c.sphb", "--spheres", "6"]);
    assert_eq!((s["spheres"].as_u64(), s["seed"].as_u64()), (Some(6), Some(7)), "{s}");
    std::fs::write(d.join("spherebake.toml"), "[defaults]\nsphers = 5\n").unwrap();
    let o = run(&["bake", "capsule.obj", "-o", "c.sphb"], d);
    assert_eq!(o.status.code(), Some(2), "a typo in the config is a usage error");
    assert!(stderr(&o).contains("spherebake.toml"), "{}", stderr(&o));
    // A value out of range in the config names the config (the message names the setting by
    // its flag); the same value from the command line does not.
    std::fs::write(d.join("spherebake.toml"), "[defaults]\nspheres = 9000\n").unwrap();
    let o = run(&["bake", "capsule.obj", "-o", "c.sphb"], d);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("9000") && stderr(&o).contains("(set in spherebake.toml)"), "{}", stderr(&o));
    std::fs::write(d.join("spherebake.toml"), "[defaults]\nseed = 3\n").unwrap();
    let o = run(&["bake", "capsule.obj", "-o", "c.sphb", "--spheres", "9000"], d);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("9000") && !stderr(&o).contains("set in"), "{}", stderr(&o));
}

#[test]
fn preset_from_the_flag_or_the_config_reaches_the_fit_and_rebakes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(repo().join("fixtures/capsule.obj"), d.join("capsule.obj")).unwrap();
    let _ = std::fs::copy(repo().join("fixtures/capsule.mtl"), d.join("capsule.mtl"));
    let bake = |args: &[&str], out: &str| -> (Vec<u8>, serde_json::Value) {
        let mut all = vec!["bake", "capsule.obj", "-o", out, "-q", "--spheres", "12", "--voxels", "48"];
        all.extend_from_slice(args);
        let o = run(&all, d);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let o = run(&["inspect", out, "--json"], d);
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        (std::fs::read(d.join(out)).unwrap(), v["metadata"]["settings"].clone())
    };
    let (default, s0) = bake(&[], "default.sphb");
    let (fast, s1) = bake(&["--preset", "fast"], "fast.sphb");
    let (best, s2) = bake(&["--preset", "best"], "best.sphb");
    // The default is not recorded (files baked before presets keep their bytes); others are.
    assert!(s0.get("preset").is_none(), "{s0}");
    assert_eq!((s1["preset"].as_str(), s2["preset"].as_str()), (Some("fast"), Some("best")));
    // Fast does less work: other spheres. Best keeps the lowest E of four seeds, the first
    // being the default's run, so it may be the default's file.
    assert!(fast != default && fast != best, "the preset changes the spheres");
    let e = |f: &str| -> f64 {
        let o = run(&["eval", f, "capsule.obj", "--json"], d);
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        v["outside_ratio_e"].as_f64().unwrap()
    };
    assert!(e("best.sphb") <= e("default.sphb"), "best {} default {}", e("best.sphb"), e("default.sphb"));
    assert_eq!(bake(&["--preset", "default"], "d2.sphb").0, default);
    // The same preset from spherebake.toml gives the flag's file; the flag overrides it.
    std::fs::write(d.join("spherebake.toml"), "[[asset]]\nglob = \"*.obj\"\npreset = \"fast\"\n").unwrap();
    assert_eq!(bake(&[], "toml.sphb").0, fast);
    assert_eq!(bake(&["--preset", "best"], "over.sphb").0, best);
    std::fs::write(d.join("spherebake.toml"), "[defaults]\npreset = \"quick\"\n").unwrap();
    let o = run(&["bake", "capsule.obj", "-o", "x.sphb"], d);
    assert_eq!(o.status.code(), Some(2), "an unknown preset is a usage error");
    assert!(stderr(&o).contains("unknown preset"), "{}", stderr(&o));
    std::fs::remove_file(d.join("spherebake.toml")).unwrap();
    // Up-to-date check: a preset change re-bakes, the same preset again does not.
    let batch = |args: &[&str]| -> serde_json::Value {
        let mut all = vec!["bake", "capsule.obj", "--out-dir", "out", "--json", "--spheres", "12", "--voxels", "48"];
        all.extend_from_slice(args);
        serde_json::from_slice(&run(&all, d).stdout).unwrap()
    };
    assert_eq!(batch(&[])["baked"], 1);
    assert_eq!(batch(&[])["up_to_date"], 1);
    assert_eq!(batch(&["--preset", "fast"])["baked"], 1, "a preset change re-bakes");
    assert_eq!(batch(&["--preset", "fast"])["up_to_date"], 1);
}

/// `--preset fast` bakes at its own voxel grid (96 cells) unless `--voxels` is given, and `eval`
/// measures against the grid the file records: an open box's solid is the voxel solid, so its
/// E moves with the grid (0.971 at 96, 0.964 at 40, 1.005 at 128 on this box).
#[test]
fn fast_bakes_at_its_own_voxel_grid_and_eval_measures_at_the_recorded_one() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A box 1 × 0.7 × 0.37 without its top: its walls fall between cells differently per grid.
    std::fs::write(
        d.join("open.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 0.7 0\nv 0 0.7 0\nv 0 0 0.37\nv 1 0 0.37\nv 1 0.7 0.37\nv 0 0.7 0.37\n\
         f 1 4 3 2\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n",
    )
    .unwrap();
    let bake = |extra: &[&str], out: &str| -> (f64, serde_json::Value) {
        let mut all = vec!["bake", "open.obj", "-o", out, "--json", "--spheres", "8", "--preset", "fast"];
        all.extend_from_slice(extra);
        let o = run(&all, d);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let e = v["assets"][0]["outside_ratio_e"].as_f64().unwrap();
        let o = run(&["inspect", out, "--json"], d);
        let i: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        (e, i["metadata"]["settings"].clone())
    };
    let eval = |f: &str, extra: &[&str]| -> (f64, u64) {
        let mut all = vec!["eval", f, "open.obj", "--json", "--surface-samples", "2000"];
        all.extend_from_slice(extra);
        let o = run(&all, d);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        (v["outside_ratio_e"].as_f64().unwrap(), v["voxels"].as_u64().unwrap())
    };
    let (e96, s96) = bake(&[], "fast.sphb");
    assert_eq!(s96["voxels"], 96, "{s96}");
    let (e40, s40) = bake(&["--voxels", "40"], "fast40.sphb");
    assert_eq!(s40["voxels"], 40, "{s40}");
    for (f, e, n) in [("fast.sphb", e96, 96), ("fast40.sphb", e40, 40)] {
        let (got, voxels) = eval(f, &[]);
        assert_eq!(voxels, n);
        assert!((got - e).abs() <= 1e-9 * e, "{f}: eval {got} against the bake's {e}");
        // Another grid is another solid, and another E.
        let (other, voxels) = eval(f, &["--voxels", "128"]);
        assert_eq!(voxels, 128);
        assert!((other - e).abs() > 1e-3, "{f}: {other} at 128 against {e} at {n}");
    }
}

#[test]
fn target_mode_warns_once_and_keeps_its_stage_times_and_trace() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let model = repo().join("fixtures/capsule.obj");
    let args = ["bake", model.to_str().unwrap(), "-o", "t.sphb", "--max-outside-ratio", "0.3", "--voxels", "48"];
    let o = run(&[&args[..], &["-v"]].concat(), d);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    let lines: Vec<&str> = out.lines().filter(|l| l.contains("warning") && l.contains("target mode")).collect();
    assert_eq!(lines.len(), 1, "the target-mode result is printed once: {out}");
    // -v prints the trace: every run (at least the first count, 8) from dense points to exact E
    // and the enclosing ball it is compared with.
    let trace: Vec<&str> = out.lines().filter(|l| l.trim_start().starts_with("trace")).collect();
    assert!(trace.first().is_some_and(|l| l.contains("k 8") && l.contains("dense_points")), "{out}");
    assert!(trace.last().is_some_and(|l| l.contains("enclosing_ball")), "{out}");
    let o = run(&[&args[..], &["--json", "--force"]].concat(), d);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let rep = &v["assets"][0]["report"];
    let warnings = rep["warnings"].as_array().unwrap();
    let n = warnings.iter().filter(|w| w.as_str().is_some_and(|w| w.contains("target mode"))).count();
    assert_eq!(n, 1, "{warnings:?}");
    // The stage times of the runs are reported: the fit's stages with positive seconds.
    let fit_stages = rep["fit_stages"].as_array().unwrap();
    for st in ["lloyd", "polish", "descent", "bound", "exact_e"] {
        let secs = fit_stages.iter().find(|t| t["stage"] == st).and_then(|t| t["seconds"].as_f64());
        assert!(secs.is_some_and(|s| s > 0.0), "{st}: {fit_stages:?}");
    }
    // And the JSON trace has an exact E for every count tried (two where a second start ran),
    // the first at 8 spheres.
    let trace = rep["fit_trace"].as_array().unwrap();
    let runs: Vec<&serde_json::Value> = trace.iter().filter(|e| e["stage"] == "exact_e").collect();
    assert!(!runs.is_empty() && runs[0]["spheres"] == 8, "{trace:?}");
    let counts = |stage: &str| -> std::collections::BTreeSet<u64> {
        trace.iter().filter(|e| e["stage"] == stage).filter_map(|e| e["spheres"].as_u64()).collect()
    };
    assert_eq!(counts("dense_points"), counts("exact_e"), "{trace:?}");
    assert_eq!(trace.iter().filter(|e| e["stage"] == "dense_points").count(), counts("dense_points").len());
}

#[test]
fn eval_matches_the_analytic_outside_volume_of_a_sphere_around_a_cube() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("cube.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\n\
         f 1 3 4\nf 1 4 2\nf 5 6 8\nf 5 8 7\nf 1 2 6\nf 1 6 5\nf 3 7 8\nf 3 8 4\nf 1 5 7\nf 1 7 3\nf 2 4 8\nf 2 8 6\n",
    )
    .unwrap();
    let r = 0.9f32; // > √3/2: the cube is inside, so V(S ∩ T) = 1.
    let file = spherebake_format::SphbFile {
        spheres: vec![spherebake_format::Sphere { center: [0.5, 0.5, 0.5], radius: r }],
        ..Default::default()
    };
    std::fs::write(d.join("one.sphb"), spherebake_format::write(&file)).unwrap();
    let o = run(&["eval", "one.sphb", "cube.obj", "--json", "--surface-samples", "20000"], d);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let expected = 4.0 / 3.0 * std::f64::consts::PI * (r as f64).powi(3) - 1.0;
    let e = v["outside_ratio_e"].as_f64().unwrap();
    assert!((e - expected).abs() < 1e-9 * expected, "E {e} vs analytic {expected}");
    assert_eq!(v["surface_coverage"].as_f64(), Some(1.0));
    assert_eq!(v["sphere_count"], 1);
    // No surface points is a usage error, not a coverage of 1 over nothing.
    let o = run(&["eval", "one.sphb", "cube.obj", "--json", "--surface-samples", "0"], d);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));

    // A sphere that misses a corner region leaves surface points uncovered.
    let file = spherebake_format::SphbFile {
        spheres: vec![spherebake_format::Sphere { center: [0.5, 0.5, 0.5], radius: 0.6 }],
        ..Default::default()
    };
    std::fs::write(d.join("small.sphb"), spherebake_format::write(&file)).unwrap();
    let o = run(&["eval", "small.sphb", "cube.obj", "--json", "--surface-samples", "20000"], d);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let cov = v["surface_coverage"].as_f64().unwrap();
    assert!(cov < 0.9 && cov > 0.1, "coverage {cov}");
    // Outside volume of the r = 0.6 ball: six caps of height r − 0.5 (math reference §6:
    // 0.1068141502 at r = 0.6 exactly; here at the stored f32 radius).
    let r = 0.6f32 as f64;
    let h = r - 0.5;
    let expected = 6.0 * std::f64::consts::PI * h * h * (3.0 * r - h) / 3.0;
    assert!((expected - 0.1068141502).abs() < 1e-6);
    let e = v["outside_ratio_e"].as_f64().unwrap();
    assert!((e - expected).abs() < 1e-9 * expected, "E {e} vs {expected}");
}

#[test]
fn eval_warns_when_the_model_is_not_the_one_baked() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let capsule = repo().join("fixtures/capsule.obj");
    let capsule = capsule.to_str().unwrap();
    let o = run(&["bake", capsule, "-o", "capsule.sphb", "--spheres", "8"], d);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = run(&["eval", "capsule.sphb", capsule, "--json", "--surface-samples", "2000"], d);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["input_hash_matches"], true);
    assert_eq!(v["surface_coverage"].as_f64(), Some(1.0));
    // Another model: still measured (exit 0), with a warning naming the file.
    std::fs::write(d.join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let o = run(&["eval", "capsule.sphb", "tri.obj", "--json", "--surface-samples", "2000"], d);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("warning: capsule.sphb was baked from another input"), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["input_hash_matches"], false);
}

/// A batch's table counts each asset's warnings (before, a batch without -v said nothing of
/// them: skipped primitives, open meshes), and says -v lists them.
#[test]
fn the_batch_table_counts_each_assets_warnings() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A library that does not exist and a line element: two warnings; the capsule with its
    // library: none.
    std::fs::write(
        d.join("warned.obj"),
        "mtllib nowhere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nl 1 2\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
    )
    .unwrap();
    std::fs::copy(repo().join("fixtures/capsule.obj"), d.join("capsule.obj")).unwrap();
    std::fs::copy(repo().join("fixtures/capsule.mtl"), d.join("capsule.mtl")).unwrap();
    let single = |name: &str| {
        let o = run(&["bake", name, "-o", &format!("{name}.sphb"), "--spheres", "4", "--json", "--force"], d);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        v["assets"][0]["report"]["warnings"].as_array().map_or(0, Vec::len)
    };
    let (w_warned, w_capsule) = (single("warned.obj"), single("capsule.obj"));
    assert!(w_warned > 0 && w_capsule == 0, "{w_warned} {w_capsule}");
    let o = run(&["bake", "warned.obj", "capsule.obj", "--out-dir", "out", "--spheres", "4"], d);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let header = out.lines().next().unwrap();
    let col = header.split_whitespace().position(|c| c == "warnings").expect("a warnings column");
    for (name, want) in [("warned.obj", w_warned), ("capsule.obj", w_capsule)] {
        let row = out.lines().find(|l| l.starts_with(name)).expect("a row");
        // "time (s)" is two words in the header.
        assert_eq!(row.split_whitespace().nth(col - 1), Some(want.to_string().as_str()), "{out}");
    }
    assert!(out.contains("(-v lists each asset's warnings)"), "{out}");
}

/// `inspect` on a file that is neither a mesh (by extension) nor a `.sphb` (by magic) names its
/// type, as `bake` does, instead of reporting a malformed `.sphb` header; a `.sphb` under
/// another extension is still read.
#[test]
fn inspect_names_an_unknown_file_type() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("horse.ply"), "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n").unwrap();
    let o = run(&["inspect", "horse.ply"], d);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line expected: {err}");
    assert!(err.contains("horse.ply") && err.contains("unknown file type \"ply\""), "{err}");
    let input = repo().join("fixtures/capsule.obj");
    assert_eq!(run(&["bake", input.to_str().unwrap(), "-o", "c.sphb"], d).status.code(), Some(0));
    std::fs::copy(d.join("c.sphb"), d.join("c.bin")).unwrap();
    let o = run(&["inspect", "c.bin"], d);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// `bake` and `inspect` name the same edge counts for an open, non-manifold mesh: a cube
/// missing one face (4 boundary edges) with a fin on one of its edges (that edge used three
/// times; the fin's two other edges are boundary edges), counted by hand: 6 and 1.
#[test]
fn bake_and_inspect_count_problem_edges_alike() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut obj = String::new();
    for v in ["0 0 0", "1 0 0", "1 1 0", "0 1 0", "0 0 1", "1 0 1", "1 1 1", "0 1 1", "0.5 -1 -1"] {
        obj += &format!("v {v}\n");
    }
    // The cube's faces but the top (y = 1) pair, then the fin on edge 1–2.
    for f in ["1 3 2", "1 4 3", "5 6 7", "5 7 8", "1 2 6", "1 6 5", "2 3 7", "2 7 6", "4 1 5", "4 5 8", "1 2 9"] {
        obj += &format!("f {f}\n");
    }
    std::fs::write(d.join("fin.obj"), obj).unwrap();
    let o = run(&["inspect", "fin.obj", "--json"], d);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(
        (v["topology"]["boundary_edges"].as_u64(), v["topology"]["non_manifold_edges"].as_u64()),
        (Some(6), Some(1))
    );
    let o = run(&["bake", "fin.obj", "-o", "fin.sphb", "--spheres", "4", "--voxels", "32", "--json"], d);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let warnings = v["assets"][0]["report"]["warnings"].as_array().unwrap();
    assert!(
        warnings.iter().any(|w| w.as_str().unwrap().starts_with("mesh not closed (6 boundary edges, 1 non-manifold)")),
        "{warnings:?}"
    );
}
