//! The first step of a run out of core: the input files' points streamed into tile files
//! (`psi_tiles::TileStore`). A first pass finds the frame and the count and writes the store's
//! plan ([`partition_start`]); a second pass writes the tile files, as one part or as several
//! side by side, each streaming the whole input and keeping its own tiles ([`partition_part`],
//! a cluster task each); the manifest is assembled from the parts last
//! ([`partition_assemble`]). The files' bytes do not depend on the number of parts.
//! [`partition_files`] runs the three on this machine, as one part.

use std::fs;
use std::io::BufReader;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

use psi_io::{Format, PointStream, ReadOptions, chunk_oriented_points};
use psi_mpu::{MpuFrame, MpuParams};
use psi_octree::{Aabb, Monitor, OrientedPoint};
use psi_tiles::{StorePart, StorePlan, TileStore, TileWriter};

use crate::PsiError;
use crate::budget::OutOfCore;
use crate::files::{check_not_dir, extension_format, open_error, read_error};
use crate::read_ahead::{AHEAD, read_ahead};

/// Points streamed per chunk.
const CHUNK: usize = 1 << 18;
/// The least budget whose partition decodes the input ahead ([`read_ahead`]): 16 × the chunks
/// held ahead (576 MiB), so that they stay a small share of it.
const READ_AHEAD_BUDGET: u64 =
    16 * (AHEAD as u64 + 1) * (CHUNK * std::mem::size_of::<OrientedPoint>()) as u64;

