//! `bench level-cv`: where the per-level nearest-neighbour CV comes from. Samples a model with
//! the paper's parameters and with each pair of cross-level exponents given (`p,q`: the finer
//! particle's push across a level boundary scaled by (σ_fine/σ_coarse)^p, the coarser one's by
//! (σ_fine/σ_coarse)^q), and prints per depth level the particle count, the CV and the mean
//! spacing, split into particles inside their level (their 7 nearest particles all at the same
//! depth) and at a boundary between levels.
//!
//! `cargo xtask bench level-cv ../shared/models/bunny.ply 1.5,1 2.5,1`

use std::collections::BTreeMap;

use psi::octree::PointIndex;
use psi::particles::nearest_neighbour_distances;
use psi::{Mpu, MpuParams, ParticleParams, Particles};

/// Mean and coefficient of variation std/mean of `d` (0 when empty).
fn mean_cv(d: &[f64]) -> (f64, f64) {
    let n = d.len().max(1) as f64;
    let mean = d.iter().sum::<f64>() / n;
    let var = d.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n;
    (mean, if mean > 0.0 { var.sqrt() / mean } else { 0.0 })
}

/// Per depth: "depth:count cv (inside cv mean / boundary cv mean)", means relative to the
/// level's mean spacing.
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
            let (m, cv) = mean_cv(all);
            let (mi, cvi) = mean_cv(inside);
            let (mb, cvb) = mean_cv(boundary);
            format!(
                "{depth}:{} {cv:.3} ({cvi:.3} {:.2} / {cvb:.3} {:.2})",
                all.len(),
                mi / m,
                mb / m
            )
        })
        .collect::<Vec<_>>()
        .join("  ")
}

pub(crate) fn run(args: &[String]) -> anyhow::Result<()> {
    let mut args = args.iter().cloned();
    let points = super::load_model(args.next().as_ref())?;
    let mpu = Mpu::build(&points, &MpuParams::paper())?;
    let paper = ParticleParams::paper();
    let mut runs = vec![("paper".to_owned(), paper)];
    for pq in args {
        let (p, q) = pq
            .split_once(',')
            .ok_or_else(|| anyhow::anyhow!("expected p,q, got {pq}"))?;
        let params = ParticleParams {
            cross_level_exponents: (p.parse()?, q.parse()?),
            ..paper
        };
        runs.push((format!("cross {pq}"), params));
    }
    println!(
        "depth:count CV (inside CV mean / boundary CV mean), after {} iterations",
        paper.iterations
    );
    for (name, params) in runs {
        let run = psi::sample(&mpu, &params);
        println!("{name:>12}: {}", levels(&run.particles));
    }
    Ok(())
}
