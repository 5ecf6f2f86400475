//! The noise estimate by parts: a round's samples ([`NoiseRound`], every stride-th point by
//! input index) that are a part's own points, each fitted over its k nearest as
//! [`crate::estimate_noise`] fits it, bitwise, when the part's halo holds them (a tile and the
//! points around it). [`noise_by_rounds`] then takes the medians of all parts' fits, one round
//! after the other.

use glam::DVec3;
use psi_octree::MortonIndex;
use rayon::prelude::*;

#[cfg(doc)]
use crate::estimate_noise::noise_by_rounds;
use crate::estimate_noise::{NoiseRound, WideNeighbourhood, sample_residual};
use crate::orient_by_parts::{IncompletePart, certified};

/// The fits of `round`'s samples among a part's own points: `positions` (shape: M, world
/// units) its own points and its halo, `ids` (shape: M) their input indices, ascending, `own`
/// (shape: M) which are its own; `complete(x, r)` tells whether every input point within `r`
/// of `x` is among `positions`. Per own sample with a fit: its residual deviation and the
/// distance to its k-th nearest (world units), in no particular order (what
/// [`noise_by_rounds`] takes); or the uncertain sample whose neighbours reach farthest.
///
/// # Panics
///
/// When the lengths differ or `ids` do not ascend.
pub fn part_noise_samples(
    positions: &[DVec3],
    ids: &[u32],
    own: &[bool],
    complete: &(dyn Fn(DVec3, f64) -> bool + Sync),
    round: NoiseRound,
) -> Result<Vec<(f64, f64)>, IncompletePart> {
    part_noise_reading_wide(positions, ids, own, complete, round, None).map(|(fits, _)| fits)
}

/// A part's fits of a round (each a residual deviation and a reach, world units) and its
/// samples' neighbourhoods read ahead ([`part_noise_reading_wide`]).
pub type PartNoise = (Vec<(f64, f64)>, Vec<WideNeighbourhood>);

