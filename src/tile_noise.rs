//! The noise estimate of a store's points, tile by tile: psi-preprocess's rounds
//! ([`psi_preprocess::noise_by_rounds`]), each round's samples fitted among a tile's own points
//! and a halo around them ([`psi_preprocess::part_noise_samples`]), bitwise the in-core
//! estimate of the same points in the same order. The orientation's level (`tile_normals.rs`)
//! and the run's error threshold (`store_checks.rs`) read it.

use glam::DVec3;
use psi_octree::Monitor;
use psi_preprocess::{NoiseEstimate, NoiseRound, noise_by_rounds, part_noise_samples};
use psi_tiles::{TileStore, TileWithHalo};

use crate::tile_parts::{Halos, by_tile, each_tile, first_halo};

/// A visit of each tile's points once (its key, the tile with its halo; [`TileWithHalo::own_points`]
/// are its own), made while the noise's first round holds them.
pub(crate) type TileVisit<'a> = dyn Fn([u32; 3], &TileWithHalo) + Sync + 'a;

/// The noise estimate of `store`'s positions and the median reach of its first round's
/// samples (world units), as [`psi_preprocess::estimate_noise`] finds them for the points in
/// index order. Each tile's halo starts from `halos` (else [`first_halo`]) and is kept there,
/// grown as its points needed; `visit` sees each tile once. Progress: stage `"noise"`, tiles
/// done of tiles.
///
/// # Errors
///
/// Why the store could not be read (a file named), or `"interrupted"`.
pub(crate) fn store_noise(
    store: &TileStore,
    halos: &mut Halos,
    visit: Option<&TileVisit<'_>>,
    monitor: &Monitor<'_>,
) -> Result<(NoiseEstimate, f64), String> {
    let n =
        usize::try_from(store.manifest().population).map_err(|_| "too many points".to_string())?;
    let keys = store.tile_keys();
    let first = |key| first_halo(store, key);
    let mut rounds = 0;
    noise_by_rounds(n, |round: NoiseRound| {
        rounds += 1;
        let visit = visit.filter(|_| rounds == 1);
        let found = each_tile(
            &keys,
            (&mut *halos, &first),
            ("noise", monitor),
            &|key, halo| {
                let (tile, fits) = by_tile(store, key, halo, |t, ids, holds| {
                    let positions: Vec<DVec3> = t.points.iter().map(|p| p.p).collect();
                    part_noise_samples(&positions, ids, &t.own, holds, round)
                })?;
                if let Some(visit) = visit {
                    visit(key, &tile);
                }
                Ok(fits)
            },
        )?;
        Ok(found.concat())
    })
}
