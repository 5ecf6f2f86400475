//! The partition of a run out of core with the preprocessing that runs tile by tile: the
//! outlier step (`tile_outliers.rs`; not for a mesh's points, which the in-core preprocessing
//! does not search either) and normals for points without them (`tile_normals.rs`), else the
//! plain partition (`partition.rs`). The CLI's `--max-memory` and Python's `sample_files` run it
//! within [`crate::sample_files_out_of_core`]; `psi.distributed.sample_files` as its tasks,
//! the ones [`out_of_core_preprocessing`] names.

use std::path::{Path, PathBuf};

use psi_io::Format;
use psi_mpu::MpuParams;
use psi_octree::Monitor;
use psi_preprocess::PreprocessParams;
use psi_tiles::TileStore;

use crate::PsiError;
use crate::budget::OutOfCore;
use crate::partition::{
    Input, NormalsKind, Partition, StoreKind, file_facts, has_normals, partition_files,
};
use crate::store_checks::{ChecksWanted, StoreChecks, check_store};
use crate::tile_normals::partition_estimating_normals;
use crate::tile_outliers::{StrayTally, found_with_strays, partition_removing_outliers};

/// The store of the preprocessed points and what the preprocessing did.
#[derive(Clone, Debug)]
pub struct PreprocessedPartition {
    /// The store (in `<scratch>/tiles`).
    pub partition: Partition,
    /// What the outlier step left out (`None` when it did not run).
    pub strays: Option<StrayTally>,
    /// Whether the input had no normals and they were estimated and oriented tile by tile.
    pub normals_estimated: bool,
    /// The level their planes were fitted at (one point in 4^level; `None` when the store
    /// of an earlier run was found, or the normals were given).
    pub normals_level: Option<u32>,
    /// The checks the store gets before the MPU (`store_checks.rs`).
    pub checks: ChecksWanted,
}

/// What the preprocessing of `paths` (read as `format`) does out of core: whether the points
/// get normals, whether the outlier step runs, and whether they are a mesh's. Checks that the
/// files have normals or none, and refuses the steps not done out of core.
fn steps(
    paths: &[PathBuf],
    format: Option<Format>,
    preprocess: &PreprocessParams,
) -> Result<(bool, bool, bool), PsiError> {
    let first = paths.first().ok_or_else(|| PsiError::OutOfCore {
        path: PathBuf::new(),
        reason: "no input files given".into(),
    })?;
    let (normals, mesh) = file_facts(first, format)?;
    let estimate = !normals;
    for path in &paths[1..] {
        if has_normals(path, format)? == estimate {
            return Err(mixed(path, estimate));
        }
    }
    if estimate && !preprocess.estimate_normals {
        return Err(PsiError::OutOfCore {
            path: first.clone(),
            reason: "has no normals, and normal estimation is off".into(),
        });
    }
    // What a run out of core would otherwise leave undone without a word.
    let not_done = if estimate && preprocess.viewpoint.is_some() {
        Some("orienting estimated normals toward a viewpoint (--viewpoint)")
    } else if !estimate && preprocess.orient_given_normals {
        Some("reorienting given normals (--orient-normals)")
    } else {
        None
    };
    if let Some(step) = not_done {
        return Err(PsiError::OutOfCore {
            path: first.clone(),
            reason: format!(
                "{step} is not done out of core yet; run without --max-memory, or without it"
            ),
        });
    }
    // A mesh's triangles are the surface: in core its points are not searched for outliers.
    let remove = preprocess.remove_outliers && !mesh;
    Ok((estimate, remove, mesh))
}

/// The error for a file of an input whose first file has normals (`estimate` false) or none.
fn mixed(path: &Path, estimate: bool) -> PsiError {
    PsiError::OutOfCore {
        path: path.to_path_buf(),
        reason: format!(
            "has {}normals where the input's first file has {}: the files of one input have \
             normals or none",
            if estimate { "" } else { "no " },
            if estimate { "none" } else { "them" }
        ),
    }
}

/// What the partition of a run out of core does, as a cluster's tasks need to know.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutOfCorePreprocessing {
    /// An earlier run's finished store (and, with the outlier step, the verdicts it was made
    /// from) is in the scratch directory: [`partition_preprocessed`] finds it, nothing to do.
    Found,
    /// Normals estimated and oriented tile by tile (and the outlier step first, if on).
    Normals,
    /// The outlier step on points with normals.
    Outliers,
    /// The plain partition of the points as given.
    Plain,
}

