//! `psi.Mpu`: the MPU implicit of prepared points, built with the CLI's parameters
//! (`MpuArgs::params`), evaluated in batches with the interpreter released, polygonized.

use std::sync::Arc;

use numpy::PyArray2;
use psi::mpu::{BuildOptions, MpuFrame};
use psi::octree::PointAttributes;
use psi::preprocess::ErrorThreshold;
use psi::{BuildReport, DVec3, MpuParams, PolygonizeParams};
use pyo3::prelude::*;
use rayon::prelude::*;

use crate::arrays::{Queries, ReadOnly, flat_rows, oriented_array, vec3_array, vector3};
use crate::errors::{bounded, detached, value_error};
use crate::monitor::{Progress, monitored};
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
            error_rank: input.error_rank(threshold.relative),
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
/// `frame`: another MPU's `frame` to build in (default: the points' own). `progress`: `True`
/// for a bar on stderr, or a callable `(stage, done, total)`. The build runs with the
/// interpreter released; Ctrl-C stops it. Picklable (unpickling builds it again from its
/// points, bitwise the same). Raises `ValueError` for too few or unusable points.
#[pyclass(frozen, module = "psi", name = "Mpu")]
pub(crate) struct Mpu {
    pub(crate) mpu: Arc<psi::Mpu>,
    /// The input's name and its report object.
    pub(crate) name: String,
    pub(crate) input_json: Arc<serde_json::Value>,
    pub(crate) threshold: ErrorThreshold,
    /// The points as given to the build (a pickle rebuilds from them: the MPU's own have
    /// normals made unit); `None` for a scene's MPU, built from its own points.
    pub(crate) given: Option<Given>,
    /// The report of the build this MPU repeats (an unpickled MPU reports its original's).
    build_report: Option<BuildReport>,
    /// The attributes of its points (aligned with `mpu.points()`; empty without any), which
    /// particles sampled on it take.
    pub(crate) attributes: Arc<PointAttributes>,
    points: ReadOnly<PyArray2<f64>>,
    normals: ReadOnly<PyArray2<f64>>,
}

impl Mpu {
    /// The report of the build (of the original build, for an unpickled MPU).
    fn build_report(&self) -> &BuildReport {
        self.build_report.as_ref().unwrap_or(self.mpu.report())
    }

    /// This MPU with its points' `attributes`.
    pub(crate) fn carrying(mut self, attributes: PointAttributes) -> Self {
        self.attributes = Arc::new(attributes);
        self
    }

    /// This MPU reporting `report` (an unpickled one's original build) instead of its own.
    pub(crate) fn reporting(mut self, report: Option<BuildReport>) -> Self {
        self.build_report = report;
        self
    }

    /// A Python `Mpu` of a built MPU.
    pub(crate) fn of(
        mpu: Arc<psi::Mpu>,
        name: String,
        input_json: Arc<serde_json::Value>,
        threshold: ErrorThreshold,
        given: Option<Given>,
    ) -> Self {
        Mpu {
            mpu,
            name,
            input_json,
            threshold,
            given,
            build_report: None,
            attributes: Arc::default(),
            points: ReadOnly::default(),
            normals: ReadOnly::default(),
        }
    }
}

/// Points an MPU was built from, shared: a prepared input's, or an unpickled MPU's.
#[derive(Clone)]
pub(crate) enum Given {
    Input(Arc<Input>),
    /// An unpickled MPU's points; `true`: an MPU's own points, whose normals are unit.
    Points(Arc<Vec<psi::OrientedPoint>>, bool),
}

impl Given {
    /// Whether the normals are an MPU's own ([`BuildOptions::unit_normals`]).
    fn unit_normals(&self) -> bool {
        matches!(self, Given::Points(_, true))
    }
}

impl AsRef<[psi::OrientedPoint]> for Given {
    fn as_ref(&self) -> &[psi::OrientedPoint] {
        match self {
            Given::Input(i) => &i.points,
            Given::Points(p, _) => p,
        }
    }
}

/// What a pickled `Mpu` holds besides its input's report: enough to build it again, bitwise.
#[derive(serde::Serialize, serde::Deserialize)]
struct MpuState {
    name: String,
    points: Vec<psi::OrientedPoint>,
    unit_normals: bool,
    report: BuildReport,
    attributes: PointAttributes,
    params: MpuParams,
    frame: MpuFrame,
    threshold: ErrorThreshold,
}

/// Builds the MPU of `points` in `frame` (or its own) on a worker thread ([`monitored`]).
fn build(
    py: Python<'_>,
    name: &str,
    points: Given,
    params: MpuParams,
    frame: Option<MpuFrame>,
    progress: &Progress,
) -> PyResult<psi::Mpu> {
    monitored(py, progress, move |monitor| {
        let options = BuildOptions {
            frame,
            unit_normals: points.unit_normals(),
            monitor: *monitor,
            ..Default::default()
        };
        psi::Mpu::build_with(points.as_ref(), &params, options)
    })?
    .map_err(|e| value_error(format!("{name}: building the MPU implicit: {e}")))
}

