//! `psi.sample_files`: files larger than memory sampled out of core, as `psi sample
//! --max-memory` does ([`psi::sample_files_out_of_core`]).

use std::path::PathBuf;

use pyo3::prelude::*;

use crate::errors::{bounded, psi_error, value_error};
use crate::monitor::{Progress, monitored};

/// `max_memory` as bytes: a whole number, or a string such as "4GiB" (the CLI's parser).
pub(crate) fn memory_arg(value: &Bound<'_, PyAny>) -> PyResult<u64> {
    if let Ok(text) = value.extract::<String>() {
        return psi::parse_memory_size(&text).map_err(value_error);
    }
    let n: i128 = value
        .extract()
        .map_err(|_| value_error("max_memory: give bytes (an int) or a size such as \"4GiB\""))?;
    psi::parse_memory_size(&bounded::<u64>("max_memory", n, 0, u64::MAX)?.to_string())
        .map_err(value_error)
}

/// The input files: one path, or a sequence of them (a survey's tiles, in order).
fn inputs_arg(value: &Bound<'_, PyAny>) -> PyResult<Vec<PathBuf>> {
    if let Ok(one) = value.extract::<PathBuf>() {
        return Ok(vec![one]);
    }
    let many: Vec<PathBuf> = value
        .extract()
        .map_err(|_| value_error("inputs: give a path or a list of paths"))?;
    if many.is_empty() {
        return Err(value_error("inputs: the list of files is empty"));
    }
    Ok(many)
}

/// Runs `work` on a rayon pool of `threads` threads of its own, or on the global pool
/// (`None`); `Err` tells why the pool could not start. A Dask worker runs one task per
/// thread, so its tasks ask for one each.
pub(crate) fn on_threads<T: Send>(
    threads: Option<usize>,
    work: impl FnOnce() -> T + Send,
) -> Result<T, String> {
    match threads {
        None => Ok(work()),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .thread_name(|i| format!("psi-task-{i}"))
            .build()
            .map(|pool| pool.install(work))
            .map_err(|e| format!("psi: could not start {n} threads: {e}")),
    }
}

/// `threads` as a pool size: `None`, or a whole number from 1 on.
pub(crate) fn threads_arg(threads: Option<i128>) -> PyResult<Option<usize>> {
    threads
        .map(|n| bounded::<u32>("threads", n, 1, 4096).map(|n| n as usize))
        .transpose()
}

/// Samples `inputs` (a path, or a list of paths read as one input in that order) out of core
/// within `max_memory` (bytes, or a size such as "4GiB"), writing the particles to `output`
/// and the tile files to `scratch` (default: beside `output`). The same run as `psi sample
/// INPUT --max-memory SIZE`: bitwise its particles. Preprocessing tile by tile: repeated
/// points, outliers and stray clumps left out (unless `keep_outliers`), normals estimated and
/// oriented where there are none, given normals that point inward flipped, the error threshold
/// set from the noise (unless `mpu_error` is given), the points denoised where the noise calls
/// for it. The ceiling on spacing `max_spacing` (world units; default 2.5 % of the diagonal,
/// `inf` for none) as in core. Returns the run's report (the CLI's `--json`). A rerun with the same scratch
/// resumes from its tile files.
#[pyfunction]
#[pyo3(signature = (inputs, output, *, max_memory, scratch=None, k=1, iterations=20,
    seed=2007, mpu_error=None, keep_outliers=false, max_spacing=None, progress=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn sample_files<'py>(
    py: Python<'py>,
    inputs: &Bound<'py, PyAny>,
    output: PathBuf,
    max_memory: &Bound<'py, PyAny>,
    scratch: Option<PathBuf>,
    k: i128,
    iterations: i128,
    seed: i128,
    mpu_error: Option<f64>,
    keep_outliers: bool,
    max_spacing: Option<f64>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let particle_params = ooc_particle_params(k, iterations, seed, max_spacing)?;
    let run = (preprocess_params(keep_outliers), progress, None);
    run_sample_files(
        py,
        inputs,
        output,
        max_memory,
        scratch,
        particle_params,
        mpu_error,
        run,
    )
}

/// The particle parameters of a run out of core: k per leaf, the ceiling on spacing.
pub(crate) fn ooc_particle_params(
    k: i128,
    iterations: i128,
    seed: i128,
    max_spacing: Option<f64>,
) -> PyResult<psi::ParticleParams> {
    crate::sample::particle_params(iterations, Some(k), None, false, max_spacing, seed)
}

