//! Progress and interruption of long work: what a caller (a progress bar, the Python package's
//! Ctrl-C handling) hands to the layers' long-running functions.

use std::sync::atomic::{AtomicU8, Ordering};

use thiserror::Error;

/// What observes a [`Monitor`]: called with `(stage, done, total)` from any thread.
pub type Observer<'a> = dyn Fn(&str, u64, u64) + Sync + 'a;

/// How a caller asks long work to stop, and how work that changes state claims its commit:
/// whichever comes first wins, so a caller that gave up is never surprised by a change it
/// asked to stop, and a commit, once claimed, is never stopped half-way.
///
/// ```
/// use psi_octree::{Monitor, StopFlag};
/// let flag = StopFlag::new();
/// let monitor = Monitor::new(None, Some(&flag));
/// assert!(monitor.claim_commit().is_ok());
/// assert!(!flag.stop(), "too late: the work committed first");
/// let flag = StopFlag::new();
/// assert!(flag.stop());
/// assert!(Monitor::new(None, Some(&flag)).claim_commit().is_err());
/// ```
#[derive(Debug, Default)]
pub struct StopFlag(AtomicU8);

const RUNNING: u8 = 0;
const STOPPED: u8 = 1;
const COMMITTED: u8 = 2;

impl StopFlag {
    /// A flag that has not been set.
    pub const fn new() -> Self {
        StopFlag(AtomicU8::new(RUNNING))
    }

    /// Asks the work to stop. Returns false when the work had already claimed its commit
    /// ([`Monitor::claim_commit`]): then it completes, and the caller should take its result.
    pub fn stop(&self) -> bool {
        match self
            .0
            .compare_exchange(RUNNING, STOPPED, Ordering::AcqRel, Ordering::Acquire)
        {
            Ok(_) => true,
            Err(state) => state == STOPPED,
        }
    }

    /// Whether the work was asked to stop.
    pub fn is_stopped(&self) -> bool {
        self.0.load(Ordering::Acquire) == STOPPED
    }
}

/// A long computation was stopped on its caller's request ([`Monitor::check`]).
#[derive(Clone, Copy, Debug, Error, PartialEq, Eq)]
#[error("interrupted")]
pub struct Interrupted;

/// What a long computation reports and how its caller asks it to stop: an optional observer of
/// `(stage, done, total)` and an optional stop flag. Both are borrowed, so a monitor is `Copy`
/// and costs nothing when silent.
///
/// Work that takes a monitor reports each of its stages, in order, ending each with
/// `done == total`, and looks at the stop flag between stages and at a bounded interval inside
/// them (every cell, particle chunk or iteration). Once the flag is set it stops early and
/// returns [`Interrupted`], or, in a helper whose caller checks right after, a partial result
/// that its caller discards. The flag never changes a result that completes: a monitored run
/// equals an unmonitored one bit for bit.
///
/// ```
/// use psi_octree::{Interrupted, Monitor, StopFlag};
///
/// let stop = StopFlag::new();
/// let seen = std::sync::Mutex::new(Vec::new());
/// let observe = |stage: &str, done: u64, total: u64| {
///     seen.lock().unwrap().push((stage.to_owned(), done, total))
/// };
/// let monitor = Monitor::new(Some(&observe), Some(&stop));
/// monitor.report("fit", 1, 2);
/// assert_eq!(monitor.check(), Ok(()));
/// assert!(stop.stop());
/// assert_eq!(monitor.check(), Err(Interrupted));
/// assert_eq!(seen.lock().unwrap().len(), 1);
/// assert_eq!(Monitor::silent().check(), Ok(()));
/// ```
#[derive(Clone, Copy, Default)]
pub struct Monitor<'a> {
    observe: Option<&'a Observer<'a>>,
    stop: Option<&'a StopFlag>,
}

impl std::fmt::Debug for Monitor<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Monitor")
            .field("observed", &self.observe.is_some())
            .field("stoppable", &self.stop.is_some())
            .finish()
    }
}

impl<'a> Monitor<'a> {
    /// No observer, no stop flag: the work runs to the end.
    pub const fn silent() -> Monitor<'static> {
        Monitor {
            observe: None,
            stop: None,
        }
    }

    /// A monitor reporting to `observe` (called from any thread, with `(stage, done, total)`)
    /// and stopping once `stop` is set.
    pub fn new(observe: Option<&'a Observer<'a>>, stop: Option<&'a StopFlag>) -> Self {
        Monitor { observe, stop }
    }

    /// The same stop flag without the observer: for the inner calls of a long call that
    /// reports its own stages (their stages would interleave with it).
    pub fn quiet(&self) -> Monitor<'a> {
        Monitor {
            observe: None,
            stop: self.stop,
        }
    }

    /// Whether the caller asked the work to stop.
    #[inline]
    pub fn stopped(&self) -> bool {
        self.stop.is_some_and(StopFlag::is_stopped)
    }

    /// Claims the commit of work that changes state (call it right before the change): `Ok`
    /// unless the caller asked to stop first, after which a stop request no longer takes
    /// effect ([`StopFlag::stop`] returns false).
    pub fn claim_commit(&self) -> Result<(), Interrupted> {
        match self.stop {
            None => Ok(()),
            Some(flag) => match flag.0.compare_exchange(
                RUNNING,
                COMMITTED,
                Ordering::AcqRel,
                Ordering::Acquire,
            ) {
                Ok(_) => Ok(()),
                Err(state) if state == COMMITTED => Ok(()),
                Err(_) => Err(Interrupted),
            },
        }
    }

    /// `Err(Interrupted)` once the caller asked the work to stop.
    #[inline]
    pub fn check(&self) -> Result<(), Interrupted> {
        if self.stopped() {
            Err(Interrupted)
        } else {
            Ok(())
        }
    }

    /// Reports that `done` of `total` steps of `stage` are finished.
    pub fn report(&self, stage: &str, done: u64, total: u64) {
        if let Some(observe) = self.observe {
            observe(stage, done, total);
        }
    }
}
