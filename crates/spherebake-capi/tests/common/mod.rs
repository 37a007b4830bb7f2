//! Helpers shared by the tests that build C and C++ programs.
#![allow(dead_code)] // Each test file uses a subset.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A golden fixture's bytes.
pub fn golden(name: &str) -> Vec<u8> {
    std::fs::read(repo().join("fixtures/golden").join(name)).unwrap()
}

/// An error record with every field set to a value no call leaves, so a test sees what the
/// call wrote.
pub fn new_err() -> spherebake::SphbError {
    spherebake::SphbError { code: -1, rule_id: 7, message: [1; spherebake::SPHB_MESSAGE_CAPACITY] }
}

/// The NUL-terminated message of `e`.
pub fn message(e: &spherebake::SphbError) -> String {
    let bytes: Vec<u8> = e.message.iter().take_while(|&&c| c != 0).map(|&c| c as u8).collect();
    String::from_utf8(bytes).unwrap()
}

/// `name` if it runs; otherwise fails with the Debian package to install (never a silent pass).
pub fn compiler(name: &str, package: &str) -> String {
    let ok = Command::new(name).arg("--version").output().is_ok_and(|o| o.status.success());
    assert!(
        ok,
        "no `{name}` on PATH: this test needs a system compiler; install the Debian package {package} \
         (.ci/run does: apt-get install {package})"
    );
    name.to_string()
}

/// A scratch directory of this test process (one per test binary and `tag`).
pub fn tempdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("spherebake-capi-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The static library of this crate, built now: `cargo test` builds only the rlib the tests link,
/// so this runs `cargo build -p spherebake-capi --lib` (a no-op when it is up to date) into this
/// test's target directory and profile, then returns target/<profile>/libspherebake.a.
pub fn static_lib() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let profile_dir = exe.parent().unwrap().parent().unwrap();
    let target_dir = profile_dir.parent().unwrap();
    let release = profile_dir.file_name().is_some_and(|n| n == "release");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.args(["build", "--quiet", "--locked", "-p", "spherebake-capi", "--lib"]).env("CARGO_TARGET_DIR", target_dir);
    if release {
        cmd.arg("--release");
    }
    let o = cmd.output().unwrap();
    assert!(o.status.success(), "cargo build of the static library failed: {}", String::from_utf8_lossy(&o.stderr));
    let p = profile_dir.join("libspherebake.a");
    assert!(p.is_file(), "cargo built no {}", p.display());
    p
}

/// Compiles `sources` with `cc` (`-std=<std>`, warnings as errors, no FP contraction, `include/`
/// and `examples/cpp/` on the include path) plus `extra` arguments into `out`; fails with the
/// compiler's message.
pub fn build(cc: &str, std: &str, sources: &[&Path], extra: &[OsString], out: &Path) {
    let o = Command::new(cc)
        .arg(format!("-std={std}"))
        .args(["-O2", "-ffp-contract=off", "-Wall", "-Wextra", "-Werror", "-pedantic"])
        .arg("-I")
        .arg(repo().join("include"))
        .arg("-I")
        .arg(repo().join("examples/cpp"))
        .args(sources)
        .args(extra)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{cc} {sources:?}: {}", String::from_utf8_lossy(&o.stderr));
}

/// C's `%a` of a double (glibc style: `0x1.8p+1`, `0x0p+0`) for zero and normal numbers.
pub fn hexf(v: f64) -> String {
    let sign = if v.is_sign_negative() { "-" } else { "" };
    if v == 0.0 {
        return format!("{sign}0x0p+0");
    }
    assert!(v.is_normal(), "only normal numbers are printed by the examples: {v}");
    let bits = v.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i64 - 1023;
    let mut mant = format!("{:013x}", bits & ((1u64 << 52) - 1));
    while mant.ends_with('0') {
        mant.pop();
    }
    let dot = if mant.is_empty() { String::new() } else { format!(".{mant}") };
    let es = if exp >= 0 { format!("+{exp}") } else { format!("{exp}") };
    format!("{sign}0x1{dot}p{es}")
}

/// `%a` of a float promoted to double, as C's printf prints it.
pub fn hf(v: f32) -> String {
    hexf(f64::from(v))
}

/// The static library and the system libraries a Rust staticlib needs on Linux.
pub fn link_static() -> Vec<OsString> {
    vec![static_lib().into(), "-lm".into(), "-lpthread".into(), "-ldl".into()]
}
