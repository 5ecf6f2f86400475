//! The outlier step of a run out of core: repeated positions and the outlier search's strays
//! left out tile by tile (psi-preprocess's `part_outlier_reaches` and `part_outliers` on each
//! tile and a halo of the points around it), bitwise the in-core step before its clump search.
//! The verdicts go to `strays.bin` in the scratch directory (one byte a point, by its index in
//! the store of all points; renamed into place once whole, kept for a rerun's report), which the
//! partition of the kept points reads ([`crate::partition::Points::keep`]). Progress: stages
//! `"reaches"` and `"strays"` (tiles done of tiles). Notes:
//! `docs/notes/2026-12-03-outliers-by-parts.md`.

use std::collections::BTreeMap;
use std::fs::{self, File};
use std::io::{BufReader, BufWriter, Read, Write};
use std::path::Path;

use glam::DVec3;
use psi_octree::Monitor;
use psi_preprocess::{
    OutlierStats, StrayVerdict, median_of_passes, part_outlier_reaches, part_outliers,
};
use psi_tiles::TileStore;
use serde::{Deserialize, Serialize};

use crate::PsiError;
use crate::partition::{Input, Normals, NormalsKind, Partition, Points, StoreKind, failure, found};
use crate::tile_parts::{RecordFile, by_tile, first_halo, io_reason};

/// The verdicts' file in the scratch directory.
pub(crate) const STRAYS_FILE: &str = "strays.bin";

/// What the outlier step left out of a run out of core.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct StrayTally {
    /// Points whose position repeats that of a point of lower index.
    pub repeated: u64,
    /// Outliers farther than a few sample spacings from every point on a surface.
    pub far: u64,
    /// Outliers near the data but off the surface it describes.
    pub off_surface: u64,
}

impl StrayTally {
    /// Points left out.
    pub fn removed(&self) -> u64 {
        self.repeated + self.far + self.off_surface
    }
}

/// A verdict as `strays.bin` stores it.
fn code(v: StrayVerdict) -> u8 {
    match v {
        StrayVerdict::Kept => 0,
        StrayVerdict::Repeated => 1,
        StrayVerdict::Far => 2,
        StrayVerdict::OffSurface => 3,
    }
}

/// The tally of the verdicts in the file at `path`.
pub(crate) fn tally_of(path: &Path) -> Result<StrayTally, String> {
    let file = File::open(path).map_err(|e| io_reason(path, &e))?;
    let mut counts = [0u64; 4];
    let mut bytes = BufReader::new(file).bytes();
    bytes.try_for_each(|b| {
        let b = b.map_err(|e| io_reason(path, &e))?;
        let slot = counts
            .get_mut(b as usize)
            .ok_or_else(|| format!("{}: not a verdict: {b}", path.display()))?;
        *slot += 1;
        Ok::<(), String>(())
    })?;
    Ok(StrayTally {
        repeated: counts[1],
        far: counts[2],
        off_surface: counts[3],
    })
}

