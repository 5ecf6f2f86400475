//! The noise estimate of a store's points, tile by tile: psi-preprocess's rounds
//! ([`psi_preprocess::noise_by_rounds`]), each round's samples fitted among a tile's own points
//! and a halo around them ([`psi_preprocess::part_noise_samples`]), bitwise the in-core
//! estimate of the same points in the same order. The orientation's level (`tile_normals.rs`)
//! and the run's error threshold (`store_checks.rs`) read it.

use std::sync::Mutex;

use glam::DVec3;
use psi_octree::Monitor;
use psi_preprocess::{
    CONSISTENCY_QUERIES, NoiseEstimate, NoiseRound, NormalConsistency, noise_by_rounds,
    part_noise_samples, part_normal_consistency,
};
use psi_tiles::{TileStore, TileWithHalo};

use crate::tile_parts::{Halos, by_tile, each_tile, first_halo};

/// A visit of each tile's points once (its key, the tile with its halo; [`TileWithHalo::own_points`]
/// are its own), made while the noise's first round holds them.
pub(crate) type TileVisit<'a> = dyn Fn([u32; 3], &TileWithHalo) + Sync + 'a;

/// The noise estimate of `store`'s positions and the median reach of its first round's
/// samples (world units), as [`psi_preprocess::estimate_noise`] finds them for the points in
/// index order. Each tile's halo starts from `halos` (else [`first_halo`]) and is kept there,
/// grown as its points needed; `visit` sees each tile once. With `consistency`, also the
/// consistency check of the normals ([`psi_preprocess::check_normal_consistency`] with the
/// preprocessing's queries) in the first round's tiles. Progress: stage `"noise"`, tiles done
/// of tiles.
///
/// # Errors
///
/// Why the store could not be read (a file named), or `"interrupted"`.
pub(crate) fn store_noise(
    store: &TileStore,
    halos: &mut Halos,
    visit: Option<&TileVisit<'_>>,
    consistency: bool,
    monitor: &Monitor<'_>,
) -> Result<((NoiseEstimate, f64), Option<NormalConsistency>), String> {
    let n =
        usize::try_from(store.manifest().population).map_err(|_| "too many points".to_string())?;
    let keys = store.tile_keys();
    let first = |key| first_halo(store, key);
    let mut rounds = 0;
    let counted = Mutex::new(consistency.then(NormalConsistency::default));
    let noise = noise_by_rounds(n, |round: NoiseRound| {
        rounds += 1;
        let first_round = rounds == 1;
        let visit = visit.filter(|_| first_round);
        let found = each_tile(
            &keys,
            (&mut *halos, &first),
            ("noise", monitor),
            &|key, halo| {
                let (tile, (fits, c)) = by_tile(store, key, halo, |t, ids, holds| {
                    let positions: Vec<DVec3> = t.points.iter().map(|p| p.p).collect();
                    let fits = part_noise_samples(&positions, ids, &t.own, holds, round)?;
                    let queries = (n, CONSISTENCY_QUERIES);
                    let c = (consistency && first_round)
                        .then(|| part_normal_consistency(&t.points, ids, &t.own, holds, queries))
                        .transpose()?;
                    Ok((fits, c))
                })?;
                if let (Some(c), Some(sum)) = (c, counted.lock().expect("not poisoned").as_mut()) {
                    *sum = sum.merge(c);
                }
                if let Some(visit) = visit {
                    visit(key, &tile);
                }
                Ok(fits)
            },
        )?;
        Ok::<_, String>(found.concat())
    })?;
    // (Fewer than 7 points have no noise round: their normals by a pass of their own.)
    let counted = match counted.into_inner().expect("not poisoned") {
        Some(_) if rounds == 0 => Some(store_consistency(store, halos, monitor)?),
        counted => counted,
    };
    Ok((noise, counted))
}

/// The consistency check of `store`'s normals ([`psi_preprocess::check_normal_consistency`]
/// with the preprocessing's queries) tile by tile, for a run that estimates no noise (the
/// halos as [`store_noise`] takes them). Progress: stage `"normals"`, tiles done of tiles.
///
/// # Errors
///
/// Why the store could not be read (a file named), or `"interrupted"`.
pub(crate) fn store_consistency(
    store: &TileStore,
    halos: &mut Halos,
    monitor: &Monitor<'_>,
) -> Result<NormalConsistency, String> {
    let n =
        usize::try_from(store.manifest().population).map_err(|_| "too many points".to_string())?;
    let keys = store.tile_keys();
    let first = |key| first_halo(store, key);
    let found = each_tile(
        &keys,
        (halos, &first),
        ("normals", monitor),
        &|key, halo| {
            let queries = (n, CONSISTENCY_QUERIES);
            let (_, c) = by_tile(store, key, halo, |t, ids, holds| {
                part_normal_consistency(&t.points, ids, &t.own, holds, queries)
            })?;
            Ok(c)
        },
    )?;
    Ok(found
        .into_iter()
        .fold(NormalConsistency::default(), NormalConsistency::merge))
}
