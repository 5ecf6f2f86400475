//! Tasks of `psi.distributed.sample_files` for the outlier step out of core (not API): its two
//! passes over batches of the tiles of the store of all points, the statistics between them
//! and the join of the verdicts ([`psi::stray_standings`], [`psi::stray_stats`],
//! [`psi::stray_verdicts_of_batch`], [`psi::stray_join`]).

use std::path::PathBuf;

use pyo3::prelude::*;

use crate::errors::value_error;
use crate::out_of_core::{on_threads, threads_arg};

/// Runs an outlier-step task on the store of all points in `scratch` on a pool of `threads`;
/// its error as a `ValueError`.
fn strays_task<T: Send>(
    py: Python<'_>,
    scratch: &std::path::Path,
    threads: Option<i128>,
    work: impl FnOnce(&psi::tiles::TileStore) -> Result<T, String> + Send,
) -> PyResult<T> {
    let threads = threads_arg(threads)?;
    let store = psi::tiles::TileStore::open(&scratch.join("all"))
        .map_err(|e| value_error(e.to_string()))?;
    crate::errors::detached(py, move || on_threads(threads, || work(&store)))?
        .map_err(value_error)?
        .map_err(value_error)
}

/// Task of `psi.distributed.sample_files` (not API): the outlier step's first pass over batch
/// `batch` of `batches` of the tiles of the store of all points (with normals); returns how
/// many points it searched.
#[pyfunction]
#[pyo3(signature = (scratch, batch, batches, threads=None))]
pub(crate) fn _ooc_stray_standings(
    py: Python<'_>,
    scratch: PathBuf,
    batch: u32,
    batches: u32,
    threads: Option<i128>,
) -> PyResult<u64> {
    let dir = scratch.clone();
    strays_task(py, &scratch, threads, move |store| {
        psi::stray_standings(
            store,
            &dir,
            (batch, batches),
            true,
            &psi::octree::Monitor::silent(),
        )
    })
}

/// Task of `psi.distributed.sample_files` (not API): the outlier search's statistics from the
/// first pass's `batches` files: (the median 16th-neighbour distance, the points searched).
#[pyfunction]
pub(crate) fn _ooc_stray_stats(scratch: PathBuf, batches: u32) -> PyResult<(f64, u64)> {
    let stats = psi::stray_stats(&scratch, batches).map_err(value_error)?;
    Ok((stats.typical, stats.points))
}

/// Task of `psi.distributed.sample_files` (not API): the outlier step's verdicts on batch
/// `batch` of `batches` of the tiles, with the statistics of [`_ooc_stray_stats`].
#[pyfunction]
#[pyo3(signature = (scratch, batch, batches, stats, threads=None))]
pub(crate) fn _ooc_stray_verdicts(
    py: Python<'_>,
    scratch: PathBuf,
    batch: u32,
    batches: u32,
    stats: (f64, u64),
    threads: Option<i128>,
) -> PyResult<()> {
    let dir = scratch.clone();
    let stats = psi::preprocess::OutlierStats {
        typical: stats.0,
        points: stats.1,
    };
    strays_task(py, &scratch, threads, move |store| {
        let silent = psi::octree::Monitor::silent();
        psi::stray_verdicts_of_batch(store, &dir, (batch, batches), (true, stats), &silent)
    })
}

/// Task of `psi.distributed.sample_files` (not API): `strays.bin` from the `batches` verdict
/// files; returns the points left out.
#[pyfunction]
pub(crate) fn _ooc_stray_join(py: Python<'_>, scratch: PathBuf, batches: u32) -> PyResult<u64> {
    let dir = scratch.clone();
    strays_task(py, &scratch, None, move |store| {
        psi::stray_join(store, &dir, batches, &psi::octree::Monitor::silent()).map(|t| t.removed())
    })
}
