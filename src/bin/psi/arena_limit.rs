//! glibc's malloc arenas under a memory budget. glibc gives a thread that meets contention an
//! arena of its own (up to 8 per core) and keeps the pages freed in each resident; under
//! `--max-memory` those kept pages were a large share of the peak, and two arenas take most of
//! them off at the same speed (measured: docs/results/2026-12-04-cell-bound/, second table;
//! docs/notes/2026-12-04-cell-bound.md). The process is run again with `MALLOC_ARENA_MAX=2`
//! (glibc's own setting, read when it starts) unless the user set it; the crate forbids
//! `unsafe`, so no `mallopt` call.

/// Replaces this process by the same command with `MALLOC_ARENA_MAX=2`, on Linux with glibc,
/// when the variable is not set; returns (doing nothing) elsewhere, when it is set, or when the
/// program cannot be run again (the run goes on with glibc's default arenas).
pub(crate) fn limit_arenas() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        use std::os::unix::process::CommandExt;
        if std::env::var_os("MALLOC_ARENA_MAX").is_some() {
            return;
        }
        let Ok(exe) = std::env::current_exe() else {
            return;
        };
        // (`exec` returns only when it failed.)
        let _failed = std::process::Command::new(exe)
            .args(std::env::args_os().skip(1))
            .env("MALLOC_ARENA_MAX", "2")
            .exec();
    }
}
