//! OBJ + MTL import from bytes (issue 17). Input: the OBJ text up to the first line `#MTL`, the
//! MTL text after it; a fixed in-memory resolver serves the MTL under every `mtllib` name the
//! seeds use and an empty file for textures. Any result is fine; a panic, hang or huge
//! allocation is a bug.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fuzz_target!(|data: &[u8]| {
    let cut = data.windows(6).position(|w| w == b"\n#MTL\n");
    let (obj, mtl) = match cut {
        Some(i) => (&data[..i + 1], &data[i + 6..]),
        None => (data, &[][..]),
    };
    let dir = PathBuf::from("/fuzz/asset");
    let mut files = BTreeMap::new();
    for n in ["a.mtl", "capsule.mtl", "m.mtl"] {
        files.insert(dir.join(n), mtl.to_vec());
    }
    for n in ["tex.png", "a.png"] {
        files.insert(dir.join(n), Vec::new());
    }
    let opts = spherebake_io::ImportOptions { allow_outside_paths: false, max_input_bytes: 64 << 20, ..Default::default() };
    let _ = spherebake_io::load_mesh_from_memory(Path::new("/fuzz/asset/a.obj"), obj, files, &opts);
});
