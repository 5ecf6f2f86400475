"""The same tiles on a Dask cluster: ``sample_files`` runs a run out of core (``psi sample
--max-memory``) as Dask tasks on a ``dask.distributed.Client`` — the partition of the inputs
into tile files (a first pass, then the files in parts, a task per worker thread; with the
outlier step, all points so, its passes as a task per batch of tiles, then the kept points so;
normals estimated where there are none as one task), the cells
above the tiles (one task per octant of the root), the tiles (a task per batch of neighbours),
the seeds (one task per octant), then the relaxation and the writing — and writes bitwise the
particles the command line writes.

Needs ``dask[distributed]`` (``pip install "./python[dask]"``). Every task reads and writes the
scratch directory, so on a real cluster it must be on a file system every worker sees. The
cells above the tiles are a task for the root's levels, then one per octant of the root, then
one that merges them. Each task is a pure function of the inputs, the budget and its part: a
worker lost while it runs one costs a retry (the files are written whole or not at all), never
a different result; a rerun with the same scratch resumes from the files there.
"""

import ctypes
import importlib
import os
import platform
import uuid
from os import PathLike, fspath
from typing import Any, Dict, List, Optional, Union

from ._allocator import limit_arenas

# The extension's task functions are not part of the typed API (psi/__init__.pyi).
_psi: Any = importlib.import_module("psi._psi")

_Path = Union[str, "PathLike[str]"]

#: How often Dask retries a task whose worker died.
RETRIES = 3

#: The most parts the tile files are written in (one task each, each reading the whole input:
#: beyond a few, reading again costs more than the writing it shares out).
MAX_PARTS = 8


#: Tiles decided by one task, neighbours in the tiles' order. A task opens the store and reads
#: the cells above the tiles, which costs more than a small tile's own work, and Dask adds its
#: own cost per task on the scheduler and the worker (docs/notes/2026-11-27-tile-batches.md).
TILES_PER_TASK = 8

#: Batches of tiles per partition part in each pass of the outlier step (a task each): a few
#: per worker thread, so that a slow batch leaves the others work to do.
STRAY_BATCHES_PER_PART = 4


#: glibc's ``mallopt`` parameters (``malloc.h``).
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
_allocator_tuned = False


def _tune_allocator() -> None:
    """Once per worker process: undo a side effect of Dask's worker environment. The nanny
    starts every worker with ``MALLOC_TRIM_THRESHOLD_=65536``, and with any such threshold set
    glibc keeps its mmap threshold at 128 KiB instead of raising it as large blocks are freed:
    every larger buffer is then mapped, faulted in page by page and unmapped again (measured in
    docs/notes/2026-11-27-dask-allocator.md). This sets the thresholds glibc's own dynamic rule reaches (mmap 32 MiB, trim twice that);
    only on glibc, and only when the mmap threshold was not chosen explicitly."""
    global _allocator_tuned
    if _allocator_tuned:
        return
    _allocator_tuned = True
    if "MALLOC_TRIM_THRESHOLD_" not in os.environ or "MALLOC_MMAP_THRESHOLD_" in os.environ:
        return
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        return
    libc = ctypes.CDLL(None)
    libc.mallopt(_M_MMAP_THRESHOLD, 32 << 20)
    libc.mallopt(_M_TRIM_THRESHOLD, 64 << 20)


def _task(f: Any, *a: Any, **kw: Any) -> Any:
    """Runs the extension's task function ``f`` on a worker, its allocator tuned first (and
    its arenas limited as ``psi.sample_files`` limits them)."""
    _tune_allocator()
    limit_arenas()
    return f(*a, **kw)


def _scratch_for(output: _Path) -> str:
    path = fspath(output)
    return path + ".psi-scratch"


