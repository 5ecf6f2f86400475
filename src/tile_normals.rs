//! Normals for a run out of core whose input has none: estimated and oriented tile by tile
//! (psi-preprocess's by-parts functions on each tile and a halo of the points around it), so
//! that the store the MPU is decided from holds, bitwise, the points and normals the in-core
//! preprocessing gives the same input (denoising follows in `store_checks.rs`). Stores in
//! the scratch directory, each found
//! again by a run on the same input: the positions (`positions/`), with the outlier step the
//! positions it keeps (`kept/`, `tile_outliers.rs`), the estimated normals by index
//! (`normals.bin`, renamed into place once whole), the points with their unoriented normals
//! (`estimated/`), and the final store (`tiles/`, the normals oriented); the others are removed
//! once it is written. Where the noise asks for planes among a coarser level of the points,
//! `tile_level_normals.rs` writes the final store instead of the last three. Progress: stages
//! `"positions"`, `"noise"`, `"planes"`, `"normals"`, `"sides"`, `"orient"` (tiles done of
//! tiles, where by tile). Notes: `docs/notes/2026-12-03-orientation-by-parts.md`,
//! `docs/notes/2026-12-03-outliers-by-parts.md`.
//!
//! Not yet: the stages as a cluster's tasks per tile (a cluster runs them as one task).

use std::fs::{self, File};

use glam::DVec3;
use psi_octree::Monitor;
use psi_preprocess::{
    PartEdges, noise_level, orientation_flips, part_normals, part_orientation_edges,
};

use crate::PsiError;
use crate::given_stages::{STRAYS_FILE, kept_by, stray_indices};
use crate::partition::{
    Input, Keep, KeptFrom, Normals, NormalsKind, Partition, Points, StoreKind, failure,
};
use crate::tile_level_normals::partition_from_level;
use crate::tile_noise::store_noise;
use crate::tile_outliers::{StrayTally, found_with_strays, stray_verdicts};
use crate::tile_parts::{
    Halos, RecordFile, by_tile, each_tile, first_halo, io_reason, normal_bytes, normal_of_bytes,
    write_at,
};

/// Bytes of a normal in `normals.bin` (three little-endian f64).
const NORMAL_BYTES: u64 = 24;

/// Bytes a point the orientation's join holds at once (all points together): its sets (the
/// trees, the sides and their parities, the islands, their sizes, the seeds, the pieces: 23),
/// x and the side of n.x (9), the flips (1), the parts' forests and same-sheet links (up to 32).
const JOIN_BYTES: u64 = 65;

