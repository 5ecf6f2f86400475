//! Seeding for exact counts and uniform mode: dart throwing over the input points (a seeded
//! random order, each point accepted when no accepted point lies within c·(r_p + r_q)/2), the
//! scale c found by bisection so that at least the requested count is accepted, then the most
//! crowded extras removed. Radii r are the target σ̂ of the point's leaf (or one constant).

use std::collections::HashSet;

use glam::DVec3;
use psi_mpu::Mpu;
use psi_octree::{Monitor, PointIndex};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_pcg::Pcg64Mcg;

use crate::dart_grid::DartGrid;
use crate::seed::Seed;

/// Accepted input-point indices for scale `c` (radius of point i: c·radius[i]; `cell` ≥ every
/// c·(r_p + r_q)/2, the grid's cube edge). Stops early (a partial list) once `monitor`'s flag is
/// set.
fn throw(
    positions: &[DVec3],
    radius: &[f64],
    order: &[u32],
    (c, cell): (f64, f64),
    monitor: &Monitor<'_>,
) -> Vec<u32> {
    let mut grid = DartGrid::new(cell, order.len() / 4);
    let mut accepted = Vec::new();
    for (k, &i) in order.iter().enumerate() {
        if k % 65_536 == 0 && monitor.stopped() {
            break;
        }
        let p = positions[i as usize];
        let taken = grid.any_around(p, |j, q| {
            let r = 0.5 * c * (radius[i as usize] + radius[j as usize]);
            (q - p).length_squared() < r * r
        });
        if !taken {
            grid.insert(i, p);
            accepted.push(i);
        }
    }
    accepted
}

/// Whether a throw whose darts lie at least `spacing` apart (world units; c·r_min) may accept
/// `count` of `positions`: false when fewer half-open cubes of edge spacing/√3 hold points
/// (two darts in one cube would be closer than `spacing`; the edge is shrunk by 1e-9 against
/// rounding). True whenever that bound cannot be read (no spacing, or cubes too small for
/// exact integer keys).
fn may_accept(positions: &[DVec3], spacing: f64, count: usize) -> bool {
    let edge = spacing / 3f64.sqrt() * (1.0 - 1e-9);
    let reach = positions
        .iter()
        .fold(0.0f64, |m, p| m.max(p.abs().max_element()));
    if !(edge > 0.0 && reach / edge < 1e15) {
        return true;
    }
    let mut cubes = HashSet::new();
    positions.iter().any(|p| {
        cubes.insert((*p / edge).floor().to_array().map(|x| x as i64));
        cubes.len() >= count
    })
}

