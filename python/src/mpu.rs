//! `psi.Mpu`: the MPU implicit of prepared points, built with the CLI's parameters
//! (`MpuArgs::params`), evaluated in batches with the interpreter released, polygonized.

use std::sync::Arc;

use numpy::PyArray2;
use psi::preprocess::ErrorThreshold;
use psi::{DVec3, MpuParams, PolygonizeParams};
use pyo3::prelude::*;
use rayon::prelude::*;

use crate::arrays::{Queries, flat_rows, oriented_array, vec3_array, vector};
use crate::errors::{bounded, detached, value_error};
use crate::points::{Input, input_of};

/// The MPU options a user may change, the CLI's `--mpu-error`, `--max-depth`, `--smooth` and
/// `--scale-invariant`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MpuOptions {
    pub(crate) error: Option<f64>,
    pub(crate) max_depth: i128,
    pub(crate) smooth: bool,
    pub(crate) scale_invariant: bool,
}

impl MpuOptions {
    /// The MPU parameters for `input` and the error threshold they use (the user's, else the
    /// noise's, else the paper's), as the CLI chooses them.
    pub(crate) fn params(&self, input: &Input) -> PyResult<(MpuParams, ErrorThreshold)> {
        if let Some(e) = self.error
            && !(e.is_finite() && e > 0.0 && e <= 1.0)
        {
            return Err(value_error(format!("error: {e} is not in (0, 1]")));
        }
        let max_depth: u8 = bounded("max_depth", self.max_depth, 0, 16)?;
        let threshold = input.report.error_threshold(self.error);
        let params = MpuParams {
            error_rel: threshold.relative,
            max_depth,
            sharp: !self.smooth,
            fit_unit: if self.scale_invariant {
                None
            } else {
                MpuParams::paper().fit_unit
            },
            ..MpuParams::paper()
        };
        Ok((params, threshold))
    }
}

/// A triangle mesh for Python: vertices (V, 3) float64 and faces (F, 3) uint32.
type Mesh<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<u32>>);

/// A multi-level partition of unity implicit f (Ohtake et al. 2003): f > 0 outside, f < 0
/// inside, close to the signed distance (world units) near the surface.
///
/// `Mpu(points, normals=None, *, error=None, max_depth=12, smooth=False,
/// scale_invariant=False, preprocess=True)`: `points` is a `PointSet` (then `normals` must be
/// `None`), or an (N, 3) array of positions with `normals` (N, 3) or `None`, prepared as an XYZ
/// file of them (`preprocess=False`: used as given, normals required). `error` is ε0 relative
/// to the bounding-box diagonal D, in (0, 1] (default: the points' suggestion, `PointSet.error`,
/// at least the paper's 0.005); `max_depth` the octree's depth limit (0 to 16); `smooth`
/// disables sharp edge and corner fits; `scale_invariant` solves the fits in each cell's units.
/// The build releases the interpreter. Raises `ValueError` for too few or unusable points.
#[pyclass(frozen, module = "psi", name = "Mpu")]
pub(crate) struct Mpu {
    pub(crate) mpu: Arc<psi::Mpu>,
    /// The input's name and its report object (the points live in `mpu`).
    pub(crate) name: String,
    pub(crate) input_json: Arc<serde_json::Value>,
    pub(crate) threshold: ErrorThreshold,
}

/// f and ∇f at `xyz` (x0 y0 z0 x1 …) into `f` and `g` (gx0 gy0 gz0 …), in parallel chunks.
fn evaluate_into(mpu: &psi::Mpu, xyz: &[f64], f: &mut [f64], g: &mut [f64]) {
    const CHUNK: usize = 1024;
    f.par_chunks_mut(CHUNK)
        .zip(g.par_chunks_mut(3 * CHUNK))
        .zip(xyz.par_chunks(3 * CHUNK))
        .for_each(|((f, g), x)| {
            for ((f, g), x) in f
                .iter_mut()
                .zip(g.chunks_exact_mut(3))
                .zip(x.chunks_exact(3))
            {
                let (value, gradient) = mpu.value_and_gradient(DVec3::new(x[0], x[1], x[2]));
                *f = value;
                g.copy_from_slice(&gradient.to_array());
            }
        });
}

