//! A tiled build out of core: the cells above the tiles decided from the coarse points (and
//! the few balls they need in full, read from the tile files) — the root's levels down to
//! [`TOP_GROUP_DEPTH`], then one group per cell there (tasks of their own on a cluster) — then
//! each tile from its file and the neighbours' points within its halo. Each region's
//! decisions go to a file of their own (checksummed, written atomically), so an interrupted
//! run resumes without redoing finished ones, and a damaged decisions file is decided again,
//! never used.

use std::time::Instant;

use psi_mpu::{BallSource, MpuParams, Region, fit_top_region};
use psi_octree::{Monitor, OrientedPoint};
use sha2::{Digest, Sha256};

use crate::decide_tile::{TileOutcome, decide_all, decide_tile, tile_keys};
use crate::record_file::{read_record, write_record};
use crate::{TileError, TileParams, TileStore, TiledDecisions};

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
    let decide = |key: [u32; 3], left: Option<u64>| {
        let at = (&top, &print[..], left);
        decide_store_tile_with(store, params, tiles, at, key, monitor)
    };
    let (cells, surface, mut report) = decide_all(&top, tiles, monitor, &decide)?;
    report.top_seconds = top_seconds;
    Ok(TiledDecisions {
        frame: store.manifest().frame,
        cells,
        surface,
        report,
    })
}

/// The pass above the tiles is split at this depth: one region for the levels above it, then
/// one per cell at it (at most 8), each a task of its own on a cluster.
pub const TOP_GROUP_DEPTH: u8 = 1;

/// The first task of [`decide_store`] (a cluster runs it alone): the levels above
/// [`TOP_GROUP_DEPTH`], decided from the coarse points (or taken from an intact decisions
/// file). Returns the keys of the groups below for [`decide_store_top_group`], the group
/// holding the most input points first (ties in key order): the largest-first rule, which
/// bounds how late a cluster ends the last of them (not always the best order for a few
/// tasks of similar sizes). The groups are the octants of the root, so the order suits the
/// seeds' tasks ([`crate::seed_octant`]) too.
///
/// Errors as [`decide_store`].
pub fn decide_store_top_upper(
    store: &TileStore,
    params: &MpuParams,
    tiles: &TileParams,
    monitor: &Monitor<'_>,
) -> Result<Vec<[u32; 3]>, TileError> {
    check_tiles(store, tiles)?;
    let print = fingerprint(store, params, tiles);
    let coarse = CoarseOnce::default();
    let part = TopPart::Upper;
    let upper = decide_top_part(store, params, tiles, &print, part, &coarse, monitor)?;
    Ok(largest_first(store, group_keys(&upper, tiles)))
}

/// `octants` (keys at depth 1) ordered by the input points of the store's tiles in each, the
/// most first, ties in key order.
fn largest_first(store: &TileStore, mut octants: Vec<[u32; 3]>) -> Vec<[u32; 3]> {
    let m = store.manifest();
    let shift = m.depth.saturating_sub(1);
    let points_in = |o: &[u32; 3]| -> u64 {
        m.tiles
            .iter()
            .filter(|t| t.key.map(|k| k >> shift) == *o)
            .map(|t| t.points)
            .sum()
    };
    octants.sort_by_cached_key(|o| (std::cmp::Reverse(points_in(o)), *o));
    octants
}

/// One group of the pass above the tiles (a cluster's task): the cells at and below the
/// cell `key` at [`TOP_GROUP_DEPTH`], down to the tiles' shared levels, decided and written
/// (or found intact). Needs the file of [`decide_store_top_upper`].
///
/// Errors as [`decide_store`].
pub fn decide_store_top_group(
    store: &TileStore,
    params: &MpuParams,
    tiles: &TileParams,
    key: [u32; 3],
    monitor: &Monitor<'_>,
) -> Result<(), TileError> {
    check_tiles(store, tiles)?;
    let print = fingerprint(store, params, tiles);
    let coarse = CoarseOnce::default();
    let part = TopPart::Octant(key);
    decide_top_part(store, params, tiles, &print, part, &coarse, monitor).map(|_| ())
}

/// The task after the groups of [`decide_store`] (a cluster runs it alone): the cells above
/// the tiles, merged from the groups' files (any missing is decided here). Returns the tiles'
/// keys, in order, for [`decide_store_tiles`].
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

