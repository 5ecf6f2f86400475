//! The outlier step of a run out of core: repeated positions and the outlier search's strays
//! left out tile by tile (psi-preprocess's `part_standings` and `part_outliers` on each tile
//! and a halo of the points around it), then the stray clumps among the points kept
//! (`tile_clumps.rs`), bitwise the in-core step. The verdicts go to `strays.bin` in the scratch directory (one byte a point, by its index in
//! the store of all points; renamed into place once whole, kept for a rerun's report), which the
//! partition of the kept points reads ([`crate::partition::Points::keep`]). Progress: stages
//! `"standings"`, `"strays"` and `"clumps"` (tiles done of tiles). Notes:
//! `docs/notes/2026-12-03-outliers-by-parts.md`.

use std::fs::{self, File};
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

use glam::DVec3;
use psi_octree::Monitor;
use psi_preprocess::{
    OutlierStats, OwnStanding, StrayVerdict, median_of_passes, part_outliers, part_standings,
    settled_verdicts,
};
use psi_tiles::{TileStore, TileWithHalo};
use serde::{Deserialize, Serialize};

use crate::PsiError;
use crate::budget::OutOfCore;
use crate::given_stages::{
    GivenStage, STRAYS_FILE, strays_source, verdicts_source, with_given_stage,
};
use crate::partition::{Input, NormalsKind, Partition, StoreKind, failure, found, store_source};
use crate::tile_clumps::stray_clumps;
use crate::tile_parts::{
    Halos, WholeFile, by_tile, each_tile_into, first_halo, io_reason, read_at,
};

/// What the outlier step left out of a run out of core.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct StrayTally {
    /// Points whose position repeats that of a point of lower index.
    pub repeated: u64,
    /// Outliers farther than a few sample spacings from every point on a surface.
    pub far: u64,
    /// Outliers near the data but off the surface it describes.
    pub off_surface: u64,
    /// Points in small groups lying apart from the rest, off its surface (stray clumps).
    #[serde(default)]
    pub clumps: u64,
}

