//! The noise estimate of a store's points, tile by tile: psi-preprocess's rounds
//! ([`psi_preprocess::noise_by_rounds`]), each round's samples fitted among a tile's own points
//! and a halo around them ([`psi_preprocess::part_noise_reading_wide`]), bitwise the in-core
//! estimate of the same points in the same order. The orientation's level (`tile_normals.rs`)
//! and the run's error threshold (`store_checks.rs`) read it.

use std::collections::HashMap;
use std::sync::Mutex;

use glam::DVec3;
use psi_octree::Monitor;
use psi_preprocess::{
    CONSISTENCY_QUERIES, NoiseEstimate, NoiseRound, NormalConsistency, WideNeighbourhood,
    noise_by_rounds, part_noise_reading_wide, part_normal_consistency, wide_residuals,
    widest_round,
};
use psi_tiles::{TileStore, TileWithHalo};

use crate::tile_parts::{Halos, by_tile, each_tile, first_halo};

/// A visit of each tile's points once (its key, the tile with its halo; [`TileWithHalo::own_points`]
/// are its own), made while the noise's first round holds them.
pub(crate) type TileVisit<'a> = dyn Fn([u32; 3], &TileWithHalo) + Sync + 'a;

/// The second round's neighbourhoods are read in the first when they take at most this share
/// of the memory budget (2 048 samples of up to 256 neighbours, 32 bytes each: 16.8 MB).
const READ_AHEAD_SHARE: u64 = 32;

/// The bytes the second round's neighbourhoods take when read ahead, for `n` points.
fn read_ahead_bytes(n: usize) -> u64 {
    let wide = widest_round(n);
    (n.div_ceil(wide.stride) * wide.k * std::mem::size_of::<(DVec3, f64)>()) as u64
}

