//! A tiled build out of core: the cells above the tiles decided from the coarse points (and
//! the few balls they need in full, read from the tile files), then each tile from its file
//! and the neighbours' points within its halo. Each tile's decisions go to a file of their own
//! (checksummed, written atomically), so an interrupted run resumes without redoing finished
//! tiles, and a damaged decisions file is decided again, never used.

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use psi_mpu::{CellTable, MpuParams, Region, RegionFit, fit_region, fit_top};
use psi_octree::Monitor;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::{TileError, TileParams, TileReport, TileStore, TiledDecisions, write_atomically};

/// What a decisions file holds: one region's decisions and how they were reached.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct RegionRecord {
    /// What the decisions were made from ([`fingerprint`]): a file left by a run on other
    /// points or parameters is not taken.
    fingerprint: String,
    cells: CellTable,
    crossing: usize,
    grown: usize,
    points: u64,
    halo_points: usize,
}

/// Decides every cell of the MPU of the points in `store` with `params` (tiles at the store's
/// depth, first halo `halo` × the tile edge): bitwise the decisions of a build over all the
/// points in memory. Memory: the coarse points (about 1 in 16) and, per thread, one tile with
/// its halo. Decisions files go to the store's directory; those already there and intact are
/// taken as they are ([`TileReport::halos_grown`] and the rest still count them). Progress:
/// stage `"tiles"`.
///
/// Errors: the MPU layer's, a store file that is missing, truncated or corrupted (named), an
/// interruption.
pub fn decide_store(
    store: &TileStore,
    params: &MpuParams,
    halo: f64,
    monitor: &Monitor<'_>,
) -> Result<TiledDecisions, TileError> {
    let manifest = store.manifest();
    let tiles = TileParams {
        depth: manifest.depth,
        halo,
    };
    tiles.validate()?;
    let frame = manifest.frame;
    let population = manifest.population as usize;
    let print = fingerprint(store, params, halo);
    let t0 = Instant::now();
    let top_path = store.dir().join("cells-top.bin");
    let top = match read_record(&top_path, &print) {
        Some(r) => r,
        None => {
            let coarse = store.coarse_points()?;
            let fetch = |c, r| store.gather_ball(c, r).map_err(|e| e.to_string());
            let fit = fit_top(
                &coarse,
                population,
                &frame,
                params,
                tiles.depth,
                &fetch,
                monitor,
            )?;
            let record = RegionRecord {
                fingerprint: print.clone(),
                cells: fit.cells,
                crossing: 0,
                grown: 0,
                points: population as u64,
                halo_points: coarse.len(),
            };
            write_record(&top_path, &record)?;
            record
        }
    };
    let top_seconds = t0.elapsed().as_secs_f64();
    let keys = crate::decide_tiles::tile_keys(&top.cells, tiles.depth);
    let t1 = Instant::now();
    let done = AtomicU64::new(0);
    let total = keys.len() as u64;
    monitor.report("tiles", 0, total);
    let records: Vec<Result<RegionRecord, TileError>> =
        keys.par_iter()
            .map(|&key| {
                let path = store
                    .dir()
                    .join(format!("cells-{}-{}-{}.bin", key[0], key[1], key[2]));
                let out = match read_record(&path, &print) {
                    Some(r) => Ok(r),
                    None => decide_stored_tile(store, params, &tiles, key, &print, monitor)
                        .and_then(|r| {
                            write_record(&path, &r)?;
                            Ok(r)
                        }),
                };
                monitor.report("tiles", done.fetch_add(1, Ordering::Relaxed) + 1, total);
                out
            })
            .collect();
    let mut report = TileReport {
        count: keys.len(),
        depth: tiles.depth,
        halo,
        top_cells: top.cells.len(),
        top_seconds,
        ..Default::default()
    };
    let mut cells = top.cells;
    for r in records {
        let r = r?;
        report.points_per_tile.push(r.points as usize);
        report.halo_points.push(r.halo_points);
        report.halos_grown += r.grown;
        report.crossing_cells += r.crossing;
        cells.merge(r.cells).map_err(TileError::Conflict)?;
    }
    report.cells = cells.len();
    report.tile_seconds = t1.elapsed().as_secs_f64();
    Ok(TiledDecisions {
        frame,
        cells,
        report,
    })
}

/// One tile from the store, its halo grown until it holds every point its fits read.
fn decide_stored_tile(
    store: &TileStore,
    params: &MpuParams,
    tiles: &TileParams,
    key: [u32; 3],
    print: &str,
    monitor: &Monitor<'_>,
) -> Result<RegionRecord, TileError> {
    let frame = store.manifest().frame;
    let population = store.manifest().population as usize;
    let region = Region::tile(tiles.depth, key);
    let (center, half) = region.cube(&frame);
    let margin = 1e-9 * frame.root_half;
    let mut halo = tiles.halo * 2.0 * half;
    let mut grown = 0;
    loop {
        let points = store.gather_box(center, half, halo)?;
        let fit: RegionFit = fit_region(&points, population, &frame, params, &region, monitor)?;
        if fit.reach + margin <= halo || points.len() == population {
            return Ok(RegionRecord {
                fingerprint: print.to_string(),
                cells: fit.cells,
                crossing: fit.crossing,
                grown,
                points: store.count(key),
                halo_points: points.len(),
            });
        }
        grown += 1;
        halo = crate::decide_tiles::grown_halo(fit.reach, halo, half, margin);
    }
}

/// What a run's decisions depend on: the store's files (their checksums), the parameters and
/// the first halo, hashed.
fn fingerprint(store: &TileStore, params: &MpuParams, halo: f64) -> String {
    let mut h = Sha256::new();
    let m = store.manifest();
    h.update(format!(
        "{:?}{}{}{:?}{}",
        m.frame_bits,
        m.population,
        m.depth,
        params,
        halo.to_bits()
    ));
    for t in m.tiles.iter().chain([&m.coarse]) {
        h.update(&t.sha256);
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// A decisions file's record, if the file is there, whole and intact (its last 32 bytes the
/// SHA-256 of the rest) and made from what `print` names.
fn read_record(path: &PathBuf, print: &str) -> Option<RegionRecord> {
    let bytes = std::fs::read(path).ok()?;
    let (body, sum) = bytes.split_at(bytes.len().checked_sub(32)?);
    if Sha256::digest(body).as_slice() != sum {
        tracing::warn!("{}: checksum mismatch, decided again", path.display());
        return None;
    }
    let record: RegionRecord = postcard::from_bytes(body).ok()?;
    (record.fingerprint == print).then_some(record)
}

fn write_record(path: &PathBuf, record: &RegionRecord) -> Result<(), TileError> {
    let mut bytes = postcard::to_stdvec(record).expect("serialisable");
    let sum = Sha256::digest(&bytes);
    bytes.extend_from_slice(&sum);
    write_atomically(path, &bytes)
}
