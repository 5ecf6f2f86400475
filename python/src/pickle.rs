//! Pickling: an object's state as bytes (postcard, exact for every f64) plus its report as a
//! Python object, and back. Unpickling goes through a classmethod `_from_state` of each class,
//! which pickle names as `getattr(psi.Class, "_from_state")`.

use pyo3::IntoPyObjectExt;
use pyo3::prelude::*;
use pyo3::type_object::PyTypeInfo;
use pyo3::types::{PyBool, PyBytes, PyDict, PyFloat, PyInt, PyList, PyString};
use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::Value;

use crate::errors::value_error;

/// `state` as bytes.
pub(crate) fn encode<T: Serialize>(state: &T) -> PyResult<Vec<u8>> {
    postcard::to_stdvec(state).map_err(|e| value_error(format!("pickling: {e}")))
}

/// What `__reduce__` returns: `(T._from_state, (state as bytes, extra))`, `extra` the
/// object's report (a Python object pickle handles itself).
pub(crate) fn reduce<'py, T: PyTypeInfo>(
    py: Python<'py>,
    state: &impl Serialize,
    extra: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let restore = py.get_type::<T>().getattr("_from_state")?;
    let bytes = PyBytes::new(py, &encode(state)?);
    (restore, (bytes, extra)).into_bound_py_any(py)
}

/// The state `bytes` hold; a `ValueError` when they are not a state of this kind.
pub(crate) fn decode<T: DeserializeOwned>(bytes: &[u8], what: &str) -> PyResult<T> {
    postcard::from_bytes(bytes).map_err(|e| value_error(format!("unpickling a {what}: {e}")))
}

/// A report object (nested dicts, lists, numbers, strings, booleans, `None`) as a JSON value,
/// floats exactly; the inverse of [`crate::json::to_python`].
pub(crate) fn json_of(obj: &Bound<'_, PyAny>) -> PyResult<Value> {
    if obj.is_none() {
        return Ok(Value::Null);
    }
    if obj.is_instance_of::<PyBool>() {
        return Ok(Value::Bool(obj.extract()?));
    }
    if obj.is_instance_of::<PyInt>() {
        if let Ok(u) = obj.extract::<u64>() {
            return Ok(Value::from(u));
        }
        return Ok(Value::from(obj.extract::<i64>()?));
    }
    if obj.is_instance_of::<PyFloat>() {
        let f: f64 = obj.extract()?;
        return Ok(serde_json::Number::from_f64(f).map_or(Value::Null, Value::Number));
    }
    if obj.is_instance_of::<PyString>() {
        return Ok(Value::String(obj.extract()?));
    }
    if let Ok(list) = obj.cast::<PyList>() {
        return list.iter().map(|v| json_of(&v)).collect();
    }
    if let Ok(dict) = obj.cast::<PyDict>() {
        let mut map = serde_json::Map::new();
        for (k, v) in dict.iter() {
            map.insert(k.extract::<String>()?, json_of(&v)?);
        }
        return Ok(Value::Object(map));
    }
    Err(value_error(format!(
        "unpickling: a report holds an unexpected {}",
        obj.get_type().name()?
    )))
}
