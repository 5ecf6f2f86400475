//! Errors across the boundary: the facade's errors become `OSError` (files that cannot be
//! opened or written) or `ValueError` (bad input), with the CLI's message text; a Rust panic
//! becomes a `RuntimeError`, never a crash; heavy work runs with the interpreter released.

use std::panic::{AssertUnwindSafe, catch_unwind};

use pyo3::exceptions::{
    PyFileNotFoundError, PyIsADirectoryError, PyOSError, PyPermissionError, PyRuntimeError,
    PyValueError,
};
use pyo3::prelude::*;

/// A `ValueError` with `message`.
pub(crate) fn value_error(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

/// An `OSError` (the subclass for the error's kind: `FileNotFoundError`, `PermissionError`,
/// `IsADirectoryError`) whose text is `message` and whose `errno` is set when known (not its
/// `filename`, which would replace the text by `[Errno n] strerror: filename`).
pub(crate) fn os_error(py: Python<'_>, message: String, reason: &std::io::Error) -> PyErr {
    use std::io::ErrorKind;
    let err = match reason.kind() {
        ErrorKind::NotFound => PyFileNotFoundError::new_err(message),
        ErrorKind::PermissionDenied => PyPermissionError::new_err(message),
        ErrorKind::IsADirectory => PyIsADirectoryError::new_err(message),
        _ => PyOSError::new_err(message),
    };
    if let Some(code) = reason.raw_os_error() {
        // Best effort: the message is what matters, the number is an extra.
        let _ = err.value(py).setattr("errno", code);
    }
    err
}

/// The Python exception for a facade error, its text `context: error` (or the error alone),
/// as the CLI prints it after `psi: error: `.
pub(crate) fn psi_error(py: Python<'_>, error: psi::PsiError, context: Option<&str>) -> PyErr {
    let message = match context {
        Some(c) => format!("{c}: {error}"),
        None => error.to_string(),
    };
    match &error {
        // A path psi refuses before writing (a picture not named .png) is bad input.
        psi::PsiError::Write { reason, .. }
            if reason.kind() == std::io::ErrorKind::InvalidInput =>
        {
            value_error(message)
        }
        psi::PsiError::Open { reason, .. } | psi::PsiError::Write { reason, .. } => {
            os_error(py, message, reason)
        }
        psi::PsiError::Read { .. }
        | psi::PsiError::Render { .. }
        | psi::PsiError::OutOfCore { .. } => value_error(message),
    }
}

/// Runs `work` with the interpreter released (other Python threads run meanwhile) and turns a
/// panic inside it into a `RuntimeError` naming it as psi's bug.
pub(crate) fn detached<T: Send>(py: Python<'_>, work: impl FnOnce() -> T + Send) -> PyResult<T> {
    py.detach(|| catch_unwind(AssertUnwindSafe(work)))
        .map_err(panic_error)
}

/// The `RuntimeError` for a panic's payload, naming it as psi's bug.
pub(crate) fn panic_error(payload: Box<dyn std::any::Any + Send>) -> PyErr {
    let what = payload
        .downcast_ref::<&str>()
        .map(|s| (*s).to_owned())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".to_owned());
    PyRuntimeError::new_err(format!("psi: internal error (please report it): {what}"))
}

/// The whole number `value` as a `T` when it lies in `lo..=hi`, else a `ValueError` `name:
/// value is not in lo..=hi` (the CLI's bound check for the same option).
pub(crate) fn bounded<T>(name: &str, value: i128, lo: T, hi: T) -> PyResult<T>
where
    T: Copy + Into<i128> + TryFrom<i128> + std::fmt::Display,
{
    if value >= lo.into() && value <= hi.into() {
        T::try_from(value).map_err(|_| value_error(format!("{name}: {value} is out of range")))
    } else {
        Err(value_error(format!(
            "{name}: {value} is not in {lo}..={hi}"
        )))
    }
}
