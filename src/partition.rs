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

use glam::DVec3;
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

/// Where the normals of a partition's points come from.
#[derive(Clone, Copy)]
pub(crate) enum Normals<'a> {
    /// The input's own; an input without normals is refused.
    Given,
    /// None: every point with a zero normal (the store the normals are estimated from).
    Zero,
    /// Per point of the input, by its index among the points [`Points::keep`] keeps (without
    /// a test: its index in the whole input, all files, every point): `normals[i]`, turned
    /// over where `flips` (by index among the points stored) says; points with a zero normal
    /// are left out.
    Estimated {
        /// A point's normal by its index in the whole input (or why it cannot be read).
        normals: &'a (dyn Fn(u64) -> Result<DVec3, String> + Sync),
        /// Whether to turn the k-th kept point's normal over.
        flips: Option<&'a [bool]>,
    },
    /// Per point, from its position (world units): oriented normals; points with a zero
    /// normal are left out.
    Located(&'a (dyn Fn(DVec3) -> Result<DVec3, String> + Sync)),
}

/// Whether to keep a point, by its index among the points its store would hold without the
/// test (every point of the input; those with a normal, where the normals are given); or why
/// that cannot be read.
pub(crate) type Keep<'a> = &'a (dyn Fn(u64) -> Result<bool, String> + Sync);

/// What a partition stores: the points' normals, and which points it keeps (all, without a
/// test).
#[derive(Clone, Copy)]
pub(crate) struct Points<'a> {
    /// Where the normals come from.
    pub(crate) normals: Normals<'a>,
    /// Which points are kept (the outlier step's verdicts).
    pub(crate) keep: Option<Keep<'a>>,
}

impl<'a> Points<'a> {
    /// All points, with the normals `normals` gives.
    pub(crate) fn all(normals: Normals<'a>) -> Self {
        Self {
            normals,
            keep: None,
        }
    }

    /// The kind of store these points make.
    fn kind(&self) -> StoreKind {
        StoreKind {
            normals: self.normals.kind(),
            strays_left_out: self.keep.is_some(),
        }
    }
}

/// The normals of a kind of store, by where they come from.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum NormalsKind {
    /// The input's own normals.
    Given,
    /// Positions alone ([`Normals::Zero`]).
    Positions,
    /// Estimated normals, unoriented.
    Estimated,
    /// Estimated normals, oriented.
    Oriented,
}

/// The kind of store a partition writes, by where its normals come from and whether the
/// outlier step's strays were left out: a store's source records it beside the input's
/// files, so a run finds its own store.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) struct StoreKind {
    /// Where its normals come from.
    pub(crate) normals: NormalsKind,
    /// Whether the outlier step's strays were left out.
    pub(crate) strays_left_out: bool,
}

impl Normals<'_> {
    /// The kind of normals these make.
    fn kind(&self) -> NormalsKind {
        match self {
            Normals::Given => NormalsKind::Given,
            Normals::Zero => NormalsKind::Positions,
            Normals::Estimated { flips: None, .. } => NormalsKind::Estimated,
            Normals::Estimated { flips: Some(_), .. } | Normals::Located(_) => {
                NormalsKind::Oriented
            }
        }
    }
}

/// What a store of kind `kind` of the files at `paths` records as its source.
fn store_source(paths: &[PathBuf], kind: StoreKind) -> Result<String, PsiError> {
    let tag = match kind.normals {
        NormalsKind::Given => "",
        NormalsKind::Positions => "positions of ",
        NormalsKind::Estimated => "estimated normals of ",
        NormalsKind::Oriented => "oriented normals of ",
    };
    let strays = if kind.strays_left_out {
        "strays left out of "
    } else {
        ""
    };
    Ok(format!("{tag}{strays}{}", sources_of(paths)?))
}

/// The file at `path` (read as `format`, or as its extension says) as a stream of points when
/// it streams (the scanner formats, XYZ, a PLY point cloud); `None` for a file read whole (a
/// PLY mesh, whose faces need every vertex; OBJ; an unknown format).
fn stream_of(
    path: &Path,
    format: Option<Format>,
) -> Result<Option<PointStream<BufReader<fs::File>>>, PsiError> {
    check_not_dir(path)?;
    let Some(format) = format.or_else(|| extension_format(path)) else {
        return Ok(None);
    };
    if format != Format::Ply && !format.is_streamed() && format != Format::Xyz {
        return Ok(None);
    }
    let file = fs::File::open(path).map_err(|e| open_error(path, e))?;
    match PointStream::open(BufReader::new(file), format) {
        Ok(stream) => Ok(Some(stream)),
        Err(_) if format == Format::Ply => Ok(None),
        Err(e) => Err(read_error(path)(e)),
    }
}