/// What [`partition_preprocessed`] does for `paths` (read as `format`) with `preprocess` and
/// `options`.
///
/// # Errors
///
/// As [`partition_preprocessed`]'s checks: the files cannot be read, have normals in some and
/// none in others, or have none while normal estimation is off.
pub fn out_of_core_preprocessing(
    paths: &[PathBuf],
    format: Option<Format>,
    preprocess: &PreprocessParams,
    options: &OutOfCore,
) -> Result<OutOfCorePreprocessing, PsiError> {
    let (estimate, remove, _) = steps(paths, format, preprocess)?;
    let (normals, all_normals) = if estimate {
        (NormalsKind::Oriented, NormalsKind::Positions)
    } else {
        (NormalsKind::Given, NormalsKind::Given)
    };
    let kind = StoreKind {
        normals,
        strays_left_out: remove,
    };
    Ok(
        if found_with_strays(paths, options, kind, all_normals)?.is_some() {
            OutOfCorePreprocessing::Found
        } else if estimate {
            OutOfCorePreprocessing::Normals
        } else if remove {
            OutOfCorePreprocessing::Outliers
        } else {
            OutOfCorePreprocessing::Plain
        },
    )
}

/// The store of `paths`' points (one input, in this order; each read as `format` or as its
/// extension says) in `options.scratch/tiles`, preprocessed as `preprocess` asks of the steps
/// that run out of core, bitwise the in-core steps: repeated points and outliers left out
/// (`remove_outliers`, not for a mesh's points), normals estimated and oriented where there
/// are none (`estimate_normals`, else such an input is refused). Found there when an earlier
/// run wrote it for the same files and steps. Progress: the stages of the steps that run, then
/// the partition's.
///
/// # Errors
///
/// [`PsiError::Open`] / [`PsiError::Read`] for the input; [`PsiError::OutOfCore`] naming the
/// file when the files have normals in some and none in others, none while normal estimation
/// is off, a scratch file fails, or a step refuses (its reason).
pub fn partition_preprocessed(
    paths: &[PathBuf],
    format: Option<Format>,
    preprocess: &PreprocessParams,
    mpu_params: &MpuParams,
    options: &OutOfCore,
    monitor: &Monitor<'_>,
) -> Result<PreprocessedPartition, PsiError> {
    let (estimate, remove, mesh) = steps(paths, format, preprocess)?;
    let input = Input {
        paths,
        format,
        mpu_params,
        options,
    };
    let (partition, strays, normals_level) = match (estimate, remove) {
        (true, _) => partition_estimating_normals(input, remove, monitor)?,
        (false, true) => {
            let (partition, tally) = partition_removing_outliers(input, monitor)?;
            (partition, Some(tally), None)
        }
        (false, false) => (
            partition_files(paths, format, mpu_params, options, monitor)?,
            None,
            None,
        ),
    };
    Ok(PreprocessedPartition {
        partition,
        strays,
        normals_estimated: estimate,
        normals_level,
        checks: checks_wanted(preprocess, estimate, mesh),
    })
}

/// The checks the final store gets before the MPU (`store_checks.rs`), as the in-core
/// preprocessing makes them: the inward check for given normals (unless reoriented), the noise
/// estimate for a scan's points (with it, the consistency of given normals and denoising).
fn checks_wanted(preprocess: &PreprocessParams, estimate: bool, mesh: bool) -> ChecksWanted {
    ChecksWanted {
        inward: !estimate && preprocess.flip_inward_normals && !preprocess.orient_given_normals,
        // A mesh's triangles are the surface: in core their residuals set no threshold.
        noise: preprocess.estimate_noise && !mesh,
        denoise: preprocess.denoise,
        consistency: !estimate,
    }
}

/// The checks of the run out of core on `paths` (read as `format`) with `preprocess`, on the
/// final store its partition wrote in `options.scratch` (a cluster's task, after the
/// partition's): made, or found from an earlier run, and kept in the scratch directory where
/// the later tasks read the run's error threshold and the store to decide from
/// ([`crate::out_of_core_store`]; the denoised points', their frame as `mpu_params` makes it,
/// when the noise called for denoising).
///
/// # Errors
///
/// As [`partition_preprocessed`]'s checks of the files; [`PsiError::OutOfCore`] when the store
/// or the checks' file cannot be read or written.
pub fn check_out_of_core_store(
    paths: &[PathBuf],
    format: Option<Format>,
    preprocess: &PreprocessParams,
    mpu_params: &MpuParams,
    options: &OutOfCore,
    monitor: &Monitor<'_>,
) -> Result<StoreChecks, PsiError> {
    let (estimate, _, mesh) = steps(paths, format, preprocess)?;
    let dir = options.scratch.join("tiles");
    let store = TileStore::open(&dir).map_err(|e| PsiError::OutOfCore {
        path: dir.clone(),
        reason: e.to_string(),
    })?;
    let wanted = checks_wanted(preprocess, estimate, mesh);
    Ok(check_store(store, wanted, (options, mpu_params), monitor)?.1)
}
