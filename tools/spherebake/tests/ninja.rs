//! The guide's Ninja integration, for real: a generated `build.ninja` over generated assets with
//! `depfile` / `deps = gcc`; a second run does no work, editing a texture rebuilds exactly the
//! one output that uses it, touching an input without a change costs one up-to-date check, and a broken asset fails its edge while `ninja -k 0` builds the rest.
//! Needs `ninja` on PATH (Debian package `ninja-build`; `.ci/run` installs it).

use std::path::Path;
use std::process::{Command, Output};

const CUBE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
f 1 4 3\nf 1 3 2\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 4 8 7\nf 4 7 3\nf 1 5 8\nf 1 8 4\nf 2 3 7\nf 2 7 6\n";

fn ninja(dir: &Path, args: &[&str]) -> Output {
    match Command::new("ninja").args(args).current_dir(dir).output() {
        Ok(o) => o,
        Err(e) => panic!(
            "cannot run ninja ({e}): install the Debian package ninja-build (apt-get install ninja-build); \
             .ci/run installs it"
        ),
    }
}

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

fn mtime(p: &Path) -> std::time::SystemTime {
    std::fs::metadata(p).unwrap().modified().unwrap()
}

/// The cube with texture coordinates on every face and material `m` of library `mtllib`.
fn textured_cube(mtllib: &str) -> String {
    let mut tex = format!("mtllib {mtllib}\nusemtl m\nvt 0 0\nvt 1 0\nvt 1 1\n");
    tex += &CUBE_OBJ.replace("\nf ", "\n#f ");
    for line in CUBE_OBJ.lines().filter(|l| l.starts_with("f ")) {
        let v: Vec<&str> = line[2..].split(' ').collect();
        tex += &format!("f {}/1 {}/2 {}/3\n", v[0], v[1], v[2]);
    }
    tex
}

/// `textured.obj` + `textured.mtl` + `tex.png`, `plain.obj`, `other.obj`, and the build file.
fn write_project(d: &Path) {
    std::fs::create_dir_all(d.join("assets")).unwrap();
    std::fs::write(d.join("assets/plain.obj"), CUBE_OBJ).unwrap();
    std::fs::write(d.join("assets/other.obj"), CUBE_OBJ.replace("v 1 1 1", "v 1.5 1.5 1.5")).unwrap();
    std::fs::write(d.join("assets/textured.obj"), textured_cube("textured.mtl")).unwrap();
    std::fs::write(d.join("assets/textured.mtl"), "newmtl m\nKd 1 1 1\nmap_Kd tex.png\n").unwrap();
    image::RgbImage::from_pixel(4, 4, image::Rgb([200, 30, 30])).save(d.join("assets/tex.png")).unwrap();
    let exe = env!("CARGO_BIN_EXE_spherebake");
    let mut b = format!(
        "rule sphb\n  command = {exe} bake $in -o $out --depfile -q --spheres 4 --method kmeans\n  \
         depfile = $out.d\n  deps = gcc\n  description = SPHB $out\n"
    );
    for n in ["plain", "textured", "other"] {
        b += &format!("build out/{n}.sphb: sphb assets/{n}.obj\n");
    }
    std::fs::write(d.join("build.ninja"), b).unwrap();
}

#[test]
fn ninja_builds_incrementally_from_depfiles_and_keeps_going() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    write_project(d);
    let o = ninja(d, &[]);
    assert!(o.status.success(), "{}", text(&o));
    for n in ["plain", "textured", "other"] {
        assert!(d.join(format!("out/{n}.sphb")).is_file(), "{n} built");
    }
    // deps = gcc: ninja read the depfile (the texture is a dependency) and removed it.
    let deps = ninja(d, &["-t", "deps", "out/textured.sphb"]);
    assert!(text(&deps).contains("assets/tex.png"), "{}", text(&deps));

    // Second run: nothing to do.
    let o = ninja(d, &[]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("no work to do"), "{}", text(&o));

    // Editing the texture rebuilds exactly the textured output.
    let before: Vec<_> =
        ["plain", "textured", "other"].iter().map(|n| mtime(&d.join(format!("out/{n}.sphb")))).collect();
    std::thread::sleep(std::time::Duration::from_millis(20));
    image::RgbImage::from_pixel(4, 4, image::Rgb([30, 30, 200])).save(d.join("assets/tex.png")).unwrap();
    let o = ninja(d, &[]);
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    assert!(t.contains("[1/1]") && t.contains("out/textured.sphb"), "exactly one edge: {t}");
    let after: Vec<_> =
        ["plain", "textured", "other"].iter().map(|n| mtime(&d.join(format!("out/{n}.sphb")))).collect();
    assert_eq!((before[0], before[2]), (after[0], after[2]), "other outputs untouched");
    assert!(after[1] > before[1], "textured output rebuilt");
    let o = ninja(d, &[]);
    assert!(text(&o).contains("no work to do"), "{}", text(&o));

    // An input touched without a change (a `git checkout`, a `touch`): ninja runs the edge
    // once, the tool finds the output up to date and marks it as made, and the next run has
    // nothing to do (without the mark, ninja ran the edge on every build).
    let content = std::fs::read(d.join("out/plain.sphb")).unwrap();
    std::thread::sleep(std::time::Duration::from_millis(20));
    std::fs::File::options()
        .append(true)
        .open(d.join("assets/plain.obj"))
        .unwrap()
        .set_modified(std::time::SystemTime::now())
        .unwrap();
    let o = ninja(d, &[]);
    assert!(text(&o).contains("out/plain.sphb") && text(&o).contains("[1/1]"), "{}", text(&o));
    assert_eq!(std::fs::read(d.join("out/plain.sphb")).unwrap(), content, "not re-baked");
    let o = ninja(d, &[]);
    assert!(text(&o).contains("no work to do"), "{}", text(&o));

    // A broken asset fails its edge; -k 0 still builds the others.
    for n in ["plain", "textured", "other"] {
        std::fs::remove_file(d.join(format!("out/{n}.sphb"))).unwrap();
    }
    std::fs::write(d.join("assets/other.obj"), "v 0 0 0\nf 1 2 3\n").unwrap();
    let o = ninja(d, &["-k", "0"]);
    assert!(!o.status.success(), "the broken edge fails: {}", text(&o));
    let t = text(&o);
    assert!(t.contains("FAILED") && t.contains("out/other.sphb"), "{t}");
    assert!(t.contains("spherebake: error: assets/other.obj"), "the error names the asset: {t}");
    assert!(d.join("out/plain.sphb").is_file() && d.join("out/textured.sphb").is_file());
    assert!(!d.join("out/other.sphb").exists(), "no output for the broken asset");
    let left: Vec<_> = std::fs::read_dir(d.join("out"))
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

