//! Large arrays dropped on a thread of their own: returning a large buffer's pages to the
//! system is one core's work, which the next stage need not wait for (notes:
//! 2026-12-04-exact-speedups).

/// Arrays from this size on (bytes) are freed on a thread of their own.
const FREE_ASIDE_BYTES: usize = 64 << 20;

/// Drops `v`: a large array on a thread of its own, a small one (or any, when no thread can be
/// made) here.
///
/// ```
/// psi_io::free_aside(vec![0u8; 1 << 10]);
/// psi_io::free_aside(vec![0u64; 10 << 20]);
/// ```
pub fn free_aside<T: Send + 'static>(v: Vec<T>) {
    if v.capacity() * std::mem::size_of::<T>() >= FREE_ASIDE_BYTES {
        // (Without a thread, `v` is dropped here as the spawn fails.)
        let _ = std::thread::Builder::new().spawn(move || drop(v));
    }
}
