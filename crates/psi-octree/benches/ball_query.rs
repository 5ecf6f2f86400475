//! Radius queries over the built-in model: the octree as a search structure versus kiddo 6.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use psi_octree::{Octree, OctreeParams, PointIndex};
use psi_shapes::builtin_model;

fn ball_query(c: &mut Criterion) {
    let points: Vec<DVec3> = builtin_model().iter().map(|p| p.p).collect();
    let tree = Octree::build(&points, &OctreeParams::mpu(), |v| v.points.len() > 16).unwrap();
    let index = PointIndex::new(&points);
    let radius = 0.02;
    let queries: Vec<DVec3> = points.iter().step_by(97).copied().collect();
    let mut group = c.benchmark_group("points_within_r0.02");
    group.bench_function("octree", |b| {
        let mut out = Vec::new();
        b.iter(|| {
            for q in &queries {
                out.clear();
                tree.points_within(*q, radius, &mut out);
                black_box(out.len());
            }
        })
    });
    group.bench_function("kiddo", |b| {
        let mut out = Vec::new();
        b.iter(|| {
            for q in &queries {
                out.clear();
                index.within(*q, radius, &mut out);
                black_box(out.len());
            }
        })
    });
    group.finish();
}

criterion_group!(benches, ball_query);
criterion_main!(benches);
