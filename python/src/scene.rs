//! `psi.Scene`: points, their MPU and their particles kept consistent under shape edits by
//! local regeneration (`psi::regen::Scene`), as `psi edit` does; safe from any number of
//! threads (one lock), picklable.

use std::sync::{Arc, Mutex, MutexGuard, PoisonError, TryLockError};

use numpy::PyArray2;
use psi::mpu::MpuFrame;
use psi::octree::PointAttributes;
use psi::particles::DensityField;
use psi::preprocess::ErrorThreshold;
use psi::regen::{Edit, FRAME_ITERATIONS, RegenError};
use psi::{MpuParams, OrientedPoint, ParticleParams, SampleReport};
use pyo3::prelude::*;

use crate::arrays::{oriented_array, vector3};
use crate::attributes::attributes_of;
use crate::errors::value_error;
use crate::monitor::{Progress, monitored};
use crate::mpu::{Mpu, MpuOptions};
use crate::points::input_of;
use crate::sample::{Particles, particle_params};

/// Points, their MPU and their particles, updated locally by edits (paper §6): only the cells
/// an edit can reach are refitted and only their particles regenerated; the particles elsewhere
/// stay bitwise unchanged, and the MPU equals a build from scratch in the scene's frame
/// (`Mpu(scene.points, scene.normals, preprocess=False, frame=scene.mpu.frame)`).
///
/// `Scene(points, normals=None, *, error=None, max_depth=12, smooth=False,
/// scale_invariant=False, preprocess=True, iterations=20, k=None, count=None, uniform=False,
/// max_spacing=None, seed=2007, progress=None)`: the input and MPU options of `psi.Mpu`, the
/// sampling options
/// of `psi.sample` (`psi edit` uses their defaults but for `iterations`). Building and every
/// edit release the interpreter; Ctrl-C stops the build. Each edit returns its report as a
/// dict (`RegenReport`: marked and refitted cells, particles removed and regenerated, points,
/// whether the edit left the root cube and forced a full rebuild, seconds, CPU seconds,
/// pending iterations; `edit`: the edit's
/// place in the scene's sequence, from 0); a refused edit raises `ValueError` and leaves the
/// scene unchanged.
///
/// Threads: every method takes the scene's lock (waiting with the interpreter released), so
/// edits and reads from any number of threads apply one at a time, in some order. Picklable.
#[pyclass(frozen, module = "psi", name = "Scene")]
pub(crate) struct Scene {
    /// Shared with the worker thread an edit runs on, which holds the lock while it works.
    state: Arc<Mutex<State>>,
    /// The input's name, its report object and the error threshold used.
    name: String,
    input_json: Arc<serde_json::Value>,
    threshold: ErrorThreshold,
    report: SampleReport,
}

/// What the lock guards: the scene, the number of edits applied to it, and, for a scene just
/// unpickled, the report of the build its MPU repeats (until the next edit).
struct State {
    scene: psi::regen::Scene,
    edits: usize,
    mpu_report: Option<psi::BuildReport>,
}

/// What a pickled `Scene` holds besides its input's report.
#[derive(serde::Serialize, serde::Deserialize)]
struct SceneState {
    name: String,
    points: Vec<OrientedPoint>,
    frame: MpuFrame,
    mpu_params: MpuParams,
    particle_params: ParticleParams,
    particles: psi::Particles,
    field: DensityField,
    edits: usize,
    threshold: ErrorThreshold,
    report: SampleReport,
    mpu_report: psi::BuildReport,
    attributes: [PointAttributes; 2],
}

// The signatures below spell `frame_iterations=4` out (a literal shows in the stub);
// it must stay psi's frame.
const _: () = assert!(FRAME_ITERATIONS == 4);

fn edit_error(e: RegenError) -> PyErr {
    value_error(format!("applying an edit: {e}"))
}

