//! Measures the albedo stage on the shared models (issue 7):
//!
//! - wall time of `bake_albedo` at 64 spheres, 32² faces, order 4, on the current rayon pool
//!   (run with `RAYON_NUM_THREADS=2` for the 2-core target);
//! - SH error against a 512² reference for face sizes 8 … 128, with the footprint mip level
//!   and with the base level only.
//!
//! Spheres: `spherebake_fit::fit` (variational, 64 spheres, default settings) on the welded mesh.
//! Orientation: `spherebake_geom::orient::outward_orientation`.
//!
//! `cargo run --release -p spherebake-bake --example albedo_measure [-- MODEL...]`
//! (`ALBEDO_ERROR_SIZES=0` skips the error table, `ALBEDO_DEBUG_DIR=DIR` writes debug crosses).

use spherebake_bake::{bake_albedo, AlbedoSettings, TextureLod};
use spherebake_geom::winding::WindingNumber;
use std::path::PathBuf;
use std::time::Instant;

fn main() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/models");
    let args: Vec<String> = std::env::args().skip(1).collect();
    let models: Vec<PathBuf> = if args.is_empty() {
        vec![root.join("gltf/CesiumMan.glb"), root.join("obj/spot/spot.obj")]
    } else {
        args.iter().map(PathBuf::from).collect()
    };
    let error_sizes = std::env::var("ALBEDO_ERROR_SIZES").map_or(true, |v| v != "0");
    for path in models {
        if !path.exists() {
            println!("{}: not found, skipped", path.display());
            continue;
        }
        let imported = spherebake_io::load_mesh(&path).expect("import");
        let mesh = imported.mesh;
        let t = Instant::now();
        let wn = WindingNumber::new(&mesh.positions, &mesh.triangles);
        let orient = spherebake_geom::orient::outward_orientation(&mesh.positions, &mesh.triangles, &wn);
        let orient_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let fit = spherebake_fit::fit(
            &mesh.welded_positions,
            &mesh.welded_triangles(),
            &spherebake_fit::FitSettings::default(),
            &|_| {},
        )
        .expect("fit");
        let fit_s = t.elapsed().as_secs_f64();
        let spheres: Vec<[f32; 4]> = fit.spheres.clone();
        println!(
            "{}: {} triangles, {} spheres (fit {:.2} s), orientation {:.2} s ({} flipped, {} ambiguous)",
            path.file_name().unwrap().to_string_lossy(),
            mesh.triangles.len(),
            spheres.len(),
            fit_s,
            orient_s,
            orient.flipped,
            orient.ambiguous
        );
        let flip = orient.flip;
        // Timing: best of 5 at the default settings.
        let s = AlbedoSettings::default();
        let mut best = f64::INFINITY;
        let mut stats = None;
        for _ in 0..5 {
            let t = Instant::now();
            let (_, st) = bake_albedo(&mesh, &flip, &spheres, &s).expect("albedo");
            best = best.min(t.elapsed().as_secs_f64());
            stats = Some(st);
        }
        let st = stats.unwrap();
        if let Ok(dir) = std::env::var("ALBEDO_DEBUG_DIR") {
            let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
            let s = AlbedoSettings { debug_dir: Some(PathBuf::from(dir).join(stem)), ..Default::default() };
            let (_, st) = bake_albedo(&mesh, &flip, &spheres, &s).expect("albedo");
            println!("  wrote {} debug images", st.debug_files.len());
        }
        println!(
            "  albedo 32², order 4, {} threads: {:.3} s (best of 5); texels rule1 {} rule2 {} rule3 {} empty {}; \
             triangle assignments {} ({} shared)",
            rayon::current_num_threads(),
            best,
            st.texels_rule1,
            st.texels_rule2,
            st.texels_rule3,
            st.texels_empty,
            st.triangle_assignments,
            st.shared_triangles
        );
        if !error_sizes {
            continue;
        }
        let run = |n: usize, lod: TextureLod| {
            let s = AlbedoSettings { sh_order: 4, cubemap_size: n, texture_lod: lod, ..Default::default() };
            bake_albedo(&mesh, &flip, &spheres, &s).expect("albedo").0.coefficients
        };
        // One reference for both LOD modes: footprint LOD at 512² faces.
        let reference = run(512, TextureLod::Footprint);
        let ref_rms = rms(&reference, None);
        println!("  reference 512², order 4: RMS coefficient {ref_rms:.4}");
        for lod in [TextureLod::Footprint, TextureLod::Base] {
            print!("  {lod:?}: RMS error (max abs error) vs reference:");
            for n in [8, 16, 32, 64, 128] {
                let c = run(n, lod);
                print!(" {n}: {:.5} ({:.4})", rms(&c, Some(&reference)), max_abs(&c, &reference));
            }
            println!();
        }
    }
}

/// RMS over all coefficients and channels of `a − b` (or of `a`).
fn rms(a: &[[f32; 3]], b: Option<&[[f32; 3]]>) -> f64 {
    let mut s = 0.0;
    for (i, x) in a.iter().enumerate() {
        for k in 0..3 {
            let d = f64::from(x[k]) - b.map_or(0.0, |b| f64::from(b[i][k]));
            s += d * d;
        }
    }
    (s / (3 * a.len()).max(1) as f64).sqrt()
}

/// Largest |a − b| over all coefficients and channels.
fn max_abs(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| (0..3).map(move |k| (f64::from(x[k]) - f64::from(y[k])).abs()))
        .fold(0.0, f64::max)
}
