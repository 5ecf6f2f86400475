//! NumPy arrays in and out: inputs of any real dtype and any layout read without per-point
//! Python work (a float64 C-ordered array is borrowed, anything else converted once by NumPy),
//! outputs made from Rust vectors without a further copy where the layout allows.

use std::borrow::Cow;

use numpy::ndarray::{Array2, Array3};
use numpy::{
    AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayDescrMethods,
    PyArrayLikeDyn, PyUntypedArray, PyUntypedArrayMethods,
};
use psi::{DVec3, OrientedPoint};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;

use crate::errors::value_error;

/// `obj` as a float64 array: the array itself when it already is one, else NumPy's
/// conversion of it (integers, float16/32, lists, other layouts). Complex, boolean and object
/// arrays are refused.
fn float_array<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<PyArrayLikeDyn<'py, f64, AllowTypeChange>> {
    if let Ok(array) = obj.cast::<PyUntypedArray>() {
        let kind = array.dtype().kind();
        if !matches!(kind, b'f' | b'i' | b'u') {
            return Err(value_error(format!(
                "{name} must hold real numbers, not dtype {}",
                array.dtype()
            )));
        }
    }
    obj.extract()
        .map_err(|e: PyErr| value_error(format!("{name} is not an array of numbers: {e}")))
}

fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|s| s.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// The shape check of an (N, 3) array.
fn check_rows(shape: &[usize], name: &str) -> PyResult<usize> {
    if shape.len() != 2 || shape[1] != 3 {
        return Err(value_error(format!(
            "{name} must have shape (N, 3), got {}",
            shape_text(shape)
        )));
    }
    Ok(shape[0])
}

/// The rows of an (N, 3) array as vectors (one copy, in row order whatever the layout).
pub(crate) fn vectors(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<DVec3>> {
    let array = float_array(obj, name)?;
    let view = array.as_array();
    check_rows(view.shape(), name)?;
    if let Some(flat) = view.as_slice() {
        return Ok(flat
            .chunks_exact(3)
            .map(|c| DVec3::new(c[0], c[1], c[2]))
            .collect());
    }
    Ok(view
        .rows()
        .into_iter()
        .map(|r| DVec3::new(r[0], r[1], r[2]))
        .collect())
}

/// The number of rows of an (N, 3) array (checked as [`vectors`] checks it).
pub(crate) fn rows(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<usize> {
    check_rows(float_array(obj, name)?.as_array().shape(), name)
}

/// One finite point or vector of shape (3,).
pub(crate) fn vector3(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<DVec3> {
    let array = float_array(obj, name)?;
    let view = array.as_array();
    if view.shape() != [3] {
        return Err(value_error(format!(
            "{name} must have shape (3,), got {}",
            shape_text(view.shape())
        )));
    }
    Ok(DVec3::new(view[[0]], view[[1]], view[[2]]))
}

/// Query points of shape (3,) or (..., 3), kept alive while their coordinates are read.
pub(crate) struct Queries<'py> {
    array: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    /// The leading dimensions: empty for one point of shape (3,).
    pub(crate) shape: Vec<usize>,
}

impl<'py> Queries<'py> {
    /// Reads `obj` (any real dtype, any layout), refusing shapes whose last dimension is not 3.
    pub(crate) fn new(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Self> {
        let array = float_array(obj, name)?;
        let full = array.as_array().shape().to_vec();
        match full.split_last() {
            Some((3, leading)) => Ok(Queries {
                array,
                shape: leading.to_vec(),
            }),
            _ => Err(value_error(format!(
                "{name} must have shape (3,) or (..., 3), got {}",
                shape_text(&full)
            ))),
        }
    }

    /// Whether the input was one point of shape (3,).
    pub(crate) fn single(&self) -> bool {
        self.shape.is_empty()
    }

    /// Values per query (`per` of them each: 1 for f, 3 for ∇f, in query order) as an array
    /// of the queries' leading shape, plus a last dimension of `per` when `per > 1`; one
    /// query of shape (3,) gives a `numpy.float64` for `per == 1`.
    pub(crate) fn shaped(
        &self,
        py: Python<'py>,
        values: Vec<f64>,
        per: usize,
    ) -> PyResult<Bound<'py, PyAny>> {
        if self.single() && per == 1 {
            let f = values.first().copied().unwrap_or(f64::NAN);
            return py.import("numpy")?.getattr("float64")?.call1((f,));
        }
        let mut dims = self.shape.clone();
        if per > 1 {
            dims.push(per);
        }
        let array = numpy::ndarray::ArrayD::from_shape_vec(numpy::ndarray::IxDyn(&dims), values)
            .map_err(|e| value_error(format!("result shape: {e}")))?;
        Ok(array.into_pyarray(py).into_any())
    }

    /// The coordinates x0 y0 z0 x1 … in row order: borrowed from a float64 C-ordered array,
    /// else copied once; a `ValueError` naming the first point with a NaN or infinite
    /// coordinate.
    pub(crate) fn coordinates(&self, name: &str) -> PyResult<Cow<'_, [f64]>> {
        // `as_slice` also takes a Fortran-ordered array (in memory order): only C order is
        // row order.
        let in_rows = self.array.is_c_contiguous();
        let flat = match self.array.as_slice() {
            Ok(slice) if in_rows => Cow::Borrowed(slice),
            _ => Cow::Owned(self.array.as_array().iter().copied().collect()),
        };
        if let Some(i) = flat.iter().position(|v| !v.is_finite()) {
            return Err(value_error(format!(
                "{name}: point {} has a NaN or infinite coordinate",
                i / 3
            )));
        }
        Ok(flat)
    }
}

/// An (N, 3) float64 array of `v` (one copy).
pub(crate) fn vec3_array<'py>(py: Python<'py>, v: &[DVec3]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = v.iter().flat_map(|p| p.to_array()).collect();
    flat_rows(py, flat, 3)
}

