//! Reading ahead: an input decoded on a thread of its own while the caller uses its chunks.

use std::sync::mpsc::sync_channel;

/// Chunks a reading thread may decode ahead of their use.
pub(crate) const AHEAD: usize = 2;

/// Calls `consume` with every chunk `produce` hands its callback, in order, and returns what
/// `produce` returns. When `allowed` and the current rayon pool has two threads or more,
/// `produce` runs on a thread of its own, at most [`AHEAD`] chunks ahead (each copied once:
/// up to `AHEAD` + 1 more chunks held), so that decoding overlaps with consuming; otherwise on
/// this one. The first error wins: `consume`'s stops `produce` (its callback then returns
/// `stopped()`, which is discarded).
pub(crate) fn read_ahead<T, R, E>(
    allowed: bool,
    produce: impl FnOnce(&mut dyn FnMut(&[T]) -> Result<(), E>) -> Result<R, E> + Send,
    mut consume: impl FnMut(&[T]) -> Result<(), E>,
    stopped: impl Fn() -> E + Send,
) -> Result<R, E>
where
    T: Clone + Send,
    R: Send,
    E: Send,
{
    if !allowed || rayon::current_num_threads() < 2 {
        return produce(&mut consume);
    }
    let (send, receive) = sync_channel::<Vec<T>>(AHEAD);
    std::thread::scope(|scope| {
        let reader = scope.spawn(move || {
            produce(&mut |chunk: &[T]| send.send(chunk.to_vec()).map_err(|_| stopped()))
        });
        let mut failure = None;
        for chunk in receive.iter() {
            if let Err(e) = consume(&chunk) {
                failure = Some(e);
                break;
            }
        }
        // The reader's next send fails once nothing receives.
        drop(receive);
        let produced = reader
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        match failure {
            Some(e) => Err(e),
            None => produced,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The chunks arrive in order and whole, with one thread or two, and an error of either
    /// side stops the other.
    #[test]
    fn chunks_arrive_in_order_and_errors_stop_both_sides() {
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let produce = |up_to: u32, fail_at: Option<u32>| {
                    move |visit: &mut dyn FnMut(&[u32]) -> Result<(), String>| {
                        for k in 0..up_to {
                            if Some(k) == fail_at {
                                return Err(format!("reader failed at {k}"));
                            }
                            visit(&[2 * k, 2 * k + 1])?;
                        }
                        Ok(up_to)
                    }
                };
                let mut seen = Vec::new();
                let made = read_ahead(
                    true,
                    produce(100, None),
                    |c: &[u32]| {
                        seen.extend_from_slice(c);
                        Ok(())
                    },
                    || "stopped".to_string(),
                );
                assert_eq!(made, Ok(100));
                assert_eq!(seen, (0..200).collect::<Vec<u32>>());
                let failed =
                    read_ahead(true, produce(100, Some(7)), |_| Ok(()), || "stopped".into());
                assert_eq!(failed, Err("reader failed at 7".to_string()));
                let mut calls = 0;
                let stopped = read_ahead(
                    true,
                    produce(1000, None),
                    |_| {
                        calls += 1;
                        if calls == 3 {
                            Err("consumer failed".into())
                        } else {
                            Ok(())
                        }
                    },
                    || "stopped".into(),
                );
                assert_eq!(stopped, Err("consumer failed".to_string()));
                assert_eq!(calls, 3);
            });
        }
    }
}