/// A texture the model names but that does not exist yet (a warning at bake time) is still a
/// dependency: the depfile lists it with an empty rule (as `gcc -MP` does for headers), so once
/// it appears Ninja rebuilds the output, and the tool's own up-to-date check re-bakes too.
#[test]
fn a_missing_texture_that_appears_rebuilds_the_output() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    std::fs::create_dir_all(d.join("assets")).unwrap();
    std::fs::write(d.join("assets/late.obj"), textured_cube("late.mtl")).unwrap();
    std::fs::write(d.join("assets/late.mtl"), "newmtl m\nKd 1 1 1\nmap_Kd late.png\n").unwrap();
    let exe = env!("CARGO_BIN_EXE_spherebake");
    let build = format!(
        "rule sphb\n  command = {exe} bake $in -o $out --depfile -q --spheres 4 --method kmeans\n  \
         depfile = $out.d\n  deps = gcc\nbuild out/late.sphb: sphb assets/late.obj\n"
    );
    std::fs::write(d.join("build.ninja"), build).unwrap();
    let o = ninja(d, &[]);
    assert!(o.status.success(), "{}", text(&o));
    let deps = ninja(d, &["-t", "deps", "out/late.sphb"]);
    assert!(text(&deps).contains("assets/late.png"), "the missing texture is a dependency: {}", text(&deps));
    let dc = |d: &Path| {
        let f = spherebake_format::read(&std::fs::read(d.join("out/late.sphb")).unwrap()).unwrap();
        f.albedo_sh.unwrap().coefficients[0]
    };
    let white = dc(d);
    // The texture appears (red): Ninja rebuilds, the albedo turns red, then nothing is left to do.
    std::thread::sleep(std::time::Duration::from_millis(20));
    image::RgbImage::from_pixel(4, 4, image::Rgb([220, 20, 20])).save(d.join("assets/late.png")).unwrap();
    let o = ninja(d, &[]);
    assert!(o.status.success() && text(&o).contains("out/late.sphb"), "rebuilt: {}", text(&o));
    let red = dc(d);
    assert!(red[0] > 2.0 * red[1] && white[0] == white[1], "white {white:?} -> red {red:?}");
    let o = ninja(d, &[]);
    assert!(text(&o).contains("no work to do"), "{}", text(&o));

    // Without a build system: the tool's up-to-date check sees the texture appear too.
    std::fs::remove_file(d.join("assets/late.png")).unwrap();
    let run = |args: &[&str]| Command::new(exe).args(args).current_dir(d).output().unwrap();
    let o = run(&["bake", "assets/late.obj", "-o", "plain.sphb", "--spheres", "4", "--method", "kmeans"]);
    assert!(o.status.success());
    let o = run(&["bake", "assets/late.obj", "-o", "plain.sphb", "--spheres", "4", "--method", "kmeans", "--json"]);
    assert_eq!(serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()["up_to_date"], 1);
    image::RgbImage::from_pixel(4, 4, image::Rgb([220, 20, 20])).save(d.join("assets/late.png")).unwrap();
    let o = run(&["bake", "assets/late.obj", "-o", "plain.sphb", "--spheres", "4", "--method", "kmeans", "--json"]);
    assert_eq!(
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()["baked"],
        1,
        "re-baked once the texture exists"
    );
}

/// A material library the OBJ names but that does not exist yet is recorded like a missing
/// texture: the depfile lists it, and the up-to-date check re-bakes once it appears.
#[test]
fn a_missing_material_library_that_appears_rebakes() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    std::fs::write(d.join("m.obj"), format!("mtllib later.mtl\nusemtl red\n{CUBE_OBJ}")).unwrap();
    let exe = env!("CARGO_BIN_EXE_spherebake");
    let run = |extra: &[&str]| {
        let mut args = vec!["bake", "m.obj", "-o", "m.sphb", "--spheres", "4", "--method", "kmeans", "--json"];
        args.extend_from_slice(extra);
        let o = Command::new(exe).args(&args).current_dir(d).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()
    };
    let v = run(&["--depfile"]);
    assert_eq!(v["baked"], 1);
    let dep = std::fs::read_to_string(d.join("m.sphb.d")).unwrap();
    assert!(dep.contains("later.mtl") && dep.contains("\nlater.mtl:\n"), "{dep}");
    assert_eq!(run(&[])["up_to_date"], 1);
    std::fs::write(d.join("later.mtl"), "newmtl red\nKd 1 0 0\n").unwrap();
    assert_eq!(run(&[])["baked"], 1, "re-baked once the library exists");
}