/// [`part_noise_samples`], and with `wide` (the second round's samples and most neighbours,
/// [`crate::widest_round`]) the neighbourhoods of its samples among the part's own points, in
/// input order, read while the part is indexed: each sample's nearest up to `wide.k`, as many
/// as the part holds whole (a ball the part does not hold does not make it incomplete: a round
/// that needs more neighbours reads the part again).
///
/// # Panics
///
/// As [`part_noise_samples`].
pub fn part_noise_reading_wide(
    positions: &[DVec3],
    ids: &[u32],
    own: &[bool],
    complete: &(dyn Fn(DVec3, f64) -> bool + Sync),
    round: NoiseRound,
    wide: Option<NoiseRound>,
) -> Result<PartNoise, IncompletePart> {
    assert!(positions.len() == ids.len() && ids.len() == own.len());
    assert!(ids.is_sorted(), "ids ascend");
    // Ties among neighbours go to the lower local index, which is the lower input index.
    let index = MortonIndex::new(positions);
    // The distance to the k-th of `near`, or infinite when fewer were found (the part then
    // holds them whole only when it holds every input point).
    let reach_of = |near: &[(u32, f64)], k: usize| {
        if near.len() < k {
            f64::INFINITY
        } else {
            near.last().map_or(0.0, |n| n.1.sqrt())
        }
    };
    let samples: Vec<usize> = (0..positions.len())
        .filter(|&i| own[i] && round.holds(ids[i] as usize))
        .collect();
    let fits: Vec<Result<Option<(f64, f64)>, IncompletePart>> = samples
        .par_iter()
        .map(|&i| {
            let near = index.nearest(positions[i], round.k);
            let reach = reach_of(&near, round.k);
            if !complete(positions[i], reach) {
                return Err(IncompletePart {
                    id: ids[i],
                    neighbours: round.k,
                    reach,
                });
            }
            Ok(sample_residual(index.points(), &near))
        })
        .collect();
    let fits = certified(fits)?.into_iter().flatten().collect();
    let wide = wide.map_or_else(Vec::new, |wide| {
        let samples: Vec<usize> = (0..positions.len())
            .filter(|&i| own[i] && wide.holds(ids[i] as usize))
            .collect();
        samples
            .par_iter()
            .map(|&i| {
                let x = positions[i];
                let mut near = index.nearest(x, wide.k);
                // (Whether a ball is held is monotone in its radius. A part that holds every
                // input point holds the widest round's min(256, N) of them.)
                near.truncate(near.partition_point(|&(_, d2)| complete(x, d2.sqrt())));
                WideNeighbourhood {
                    near: near
                        .iter()
                        .map(|&(j, d2)| (index.points()[j as usize], d2))
                        .collect(),
                }
            })
            .collect()
    });
    Ok((fits, wide))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate_noise::{NoiseEstimate, estimate_noise, noise_by_rounds};
    use crate::grid_parts::grid_parts;
    use psi_shapes::AnalyticShape;

    /// 20 000 points of a torus sampled with `seed`, and their spacing (world units).
    fn torus(seed: u64) -> (Vec<psi_octree::OrientedPoint>, f64) {
        let torus = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        };
        (torus.sample(20_000, seed), (torus.area() / 20_000.0).sqrt())
    }

    /// Noisy tori (one with noise that asks for the wide round, one without) on 27 parts:
    /// the estimate from the parts' fits is the whole estimate, bit for bit.
    #[test]
    fn parts_estimate_the_noise_bitwise_as_the_whole() {
        let (clean, spacing) = torus(3);
        let mut rng = <rand_pcg::Pcg64Mcg as rand::SeedableRng>::seed_from_u64(8);
        let mut wide_rounds = 0;
        for relative in [0.05, 1.0] {
            let positions: Vec<DVec3> = clean
                .iter()
                .map(|p| p.p + relative * spacing * psi_shapes::gaussian_vector(&mut rng))
                .collect();
            let whole = estimate_noise(&positions);
            let parts = grid_parts(&positions, 3, 0.3);
            let mut rounds = 0;
            let by_parts: Result<(NoiseEstimate, f64), IncompletePart> =
                noise_by_rounds(positions.len(), |round| {
                    rounds += 1;
                    let mut found = Vec::new();
                    for part in &parts {
                        let held: Vec<DVec3> =
                            part.ids.iter().map(|&i| positions[i as usize]).collect();
                        let holds = |x: DVec3, r: f64| part.holds_ball(x, r);
                        found.extend(part_noise_samples(
                            &held, &part.ids, &part.own, &holds, round,
                        )?);
                    }
                    Ok(found)
                });
            let (estimate, _) = by_parts.unwrap();
            assert!(
                estimate == whole,
                "noise {relative}: {estimate:?} against {whole:?}"
            );
            wide_rounds += usize::from(rounds == 2);
        }
        // The wide round ran for the noisier torus only.
        assert_eq!(wide_rounds, 1);
    }

    /// The second round's fits from neighbourhoods read in the first round
    /// (`part_noise_reading_wide`, then `wide_residuals`) for the parts that held them whole,
    /// read again for the others: the estimate is the whole one, bit for bit. A noisy torus in
    /// 27 parts with a wide halo: every part holds the neighbourhoods, or, where the odd parts
    /// hold no ball in the first round wider than it needs, the even parts alone.
    #[test]
    fn the_wide_rounds_neighbourhoods_read_ahead_give_the_whole_estimate() {
        use crate::estimate_noise::{wide_residuals, widest_round};
        let (clean, spacing) = torus(5);
        let mut rng = <rand_pcg::Pcg64Mcg as rand::SeedableRng>::seed_from_u64(9);
        let positions: Vec<DVec3> = clean
            .iter()
            .map(|p| p.p + spacing * psi_shapes::gaussian_vector(&mut rng))
            .collect();
        let whole = estimate_noise(&positions);
        let widest = widest_round(positions.len());
        let parts = grid_parts(&positions, 3, 0.8);
        // (The first round's balls reach about 0.08 here, the widest round's about 0.24.)
        for odd_reach in [f64::INFINITY, 0.15] {
            let mut read: Vec<Option<Vec<WideNeighbourhood>>> = vec![None; parts.len()];
            let (mut rounds, mut used) = (0, 0);
            let by_parts: Result<(NoiseEstimate, f64), IncompletePart> =
                noise_by_rounds(positions.len(), |round| {
                    rounds += 1;
                    let mut found = Vec::new();
                    for (p, (part, read)) in parts.iter().zip(&mut read).enumerate() {
                        let reads =
                            |near: &&Vec<WideNeighbourhood>| near.iter().all(|w| w.reads(round.k));
                        if let Some(near) = read.as_ref().filter(reads).filter(|_| rounds == 2) {
                            found.extend(wide_residuals(near, round.k));
                            used += 1;
                            continue;
                        }
                        let held: Vec<DVec3> =
                            part.ids.iter().map(|&i| positions[i as usize]).collect();
                        let first = rounds == 1 && p % 2 == 1;
                        let reach = if first { odd_reach } else { f64::INFINITY };
                        let holds = |x: DVec3, r: f64| r <= reach && part.holds_ball(x, r);
                        let wide = (rounds == 1).then_some(widest);
                        let (fits, near) = part_noise_reading_wide(
                            &held, &part.ids, &part.own, &holds, round, wide,
                        )?;
                        found.extend(fits);
                        if rounds == 1 {
                            *read = Some(near);
                        }
                    }
                    Ok(found)
                });
            let (estimate, _) = by_parts.unwrap();
            assert_eq!(rounds, 2);
            assert!(estimate == whole, "{estimate:?} against {whole:?}");
            // Every part's second-round fits from what it read ahead, or the even parts'.
            let all = odd_reach.is_infinite();
            assert_eq!(used == parts.len(), all, "{used} parts read ahead");
            assert!(used >= parts.len() / 2);
        }
    }
}
