//! Wall and CPU time per stage of a run, for the JSON report's `stage_seconds` list (issue
//! "Throughput": each stage's CPU time against its wall time shows whether both cores work).
//!
//! The stages are the names the layers report to their [`psi::octree::Monitor`] (`outliers`,
//! `normals`, the MPU's levels, `relax`, …) and the ones the command marks itself (`read`,
//! `write`). A stage runs from the first report of its name to the first report of another;
//! time spent under one name in several stretches is summed.

use std::sync::Mutex;
use std::time::Instant;

use serde_json::{Value, json};

/// Process CPU seconds so far, every thread.
fn cpu_now() -> f64 {
    cpu_time::ProcessTime::now().as_duration().as_secs_f64()
}

/// The stages seen so far: the running one with its start, and the totals in first-seen order.
#[derive(Default)]
struct Timeline {
    current: Option<(String, Instant, f64)>,
    /// `(stage, wall seconds, CPU seconds)`.
    totals: Vec<(String, f64, f64)>,
}

impl Timeline {
    fn close(&mut self) {
        if let Some((name, wall, cpu)) = self.current.take() {
            let (w, c) = (wall.elapsed().as_secs_f64(), cpu_now() - cpu);
            match self.totals.iter_mut().find(|t| t.0 == name) {
                Some(t) => (t.1, t.2) = (t.1 + w, t.2 + c),
                None => self.totals.push((name, w, c)),
            }
        }
    }
}

/// The process's stage timeline (one run per process).
static TIMELINE: Mutex<Option<Timeline>> = Mutex::new(None);

/// Marks the start of `stage` (ending the one running) unless it is already running.
pub(crate) fn enter(stage: &str) {
    let mut guard = TIMELINE.lock().unwrap_or_else(|e| e.into_inner());
    let timeline = guard.get_or_insert_with(Timeline::default);
    if timeline.current.as_ref().is_some_and(|c| c.0 == stage) {
        return;
    }
    timeline.close();
    timeline.current = Some((stage.to_owned(), Instant::now(), cpu_now()));
}

/// Ends the running stage.
pub(crate) fn leave() {
    if let Some(t) = TIMELINE.lock().unwrap_or_else(|e| e.into_inner()).as_mut() {
        t.close();
    }
}

/// The stages so far as JSON, in the order they first ran (the running one is ended first):
/// `[{"stage", "wall_seconds", "cpu_seconds"}, …]`.
pub(crate) fn report() -> Value {
    leave();
    let guard = TIMELINE.lock().unwrap_or_else(|e| e.into_inner());
    guard
        .iter()
        .flat_map(|t| &t.totals)
        .map(|(name, wall, cpu)| json!({"stage": name, "wall_seconds": wall, "cpu_seconds": cpu}))
        .collect()
}

/// A monitor observer that marks each reported stage ([`enter`]).
pub(crate) fn observe(stage: &str, _done: u64, _total: u64) {
    enter(stage);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stages_sum_their_stretches_in_first_seen_order() {
        enter("a");
        std::thread::sleep(std::time::Duration::from_millis(20));
        enter("b");
        enter("b"); // still b; a stretch of microseconds, far below a's sleeps
        enter("a");
        std::thread::sleep(std::time::Duration::from_millis(20));
        let r = report();
        let names: Vec<&str> = r
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["stage"].as_str().unwrap())
            .collect();
        assert_eq!(names, ["a", "b"]);
        let wall = |k: usize| r[k]["wall_seconds"].as_f64().unwrap();
        // a's two stretches are summed; b's is all but empty.
        assert!(wall(0) >= 0.04, "{r}");
        assert!(wall(1) < wall(0), "{r}");
    }
}
