//! Quality figures of a particle set: surface adherence |f|/|∇f| over D, nearest-neighbour
//! spacing statistics overall and per depth level (algorithms.md §3).

use std::collections::BTreeMap;

use glam::DVec3;
use psi_mpu::Mpu;
use psi_octree::PointIndex;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::Particles;

/// Nearest-neighbour statistics of one group of particles (distances in world units).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SpacingStats {
    /// Particles in the group.
    pub count: usize,
    /// Mean nearest-neighbour distance.
    pub mean: f64,
    /// Smallest nearest-neighbour distance.
    pub min: f64,
    /// Coefficient of variation std/mean of the nearest-neighbour distance.
    pub cv: f64,
}

/// Spacing statistics of one depth level.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LevelStats {
    /// Octree depth.
    pub depth: u8,
    /// Statistics of the particles at that depth.
    pub spacing: SpacingStats,
}

/// Quality of a particle set.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Quality {
    /// Largest |f|/|∇f| over the particles, relative to D.
    pub max_surface_distance: f64,
    /// Mean |f|/|∇f|, relative to D.
    pub mean_surface_distance: f64,
    /// Nearest-neighbour statistics of all particles.
    pub spacing: SpacingStats,
    /// Per depth level.
    pub levels: Vec<LevelStats>,
}

fn stats(d: &[f64]) -> SpacingStats {
    if d.is_empty() {
        return SpacingStats::default();
    }
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let var = d.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n;
    let min = d.iter().copied().fold(f64::INFINITY, f64::min);
    SpacingStats {
        count: d.len(),
        mean,
        min,
        cv: if mean > 0.0 { var.sqrt() / mean } else { 0.0 },
    }
}

/// Distance from each point to its nearest other point (shape: N, world units; ∞ for N = 1).
pub fn nearest_neighbour_distances(positions: &[DVec3]) -> Vec<f64> {
    let all: Vec<u32> = (0..positions.len() as u32).collect();
    nearest_other_distances(&PointIndex::new(positions), positions, &all)
}

/// For each of `which` (indices into `positions`, shape: M), the distance to its nearest other
/// point (shape: M, world units; ∞ when there is none); `index` holds `positions`.
pub(crate) fn nearest_other_distances(
    index: &PointIndex,
    positions: &[DVec3],
    which: &[u32],
) -> Vec<f64> {
    which
        .par_iter()
        .map(|&i| {
            index
                .nearest(positions[i as usize], 2)
                .into_iter()
                .find(|(j, _)| *j != i)
                .map_or(f64::INFINITY, |(_, d2)| d2.sqrt())
        })
        .collect()
}

/// Measures `particles` on `mpu`.
pub fn measure_quality(mpu: &Mpu, particles: &Particles) -> Quality {
    quality_from_surface_distances(particles, &surface_distances(mpu, &particles.positions))
}

/// |f|/|∇f| of `mpu` at each of `positions` (shape: N, world units), relative to D (shape: N).
pub fn surface_distances(mpu: &Mpu, positions: &[DVec3]) -> Vec<f64> {
    let d = mpu.diagonal();
    positions
        .par_iter()
        .map(|x| {
            let (f, g) = mpu.value_and_gradient(*x);
            f.abs() / g.length().max(1e-300) / d
        })
        .collect()
}

/// The quality of `particles` given their surface distances (shape: N, relative to D, as
/// [`surface_distances`] gives them; measured by the caller, perhaps piece by piece).
pub fn quality_from_surface_distances(particles: &Particles, surface: &[f64]) -> Quality {
    let nn = nearest_neighbour_distances(&particles.positions);
    let mut by_depth: BTreeMap<u8, Vec<f64>> = BTreeMap::new();
    for (i, &dist) in nn.iter().enumerate() {
        by_depth.entry(particles.depth[i]).or_default().push(dist);
    }
    Quality {
        max_surface_distance: surface.iter().copied().fold(0.0, f64::max),
        mean_surface_distance: surface.iter().sum::<f64>() / surface.len().max(1) as f64,
        spacing: stats(&nn),
        levels: by_depth
            .into_iter()
            .map(|(depth, v)| LevelStats {
                depth,
                spacing: stats(&v),
            })
            .collect(),
    }
}
