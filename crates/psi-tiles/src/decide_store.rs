//! A tiled build out of core: the cells above the tiles decided from the coarse points (and
//! the few balls they need in full, read from the tile files), then each tile from its file
//! and the neighbours' points within its halo. Each tile's decisions go to a file of their own
//! (checksummed, written atomically), so an interrupted run resumes without redoing finished
//! tiles, and a damaged decisions file is decided again, never used.

use std::path::Path;
use std::time::Instant;

use psi_mpu::{BallSource, MpuParams, fit_top};
use psi_octree::Monitor;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::decide_tile::{TileOutcome, decide_all, decide_tile};
use crate::{TileError, TileParams, TileStore, TiledDecisions, write_atomically};

/// What a decisions file holds: one region's decisions and what they were made from
/// ([`fingerprint`]: a file left by a run on other points or parameters is not taken).
#[derive(Clone, Debug, Serialize, Deserialize)]
struct RegionRecord {
    fingerprint: String,
    outcome: TileOutcome,
}

/// Decides every cell of the MPU of the points in `store` with `params` (tiles at the store's
/// depth, as `tiles` says): bitwise the decisions of a build over all the
/// points in memory. Memory: the coarse points (about 1 in 16) and, per thread, one tile with
/// its halo. Decisions files go to the store's directory; those already there and intact are
/// taken as they are ([`crate::TileReport::halos_grown`] and the rest still count them). Progress:
/// stage `"tiles"`.
///
/// Errors: the MPU layer's, a store file that is missing, truncated or corrupted (named), an
/// interruption.
pub fn decide_store(
    store: &TileStore,
    params: &MpuParams,
    tiles: &TileParams,
    monitor: &Monitor<'_>,
) -> Result<TiledDecisions, TileError> {
    check_tiles(store, tiles)?;
    // What every decisions file must have been made from, hashed once for all of them.
    let print = fingerprint(store, params, tiles);
    let t0 = Instant::now();
    let top = decide_store_top(store, params, tiles, &print, monitor)?;
    let top_seconds = t0.elapsed().as_secs_f64();
    let decide =
        |key: [u32; 3]| decide_store_tile_with(store, params, tiles, &top, key, &print, monitor);
    let (cells, surface, mut report) = decide_all(&top, tiles, monitor, &decide)?;
    report.top_seconds = top_seconds;
    Ok(TiledDecisions {
        frame: store.manifest().frame,
        cells,
        surface,
        report,
    })
}

/// The first task of [`decide_store`] (a cluster runs it alone): the cells above the tiles,
/// decided from the coarse points (or taken from an intact decisions file). Returns the
/// tiles' keys, in order, for [`decide_store_tile`].
///
/// Errors as [`decide_store`].
pub fn decide_store_top_keys(
    store: &TileStore,
    params: &MpuParams,
    tiles: &TileParams,
    monitor: &Monitor<'_>,
) -> Result<Vec<[u32; 3]>, TileError> {
    check_tiles(store, tiles)?;
    let print = fingerprint(store, params, tiles);
    let top = decide_store_top(store, params, tiles, &print, monitor)?;
    Ok(crate::decide_tile::tile_keys(&top.cells, tiles.depth))
}

/// One tile of [`decide_store`] (a cluster's task): decided and its decisions file written,
/// unless an intact one is there. Needs the file of [`decide_store_top_keys`].
///
/// Errors as [`decide_store`].
pub fn decide_store_tile(
    store: &TileStore,
    params: &MpuParams,
    tiles: &TileParams,
    key: [u32; 3],
    monitor: &Monitor<'_>,
) -> Result<(), TileError> {
    check_tiles(store, tiles)?;
    let print = fingerprint(store, params, tiles);
    let top = decide_store_top(store, params, tiles, &print, monitor)?;
    decide_store_tile_with(store, params, tiles, &top, key, &print, monitor).map(|_| ())
}