/// Exactly `count` seeds from `mpu`'s input points with spacing proportional to
/// `radius_of(depth)`; `None` when the input has fewer usable points than `count`.
pub(crate) fn poisson_seeds(
    mpu: &Mpu,
    count: usize,
    radius_of: &dyn Fn(u8) -> f64,
    seed: u64,
    monitor: &Monitor<'_>,
) -> Option<Vec<Seed>> {
    let input = mpu.points();
    if count == 0 || count > input.len() {
        return None;
    }
    let tree = mpu.octree();
    let depth: Vec<u8> = (0..input.len() as u32)
        .map(|i| tree.cell(tree.leaf_of_point(i)).depth)
        .collect();
    let radius: Vec<f64> = depth.iter().map(|&d| radius_of(d)).collect();
    let positions: Vec<DVec3> = tree.positions().to_vec();
    let mut order: Vec<u32> = (0..input.len() as u32).collect();
    order.shuffle(&mut Pcg64Mcg::seed_from_u64(seed));
    let r_max = radius.iter().copied().fold(0.0, f64::max);
    let r_min = radius.iter().copied().fold(f64::INFINITY, f64::min);
    // Bisection on c: the accepted count decreases as c grows.
    let (mut lo, mut hi) = (0.0f64, 8.0f64);
    let mut best: Option<Vec<u32>> = None;
    for _ in 0..18 {
        if monitor.stopped() {
            // The caller checks the flag and discards the seeds (none, so that it does not
            // fall back on seeding by leaf first).
            return Some(Vec::new());
        }
        let c = 0.5 * (lo + hi);
        if !may_accept(&positions, c * r_min, count) {
            // Fewer than `count` would be accepted: what the throw would conclude.
            hi = c;
            continue;
        }
        let acc = throw(
            &positions,
            &radius,
            &order,
            (c, (c * r_max).max(1e-300)),
            monitor,
        );
        if acc.len() >= count {
            lo = c;
            let better = best.as_ref().is_none_or(|b| acc.len() < b.len());
            if better {
                best = Some(acc);
            }
            if best.as_ref().is_some_and(|b| b.len() == count) {
                break;
            }
        } else {
            hi = c;
        }
    }
    let mut chosen = best.or_else(|| Some((0..input.len() as u32).collect()))?;
    // Remove the extras with the smallest nearest-neighbour distance relative to their radius.
    if chosen.len() > count {
        let pts: Vec<DVec3> = chosen.iter().map(|&i| positions[i as usize]).collect();
        let index = PointIndex::new(&pts);
        let mut crowd: Vec<(f64, usize)> = pts
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let d = index
                    .nearest(*p, 2)
                    .get(1)
                    .map_or(f64::INFINITY, |n| n.1.sqrt());
                (d / radius[chosen[k] as usize], k)
            })
            .collect();
        crowd.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut drop = vec![false; pts.len()];
        for &(_, k) in crowd.iter().take(chosen.len() - count) {
            drop[k] = true;
        }
        let mut k = 0;
        chosen.retain(|_| {
            k += 1;
            !drop[k - 1]
        });
    }
    chosen.sort_unstable();
    Some(
        chosen
            .iter()
            .map(|&i| Seed {
                p: input[i as usize].p,
                n: input[i as usize].n,
                depth: depth[i as usize],
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use glam::DVec3;
    use psi_octree::Monitor;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    use super::{may_accept, throw};

    /// `n` seeded points in a slab of thickness `thick` over the unit square, with radii
    /// uniform in `radii`, and the smallest and largest radius.
    fn cloud(
        n: usize,
        seed: u64,
        thick: f64,
        radii: (f64, f64),
    ) -> (Vec<DVec3>, Vec<f64>, f64, f64) {
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let positions = (0..n)
            .map(|_| DVec3::new(rng.random(), rng.random(), thick * rng.random::<f64>()))
            .collect();
        let radius: Vec<f64> = (0..n)
            .map(|_| radii.0 + (radii.1 - radii.0) * rng.random::<f64>())
            .collect();
        let r_min = radius.iter().copied().fold(f64::INFINITY, f64::min);
        let r_max = radius.iter().copied().fold(0.0, f64::max);
        (positions, radius, r_min, r_max)
    }

    /// Accepted darts of scale `c` over `order` (a throw).
    fn darts(positions: &[DVec3], radius: &[f64], order: &[u32], c: f64, r_max: f64) -> Vec<u32> {
        throw(positions, radius, order, (c, c * r_max), &Monitor::silent())
    }

    /// Brute-force twin: every point tested against every accepted one, for random points and
    /// radii at several scales.
    #[test]
    fn a_throw_accepts_what_testing_every_pair_accepts() {
        let (positions, radius, _, r_max) = cloud(3000, 8, 0.2, (0.01, 0.04));
        let order: Vec<u32> = (0..3000).rev().collect();
        for c in [0.3, 1.0, 2.5] {
            let got = darts(&positions, &radius, &order, c, r_max);
            let mut want: Vec<u32> = Vec::new();
            for &i in &order {
                let p = positions[i as usize];
                let free = want.iter().all(|&j| {
                    let r = 0.5 * c * (radius[i as usize] + radius[j as usize]);
                    (positions[j as usize] - p).length_squared() >= r * r
                });
                if free {
                    want.push(i);
                }
            }
            assert_eq!(got, want, "c = {c}");
            assert!(want.len() > 20 && want.len() < 3000, "{}", want.len());
        }
    }

    /// The cube bound never rules out a count a throw reaches, and does rule out some.
    #[test]
    fn the_cube_bound_never_rules_out_a_reachable_count() {
        let (positions, radius, r_min, r_max) = cloud(4000, 9, 0.1, (0.5, 1.5));
        let order: Vec<u32> = (0..4000).collect();
        let mut ruled_out = 0;
        for k in 0..40 {
            let c = 0.002 * 1.2f64.powi(k);
            let accepted = darts(&positions, &radius, &order, c, r_max);
            for count in [
                accepted.len() / 2 + 1,
                accepted.len(),
                accepted.len() + 1,
                2 * accepted.len(),
            ] {
                let may = may_accept(&positions, c * r_min, count);
                assert!(may || count > accepted.len(), "c = {c}, count {count}");
                ruled_out += usize::from(!may);
            }
        }
        assert!(ruled_out > 10, "{ruled_out}");
    }
}
