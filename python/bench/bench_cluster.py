"""How a run out of core scales over Dask workers (a benchmark, not a test; issue 26).

``psi.distributed.sample_files`` on one input with the same budget on ``LocalCluster``s of
1, 2, ... worker processes of one thread each, in the order given (the default 1, 2, 2, 1:
this host's speed drifts within an hour, and a drift linear in time then adds alike to both
counts' mean): the wall time of each run, the speed-up of each count's mean over the first's,
each task function's span and busy time (Dask's task stream), each worker process's peak
resident memory, the CPU time of this process (the scheduler's and the client's: on a
``LocalCluster`` they take it from the workers' cores), and whether the particles written are
bitwise the same (they must be: the tiling is a function of the input and the budget alone).
Each run starts from an empty scratch directory.

    python python/bench/bench_cluster.py INPUT [--max-memory 1GiB] [--workers 1,2,2,1]
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


def stages(task_stream):
    """Per task function (the key's prefix): tasks, wall span from the first start to the
    last stop, and the summed compute time, in seconds."""
    spans = {}
    for task in task_stream:
        name = task["key"].rsplit("-", 1)[0]
        for s in task["startstops"]:
            if s["action"] != "compute":
                continue
            a = spans.setdefault(
                name, {"tasks": 0, "start": s["start"], "stop": s["stop"], "busy": 0.0}
            )
            a["tasks"] += 1
            a["start"], a["stop"] = min(a["start"], s["start"]), max(a["stop"], s["stop"])
            a["busy"] += s["stop"] - s["start"]
    return {
        k: {"tasks": v["tasks"], "span": v["stop"] - v["start"], "busy": v["busy"]}
        for k, v in sorted(spans.items(), key=lambda kv: kv[1]["start"])
    }


def peak_rss():
    """This process's peak resident memory, bytes (Linux reports KiB)."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def run(input_path, workers, max_memory, work):
    from dask.distributed import Client, LocalCluster, get_task_stream

    out = work / f"particles-{workers}.ply"
    scratch = work / f"scratch-{workers}"
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True) as cluster:
        with Client(cluster) as client, get_task_stream(client) as stream:
            t, cpu = time.perf_counter(), time.process_time()
            report = psi.distributed.sample_files(
                input_path, out, client, max_memory=max_memory, scratch=scratch
            )
            seconds, cpu = time.perf_counter() - t, time.process_time() - cpu
            peaks = sorted(client.run(peak_rss).values())
    digest = hashlib.sha256(out.read_bytes()).hexdigest()
    shutil.rmtree(scratch, ignore_errors=True)
    return {
        "workers": workers,
        "seconds": seconds,
        "scheduler_cpu_seconds": cpu,
        "points": report["input"]["points"],
        "particles": report["particles"]["count"],
        "worker_peak_bytes": peaks,
        "sha256": digest,
        "tasks": stages(stream.data),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("input")
    ap.add_argument("--max-memory", default="1GiB")
    ap.add_argument("--workers", default="1,2,2,1")
    ap.add_argument("--out")
    args = ap.parse_args()
    counts = [int(w) for w in args.workers.split(",")]
    with tempfile.TemporaryDirectory(prefix="psi-cluster-") as tmp:
        rows = [run(args.input, w, args.max_memory, Path(tmp)) for w in counts]

    def mean(w):
        runs = [r["seconds"] for r in rows if r["workers"] == w]
        return sum(runs) / len(runs), runs

    base = mean(counts[0])[0]
    print(f"| workers | mean s (runs) | speed-up over {counts[0]} | particles | same bytes |")
    print("|---|---|---|---|---|")
    for w in dict.fromkeys(counts):
        s, runs = mean(w)
        same = all(r["sha256"] == rows[0]["sha256"] for r in rows if r["workers"] == w)
        particles = next(r["particles"] for r in rows if r["workers"] == w)
        print(
            f"| {w} | {s:.1f} ({', '.join(f'{t:.1f}' for t in runs)}) | {base / s:.2f}× | "
            f"{particles} | {'yes' if same else 'NO'} |"
        )
    for r in rows:
        print(f"{r['workers']} worker(s), scheduler CPU {r['scheduler_cpu_seconds']:.1f} s: "
              + ", ".join(
            f"{k} {v['tasks']}× span {v['span']:.1f} s busy {v['busy']:.1f} s"
            for k, v in r["tasks"].items()))
    if args.out:
        Path(args.out).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