/// The preprocessing of a run out of core: the in-core defaults, outliers kept when asked.
fn preprocess_params(keep_outliers: bool) -> psi::preprocess::PreprocessParams {
    psi::preprocess::PreprocessParams {
        remove_outliers: !keep_outliers,
        ..psi::preprocess::PreprocessParams::scan()
    }
}

/// Task of `psi.distributed.sample_files` (not API): [`sample_files`] on a pool of `threads`.
#[pyfunction]
#[pyo3(signature = (inputs, output, *, max_memory, scratch=None, k=1, iterations=20,
    seed=2007, mpu_error=None, keep_outliers=false, max_spacing=None, threads=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn _ooc_sample<'py>(
    py: Python<'py>,
    inputs: &Bound<'py, PyAny>,
    output: PathBuf,
    max_memory: &Bound<'py, PyAny>,
    scratch: Option<PathBuf>,
    k: i128,
    iterations: i128,
    seed: i128,
    mpu_error: Option<f64>,
    keep_outliers: bool,
    max_spacing: Option<f64>,
    threads: Option<i128>,
) -> PyResult<Bound<'py, PyAny>> {
    let particle_params = ooc_particle_params(k, iterations, seed, max_spacing)?;
    let run = (
        preprocess_params(keep_outliers),
        None,
        threads_arg(threads)?,
    );
    run_sample_files(
        py,
        inputs,
        output,
        max_memory,
        scratch,
        particle_params,
        mpu_error,
        run,
    )
}

/// [`sample_files`] with `preprocess`, reporting to `progress`, on a pool of `threads`
/// ([`on_threads`]).
#[allow(clippy::too_many_arguments)]
fn run_sample_files<'py>(
    py: Python<'py>,
    inputs: &Bound<'py, PyAny>,
    output: PathBuf,
    max_memory: &Bound<'py, PyAny>,
    scratch: Option<PathBuf>,
    particle_params: psi::ParticleParams,
    mpu_error: Option<f64>,
    (preprocess, progress, threads): (
        psi::preprocess::PreprocessParams,
        Option<&Bound<'py, PyAny>>,
        Option<usize>,
    ),
) -> PyResult<Bound<'py, PyAny>> {
    let inputs = inputs_arg(inputs)?;
    let max_memory = memory_arg(max_memory)?;
    let mpu = psi::OutOfCoreMpu::given(mpu_params(mpu_error)?, mpu_error);
    let scratch = scratch.unwrap_or_else(|| default_scratch(&output));
    let options = psi::OutOfCore {
        max_memory,
        scratch,
        tile_depth: None,
    };
    let progress = Progress::from_arg(py, progress)?;
    let (work_inputs, work_options) = (inputs.clone(), options.clone());
    let run = monitored(py, &progress, move |monitor| {
        on_threads(threads, || {
            psi::sample_files_out_of_core(
                &work_inputs,
                None,
                &preprocess,
                &mpu,
                &particle_params,
                &work_options,
                monitor,
            )
            .and_then(|run| {
                psi::save_particles(
                    &output,
                    &run.particles,
                    &psi::io::PointAttributes::default(),
                )?;
                Ok(run)
            })
        })
    })?
    .map_err(value_error)?
    .map_err(|e| psi_error(py, e, Some("sampling out of core")))?;
    warn_of_checks(py, &inputs[0].display().to_string(), &run.checks)?;
    let report = psi::out_of_core_json(&inputs, &particle_params, &options, &run);
    crate::json::to_python(py, &report)
}

/// Warns, as the in-core run does, when the checks of input `what` flipped its normals outward
/// or found them pointing every way (then not denoised).
fn warn_of_checks(py: Python<'_>, what: &str, checks: &psi::StoreChecks) -> PyResult<()> {
    let mut messages = Vec::new();
    if checks.inward_normals_flipped {
        messages.push(format!(
            "psi: {}",
            psi::preprocess::inward_flip_notice(what)
        ));
    }
    if let Some(opposed) = checks.inconsistent_normals() {
        messages.push(format!(
            "psi: {what}: {:.1} % of neighbouring normals point to opposite sides, so the points were not denoised; orient_normals=True (in core) repairs them",
            100.0 * opposed
        ));
    }
    for message in messages {
        let message = std::ffi::CString::new(message).unwrap_or_default();
        PyErr::warn(
            py,
            &py.get_type::<pyo3::exceptions::PyUserWarning>(),
            &message,
            1,
        )?;
    }
    Ok(())
}

