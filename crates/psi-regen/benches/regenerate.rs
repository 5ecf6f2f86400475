//! One local brush edit on the built-in model (mark, refit, reseed, relax) versus a full
//! rebuild and sampling of the edited points.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use psi_mpu::MpuParams;
use psi_particles::ParticleParams;
use psi_regen::{Edit, Scene};

fn regenerate(c: &mut Criterion) {
    let points = psi_shapes::builtin_model();
    let (scene, _) = Scene::new(
        points.clone(),
        &MpuParams::paper(),
        &ParticleParams::paper(),
    )
    .unwrap();
    let edit = Edit::Brush {
        center: points[100].p,
        radius: 0.08,
        displacement: DVec3::new(0.0, 0.0, 0.02),
    };
    let mut group = c.benchmark_group("edit_builtin");
    group.sample_size(10);
    group.bench_function("local", |b| {
        b.iter(|| {
            let mut s = scene.clone();
            black_box(s.apply(&edit).unwrap())
        })
    });
    let (edited, _) = edit.apply(scene.points()).unwrap();
    group.bench_function("full", |b| {
        b.iter(|| {
            black_box(
                Scene::new(
                    edited.clone(),
                    &MpuParams::paper(),
                    &ParticleParams::paper(),
                )
                .unwrap(),
            )
        })
    });
    group.finish();
}

criterion_group!(benches, regenerate);
criterion_main!(benches);
