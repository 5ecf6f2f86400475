//! MPU build time on the built-in model (and the bunny when `../shared/models` exists: see the
//! xtask for the paper-table timings).

use criterion::{Criterion, criterion_group, criterion_main};
use psi_mpu::{Mpu, MpuParams};

fn build(c: &mut Criterion) {
    let points = psi_shapes::builtin_model();
    let mut group = c.benchmark_group("mpu_build");
    group.sample_size(10);
    group.bench_function("builtin_80k", |b| {
        b.iter(|| Mpu::build(&points, &MpuParams::paper()).unwrap())
    });
    group.finish();
}

criterion_group!(benches, build);
criterion_main!(benches);
