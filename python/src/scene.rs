//! `psi.Scene`: points, their MPU and their particles kept consistent under shape edits by
//! local regeneration (`psi::regen::Scene`), as `psi edit` does.

use std::sync::Arc;

use numpy::PyArray2;
use psi::regen::{Edit, RegenError};
use pyo3::prelude::*;

use crate::arrays::{oriented_array, vector3};
use crate::errors::{detached, value_error};
use crate::mpu::MpuOptions;
use crate::points::input_of;
use crate::sample::{Particles, particle_params};

/// Points, their MPU and their particles, updated locally by edits (paper §6): only the cells
/// an edit can reach are refitted and only their particles regenerated; the particles elsewhere
/// stay bitwise unchanged, and the result equals a build from scratch.
///
/// `Scene(points, normals=None, *, error=None, max_depth=12, smooth=False,
/// scale_invariant=False, preprocess=True, iterations=20, k=1, count=None, uniform=False,
/// seed=2007)`: the input and MPU options of `psi.Mpu`, the sampling options of `psi.sample`
/// (`psi edit` uses their defaults but for `iterations`). Building and every edit release the
/// interpreter. Each edit returns its report as a dict (`RegenReport`: marked and refitted
/// cells, particles removed and regenerated, points, whether the edit left the root cube and
/// forced a full rebuild, seconds); a refused edit raises `ValueError` and leaves the scene
/// unchanged.
#[pyclass(module = "psi", name = "Scene")]
pub(crate) struct Scene {
    scene: psi::regen::Scene,
    /// The input's name.
    name: String,
    report: psi::SampleReport,
}

fn edit_error(e: RegenError) -> PyErr {
    value_error(format!("applying an edit: {e}"))
}

impl Scene {
    fn apply<'py>(&mut self, py: Python<'py>, edit: Edit) -> PyResult<Bound<'py, PyAny>> {
        let scene = &mut self.scene;
        let report = detached(py, || scene.apply(&edit))?.map_err(edit_error)?;
        crate::json::report(py, &report)
    }
}

#[pymethods]
impl Scene {
    #[new]
    #[pyo3(signature = (points, normals=None, *, error=None, max_depth=12, smooth=false,
        scale_invariant=false, preprocess=true, iterations=20, k=1, count=None, uniform=false,
        seed=2007))]
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
        k: i128,
        count: Option<i128>,
        uniform: bool,
        seed: i128,
    ) -> PyResult<Self> {
        let options = MpuOptions {
            error,
            max_depth,
            smooth,
            scale_invariant,
        };
        let params = particle_params(iterations, k, count, uniform, seed)?;
        let input = input_of(py, points, normals, preprocess)?;
        let (mpu_params, _) = options.params(&input)?;
        // The points move into the scene unless a `PointSet` still holds them.
        let (name, points) = match Arc::try_unwrap(input) {
            Ok(input) => (input.name, input.points),
            Err(shared) => (shared.name.clone(), shared.points.clone()),
        };
        let (scene, report) =
            detached(py, || psi::regen::Scene::new(points, &mpu_params, &params))?
                .map_err(|e| value_error(format!("{name}: building the scene: {e}")))?;
        Ok(Scene {
            scene,
            name,
            report,
        })
    }

    /// Moves the points within `radius` of `centre` (3,) by `displacement` (3,) × (1 − t²)²,
    /// t = distance / radius (world units; the normals follow the deformation); returns the
    /// edit's report.
    fn brush<'py>(
        &mut self,
        py: Python<'py>,
        centre: &Bound<'py, PyAny>,
        radius: f64,
        displacement: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let edit = Edit::Brush {
            center: vector3(centre, "centre")?,
            radius,
            displacement: vector3(displacement, "displacement")?,
        };
        self.apply(py, edit)
    }

    /// Removes the points within `radius` of `centre` (3,); returns the edit's report.
    fn remove<'py>(
        &mut self,
        py: Python<'py>,
        centre: &Bound<'py, PyAny>,
        radius: f64,
    ) -> PyResult<Bound<'py, PyAny>> {
        let edit = Edit::Remove {
            center: vector3(centre, "centre")?,
            radius,
        };
        self.apply(py, edit)
    }

    /// Adds oriented points: `points` and `normals` (N, 3), normals normalised here (rows with
    /// a zero normal dropped); returns the edit's report.
    fn insert<'py>(
        &mut self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        normals: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let points = crate::points::columns(points, Some(normals))?.points;
        self.apply(py, Edit::Insert { points })
    }

    /// The current particles (a copy; `report` is `None`).
    #[getter]
    fn particles(&self) -> Particles {
        Particles::bare(self.scene.particles().clone())
    }

    /// The current control points, shape (N, 3), float64, world units.
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        oriented_array(py, self.scene.points(), false)
    }

    /// Their unit normals, shape (N, 3), float64.
    #[getter]
    fn normals<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        oriented_array(py, self.scene.points(), true)
    }

    /// The first sampling's report (`SampleReport`: count, seconds, density, spacing quality
    /// before and after relaxation), as a dict.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::json::report(py, &self.report)
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene({:?}: {} points, {} particles)",
            self.name,
            self.scene.points().len(),
            self.scene.particles().len()
        )
    }
}
