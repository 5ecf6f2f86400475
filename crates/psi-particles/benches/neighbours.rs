//! Neighbour search over particle positions: the MPU octree as an adaptive grid, a kiddo kd-tree
//! and a uniform grid (the default), each built and queried once per relaxation iteration.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use psi_mpu::{Mpu, MpuParams};
use psi_octree::PointIndex;
use psi_particles::{GRID_EDGE_FACTOR, OctreeBuckets, ParticleGrid, ParticleParams, initialize};

fn neighbours(c: &mut Criterion) {
    let points = psi_shapes::builtin_model();
    let mpu = Mpu::build(&points, &MpuParams::paper()).unwrap();
    let particles = initialize(&mpu, &ParticleParams::paper()).particles;
    let origin = mpu.frame_origin();
    let local: Vec<_> = particles.positions.iter().map(|p| *p - origin).collect();
    let radii: Vec<f64> = particles.sigma.iter().map(|s| 3.0 * s).collect();
    let mut group = c.benchmark_group("neighbours_one_iteration");
    group.bench_function("octree", |b| {
        b.iter(|| {
            let buckets = OctreeBuckets::new(mpu.octree(), &local);
            let mut n = 0usize;
            for (x, r) in local.iter().zip(&radii) {
                buckets.for_each_within(*x, *r, |_| n += 1);
            }
            black_box(n)
        })
    });
    group.bench_function("kiddo", |b| {
        b.iter(|| {
            let index = PointIndex::new(&local);
            let mut out = Vec::new();
            let mut n = 0usize;
            for (x, r) in local.iter().zip(&radii) {
                out.clear();
                index.within(*x, *r, &mut out);
                n += out.len();
            }
            black_box(n)
        })
    });
    let edge = GRID_EDGE_FACTOR * radii.iter().sum::<f64>() / radii.len() as f64;
    group.bench_function("grid", |b| {
        b.iter(|| {
            let grid = ParticleGrid::new(&local, edge);
            let mut out = Vec::new();
            let mut n = 0usize;
            for (x, r) in local.iter().zip(&radii) {
                out.clear();
                grid.append_within(*x, *r, &mut out);
                n += out.len();
            }
            black_box(n)
        })
    });
    group.finish();
}

criterion_group!(benches, neighbours);
criterion_main!(benches);
