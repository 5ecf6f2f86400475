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
use crate::estimate_noise::{NoiseRound, sample_residual};
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
    assert!(positions.len() == ids.len() && ids.len() == own.len());
    assert!(ids.is_sorted(), "ids ascend");
    // Ties among neighbours go to the lower local index, which is the lower input index.
    let index = MortonIndex::new(positions);
    let samples: Vec<usize> = (0..positions.len())
        .filter(|&i| own[i] && round.holds(ids[i] as usize))
        .collect();
    let fits: Vec<Result<Option<(f64, f64)>, IncompletePart>> = samples
        .par_iter()
        .map(|&i| {
            let near = index.nearest(positions[i], round.k);
            let reach = if near.len() < round.k {
                f64::INFINITY
            } else {
                near.last().map_or(0.0, |n| n.1.sqrt())
            };
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
    Ok(certified(fits)?.into_iter().flatten().collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate_noise::{NoiseEstimate, estimate_noise, noise_by_rounds};
    use crate::grid_parts::grid_parts;
    use psi_shapes::AnalyticShape;

    /// Noisy tori (one with noise that asks for the wide round, one without) on 27 parts:
    /// the estimate from the parts' fits is the whole estimate, bit for bit.
    #[test]
    fn parts_estimate_the_noise_bitwise_as_the_whole() {
        let torus = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        };
        let clean = torus.sample(20_000, 3);
        let spacing = (torus.area() / 20_000.0).sqrt();
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
}