/// Where a partition's pass has got to, over the files of one input: points read (the input
/// index of the next one), ranked (past the drop of zero given normals: the index
/// [`Points::keep`] takes), kept by that test (the index [`Normals::Estimated`] takes), and
/// stored (its flips' index).
#[derive(Clone, Copy, Debug, Default)]
struct Counts {
    read: u64,
    ranked: u64,
    kept: u64,
    stored: u64,
}

/// Calls `visit` with the oriented points of the file at `path`, chunk by chunk in file
/// order: the scanner formats, XYZ and PLY point clouds streamed, PLY meshes and OBJ read
/// whole first; their normals and which are kept as `points` says, `counts` where the pass
/// over the input's earlier files got to (advanced past this file). Returns the points
/// dropped for a zero normal.
fn for_each_points(
    path: &Path,
    format: Option<Format>,
    points: Points<'_>,
    counts: &mut Counts,
    mut visit: impl FnMut(&[OrientedPoint]) -> Result<(), PsiError>,
) -> Result<u64, PsiError> {
    let no_normals = || PsiError::OutOfCore {
        path: path.to_path_buf(),
        reason: "has no normals, where the input's first file has them: the files of one \
                 input have normals or none"
            .into(),
    };
    let fail = |reason| PsiError::OutOfCore {
        path: path.to_path_buf(),
        reason,
    };
    let keep = |rank: u64| points.keep.map_or(Ok(true), |k| k(rank)).map_err(fail);
    // The given points (their normals unit, the zero ones dropped) that the test keeps.
    let kept_given = |given: Vec<OrientedPoint>, counts: &mut Counts| {
        if points.keep.is_none() {
            counts.ranked += given.len() as u64;
            return Ok(given);
        }
        let mut out = Vec::with_capacity(given.len());
        for p in given {
            if keep(counts.ranked)? {
                out.push(p);
            }
            counts.ranked += 1;
        }
        Ok::<_, PsiError>(out)
    };
    // The points at `positions` (the next of the input) that the test keeps, with the normals
    // the mode gives (not `Given`), and how many were dropped for a zero normal.
    let with_normals = |positions: &[DVec3], counts: &mut Counts| -> Result<_, PsiError> {
        let mut out = Vec::with_capacity(positions.len());
        let mut dropped = 0;
        for &p in positions {
            let rank = counts.ranked;
            counts.ranked += 1;
            if !keep(rank)? {
                continue;
            }
            let at = counts.kept;
            counts.kept += 1;
            let n = match points.normals {
                Normals::Given => unreachable!("given normals are the input's"),
                Normals::Zero => DVec3::ZERO,
                Normals::Estimated { normals, flips } => {
                    let n = normals(at).map_err(fail)?;
                    if n == DVec3::ZERO {
                        dropped += 1;
                        continue;
                    }
                    let turn = flips.is_some_and(|f| f.get(counts.stored as usize) == Some(&true));
                    if turn { -n } else { n }
                }
                Normals::Located(normal_at) => {
                    let n = normal_at(p).map_err(fail)?;
                    if n == DVec3::ZERO {
                        dropped += 1;
                        continue;
                    }
                    n
                }
            };
            counts.stored += 1;
            out.push(OrientedPoint { p, n });
        }
        Ok((out, dropped))
    };
    let given = matches!(points.normals, Normals::Given);
    match stream_of(path, format)? {
        Some(stream) => {
            let (first, mut dropped) = (counts.read, 0u64);
            let mut failure = None;
            stream
                .for_each_chunk(CHUNK, |chunk| {
                    let read = counts.read - first;
                    let result = match (given, chunk_oriented_points(&chunk, read)) {
                        (true, None) => Err(no_normals()),
                        (true, Some(Err(e))) => Err(read_error(path)(e)),
                        (true, Some(Ok((found, d)))) => {
                            dropped += d as u64;
                            kept_given(found, counts).and_then(|p| visit(&p))
                        }
                        (false, _) => with_normals(&chunk.positions, counts).and_then(|(p, d)| {
                            dropped += d;
                            visit(&p)
                        }),
                    };
                    counts.read += chunk.len() as u64;
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
        None => {
            let file = crate::load_points_as(path, format, &ReadOptions::paper())?;
            if given {
                if file.normals == psi_io::NormalSource::Missing {
                    return Err(no_normals());
                }
                let dropped = file.dropped_points as u64;
                counts.read += file.points.len() as u64 + dropped;
                for chunk in file.points.chunks(CHUNK) {
                    visit(&kept_given(chunk.to_vec(), counts)?)?;
                }
                return Ok(dropped);
            }
            // (The points the reader kept: an input's files have normals or none, so a file
            // read here has none and dropped nothing.)
            counts.read += file.points.len() as u64;
            let positions: Vec<DVec3> = file.points.iter().map(|p| p.p).collect();
            let mut dropped = 0;
            for chunk in positions.chunks(CHUNK) {
                let (points, d) = with_normals(chunk, counts)?;
                dropped += d;
                visit(&points)?;
            }
            Ok(dropped)
        }
    }
}

/// Whether the file at `path` (read as `format`, or as its extension says) has normals: its
/// first chunk's, for a streamed file; a file read whole is read.
///
/// # Errors
///
/// [`PsiError::Open`] / [`PsiError::Read`] for the file.
pub fn has_normals(path: &Path, format: Option<Format>) -> Result<bool, PsiError> {
    if let Some(stream) = stream_of(path, format)? {
        let mut normals = None;
        stream
            .for_each_chunk(1024, |chunk| {
                normals = Some(chunk.normals.is_some());
                ControlFlow::Break(())
            })
            .map_err(read_error(path))?;
        return Ok(normals.unwrap_or(true));
    }
    let file = crate::load_points_as(path, format, &ReadOptions::paper())?;
    Ok(file.normals != psi_io::NormalSource::Missing)
}

/// Whether the file at `path` (read as `format`, or as its extension says) is a triangle mesh:
/// a file read whole that has faces (its points are the triangles', which the in-core
/// preprocessing does not search for outliers).
///
/// # Errors
///
/// [`PsiError::Open`] / [`PsiError::Read`] for the file.
pub(crate) fn is_mesh(path: &Path, format: Option<Format>) -> Result<bool, PsiError> {
    if stream_of(path, format)?.is_some() {
        return Ok(false);
    }
    let file = crate::load_points_as(path, format, &ReadOptions::paper())?;
    Ok(file.mesh.is_some())
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
    let dir = store_dir(options);
    start_in(
        paths,
        format,
        mpu_params,
        options,
        (&dir, Points::all(Normals::Given)),
        monitor,
    )
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
    let mut bounds: Option<Aabb> = None;
    let mut count = 0u64;
    monitor.report("read", 0, 2);
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
    let bounds = bounds.ok_or_else(|| fail("holds no points".into()))?;
    let frame = MpuFrame::for_bounds(&bounds, count as usize, mpu_params)
        .map_err(|e| fail(e.to_string()))?;
    let depth = options.tile_depth_for(count).map_err(&fail)?;
    let plan = StorePlan::new(&source, &frame, depth);
    plan.start(dir).map_err(|e| fail(e.to_string()))?;
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
    let dir = store_dir(options);
    part_in(
        paths,
        format,
        part,
        options,
        (&dir, Points::all(Normals::Given)),
        monitor,
    )
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
    let buffer = (options.max_memory / 4 / 56).max(1 << 16) as usize;
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
) -> Result<Partition, PsiError> {
    assemble_in(paths, parts, points, &store_dir(options))
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
    let dir = store_dir(options);
    partition_with(
        paths,
        format,
        mpu_params,
        options,
        (&dir, Points::all(Normals::Given)),
        monitor,
    )
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

/// [`for_each_points`] of every file in `paths`, in order; returns the points dropped.
fn for_each_input(
    paths: &[PathBuf],
    format: Option<Format>,
    points: Points<'_>,
    mut visit: impl FnMut(&[OrientedPoint]) -> Result<(), PsiError>,
) -> Result<u64, PsiError> {
    let mut counts = Counts::default();
    let mut dropped = 0;
    for path in paths {
        dropped += for_each_points(path, format, points, &mut counts, &mut visit)?;
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