/// A frame from its dict (`Mpu.frame`).
fn frame_of(obj: &Bound<'_, PyAny>) -> PyResult<MpuFrame> {
    let field = |k: &str| {
        obj.get_item(k)
            .map_err(|_| value_error(format!("frame: no {k:?}; pass another Mpu's .frame")))
    };
    let frame = MpuFrame {
        origin: vector3(&field("origin")?, "frame origin")?,
        root_center: vector3(&field("root_center")?, "frame root_center")?,
        root_half: field("root_half")?.extract()?,
        diagonal: field("diagonal")?.extract()?,
    };
    let finite = frame.origin.is_finite() && frame.root_center.is_finite();
    if !(finite && frame.root_half > 0.0 && frame.diagonal > 0.0) {
        return Err(value_error(
            "frame: positions must be finite and sizes positive",
        ));
    }
    Ok(frame)
}

/// f at `xyz` (x0 y0 z0 x1 …) into `f` and, when `g` is not empty, ∇f into `g` (gx0 gy0
/// gz0 …), in parallel chunks; a chunk is skipped once `stopped()` (the caller discards all).
fn evaluate_into(
    mpu: &psi::Mpu,
    xyz: &[f64],
    f: &mut [f64],
    g: &mut [f64],
    stopped: &(dyn Fn() -> bool + Sync),
) {
    const CHUNK: usize = 1024;
    let with_gradient = !g.is_empty();
    let g_chunks: Vec<&mut [f64]> = if with_gradient {
        g.chunks_mut(3 * CHUNK).collect()
    } else {
        f.chunks(CHUNK).map(|_| -> &mut [f64] { &mut [] }).collect()
    };
    f.par_chunks_mut(CHUNK)
        .zip(g_chunks)
        .zip(xyz.par_chunks(3 * CHUNK))
        .for_each(|((f, g), x)| {
            if stopped() {
                return;
            }
            for (i, (f, x)) in f.iter_mut().zip(x.chunks_exact(3)).enumerate() {
                let x = DVec3::new(x[0], x[1], x[2]);
                if with_gradient {
                    let (value, gradient) = mpu.value_and_gradient(x);
                    *f = value;
                    g[3 * i..3 * i + 3].copy_from_slice(&gradient.to_array());
                } else {
                    *f = mpu.value(x);
                }
            }
        });
}

/// Queries at least this many run as a monitored call (Ctrl-C stops them; their coordinates
/// are copied once for the worker thread); fewer run in place, without a thread's start-up.
const MONITORED_QUERIES: usize = 1 << 16;

/// f, and ∇f when `gradient` (else an empty vector), at the row-major coordinates `xyz`.
fn evaluate(
    py: Python<'_>,
    mpu: &Arc<psi::Mpu>,
    xyz: std::borrow::Cow<'_, [f64]>,
    gradient: bool,
) -> PyResult<(Vec<f64>, Vec<f64>)> {
    let n = xyz.len() / 3;
    let run = move |mpu: &psi::Mpu, xyz: &[f64], stopped: &(dyn Fn() -> bool + Sync)| {
        let mut f = vec![0.0; n];
        let mut g = vec![0.0; if gradient { 3 * n } else { 0 }];
        evaluate_into(mpu, xyz, &mut f, &mut g, stopped);
        (f, g)
    };
    if n < MONITORED_QUERIES {
        return detached(py, || run(mpu, &xyz, &|| false));
    }
    let (mpu, xyz) = (mpu.clone(), xyz.into_owned());
    monitored(py, &Progress::Silent, move |m| {
        run(&mpu, &xyz, &|| m.stopped())
    })
}

