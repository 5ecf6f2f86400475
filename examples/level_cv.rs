//! Development aid: where the per-level nearest-neighbour CV comes from. For the paper's
//! relaxation and for variants with σ pinned to c·σ̂ (no Witkin–Heckbert σ adaptation), prints
//! per depth level the particle count and CV, split into particles inside their level (their
//! 7 nearest particles all at the same depth) and at a boundary between levels.
//!
//! `cargo run --release --example level_cv -- ../shared/models/bunny.ply`

use std::collections::BTreeMap;

use psi::octree::PointIndex;
use psi::particles::{RelaxRegion, initialize, nearest_neighbour_distances, relax};
use psi::{Mpu, MpuParams, ParticleParams, Particles};

/// Coefficient of variation std/mean of `d` (0 when empty).
fn cv(d: &[f64]) -> f64 {
    let n = d.len().max(1) as f64;
    let mean = d.iter().sum::<f64>() / n;
    let var = d.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n;
    if mean > 0.0 { var.sqrt() / mean } else { 0.0 }
}

/// Per depth: "depth:count cv (inside cv / boundary cv)".
fn levels(p: &Particles) -> String {
    let index = PointIndex::new(&p.positions);
    let nn = nearest_neighbour_distances(&p.positions);
    // depth → (all, inside, boundary) nearest-neighbour distances.
    let mut by_depth: BTreeMap<u8, [Vec<f64>; 3]> = BTreeMap::new();
    for (i, &d) in nn.iter().enumerate() {
        let near = index.nearest(p.positions[i], 7);
        let inside = near.iter().all(|&(j, _)| p.depth[j as usize] == p.depth[i]);
        let groups = by_depth.entry(p.depth[i]).or_default();
        groups[0].push(d);
        groups[if inside { 1 } else { 2 }].push(d);
    }
    by_depth
        .iter()
        .map(|(depth, [all, inside, boundary])| {
            format!(
                "{depth}:{} {:.3} ({:.3}/{:.3})",
                all.len(),
                cv(all),
                cv(inside),
                cv(boundary)
            )
        })
        .collect::<Vec<_>>()
        .join("  ")
}

fn main() -> anyhow::Result<()> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "../shared/models/bunny.ply".into());
    let points = psi::load_points(std::path::Path::new(&path), &psi::ReadOptions::paper())?.points;
    let mpu = Mpu::build(&points, &MpuParams::paper())?;
    let paper = ParticleParams::paper();
    let pinned = ParticleParams {
        adapt_sigma: false,
        sigma_clamp: (1.0, 1.0),
        ..paper
    };
    let runs = [
        ("paper", paper, 1.0),
        ("σ = 0.55 σ̂", pinned, 0.55),
        ("σ = 0.6 σ̂", pinned, 0.6),
    ];
    println!(
        "depth:count CV (inside / boundary), after {} iterations",
        paper.iterations
    );
    for (name, params, c) in runs {
        let (mut particles, mut field, _) = initialize(&mpu, &params);
        field.scale *= c;
        for i in 0..particles.len() {
            particles.sigma[i] *= c;
            particles.target[i] *= c;
        }
        relax(
            &mpu,
            &mut particles,
            &field,
            &params,
            RelaxRegion::default(),
        );
        println!("{name:>12}: {}", levels(&particles));
    }
    Ok(())
}
