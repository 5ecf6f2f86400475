//! The first step of a run out of core: the input files' points streamed into tile files
//! (`psi_tiles::TileStore`). A first pass finds the frame and the count and writes the store's
//! plan ([`partition_start`]); a second pass writes the tile files, as one part or as several
//! side by side, each streaming the whole input and keeping its own tiles ([`partition_part`],
//! a cluster task each); the manifest is assembled from the parts last
//! ([`partition_assemble`]). The files' bytes do not depend on the number of parts.
//! [`partition_files`] runs the three on this machine, as one part.

use std::fs;
use std::path::{Path, PathBuf};

use psi_io::Format;
use psi_mpu::{MpuFrame, MpuParams};
use psi_octree::{Aabb, Monitor, OrientedPoint};
use psi_tiles::{StorePart, StorePlan, TileStore, TileWriter};

use crate::PsiError;
use crate::budget::OutOfCore;
use crate::files::open_error;
use crate::given_stages::{GivenStage, with_given_stage};
pub use crate::input_points::has_normals;
pub(crate) use crate::input_points::{
    CHUNK, Keep, KeptFrom, Normals, NormalsKind, Points, StoreKind, file_facts, for_each_input,
};
use crate::read_ahead::{AHEAD, read_ahead};

/// The least budget whose partition decodes the input ahead ([`read_ahead`]): 16 × the chunks
/// held ahead (576 MiB), so that they stay a small share of it.
const READ_AHEAD_BUDGET: u64 =
    16 * (AHEAD as u64 + 1) * (CHUNK * std::mem::size_of::<OrientedPoint>()) as u64;

/// What a store of kind `kind` of the files at `paths` records as its source.
pub(crate) fn store_source(paths: &[PathBuf], kind: StoreKind) -> Result<String, PsiError> {
    let tag = match kind.normals {
        NormalsKind::Given => "",
        NormalsKind::Positions => "positions of ",
        NormalsKind::Estimated => "estimated normals of ",
        NormalsKind::Oriented => "oriented normals of ",
    };
    let strays = if kind.strays_left_out {
        // (Since the clump search runs out of core: an earlier psi's store had them in.)
        "strays and clumps left out of "
    } else {
        ""
    };
    Ok(format!("{tag}{strays}{}", sources_of(paths)?))
}

/// The input's points in tile files: what [`partition_files`] made or found.
#[derive(Clone, Debug)]
pub struct Partition {
    /// The tile store (in `<scratch>/tiles`).
    pub store: TileStore,
    /// Points in it.
    pub points: u64,
    /// Points dropped for a zero normal (0 when the store was found).
    pub dropped: u64,
    /// Whether the store of an earlier run on the same files was found and used.
    pub resumed: bool,
}

/// Why a partition stops when the files change between its passes.
const CHANGED: &str = "the input changed while it was being read; run again";

/// What the first pass of a partition found.
#[derive(Clone, Debug)]
pub enum PartitionStart {
    /// The finished store of an earlier run on the same files, tiled as this budget tiles
    /// them: nothing to write.
    Found(Box<Partition>),
    /// A new store was started (its plan written in `<scratch>/tiles`, which the parts
    /// read) for `points` points.
    Planned {
        /// Points in the input (zero normals dropped).
        points: u64,
    },
}

/// The error of a partition of `paths`, named after the first file; an error when there is
/// none.
fn failure_of(paths: &[PathBuf]) -> Result<impl Fn(String) -> PsiError + '_, PsiError> {
    let first = paths.first().ok_or_else(|| PsiError::OutOfCore {
        path: PathBuf::new(),
        reason: "no input files given".into(),
    })?;
    Ok(failure(first))
}

/// What identifies the input `paths`: each file's path, size and modification time.
fn sources_of(paths: &[PathBuf]) -> Result<String, PsiError> {
    Ok(paths
        .iter()
        .map(|p| source_of(p))
        .collect::<Result<Vec<_>, _>>()?
        .join("\n"))
}

