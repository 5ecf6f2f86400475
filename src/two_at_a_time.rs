//! Two workers over a list of items (the tiles of a pass out of core, the parts of a store),
//! the results handed over in item order: a large tile does not hold the other worker idle
//! while the small ones after it wait, as a pass taking its tiles in pairs did
//! (`docs/notes/2026-12-05-tiles-two-at-a-time.md`).

use std::collections::BTreeMap;
use std::sync::{Condvar, Mutex};

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
/// The workers are tasks of the current pool. A thread that waits inside a task's parallel
/// work runs other waiting tasks, so a worker may start on top of an unfinished item on the
/// same thread: the other worker's, or another run's when several share the pool (a Dask
/// worker of several threads). Such a worker never waits: the item beneath it could not finish
/// before the worker returns, and the worker it waits for might itself sit on top of an item
/// of this run on the other thread. It returns instead, and the work beneath carries on.
pub(crate) fn two_at_a_time<T: Send>(
    count: usize,
    work: &(dyn Fn(usize) -> Result<T, String> + Sync),
    stopped: &(dyn Fn() -> bool + Sync),
    sink: &mut (dyn FnMut(usize, T) -> Result<(), String> + Send),
) -> Result<(), String> {
    struct Turn<'s, T> {
        /// Items taken by a worker so far.
        taken: usize,
        /// The first item whose result is not handed over.
        next: usize,
        ahead: BTreeMap<usize, Result<T, String>>,
        sink: &'s mut (dyn FnMut(usize, T) -> Result<(), String> + Send),
        failed: Option<String>,
    }
    thread_local! {
        /// Items of any run whose work is on this thread's stack.
        static UNDER_WAY: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
    }
    /// One item under way on this thread, until dropped (also when its work panics).
    struct UnderWay;
    impl UnderWay {
        fn begin() -> Self {
            UNDER_WAY.set(UNDER_WAY.get() + 1);
            UnderWay
        }
    }
    impl Drop for UnderWay {
        fn drop(&mut self) {
            UNDER_WAY.set(UNDER_WAY.get() - 1);
        }
    }
    let turn = Mutex::new(Turn {
        taken: 0,
        next: 0,
        ahead: BTreeMap::new(),
        sink,
        failed: None,
    });
    let handed = Condvar::new();
    let worker = || {
        loop {
            let i = {
                let mut t = turn.lock().expect("not poisoned");
                while t.failed.is_none() && t.taken < count && t.taken >= t.next + AHEAD {
                    if UNDER_WAY.get() > 0 {
                        return;
                    }
                    // (The other worker has the item `next`: it hands it over, and wakes this.)
                    t = handed.wait(t).expect("not poisoned");
                }
                if t.failed.is_some() || t.taken >= count || stopped() {
                    return;
                }
                t.taken += 1;
                t.taken - 1
            };
            let result = {
                let _under_way = UnderWay::begin();
                work(i)
            };
            let mut t = turn.lock().expect("not poisoned");
            t.ahead.insert(i, result);
            while t.failed.is_none() {
                let next = t.next;
                let Some(result) = t.ahead.remove(&next) else {
                    break;
                };
                t.next += 1;
                if let Err(e) = result.and_then(|out| (t.sink)(next, out)) {
                    t.failed = Some(e);
                    break;
                }
            }
            drop(t);
            handed.notify_all();
        }
    };
    rayon::scope(|s| {
        s.spawn(|_| worker());
        s.spawn(|_| worker());
    });
    let t = turn.into_inner().expect("not poisoned");
    match t.failed {
        Some(e) => Err(e),
        None => Ok(()),
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
