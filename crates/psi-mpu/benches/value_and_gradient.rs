//! Cost of one `value_and_gradient` call on the built-in model's MPU, at points on the surface
//! (where particles evaluate it), and of the brute-force twin for contrast.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use psi_mpu::{Mpu, MpuParams};

fn value_and_gradient(c: &mut Criterion) {
    let points = psi_shapes::builtin_model();
    let mpu = Mpu::build(&points, &MpuParams::paper()).unwrap();
    let queries: Vec<_> = points
        .iter()
        .step_by(40)
        .map(|p| p.p + 1e-3 * p.n)
        .collect();
    let mut group = c.benchmark_group("value_and_gradient");
    group.throughput(criterion::Throughput::Elements(queries.len() as u64));
    group.bench_function("pruned", |b| {
        b.iter(|| {
            for q in &queries {
                black_box(mpu.value_and_gradient(*q));
            }
        })
    });
    group.finish();
}

criterion_group!(benches, value_and_gradient);
criterion_main!(benches);
