//! `psi.PointSet`, `psi.load_points` and `psi.builtin_model`: points read (from a file, arrays
//! or the built-in model) and prepared for the MPU exactly as the CLI's `input.rs` does —
//! `psi::load_points`, then `psi::prepare_points` with the CLI's preprocessing flags.

use std::path::PathBuf;
use std::sync::Arc;

use numpy::PyArray2;
use psi::octree::{Monitor, PointAttributes};
use psi::preprocess::PreprocessParams;
use psi::{MeshSampling, PointCloudFile, PreparedInput, ReadOptions};
use pyo3::exceptions::PyUserWarning;
use pyo3::prelude::*;

use crate::arrays::{ReadOnly, oriented_array, vector3, vectors};
use crate::attributes::{AttributeArrays, attributes_of};
use crate::errors::{bounded, psi_error, value_error};
use crate::monitor::{Progress, monitored};

/// What was read and how it was prepared (the CLI's input, from the facade).
pub(crate) type Input = PreparedInput;

/// The preprocessing steps the keyword arguments choose (the CLI's flags of those names):
/// [`PreprocessParams::scan`] changed where asked, or [`PreprocessParams::none`] with
/// `preprocess=False`.
#[allow(clippy::too_many_arguments)]
fn preprocess_params(
    preprocess: bool,
    keep_outliers: bool,
    estimate_normals: bool,
    orient_normals: bool,
    viewpoint: Option<&Bound<'_, PyAny>>,
    estimate_noise: bool,
    denoise: bool,
    densify: bool,
    keep_inward_normals: bool,
) -> PyResult<PreprocessParams> {
    let viewpoint = viewpoint.map(|v| vector3(v, "viewpoint")).transpose()?;
    if viewpoint.is_some_and(|v| !v.is_finite()) {
        return Err(value_error("viewpoint must be three finite numbers"));
    }
    if !preprocess {
        let asked: Vec<&str> = [
            (keep_outliers, "keep_outliers"),
            (!estimate_normals, "estimate_normals"),
            (orient_normals, "orient_normals"),
            (viewpoint.is_some(), "viewpoint"),
            (!estimate_noise, "estimate_noise"),
            (!denoise, "denoise"),
            (!densify, "densify"),
            (keep_inward_normals, "keep_inward_normals"),
        ]
        .into_iter()
        .filter_map(|(given, name)| given.then_some(name))
        .collect();
        if !asked.is_empty() {
            return Err(value_error(format!(
                "preprocess=False turns every preprocessing step off; {} asks for one",
                asked.join(", ")
            )));
        }
        return Ok(PreprocessParams::none());
    }
    Ok(PreprocessParams {
        remove_outliers: !keep_outliers,
        estimate_normals,
        viewpoint,
        orient_given_normals: orient_normals,
        estimate_noise,
        denoise,
        densify_meshes: densify,
        flip_inward_normals: !keep_inward_normals,
    })
}