/// The first pass over the files at `paths` (one input, their points in this order; each read
/// as `format`, or as its extension says): the store an earlier run on the same files left in
/// `options.scratch`, or the frame (from `mpu_params`) and count, and a new store started with
/// its plan. The tile depth follows the budget ([`OutOfCore::tile_depth_for`]).
///
/// # Errors
///
/// [`PsiError::Open`] / [`PsiError::Read`] for the input; [`PsiError::OutOfCore`] when it has
/// no points or no normals, the budget is too small, or the scratch directory fails (named).
pub fn partition_start(
    paths: &[PathBuf],
    format: Option<Format>,
    mpu_params: &MpuParams,
    options: &OutOfCore,
    stage: GivenStage,
    monitor: &Monitor<'_>,
) -> Result<PartitionStart, PsiError> {
    with_given_stage(options, (stage, true), |dir, points| {
        start_in(paths, format, mpu_params, options, (dir, points), monitor)
    })
}

/// The finished store of kind `kind` in `dir` that an earlier run on the same files wrote,
/// tiled as this budget tiles them; `None` without one.
pub(crate) fn found(
    paths: &[PathBuf],
    options: &OutOfCore,
    dir: &Path,
    kind: StoreKind,
) -> Result<Option<Partition>, PsiError> {
    let source = store_source(paths, kind)?;
    Ok(TileStore::open(dir).ok().and_then(|store| {
        let m = store.manifest();
        let same = m.source == source && options.tile_depth_for(m.population) == Ok(m.depth);
        let points = m.population;
        same.then_some(Partition {
            store,
            points,
            dropped: 0,
            resumed: true,
        })
    }))
}