/// The MPU parameters of a run out of core: the paper's, with `mpu_error` as ε when given.
pub(crate) fn mpu_params(mpu_error: Option<f64>) -> PyResult<psi::MpuParams> {
    let error_rel = match mpu_error {
        Some(e) if e > 0.0 && e < 1.0 => e,
        Some(e) => return Err(value_error(format!("mpu_error: {e} is not in (0, 1)"))),
        None => psi::MpuParams::paper().error_rel,
    };
    Ok(psi::MpuParams {
        error_rel,
        ..psi::MpuParams::paper()
    })
}

/// `<output>.psi-scratch` beside `output` (the CLI's default).
fn default_scratch(output: &std::path::Path) -> PathBuf {
    let name = output
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "particles".into());
    output.with_file_name(format!("{name}.psi-scratch"))
}

/// A partition task's store: `"tiles"` (the points as given), `"all"` (every point, for the
/// outlier step) or `"kept"` (the points it keeps).
fn stage_arg(stage: &str) -> PyResult<psi::GivenStage> {
    match stage {
        "tiles" => Ok(psi::GivenStage::Plain),
        "all" => Ok(psi::GivenStage::All),
        "kept" => Ok(psi::GivenStage::Kept),
        other => Err(value_error(format!(
            "stage: {other:?} is not \"tiles\", \"all\" or \"kept\""
        ))),
    }
}

/// The options of a partition task: the budget and the scratch directory.
fn partition_options(max_memory: &Bound<'_, PyAny>, scratch: PathBuf) -> PyResult<psi::OutOfCore> {
    Ok(psi::OutOfCore {
        max_memory: memory_arg(max_memory)?,
        scratch,
        tile_depth: None,
    })
}

/// Runs a partition task: `work` on a pool of `threads` with the interpreter released; its
/// error as psi's Python exception.
fn partition_task<T: Send>(
    py: Python<'_>,
    threads: Option<i128>,
    work: impl FnOnce() -> Result<T, psi::PsiError> + Send,
) -> PyResult<T> {
    let threads = threads_arg(threads)?;
    crate::errors::detached(py, move || on_threads(threads, work))?
        .map_err(value_error)?
        .map_err(|e| psi_error(py, e, Some("sampling out of core")))
}

/// Task of `psi.distributed.sample_files` (not API) for inputs without normals: the store of
/// the preprocessed points (the outlier step unless `keep_outliers`, then the normals), written
/// in `scratch` as `psi sample --max-memory` writes it (the whole stage in this task, on its
/// threads), or found there.
#[pyfunction]
#[pyo3(signature = (inputs, max_memory, scratch, mpu_error=None, keep_outliers=false,
    threads=None))]
pub(crate) fn _ooc_preprocess(
    py: Python<'_>,
    inputs: &Bound<'_, PyAny>,
    max_memory: &Bound<'_, PyAny>,
    scratch: PathBuf,
    mpu_error: Option<f64>,
    keep_outliers: bool,
    threads: Option<i128>,
) -> PyResult<()> {
    let inputs = inputs_arg(inputs)?;
    let options = partition_options(max_memory, scratch)?;
    let params = mpu_params(mpu_error)?;
    partition_task(py, threads, move || {
        let preprocess = preprocess_params(keep_outliers);
        let silent = psi::octree::Monitor::silent();
        psi::partition_preprocessed(&inputs, None, &preprocess, &params, &options, &silent)?;
        Ok(())
    })
}

/// Task of `psi.distributed.sample_files` (not API): the first pass over the inputs, the
/// store's plan written in `scratch`; returns the point count, or `None` when the store of an
/// earlier run on the same inputs was found there (nothing to write).
#[pyfunction]
#[pyo3(signature = (inputs, max_memory, scratch, mpu_error=None, threads=None, stage="tiles"))]
pub(crate) fn _ooc_partition_start(
    py: Python<'_>,
    inputs: &Bound<'_, PyAny>,
    max_memory: &Bound<'_, PyAny>,
    scratch: PathBuf,
    mpu_error: Option<f64>,
    threads: Option<i128>,
    stage: &str,
) -> PyResult<Option<u64>> {
    let inputs = inputs_arg(inputs)?;
    let options = partition_options(max_memory, scratch)?;
    let params = mpu_params(mpu_error)?;
    let stage = stage_arg(stage)?;
    let start = partition_task(py, threads, move || {
        let silent = psi::octree::Monitor::silent();
        psi::partition_start(&inputs, None, &params, &options, stage, &silent)
    })?;
    Ok(match start {
        psi::PartitionStart::Found(_) => None,
        psi::PartitionStart::Planned { points } => Some(points),
    })
}

