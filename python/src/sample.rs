//! `psi.sample`, `psi.Particles` and `psi.save_particles`: the CLI's `psi sample` — the same
//! `ParticleParams`, the same particles bit for bit, the same JSON report as a dict.

use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use numpy::{PyArray1, PyArray2};
use psi::octree::PointAttributes;
use psi::preprocess::ErrorThreshold;
use psi::{DVec3, DensityMode, ParticleParams, SampleReport};
use pyo3::prelude::*;

use crate::arrays::{ReadOnly, column, vec3_array, vector, vectors};
use crate::attributes::{AttributeArrays, attributes_of};
use crate::errors::{bounded, detached, psi_error, value_error};
use crate::monitor::{Progress, monitored};
use crate::mpu::Mpu;

/// The sampling options of `psi sample` (`--iterations`, `--k`, `--count`, `--uniform`,
/// `--max-spacing`, `--seed`) as `ParticleParams`, with the CLI's bounds.
pub(crate) fn particle_params(
    iterations: i128,
    k: Option<i128>,
    count: Option<i128>,
    uniform: bool,
    max_spacing: Option<f64>,
    seed: i128,
) -> PyResult<ParticleParams> {
    if let Some(s) = max_spacing {
        if s.is_nan() || s <= 0.0 {
            return Err(crate::errors::value_error(format!(
                "max_spacing={s} is not a positive length (world units; inf for none)"
            )));
        }
        if count.is_some() || uniform {
            return Err(crate::errors::value_error(format!(
                "max_spacing={s} conflicts with count= and uniform=True, which set their own spacing"
            )));
        }
    }
    if let (Some(k), Some(c)) = (k, count) {
        return Err(crate::errors::value_error(format!(
            "k={k} and count={c} conflict: give k (particles per leaf) or count (exactly that many), not both"
        )));
    }
    if let (Some(k), true) = (k, uniform) {
        return Err(crate::errors::value_error(format!(
            "k={k} and uniform=True conflict: uniform sampling sets its count from count= (or one per leaf), not k"
        )));
    }
    let exact = |c| bounded::<u32>("count", c, 1, 50_000_000).map(|c| c as usize);
    Ok(ParticleParams {
        k: bounded::<u8>("k", k.unwrap_or(1), 1, 64)?.into(),
        count: count.map(exact).transpose()?,
        iterations: bounded::<u32>("iterations", iterations, 0, 100_000)? as usize,
        density: if uniform {
            DensityMode::Uniform
        } else {
            DensityMode::Adaptive
        },
        max_spacing,
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
/// units); `colors` (n, 3) uint8, `intensity` (n,) float32 and `classification` (n,) uint8
/// where the input had them (carried from the input points near each particle); from
/// `psi.sample` also `report`, the CLI's JSON report. Arrays are read-only and made once.
#[pyclass(frozen, module = "psi", name = "Particles")]
pub(crate) struct Particles {
    pub(crate) particles: psi::Particles,
    /// Whether `particles.depth` and `.sigma` were given (particles from arrays or a file may
    /// lack them: then depth is 0 and σ the splat estimate, and the getters give `None`).
    pub(crate) has_depth: bool,
    pub(crate) has_sigma: bool,
    source: Option<ReportSource>,
    report: OnceLock<serde_json::Value>,
    /// Colours, intensities and classes (aligned with the particles; empty without any).
    pub(crate) attributes: PointAttributes,
    arrays: [ReadOnly<PyArray2<f64>>; 2],
    depth_array: ReadOnly<PyArray1<u8>>,
    sigma_array: ReadOnly<PyArray1<f64>>,
    attribute_arrays: AttributeArrays,
}

impl Particles {
    fn with(particles: psi::Particles, has: (bool, bool), source: Option<ReportSource>) -> Self {
        Particles {
            particles,
            has_depth: has.0,
            has_sigma: has.1,
            source,
            report: OnceLock::new(),
            attributes: PointAttributes::default(),
            arrays: Default::default(),
            depth_array: ReadOnly::default(),
            sigma_array: ReadOnly::default(),
            attribute_arrays: AttributeArrays::default(),
        }
    }

    /// These particles carrying `attributes` (aligned with them, or empty).
    pub(crate) fn carrying(mut self, attributes: PointAttributes) -> Self {
        self.attributes = attributes;
        self
    }

    /// Particles without a report (a scene's).
    pub(crate) fn bare(particles: psi::Particles) -> Self {
        Self::with(particles, (true, true), None)
    }

    /// Particles from columns: normals estimated where absent, σ estimated for drawing where
    /// absent ([`psi::render::splat_radii`], as `psi render` does).
    fn from_columns(c: psi::ParticleColumns, normals_given: bool) -> PyResult<Self> {
        let n = c.positions.len();
        let normals = if normals_given {
            c.normals
        } else {
            psi::preprocess::estimate_normals(&c.positions)
                .into_iter()
                .map(|v| if v == DVec3::ZERO { DVec3::Z } else { v })
                .collect()
        };
        let depth = match &c.depth {
            Some(d) => d
                .iter()
                .enumerate()
                .map(|(i, &v)| {
                    if v.fract() == 0.0 && (0.0..=255.0).contains(&v) {
                        Ok(v as u8)
                    } else {
                        Err(value_error(format!(
                            "depth: particle {i} has depth {v}, not a whole number in 0..=255"
                        )))
                    }
                })
                .collect::<PyResult<Vec<u8>>>()?,
            None => vec![0; n],
        };
        if let Some(i) = c
            .sigma
            .as_ref()
            .and_then(|s| s.iter().position(|v| !(v.is_finite() && *v > 0.0)))
        {
            return Err(value_error(format!(
                "sigma: particle {i} has a sigma that is not a positive number"
            )));
        }
        let sigma = c
            .sigma
            .clone()
            .unwrap_or_else(|| psi::render::splat_radii(&c.positions, None));
        let particles = psi::Particles {
            target: sigma.clone(),
            positions: c.positions,
            normals,
            depth,
            sigma,
        };
        Ok(
            Self::with(particles, (c.depth.is_some(), c.sigma.is_some()), None)
                .carrying(c.attributes),
        )
    }

    /// The particles as the columns of a file, without what they were not given.
    pub(crate) fn columns(&self) -> psi::ParticleColumns {
        let p = &self.particles;
        psi::ParticleColumns {
            positions: p.positions.clone(),
            normals: p.normals.clone(),
            depth: self
                .has_depth
                .then(|| p.depth.iter().map(|&d| f64::from(d)).collect()),
            sigma: self.has_sigma.then(|| p.sigma.clone()),
            attributes: self.attributes.clone(),
        }
    }
}

/// What a pickled `Particles` holds besides its report.
#[derive(serde::Serialize, serde::Deserialize)]
struct ParticlesState {
    particles: psi::Particles,
    has_depth: bool,
    has_sigma: bool,
    attributes: PointAttributes,
}

#[pymethods]
impl Particles {
    /// Particles from arrays (another tool's samples, say): `positions` (N, 3) world units;
    /// `normals` (N, 3) or `None` (estimated from the positions' neighbourhoods); `depth` (N,)
    /// whole numbers 0..255 or `None`; `sigma` (N,) positive radii or `None` (then `render`
    /// sizes the splats from the point count); `colors` (N, 3) 0–255, `intensity` (N,) and
    /// `classification` (N,) 0–255 or `None`. Picklable, as every `Particles`.
    #[new]
    #[pyo3(signature = (positions, normals=None, *, depth=None, sigma=None, colors=None,
        intensity=None, classification=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        positions: &Bound<'_, PyAny>,
        normals: Option<&Bound<'_, PyAny>>,
        depth: Option<&Bound<'_, PyAny>>,
        sigma: Option<&Bound<'_, PyAny>>,
        colors: Option<&Bound<'_, PyAny>>,
        intensity: Option<&Bound<'_, PyAny>>,
        classification: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let positions = vectors(positions, "positions")?;
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(value_error(format!(
                "positions: point {i} has a NaN or infinite coordinate"
            )));
        }
        let n = positions.len();
        let given = normals.is_some();
        let normals = match normals {
            Some(v) => {
                let v = vectors(v, "normals")?;
                if v.len() != n {
                    return Err(value_error(format!(
                        "normals must have the shape of positions, ({n}, 3), got ({}, 3)",
                        v.len()
                    )));
                }
                if let Some(i) = v.iter().position(|p| !p.is_finite() || *p == DVec3::ZERO) {
                    return Err(value_error(format!(
                        "normals: row {i} is zero, NaN or infinite"
                    )));
                }
                // Unit rows (to rounding) are kept bit for bit, others made unit.
                v.into_iter()
                    .map(|n| {
                        if (n.length_squared() - 1.0).abs() <= 1e-12 {
                            n
                        } else {
                            n.normalize()
                        }
                    })
                    .collect()
            }
            None => Vec::new(),
        };
        let columns = psi::ParticleColumns {
            positions,
            normals,
            depth: depth.map(|d| column(d, "depth", n)).transpose()?,
            sigma: sigma.map(|s| column(s, "sigma", n)).transpose()?,
            attributes: attributes_of(colors, intensity, classification, n)?,
        };
        detached(py, || Self::from_columns(columns, given))?
    }

    /// Positions, shape (n, 3), float64, world units: read-only, made on first access and the
    /// same array afterwards (as every array here).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        self.arrays[0].get(py, || vec3_array(py, &self.particles.positions))
    }

    /// Unit normals ∇f/|∇f|, shape (n, 3), float64.
    #[getter]
    fn normals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        self.arrays[1].get(py, || vec3_array(py, &self.particles.normals))
    }

    /// Octree depth of each particle's leaf, shape (n,), uint8; `None` when not given.
    #[getter]
    fn depth<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray1<u8>>>> {
        if !self.has_depth {
            return Ok(None);
        }
        let d = &self.particles.depth;
        self.depth_array.get(py, || vector(py, d.clone())).map(Some)
    }

    /// Repulsion radius σ of each particle (about half the local spacing), shape (n,),
    /// float64, world units; `None` when not given.
    #[getter]
    fn sigma<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray1<f64>>>> {
        if !self.has_sigma {
            return Ok(None);
        }
        let s = &self.particles.sigma;
        self.sigma_array.get(py, || vector(py, s.clone())).map(Some)
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let state = ParticlesState {
            particles: self.particles.clone(),
            has_depth: self.has_depth,
            has_sigma: self.has_sigma,
            attributes: self.attributes.clone(),
        };
        let report = self.report(py)?;
        crate::pickle::reduce::<Particles>(py, &state, report)
    }

    /// Unpickling (not API).
    #[classmethod]
    fn _from_state(
        _cls: &Bound<'_, pyo3::types::PyType>,
        state: &[u8],
        report: &Bound<'_, PyAny>,
    ) -> PyResult<Self> {
        let s: ParticlesState = crate::pickle::decode(state, "Particles")?;
        let has = (s.has_depth, s.has_sigma);
        let out = Self::with(s.particles, has, None).carrying(s.attributes);
        if !report.is_none() {
            let _ = out.report.set(crate::pickle::json_of(report)?);
        }
        Ok(out)
    }

    /// Colours carried from the input, (n, 3) uint8 (read-only), or `None`.
    #[getter]
    fn colors<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray2<u8>>>> {
        self.attribute_arrays.colors(py, &self.attributes)
    }

    /// Intensities carried from the input, (n,) float32 (read-only), or `None`.
    #[getter]
    fn intensity<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray1<f32>>>> {
        self.attribute_arrays.intensity(py, &self.attributes)
    }

    /// LAS classes carried from the input (weighted majority), (n,) uint8, or `None`.
    #[getter]
    fn classification<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray1<u8>>>> {
        self.attribute_arrays.classification(py, &self.attributes)
    }

    /// The run's report, the dict `psi sample --json` writes (`input`, `mpu`, `particles`,
    /// `peak_memory_bytes`); made on first access (it measures the MPU's data coverage).
    /// `None` for particles not sampled by `psi.sample` (a scene's, arrays, a file's).
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        if let Some(value) = self.report.get() {
            return crate::json::to_python(py, value);
        }
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
/// depth-adaptive spacing or one `uniform` spacing (blue noise), the adaptive spacing never
/// coarser than `max_spacing` (world units; default 2.5 % of the bounding-box diagonal, `inf`
/// for none: particles are added where the data has none near), `iterations` relaxation steps
/// (0 to 100 000), every random choice from `seed`. For the same input and seed the particles
/// are bitwise those the CLI writes. The interpreter is released meanwhile.
#[pyfunction]
#[pyo3(signature = (mpu, *, iterations=20, k=None, count=None, uniform=false, max_spacing=None,
    seed=2007, progress=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn sample(
    py: Python<'_>,
    mpu: &Mpu,
    iterations: i128,
    k: Option<i128>,
    count: Option<i128>,
    uniform: bool,
    max_spacing: Option<f64>,
    seed: i128,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<Particles> {
    let params = particle_params(iterations, k, count, uniform, max_spacing, seed)?;
    let progress = Progress::from_arg(py, progress)?;
    let shared = mpu.mpu.clone();
    let worker = shared.clone();
    let input_attributes = mpu.attributes.clone();
    let run = monitored(py, &progress, move |monitor| {
        let run = psi::particles::sample_with(&worker, &params, monitor)?;
        let carried =
            psi::particles::transfer_attributes(&worker, &run.particles, &input_attributes);
        Ok::<_, psi::octree::Interrupted>((run, carried))
    })?
    .map_err(|_| crate::errors::value_error("interrupted"));
    let (run, carried) = run?;
    let source = ReportSource {
        mpu: shared,
        input_json: mpu.input_json.clone(),
        threshold: mpu.threshold,
        sampling: run.report,
        params,
        peak_memory_bytes: psi::report::peak_memory_bytes(),
    };
    Ok(Particles::with(run.particles, (true, true), Some(source)).carrying(carried))
}

/// Reads particles from a file: a PLY with `x y z nx ny nz` and, when present, `depth` and
/// `sigma` (what `psi sample -o` and `save_particles` write; bitwise back), or any points file
/// psi reads (PLY, OBJ, XYZ: normals estimated when absent, no depth, no σ). Raises `OSError`
/// when the file cannot be read and `ValueError` when it is malformed.
#[pyfunction]
pub(crate) fn load_particles(py: Python<'_>, path: PathBuf) -> PyResult<Particles> {
    let loaded = detached(py, || psi::load_particles(&path))?;
    match loaded {
        Ok(columns) => {
            // A points file without normals reads them as zero: estimate them.
            let given = columns.normals.iter().any(|n| *n != DVec3::ZERO);
            detached(py, || Particles::from_columns(columns, given))?
        }
        Err(psi::PsiError::Read {
            reason: psi::io::ReadError::NoNormals,
            ..
        }) => {
            let file = detached(py, || psi::load_points(&path, &psi::ReadOptions::paper()))?;
            let file = file.map_err(|e| psi_error(py, e, None));
            match file {
                Ok(f) => {
                    let columns = psi::ParticleColumns {
                        positions: f.points.iter().map(|p| p.p).collect(),
                        ..Default::default()
                    };
                    detached(py, || Particles::from_columns(columns, false))?
                }
                Err(e) => Err(e),
            }
        }
        Err(e) => Err(psi_error(py, e, None)),
    }
}

/// Writes particles as `psi sample -o` does: binary little-endian PLY with `x y z nx ny nz
/// depth sigma` (float64), through a temporary file renamed into place. Raises `OSError` when
/// the file cannot be written (an existing file is then untouched).
#[pyfunction]
pub(crate) fn save_particles(py: Python<'_>, path: PathBuf, particles: &Particles) -> PyResult<()> {
    if particles.has_depth && particles.has_sigma {
        return detached(py, || {
            psi::save_particles(&path, &particles.particles, &particles.attributes)
        })?
        .map_err(|e| psi_error(py, e, None));
    }
    let columns = particles.columns();
    detached(py, || psi::save_particle_columns(&path, &columns))?
        .map_err(|e| psi_error(py, e, None))
}
