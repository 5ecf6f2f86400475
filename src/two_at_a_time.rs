//! Two workers over a list of items (the tiles of a pass out of core, the parts of a store),
//! the results handed over in item order: a large tile does not hold the other worker idle
//! while the small ones after it wait, as a pass taking its tiles in pairs did
//! (`docs/notes/2026-12-05-tiles-two-at-a-time.md`).

use std::collections::BTreeMap;
use std::sync::{Mutex, MutexGuard, PoisonError};

/// Items a worker of [`two_at_a_time`] may run ahead of the first whose result is not yet
/// handed over, so at most this many results wait. A tile pass's result is at most a few tens
/// of bytes an own point (standings 17, verdicts 9, denoised positions 32), and its working
/// memory a few hundred (the tile and its halo, their index), while the tile depth gives each
/// of the two tiles held 1 500 bytes a point (`budget.rs`): the waiting results stay within
/// what the budget set aside.
const AHEAD: usize = 8;

/// `work` on items `0..count`, two at a time (the most the budget holds at once): each of two
/// workers takes the next item as soon as it is done with its last, so a large tile does not
/// hold the other worker idle while small ones wait (rayon's pool runs a worker's own parallel
/// work on both threads when the other worker has none), up to [`AHEAD`] items past the first
/// whose result is not handed over yet. The results go to `sink` in item order, on whichever
/// worker completes the run. No item is taken once `stopped()` says so or a result or `sink`
/// failed; the first error in item order is returned, and `Ok` means every item was handed
/// over (or `stopped()`). The results, and what `sink` sees, do not depend on the threads.
///
/// No worker ever waits for another: one that finds the items it may take used up returns,
/// and the worker that hands over the result holding them back starts another in its place.
/// (The workers are tasks of the current pool, and a thread that waits inside a task's
/// parallel work runs other tasks on top of it: a worker that waited there for an item beneath
/// it, or for one whose work waits on such a thread, would wait for ever.) A panic in `work` or
/// `sink` ends the run and reaches the caller.
pub(crate) fn two_at_a_time<T: Send>(
    count: usize,
    work: &(dyn Fn(usize) -> Result<T, String> + Sync),
    stopped: &(dyn Fn() -> bool + Sync),
    sink: &mut (dyn FnMut(usize, T) -> Result<(), String> + Send),
) -> Result<(), String> {
    let run = Run {
        count,
        work,
        stopped,
        turn: Mutex::new(Turn {
            taken: 0,
            next: 0,
            workers: 2,
            ahead: BTreeMap::new(),
            sink,
            failed: None,
        }),
    };
    rayon::scope(|s| {
        s.spawn(|s| run.worker(s));
        s.spawn(|s| run.worker(s));
    });
    let t = run
        .turn
        .into_inner()
        .unwrap_or_else(PoisonError::into_inner);
    match t.failed {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Where the workers of a [`two_at_a_time`] run stand.
struct Turn<'s, T> {
    /// Items taken by a worker so far.
    taken: usize,
    /// The first item whose result is not handed over.
    next: usize,
    /// Workers started and not yet returned.
    workers: usize,
    ahead: BTreeMap<usize, Result<T, String>>,
    sink: &'s mut (dyn FnMut(usize, T) -> Result<(), String> + Send),
    failed: Option<String>,
}

impl<T> Turn<'_, T> {
    /// Whether a worker may take the item `taken` now.
    fn may_take(&self, count: usize) -> bool {
        self.failed.is_none() && self.taken < count && self.taken < self.next + AHEAD
    }
}

/// A [`two_at_a_time`] run.
struct Run<'r, 's, T> {
    count: usize,
    work: &'r (dyn Fn(usize) -> Result<T, String> + Sync),
    stopped: &'r (dyn Fn() -> bool + Sync),
    turn: Mutex<Turn<'s, T>>,
}

