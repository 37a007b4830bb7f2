//! Writes small example `.sphb` files (the test fixtures) into a directory, e.g. to seed the fuzzer:
//! `cargo run -p spherebake-format --example write_examples -- fuzz/seeds`.

#[path = "../tests/common/mod.rs"]
mod common;

use spherebake_format::{write, write_compact, SphbFile, Sphere};

fn main() -> std::io::Result<()> {
    let dir = std::env::args().nth(1).unwrap_or_else(|| ".".into());
    std::fs::create_dir_all(&dir)?;
    let full = common::full_file();
    let minimal = SphbFile { spheres: vec![Sphere { center: [0.0, 0.0, 0.0], radius: 1.0 }], ..SphbFile::default() };
    let mut no_skin = full.clone();
    no_skin.skin = None;
    no_skin.bones = None;
    let unknown =
        common::assemble(1, 1, 64, &[(1, common::spheres_body(&[[0.0, 1.0, 0.0, 0.5]])), (42, vec![1, 2, 3, 4])]);
    for (name, bytes) in [
        ("full.sphb", write(&full)),
        // The compact kinds 8 (samples_q16) and 9 (albedo_sh_f16), format minor 1.
        ("full_compact.sphb", write_compact(&full).expect("the full fixture encodes")),
        ("minimal.sphb", write(&minimal)),
        ("no_skin.sphb", write(&no_skin)),
        ("unknown_section_minor1.sphb", unknown),
    ] {
        let path = std::path::Path::new(&dir).join(name);
        std::fs::write(&path, &bytes)?;
        println!("{} ({} bytes)", path.display(), bytes.len());
    }
    Ok(())
}