/// A batch of tiles of [`decide_store`] (a cluster's task): each tile of `keys` decided, in
/// order, and its decisions file written, unless an intact one is there. The store and the
/// cells above the tiles are read once for the batch: per tile they would cost more than a
/// small tile's own work (docs/notes/2026-11-27-tile-batches.md). Needs the file of
/// [`decide_store_top_keys`].
///
/// Errors as [`decide_store`].
pub fn decide_store_tiles(
    store: &TileStore,
    params: &MpuParams,
    tiles: &TileParams,
    keys: &[[u32; 3]],
    monitor: &Monitor<'_>,
) -> Result<(), TileError> {
    check_tiles(store, tiles)?;
    let print = fingerprint(store, params, tiles);
    let top = decide_store_top(store, params, tiles, &print, monitor)?;
    for &key in keys {
        monitor.check()?;
        let at = (&top, &print[..], tiles.max_cells);
        decide_store_tile_with(store, params, tiles, at, key, monitor)?;
    }
    Ok(())
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

/// The cells above the tiles: from their decisions file; else, when a cluster's first task
/// left the upper levels' file, merged from the upper levels' and the groups' (each from its
/// file, or decided and written); else decided in one pass (one octree and one coarse index
/// for all: the merge of the parts is this pass's table, bit for bit, tested). Written.
fn decide_store_top(
    store: &TileStore,
    params: &MpuParams,
    tiles: &TileParams,
    print: &str,
    monitor: &Monitor<'_>,
) -> Result<TileOutcome, TileError> {
    let top_path = store.dir().join("cells-top.bin");
    if let Some(r) = read_record(&top_path, print) {
        return Ok(r);
    }
    let coarse = CoarseOnce::default();
    if !store.dir().join(UPPER_FILE).exists() {
        return decide_top_part(
            store,
            params,
            tiles,
            print,
            TopPart::Whole,
            &coarse,
            monitor,
        );
    }
    // The coarse points read once for all parts; the parts one after the other (each fit
    // runs on every thread), so that one copy of the coarse structures is held at a time.
    let mut top = decide_top_part(
        store,
        params,
        tiles,
        print,
        TopPart::Upper,
        &coarse,
        monitor,
    )?;
    let groups = group_keys(&top, tiles)
        .iter()
        .map(|&key| {
            let part = TopPart::Octant(key);
            decide_top_part(store, params, tiles, print, part, &coarse, monitor)
        })
        .collect::<Result<Vec<_>, _>>()?;
    // In group order, so the surface's order does not depend on which task finished first.
    for g in groups {
        top.cells.merge(g.cells).map_err(|a| {
            TileError::Store(format!(
                "the cell {a:?} was decided by two groups above the tiles"
            ))
        })?;
        top.surface.extend(g.surface);
    }
    write_record(&top_path, print, &top)?;
    Ok(top)
}

/// The keys of the groups under the upper levels `upper` decided (none when the pass above
/// the tiles ends above [`TOP_GROUP_DEPTH`]).
fn group_keys(upper: &TileOutcome, tiles: &TileParams) -> Vec<[u32; 3]> {
    if tiles.depth + tiles.shared_levels <= TOP_GROUP_DEPTH {
        return Vec::new();
    }
    tile_keys(&upper.cells, TOP_GROUP_DEPTH)
}

/// The store's coarse points, read the first time a part of the pass above the tiles needs
/// them (a part found in its file needs none).
#[derive(Default)]
struct CoarseOnce(std::sync::OnceLock<Vec<OrientedPoint>>);

impl CoarseOnce {
    fn get(&self, store: &TileStore) -> Result<&[OrientedPoint], TileError> {
        if let Some(c) = self.0.get() {
            return Ok(c);
        }
        let read = store.coarse_points()?;
        Ok(self.0.get_or_init(|| read))
    }
}

/// The upper levels' decisions file (a cluster's first task of the pass above the tiles).
const UPPER_FILE: &str = "cells-upper.bin";

/// A part of the pass above the tiles.
#[derive(Clone, Copy)]
enum TopPart {
    /// All of it, in one pass.
    Whole,
    /// The levels above [`TOP_GROUP_DEPTH`].
    Upper,
    /// The cell with this key at [`TOP_GROUP_DEPTH`] and those below it, down to the tiles'
    /// shared levels.
    Octant([u32; 3]),
}

/// One part of the pass above the tiles, from its decisions file or decided and written.
fn decide_top_part(
    store: &TileStore,
    params: &MpuParams,
    tiles: &TileParams,
    print: &str,
    part: TopPart,
    coarse: &CoarseOnce,
    monitor: &Monitor<'_>,
) -> Result<TileOutcome, TileError> {
    let manifest = store.manifest();
    let population = manifest.population as usize;
    let until = tiles.depth + tiles.shared_levels;
    let (path, region) = match part {
        TopPart::Whole => (store.dir().join("cells-top.bin"), Region::top(until)),
        TopPart::Upper => (
            store.dir().join(UPPER_FILE),
            Region::top(until.min(TOP_GROUP_DEPTH)),
        ),
        TopPart::Octant(key) => (
            store
                .dir()
                .join(format!("cells-group-{}-{}-{}.bin", key[0], key[1], key[2])),
            Region {
                depth: TOP_GROUP_DEPTH,
                key,
                until: Some(until),
            },
        ),
    };
    if let Some(r) = read_record(&path, print) {
        return Ok(r);
    }
    let coarse = coarse.get(store)?;
    let fetch = |c, r| store.gather_ball(c, r).map_err(|e| e.to_string());
    let kth = |c, k| store.kth_distance(c, k).map_err(|e| e.to_string());
    let fit = fit_top_region(
        coarse,
        population,
        &manifest.frame,
        params,
        &region,
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
    write_record(&path, print, &outcome)?;
    Ok(outcome)
}

/// One tile, under the cells `top` decided (the run's fingerprint `print`; at most `max_cells`
/// cells): from its decisions file, or decided and written.
fn decide_store_tile_with(
    store: &TileStore,
    params: &MpuParams,
    tiles: &TileParams,
    (top, print, max_cells): (&TileOutcome, &str, Option<u64>),
    key: [u32; 3],
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
        (manifest.population as usize, store.count(key)),
        &top.cells,
        store,
        max_cells,
        monitor,
    )?;
    write_record(&path, print, &outcome)?;
    Ok(outcome)
}

/// What a run's decisions depend on: the store's files (their checksums), the parameters and
/// the first halo, hashed.
pub(crate) fn fingerprint(store: &TileStore, params: &MpuParams, tiles: &TileParams) -> String {
    let mut h = Sha256::new();
    let m = store.manifest();
    h.update(format!(
        "{:?} {} {} {:?} {} {}{}",
        m.frame_bits,
        m.population,
        m.depth,
        params,
        tiles.halo.to_bits(),
        tiles.shared_levels,
        if m.normals_negated { " negated" } else { "" }
    ));
    for t in m.tiles.iter().chain([&m.coarse]) {
        h.update(&t.sha256);
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}
