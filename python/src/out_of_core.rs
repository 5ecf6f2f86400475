//! `psi.sample_files`: files larger than memory sampled out of core, as `psi sample
//! --max-memory` does ([`psi::sample_files_out_of_core`]).

use std::path::PathBuf;

use pyo3::prelude::*;

use crate::errors::{bounded, psi_error, value_error};
use crate::monitor::{Progress, monitored};

/// `max_memory` as bytes: a whole number, or a string such as "4GiB" (the CLI's parser).
fn memory_arg(value: &Bound<'_, PyAny>) -> PyResult<u64> {
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

/// Samples `inputs` (a path, or a list of paths read as one input in that order) out of core
/// within `max_memory` (bytes, or a size such as "4GiB"), writing the particles to `output`
/// and the tile files to `scratch` (default: beside `output`). The same run as `psi sample
/// INPUT --max-memory SIZE`: bitwise its particles. The points are used as given (with their
/// normals; no outlier search or noise estimate out of core yet). Returns the run's report
/// (the CLI's `--json`). A rerun with the same scratch resumes from its tile files.
#[pyfunction]
#[pyo3(signature = (inputs, output, *, max_memory, scratch=None, k=1, iterations=20,
    seed=2007, mpu_error=None, progress=None))]
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
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let inputs = inputs_arg(inputs)?;
    let max_memory = memory_arg(max_memory)?;
    let particle_params = crate::sample::particle_params(iterations, Some(k), None, false, seed)?;
    let error_rel = match mpu_error {
        Some(e) if e > 0.0 && e < 1.0 => e,
        Some(e) => return Err(value_error(format!("mpu_error: {e} is not in (0, 1)"))),
        None => psi::MpuParams::paper().error_rel,
    };
    let mpu_params = psi::MpuParams {
        error_rel,
        ..psi::MpuParams::paper()
    };
    let scratch = scratch.unwrap_or_else(|| {
        let name = output
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "particles".into());
        output.with_file_name(format!("{name}.psi-scratch"))
    });
    let options = psi::OutOfCore {
        max_memory,
        scratch,
        tile_depth: None,
    };
    let progress = Progress::from_arg(py, progress)?;
    let (work_inputs, work_options) = (inputs.clone(), options.clone());
    let run = monitored(py, &progress, move |monitor| {
        psi::sample_files_out_of_core(
            &work_inputs,
            None,
            &mpu_params,
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
    })?
    .map_err(|e| psi_error(py, e, Some("sampling out of core")))?;
    let report = psi::out_of_core_json(&inputs, &mpu_params, &particle_params, &options, &run);
    crate::json::to_python(py, &report)
}
