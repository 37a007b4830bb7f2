//! Helpers shared by spherebake's tests (a dev-dependency only; nothing ships with it).
//!
//! - [`shared_model`] / [`shared_models_dir`]: the one rule for tests that need the real models
//!   of `../shared/models` beside the repository: present → the path; absent → a message on
//!   stderr (which the harness shows even for passing tests with `--nocapture`, and always in
//!   its summary when the test fails) and `None`, or a failure when `SPHEREBAKE_REQUIRE_MODELS=1`
//!   (set by `.ci/run`: CI always has the models, so a skip there is a bug).
//! - [`oracle`]: an outside-volume oracle written apart from the fit (no shared code: this crate
//!   has no dependencies), the method of `../shared/tools/outside_volume.py` re-derived.
//! - [`rng`]: SplitMix64 for the tests of the runtime and spherebake-sh, which cannot reach
//!   `spherebake_geom::rng`.
//! - [`mesh`]: the test meshes several crates' tests build (the unit cube) and a minimal
//!   OBJ reader, as plain arrays.
//! - [`png`]: PNG chunks (with their CRC) for tests that build PNGs by hand.

pub mod mesh;
pub mod oracle;
pub mod png;
pub mod rng;

use std::path::{Path, PathBuf};

/// The environment variable that turns a missing shared model into a test failure.
pub const REQUIRE_MODELS: &str = "SPHEREBAKE_REQUIRE_MODELS";

/// `../shared/models` beside the repository (every crate sits two levels below the root).
fn models_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/models")
}

fn missing(p: &Path) -> Option<PathBuf> {
    assert!(std::env::var(REQUIRE_MODELS).as_deref() != Ok("1"), "{REQUIRE_MODELS}=1 but {} is missing", p.display());
    eprintln!("skipping: {} not found (../shared/models absent; {REQUIRE_MODELS}=1 makes this fail)", p.display());
    None
}

/// `../shared/models/<rel>` if it exists; otherwise a skip message on stderr and `None`.
///
/// # Panics
/// When the file is missing and `SPHEREBAKE_REQUIRE_MODELS=1`.
pub fn shared_model(rel: &str) -> Option<PathBuf> {
    let p = models_root().join(rel);
    if p.exists() {
        Some(p)
    } else {
        missing(&p)
    }
}

/// The `../shared/models` directory if it exists (for tests that walk every model); otherwise
/// a skip message on stderr and `None`.
///
/// # Panics
/// When the directory is missing and `SPHEREBAKE_REQUIRE_MODELS=1`.
pub fn shared_models_dir() -> Option<PathBuf> {
    let p = models_root();
    if p.is_dir() {
        Some(p)
    } else {
        missing(&p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::process::Command;

    /// Run only as a child of [`a_missing_model_skips_visibly_or_fails_when_required`].
    #[test]
    #[ignore = "a probe run by another test in a child process"]
    fn probe_missing_model() {
        if std::env::var_os("SPHEREBAKE_TESTKIT_PROBE").is_none() {
            return;
        }
        assert!(shared_model("no-such-dir/no-such-model.obj").is_none());
    }

    fn run_probe(require: Option<&str>) -> std::process::Output {
        let mut c = Command::new(std::env::current_exe().unwrap());
        c.args(["--exact", "tests::probe_missing_model", "--ignored", "--nocapture", "--test-threads", "1"]);
        c.env("SPHEREBAKE_TESTKIT_PROBE", "1").env_remove(REQUIRE_MODELS);
        if let Some(v) = require {
            c.env(REQUIRE_MODELS, v);
        }
        c.output().unwrap()
    }

    #[test]
    fn a_missing_model_skips_visibly_or_fails_when_required() {
        let skip = run_probe(None);
        let err = String::from_utf8_lossy(&skip.stderr);
        assert!(skip.status.success(), "{err}");
        assert!(err.contains("skipping: ") && err.contains("no-such-model.obj"), "skip message on stderr: {err}");
        let fail = run_probe(Some("1"));
        let out = format!("{}{}", String::from_utf8_lossy(&fail.stdout), String::from_utf8_lossy(&fail.stderr));
        assert!(!fail.status.success(), "with {REQUIRE_MODELS}=1 the missing model must fail the test");
        assert!(out.contains("SPHEREBAKE_REQUIRE_MODELS=1 but") && out.contains("no-such-model.obj"), "{out}");
        // Any other value keeps the skip.
        assert!(run_probe(Some("0")).status.success());
    }

    #[test]
    fn present_models_are_found() {
        // The README is there whenever the models are; without them this is the visible skip.
        if let Some(p) = shared_model("README.md") {
            assert!(p.is_file());
            assert_eq!(shared_models_dir().as_deref(), p.parent());
        }
    }
}
