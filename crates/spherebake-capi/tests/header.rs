//! include/spherebake.h is what cbindgen generates from this crate with cbindgen.toml: the test
//! regenerates it and fails on any difference (SPHEREBAKE_BLESS=1 rewrites the committed file).

use std::path::Path;

#[test]
fn committed_header_is_the_generated_one() {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(crate_dir.join("cbindgen.toml")).expect("cbindgen.toml parses");
    let bindings = cbindgen::Builder::new()
        .with_crate(crate_dir)
        .with_config(config)
        .generate()
        .expect("cbindgen generates the header");
    let mut generated = Vec::new();
    bindings.write(&mut generated);
    let path = crate_dir.join("../../include/spherebake.h");
    if std::env::var_os("SPHEREBAKE_BLESS").is_some() {
        std::fs::write(&path, &generated).unwrap();
    }
    let committed = std::fs::read(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "include/spherebake.h differs from cbindgen's output; regenerate it with \
         SPHEREBAKE_BLESS=1 cargo test -p spherebake-capi --test header"
    );
}

/// The float constant written by hand into the header (cbindgen.toml `after_includes`, for its `f`
/// suffix) is the Rust one: its digits parse to the same f32.
#[test]
fn the_theta_define_is_the_rust_constant_as_a_float() {
    let header = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../include/spherebake.h"))
        .expect("header");
    let line = header.lines().find(|l| l.starts_with("#define SPHB_DEFAULT_THETA_MAX_RAD ")).expect("the define");
    let literal = line.trim_start_matches("#define SPHB_DEFAULT_THETA_MAX_RAD ");
    let digits = literal.strip_suffix('f').expect("an f suffix");
    assert_eq!(digits.parse::<f32>().unwrap(), spherebake::SPHB_DEFAULT_THETA_MAX_RAD);
}
