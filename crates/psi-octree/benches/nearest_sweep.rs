//! Every point's k nearest others in one sweep (`MortonIndex::map_nearest`), the search the
//! preprocessing runs over whole clouds: k = 16 (outliers) and k = 47 (normal estimation), on
//! 300 000 points of the built-in model with noise of about a tenth of their spacing.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use psi_octree::MortonIndex;
use psi_shapes::{gaussian_vector, sample_builtin};
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;

fn nearest_sweep(c: &mut Criterion) {
    let mut rng = Pcg64Mcg::seed_from_u64(5);
    let points: Vec<DVec3> = sample_builtin(300_000, 5)
        .iter()
        .map(|p| p.p + 2e-4 * gaussian_vector(&mut rng))
        .collect();
    let index = MortonIndex::new(&points);
    let mut group = c.benchmark_group("map_nearest_300k");
    group.sample_size(10);
    for k in [16, 47] {
        group.bench_function(format!("k{k}"), |b| {
            b.iter(|| black_box(index.map_nearest(k, |_, near| near[k - 1].1)))
        });
    }
    group.finish();
}

criterion_group!(benches, nearest_sweep);
criterion_main!(benches);