#[pymethods]
impl Mpu {
    #[new]
    #[pyo3(signature = (points, normals=None, *, error=None, max_depth=12, smooth=false,
        scale_invariant=false, preprocess=true))]
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
    ) -> PyResult<Self> {
        let options = MpuOptions {
            error,
            max_depth,
            smooth,
            scale_invariant,
        };
        let input = input_of(py, points, normals, preprocess)?;
        let (params, threshold) = options.params(&input)?;
        let mpu = detached(py, || psi::Mpu::build(&input.points, &params))?
            .map_err(|e| value_error(format!("{}: building the MPU implicit: {e}", input.name)))?;
        Ok(Mpu {
            mpu: Arc::new(mpu),
            name: input.name.clone(),
            input_json: Arc::new(input.json.clone()),
            threshold,
        })
    }

    /// f and ∇f at `x`: shape (3,) gives `(float, (3,) array)`, shape (M, 3) gives `(f (M,),
    /// ∇f (M, 3))`, float64; x in world units, any real dtype and layout (a float64 C-ordered
    /// array is read in place). ∇f is dimensionless (|∇f| ≈ 1 near the surface). Raises
    /// `ValueError` for another shape or a NaN or infinite coordinate.
    fn value_and_gradient<'py>(
        &self,
        py: Python<'py>,
        x: &Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let queries = Queries::new(x, "x")?;
        let xyz = queries.coordinates("x")?;
        let n = xyz.len() / 3;
        let mpu = &*self.mpu;
        let (f, g) = detached(py, || {
            let (mut f, mut g) = (vec![0.0; n], vec![0.0; 3 * n]);
            evaluate_into(mpu, &xyz, &mut f, &mut g);
            (f, g)
        })?;
        if queries.single {
            let value = f[0].into_pyobject(py)?.into_any();
            return Ok((value, vector(py, g).into_any()));
        }
        Ok((vector(py, f).into_any(), flat_rows(py, g, 3).into_any()))
    }

    /// f at `x` (shape (3,) gives a float, (M, 3) an (M,) float64 array); see
    /// `value_and_gradient`.
    fn value<'py>(&self, py: Python<'py>, x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let queries = Queries::new(x, "x")?;
        let xyz = queries.coordinates("x")?;
        let mpu = &*self.mpu;
        let f: Vec<f64> = detached(py, || {
            xyz.par_chunks(3)
                .map(|x| mpu.value(DVec3::new(x[0], x[1], x[2])))
                .collect()
        })?;
        if queries.single {
            return Ok(f[0].into_pyobject(py)?.into_any());
        }
        Ok(vector(py, f).into_any())
    }

    /// The zero set near the data as a triangle mesh (what `psi mesh` writes): `(vertices
    /// (V, 3) float64, world units; faces (F, 3) uint32, counter-clockwise seen from outside)`.
    /// `resolution`: grid cells across the root cube (2 to 2048).
    #[pyo3(signature = (resolution=256))]
    fn mesh<'py>(&self, py: Python<'py>, resolution: i128) -> PyResult<Mesh<'py>> {
        let resolution: u32 = bounded("resolution", resolution, 2, 2048)?;
        let mpu = &*self.mpu;
        let soup = detached(py, || {
            psi::polygonize(
                mpu,
                &PolygonizeParams {
                    resolution,
                    ..PolygonizeParams::standard()
                },
            )
        })?;
        let faces: Vec<u32> = soup.faces.iter().flatten().copied().collect();
        Ok((vec3_array(py, &soup.vertices), flat_rows(py, faces, 3)))
    }

    /// Number of octree leaves (each holds a local fit).
    #[getter]
    fn leaves(&self) -> usize {
        self.mpu.report().leaves
    }

    /// Leaves whose cube holds an input point (particles are seeded from these).
    #[getter]
    fn surface_leaves(&self) -> usize {
        self.mpu.report().surface_leaves
    }

    /// Depth of the deepest leaf (root = 0).
    #[getter]
    fn max_depth(&self) -> u8 {
        self.mpu.report().max_depth
    }

    /// The input's bounding box, shape (2, 3): minimum and maximum corners, world units.
    #[getter]
    fn bbox<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let b = self.mpu.bounds();
        vec3_array(py, &[b.min, b.max])
    }

    /// The length scale D: the bounding-box diagonal, world units.
    #[getter]
    fn diagonal(&self) -> f64 {
        self.mpu.diagonal()
    }

    /// The error threshold ε0/D used.
    #[getter]
    fn error(&self) -> f64 {
        self.threshold.relative
    }

    /// Where ε0 came from: `"user"`, `"noise"` or `"paper"`.
    #[getter]
    fn error_source<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::json::report(py, &self.threshold.source)
    }

    /// Every build parameter (`MpuParams`), as a dict.
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::json::report(py, self.mpu.params())
    }

    /// The build's diagnostics (`BuildReport`: cells, leaves per depth, fit kinds, seconds),
    /// as a dict.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::json::report(py, self.mpu.report())
    }

    /// The points the MPU was built from, shape (N, 3), float64 (a new array each access).
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        oriented_array(py, self.mpu.points(), false)
    }

    /// Their unit normals, shape (N, 3), float64 (a new array each access).
    #[getter]
    fn normals<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        oriented_array(py, self.mpu.points(), true)
    }

    fn __repr__(&self) -> String {
        let r = self.mpu.report();
        format!(
            "Mpu({:?}: {} points, {} leaves, depth {})",
            self.name, r.points, r.leaves, r.max_depth
        )
    }
}

/// Benchmark helper (not API): seconds of a plain Rust loop computing f and ∇f at the rows of
/// `x` (M, 3) — `parallel`: a rayon map over the points collected into a `Vec` (what a Rust
/// caller would write), else one thread — after copying them out of the array, so that the
/// Python call's cost can be compared with the Rust work alone.
#[pyfunction]
#[pyo3(signature = (mpu, x, parallel=true))]
pub(crate) fn _rust_loop_seconds(
    py: Python<'_>,
    mpu: &Mpu,
    x: &Bound<'_, PyAny>,
    parallel: bool,
) -> PyResult<f64> {
    let points = crate::arrays::vectors(x, "x")?;
    let mpu = &*mpu.mpu;
    detached(py, || {
        let t = std::time::Instant::now();
        let out: Vec<(f64, DVec3)> = if parallel {
            points
                .par_iter()
                .map(|&x| mpu.value_and_gradient(x))
                .collect()
        } else {
            points.iter().map(|&x| mpu.value_and_gradient(x)).collect()
        };
        let seconds = t.elapsed().as_secs_f64();
        std::hint::black_box(out);
        seconds
    })
}