/// [`partition_start`] of the store in `dir` of the points `points` gives.
fn start_in(
    paths: &[PathBuf],
    format: Option<Format>,
    mpu_params: &MpuParams,
    options: &OutOfCore,
    (dir, points): (&Path, Points<'_>),
    monitor: &Monitor<'_>,
) -> Result<PartitionStart, PsiError> {
    let fail = failure_of(paths)?;
    let source = store_source(paths, points.kind())?;
    // An earlier run's store is used when it holds the same files, tiled as this budget
    // tiles them (the particles depend on the tiling).
    if let Some(partition) = found(paths, options, dir, points.kind())? {
        return Ok(PartitionStart::Found(Box::new(partition)));
    }
    monitor.report("read", 0, 2);
    let (bounds, count) = match kept_extent(paths, points)? {
        Some(known) => known,
        None => extent_of(paths, format, points, monitor)?,
    };
    let bounds = bounds.ok_or_else(|| fail("holds no points".into()))?;
    let frame = MpuFrame::for_bounds(&bounds, count as usize, mpu_params)
        .map_err(|e| fail(e.to_string()))?;
    let depth = options.tile_depth_for(count).map_err(&fail)?;
    let plan = StorePlan::new(&source, &frame, depth);
    plan.start(dir).map_err(|e| fail(e.to_string()))?;
    Ok(PartitionStart::Planned { points: count })
}

/// The bounds and count of the points `points` keeps, from the store of all points they
/// were chosen from ([`Points::kept_from`], when it holds these files' points; its sub-cells
/// at the extremes alone are read); `None` otherwise. The same box as a pass over the input
/// finds (each bound is a minimum or maximum of the same numbers).
fn kept_extent(
    paths: &[PathBuf],
    points: Points<'_>,
) -> Result<Option<(Option<Aabb>, u64)>, PsiError> {
    let Some(from) = points.kept_from.filter(|_| points.keep.is_some()) else {
        return Ok(None);
    };
    let all = StoreKind {
        strays_left_out: false,
        ..points.kind()
    };
    if from.store.manifest().source != store_source(paths, all)? {
        return Ok(None);
    }
    let fail = failure_of(paths)?;
    let keep = |i: u64| Ok(from.strays.binary_search(&i).is_err());
    let bounds = from
        .store
        .bounds_where(&keep)
        .map_err(|e| fail(e.to_string()))?;
    let count = from.store.manifest().population - from.strays.len() as u64;
    tracing::info!(
        found = bounds.is_some(),
        "kept points' bounds from the store of all points"
    );
    Ok(bounds.map(|b| (Some(b), count)))
}

/// The bounds and count of the points `points` gives from the files at `paths` (read as
/// `format`): a pass over the input.
fn extent_of(
    paths: &[PathBuf],
    format: Option<Format>,
    points: Points<'_>,
    monitor: &Monitor<'_>,
) -> Result<(Option<Aabb>, u64), PsiError> {
    let fail = failure_of(paths)?;
    let mut bounds: Option<Aabb> = None;
    let mut count = 0u64;
    for_each_input(paths, format, points, |chunk| {
        count += chunk.len() as u64;
        let b = Aabb::from_points(chunk.iter().map(|p| p.p));
        bounds = match (bounds, b) {
            (Some(a), Some(b)) => Some(Aabb {
                min: a.min.min(b.min),
                max: a.max.max(b.max),
            }),
            (a, b) => a.or(b),
        };
        monitor.check().map_err(|_| fail("interrupted".into()))
    })?;
    Ok((bounds, count))
}

/// The second pass over the files at `paths` for `part` of the store [`partition_start`]
/// planned in `options.scratch`: the whole input streamed, this part's tile files written,
/// grouped and checksummed, and the part's record written last (a part run again, as a
/// cluster retries a task, rewrites the same bytes). Returns the points dropped for a zero
/// normal.
///
/// # Errors
///
/// As [`partition_start`], and [`PsiError::OutOfCore`] when the plan is missing or the files
/// changed since it was made.
pub fn partition_part(
    paths: &[PathBuf],
    format: Option<Format>,
    part: StorePart,
    options: &OutOfCore,
    stage: GivenStage,
    monitor: &Monitor<'_>,
) -> Result<u64, PsiError> {
    with_given_stage(options, (stage, false), |dir, points| {
        part_in(paths, format, part, options, (dir, points), monitor)
    })
}

/// [`partition_part`] of the store in `dir` of the points `points` gives.
fn part_in(
    paths: &[PathBuf],
    format: Option<Format>,
    part: StorePart,
    options: &OutOfCore,
    (dir, points): (&Path, Points<'_>),
    monitor: &Monitor<'_>,
) -> Result<u64, PsiError> {
    let fail = failure_of(paths)?;
    let plan = StorePlan::read(dir).map_err(|e| fail(e.to_string()))?;
    let changed = || fail(CHANGED.into());
    let source = || store_source(paths, points.kind());
    if source()? != plan.source {
        return Err(changed());
    }
    monitor.report("read", 1, 2);
    let buffer = crate::budget::write_buffer_points(options.max_memory);
    let mut writer =
        TileWriter::create_part(dir, &plan, part, buffer).map_err(|e| fail(e.to_string()))?;
    // Decoding the input (on a thread of its own when the pool has two and the budget has
    // room for the chunks ahead) overlaps with writing the tiles.
    let dropped = read_ahead(
        options.max_memory >= READ_AHEAD_BUDGET,
        |visit| for_each_input(paths, format, points, visit),
        |chunk| {
            writer.push(chunk).map_err(|e| fail(e.to_string()))?;
            monitor.check().map_err(|_| fail("interrupted".into()))
        },
        || fail("stopped".into()),
    )?;
    writer.finish_part().map_err(|e| fail(e.to_string()))?;
    // The files must not have changed between the two passes.
    if source()? != plan.source {
        return Err(changed());
    }
    Ok(dropped)
}

/// The manifest of the store in `options.scratch` from its `parts` parts (each written by
/// [`partition_part`]), written last; the store opened. `points`, when given (the count of
/// [`partition_start`]), must be what the parts counted.
///
/// # Errors
///
/// [`PsiError::OutOfCore`] naming the file when a part is missing or the parts disagree.
pub fn partition_assemble(
    paths: &[PathBuf],
    parts: u32,
    points: Option<u64>,
    options: &OutOfCore,
    stage: GivenStage,
) -> Result<Partition, PsiError> {
    with_given_stage(options, (stage, false), |dir, _| {
        assemble_in(paths, parts, points, dir)
    })
}

/// [`partition_assemble`] of the store in `dir`.
fn assemble_in(
    paths: &[PathBuf],
    parts: u32,
    points: Option<u64>,
    dir: &Path,
) -> Result<Partition, PsiError> {
    let fail = failure_of(paths)?;
    let store = TileStore::assemble(dir, parts).map_err(|e| fail(e.to_string()))?;
    let population = store.manifest().population;
    if points.is_some_and(|n| n != population) {
        return Err(fail(CHANGED.into()));
    }
    Ok(Partition {
        store,
        points: population,
        dropped: 0,
        resumed: false,
    })
}

/// The partition on this machine ([`partition_start`], then one [`partition_part`] of the
/// whole store, then [`partition_assemble`]), or the store an earlier run on the same files
/// left in `options.scratch`.
///
/// # Errors
///
/// As the three steps.
pub fn partition_files(
    paths: &[PathBuf],
    format: Option<Format>,
    mpu_params: &MpuParams,
    options: &OutOfCore,
    monitor: &Monitor<'_>,
) -> Result<Partition, PsiError> {
    with_given_stage(options, (GivenStage::Plain, true), |dir, points| {
        partition_with(paths, format, mpu_params, options, (dir, points), monitor)
    })
}

/// What every store of a run is made from: the input's files (one input, in this order; read as
/// `format`, or as their extensions say), the MPU parameters (the frame) and the budget.
#[derive(Clone, Copy)]
pub(crate) struct Input<'a> {
    pub(crate) paths: &'a [PathBuf],
    pub(crate) format: Option<Format>,
    pub(crate) mpu_params: &'a MpuParams,
    pub(crate) options: &'a OutOfCore,
}

impl Input<'_> {
    /// [`partition_with`] of the store in `dir` of the points `points` gives, between the
    /// monitor's reports of stage `name` (started, done).
    pub(crate) fn stage(
        &self,
        name: &str,
        dir: &Path,
        points: Points<'_>,
        monitor: &Monitor<'_>,
    ) -> Result<Partition, PsiError> {
        monitor.report(name, 0, 1);
        let _span = tracing::info_span!("out_of_core_stage", stage = name).entered();
        let (paths, format) = (self.paths, self.format);
        let store = partition_with(
            paths,
            format,
            self.mpu_params,
            self.options,
            (dir, points),
            monitor,
        )?;
        monitor.report(name, 1, 1);
        Ok(store)
    }
}