#[pymethods]
impl Mpu {
    #[new]
    #[pyo3(signature = (points, normals=None, *, error=None, max_depth=12, smooth=false,
        scale_invariant=false, preprocess=true, frame=None, progress=None))]
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
        frame: Option<&Bound<'_, PyAny>>,
        progress: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let options = MpuOptions {
            error,
            max_depth,
            smooth,
            scale_invariant,
        };
        let frame = frame.map(frame_of).transpose()?;
        let progress = Progress::from_arg(py, progress)?;
        let input = input_of(py, points, normals, preprocess, &progress)?;
        let (params, threshold) = options.params(&input)?;
        let given = Given::Input(input.clone());
        let mpu = build(py, &input.name, given.clone(), params, frame, &progress)?;
        Ok(Mpu::of(
            Arc::new(mpu),
            input.name.clone(),
            Arc::new(input.json.clone()),
            threshold,
            Some(given),
        )
        .carrying(input.attributes.clone()))
    }

    /// The frame the MPU lives in, a dict: `origin` (3,) the world position of its local
    /// coordinates, `root_center` (3,) and `root_half` the root cube (local frame, world
    /// units), `diagonal` the length scale D. `Mpu(..., frame=other.frame)` builds in it (a
    /// scene's MPU and a build from scratch of its points then agree).
    #[getter]
    fn frame<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let f = self.mpu.frame();
        let dict = pyo3::types::PyDict::new(py);
        let triple = |v: DVec3| (v.x, v.y, v.z);
        dict.set_item("origin", triple(f.origin))?;
        dict.set_item("root_center", triple(f.root_center))?;
        dict.set_item("root_half", f.root_half)?;
        dict.set_item("diagonal", f.diagonal)?;
        Ok(dict.into_any())
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (points, unit_normals) = match &self.given {
            Some(given) => (given.as_ref().to_vec(), given.unit_normals()),
            None => (self.mpu.points().to_vec(), true),
        };
        let state = MpuState {
            name: self.name.clone(),
            points,
            unit_normals,
            report: self.build_report().clone(),
            attributes: (*self.attributes).clone(),
            params: *self.mpu.params(),
            frame: *self.mpu.frame(),
            threshold: self.threshold,
        };
        let json = crate::json::to_python(py, &self.input_json)?;
        crate::pickle::reduce::<Mpu>(py, &state, json)
    }

    /// Unpickling (not API): builds the MPU again from its points, in its frame.
    #[classmethod]
    fn _from_state(
        cls: &Bound<'_, pyo3::types::PyType>,
        state: &[u8],
        json: &Bound<'_, PyAny>,
    ) -> PyResult<Self> {
        let py = cls.py();
        let s: MpuState = crate::pickle::decode(state, "Mpu")?;
        let input_json = crate::pickle::json_of(json)?;
        let given = Given::Points(Arc::new(s.points), s.unit_normals);
        let mpu = build(
            py,
            &s.name,
            given.clone(),
            s.params,
            Some(s.frame),
            &Progress::Silent,
        )?;
        let out = Mpu::of(
            Arc::new(mpu),
            s.name,
            Arc::new(input_json),
            s.threshold,
            Some(given),
        );
        Ok(out.reporting(Some(s.report)).carrying(s.attributes))
    }

    /// f and ∇f at `x`: shape (3,) gives `(float, (3,) array)` (the float a `numpy.float64`),
    /// shape (..., 3) gives `(f (...), ∇f (..., 3))`, float64; x in world units, any real
    /// dtype and layout (a float64 C-ordered array of fewer than 65 536 points is read in
    /// place; more are copied once and run on a worker thread that Ctrl-C stops). ∇f is
    /// dimensionless (|∇f| ≈ 1 near the surface). Raises `ValueError` for another shape or a
    /// NaN or infinite coordinate.
    fn value_and_gradient<'py>(
        &self,
        py: Python<'py>,
        x: &Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let queries = Queries::new(x, "x")?;
        let (f, g) = evaluate(py, &self.mpu, queries.coordinates("x")?, true)?;
        Ok((queries.shaped(py, f, 1)?, queries.shaped(py, g, 3)?))
    }

    /// f at `x` (shape (3,) gives a float, a `numpy.float64`; (..., 3) a float64 array of shape
    /// (...)); see `value_and_gradient`.
    fn value<'py>(&self, py: Python<'py>, x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let queries = Queries::new(x, "x")?;
        let (f, _) = evaluate(py, &self.mpu, queries.coordinates("x")?, false)?;
        queries.shaped(py, f, 1)
    }

    /// The zero set near the data as a triangle mesh (what `psi mesh` writes): `(vertices
    /// (V, 3) float64, world units; faces (F, 3) uint32, counter-clockwise seen from outside)`.
    /// `resolution`: grid cells across the root cube (2 to 2048).
    /// `progress` as for `Mpu(...)`; Ctrl-C stops it.
    #[pyo3(signature = (resolution=256, *, progress=None))]
    fn mesh<'py>(
        &self,
        py: Python<'py>,
        resolution: i128,
        progress: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Mesh<'py>> {
        let resolution: u32 = bounded("resolution", resolution, 2, 2048)?;
        let progress = Progress::from_arg(py, progress)?;
        let mpu = self.mpu.clone();
        let params = PolygonizeParams {
            resolution,
            ..PolygonizeParams::standard()
        };
        let soup = monitored(py, &progress, move |monitor| {
            psi::mpu::polygonize_with(&mpu, &params, monitor)
        })?
        .map_err(|_| value_error("interrupted"))?;
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
        crate::json::report(py, self.build_report())
    }

    /// The points the MPU was built from, shape (N, 3), float64: read-only, made on first
    /// access and the same array afterwards.
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        self.points
            .get(py, || oriented_array(py, self.mpu.points(), false))
    }

    /// Their unit normals, shape (N, 3), float64: read-only, as `points`.
    #[getter]
    fn normals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        self.normals
            .get(py, || oriented_array(py, self.mpu.points(), true))
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