def sample_files(
    inputs: Union[_Path, List[_Path]],
    output: _Path,
    client: Optional[Any] = None,
    *,
    max_memory: Union[int, str],
    scratch: Optional[_Path] = None,
    k: int = 1,
    iterations: int = 20,
    seed: int = 2007,
    mpu_error: Optional[float] = None,
    keep_outliers: bool = False,
    max_spacing: Optional[float] = None,
    threads: int = 1,
) -> Dict[str, Any]:
    """``psi.sample_files`` as Dask tasks on ``client`` (a ``LocalCluster`` of worker
    processes when ``None``, closed afterwards). The tiling is a function of the inputs and
    ``max_memory`` alone, so the particles written to ``output`` are bitwise those of
    ``psi sample INPUT --max-memory SIZE`` and of ``psi.sample_files`` (``keep_outliers`` and
    ``max_spacing`` as there); ``max_memory`` bounds
    what psi allocates in a task, not the worker's own baseline. Each task runs psi on
    ``threads`` threads of its own (Dask's convention is one task per worker thread, so one;
    give more for workers started with fewer threads than their cores); the particles do not
    depend on it. Returns the run's report."""
    from dask.distributed import Client, LocalCluster

    paths = [fspath(p) for p in ([inputs] if isinstance(inputs, (str, PathLike)) else inputs)]
    scratch_dir = fspath(scratch) if scratch is not None else _scratch_for(output)
    own: Any = None
    if client is None:
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True)
        client = Client(cluster)
        own = (client, cluster)
    try:

        def submit(f: Any, *a: Any, **kw: Any) -> Any:
            # Named after the task function (Dask's dashboard and task stream show it).
            key = f"{f.__name__}-{uuid.uuid4().hex}"
            return client.submit(_task, f, *a, key=key, retries=RETRIES, **kw)

        # The partition: a first pass (the frame and the count), then the tile files written
        # in parts side by side, each streaming the whole input and keeping its own tiles (the
        # files' bytes do not depend on the number of parts), then the manifest.
        parts = min(MAX_PARTS, max(1, sum(client.nthreads().values())))

        def partition(stage: str) -> None:
            points = submit(
                _psi._ooc_partition_start, paths, max_memory, scratch_dir, mpu_error, threads,
                stage=stage
            ).result()
            if points is None:
                return
            client.gather(
                [
                    submit(_psi._ooc_partition_part, paths, max_memory, scratch_dir, i, parts,
                           threads, stage=stage)
                    for i in range(parts)
                ]
            )
            submit(
                _psi._ooc_partition_assemble, paths, max_memory, scratch_dir, parts, points,
                stage=stage
            ).result()

        preprocessing = submit(
            _psi._ooc_preprocessing, paths, max_memory, scratch_dir, keep_outliers
        ).result()
        if preprocessing == "found":
            # An earlier run's finished store (and verdicts): nothing to partition again.
            pass
        elif preprocessing == "normals":
            # Normals estimated and oriented tile by tile: the whole stage one task (the store
            # it writes is the partition's).
            submit(
                _psi._ooc_preprocess, paths, max_memory, scratch_dir, mpu_error, keep_outliers,
                threads
            ).result()
        elif preprocessing == "outliers":
            # All points stored, the outlier step's two passes over batches of their tiles
            # (the exact median between them), its verdicts joined, the kept points stored.
            partition("all")
            batches = parts * STRAY_BATCHES_PER_PART
            client.gather(
                [submit(_psi._ooc_stray_standings, scratch_dir, b, batches, threads)
                 for b in range(batches)]
            )
            stats = submit(_psi._ooc_stray_stats, scratch_dir, batches).result()
            client.gather(
                [submit(_psi._ooc_stray_verdicts, scratch_dir, b, batches, stats, threads)
                 for b in range(batches)]
            )
            submit(_psi._ooc_stray_join, scratch_dir, batches).result()
            partition("kept")
        else:
            partition("tiles")
        # The final store's checks (inward normals, the noise's error threshold), kept in the
        # scratch directory where the tasks below read the run's threshold.
        submit(
            _psi._ooc_checks, paths, max_memory, scratch_dir, keep_outliers, threads
        ).result()
        groups = submit(_psi._ooc_top_upper, scratch_dir, mpu_error, threads).result()
        client.gather(
            [submit(_psi._ooc_top_group, scratch_dir, g, mpu_error, threads) for g in groups]
        )
        keys = submit(_psi._ooc_top, scratch_dir, mpu_error, threads).result()
        batches = [keys[i : i + TILES_PER_TASK] for i in range(0, len(keys), TILES_PER_TASK)]
        client.gather(
            [
                submit(_psi._ooc_tiles, scratch_dir, b, mpu_error, threads,
                       max_memory=max_memory)
                for b in batches
            ]
        )
        # The seeds by octant of the root, the largest first as the groups came (a task for an
        # octant without regions does nothing).
        octants = list(groups) + [
            (x, y, z)
            for z in (0, 1)
            for y in (0, 1)
            for x in (0, 1)
            if (x, y, z) not in groups
        ]
        client.gather(
            [
                submit(_psi._ooc_seed, scratch_dir, o, max_memory=max_memory, k=k,
                       iterations=iterations, seed=seed, mpu_error=mpu_error,
                       max_spacing=max_spacing, threads=threads)
                for o in octants
            ]
        )
        report: Dict[str, Any] = submit(
            _psi._ooc_sample,
            paths,
            fspath(output),
            max_memory=max_memory,
            scratch=scratch_dir,
            k=k,
            iterations=iterations,
            seed=seed,
            mpu_error=mpu_error,
            keep_outliers=keep_outliers,
            max_spacing=max_spacing,
            threads=threads,
        ).result()
        return report
    finally:
        if own is not None:
            own[0].close()
            own[1].close()
