//! Point attributes across the boundary: `colors` (N, 3) uint8, `intensity` (N,) float32 and
//! `classification` (N,) uint8 arrays in and out, as `psi::octree::PointAttributes`.

use numpy::{PyArray1, PyArray2};
use psi::octree::PointAttributes;
use pyo3::prelude::*;

use crate::arrays::{ReadOnly, flat_rows, vector};
use crate::errors::value_error;

/// The `colors`, `intensity` and `classification` keywords as attributes for `n` points: each
/// `None` or an array of that many rows (colours whole numbers 0–255 of any integer dtype or
/// floats, intensities finite numbers, classes whole numbers 0–255).
pub(crate) fn attributes_of(
    colors: Option<&Bound<'_, PyAny>>,
    intensity: Option<&Bound<'_, PyAny>>,
    classification: Option<&Bound<'_, PyAny>>,
    n: usize,
) -> PyResult<PointAttributes> {
    let whole = |v: f64, name: &str, i: usize| -> PyResult<u8> {
        if v.fract() == 0.0 && (0.0..=255.0).contains(&v) {
            Ok(v as u8)
        } else {
            Err(value_error(format!(
                "{name}: row {i} holds {v}, not a whole number in 0..=255"
            )))
        }
    };
    let colors = colors
        .map(|c| -> PyResult<Vec<[u8; 3]>> {
            let rows = crate::arrays::vectors(c, "colors")?;
            if rows.len() != n {
                return Err(value_error(format!(
                    "colors must have shape ({n}, 3), got ({}, 3)",
                    rows.len()
                )));
            }
            rows.iter()
                .enumerate()
                .map(|(i, r)| {
                    Ok([
                        whole(r.x, "colors", i)?,
                        whole(r.y, "colors", i)?,
                        whole(r.z, "colors", i)?,
                    ])
                })
                .collect()
        })
        .transpose()?;
    let column = |obj: &Bound<'_, PyAny>, name: &str| -> PyResult<Vec<f64>> {
        let v = crate::arrays::column(obj, name, n)?;
        Ok(v)
    };
    let intensity = intensity
        .map(|v| column(v, "intensity").map(|v| v.into_iter().map(|x| x as f32).collect()))
        .transpose()?;
    let classification = classification
        .map(|v| {
            column(v, "classification")?
                .into_iter()
                .enumerate()
                .map(|(i, x)| whole(x, "classification", i))
                .collect::<PyResult<Vec<u8>>>()
        })
        .transpose()?;
    Ok(PointAttributes {
        colors,
        intensity,
        classification,
    })
}

/// Read-only arrays of attributes, made on first access.
#[derive(Default)]
pub(crate) struct AttributeArrays {
    colors: ReadOnly<PyArray2<u8>>,
    intensity: ReadOnly<PyArray1<f32>>,
    classification: ReadOnly<PyArray1<u8>>,
}

impl AttributeArrays {
    /// `attributes.colors` as an (N, 3) uint8 array, or `None`.
    pub(crate) fn colors<'py>(
        &self,
        py: Python<'py>,
        attributes: &PointAttributes,
    ) -> PyResult<Option<Bound<'py, PyArray2<u8>>>> {
        let Some(c) = &attributes.colors else {
            return Ok(None);
        };
        let flat: Vec<u8> = c.iter().flatten().copied().collect();
        self.colors.get(py, || flat_rows(py, flat, 3)).map(Some)
    }

    /// `attributes.intensity` as an (N,) float32 array, or `None`.
    pub(crate) fn intensity<'py>(
        &self,
        py: Python<'py>,
        attributes: &PointAttributes,
    ) -> PyResult<Option<Bound<'py, PyArray1<f32>>>> {
        let Some(v) = &attributes.intensity else {
            return Ok(None);
        };
        self.intensity.get(py, || vector(py, v.clone())).map(Some)
    }

    /// `attributes.classification` as an (N,) uint8 array, or `None`.
    pub(crate) fn classification<'py>(
        &self,
        py: Python<'py>,
        attributes: &PointAttributes,
    ) -> PyResult<Option<Bound<'py, PyArray1<u8>>>> {
        let Some(v) = &attributes.classification else {
            return Ok(None);
        };
        self.classification
            .get(py, || vector(py, v.clone()))
            .map(Some)
    }
}
