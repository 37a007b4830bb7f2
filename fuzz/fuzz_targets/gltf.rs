//! glTF / GLB import from bytes (issue 17). Input: byte 0 picks `.glb` (odd) or `.gltf` (even),
//! bytes 1..5 (u32 LE, modulo the rest) split the rest into the model and one side file, which a
//! fixed in-memory resolver serves under every name the fixtures use (`*.bin`, `*.png`), so
//! external buffers and images are reached without touching the file system. Any result is
//! fine; a panic, hang or huge allocation is a bug.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

const SIDE_NAMES: &[&str] =
    &["a.bin", "a.png", "textured-cube.bin", "textured-cube.png", "skinned-arm.c.bin", "skinned-arm.bin"];

fuzz_target!(|data: &[u8]| {
    if data.len() < 5 {
        return;
    }
    let glb = data[0] & 1 == 1;
    let rest = &data[5..];
    let split = u32::from_le_bytes([data[1], data[2], data[3], data[4]]) as usize % (rest.len() + 1);
    let (model, side) = rest.split_at(split);
    let mut files = BTreeMap::new();
    for n in SIDE_NAMES {
        files.insert(PathBuf::from("/fuzz/asset").join(n), side.to_vec());
    }
    let path = if glb { Path::new("/fuzz/asset/a.glb") } else { Path::new("/fuzz/asset/a.gltf") };
    let opts = spherebake_io::ImportOptions { allow_outside_paths: false, max_input_bytes: 64 << 20, ..Default::default() };
    let _ = spherebake_io::load_mesh_from_memory(path, model, files, &opts);
});