/// The store of `input`'s points (files without normals) with normals estimated and oriented tile by tile, in `options.scratch/tiles`
/// (found there when an earlier run wrote it for the same files), where the decisions of
/// [`crate::sample_files_out_of_core`] read it; on a cluster, one task
/// (`psi.distributed.sample_files`). With `remove_outliers`, the outlier step's strays are left
/// out first (`tile_outliers.rs`, on the store of all positions; the rest on a store of the
/// kept ones, `kept/`), and what it left out is returned; and the level the planes were fitted
/// at (`None` when the final store was found).
///
/// # Errors
///
/// [`PsiError::OutOfCore`] naming the first file: a scratch file fails, the points or their
/// coarser level do not fit in `--max-memory`, or they are too many for 32-bit indices; the
/// partition's errors.
pub(crate) fn partition_estimating_normals(
    input: Input<'_>,
    remove_outliers: bool,
    monitor: &Monitor<'_>,
) -> Result<(Partition, Option<StrayTally>, Option<u32>), PsiError> {
    let (paths, options) = (input.paths, input.options);
    let fail = failure(&paths[0]);
    let scratch = &options.scratch;
    let final_dir = scratch.join("tiles");
    let positions_dir = scratch.join("positions");
    let kept_dir = scratch.join("kept");
    let estimated_dir = scratch.join("estimated");
    let normals_path = scratch.join("normals.bin");
    let strays_path = scratch.join(STRAYS_FILE);
    // The stages' files, once the final store is whole (also those a run stopped between the
    // two left).
    let clean_up = || -> Result<(), PsiError> {
        for dir in [&positions_dir, &kept_dir, &estimated_dir] {
            if dir.exists() {
                fs::remove_dir_all(dir).map_err(|e| fail(io_reason(dir, &e)))?;
            }
        }
        if normals_path.exists() {
            fs::remove_file(&normals_path).map_err(|e| fail(io_reason(&normals_path, &e)))?;
        }
        Ok(())
    };
    let kind = StoreKind {
        normals: NormalsKind::Oriented,
        strays_left_out: remove_outliers,
    };
    // The final store of an earlier run, with the verdicts it was made from (for the report).
    if let Some((found, tally)) = found_with_strays(paths, options, kind, NormalsKind::Positions)? {
        clean_up()?;
        return Ok((found, tally, None));
    }
    // The positions, every point with a zero normal.
    let all = {
        let points = Points::all(Normals::Zero);
        input.stage("positions", &positions_dir, points, monitor)?
    };
    // The outlier step's verdicts, and the positions it keeps.
    let mut tally = None;
    let verdicts = if remove_outliers {
        tally = Some(stray_verdicts(&all.store, scratch, false, monitor).map_err(&fail)?);
        Some(RecordFile::<1>::open(&strays_path).map_err(&fail)?)
    } else {
        None
    };
    let keep_strays = verdicts.as_ref().map(kept_by);
    let strays = remove_outliers
        .then(|| stray_indices(&strays_path))
        .flatten();
    let keep: Option<Keep<'_>> = keep_strays.as_ref().map(|k| k as Keep<'_>);
    let bare = if remove_outliers {
        // (Every position is stored: the kept points' bounds come from the store of all.)
        let kept_from = strays.as_deref().map(|strays| KeptFrom {
            store: &all.store,
            strays,
        });
        let points = Points {
            normals: Normals::Zero,
            keep,
            kept_from,
        };
        input.stage("kept", &kept_dir, points, monitor)?
    } else {
        all
    };
    let store = &bare.store;
    // Normals of another input (an earlier run's, left in this scratch directory) never serve:
    // a positions store written afresh writes them afresh.
    if !bare.resumed && normals_path.exists() {
        fs::remove_file(&normals_path).map_err(|e| fail(io_reason(&normals_path, &e)))?;
    }
    let n = usize::try_from(bare.points)
        .ok()
        .filter(|&n| n < u32::MAX as usize)
        .ok_or_else(|| fail("too many points for 32-bit indices".into()))?;
    // The level the noise asks for. Each tile's halo, grown as its points need (a stray point's
    // far neighbours grow its own tile's only), kept for the next stage over the same tiles.
    let mut halos = Halos::new();
    let keys = store.tile_keys();
    let first = |key| first_halo(store, key);
    let ((noise, reach), _) = store_noise(
        store,
        &mut halos,
        None,
        (false, options.max_memory),
        monitor,
    )
    .map_err(&fail)?;
    let level = noise_level(noise.sigma, reach);
    if level > 0 {
        // The planes among the level's points (none when it holds too few: level 0 then).
        let at = (store, keep, level);
        let found = partition_from_level(input, at, &mut halos, &final_dir, monitor)?;
        if let Some(partition) = found {
            clean_up()?;
            return Ok((partition, tally, Some(level)));
        }
    }
    // The join holds every point at once: refused up front when that does not fit.
    let join = bare.points.saturating_mul(JOIN_BYTES);
    if join > options.max_memory {
        return Err(fail(format!(
            "its {} points have no normals, and orienting the normals joins them all at once: \
             about {} MiB, more than the {} MiB of --max-memory; give more, or give the points \
             with normals",
            bare.points,
            join.div_ceil(1 << 20),
            options.max_memory >> 20
        )));
    }
    // The normals by input index.
    if fs::metadata(&normals_path).map(|m| m.len()).ok() != Some(n as u64 * NORMAL_BYTES) {
        let partial = scratch.join("normals.bin.partial");
        let file = File::create(&partial).map_err(|e| fail(io_reason(&partial, &e)))?;
        file.set_len(n as u64 * NORMAL_BYTES)
            .map_err(|e| fail(io_reason(&partial, &e)))?;
        let found = each_tile(
            &keys,
            (&mut halos, &first),
            ("planes", monitor),
            &|key, halo| {
                let (tile, normals) = by_tile(store, key, halo, |t, ids, holds| {
                    let positions: Vec<DVec3> = t.points.iter().map(|p| p.p).collect();
                    part_normals(&positions, ids, &t.own, holds)
                })?;
                Ok(tile
                    .own_points()
                    .map(|(i, _)| i)
                    .zip(normals)
                    .collect::<Vec<_>>())
            },
        )
        .map_err(&fail)?;
        for (i, normal) in found.into_iter().flatten() {
            write_at(&file, &normal_bytes(normal), i * NORMAL_BYTES)
                .map_err(|e| fail(io_reason(&partial, &e)))?;
        }
        file.sync_all().map_err(|e| fail(io_reason(&partial, &e)))?;
        fs::rename(&partial, &normals_path).map_err(|e| fail(io_reason(&normals_path, &e)))?;
    }
    let reader = RecordFile::<24>::open(&normals_path).map_err(&fail)?;
    let read = |i: u64| reader.get(i).map(normal_of_bytes);
    // The points with their estimated normals (none dropped where no plane was found), then
    // their sides from the parts' edges.
    let estimated = {
        let normals = Normals::Estimated {
            normals: &read,
            flips: None,
        };
        let points = Points {
            normals,
            keep,
            kept_from: None,
        };
        input.stage("normals", &estimated_dir, points, monitor)?
    };
    let kept = estimated.points as usize;
    let mut parts: Vec<PartEdges> = Vec::new();
    let (mut x, mut x_negative) = (vec![0.0; kept], vec![false; kept]);
    let keys = estimated.store.tile_keys();
    let first_estimated = |key| first_halo(&estimated.store, key);
    let found = each_tile(
        &keys,
        (&mut Halos::new(), &first_estimated),
        ("sides", monitor),
        &|key, halo| {
            let (tile, edges) = by_tile(&estimated.store, key, halo, |t, ids, holds| {
                part_orientation_edges(&t.points, ids, &t.own, holds)
            })?;
            let mine: Vec<(u64, f64, bool)> = tile
                .own_points()
                .map(|(i, p)| (i, p.p.x, p.n.x < 0.0))
                .collect();
            Ok((edges, mine))
        },
    )
    .map_err(&fail)?;
    for (edges, mine) in found {
        for (i, px, negative) in mine {
            x[i as usize] = px;
            x_negative[i as usize] = negative;
        }
        parts.push(edges);
    }
    let flips = orientation_flips(kept, &parts, &|i| x[i as usize], &|i| {
        x_negative[i as usize]
    });
    drop(parts);
    let oriented = {
        let normals = Normals::Estimated {
            normals: &read,
            flips: Some(&flips),
        };
        let points = Points {
            normals,
            keep,
            kept_from: None,
        };
        input.stage("orient", &final_dir, points, monitor)?
    };
    drop(reader);
    clean_up()?;
    let partition = Partition {
        dropped: estimated.dropped,
        ..oriented
    };
    Ok((partition, tally, Some(0)))
}
