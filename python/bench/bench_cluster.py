"""How a run out of core scales over Dask workers (a benchmark, not a test; issue 26).

``psi.distributed.sample_files`` on one input with the same budget on ``LocalCluster``s of
1, 2, ... worker processes of one thread each: the wall time of each, the speed-up over one
worker, and whether the particles written are bitwise the same (they must be: the tiling is a
function of the input and the budget alone). Each run starts from an empty scratch directory.

    python python/bench/bench_cluster.py INPUT [--max-memory 1GiB] [--workers 1,2]
        [--out docs/results/.../cluster.json]
"""

import argparse
import hashlib
import json
import shutil
import tempfile
import time
from pathlib import Path

import psi.distributed


def run(input_path, workers, max_memory, work):
    from dask.distributed import Client, LocalCluster

    out = work / f"particles-{workers}.ply"
    scratch = work / f"scratch-{workers}"
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True) as cluster:
        with Client(cluster) as client:
            t = time.perf_counter()
            report = psi.distributed.sample_files(
                input_path, out, client, max_memory=max_memory, scratch=scratch
            )
            seconds = time.perf_counter() - t
    digest = hashlib.sha256(out.read_bytes()).hexdigest()
    shutil.rmtree(scratch, ignore_errors=True)
    return {
        "workers": workers,
        "seconds": seconds,
        "particles": report["particles"]["count"],
        "sha256": digest,
        "stages": report["tiles"]["seconds"],
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("input")
    ap.add_argument("--max-memory", default="1GiB")
    ap.add_argument("--workers", default="1,2")
    ap.add_argument("--out")
    args = ap.parse_args()
    counts = [int(w) for w in args.workers.split(",")]
    with tempfile.TemporaryDirectory(prefix="psi-cluster-") as tmp:
        rows = [run(args.input, w, args.max_memory, Path(tmp)) for w in counts]
    base = rows[0]["seconds"]
    print(f"| workers | s | speed-up over {counts[0]} | particles | same bytes |")
    print("|---|---|---|---|---|")
    for r in rows:
        same = r["sha256"] == rows[0]["sha256"]
        print(
            f"| {r['workers']} | {r['seconds']:.1f} | {base / r['seconds']:.2f}× | "
            f"{r['particles']} | {'yes' if same else 'NO'} |"
        )
    if args.out:
        Path(args.out).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
