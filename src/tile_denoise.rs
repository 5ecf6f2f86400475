//! Denoising out of core, bitwise the in-core step ([`psi_preprocess::denoise`]) on the same
//! points: the neighbourhood's scale from the samples' reaches, each found in the tile that
//! holds the sample with a halo around it ([`psi_preprocess::part_denoise_samples`]), then
//! every point's move among its tile's points and halo ([`psi_preprocess::part_denoise`]),
//! written by the point's index to `<scratch>/denoised.bin` (56 bytes a point: the position,
//! the normal, the squared move or NaN where it stayed; removed once read), then
//! the store of the moved points in `<scratch>/denoised` (their frame from their own bounds,
//! as in core; the tiles at the same depth). `store_checks.rs` runs it when the noise asks for
//! it and keeps what it did in the checks' file. Progress: stages `"denoise scale"`,
//! `"denoise"` (tiles done of tiles), then `"denoised"`.

use std::fs::{self, File};
use std::path::Path;

use glam::DVec3;
use psi_mpu::{MpuFrame, MpuParams};
use psi_octree::{Aabb, Monitor, OrientedPoint};
use psi_preprocess::{DenoiseReport, DenoiseScale, part_denoise, part_denoise_samples};
use psi_tiles::{TileStore, TileWriter};

use crate::tile_parts::{Halos, RecordFile, by_tile, each_tile, each_tile_into, first_halo};
use crate::tile_parts::{io_reason, write_at};

/// The moves' file in the scratch directory.
pub(crate) const DENOISED_FILE: &str = "denoised.bin";

/// The store of the moved points in the scratch directory.
pub(crate) const DENOISED_DIR: &str = "denoised";

/// Bytes of a point's record in `denoised.bin`: position, normal, squared move (f64 each).
const RECORD: usize = 56;

/// Points written to the store a chunk at a time.
const CHUNK: u64 = 1 << 16;

/// What the store of the moved points records as its source: the store they were moved from.
pub(crate) fn denoised_source(from: &TileStore) -> String {
    format!(
        "denoised points of the store {}\n{}",
        from.digest(),
        from.manifest().source
    )
}

/// The record of point `p` that moved by `move2` (world units²; NaN: it stayed).
fn record_of(p: &OrientedPoint, move2: f64) -> [u8; RECORD] {
    let mut out = [0u8; RECORD];
    let values = [p.p.x, p.p.y, p.p.z, p.n.x, p.n.y, p.n.z, move2];
    for (k, v) in values.iter().enumerate() {
        out[8 * k..8 * k + 8].copy_from_slice(&v.to_le_bytes());
    }
    out
}

/// The point and squared move of a record.
fn of_record(r: &[u8; RECORD]) -> (OrientedPoint, f64) {
    let f = |k: usize| f64::from_le_bytes(r[8 * k..8 * k + 8].try_into().expect("8"));
    let point = OrientedPoint {
        p: DVec3::new(f(0), f(1), f(2)),
        n: DVec3::new(f(3), f(4), f(5)),
    };
    (point, f(6))
}

