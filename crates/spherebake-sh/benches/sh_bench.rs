//! Micro-benchmarks at SH order 4: the SH exponential (accurate, PS*, OL, HYB) of a representative log-visibility
//! vector, and the per-sphere accumulation f += w_l F_l(θ) y_lm(s) of the runtime query.
//!
//! ```text
//! cargo bench -p spherebake-sh --bench sh_bench
//! ```

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use spherebake_sh::{
    accumulate_log_visibility_f32, log_visibility_zh, sh_exp_accurate, sh_exp_hyb, sh_exp_ol, sh_exp_ol_f32,
    sh_exp_ps_star, zh_rotate, TripleProduct, HYB_DEFAULT_NORM_BOUND,
};
use std::hint::black_box;

const ORDER: usize = 4;
const NC: usize = ORDER * ORDER;
const SPHERES: usize = 1024;

/// Deterministic pseudo-random numbers in [0, 1).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    fn dir(&mut self) -> [f64; 3] {
        let z = 2.0 * self.next() - 1.0;
        let phi = 2.0 * std::f64::consts::PI * self.next();
        let r = (1.0 - z * z).sqrt();
        [r * phi.cos(), r * phi.sin(), z]
    }
}

/// The log-visibility vector of four spheres of 10°..35° around a receiver (‖f̂‖ ≈ 2–3).
fn representative_log(rng: &mut Rng) -> [f64; NC] {
    let mut f = [0.0; NC];
    for _ in 0..4 {
        let mut zh = [0.0; ORDER];
        log_visibility_zh((10.0 + 25.0 * rng.next()).to_radians(), ORDER, &mut zh).unwrap();
        let mut v = [0.0; NC];
        zh_rotate(&zh, rng.dir(), &mut v).unwrap();
        for i in 0..NC {
            f[i] += v[i];
        }
    }
    f
}

fn bench_exp(c: &mut Criterion) {
    let tp = TripleProduct::new(ORDER).unwrap();
    let mut rng = Rng(0x9e3779b97f4a7c15);
    let f = representative_log(&mut rng);
    let f32in = f.map(|v| v as f32);
    let mut g = c.benchmark_group("exp_order4");
    g.throughput(Throughput::Elements(1));
    let mut out = [0.0; NC];
    g.bench_function("one_sh_product", |b| b.iter(|| tp.product(black_box(&f), black_box(&f), &mut out).unwrap()));
    g.bench_function("accurate", |b| b.iter(|| sh_exp_accurate(&tp, black_box(&f), &mut out).unwrap()));
    g.bench_function("ps_star_4", |b| b.iter(|| sh_exp_ps_star(&tp, black_box(&f), 4, &mut out).unwrap()));
    g.bench_function("ps_star_8", |b| b.iter(|| sh_exp_ps_star(&tp, black_box(&f), 8, &mut out).unwrap()));
    g.bench_function("hyb", |b| b.iter(|| sh_exp_hyb(&tp, black_box(&f), HYB_DEFAULT_NORM_BOUND, &mut out).unwrap()));
    g.bench_function("ol_f64", |b| b.iter(|| sh_exp_ol(ORDER, black_box(&f), &mut out).unwrap()));
    let mut out32 = [0.0f32; NC];
    g.bench_function("ol_f32", |b| b.iter(|| sh_exp_ol_f32(ORDER, black_box(&f32in), &mut out32).unwrap()));
    g.finish();
}

fn bench_accumulate(c: &mut Criterion) {
    let mut rng = Rng(0x2545f4914f6cdd1d);
    // Spheres around a receiver at the origin: centre distance 1..5, radius up to 0.9 × distance.
    let spheres: Vec<([f32; 3], f32)> = (0..SPHERES)
        .map(|_| {
            let d = 1.0 + 4.0 * rng.next();
            let s = rng.dir();
            ([(s[0] * d) as f32, (s[1] * d) as f32, (s[2] * d) as f32], (0.9 * d * rng.next()) as f32)
        })
        .collect();
    let pre: Vec<(f32, [f32; 3])> = spheres
        .iter()
        .map(|&(c, r)| {
            let d = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
            ((r / d).asin(), [c[0] / d, c[1] / d, c[2] / d])
        })
        .collect();
    let ones = [1.0f32; ORDER];
    let mut g = c.benchmark_group("accumulate_order4");
    g.throughput(Throughput::Elements(SPHERES as u64));
    g.bench_function("table_and_sh_eval", |b| {
        b.iter(|| {
            let mut f = [0.0f32; NC];
            for &(theta, s) in black_box(&pre) {
                accumulate_log_visibility_f32(theta, s, &ones, &mut f).unwrap();
            }
            f
        })
    });
    // The whole per-sphere step of the query: direction and angular radius from centre and radius, then accumulate.
    g.bench_function("with_geometry", |b| {
        let p = [0.01f32, -0.02, 0.03];
        b.iter(|| {
            let mut f = [0.0f32; NC];
            for &(c, r) in black_box(&spheres) {
                let v = [c[0] - p[0], c[1] - p[1], c[2] - p[2]];
                let d2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
                let inv = 1.0 / d2.sqrt();
                let theta = (r * inv).min(1.0).asin();
                accumulate_log_visibility_f32(theta, [v[0] * inv, v[1] * inv, v[2] * inv], &ones, &mut f).unwrap();
            }
            f
        })
    });
    g.finish();
}

criterion_group!(benches, bench_exp, bench_accumulate);
criterion_main!(benches);