/// The positions (`normals == false`) or the unit normals of `points` as an (N, 3) float64
/// array (one copy).
pub(crate) fn oriented_array<'py>(
    py: Python<'py>,
    points: &[OrientedPoint],
    normals: bool,
) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = points
        .iter()
        .flat_map(|p| if normals { p.n } else { p.p }.to_array())
        .collect();
    flat_rows(py, flat, 3)
}

/// An (N, `columns`) array of the row-major `flat` (no copy).
pub(crate) fn flat_rows<'py, T: numpy::Element>(
    py: Python<'py>,
    flat: Vec<T>,
    columns: usize,
) -> Bound<'py, PyArray2<T>> {
    let rows = flat.len() / columns;
    Array2::from_shape_vec((rows, columns), flat)
        .expect("the length is rows × columns")
        .into_pyarray(py)
}

/// A one-dimensional array of `v` (no copy).
pub(crate) fn vector<'py, T: numpy::Element>(
    py: Python<'py>,
    v: Vec<T>,
) -> Bound<'py, PyArray1<T>> {
    PyArray1::from_vec(py, v)
}

/// An (H, W, 4) uint8 array of straight (not premultiplied) RGBA pixels.
pub(crate) fn image_array<'py>(
    py: Python<'py>,
    height: usize,
    width: usize,
    rgba: Vec<u8>,
) -> Bound<'py, PyArray3<u8>> {
    Array3::from_shape_vec((height, width, 4), rgba)
        .expect("the length is height × width × 4")
        .into_pyarray(py)
}

/// An array handed out read-only, copied once: made on first access (the object then keeps
/// this copy for its lifetime), then the same object every time (`a.flags.writeable` is false, and NumPy refuses to turn it back on, as
/// its memory belongs to psi).
pub(crate) struct ReadOnly<A>(PyOnceLock<Py<A>>);

impl<A> Default for ReadOnly<A> {
    fn default() -> Self {
        ReadOnly(PyOnceLock::new())
    }
}

impl<A> ReadOnly<A> {
    /// The array, made by `make` on first access and marked read-only.
    pub(crate) fn get<'py>(
        &self,
        py: Python<'py>,
        make: impl FnOnce() -> Bound<'py, A>,
    ) -> PyResult<Bound<'py, A>> {
        let array = self.0.get_or_try_init(py, || -> PyResult<Py<A>> {
            let array = make();
            array
                .as_any()
                .getattr("flags")?
                .setattr("writeable", false)?;
            Ok(array.unbind())
        })?;
        Ok(array.bind(py).clone())
    }
}

/// A one-dimensional float64 column of `n` values, or a `ValueError`.
pub(crate) fn column(obj: &Bound<'_, PyAny>, name: &str, n: usize) -> PyResult<Vec<f64>> {
    let array: numpy::PyArrayLike1<'_, f64, numpy::AllowTypeChange> = obj
        .extract()
        .map_err(|e: PyErr| value_error(format!("{name} must be a 1-D array of numbers: {e}")))?;
    let v: Vec<f64> = array.as_array().iter().copied().collect();
    if v.len() != n {
        return Err(value_error(format!(
            "{name} must have shape ({n},), got ({},)",
            v.len()
        )));
    }
    if let Some(i) = v.iter().position(|x| !x.is_finite()) {
        return Err(value_error(format!("{name}: value {i} is NaN or infinite")));
    }
    Ok(v)
}
