//! # psi for Python
//!
//! The extension module `psi._psi` behind `import psi`: the facade's pipeline — read and
//! prepare points, build the MPU implicit, sample particles, edit locally, render — with NumPy
//! arrays in and out. Wiring only: every algorithm is the facade's (`psi`), and every result
//! equals the CLI's for the same input and options. Heavy work runs with the interpreter
//! released; bad input raises `ValueError` or `OSError` with the CLI's message; a panic
//! becomes a `RuntimeError`.

use pyo3::prelude::*;

mod arrays;
mod attributes;
mod errors;
mod json;
mod monitor;
mod mpu;
mod mpu_tasks;
mod out_of_core;
mod pickle;
mod points;
mod render;
mod sample;
mod scene;
mod stray_tasks;

/// Point-set implicits: an MPU surface from oriented points, and adaptive particles on it.
#[pymodule]
#[pyo3(name = "_psi")]
fn psi_python(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<points::PointSet>()?;
    m.add_class::<mpu::Mpu>()?;
    m.add_class::<sample::Particles>()?;
    m.add_class::<scene::Scene>()?;
    m.add_function(wrap_pyfunction!(points::load_points, m)?)?;
    m.add_function(wrap_pyfunction!(points::builtin_model, m)?)?;
    m.add_function(wrap_pyfunction!(sample::sample, m)?)?;
    m.add_function(wrap_pyfunction!(sample::save_particles, m)?)?;
    m.add_function(wrap_pyfunction!(sample::load_particles, m)?)?;
    m.add_function(wrap_pyfunction!(out_of_core::sample_files, m)?)?;
    m.add_function(wrap_pyfunction!(out_of_core::_ooc_preprocess, m)?)?;
    m.add_function(wrap_pyfunction!(out_of_core::_ooc_preprocessing, m)?)?;
    m.add_function(wrap_pyfunction!(stray_tasks::_ooc_stray_standings, m)?)?;
    m.add_function(wrap_pyfunction!(stray_tasks::_ooc_stray_stats, m)?)?;
    m.add_function(wrap_pyfunction!(stray_tasks::_ooc_stray_verdicts, m)?)?;
    m.add_function(wrap_pyfunction!(stray_tasks::_ooc_stray_join, m)?)?;
    m.add_function(wrap_pyfunction!(out_of_core::_ooc_partition_start, m)?)?;
    m.add_function(wrap_pyfunction!(out_of_core::_ooc_partition_part, m)?)?;
    m.add_function(wrap_pyfunction!(out_of_core::_ooc_partition_assemble, m)?)?;
    m.add_function(wrap_pyfunction!(out_of_core::_ooc_checks, m)?)?;
    m.add_function(wrap_pyfunction!(mpu_tasks::_ooc_top_upper, m)?)?;
    m.add_function(wrap_pyfunction!(mpu_tasks::_ooc_top_group, m)?)?;
    m.add_function(wrap_pyfunction!(mpu_tasks::_ooc_top, m)?)?;
    m.add_function(wrap_pyfunction!(mpu_tasks::_ooc_tiles, m)?)?;
    m.add_function(wrap_pyfunction!(mpu_tasks::_ooc_seed, m)?)?;
    m.add_function(wrap_pyfunction!(out_of_core::_ooc_sample, m)?)?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(render::render_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(mpu::_rust_loop_seconds, m)?)?;
    m.add_function(wrap_pyfunction!(_panic_for_tests, m)?)?;
    Ok(())
}

/// Test hook (not API): panics inside the guard every call into Rust goes through, so the tests
/// can check that a panic becomes a `RuntimeError` and the interpreter carries on.
#[pyfunction]
fn _panic_for_tests(py: Python<'_>) -> PyResult<()> {
    errors::detached(py, || panic!("a deliberate panic"))
}