/// Task of `psi.distributed.sample_files` (not API): part `index` of `count` of the tile files
/// written (the whole input streamed, this part's tiles kept); returns the points dropped.
#[pyfunction]
#[pyo3(signature = (inputs, max_memory, scratch, index, count, threads=None, stage="tiles"))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn _ooc_partition_part(
    py: Python<'_>,
    inputs: &Bound<'_, PyAny>,
    max_memory: &Bound<'_, PyAny>,
    scratch: PathBuf,
    index: u32,
    count: u32,
    threads: Option<i128>,
    stage: &str,
) -> PyResult<u64> {
    let inputs = inputs_arg(inputs)?;
    let options = partition_options(max_memory, scratch)?;
    let part = psi::tiles::StorePart::new(index, count).map_err(|e| value_error(e.to_string()))?;
    let stage = stage_arg(stage)?;
    partition_task(py, threads, move || {
        let silent = psi::octree::Monitor::silent();
        psi::partition_part(&inputs, None, part, &options, stage, &silent)
    })
}

/// Task of `psi.distributed.sample_files` (not API): the store's manifest from its `count`
/// parts; `points` (the first pass's count) must be what they counted. Returns the count.
#[pyfunction]
#[pyo3(signature = (inputs, max_memory, scratch, count, points, stage="tiles"))]
pub(crate) fn _ooc_partition_assemble(
    py: Python<'_>,
    inputs: &Bound<'_, PyAny>,
    max_memory: &Bound<'_, PyAny>,
    scratch: PathBuf,
    count: u32,
    points: u64,
    stage: &str,
) -> PyResult<u64> {
    let inputs = inputs_arg(inputs)?;
    let options = partition_options(max_memory, scratch)?;
    let stage = stage_arg(stage)?;
    let part = partition_task(py, None, move || {
        psi::partition_assemble(&inputs, count, Some(points), &options, stage)
    })?;
    Ok(part.points)
}

/// Task of `psi.distributed.sample_files` (not API): which preprocessing a run out of core on
/// `inputs` does ([`psi::out_of_core_preprocessing`]): `"found"` (an earlier run's finished
/// store is in `scratch`: nothing to partition), `"normals"` (points without normals: one task,
/// [`_ooc_preprocess`]), `"outliers"` (the outlier step's tasks) or `"none"`.
#[pyfunction]
#[pyo3(signature = (inputs, max_memory, scratch, keep_outliers=false))]
pub(crate) fn _ooc_preprocessing(
    py: Python<'_>,
    inputs: &Bound<'_, PyAny>,
    max_memory: &Bound<'_, PyAny>,
    scratch: PathBuf,
    keep_outliers: bool,
) -> PyResult<&'static str> {
    let inputs = inputs_arg(inputs)?;
    let options = partition_options(max_memory, scratch)?;
    partition_task(py, None, move || {
        let preprocess = preprocess_params(keep_outliers);
        use psi::OutOfCorePreprocessing as P;
        Ok(
            match psi::out_of_core_preprocessing(&inputs, None, &preprocess, &options)? {
                P::Found => "found",
                P::Normals => "normals",
                P::Outliers => "outliers",
                P::Plain => "none",
            },
        )
    })
}

/// Task of `psi.distributed.sample_files` (not API), after the partition's: the checks of the
/// final store in `scratch` before the MPU (inward normals flipped, the noise's error
/// threshold, denoising where it calls for it; [`psi::check_out_of_core_store`]), kept there
/// for the later tasks.
#[pyfunction]
#[pyo3(signature = (inputs, max_memory, scratch, keep_outliers=false, threads=None))]
pub(crate) fn _ooc_checks(
    py: Python<'_>,
    inputs: &Bound<'_, PyAny>,
    max_memory: &Bound<'_, PyAny>,
    scratch: PathBuf,
    keep_outliers: bool,
    threads: Option<i128>,
) -> PyResult<()> {
    let inputs = inputs_arg(inputs)?;
    let options = partition_options(max_memory, scratch)?;
    let mpu = mpu_params(None)?;
    partition_task(py, threads, move || {
        let preprocess = preprocess_params(keep_outliers);
        let silent = psi::octree::Monitor::silent();
        psi::check_out_of_core_store(&inputs, None, &preprocess, &mpu, &options, &silent)?;
        Ok(())
    })
}