/// The points of `file` (named `name`; read by `read` on the worker thread) prepared for the
/// MPU, on a worker thread ([`monitored`]: progress, Ctrl-C); warns, as the CLI notices, when
/// given normals disagree or were flipped outward.
fn prepare(
    py: Python<'_>,
    name: String,
    read: impl FnOnce(&Monitor<'_>) -> Result<PointCloudFile, psi::PsiError> + Send + 'static,
    params: PreprocessParams,
    progress: &Progress,
) -> PyResult<Input> {
    /// Why preparing failed, told on the caller's thread.
    enum Failed {
        Read(psi::PsiError),
        Prepare(psi::preprocess::PreprocessError),
    }
    let what = name.clone();
    let input = monitored(py, progress, move |monitor| {
        monitor.report("read", 0, 1);
        let file = read(monitor).map_err(Failed::Read)?;
        if monitor.stopped() {
            // The caller has raised already; nothing of this is kept.
            return Err(Failed::Prepare(psi::octree::Interrupted.into()));
        }
        monitor.report("read", 1, 1);
        psi::prepare_input(name, file, &params, monitor).map_err(Failed::Prepare)
    })?;
    let input = input.map_err(|e| match e {
        Failed::Read(e) => psi_error(py, e, Some("reading the input")),
        Failed::Prepare(e @ psi::preprocess::PreprocessError::NoNormals) => value_error(format!(
            "{what}: {e}; give normals or let psi estimate them (estimate_normals=True, preprocess=True)"
        )),
        Failed::Prepare(e) => value_error(format!("{what}: {e}")),
    })?;
    if let Some(notice) = input.report.inward_notice(&what) {
        let message = format!("psi: {notice} (keep_inward_normals=True to keep them)");
        let message = std::ffi::CString::new(message).unwrap_or_default();
        PyErr::warn(py, &py.get_type::<PyUserWarning>(), &message, 1)?;
    }
    if let Some(opposed) = input.report.inconsistent_normals() {
        let message = format!(
            "psi: {what}: {:.1} % of neighbouring normals point to opposite sides; try orient_normals=True",
            100.0 * opposed
        );
        let message = std::ffi::CString::new(message).unwrap_or_default();
        PyErr::warn(py, &py.get_type::<PyUserWarning>(), &message, 1)?;
    }
    Ok(input)
}

/// Arrays `points` (N, 3) and optional `normals` (N, 3), read as an XYZ file of them.
fn from_arrays(
    py: Python<'_>,
    points: &Bound<'_, PyAny>,
    normals: Option<&Bound<'_, PyAny>>,
    attributes: PointAttributes,
    params: PreprocessParams,
    progress: &Progress,
) -> PyResult<Input> {
    let file = columns(points, normals, attributes)?;
    prepare(py, "points".to_owned(), move |_| Ok(file), params, progress)
}

/// Arrays `points` (N, 3) and optional `normals` (N, 3), with their `attributes`, as `psi_io`
/// reads an XYZ file of them (zero normals dropped, with their attributes); a `ValueError` when
/// the shapes differ or a value is not finite.
pub(crate) fn columns(
    points: &Bound<'_, PyAny>,
    normals: Option<&Bound<'_, PyAny>>,
    attributes: PointAttributes,
) -> PyResult<PointCloudFile> {
    let positions = vectors(points, "points")?;
    let normals = normals.map(|n| vectors(n, "normals")).transpose()?;
    if let Some(n) = &normals
        && n.len() != positions.len()
    {
        return Err(value_error(format!(
            "normals must have the shape of points, ({}, 3), got ({}, 3)",
            positions.len(),
            n.len()
        )));
    }
    psi::io::points_from_columns(positions, normals, attributes)
        .map_err(|e| value_error(format!("points: {e}")))
}

/// The input of [`crate::mpu`] and [`crate::scene`]: a `PointSet`, or arrays (then prepared
/// with every step on, or none with `preprocess=False`).
pub(crate) fn input_of(
    py: Python<'_>,
    points: &Bound<'_, PyAny>,
    normals: Option<&Bound<'_, PyAny>>,
    preprocess: bool,
    progress: &Progress,
) -> PyResult<Arc<Input>> {
    if let Ok(set) = points.cast::<PointSet>() {
        if normals.is_some() {
            return Err(value_error(
                "normals: a PointSet carries its normals; give normals only with arrays",
            ));
        }
        return Ok(set.get().input.clone());
    }
    let params = if preprocess {
        PreprocessParams::scan()
    } else {
        PreprocessParams::none()
    };
    let none = PointAttributes::default();
    Ok(Arc::new(from_arrays(
        py, points, normals, none, params, progress,
    )?))
}

/// Oriented points prepared for the MPU: as read (from a file, arrays or the built-in model),
/// then, as the CLI does, stray points left out, missing normals estimated and oriented, the
/// noise estimated and, where it would matter, taken out, a coarse mesh given more points.
///
/// `PointSet(points, normals=None, *, preprocess=True, keep_outliers=False,
/// estimate_normals=True, orient_normals=False, viewpoint=None, estimate_noise=True,
/// denoise=True, densify=True)` reads arrays: `points` (N, 3) positions in world units and
/// `normals` (N, 3) (normalised; rows with a zero normal dropped) or `None` (estimated), any
/// real dtype and layout, as an XYZ file of them would be read. `preprocess=False` turns every
/// step off (normals are then required); otherwise each flag is the CLI's flag of that name,
/// `keep_inward_normals` the CLI's `--keep-inward-normals` (normals that point inward as a
/// whole are otherwise flipped outward, with a `UserWarning`). `progress`: `True` for a bar on
/// stderr, or a callable `(stage, done, total)`. Ctrl-C stops the work. Picklable.
#[pyclass(frozen, module = "psi", name = "PointSet")]
pub(crate) struct PointSet {
    pub(crate) input: Arc<Input>,
    points: ReadOnly<PyArray2<f64>>,
    normals: ReadOnly<PyArray2<f64>>,
    attributes: AttributeArrays,
}

impl PointSet {
    pub(crate) fn of(input: Input) -> Self {
        PointSet {
            input: Arc::new(input),
            points: ReadOnly::default(),
            normals: ReadOnly::default(),
            attributes: AttributeArrays::default(),
        }
    }
}

/// What a pickled `PointSet` holds besides its report.
#[derive(serde::Serialize, serde::Deserialize)]
struct PointSetState {
    name: String,
    points_read: usize,
    points: Vec<psi::OrientedPoint>,
    report: psi::preprocess::PreprocessReport,
    attributes: PointAttributes,
}

#[pymethods]
impl PointSet {
    #[new]
    #[pyo3(signature = (points, normals=None, *, colors=None, intensity=None,
        classification=None, preprocess=true, keep_outliers=false, estimate_normals=true,
        orient_normals=false, viewpoint=None, estimate_noise=true, denoise=true, densify=true,
        keep_inward_normals=false, progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        points: &Bound<'_, PyAny>,
        normals: Option<&Bound<'_, PyAny>>,
        colors: Option<&Bound<'_, PyAny>>,
        intensity: Option<&Bound<'_, PyAny>>,
        classification: Option<&Bound<'_, PyAny>>,
        preprocess: bool,
        keep_outliers: bool,
        estimate_normals: bool,
        orient_normals: bool,
        viewpoint: Option<&Bound<'_, PyAny>>,
        estimate_noise: bool,
        denoise: bool,
        densify: bool,
        keep_inward_normals: bool,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let params = preprocess_params(
            preprocess,
            keep_outliers,
            estimate_normals,
            orient_normals,
            viewpoint,
            estimate_noise,
            denoise,
            densify,
            keep_inward_normals,
        )?;
        let progress = Progress::from_arg(py, progress)?;
        let n = crate::arrays::rows(points, "points")?;
        let attributes = attributes_of(colors, intensity, classification, n)?;
        Ok(PointSet::of(from_arrays(
            py, points, normals, attributes, params, &progress,
        )?))
    }

    /// Positions after preprocessing, shape (N, 3), float64, world units: a read-only array,
    /// made on first access and the same object afterwards.
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        self.points
            .get(py, || oriented_array(py, &self.input.points, false))
    }

    /// Unit normals after preprocessing, shape (N, 3), float64: read-only, as `points`.
    #[getter]
    fn normals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        self.normals
            .get(py, || oriented_array(py, &self.input.points, true))
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let i = &*self.input;
        let state = PointSetState {
            name: i.name.clone(),
            points_read: i.points_read,
            points: i.points.clone(),
            report: i.report.clone(),
            attributes: i.attributes.clone(),
        };
        crate::pickle::reduce::<PointSet>(py, &state, crate::json::to_python(py, &i.json)?)
    }

    /// Unpickling (not API).
    #[classmethod]
    fn _from_state(
        _cls: &Bound<'_, pyo3::types::PyType>,
        state: &[u8],
        json: &Bound<'_, PyAny>,
    ) -> PyResult<Self> {
        let s: PointSetState = crate::pickle::decode(state, "PointSet")?;
        Ok(PointSet::of(Input {
            name: s.name,
            points_read: s.points_read,
            points: s.points,
            report: s.report,
            json: crate::pickle::json_of(json)?,
            attributes: s.attributes,
        }))
    }

    /// Colours of the points, (N, 3) uint8 (read-only), or `None` when the input had none.
    #[getter]
    fn colors<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray2<u8>>>> {
        self.attributes.colors(py, &self.input.attributes)
    }

    /// Return intensities, (N,) float32 (read-only), or `None`.
    #[getter]
    fn intensity<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<Option<Bound<'py, numpy::PyArray1<f32>>>> {
        self.attributes.intensity(py, &self.input.attributes)
    }

    /// LAS classes, (N,) uint8 (read-only), or `None`.
    #[getter]
    fn classification<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<Option<Bound<'py, numpy::PyArray1<u8>>>> {
        self.attributes.classification(py, &self.input.attributes)
    }

    /// Points read, before preprocessing.
    #[getter]
    fn points_read(&self) -> usize {
        self.input.points_read
    }

    /// The MPU error threshold ε0/D the data suggest: the paper's 0.005, or 4× the noise left
    /// when that is larger (what `Mpu(point_set)` uses unless `error` is given).
    #[getter]
    fn error(&self) -> f64 {
        self.input.report.error_threshold(None).relative
    }

    /// The input's name: the file as given, `builtin` or `points` (arrays).
    #[getter]
    fn name(&self) -> &str {
        &self.input.name
    }

    /// What was read and what preprocessing did: the `input` object of the CLI's JSON report
    /// (`psi info --json`), as a dict.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::json::to_python(py, &self.input.json)
    }

    fn __len__(&self) -> usize {
        self.input.points.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "PointSet({:?}: {} points, {} read)",
            self.input.name,
            self.input.points.len(),
            self.input.points_read
        )
    }
}