impl Scene {
    /// The state, locked; waits with the interpreter released.
    /// The state, locked. While another thread holds it, waits in short sleeps without the
    /// interpreter, checking for signals between them (Ctrl-C raises). A lock poisoned by a
    /// panic is taken all the same: an edit changes the state only in its last, panic-free
    /// step, so the state is whole.
    fn lock<'s>(&'s self, py: Python<'_>) -> PyResult<MutexGuard<'s, State>> {
        loop {
            match self.state.try_lock() {
                Ok(guard) => return Ok(guard),
                Err(TryLockError::Poisoned(p)) => return Ok(p.into_inner()),
                Err(TryLockError::WouldBlock) => {
                    py.detach(|| std::thread::sleep(std::time::Duration::from_millis(2)));
                    py.check_signals()?;
                }
            }
        }
    }

    /// Applies `edit` on a worker thread ([`monitored`]: Ctrl-C stops it and leaves the scene
    /// unchanged); the worker takes the lock, so edits from several threads apply in turn.
    fn apply<'py>(
        &self,
        py: Python<'py>,
        edit: Edit,
        added: PointAttributes,
        settle: bool,
        frame_iterations: usize,
    ) -> PyResult<Bound<'py, PyAny>> {
        let frame = if settle { usize::MAX } else { frame_iterations };
        let shared = self.state.clone();
        let (report, index) = monitored(py, &Progress::Silent, move |monitor| {
            let mut state = shared.lock().unwrap_or_else(PoisonError::into_inner);
            // Waiting for the lock may have taken long: stop now rather than after a refit.
            monitor.check().map_err(|e| edit_error(e.into()))?;
            let report = state
                .scene
                .apply_deferred(&edit, &added, frame, monitor)
                .map_err(edit_error)?;
            let index = state.edits;
            state.edits += 1;
            state.mpu_report = None;
            Ok::<_, PyErr>((report, index))
        })??;
        let dict = crate::json::report(py, &report)?;
        dict.set_item("edit", index)?;
        Ok(dict)
    }
}