impl<'r, 's, T: Send> Run<'r, 's, T> {
    fn lock(&self) -> MutexGuard<'_, Turn<'s, T>> {
        self.turn.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// One worker: items taken and their results handed over in order until none may be
    /// taken; then, if fewer than two workers remain and an item may be taken again (this
    /// worker's hand-over freed room), another is started.
    fn worker<'scope>(&'scope self, s: &rayon::Scope<'scope>)
    where
        'r: 'scope,
        's: 'scope,
    {
        // (A panic in `work` or `sink` marks the run failed, so that no worker takes more.)
        let _on_panic = OnUnwind(|| {
            let mut t = self.lock();
            t.failed
                .get_or_insert_with(|| "a worker panicked".to_string());
        });
        loop {
            let i = {
                let mut t = self.lock();
                if !t.may_take(self.count) || (self.stopped)() {
                    t.workers -= 1;
                    return;
                }
                t.taken += 1;
                t.taken - 1
            };
            let result = (self.work)(i);
            let mut t = self.lock();
            t.ahead.insert(i, result);
            while t.failed.is_none() {
                let next = t.next;
                let Some(result) = t.ahead.remove(&next) else {
                    break;
                };
                t.next += 1;
                if let Err(e) = result.and_then(|out| (t.sink)(next, out)) {
                    t.failed = Some(e);
                }
            }
            // (This worker takes the next item itself: another only when one more remains.)
            if t.workers < 2 && t.may_take(self.count) && self.count - t.taken >= 2 {
                t.workers += 1;
                s.spawn(|s| self.worker(s));
            }
        }
    }
}

/// Calls its function when dropped while the thread unwinds from a panic.
struct OnUnwind<F: Fn()>(F);

impl<F: Fn()> Drop for OnUnwind<F> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            (self.0)();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use rayon::prelude::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// Item `i`'s work: a sum over a range whose length varies a hundredfold between items,
    /// and a thousandfold for every 50th, done in parallel (the workers' own parallel work, as
    /// a tile's).
    fn uneven(i: usize) -> u64 {
        let n = match i % 50 {
            10 => 4_000_000,
            _ => 1 + (i * 7919 % 13) * (i * 104_729 % 97) * 20,
        };
        (0..n as u64)
            .into_par_iter()
            .map(|k| k * k % 1_000_003)
            .sum()
    }