/// The noise estimate of `store`'s positions and the median reach of its first round's
/// samples (world units), as [`psi_preprocess::estimate_noise`] finds them for the points in
/// index order. Each tile's halo starts from `halos` (else [`first_halo`]) and is kept there,
/// grown as its points needed; `visit` sees each tile once. With `consistency`, also the
/// consistency check of the normals ([`psi_preprocess::check_normal_consistency`] with the
/// preprocessing's queries) in the first round's tiles. Where the second round's
/// neighbourhoods fit a 32nd of `max_memory` (bytes; 0: never), the first round reads them
/// too, as far as each tile's halo holds them, and the second reads again only the tiles whose
/// halo held fewer than it asks for (the same fits: `docs/notes/2026-12-04-noise-read-ahead.md`). Progress: stage `"noise"`, tiles done of
/// tiles.
///
/// # Errors
///
/// Why the store could not be read (a file named), or `"interrupted"`.
pub(crate) fn store_noise(
    store: &TileStore,
    halos: &mut Halos,
    visit: Option<&TileVisit<'_>>,
    (consistency, max_memory): (bool, u64),
    monitor: &Monitor<'_>,
) -> Result<((NoiseEstimate, f64), Option<NormalConsistency>), String> {
    let n =
        usize::try_from(store.manifest().population).map_err(|_| "too many points".to_string())?;
    let keys = store.tile_keys();
    let first = |key| first_halo(store, key);
    let mut rounds = 0;
    let counted = Mutex::new(consistency.then(NormalConsistency::default));
    let read_ahead = (n >= 7 && read_ahead_bytes(n).saturating_mul(READ_AHEAD_SHARE) <= max_memory)
        .then(|| widest_round(n));
    // The second round's neighbourhoods of each tile's samples, as far as its halo held them.
    let mut read: HashMap<[u32; 3], Vec<WideNeighbourhood>> = HashMap::new();
    let noise = noise_by_rounds(n, |round: NoiseRound| {
        rounds += 1;
        let first_round = rounds == 1;
        let visit = visit.filter(|_| first_round);
        let wide = read_ahead.filter(|_| first_round);
        // The second round: from the neighbourhoods read, the other tiles read again.
        let mut found = Vec::new();
        let keys: Vec<[u32; 3]> = match first_round {
            true => keys.clone(),
            false => {
                let reads = |key: &[u32; 3]| {
                    read.get(key)
                        .is_some_and(|near| near.iter().all(|w| w.reads(round.k)))
                };
                for key in keys.iter().filter(|k| reads(k)) {
                    found.extend(wide_residuals(&read[key], round.k));
                }
                keys.iter().copied().filter(|k| !reads(k)).collect()
            }
        };
        let reading = Mutex::new(HashMap::new());
        let fits = each_tile(
            &keys,
            (&mut *halos, &first),
            ("noise", monitor),
            &|key, halo| {
                let (tile, (fits, c, near)) = by_tile(store, key, halo, |t, ids, holds| {
                    let positions: Vec<DVec3> = t.points.iter().map(|p| p.p).collect();
                    let (fits, near) =
                        part_noise_reading_wide(&positions, ids, &t.own, holds, round, wide)?;
                    let queries = (n, CONSISTENCY_QUERIES);
                    let c = (consistency && first_round)
                        .then(|| part_normal_consistency(&t.points, ids, &t.own, holds, queries))
                        .transpose()?;
                    Ok((fits, c, near))
                })?;
                if let (Some(c), Some(sum)) = (c, counted.lock().expect("not poisoned").as_mut()) {
                    *sum = sum.merge(c);
                }
                if wide.is_some() {
                    reading.lock().expect("not poisoned").insert(key, near);
                }
                if let Some(visit) = visit {
                    visit(key, &tile);
                }
                Ok(fits)
            },
        )?;
        read.extend(reading.into_inner().expect("not poisoned"));
        found.extend(fits.concat());
        Ok::<_, String>(found)
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

#[cfg(test)]
mod tests {
    use super::*;
    use psi_mpu::{MpuFrame, MpuParams};
    use psi_octree::Aabb;
    use psi_tiles::TileWriter;

    /// A noisy torus in a store of 64 tiles (noise of a spacing, which asks for the second
    /// round): the estimate tile by tile is the in-core one, bit for bit, with the second
    /// round's neighbourhoods read ahead (a budget that holds them: the second round reads
    /// fewer than every tile again) and without (none: every tile).
    #[test]
    fn the_noise_of_a_store_is_the_whole_estimate_with_and_without_reading_ahead() {
        use rand::SeedableRng;
        let torus = psi_shapes::AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        };
        let n = 20_000;
        let spacing = (torus.area() / n as f64).sqrt();
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
        let mut points = torus.sample(n, 2);
        for p in &mut points {
            p.p += spacing * psi_shapes::gaussian_vector(&mut rng);
        }
        let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
        let whole = psi_preprocess::estimate_noise(&positions);
        // (The second round ran: its 2 048 samples, not the first round's 6 667.)
        assert!(whole.samples <= 2048, "{whole:?}");
        let dir = std::env::temp_dir().join(format!("psi-tile-noise-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let bounds = Aabb::from_points(positions.iter().copied()).unwrap();
        let frame = MpuFrame::for_bounds(&bounds, n, &MpuParams::paper()).unwrap();
        let mut writer = TileWriter::create(&dir, frame, 2, 1000, "test").unwrap();
        writer.push(&points).unwrap();
        let store = writer.finish().unwrap();
        assert!(store.tile_keys().len() >= 8);
        let tiles = store.tile_keys().len() as u64;
        let mut passes = Vec::new();
        for budget in [0, u64::MAX] {
            // The passes over every tile, counted from the progress reports' totals.
            let whole_passes = std::sync::atomic::AtomicUsize::new(0);
            let observe = |stage: &str, done: u64, total: u64| {
                if stage == "noise" && done == 0 && total == tiles {
                    whole_passes.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                }
            };
            let monitor = Monitor::new(Some(&observe), None);
            let found = store_noise(&store, &mut Halos::new(), None, (false, budget), &monitor);
            passes.push(whole_passes.into_inner());
            let ((estimate, _), _) = found.unwrap();
            assert!(
                estimate == whole,
                "budget {budget}: {estimate:?} against {whole:?}"
            );
        }
        // Without a budget the second round reads every tile again; with one, the first
        // round's reading serves some tiles at least.
        assert_eq!(passes[0], 2, "{passes:?}");
        assert_eq!(passes[1], 1, "{passes:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
