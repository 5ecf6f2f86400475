//! Initial particles from the MPU octree (paper §4): k per surface-containing leaf, the first
//! being the leaf's input point nearest the cell centre (already on the surface, no Newton
//! step); further ones are the leaf's points farthest from those taken, then random positions
//! in the cell projected by Newton steps. An exact count spreads quotas over the leaves.

use glam::DVec3;
use psi_mpu::Mpu;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;

use crate::project::newton_project;
use crate::{DensityMode, ParticleParams};

/// One seeded particle before densities are known.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Seed {
    pub(crate) p: DVec3,
    pub(crate) n: DVec3,
    pub(crate) depth: u8,
}

/// Quotas per surface leaf: k each, or an exact `count` apportioned by largest remainder with
/// weight 1 per leaf (adaptive: keeps one-per-cell density ratios) or edge² (uniform: ∝ area).
pub(crate) fn quotas(mpu: &Mpu, leaves: &[u32], params: &ParticleParams) -> Vec<usize> {
    let Some(count) = params.count else {
        return vec![params.k.max(1); leaves.len()];
    };
    let weights: Vec<f64> = leaves
        .iter()
        .map(|&l| match params.density {
            DensityMode::Adaptive => 1.0,
            DensityMode::Uniform => mpu.octree().cell(l).edge().powi(2),
        })
        .collect();
    let total: f64 = weights.iter().sum();
    let exact: Vec<f64> = weights.iter().map(|w| count as f64 * w / total).collect();
    let mut q: Vec<usize> = exact.iter().map(|e| e.floor() as usize).collect();
    let mut rest = count.saturating_sub(q.iter().sum::<usize>());
    // Largest fractional parts first; ties broken by a leaf hash so the extras spread evenly.
    let mut order: Vec<usize> = (0..leaves.len()).collect();
    order.sort_by(|&a, &b| {
        let fa = exact[a] - exact[a].floor();
        let fb = exact[b] - exact[b].floor();
        fb.total_cmp(&fa).then(spread_hash(a).cmp(&spread_hash(b)))
    });
    for &i in order.iter().cycle() {
        if rest == 0 {
            break;
        }
        q[i] += 1;
        rest -= 1;
    }
    q
}

/// A bijective scramble of an index (so "every m-th leaf" picks are spatially spread).
pub(crate) fn spread_hash(i: usize) -> u64 {
    let mut x = i as u64 ^ 0x9E37_79B9_7F4A_7C15;
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// Seeds `quota[i]` particles in surface leaf `leaves[i]`, in parallel; the output order is the
/// leaves' order whatever the thread count.
pub(crate) fn seed(
    mpu: &Mpu,
    leaves: &[u32],
    quota: &[usize],
    params: &ParticleParams,
) -> Vec<Seed> {
    let tol = params.newton_tolerance * mpu.diagonal();
    leaves
        .par_iter()
        .zip(quota)
        .flat_map_iter(|(&leaf, &q)| seed_leaf(mpu, leaf, q, params.seed, tol))
        .collect()
}

fn seed_leaf(mpu: &Mpu, leaf: u32, quota: usize, seed: u64, tol: f64) -> Vec<Seed> {
    let tree = mpu.octree();
    let cell = *tree.cell(leaf);
    let origin = mpu.frame_origin();
    let pts = tree.points_in(leaf);
    let mut out: Vec<Seed> = Vec::with_capacity(quota.min(1 << 16));
    if quota == 0 || pts.is_empty() {
        return out;
    }
    let input = mpu.points();
    let local = tree.positions();
    // First: the point nearest the centre (ties by index).
    let first = *pts
        .iter()
        .min_by(|&&a, &&b| {
            (local[a as usize] - cell.center)
                .length_squared()
                .total_cmp(&(local[b as usize] - cell.center).length_squared())
                .then(a.cmp(&b))
        })
        .expect("non-empty");
    let mut taken = vec![first];
    // Then farthest-point picks among the leaf's points.
    while taken.len() < quota.min(pts.len()) {
        let next = pts
            .iter()
            .copied()
            .filter(|p| !taken.contains(p))
            .max_by(|&a, &b| {
                let da = taken
                    .iter()
                    .map(|&t| (local[a as usize] - local[t as usize]).length_squared())
                    .fold(f64::INFINITY, f64::min);
                let db = taken
                    .iter()
                    .map(|&t| (local[b as usize] - local[t as usize]).length_squared())
                    .fold(f64::INFINITY, f64::min);
                da.total_cmp(&db).then(b.cmp(&a))
            });
        match next {
            Some(n)
                if taken
                    .iter()
                    .all(|&t| local[t as usize] != local[n as usize]) =>
            {
                taken.push(n)
            }
            _ => break,
        }
    }
    for &t in &taken {
        let p = input[t as usize];
        out.push(Seed {
            p: p.p,
            n: p.n,
            depth: cell.depth,
        });
    }
    // Then random positions in the cell, projected onto the surface (seeded per leaf).
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ spread_hash(leaf as usize));
    let mut attempts = 0;
    while out.len() < quota && attempts < quota.saturating_mul(64) {
        attempts += 1;
        let u = DVec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - DVec3::ONE;
        let x0 = origin + cell.center + cell.half * u;
        let on = newton_project(mpu, x0, tol, 8, cell.half, None);
        let (x, f, g) = (on.position, on.f, on.gradient);
        let inside = ((x - origin) - cell.center).abs().max_element() <= 1.5 * cell.half;
        if g.length_squared() > 0.0 && f.abs() <= tol * g.length() && inside {
            out.push(Seed {
                p: x,
                n: g.normalize(),
                depth: cell.depth,
            });
        }
    }
    // Exact counts never fall short: the remaining particles take the leaf's points again,
    // nudged along a tangent so that no two coincide.
    let mut i = 0;
    while out.len() < quota {
        let base = out[i % taken.len()];
        let t = base.n.any_orthonormal_vector();
        let shift = cell.half * 0.1 * (1 + i / taken.len()) as f64;
        out.push(Seed {
            p: base.p + shift * t.rotate_axis(base.n, i as f64),
            n: base.n,
            depth: cell.depth,
        });
        i += 1;
    }
    out
}