    fn in_pool<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("a pool")
            .install(f)
    }

    /// Every item's result reaches the sink once, in item order, as a sequential map gives
    /// them (the oracle), for one to three threads; no item starts more than `AHEAD` past the
    /// results handed over.
    #[test]
    fn results_come_in_item_order_whatever_the_threads() {
        let count = 300;
        let expected: Vec<(usize, u64)> = (0..count).map(|i| (i, uneven(i))).collect();
        for threads in [1, 2, 3] {
            for _ in 0..5 {
                let handed = AtomicUsize::new(0);
                let most_ahead = AtomicUsize::new(0);
                let work = |i: usize| {
                    let ahead = i - handed.load(Ordering::SeqCst);
                    most_ahead.fetch_max(ahead, Ordering::SeqCst);
                    Ok(uneven(i))
                };
                let mut seen = Vec::new();
                let mut sink = |i: usize, v: u64| {
                    seen.push((i, v));
                    handed.fetch_add(1, Ordering::SeqCst);
                    Ok(())
                };
                let out = in_pool(threads, || {
                    two_at_a_time(count, &work, &|| false, &mut sink)
                });
                assert_eq!(out, Ok(()));
                assert_eq!(seen, expected, "{threads} threads");
                assert!(most_ahead.into_inner() < AHEAD, "{threads} threads");
            }
        }
    }

    /// The first error in item order is returned, whichever fails first in time; the sink saw
    /// exactly the items before it. A failing sink stops the run as well.
    #[test]
    fn the_first_error_in_item_order_stops_the_run() {
        for threads in [1, 2] {
            // Item 40 fails after long work, item 45 at once.
            let work = |i: usize| match i {
                40 => {
                    let _ = uneven(12) + (0..2_000_000u64).into_par_iter().sum::<u64>();
                    Err("item 40".to_string())
                }
                45 => Err("item 45".to_string()),
                _ => Ok(uneven(i)),
            };
            let mut seen = Vec::new();
            let mut sink = |i: usize, _: u64| {
                seen.push(i);
                Ok(())
            };
            let out = in_pool(threads, || two_at_a_time(100, &work, &|| false, &mut sink));
            assert_eq!(out, Err("item 40".to_string()));
            assert_eq!(seen, (0..40).collect::<Vec<_>>());

            let mut sink = |i: usize, _: u64| match i {
                7 => Err("sink 7".to_string()),
                _ => Ok(()),
            };
            let work = |i: usize| Ok(uneven(i));
            let out = in_pool(threads, || two_at_a_time(100, &work, &|| false, &mut sink));
            assert_eq!(out, Err("sink 7".to_string()));
        }
    }

    /// Two runs sharing a pool of two threads (as the tasks of a Dask worker of two threads
    /// do), each worker's items doing parallel work of their own: both runs end, with their
    /// results in order. Whether a worker starts on top of an unfinished item depends on the
    /// scheduler's timing, which a test does not set; a deadline fails a run that hangs.
    #[test]
    fn runs_sharing_a_pool_end() {
        let count = 120;
        let expected: Vec<u64> = (0..count).map(uneven).collect();
        for round in 0..20 {
            let (tx, rx) = std::sync::mpsc::channel();
            std::thread::spawn(move || {
                let one = || {
                    let mut seen = Vec::new();
                    let work = |i: usize| Ok(uneven((i + round) % count));
                    let mut sink = |_: usize, v: u64| {
                        seen.push(v);
                        Ok(())
                    };
                    two_at_a_time(count, &work, &|| false, &mut sink).map(|()| seen)
                };
                let both = in_pool(2, || rayon::join(one, one));
                let _ = tx.send(both);
            });
            let (a, b) = rx
                .recv_timeout(std::time::Duration::from_secs(120))
                .expect("two runs sharing a pool ended");
            let rotated: Vec<u64> = (0..count).map(|i| expected[(i + round) % count]).collect();
            assert_eq!(a, Ok(rotated.clone()), "round {round}");
            assert_eq!(b, Ok(rotated), "round {round}");
        }
    }

    /// A panic in an item's work reaches the caller, with one thread or two: the run does not
    /// hang.
    #[test]
    fn a_panic_in_the_work_reaches_the_caller() {
        for threads in [1, 2] {
            let (tx, rx) = std::sync::mpsc::channel();
            std::thread::spawn(move || {
                let work = |i: usize| {
                    assert!(i != 37, "item 37 fails");
                    Ok(uneven(i))
                };
                let mut sink = |_: usize, _: u64| Ok(());
                let run = std::panic::AssertUnwindSafe(|| {
                    in_pool(threads, || two_at_a_time(100, &work, &|| false, &mut sink))
                });
                let _ = tx.send(std::panic::catch_unwind(run).is_err());
            });
            let panicked = rx
                .recv_timeout(std::time::Duration::from_secs(120))
                .expect("the run ended");
            assert!(panicked, "{threads} threads");
        }
    }

    /// Once `stopped()` says so no item is taken: the run ends with what was handed over.
    #[test]
    fn a_stop_ends_the_run_between_items() {
        let handed = AtomicUsize::new(0);
        let work = |i: usize| Ok(uneven(i));
        let mut sink = |_: usize, _: u64| {
            handed.fetch_add(1, Ordering::SeqCst);
            Ok(())
        };
        let stopped = || handed.load(Ordering::SeqCst) >= 10;
        let out = in_pool(2, || two_at_a_time(1000, &work, &stopped, &mut sink));
        assert_eq!(out, Ok(()));
        let n = handed.into_inner();
        assert!((10..10 + AHEAD + 2).contains(&n), "{n} handed over");
    }
}