/// Denoises `store`'s points (noise deviation `sigma`, world units; the halos from `halos`,
/// grown as the points need) into the store `<scratch>/denoised` (its frame from `mpu`'s
/// parameters and the moved points' bounds; its writer buffers an eighth of `max_memory`
/// bytes, as the partition's does); returns it with what the step did, as
/// [`psi_preprocess::denoise`] reports it. `None` when there is nothing to denoise (as in
/// core: fewer than 24 points, σ not positive).
///
/// # Errors
///
/// Why a file could not be read or written (named), or `"interrupted"`.
pub(crate) fn denoise_store(
    store: &TileStore,
    sigma: f64,
    (scratch, mpu, max_memory): (&Path, &MpuParams, u64),
    halos: &mut Halos,
    monitor: &Monitor<'_>,
) -> Result<Option<(TileStore, DenoiseReport)>, String> {
    let m = store.manifest();
    let n = usize::try_from(m.population).map_err(|_| "too many points".to_string())?;
    let keys = store.tile_keys();
    let first = |key| first_halo(store, key);
    // The scale, from the samples' reaches.
    let samples = each_tile(
        &keys,
        (&mut *halos, &first),
        ("denoise scale", monitor),
        &|key, halo| {
            let (_, found) = by_tile(store, key, halo, |t, ids, holds| {
                let positions: Vec<DVec3> = t.points.iter().map(|p| p.p).collect();
                part_denoise_samples(&positions, ids, &t.own, holds, n)
            })?;
            Ok(found)
        },
    )?;
    let Some(scale) = DenoiseScale::of(n, sigma, &samples.concat()) else {
        return Ok(None);
    };
    // The moves by index (a file an earlier run left is stale: the checks remove it first).
    let path = scratch.join(DENOISED_FILE);
    let file = File::create(&path).map_err(|e| io_reason(&path, &e))?;
    file.set_len(m.population * RECORD as u64)
        .map_err(|e| io_reason(&path, &e))?;
    let mut written = 0u64;
    each_tile_into(
        &keys,
        (halos, &first),
        ("denoise", monitor),
        &|key, halo| {
            let (tile, moved) = by_tile(store, key, halo, |t, ids, holds| {
                part_denoise(&t.points, ids, &t.own, holds, &scale, monitor)
            })?;
            Ok(tile
                .own_points()
                .zip(moved)
                .map(|((i, p), m)| match m {
                    Some(m) => (i, record_of(&m, (m.p - p.p).length_squared())),
                    None => (i, record_of(p, f64::NAN)),
                })
                .collect::<Vec<_>>())
        },
        &mut |records| {
            written += records.len() as u64;
            for (i, r) in records {
                write_at(&file, &r, i * RECORD as u64).map_err(|e| io_reason(&path, &e))?;
            }
            Ok(())
        },
    )?;
    monitor.check().map_err(|_| "interrupted".to_string())?;
    if written != m.population {
        return Err(format!(
            "{}: the tiles hold {written} points, the store {}",
            store.dir().display(),
            m.population
        ));
    }
    file.sync_all().map_err(|e| io_reason(&path, &e))?;
    drop(file);
    // The moved points' bounds and the report's sums, in index order as in core; then the
    // store.
    let records = RecordFile::<RECORD>::open(&path)?;
    let mut bounds: Option<(DVec3, DVec3)> = None;
    let (mut moved, mut sum2) = (0, 0.0);
    for i in 0..m.population {
        let (p, move2) = of_record(&records.get(i)?);
        bounds = Some(bounds.map_or((p.p, p.p), |(lo, hi)| (lo.min(p.p), hi.max(p.p))));
        if !move2.is_nan() {
            moved += 1;
            sum2 += move2;
        }
    }
    let report = DenoiseReport::of_sum(scale.neighbours, moved, sum2);
    let (min, max) = bounds.ok_or("no points")?;
    let frame = MpuFrame::for_bounds(&Aabb { min, max }, n, mpu).map_err(|e| e.to_string())?;
    monitor.report("denoised", 0, 1);
    let dir = scratch.join(DENOISED_DIR);
    let buffer = crate::budget::write_buffer_points(max_memory);
    let mut writer = TileWriter::create(&dir, frame, m.depth, buffer, &denoised_source(store))
        .map_err(|e| e.to_string())?;
    let mut chunk = Vec::with_capacity(CHUNK as usize);
    for i in 0..m.population {
        chunk.push(of_record(&records.get(i)?).0);
        if chunk.len() as u64 == CHUNK || i + 1 == m.population {
            writer.push(&chunk).map_err(|e| e.to_string())?;
            chunk.clear();
            monitor.check().map_err(|_| "interrupted".to_string())?;
        }
    }
    let denoised = writer.finish().map_err(|e| e.to_string())?;
    drop(records);
    fs::remove_file(&path).map_err(|e| io_reason(&path, &e))?;
    monitor.report("denoised", 1, 1);
    Ok(Some((denoised, report)))
}
