//! Measures the sample-placement stage on every model in `../shared/models` (or the directory
//! given as the first argument): samples per sphere, empty shares by rule, and wall times
//! (median of 5) of the BVH build, the outward orientation and `place_samples`.
//!
//! Spheres: the pipeline's current fit (`bake_path` with `--spheres`, default 64).
//! Run: `cargo run --release -p spherebake-bake --example samples_report [dir] [spheres]`.

use spherebake_bake::samples::place_samples;
use spherebake_bake::BakeSettings;
use spherebake_geom::bvh::TriangleBvh;
use spherebake_geom::orient::outward_orientation;
use spherebake_geom::winding::WindingNumber;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn models(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else { return };
    let mut entries: Vec<PathBuf> = rd.filter_map(|e| e.ok().map(|e| e.path())).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            models(&p, out);
        } else if matches!(p.extension().and_then(|e| e.to_str()), Some("glb" | "gltf" | "obj")) {
            out.push(p);
        }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn timed<T>(runs: usize, mut f: impl FnMut() -> T) -> (T, f64) {
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..runs {
        let t = Instant::now();
        last = Some(f());
        times.push(t.elapsed().as_secs_f64());
    }
    (last.expect("runs > 0"), median(times))
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = args
        .get(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/models"));
    let count: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(64);
    let mut paths = Vec::new();
    models(&dir, &mut paths);
    println!("threads: {}", rayon::current_num_threads());
    println!(
        "| model | tris | spheres (skipped) | samples/sphere mean | min | spheres with 0 samples | rule 2 empty | rule 3 empty | place_samples s | BVH s | orient s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for path in paths {
        let settings = BakeSettings { spheres: count, ..Default::default() };
        let baked = match spherebake_bake::bake_path(&path, &settings, &|_| {}) {
            Ok(b) => b,
            Err(e) => {
                println!("| {} | not baked: {e} |", path.strip_prefix(&dir).unwrap_or(&path).display());
                continue;
            }
        };
        let spheres: Vec<[f32; 4]> =
            baked.file.spheres.iter().map(|s| [s.center[0], s.center[1], s.center[2], s.radius]).collect();
        let mesh = spherebake_io::load_mesh(&path).expect("loaded once already").mesh;
        let (bvh, bvh_s) = timed(5, || TriangleBvh::new(&mesh.positions, &mesh.triangles));
        let welded = mesh.welded_triangles();
        let (orient, orient_s) = timed(5, || {
            let w = WindingNumber::new(&mesh.welded_positions, &welded);
            outward_orientation(&mesh.welded_positions, &welded, &w)
        });
        let ((_, stats), place_s) = timed(5, || place_samples(&mesh, &bvh, &orient.flip, &spheres));
        let name = path.strip_prefix(&dir).unwrap_or(&path).display();
        let skipped = stats.per_sphere.iter().filter(|c| c.skipped > 0).count();
        let empty = stats.per_sphere.iter().filter(|c| c.skipped == 0 && c.rule1 + c.rule3 == 0).count();
        println!(
            "| {name} | {} | {} ({skipped}) | {:.1} | {} | {empty} | {:.3} | {:.3} | {:.4} | {:.4} | {:.4} (flipped {}, ambiguous {}) |",
            mesh.triangles.len(),
            spheres.len(),
            stats.samples_per_sphere_mean,
            stats.samples_per_sphere_min,
            stats.share_rule2_empty,
            stats.share_rule3_empty,
            place_s,
            bvh_s,
            orient_s,
            orient.flipped,
            orient.ambiguous
        );
    }
}
