//! Tasks of `psi.distributed.sample_files` for the MPU out of core (not API): the pass above
//! the tiles (the root's levels, a group per octant, their merge), the tiles in batches and the
//! seeds by octant, each on the store and ε0 the checks' task left
//! ([`psi::out_of_core_store`]; [`psi::tiles::decide_store`]'s tasks).

use std::path::PathBuf;

use pyo3::prelude::*;

use crate::errors::value_error;
use crate::out_of_core::{memory_arg, mpu_params, on_threads, ooc_particle_params, threads_arg};

/// Runs a task of `psi.distributed.sample_files` on the store in `scratch`: `work` with the
/// store, the MPU parameters (ε from `mpu_error`) and the run's tiling (its cells bounded by
/// `max_memory`: all of them in a task that holds them all, each tile's in a task of tiles),
/// on a pool of `threads`
/// ([`on_threads`]) with the interpreter released; its error as a `ValueError`.
fn store_task<T: Send>(
    py: Python<'_>,
    scratch: &std::path::Path,
    (mpu_error, max_memory): (Option<f64>, Option<u64>),
    threads: Option<i128>,
    work: impl FnOnce(
        &psi::tiles::TileStore,
        &psi::MpuParams,
        &psi::tiles::TileParams,
    ) -> Result<T, psi::tiles::TileError>
    + Send,
) -> PyResult<T> {
    let threads = threads_arg(threads)?;
    // The store and ε0 as the checks' task left them (the denoised points', the noise's
    // threshold when above the given or the paper's).
    let mpu = psi::OutOfCoreMpu::given(mpu_params(mpu_error)?, mpu_error);
    let (store, params) =
        psi::out_of_core_store(scratch, &mpu).map_err(|e| value_error(e.to_string()))?;
    let budget = max_memory.map(|max_memory| psi::OutOfCore {
        max_memory,
        scratch: scratch.to_path_buf(),
        tile_depth: None,
    });
    let tiles = psi::out_of_core_tiles(&store, budget.as_ref());
    let why = |e| psi::decisions_failure(e, max_memory.unwrap_or(u64::MAX), params.error_rel);
    crate::errors::detached(py, move || {
        on_threads(threads, || work(&store, &params, &tiles))
    })?
    .map_err(value_error)?
    .map_err(|e| value_error(why(e)))
}

/// Task of `psi.distributed.sample_files` (not API): the seeds of one octant of the root
/// (key at depth 1) written to their file (or found intact), after every tile is decided.
#[pyfunction]
#[pyo3(signature = (scratch, octant, *, max_memory, k=1, iterations=20, seed=2007,
    mpu_error=None, max_spacing=None, threads=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn _ooc_seed(
    py: Python<'_>,
    scratch: PathBuf,
    octant: (u32, u32, u32),
    max_memory: &Bound<'_, PyAny>,
    k: i128,
    iterations: i128,
    seed: i128,
    mpu_error: Option<f64>,
    max_spacing: Option<f64>,
    threads: Option<i128>,
) -> PyResult<()> {
    let particle_params = ooc_particle_params(k, iterations, seed, max_spacing)?;
    let budget = psi::OutOfCore {
        max_memory: memory_arg(max_memory)?,
        scratch: scratch.clone(),
        tile_depth: None,
    };
    let limits = (mpu_error, Some(budget.max_memory));
    store_task(py, &scratch, limits, threads, |store, params, tiles| {
        let silent = psi::octree::Monitor::silent();
        let decisions = psi::tiles::decide_store(store, params, tiles, &silent)?;
        let cells = decisions.cells.len() as u64;
        let relax_points = budget.relax_points_for(store.manifest().population, cells);
        let octant = [octant.0, octant.1, octant.2];
        if !psi::tiles::seed_octants(&decisions).contains(&octant) {
            return Ok(());
        }
        psi::tiles::seed_store_octant(
            store,
            tiles,
            &decisions,
            params,
            &particle_params,
            relax_points,
            octant,
            &silent,
        )
        .map(|_| ())
    })
}

/// Task of `psi.distributed.sample_files` (not API): the levels above the groups of the pass
/// above the tiles decided (or found); returns the groups' keys.
#[pyfunction]
#[pyo3(signature = (scratch, mpu_error=None, threads=None))]
pub(crate) fn _ooc_top_upper(
    py: Python<'_>,
    scratch: PathBuf,
    mpu_error: Option<f64>,
    threads: Option<i128>,
) -> PyResult<Vec<(u32, u32, u32)>> {
    let keys = store_task(
        py,
        &scratch,
        (mpu_error, None),
        threads,
        |store, params, tiles| {
            psi::tiles::decide_store_top_upper(
                store,
                params,
                tiles,
                &psi::octree::Monitor::silent(),
            )
        },
    )?;
    Ok(keys.into_iter().map(|k| (k[0], k[1], k[2])).collect())
}

/// Task of `psi.distributed.sample_files` (not API): one group of the pass above the tiles
/// decided and its decisions file written (or found intact).
#[pyfunction]
#[pyo3(signature = (scratch, key, mpu_error=None, threads=None))]
pub(crate) fn _ooc_top_group(
    py: Python<'_>,
    scratch: PathBuf,
    key: (u32, u32, u32),
    mpu_error: Option<f64>,
    threads: Option<i128>,
) -> PyResult<()> {
    store_task(
        py,
        &scratch,
        (mpu_error, None),
        threads,
        |store, params, tiles| {
            let key = [key.0, key.1, key.2];
            psi::tiles::decide_store_top_group(
                store,
                params,
                tiles,
                key,
                &psi::octree::Monitor::silent(),
            )
        },
    )
}

/// Task of `psi.distributed.sample_files` (not API): the cells above the tiles merged from
/// the groups' files (or found); returns the tiles' keys.
#[pyfunction]
#[pyo3(signature = (scratch, mpu_error=None, threads=None))]
pub(crate) fn _ooc_top(
    py: Python<'_>,
    scratch: PathBuf,
    mpu_error: Option<f64>,
    threads: Option<i128>,
) -> PyResult<Vec<(u32, u32, u32)>> {
    let keys = store_task(
        py,
        &scratch,
        (mpu_error, None),
        threads,
        |store, params, tiles| {
            psi::tiles::decide_store_top_keys(store, params, tiles, &psi::octree::Monitor::silent())
        },
    )?;
    Ok(keys.into_iter().map(|k| (k[0], k[1], k[2])).collect())
}

/// Task of `psi.distributed.sample_files` (not API): a batch of tiles decided, in order,
/// each with its decisions file written (or found intact); a tile with more cells than
/// `max_memory` holds stops, as the CLI's run does.
#[pyfunction]
#[pyo3(signature = (scratch, keys, mpu_error=None, threads=None, *, max_memory=None))]
pub(crate) fn _ooc_tiles(
    py: Python<'_>,
    scratch: PathBuf,
    keys: Vec<(u32, u32, u32)>,
    mpu_error: Option<f64>,
    threads: Option<i128>,
    max_memory: Option<&Bound<'_, PyAny>>,
) -> PyResult<()> {
    let keys: Vec<[u32; 3]> = keys.into_iter().map(|k| [k.0, k.1, k.2]).collect();
    let max_memory = max_memory.map(memory_arg).transpose()?;
    store_task(
        py,
        &scratch,
        (mpu_error, max_memory),
        threads,
        |store, params, tiles| {
            psi::tiles::decide_store_tiles(
                store,
                params,
                tiles,
                &keys,
                &psi::octree::Monitor::silent(),
            )
        },
    )
}