/// The outlier step's verdicts on the points of `store` (all the input's points; their normals
/// read when `normals_given`) into the file at `path`, one byte a point by the store's index
/// (kept: 0), unless that file is there whole; their tally. First each point's 16th-neighbour
/// distance, tile by tile, into a file beside it, whose median (streamed) the search reads;
/// then the verdicts, each tile's halo starting where the first pass left it.
pub(crate) fn stray_verdicts(
    store: &TileStore,
    path: &Path,
    normals_given: bool,
    monitor: &Monitor<'_>,
) -> Result<StrayTally, String> {
    let n = store.manifest().population;
    if fs::metadata(path).map(|m| m.len()).ok() == Some(n) {
        return tally_of(path);
    }
    let interrupted = || "interrupted".to_string();
    let keys = store.tile_keys();
    let mut halos: BTreeMap<[u32; 3], f64> = BTreeMap::new();
    let reaches_path = path.with_extension("reaches");
    let mut reaches =
        BufWriter::new(File::create(&reaches_path).map_err(|e| io_reason(&reaches_path, &e))?);
    let mut count = 0u64;
    for (done, &key) in keys.iter().enumerate() {
        monitor.report("reaches", done as u64, keys.len() as u64);
        let halo = halos.entry(key).or_insert_with(|| first_halo(store, key));
        let (_, found) = by_tile(store, key, halo, |t, ids, holds| {
            let positions: Vec<DVec3> = t.points.iter().map(|p| p.p).collect();
            part_outlier_reaches(&positions, ids, &t.own, holds)
        })?;
        for r in &found {
            reaches
                .write_all(&r.to_le_bytes())
                .map_err(|e| io_reason(&reaches_path, &e))?;
        }
        count += found.len() as u64;
        monitor.check().map_err(|_| interrupted())?;
    }
    reaches
        .into_inner()
        .map_err(|e| io_reason(&reaches_path, e.error()))?
        .sync_all()
        .map_err(|e| io_reason(&reaches_path, &e))?;
    let typical = median_of_passes(|visit: &mut dyn FnMut(f64)| {
        let file = File::open(&reaches_path).map_err(|e| io_reason(&reaches_path, &e))?;
        let mut reader = BufReader::with_capacity(1 << 20, file);
        let mut record = [0u8; 8];
        for _ in 0..count {
            reader
                .read_exact(&mut record)
                .map_err(|e| io_reason(&reaches_path, &e))?;
            visit(f64::from_le_bytes(record));
        }
        Ok::<(), String>(())
    })?;
    fs::remove_file(&reaches_path).map_err(|e| io_reason(&reaches_path, &e))?;
    let stats = OutlierStats {
        typical,
        points: count,
    };
    // The verdicts, a byte a point, held until whole.
    let mut verdicts = vec![0u8; n as usize];
    for (done, &key) in keys.iter().enumerate() {
        monitor.report("strays", done as u64, keys.len() as u64);
        let halo = halos.entry(key).or_insert_with(|| first_halo(store, key));
        let (tile, found) = by_tile(store, key, halo, |t, ids, holds| {
            let positions: Vec<DVec3> = t.points.iter().map(|p| p.p).collect();
            let normals: Option<Vec<DVec3>> =
                normals_given.then(|| t.points.iter().map(|p| p.n).collect());
            part_outliers(&positions, ids, &t.own, normals.as_deref(), holds, stats)
        })?;
        for ((i, _), v) in tile.own_points().zip(found) {
            verdicts[i as usize] = code(v);
        }
        monitor.check().map_err(|_| interrupted())?;
    }
    let partial = path.with_extension("bin.partial");
    let mut file = File::create(&partial).map_err(|e| io_reason(&partial, &e))?;
    file.write_all(&verdicts)
        .and_then(|()| file.sync_all())
        .map_err(|e| io_reason(&partial, &e))?;
    fs::rename(&partial, path).map_err(|e| io_reason(path, &e))?;
    tally_of(path)
}

/// The store of `input`'s points (files with normals) without the outlier step's strays, in `options.scratch/tiles` (found there when an
/// earlier run wrote it for the same files), with what was left out: all points first stored
/// in `options.scratch/all` (removed once the kept points are stored), their verdicts
/// ([`stray_verdicts`]), then the kept points stored. On a cluster, one task
/// (`psi.distributed.sample_files`).
///
/// # Errors
///
/// [`PsiError::OutOfCore`] naming the first file: a scratch file fails; the partition's errors.
pub(crate) fn partition_removing_outliers(
    input: Input<'_>,
    monitor: &Monitor<'_>,
) -> Result<(Partition, StrayTally), PsiError> {
    let (paths, options) = (input.paths, input.options);
    let fail = failure(&paths[0]);
    let scratch = &options.scratch;
    let (all_dir, final_dir) = (scratch.join("all"), scratch.join("tiles"));
    let strays_path = scratch.join(STRAYS_FILE);
    let kind = StoreKind {
        normals: NormalsKind::Given,
        strays_left_out: true,
    };
    let clean_up = || -> Result<(), PsiError> {
        if all_dir.exists() {
            fs::remove_dir_all(&all_dir).map_err(|e| fail(io_reason(&all_dir, &e)))?;
        }
        Ok(())
    };
    if let Some(found) = found(paths, options, &final_dir, kind)?
        && let Ok(tally) = tally_of(&strays_path)
    {
        clean_up()?;
        return Ok((found, tally));
    }
    let all = {
        let points = Points::all(Normals::Given);
        input.stage("all points", &all_dir, points, monitor)?
    };
    if !all.resumed && strays_path.exists() {
        // Another input's verdicts (an earlier run's, left in this scratch directory).
        fs::remove_file(&strays_path).map_err(|e| fail(io_reason(&strays_path, &e)))?;
    }
    let tally = stray_verdicts(&all.store, &strays_path, true, monitor).map_err(&fail)?;
    let kept = {
        let verdicts = RecordFile::<1>::open(&strays_path).map_err(&fail)?;
        let keep = |i: u64| verdicts.get(i).map(|v| v[0] == 0);
        let points = Points {
            normals: Normals::Given,
            keep: Some(&keep),
        };
        input.stage("kept points", &final_dir, points, monitor)?
    };
    clean_up()?;
    Ok((
        Partition {
            dropped: all.dropped,
            ..kept
        },
        tally,
    ))
}
