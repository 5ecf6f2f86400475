//! The whole job through the facade on the built-in model: MPU build, seeding and 20
//! iterations (`psi sample` without file IO). Per-operation benches live in each crate's
//! `benches/`; the paper's tables are timed by `cargo xtask reproduce-tables`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use psi::{Mpu, MpuParams, ParticleParams};

fn pipeline(c: &mut Criterion) {
    let points = psi::builtin_model();
    let mut group = c.benchmark_group("pipeline_builtin");
    group.sample_size(10);
    group.bench_function("build_and_sample", |b| {
        b.iter(|| {
            let mpu = Mpu::build(&points, &MpuParams::paper()).unwrap();
            black_box(psi::sample(&mpu, &ParticleParams::paper()).particles.len())
        })
    });
    group.finish();
}

criterion_group!(benches, pipeline);
criterion_main!(benches);
