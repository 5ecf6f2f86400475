//! `psi.sample`, `psi.Particles` and `psi.save_particles`: the CLI's `psi sample` — the same
//! `ParticleParams`, the same particles bit for bit, the same JSON report as a dict.

use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use numpy::{PyArray1, PyArray2};
use psi::preprocess::ErrorThreshold;
use psi::{DensityMode, ParticleParams, SampleReport};
use pyo3::prelude::*;

use crate::arrays::{vec3_array, vector};
use crate::errors::{bounded, detached, psi_error};
use crate::mpu::Mpu;

/// The sampling options of `psi sample` (`--iterations`, `--k`, `--count`, `--uniform`,
/// `--seed`) as `ParticleParams`, with the CLI's bounds.
pub(crate) fn particle_params(
    iterations: i128,
    k: i128,
    count: Option<i128>,
    uniform: bool,
    seed: i128,
) -> PyResult<ParticleParams> {
    let exact = |c| bounded::<u32>("count", c, 1, 50_000_000).map(|c| c as usize);
    Ok(ParticleParams {
        k: bounded::<u8>("k", k, 1, 64)?.into(),
        count: count.map(exact).transpose()?,
        iterations: bounded::<u32>("iterations", iterations, 0, 100_000)? as usize,
        density: if uniform {
            DensityMode::Uniform
        } else {
            DensityMode::Adaptive
        },
        seed: bounded("seed", seed, 0, u64::MAX)?,
        ..ParticleParams::paper()
    })
}

/// What the report of a sampling run is made from, kept until it is first asked for.
struct ReportSource {
    mpu: Arc<psi::Mpu>,
    input_json: Arc<serde_json::Value>,
    threshold: ErrorThreshold,
    sampling: SampleReport,
    params: ParticleParams,
    peak_memory_bytes: Option<u64>,
}

/// Particles on an MPU surface: `positions` and `normals` (n, 3) float64, `depth` (n,) uint8
/// (octree depth of each particle's leaf), `sigma` (n,) float64 (repulsion radius, world
/// units); from `psi.sample` also `report`, the CLI's JSON report. Arrays are new copies on
/// each access.
#[pyclass(frozen, module = "psi", name = "Particles")]
pub(crate) struct Particles {
    pub(crate) particles: psi::Particles,
    source: Option<ReportSource>,
    report: OnceLock<serde_json::Value>,
}

impl Particles {
    /// Particles without a report (a scene's).
    pub(crate) fn bare(particles: psi::Particles) -> Self {
        Particles {
            particles,
            source: None,
            report: OnceLock::new(),
        }
    }
}

#[pymethods]
impl Particles {
    /// Positions, shape (n, 3), float64, world units.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        vec3_array(py, &self.particles.positions)
    }

    /// Unit normals ∇f/|∇f|, shape (n, 3), float64.
    #[getter]
    fn normals<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        vec3_array(py, &self.particles.normals)
    }

    /// Octree depth of each particle's leaf, shape (n,), uint8.
    #[getter]
    fn depth<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u8>> {
        vector(py, self.particles.depth.clone())
    }

    /// Repulsion radius σ of each particle (about half the local spacing), shape (n,),
    /// float64, world units.
    #[getter]
    fn sigma<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vector(py, self.particles.sigma.clone())
    }

    /// The run's report, the dict `psi sample --json` writes (`input`, `mpu`, `particles`,
    /// `peak_memory_bytes`); made on first access (it measures the MPU's data coverage).
    /// `None` for a scene's particles.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let Some(s) = &self.source else {
            return Ok(py.None().into_bound(py));
        };
        let report = &self.report;
        let value = detached(py, || {
            report
                .get_or_init(|| {
                    psi::report::sample_json(&psi::report::SampleFacts {
                        input: &s.input_json,
                        mpu: &s.mpu,
                        threshold: s.threshold,
                        sampling: &s.sampling,
                        params: &s.params,
                        evaluation_floor: None,
                        peak_memory_bytes: s.peak_memory_bytes,
                    })
                })
                .clone()
        })?;
        crate::json::to_python(py, &value)
    }

    fn __len__(&self) -> usize {
        self.particles.len()
    }

    fn __repr__(&self) -> String {
        format!("Particles({} particles)", self.particles.len())
    }
}

/// Scatters particles over `mpu`'s surface and relaxes them, as `psi sample` does: `k`
/// particles per surface-containing leaf (1 to 64) or exactly `count` (1 to 50 000 000),
/// depth-adaptive spacing or one `uniform` spacing (blue noise), `iterations` relaxation steps
/// (0 to 100 000), every random choice from `seed`. For the same input and seed the particles
/// are bitwise those the CLI writes. The interpreter is released meanwhile.
#[pyfunction]
#[pyo3(signature = (mpu, *, iterations=20, k=1, count=None, uniform=false, seed=2007))]
pub(crate) fn sample(
    py: Python<'_>,
    mpu: &Mpu,
    iterations: i128,
    k: i128,
    count: Option<i128>,
    uniform: bool,
    seed: i128,
) -> PyResult<Particles> {
    let params = particle_params(iterations, k, count, uniform, seed)?;
    let shared = mpu.mpu.clone();
    let run = detached(py, || psi::sample(&shared, &params))?;
    Ok(Particles {
        particles: run.particles,
        source: Some(ReportSource {
            mpu: shared,
            input_json: mpu.input_json.clone(),
            threshold: mpu.threshold,
            sampling: run.report,
            params,
            peak_memory_bytes: psi::report::peak_memory_bytes(),
        }),
        report: OnceLock::new(),
    })
}

/// Writes particles as `psi sample -o` does: binary little-endian PLY with `x y z nx ny nz
/// depth sigma` (float64), through a temporary file renamed into place. Raises `OSError` when
/// the file cannot be written (an existing file is then untouched).
#[pyfunction]
pub(crate) fn save_particles(py: Python<'_>, path: PathBuf, particles: &Particles) -> PyResult<()> {
    detached(py, || psi::save_particles(&path, &particles.particles))?
        .map_err(|e| psi_error(py, e, None))
}