impl StrayTally {
    /// Points left out.
    pub fn removed(&self) -> u64 {
        self.repeated + self.far + self.off_surface + self.clumps
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

/// A stray clump's point as `strays.bin` stores it (the clump search follows the verdicts).
const CLUMP: u8 = 4;

/// The tally of the verdicts in the file at `path`.
pub(crate) fn tally_of(path: &Path) -> Result<StrayTally, String> {
    let bytes = fs::read(path).map_err(|e| io_reason(path, &e))?;
    tally_of_bytes(&bytes).map_err(|b| format!("{}: not a verdict: {b}", path.display()))
}

/// The tally of verdicts as `strays.bin` stores them ([`code`]), or the first byte that is none.
fn tally_of_bytes(verdicts: &[u8]) -> Result<StrayTally, u8> {
    let mut counts = [0u64; 5];
    for &b in verdicts {
        *counts.get_mut(b as usize).ok_or(b)? += 1;
    }
    Ok(StrayTally {
        repeated: counts[1],
        far: counts[2],
        off_surface: counts[3],
        clumps: counts[CLUMP as usize],
    })
}

/// The tiles of batch `batch` of `batches` of `store` (its keys in that many contiguous runs,
/// as a cluster's tasks take them).
fn batch_keys(store: &TileStore, (batch, batches): (u32, u32)) -> Vec<[u32; 3]> {
    let keys = store.tile_keys();
    let per = keys.len().div_ceil(batches.max(1) as usize).max(1);
    keys.chunks(per)
        .nth(batch as usize)
        .map(<[_]>::to_vec)
        .unwrap_or_default()
}

/// A batch's file in the scratch directory `scratch`.
fn batch_file(scratch: &Path, what: &str, batch: u32) -> PathBuf {
    scratch.join(format!("strays-{what}-{batch}.bin"))
}

/// The first halo of a pass of the outlier step, in first halos ([`first_halo`]): a point's
/// standing reads its neighbours' neighbours, which one first halo rarely holds at a tile's
/// face (measured: `docs/notes/2026-12-03-outliers-by-parts.md`).
const FIRST_HALOS: f64 = 2.0;

/// A tile's header in a file of [`stray_standings`]: its key (three little-endian u32) and its
/// own points' count (a little-endian u64).
const HEADER: usize = 20;

/// A record of [`stray_standings`]: a point's input index (a little-endian u64), then its
/// [`OwnStanding`].
const RECORD: usize = 8 + OwnStanding::BYTES;

/// The outlier step's first pass over batch `batch` of `batches` of the tiles of `store` (all
/// the input's points; their normals read when `normals_given`): each own point's standing
/// (`part_standings`), written to a file of the batch in `scratch`, tile by tile, each tile
/// after a header; how many points were searched (the distances whose median
/// [`stray_stats`] takes). A cluster's task each (`psi.distributed.sample_files`); run again,
/// it writes the same file.
///
/// # Errors
///
/// The store or the file cannot be read or written (named), or `monitor` stopped the work.
pub fn stray_standings(
    store: &TileStore,
    scratch: &Path,
    batch: (u32, u32),
    normals_given: bool,
    monitor: &Monitor<'_>,
) -> Result<u64, String> {
    let keys = batch_keys(store, batch);
    let first = |key| FIRST_HALOS * first_halo(store, key);
    let mut file = WholeFile::create(&batch_file(scratch, "standings", batch.0))?;
    let mut count = 0u64;
    each_tile_into(
        &keys,
        (&mut Halos::new(), &first),
        ("standings", monitor),
        &|key, halo| {
            let (tile, found) = by_tile(store, key, halo, |t, ids, holds| {
                let (positions, normals) = part_points(t, normals_given);
                part_standings(&positions, ids, &t.own, normals.as_deref(), holds)
            })?;
            let mut bytes = Vec::with_capacity(HEADER + RECORD * found.len());
            for k in key {
                bytes.extend(k.to_le_bytes());
            }
            bytes.extend((found.len() as u64).to_le_bytes());
            let mut searched = 0u64;
            for ((i, _), st) in tile.own_points().zip(found) {
                bytes.extend(i.to_le_bytes());
                bytes.extend(st.to_bytes());
                searched += u64::from(st.searched_reach().is_some());
            }
            Ok((bytes, searched))
        },
        &mut |(bytes, searched)| {
            count += searched;
            file.write(&bytes)
        },
    )?;
    file.finish()?;
    Ok(count)
}

/// A part's positions, and its normals when `normals_given` (shape: M each).
fn part_points(t: &TileWithHalo, normals_given: bool) -> (Vec<DVec3>, Option<Vec<DVec3>>) {
    let positions = t.points.iter().map(|p| p.p).collect();
    let normals = normals_given.then(|| t.points.iter().map(|p| p.n).collect());
    (positions, normals)
}

/// A batch file of [`stray_standings`]: each tile's key, and the offset and count of its
/// records.
struct Standings {
    path: PathBuf,
    file: File,
    tiles: Vec<([u32; 3], u64, u64)>,
}

impl Standings {
    /// Reads the headers of the file of batch `batch` in `scratch`.
    fn open(scratch: &Path, batch: u32) -> Result<Self, String> {
        let path = batch_file(scratch, "standings", batch);
        let file = File::open(&path).map_err(|e| io_reason(&path, &e))?;
        let len = file.metadata().map_err(|e| io_reason(&path, &e))?.len();
        let mut tiles = Vec::new();
        let mut at = 0u64;
        while at < len {
            let mut header = [0u8; HEADER];
            read_at(&file, &mut header, at).map_err(|e| io_reason(&path, &e))?;
            let word =
                |k: usize| u32::from_le_bytes(header[4 * k..4 * k + 4].try_into().expect("4"));
            let count = u64::from_le_bytes(header[12..].try_into().expect("8"));
            let start = at + HEADER as u64;
            at = count
                .checked_mul(RECORD as u64)
                .and_then(|b| b.checked_add(start))
                .filter(|&end| end <= len)
                .ok_or_else(|| format!("{}: truncated", path.display()))?;
            tiles.push(([word(0), word(1), word(2)], start, count));
        }
        Ok(Self { path, file, tiles })
    }

    /// Each record's distance of a searched point, to `visit`.
    fn each_reach(&self, visit: &mut dyn FnMut(f64)) -> Result<(), String> {
        for &(key, _, _) in &self.tiles {
            for (_, st) in self.of_tile(key)? {
                if let Some(r) = st.searched_reach() {
                    visit(r);
                }
            }
        }
        Ok(())
    }

    /// Tile `key`'s own points: their input indices and standings.
    fn of_tile(&self, key: [u32; 3]) -> Result<Vec<(u64, OwnStanding)>, String> {
        let &(_, start, count) = self
            .tiles
            .iter()
            .find(|t| t.0 == key)
            .ok_or_else(|| format!("{}: no tile {key:?}", self.path.display()))?;
        let mut bytes = vec![0u8; count as usize * RECORD];
        read_at(&self.file, &mut bytes, start).map_err(|e| io_reason(&self.path, &e))?;
        bytes
            .chunks_exact(RECORD)
            .map(|r| {
                let id = u64::from_le_bytes(r[..8].try_into().expect("8"));
                let st = OwnStanding::from_bytes(r[8..].try_into().expect("9"));
                st.map(|st| (id, st))
                    .ok_or_else(|| format!("{}: not a standing", self.path.display()))
            })
            .collect()
    }
}

/// The statistics the outlier search reads, from the `batches` files of [`stray_standings`]
/// in `scratch`: the points searched and the median of their distances (streamed, exact).
///
/// # Errors
///
/// A file cannot be read (named).
pub fn stray_stats(scratch: &Path, batches: u32) -> Result<OutlierStats, String> {
    let _span = tracing::info_span!("out_of_core_stage", stage = "median").entered();
    let files = (0..batches)
        .map(|b| Standings::open(scratch, b))
        .collect::<Result<Vec<_>, String>>()?;
    // The points searched, counted in the first pass.
    let (mut points, mut first) = (0u64, true);
    let typical = median_of_passes(|visit: &mut dyn FnMut(f64)| {
        let counting = std::mem::take(&mut first);
        let mut each = |r| {
            points += u64::from(counting);
            visit(r);
        };
        files.iter().try_for_each(|f| f.each_reach(&mut each))
    })?
    .ok_or_else(|| format!("{}: the distances changed while read", scratch.display()))?;
    Ok(OutlierStats { typical, points })
}

/// The outlier step's verdicts on batch `batch` of `batches` of the tiles of `store` (all the
/// input's points; their normals read when `normals_given`) from their standings in the
/// batch's file of [`stray_standings`] with the whole input's `stats`, written to a file of
/// the batch in `scratch` (each own point's index and verdict). A tile none of whose points is
/// unsure or sparse is not read again. A cluster's task each; run again, it writes the same
/// file.
///
/// # Errors
///
/// As [`stray_standings`], and a standing that is not of this store's tile.
pub fn stray_verdicts_of_batch(
    store: &TileStore,
    scratch: &Path,
    batch: (u32, u32),
    (normals_given, stats): (bool, OutlierStats),
    monitor: &Monitor<'_>,
) -> Result<(), String> {
    let keys = batch_keys(store, batch);
    let standings = Standings::open(scratch, batch.0)?;
    let first = |key| FIRST_HALOS * first_halo(store, key);
    let mut file = WholeFile::create(&batch_file(scratch, "verdicts", batch.0))?;
    each_tile_into(
        &keys,
        (&mut Halos::new(), &first),
        ("strays", monitor),
        &|key, halo| {
            let records = standings.of_tile(key)?;
            let stale = || {
                let path = standings.path.display();
                format!("{path}: not the standings of tile {key:?} of this store")
            };
            if records.len() as u64 != store.count(key) {
                return Err(stale());
            }
            let own: Vec<OwnStanding> = records.iter().map(|r| r.1).collect();
            let found = match settled_verdicts(&own, stats) {
                Some(found) => found,
                None => {
                    let (_, found) = by_tile(store, key, halo, |t, ids, holds| {
                        if !t.own_points().map(|p| p.0).eq(records.iter().map(|r| r.0)) {
                            return Ok(None);
                        }
                        let (positions, normals) = part_points(t, normals_given);
                        let n = normals.as_deref();
                        part_outliers(&positions, ids, &t.own, n, holds, (stats, &own)).map(Some)
                    })?;
                    found.ok_or_else(stale)?
                }
            };
            let mut bytes = Vec::with_capacity(9 * found.len());
            for ((i, _), v) in records.iter().zip(found) {
                bytes.extend(i.to_le_bytes());
                bytes.push(code(v));
            }
            Ok(bytes)
        },
        &mut |bytes| file.write(&bytes),
    )?;
    file.finish()
}

/// The tally of `strays.bin` in `scratch` when it is whole and holds the verdicts of the store
/// whose source is `source` (an earlier run's, on the same input and store); `None` otherwise.
pub(crate) fn strays_of(scratch: &Path, source: &str, n: Option<u64>) -> Option<StrayTally> {
    let path = scratch.join(STRAYS_FILE);
    let same =
        fs::read_to_string(strays_source(scratch)).is_ok_and(|s| s == verdicts_source(source));
    let whole = n.is_none_or(|n| fs::metadata(&path).is_ok_and(|m| m.len() == n));
    (same && whole).then(|| tally_of(&path).ok()).flatten()
}

/// The final store (`tiles/`) of kind `kind` an earlier run on `paths` wrote in
/// `options.scratch`, with the tally of the outlier step's verdicts it was made from when it
/// left strays out (verdicts of the store of all points whose normals are `all_normals`); `None`
/// when either is missing.
pub(crate) fn found_with_strays(
    paths: &[PathBuf],
    options: &OutOfCore,
    kind: StoreKind,
    all_normals: NormalsKind,
) -> Result<Option<(Partition, Option<StrayTally>)>, PsiError> {
    let Some(found) = found(paths, options, &options.scratch.join("tiles"), kind)? else {
        return Ok(None);
    };
    if !kind.strays_left_out {
        return Ok(Some((found, None)));
    }
    let all = StoreKind {
        normals: all_normals,
        strays_left_out: false,
    };
    let tally = strays_of(&options.scratch, &store_source(paths, all)?, None);
    Ok(tally.map(|t| (found, Some(t))))
}

/// `strays.bin` in `scratch` (one byte a point of `store`, the store of all points, by its
/// index) from the `batches` files of [`stray_verdicts_of_batch`], which are removed with those
/// of [`stray_standings`], and the stray clumps among the points they keep
/// (`tile_clumps.rs`; progress to `monitor`); the tally. The store's source is recorded beside
/// it (after it: a rerun trusts only verdicts of its own store).
///
/// # Errors
///
/// A file cannot be read or written (named), a point has no verdict, or interrupted.
pub fn stray_join(
    store: &TileStore,
    scratch: &Path,
    batches: u32,
    monitor: &Monitor<'_>,
) -> Result<StrayTally, String> {
    const UNSET: u8 = u8::MAX;
    let _span = tracing::info_span!("out_of_core_stage", stage = "join").entered();
    let source_path = strays_source(scratch);
    if source_path.exists() {
        fs::remove_file(&source_path).map_err(|e| io_reason(&source_path, &e))?;
    }
    let n = store.manifest().population;
    let mut verdicts = vec![UNSET; n as usize];
    for b in 0..batches {
        let f = batch_file(scratch, "verdicts", b);
        let file = File::open(&f).map_err(|e| io_reason(&f, &e))?;
        let mut reader = BufReader::with_capacity(9 << 16, file);
        let mut record = [0u8; 9];
        loop {
            match reader.read_exact(&mut record) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => break,
                Err(e) => return Err(io_reason(&f, &e)),
            }
            let i = u64::from_le_bytes(record[..8].try_into().expect("8 bytes"));
            let slot = verdicts
                .get_mut(i as usize)
                .ok_or_else(|| format!("{}: point {i} of {n}", f.display()))?;
            *slot = record[8];
        }
    }
    if let Some(i) = verdicts.iter().position(|&v| v == UNSET) {
        return Err(format!("{}: no verdict for point {i}", scratch.display()));
    }
    // The stray clumps among the points kept, as in core.
    let (clumped, _) = stray_clumps(store, &verdicts, monitor)?;
    for i in clumped {
        verdicts[i as usize] = CLUMP;
    }
    let tally = tally_of_bytes(&verdicts)
        .map_err(|b| format!("{}: not a verdict: {b}", scratch.display()))?;
    let path = scratch.join(STRAYS_FILE);
    let mut file = WholeFile::create(&path)?;
    file.write(&verdicts)?;
    file.finish()?;
    fs::write(&source_path, verdicts_source(&store.manifest().source))
        .map_err(|e| io_reason(&source_path, &e))?;
    for b in 0..batches {
        for what in ["standings", "verdicts"] {
            let f = batch_file(scratch, what, b);
            fs::remove_file(&f).map_err(|e| io_reason(&f, &e))?;
        }
    }
    Ok(tally)
}

/// The outlier step's verdicts on the points of `store` (all the input's points; their
/// normals read when `normals_given`) into `strays.bin` in `scratch`, unless an earlier run
/// left them there for this store; their tally. On this machine, one batch of
/// [`stray_standings`], [`stray_stats`], [`stray_verdicts_of_batch`] and [`stray_join`].
pub(crate) fn stray_verdicts(
    store: &TileStore,
    scratch: &Path,
    normals_given: bool,
    monitor: &Monitor<'_>,
) -> Result<StrayTally, String> {
    let m = store.manifest();
    if let Some(tally) = strays_of(scratch, &m.source, Some(m.population)) {
        return Ok(tally);
    }
    stray_standings(store, scratch, (0, 1), normals_given, monitor)?;
    let stats = stray_stats(scratch, 1)?;
    stray_verdicts_of_batch(store, scratch, (0, 1), (normals_given, stats), monitor)?;
    stray_join(store, scratch, 1, monitor)
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
    let all_dir = scratch.join("all");
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
    // The final store of an earlier run, with the verdicts it was made from (for the report).
    if let Some((found, Some(tally))) = found_with_strays(paths, options, kind, NormalsKind::Given)?
    {
        clean_up()?;
        return Ok((found, tally));
    }
    let all = with_given_stage(options, (GivenStage::All, true), |dir, points| {
        input.stage("all points", dir, points, monitor)
    })?;
    let tally = stray_verdicts(&all.store, scratch, true, monitor).map_err(&fail)?;
    let kept = with_given_stage(options, (GivenStage::Kept, true), |dir, points| {
        input.stage("kept points", dir, points, monitor)
    })?;
    clean_up()?;
    Ok((
        Partition {
            dropped: all.dropped,
            ..kept
        },
        tally,
    ))
}
