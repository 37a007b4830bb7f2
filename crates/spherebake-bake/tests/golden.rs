//! Golden files: baking a fixture must reproduce `fixtures/golden/<name>.sphb` byte for byte.
//! Regenerate with `UPDATE_GOLDEN=1 cargo test -p spherebake-bake --test golden` and review the
//! diff (`spherebake inspect` both files) before committing: a change here changes what users get.

use spherebake_bake::{bake_path, BakeSettings};
use std::path::Path;

fn check(fixture: &str, golden: &str, settings: &BakeSettings) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures");
    let out = bake_path(&root.join(fixture), settings, &|_| {}).expect("bake");
    let golden_path = root.join("golden").join(golden);
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        std::fs::create_dir_all(golden_path.parent().unwrap()).unwrap();
        std::fs::write(&golden_path, &out.bytes).unwrap();
        return;
    }
    let want = std::fs::read(&golden_path).unwrap_or_else(|e| panic!("{}: {e}", golden_path.display()));
    if out.bytes != want {
        let got = spherebake_format::read(&out.bytes).expect("new bytes are valid");
        let old = spherebake_format::read(&want).expect("golden bytes are valid");
        panic!(
            "{fixture}: output differs from {} ({} vs {} bytes; spheres equal: {}, samples equal: {}, SH equal: {}). \
             If intended, regenerate with UPDATE_GOLDEN=1 and review.",
            golden_path.display(),
            out.bytes.len(),
            want.len(),
            got.spheres == old.spheres,
            got.samples == old.samples,
            got.albedo_sh == old.albedo_sh
        );
    }
}

#[test]
fn capsule_16_spheres() {
    check("capsule.obj", "capsule-16.sphb", &BakeSettings { spheres: 16, ..Default::default() });
}

#[test]
fn skinned_arm_16_spheres() {
    check("skinned-arm.gltf", "skinned-arm-16.sphb", &BakeSettings { spheres: 16, ..Default::default() });
}
