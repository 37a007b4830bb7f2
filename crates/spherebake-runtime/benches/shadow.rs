//! Micro-benchmarks of the soft-shadow query at order 4: sphere–receiver log accumulations
//! (self-shadowing rules, table lookup, SH evaluation, weighted add) and the SH exponential.
//!
//! ```text
//! cargo bench -p spherebake-runtime --bench shadow
//! ```
//!
//! Accumulations per second = 64 × 64 / (time of `accumulate_64x64`).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use spherebake_runtime::shadow::{accumulate_log_visibility, ClusterBlockers, ExpMethod, ShadowContext};
use spherebake_runtime::Sphere;
use std::hint::black_box;

fn blockers() -> ClusterBlockers {
    let leaves: Vec<Sphere> = (0..64)
        .map(|i| {
            let a = i as f32 * 0.37;
            Sphere {
                center: [a.cos() * (1.0 + (i % 7) as f32 * 0.2), (i % 9) as f32 * 0.15 - 0.2, a.sin() * 1.3],
                radius: 0.1 + (i % 4) as f32 * 0.08,
            }
        })
        .collect();
    let mut cb = ClusterBlockers::new();
    cb.build(4, &leaves, None, [0.0, -0.3, 0.0], 0.2, 0.0).unwrap();
    cb
}

fn bench(c: &mut Criterion) {
    let cb = blockers();
    let receivers: Vec<[f32; 3]> = (0..64).map(|k| [(k % 8) as f32 * 0.05, -0.3, (k / 8) as f32 * 0.05]).collect();
    let mut g = c.benchmark_group("shadow");
    g.throughput(Throughput::Elements((cb.blockers().len() * receivers.len()) as u64));
    g.bench_function("accumulate_64x64", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for &p in &receivers {
                let mut log = [0.0f32; 16];
                accumulate_log_visibility(black_box(cb.blockers()), 4, p, Some([0.0, 1.0, 0.0]), &mut log).unwrap();
                acc += log[0];
            }
            acc
        })
    });
    g.finish();
    // A realistic summed log: 64 blockers seen from one receiver.
    let mut log = [0.0f32; 16];
    accumulate_log_visibility(cb.blockers(), 4, receivers[0], Some([0.0, 1.0, 0.0]), &mut log).unwrap();
    let mut g = c.benchmark_group("shadow_exp");
    g.throughput(Throughput::Elements(1));
    for (name, m) in [
        ("ps4", ExpMethod::PsStar { degree: 4 }),
        ("hyb", ExpMethod::Hyb { ol_norm_bound: 0.0 }),
        ("accurate", ExpMethod::Accurate),
    ] {
        let ctx = ShadowContext::new(4, m).unwrap();
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut out = [0.0f64; 16];
                ctx.visibility(black_box(&log), &mut out).unwrap();
                out[0]
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
