"""glibc's malloc arenas under a memory budget, as the command line limits them
(``src/bin/psi/arena_limit.rs``). glibc gives a thread that meets contention an arena of its
own and keeps the pages freed in each resident; under ``max_memory`` those kept pages were a
large share of the process's peak, and two arenas take most of them off at the same speed
(docs/notes/2026-12-04-cell-bound.md; in a Python process: docs/notes/2026-12-04-python-arenas.md).
The CLI runs itself again with ``MALLOC_ARENA_MAX=2``; a Python process cannot, so
``mallopt(M_ARENA_MAX, 2)`` is called once instead, before psi's threads allocate."""

import ctypes
import os
import platform

#: glibc's ``mallopt`` parameter for the most arenas (``malloc.h``).
M_ARENA_MAX = -8

#: The arenas a process that runs psi within a budget keeps (the CLI's ``MALLOC_ARENA_MAX``).
ARENAS = 2

_limited = False


def limit_arenas() -> None:
    """Once per process, on Linux with glibc, unless the user chose with ``MALLOC_ARENA_MAX``:
    glibc creates no arena beyond ``ARENAS`` in all from then on. Threads that already have an
    arena keep it, and threads started later share the arenas there are (all of them, when an
    earlier multi-threaded run made more). It changes nothing once the process has had more
    than eight arenas (glibc fixes its limit then); the environment variable, set before the
    process starts, always holds. Elsewhere, nothing."""
    global _limited
    if _limited:
        return
    _limited = True
    if "MALLOC_ARENA_MAX" in os.environ:
        return
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        return
    ctypes.CDLL(None).mallopt(M_ARENA_MAX, ARENAS)
