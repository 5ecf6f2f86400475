//! The points a partition stores, read from the input's files: streamed chunk by chunk (the
//! scanner formats, XYZ, PLY point clouds) or read whole (PLY meshes, OBJ), with the normals
//! the store takes (the input's own, none, estimated by index, or by position) and the outlier
//! step's keep test, and the kind of store that makes (recorded in its source, so a run finds
//! its own store again).

use std::fs;
use std::io::BufReader;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

use glam::DVec3;
use psi_io::{Format, PointStream, ReadOptions, chunk_oriented_points};
use psi_octree::OrientedPoint;
use psi_tiles::TileStore;

use crate::PsiError;
use crate::files::{check_not_dir, extension_format, open_error, read_error};

/// Points streamed per chunk.
pub(crate) const CHUNK: usize = 1 << 18;

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

/// The store of all points whose indices a keep test reads, and the indices it leaves out:
/// the kept points' bounds are read from the store's sub-cells ([`TileStore::bounds_where`])
/// instead of from the input (valid where every point the test keeps is stored: given
/// normals, or none).
#[derive(Clone, Copy)]
pub(crate) struct KeptFrom<'a> {
    /// The store of all points.
    pub(crate) store: &'a TileStore,
    /// The indices of the points left out, ascending ([`crate::given_stages::stray_indices`]).
    pub(crate) strays: &'a [u64],
}

/// What a partition stores: the points' normals, and which points it keeps (all, without a
/// test).
#[derive(Clone, Copy)]
pub(crate) struct Points<'a> {
    /// Where the normals come from.
    pub(crate) normals: Normals<'a>,
    /// Which points are kept (the outlier step's verdicts).
    pub(crate) keep: Option<Keep<'a>>,
    /// Where the kept points' bounds can be read without a pass over the input.
    pub(crate) kept_from: Option<KeptFrom<'a>>,
}

impl<'a> Points<'a> {
    /// All points, with the normals `normals` gives.
    pub(crate) fn all(normals: Normals<'a>) -> Self {
        Self {
            normals,
            keep: None,
            kept_from: None,
        }
    }

    /// The kind of store these points make.
    pub(crate) fn kind(&self) -> StoreKind {
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

/// The file at `path` (read as `format`, or as its extension says) as a stream of points when
/// it streams (the scanner formats, XYZ, a PLY point cloud); `None` for a file read whole (a
/// PLY mesh, whose faces need every vertex; OBJ; an unknown format).
pub(crate) fn stream_of(
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
    Ok(file_facts(path, format)?.0)
}

/// Whether the file at `path` (read as `format`, or as its extension says) has normals (its
/// first chunk's, for a streamed file), and whether it is a triangle mesh (a file read whole
/// that has faces: its points are the triangles', which the in-core preprocessing does not
/// search for outliers); a file read whole is read once for both.
///
/// # Errors
///
/// [`PsiError::Open`] / [`PsiError::Read`] for the file.
pub(crate) fn file_facts(path: &Path, format: Option<Format>) -> Result<(bool, bool), PsiError> {
    if let Some(stream) = stream_of(path, format)? {
        let mut normals = None;
        stream
            .for_each_chunk(1024, |chunk| {
                normals = Some(chunk.normals.is_some());
                ControlFlow::Break(())
            })
            .map_err(read_error(path))?;
        return Ok((normals.unwrap_or(true), false));
    }
    let file = crate::load_points_as(path, format, &ReadOptions::paper())?;
    Ok((
        file.normals != psi_io::NormalSource::Missing,
        file.mesh.is_some(),
    ))
}

/// [`for_each_points`] of every file in `paths`, in order; returns the points dropped.
pub(crate) fn for_each_input(
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