/// [`partition_files`] into the store in `dir` of the points `points` gives.
pub(crate) fn partition_with(
    paths: &[PathBuf],
    format: Option<Format>,
    mpu_params: &MpuParams,
    options: &OutOfCore,
    (dir, points): (&Path, Points<'_>),
    monitor: &Monitor<'_>,
) -> Result<Partition, PsiError> {
    let at = (dir, points);
    let points = match start_in(paths, format, mpu_params, options, at, monitor)? {
        PartitionStart::Found(found) => return Ok(*found),
        PartitionStart::Planned { points } => points,
    };
    let dropped = part_in(paths, format, StorePart::WHOLE, options, at, monitor)?;
    let partition = assemble_in(paths, 1, Some(points), dir)?;
    monitor.report("read", 2, 2);
    Ok(Partition {
        dropped,
        ..partition
    })
}

/// What identifies the input of a run: its path, size and modification time.
fn source_of(path: &Path) -> Result<String, PsiError> {
    let meta = fs::metadata(path).map_err(|e| open_error(path, e))?;
    let modified = meta
        .modified()
        .ok()
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
        .map_or(0, |d| d.as_nanos());
    let canonical = fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    Ok(format!(
        "{} {} {}",
        canonical.display(),
        meta.len(),
        modified
    ))
}

/// The error of a run out of core on `path`.
pub(crate) fn failure(path: &Path) -> impl Fn(String) -> PsiError + '_ {
    move |reason| PsiError::OutOfCore {
        path: path.to_path_buf(),
        reason,
    }
}
