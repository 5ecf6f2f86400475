//! Long calls from Python: run on a worker thread with the interpreter released, while the
//! calling thread wakes every few milliseconds to check for signals (Ctrl-C) and to hand the
//! work's progress to the caller's `progress` (a callable, or `True` for a bar on stderr).
//!
//! On a pending signal (or an exception from `progress`) the work's stop flag is set
//! ([`psi::octree::StopFlag`]): the layers stop at their next check and nothing is kept. The
//! call returns the exception at once. Work that changes state (a scene's edit) claims its
//! commit first; a stop that comes after the claim is too late: the call then waits for the
//! work, returns its result and raises the signal's exception again at the next line
//! (`_thread.interrupt_main`), as if the signal had come after the call.

use std::sync::mpsc::{RecvTimeoutError, channel};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use psi::octree::{Monitor, StopFlag};
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

/// How often the calling thread wakes to check for signals and deliver progress.
const TICK: Duration = Duration::from_millis(20);

/// One stage's latest progress: `(stage, done, total)`.
type Step = (String, u64, u64);

/// The progress reported so far, in stage order, each stage's `done` the largest seen.
#[derive(Default)]
struct Steps {
    steps: Vec<Step>,
    /// How many of `steps` were delivered, and the `done` last delivered for the newest.
    delivered: usize,
    delivered_done: Option<u64>,
}

impl Steps {
    fn record(&mut self, stage: &str, done: u64, total: u64) {
        match self.steps.last_mut() {
            Some(last) if last.0 == stage => {
                last.1 = last.1.max(done);
                last.2 = total;
            }
            _ => self.steps.push((stage.to_owned(), done, total)),
        }
    }

    /// The steps not yet delivered: every stage after the one delivered last, and that one
    /// again if its `done` grew. Each stage's `done` only grows.
    fn pending(&mut self) -> Vec<Step> {
        let mut out = Vec::new();
        if self.delivered > 0 {
            let last = &self.steps[self.delivered - 1];
            if self.delivered_done != Some(last.1) {
                out.push(last.clone());
            }
        }
        out.extend(self.steps[self.delivered..].iter().cloned());
        self.delivered = self.steps.len();
        self.delivered_done = self.steps.last().map(|s| s.1);
        out
    }
}

/// What the caller asked for with `progress=`.
pub(crate) enum Progress {
    /// Nothing shown.
    Silent,
    /// The caller's callable, called with `(stage, done, total)`.
    Call(Py<PyAny>),
    /// The bar of `progress=True`: called likewise, and closed once when the call that made
    /// it ends (this value is dropped), whatever the outcome.
    Bar(Py<PyAny>),
}

impl Drop for Progress {
    fn drop(&mut self) {
        if let Progress::Bar(bar) = self {
            Python::attach(|py| {
                if let Err(e) = bar.call_method0(py, "close") {
                    e.write_unraisable(py, Some(bar.bind(py)));
                }
            });
        }
    }
}

impl Progress {
    /// From the `progress` keyword: `None` or `False` (silent), `True` (a bar on stderr from
    /// `psi._progress.stderr_bar()`), or a callable.
    pub(crate) fn from_arg(py: Python<'_>, arg: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        let Some(arg) = arg else {
            return Ok(Progress::Silent);
        };
        if arg.is_none() {
            return Ok(Progress::Silent);
        }
        if let Ok(flag) = arg.extract::<bool>() {
            if !flag {
                return Ok(Progress::Silent);
            }
            let bar = py.import("psi._progress")?.call_method0("stderr_bar")?;
            return Ok(Progress::Bar(bar.unbind()));
        }
        if !arg.is_callable() {
            return Err(crate::errors::value_error(
                "progress must be True, False, None or a callable (stage, done, total)",
            ));
        }
        Ok(Progress::Call(arg.clone().unbind()))
    }

    fn deliver(&self, py: Python<'_>, steps: Vec<Step>) -> PyResult<()> {
        if let Progress::Call(f) | Progress::Bar(f) = self {
            for (stage, done, total) in steps {
                f.call1(py, (stage, done, total))?;
            }
        }
        Ok(())
    }
}

/// Runs `work` on its own thread with the interpreter released, reporting to `progress` and
/// stoppable by Ctrl-C (a pending signal raises its exception here, `KeyboardInterrupt` for
/// SIGINT, within about [`TICK`]). A panic in `work` becomes a `RuntimeError`.
pub(crate) fn monitored<T: Send + 'static>(
    py: Python<'_>,
    progress: &Progress,
    work: impl FnOnce(&Monitor<'_>) -> T + Send + 'static,
) -> PyResult<T> {
    let stop = Arc::new(StopFlag::new());
    let steps = Arc::new(Mutex::new(Steps::default()));
    let (send, receive) = channel();
    let (worker_stop, worker_steps) = (stop.clone(), steps.clone());
    let spawned = std::thread::Builder::new()
        .name("psi-work".to_owned())
        .spawn(move || {
            let observe = |stage: &str, done: u64, total: u64| {
                if let Ok(mut s) = worker_steps.lock() {
                    s.record(stage, done, total);
                }
            };
            let monitor = Monitor::new(Some(&observe), Some(&worker_stop));
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(&monitor)));
            // The caller may have gone (interrupted): then the result is dropped here.
            let _ = send.send(result);
        });
    if let Err(e) = spawned {
        return Err(PyRuntimeError::new_err(format!(
            "psi: could not start a worker thread: {e}"
        )));
    }
    let receive = Mutex::new(receive);
    let take = |steps: &Mutex<Steps>| steps.lock().map(|mut s| s.pending()).unwrap_or_default();
    loop {
        let received = py.detach(|| match receive.lock() {
            Ok(r) => r.recv_timeout(TICK),
            Err(_) => Err(RecvTimeoutError::Disconnected),
        });
        let delivered = progress.deliver(py, take(&steps));
        match received {
            Ok(result) => {
                break delivered.and_then(|()| result.map_err(crate::errors::panic_error));
            }
            Err(RecvTimeoutError::Disconnected) => {
                break Err(PyRuntimeError::new_err(
                    "psi: the worker thread ended early",
                ));
            }
            Err(RecvTimeoutError::Timeout) => {}
        }
        if let Err(e) = delivered.and_then(|()| py.check_signals()) {
            if stop.stop() {
                break Err(e);
            }
            // Too late: the work committed. Take its result and raise the signal again.
            let result = py.detach(|| match receive.lock() {
                Ok(r) => r.recv().map_err(|_| ()),
                Err(_) => Err(()),
            });
            let Ok(result) = result else {
                break Err(e);
            };
            if !e.is_instance_of::<pyo3::exceptions::PyKeyboardInterrupt>(py) {
                break Err(e);
            }
            py.import("_thread")?.call_method0("interrupt_main")?;
            break result.map_err(crate::errors::panic_error);
        }
    }
}