#[pymethods]
impl Scene {
    #[new]
    #[pyo3(signature = (points, normals=None, *, error=None, max_depth=12, smooth=false,
        scale_invariant=false, preprocess=true, iterations=20, k=None, count=None, uniform=false,
        max_spacing=None, seed=2007, progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        points: &Bound<'_, PyAny>,
        normals: Option<&Bound<'_, PyAny>>,
        error: Option<f64>,
        max_depth: i128,
        smooth: bool,
        scale_invariant: bool,
        preprocess: bool,
        iterations: i128,
        k: Option<i128>,
        count: Option<i128>,
        uniform: bool,
        max_spacing: Option<f64>,
        seed: i128,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let options = MpuOptions {
            error,
            max_depth,
            smooth,
            scale_invariant,
        };
        let params = particle_params(iterations, k, count, uniform, max_spacing, seed)?;
        let progress = Progress::from_arg(py, progress)?;
        let input = input_of(py, points, normals, preprocess, &progress)?;
        let (mpu_params, threshold) = options.params(&input)?;
        let name = input.name.clone();
        let input_json = Arc::new(input.json.clone());
        // The points move into the scene unless a `PointSet` still holds them.
        let (points, attributes) = match Arc::try_unwrap(input) {
            Ok(input) => (input.points, input.attributes),
            Err(shared) => (shared.points.clone(), shared.attributes.clone()),
        };
        let (scene, report) = monitored(py, &progress, move |monitor| {
            psi::regen::Scene::new_with(points, attributes, &mpu_params, &params, monitor)
        })?
        .map_err(|e| value_error(format!("{name}: building the scene: {e}")))?;
        Ok(Scene {
            state: Arc::new(Mutex::new(State {
                scene,
                edits: 0,
                mpu_report: None,
            })),
            name,
            input_json,
            threshold,
            report,
        })
    }

    /// Moves the points within `radius` of `centre` (3,) by `displacement` (3,) × (1 − t²)²,
    /// t = distance / radius (world units; the normals follow the deformation); returns the
    /// edit's report. With `settle=False` the edit is an interactive frame: only
    /// `frame_iterations` of the regenerated particles' relaxation run, `settle()` runs the
    /// rest (the next edit first finishes it), bitwise as `settle=True` would have.
    #[pyo3(signature = (centre, radius, displacement, *, settle=true, frame_iterations=4))]
    fn brush<'py>(
        &self,
        py: Python<'py>,
        centre: &Bound<'py, PyAny>,
        radius: f64,
        displacement: &Bound<'py, PyAny>,
        settle: bool,
        frame_iterations: usize,
    ) -> PyResult<Bound<'py, PyAny>> {
        let edit = Edit::Brush {
            center: vector3(centre, "centre")?,
            radius,
            displacement: vector3(displacement, "displacement")?,
        };
        self.apply(
            py,
            edit,
            PointAttributes::default(),
            settle,
            frame_iterations,
        )
    }

    /// Removes the points within `radius` of `centre` (3,); returns the edit's report.
    /// `settle` and `frame_iterations` as for `brush`.
    #[pyo3(signature = (centre, radius, *, settle=true, frame_iterations=4))]
    fn remove<'py>(
        &self,
        py: Python<'py>,
        centre: &Bound<'py, PyAny>,
        radius: f64,
        settle: bool,
        frame_iterations: usize,
    ) -> PyResult<Bound<'py, PyAny>> {
        let edit = Edit::Remove {
            center: vector3(centre, "centre")?,
            radius,
        };
        self.apply(
            py,
            edit,
            PointAttributes::default(),
            settle,
            frame_iterations,
        )
    }

    /// Runs up to `iterations` (default: all) more relaxation iterations of the last edit's
    /// particles when it was made with `settle=False`, finishing it once none is left; returns
    /// a dict (`iterations` run, `pending_iterations` left, `seconds`, `cpu_seconds`).
    #[pyo3(signature = (iterations=None))]
    fn settle<'py>(
        &self,
        py: Python<'py>,
        iterations: Option<usize>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let mut state = self.lock(py)?;
        let n = iterations.unwrap_or(usize::MAX);
        let scene = &mut state.scene;
        let report = py.detach(|| scene.settle(n));
        drop(state);
        crate::json::report(py, &report)
    }

    /// Relaxation iterations the last edit's particles still have to run (0 when settled).
    #[getter]
    fn pending_iterations(&self, py: Python<'_>) -> PyResult<usize> {
        Ok(self.lock(py)?.scene.pending_iterations())
    }

    /// Adds oriented points: `points` and `normals` (N, 3), normals normalised here (rows with
    /// a zero normal dropped), with their `colors`, `intensity` and `classification` (or the
    /// defaults — black, 0, class 0 — where the scene has such attributes); returns the edit's
    /// report. `settle` and `frame_iterations` as for `brush`.
    #[pyo3(signature = (points, normals, *, colors=None, intensity=None, classification=None,
        settle=true, frame_iterations=4))]
    #[allow(clippy::too_many_arguments)]
    fn insert<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        normals: &Bound<'py, PyAny>,
        colors: Option<&Bound<'py, PyAny>>,
        intensity: Option<&Bound<'py, PyAny>>,
        classification: Option<&Bound<'py, PyAny>>,
        settle: bool,
        frame_iterations: usize,
    ) -> PyResult<Bound<'py, PyAny>> {
        let n = crate::arrays::rows(points, "points")?;
        let attributes = attributes_of(colors, intensity, classification, n)?;
        let file = crate::points::columns(points, Some(normals), attributes)?;
        let added = file.attributes;
        self.apply(
            py,
            Edit::Insert {
                points: file.points,
            },
            added,
            settle,
            frame_iterations,
        )
    }

    /// The current particles (a snapshot; `report` is `None`).
    #[getter]
    fn particles(&self, py: Python<'_>) -> PyResult<Particles> {
        let state = self.lock(py)?;
        let particles = Particles::bare(state.scene.particles().clone());
        Ok(particles.carrying(state.scene.particle_attributes().clone()))
    }

    /// The current implicit, in the scene's frame (a snapshot): `scene.mpu.value(x)` is f of
    /// the edited points.
    #[getter]
    fn mpu(&self, py: Python<'_>) -> PyResult<Mpu> {
        let state = self.lock(py)?;
        let mpu = Arc::new(state.scene.mpu().clone());
        let out = Mpu::of(
            mpu,
            self.name.clone(),
            self.input_json.clone(),
            self.threshold,
            None,
        );
        let attributes = state.scene.attributes().clone();
        Ok(out.reporting(state.mpu_report.clone()).carrying(attributes))
    }

    /// The current control points, shape (N, 3), float64, world units (a new array).
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let state = self.lock(py)?;
        Ok(oriented_array(py, state.scene.points(), false))
    }

    /// Their unit normals, shape (N, 3), float64 (a new array).
    #[getter]
    fn normals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let state = self.lock(py)?;
        Ok(oriented_array(py, state.scene.points(), true))
    }

    /// Edits applied so far.
    #[getter]
    fn edits(&self, py: Python<'_>) -> PyResult<usize> {
        Ok(self.lock(py)?.edits)
    }

    /// The first sampling's report (`SampleReport`: count, seconds, density, spacing quality
    /// before and after relaxation), as a dict.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::json::report(py, &self.report)
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut state = self.lock(py)?;
        // A pickle holds settled particles: the last edit's settling finishes first.
        let scene = &mut state.scene;
        py.detach(|| scene.settle(usize::MAX));
        let scene = &state.scene;
        let saved = SceneState {
            name: self.name.clone(),
            points: scene.points().to_vec(),
            frame: *scene.mpu().frame(),
            mpu_params: *scene.mpu_params(),
            particle_params: *scene.particle_params(),
            particles: scene.particles().clone(),
            field: *scene.density(),
            edits: state.edits,
            threshold: self.threshold,
            report: self.report.clone(),
            mpu_report: state
                .mpu_report
                .clone()
                .unwrap_or_else(|| scene.mpu().report().clone()),
            attributes: [
                scene.attributes().clone(),
                scene.particle_attributes().clone(),
            ],
        };
        drop(state);
        let json = crate::json::to_python(py, &self.input_json)?;
        crate::pickle::reduce::<Scene>(py, &saved, json)
    }

    /// Unpickling (not API): the MPU built from scratch in the scene's frame, the particles
    /// as they were.
    #[classmethod]
    fn _from_state(
        cls: &Bound<'_, pyo3::types::PyType>,
        state: &[u8],
        json: &Bound<'_, PyAny>,
    ) -> PyResult<Self> {
        let py = cls.py();
        let s: SceneState = crate::pickle::decode(state, "Scene")?;
        let input_json = Arc::new(crate::pickle::json_of(json)?);
        let particles = s.particles;
        let (points, frame, field) = (s.points, s.frame, s.field);
        let (mpu_params, particle_params) = (s.mpu_params, s.particle_params);
        let scene = monitored(py, &Progress::Silent, move |_| {
            psi::regen::Scene::from_state(
                points,
                frame,
                &mpu_params,
                &particle_params,
                particles,
                field,
                s.attributes,
            )
        })?
        .map_err(|e| value_error(format!("unpickling a Scene: {e}")))?;
        Ok(Scene {
            state: Arc::new(Mutex::new(State {
                scene,
                edits: s.edits,
                mpu_report: Some(s.mpu_report),
            })),
            name: s.name,
            input_json,
            threshold: s.threshold,
            report: s.report,
        })
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let state = self.lock(py)?;
        Ok(format!(
            "Scene({:?}: {} points, {} particles)",
            self.name,
            state.scene.points().len(),
            state.scene.particles().len()
        ))
    }
}