/// Checks that `tiles` suit `store`.
fn check_tiles(store: &TileStore, tiles: &TileParams) -> Result<(), TileError> {
    tiles.validate()?;
    let depth = store.manifest().depth;
    if tiles.depth != depth {
        return Err(TileError::BadParameter(format!(
            "the store {} holds tiles at depth {depth}, not {}",
            store.dir().display(),
            tiles.depth
        )));
    }
    Ok(())
}

/// The cells above the tiles: from their decisions file, or decided and written.
fn decide_store_top(
    store: &TileStore,
    params: &MpuParams,
    tiles: &TileParams,
    print: &str,
    monitor: &Monitor<'_>,
) -> Result<TileOutcome, TileError> {
    let manifest = store.manifest();
    let population = manifest.population as usize;
    let top_path = store.dir().join("cells-top.bin");
    if let Some(r) = read_record(&top_path, print) {
        return Ok(r);
    }
    let coarse = store.coarse_points()?;
    let fetch = |c, r| store.gather_ball(c, r).map_err(|e| e.to_string());
    let kth = |c, k| store.kth_distance(c, k).map_err(|e| e.to_string());
    let fit = fit_top(
        &coarse,
        population,
        &manifest.frame,
        params,
        tiles.depth + tiles.shared_levels,
        &BallSource {
            fetch: &fetch,
            kth: Some(&kth),
        },
        &monitor.quiet(),
    )?;
    let outcome = TileOutcome {
        cells: fit.cells,
        crossing: 0,
        fetched: 0,
        grown: 0,
        points: population as u64,
        halo_points: coarse.len(),
        surface: fit.surface,
    };
    write_record(&top_path, print, &outcome)?;
    Ok(outcome)
}

/// One tile, under the cells `top` decided: from its decisions file, or decided and written.
fn decide_store_tile_with(
    store: &TileStore,
    params: &MpuParams,
    tiles: &TileParams,
    top: &TileOutcome,
    key: [u32; 3],
    print: &str,
    monitor: &Monitor<'_>,
) -> Result<TileOutcome, TileError> {
    let path = store
        .dir()
        .join(format!("cells-{}-{}-{}.bin", key[0], key[1], key[2]));
    if let Some(outcome) = read_record(&path, print) {
        return Ok(outcome);
    }
    let manifest = store.manifest();
    let outcome = decide_tile(
        &manifest.frame,
        params,
        tiles,
        key,
        manifest.population as usize,
        store.count(key),
        &top.cells,
        store,
        monitor,
    )?;
    write_record(&path, print, &outcome)?;
    Ok(outcome)
}

/// What a run's decisions depend on: the store's files (their checksums), the parameters and
/// the first halo, hashed.
fn fingerprint(store: &TileStore, params: &MpuParams, tiles: &TileParams) -> String {
    let mut h = Sha256::new();
    let m = store.manifest();
    h.update(format!(
        "{:?} {} {} {:?} {} {}",
        m.frame_bits,
        m.population,
        m.depth,
        params,
        tiles.halo.to_bits(),
        tiles.shared_levels
    ));
    for t in m.tiles.iter().chain([&m.coarse]) {
        h.update(&t.sha256);
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// A decisions file's record, if the file is there, whole and intact (its last 32 bytes the
/// SHA-256 of the rest) and made from what `print` names.
fn read_record(path: &Path, print: &str) -> Option<TileOutcome> {
    let bytes = std::fs::read(path).ok()?;
    let (body, sum) = bytes.split_at(bytes.len().checked_sub(32)?);
    if Sha256::digest(body).as_slice() != sum {
        tracing::warn!("{}: checksum mismatch, decided again", path.display());
        return None;
    }
    let record: RegionRecord = postcard::from_bytes(body).ok()?;
    (record.fingerprint == print).then_some(record.outcome)
}

fn write_record(path: &Path, print: &str, outcome: &TileOutcome) -> Result<(), TileError> {
    let record = RegionRecord {
        fingerprint: print.to_string(),
        outcome: outcome.clone(),
    };
    let mut bytes = postcard::to_stdvec(&record).expect("serialisable");
    let sum = Sha256::digest(&bytes);
    bytes.extend_from_slice(&sum);
    write_atomically(path, &bytes)
}