/// Reads oriented points from a PLY, OBJ or XYZ file (format from the extension, else from
/// the content) and prepares them as `psi sample FILE` does (see `PointSet`). A mesh gives
/// one point per triangle (centroid, face normal), or per vertex with area-weighted normals
/// when `per_vertex=True`. Raises `OSError` when the file cannot be read and `ValueError` when
/// it is malformed, with the CLI's message.
#[pyfunction]
#[pyo3(signature = (path, per_vertex=false, *, preprocess=true, keep_outliers=false,
    estimate_normals=true, orient_normals=false, viewpoint=None, estimate_noise=true,
    denoise=true, densify=true, keep_inward_normals=false, progress=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn load_points(
    py: Python<'_>,
    path: PathBuf,
    per_vertex: bool,
    preprocess: bool,
    keep_outliers: bool,
    estimate_normals: bool,
    orient_normals: bool,
    viewpoint: Option<&Bound<'_, PyAny>>,
    estimate_noise: bool,
    denoise: bool,
    densify: bool,
    keep_inward_normals: bool,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<PointSet> {
    let params = preprocess_params(
        preprocess,
        keep_outliers,
        estimate_normals,
        orient_normals,
        viewpoint,
        estimate_noise,
        denoise,
        densify,
        keep_inward_normals,
    )?;
    let sampling = if per_vertex {
        MeshSampling::VertexNormals
    } else {
        MeshSampling::FaceCentroids
    };
    let progress = Progress::from_arg(py, progress)?;
    let name = path.display().to_string();
    let read = move |_: &Monitor<'_>| {
        // An input that would not fit says so before it is read (use sample_files).
        psi::check_fits_in_memory(&path, None)?;
        psi::load_points(&path, &ReadOptions { sampling })
    };
    Ok(PointSet::of(prepare(py, name, read, params, &progress)?))
}

/// The built-in model (a bumpy, rounded-square torus with a thin neck; 80 000 points unless
/// `points` says otherwise), prepared as `psi sample` without an input does.
#[pyfunction]
#[pyo3(signature = (points=None, *, progress=None))]
pub(crate) fn builtin_model(
    py: Python<'_>,
    points: Option<i128>,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<PointSet> {
    let default = psi::shapes::BUILTIN_MODEL_POINTS as i128;
    let n = bounded::<u32>("points", points.unwrap_or(default), 1, 50_000_000)? as usize;
    let progress = Progress::from_arg(py, progress)?;
    let read = move |monitor: &Monitor<'_>| Ok(psi::builtin_file_with(n, monitor));
    let input = prepare(
        py,
        "builtin".to_owned(),
        read,
        PreprocessParams::scan(),
        &progress,
    )?;
    Ok(PointSet::of(input))
}
