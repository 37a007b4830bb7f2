//! Times `load` on baked files: median and minimum of 51 loads each, with the bytes per second.
//! Used to choose dequantise-on-load for compact files (docs/benchmarks.md, "File size").
//! `cargo run --release -p spherebake-runtime --example load_files -- A.sphb B.sphb ...`

use std::time::Instant;

fn main() {
    for path in std::env::args().skip(1) {
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("{path}: {e}");
                std::process::exit(1);
            }
        };
        let mut times = Vec::with_capacity(51);
        for _ in 0..51 {
            let t = Instant::now();
            let proxy = spherebake_runtime::load(&bytes);
            times.push(t.elapsed().as_secs_f64());
            if let Err(e) = proxy {
                eprintln!("{path}: {e}");
                std::process::exit(1);
            }
        }
        times.sort_by(f64::total_cmp);
        let median = times[times.len() / 2];
        println!(
            "{path}: {} bytes, load median {:.1} µs (min {:.1} µs), {:.0} MB/s at the median",
            bytes.len(),
            median * 1e6,
            times[0] * 1e6,
            bytes.len() as f64 / median / 1e6
        );
    }
}