/// Calls `visit` with the oriented points of the file at `path`, chunk by chunk in file
/// order: the scanner formats, XYZ and PLY point clouds streamed, PLY meshes and OBJ read
/// whole first. Returns the
/// points dropped for a zero normal.
fn for_each_points(
    path: &Path,
    format: Option<Format>,
    mut visit: impl FnMut(&[OrientedPoint]) -> Result<(), PsiError>,
) -> Result<u64, PsiError> {
    check_not_dir(path)?;
    let no_normals = || PsiError::OutOfCore {
        path: path.to_path_buf(),
        reason: "has no normals: a run out of core takes oriented points (estimating normals \
                 tile by tile is not done yet); run without --max-memory to estimate them"
            .into(),
    };
    let format = format.or_else(|| extension_format(path));
    // A PLY point cloud streams; a PLY mesh (its faces need every vertex) is read whole.
    let streams = match format {
        Some(Format::Ply) => {
            let file = fs::File::open(path).map_err(|e| open_error(path, e))?;
            PointStream::open(BufReader::new(file), Format::Ply).is_ok()
        }
        Some(f) => f.is_streamed() || f == Format::Xyz,
        None => false,
    };
    match format {
        Some(format) if streams => {
            let file = fs::File::open(path).map_err(|e| open_error(path, e))?;
            let stream =
                PointStream::open(BufReader::new(file), format).map_err(read_error(path))?;
            let (mut first, mut dropped) = (0u64, 0u64);
            let mut failure = None;
            stream
                .for_each_chunk(CHUNK, |chunk| {
                    let result = match chunk_oriented_points(&chunk, first) {
                        None => Err(no_normals()),
                        Some(Err(e)) => Err(read_error(path)(e)),
                        Some(Ok((points, d))) => {
                            dropped += d as u64;
                            visit(&points)
                        }
                    };
                    first += chunk.len() as u64;
                    match result {
                        Ok(()) => ControlFlow::Continue(()),
                        Err(e) => {
                            failure = Some(e);
                            ControlFlow::Break(())
                        }
                    }
                })
                .map_err(read_error(path))?;
            failure.map_or(Ok(dropped), Err)
        }
        _ => {
            let file = crate::load_points_as(path, format, &ReadOptions::paper())?;
            if file.normals == psi_io::NormalSource::Missing {
                return Err(no_normals());
            }
            for chunk in file.points.chunks(CHUNK) {
                visit(chunk)?;
            }
            Ok(file.dropped_points as u64)
        }
    }
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

/// The store directory of `options`.
fn store_dir(options: &OutOfCore) -> PathBuf {
    options.scratch.join("tiles")
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
    monitor: &Monitor<'_>,
) -> Result<PartitionStart, PsiError> {
    let fail = failure_of(paths)?;
    let source = sources_of(paths)?;
    let dir = store_dir(options);
    // An earlier run's store is used when it holds the same files, tiled as this budget
    // tiles them (the particles depend on the tiling).
    if let Ok(store) = TileStore::open(&dir)
        && store.manifest().source == source
        && options.tile_depth_for(store.manifest().population) == Ok(store.manifest().depth)
    {
        let points = store.manifest().population;
        return Ok(PartitionStart::Found(Box::new(Partition {
            store,
            points,
            dropped: 0,
            resumed: true,
        })));
    }
    let mut bounds: Option<Aabb> = None;
    let mut count = 0u64;
    monitor.report("read", 0, 2);
    for_each_input(paths, format, |chunk| {
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
    let bounds = bounds.ok_or_else(|| fail("holds no points".into()))?;
    let frame = MpuFrame::for_bounds(&bounds, count as usize, mpu_params)
        .map_err(|e| fail(e.to_string()))?;
    let depth = options.tile_depth_for(count).map_err(&fail)?;
    let plan = StorePlan::new(&source, &frame, depth);
    plan.start(&dir).map_err(|e| fail(e.to_string()))?;
    Ok(PartitionStart::Planned { points: count })
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
    monitor: &Monitor<'_>,
) -> Result<u64, PsiError> {
    let fail = failure_of(paths)?;
    let dir = store_dir(options);
    let plan = StorePlan::read(&dir).map_err(|e| fail(e.to_string()))?;
    let changed = || fail(CHANGED.into());
    if sources_of(paths)? != plan.source {
        return Err(changed());
    }
    monitor.report("read", 1, 2);
    let buffer = (options.max_memory / 4 / 56).max(1 << 16) as usize;
    let mut writer =
        TileWriter::create_part(&dir, &plan, part, buffer).map_err(|e| fail(e.to_string()))?;
    // Decoding the input (on a thread of its own when the pool has two and the budget has
    // room for the chunks ahead) overlaps with writing the tiles.
    let dropped = read_ahead(
        options.max_memory >= READ_AHEAD_BUDGET,
        |visit| for_each_input(paths, format, visit),
        |chunk| {
            writer.push(chunk).map_err(|e| fail(e.to_string()))?;
            monitor.check().map_err(|_| fail("interrupted".into()))
        },
        || fail("stopped".into()),
    )?;
    writer.finish_part().map_err(|e| fail(e.to_string()))?;
    // The files must not have changed between the two passes.
    if sources_of(paths)? != plan.source {
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
) -> Result<Partition, PsiError> {
    let fail = failure_of(paths)?;
    let store = TileStore::assemble(&store_dir(options), parts).map_err(|e| fail(e.to_string()))?;
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
    let points = match partition_start(paths, format, mpu_params, options, monitor)? {
        PartitionStart::Found(found) => return Ok(*found),
        PartitionStart::Planned { points } => points,
    };
    let dropped = partition_part(paths, format, StorePart::WHOLE, options, monitor)?;
    let partition = partition_assemble(paths, 1, Some(points), options)?;
    monitor.report("read", 2, 2);
    Ok(Partition {
        dropped,
        ..partition
    })
}

/// [`for_each_points`] of every file in `paths`, in order; returns the points dropped.
fn for_each_input(
    paths: &[PathBuf],
    format: Option<Format>,
    mut visit: impl FnMut(&[OrientedPoint]) -> Result<(), PsiError>,
) -> Result<u64, PsiError> {
    let mut dropped = 0;
    for path in paths {
        dropped += for_each_points(path, format, &mut visit)?;
    }
    Ok(dropped)
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
