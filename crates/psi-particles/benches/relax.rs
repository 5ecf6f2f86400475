//! Seeding and 20 relaxation iterations on the built-in model's MPU, and the ratio the issue
//! tracks: simulation time / (N × iterations × one `value_and_gradient`).

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use psi_mpu::{Mpu, MpuParams};
use psi_particles::{ParticleParams, RelaxOptions, initialize, relax};

fn relaxation(c: &mut Criterion) {
    let points = psi_shapes::builtin_model();
    let mpu = Mpu::build(&points, &MpuParams::paper()).unwrap();
    let params = ParticleParams::paper();
    let mut group = c.benchmark_group("particles_builtin");
    group.sample_size(10);
    group.bench_function("seed", |b| b.iter(|| black_box(initialize(&mpu, &params))));
    let psi_particles::Seeding {
        particles: seeds,
        density: field,
        ..
    } = initialize(&mpu, &params);
    group.bench_function("relax_20", |b| {
        b.iter(|| {
            let mut p = seeds.clone();
            relax(&mpu, &mut p, &field, &params, RelaxOptions::default());
            black_box(p)
        })
    });
    group.finish();
    // Distance to the evaluation floor.
    let t = Instant::now();
    let mut p = seeds.clone();
    relax(&mpu, &mut p, &field, &params, RelaxOptions::default());
    let sim = t.elapsed().as_secs_f64();
    let t = Instant::now();
    for x in &seeds.positions {
        black_box(mpu.value_and_gradient(*x));
    }
    let eval = t.elapsed().as_secs_f64() / seeds.len() as f64;
    println!(
        "simulation / (N × iterations × value_and_gradient) = {:.2}",
        sim / (seeds.len() as f64 * params.iterations as f64 * eval)
    );
}

criterion_group!(benches, relaxation);
criterion_main!(benches);
