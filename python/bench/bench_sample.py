"""What the Python package costs over the Rust it calls (a benchmark, not a test).

1. ``psi.sample`` on a model (default: the bunny) against ``psi sample`` (the release CLI)
   doing the same work:
   end to end (the same file in, the same PLY and JSON report out: the CLI's process against
   ``load_points``, ``Mpu``, ``sample``, ``save_particles`` and the report), and the sampling
   stage alone (the sampler's own clocks, seeding + relaxation, in both; and ``psi.sample``'s
   wall time, which adds the quality measurement and the binding).
2. ``Mpu.value_and_gradient`` on 1 M points near that model's surface against a plain Rust loop
   over the same points in the same extension (``psi._psi._rust_loop_seconds``: a rayon map
   collected into a Vec, as a Rust caller would write it, and one thread), the points already
   in Rust.

Runs are interleaved and repeated (the machine may be shared); medians and minima are printed
as a Markdown table, the raw numbers written as JSON with ``--out``.

    python python/bench/bench_sample.py [--model PLY] [--rounds 9] [--out docs/results/.../raw.json]
"""

import argparse
import json
import os
import platform
import shutil
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

import psi

ROOT = Path(__file__).resolve().parents[2]
BUNNY = ROOT.parent / "shared" / "models" / "bunny.ply"


def cli_binary():
    if os.environ.get("PSI_CLI"):
        return os.environ["PSI_CLI"]
    subprocess.run(["cargo", "build", "--release", "--bin", "psi", "--quiet"], cwd=ROOT, check=True)
    meta = subprocess.run(
        ["cargo", "metadata", "--format-version", "1", "--no-deps"],
        cwd=ROOT, check=True, capture_output=True, text=True,
    )
    return str(Path(json.loads(meta.stdout)["target_directory"]) / "release" / "psi")


def run_cli(cli, model, out_dir):
    ply, report = out_dir / "cli.ply", out_dir / "cli.json"
    t = time.perf_counter()
    subprocess.run([cli, "sample", str(model), "-q", "-o", str(ply), "--json", str(report)],
                   check=True)
    wall = time.perf_counter() - t
    r = json.loads(report.read_text())
    return {
        "wall": wall,
        "stage": r["particles"]["init_seconds"] + r["particles"]["simulate_seconds"],
        "build": r["mpu"]["build_seconds"],
        "count": r["particles"]["count"],
    }


def run_python(model, out_dir):
    ply, report = out_dir / "py.ply", out_dir / "py.json"
    t0 = time.perf_counter()
    mpu = psi.Mpu(psi.load_points(model))
    t1 = time.perf_counter()
    particles = psi.sample(mpu)
    t2 = time.perf_counter()
    psi.save_particles(ply, particles)
    r = particles.report
    report.write_text(json.dumps(r, indent=2) + "\n")
    t3 = time.perf_counter()
    return {
        "wall": t3 - t0,
        "sample_call": t2 - t1,
        "stage": r["particles"]["init_seconds"] + r["particles"]["simulate_seconds"],
        "build": r["mpu"]["build_seconds"],
        "count": r["particles"]["count"],
    }


def query_points(mpu, n, seed=1):
    """``n`` points within 1 % of D of the model's input points, along their normals."""
    rng = np.random.default_rng(seed)
    pick = rng.integers(0, len(mpu.points), n)
    offset = rng.uniform(-0.01, 0.01, n) * mpu.diagonal
    return np.ascontiguousarray(mpu.points[pick] + offset[:, None] * mpu.normals[pick])


def timed(f, rounds):
    out = []
    for _ in range(rounds):
        t = time.perf_counter()
        f()
        out.append(time.perf_counter() - t)
    return out


def summary(values):
    return {"median": statistics.median(values), "min": min(values), "runs": values}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=9)
    parser.add_argument("--points", type=int, default=1_000_000)
    parser.add_argument("--out", type=Path)
    parser.add_argument("--model", type=Path, default=BUNNY)
    args = parser.parse_args()
    model, name = args.model, args.model.stem
    if not model.is_file():
        raise SystemExit(f"{model} is absent (the paper's models live in ../shared/models)")
    cli = cli_binary()

    cli_runs, py_runs = [], []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        run_cli(cli, model, tmp)  # warm the file cache and the allocator
        run_python(model, tmp)
        for _ in range(args.rounds):
            cli_runs.append(run_cli(cli, model, tmp))
            py_runs.append(run_python(model, tmp))
        same = (tmp / "cli.ply").read_bytes() == (tmp / "py.ply").read_bytes()

    mpu = psi.Mpu(psi.load_points(model))
    x = query_points(mpu, args.points)
    batch, rust_par, rust_one, batch_f32 = [], [], [], []
    x32 = x.astype(np.float32)
    for _ in range(max(3, args.rounds // 2)):
        batch += timed(lambda: mpu.value_and_gradient(x), 1)
        rust_par.append(psi._psi._rust_loop_seconds(mpu, x, True))
        rust_one.append(psi._psi._rust_loop_seconds(mpu, x, False))
        batch_f32 += timed(lambda: mpu.value_and_gradient(x32), 1)

    pick = lambda runs, key: summary([r[key] for r in runs])  # noqa: E731
    raw = {
        "machine": {"platform": platform.platform(), "cpus": os.cpu_count(),
                    "python": platform.python_version(), "psi": psi.__version__},
        "model": {
            "name": name, "path": str(model), "particles": py_runs[0]["count"], "same_ply_as_cli": same,
            "cli_wall": pick(cli_runs, "wall"), "python_wall": pick(py_runs, "wall"),
            "cli_stage": pick(cli_runs, "stage"), "python_stage": pick(py_runs, "stage"),
            "python_sample_call": pick(py_runs, "sample_call"),
            "cli_build": pick(cli_runs, "build"), "python_build": pick(py_runs, "build"),
        },
        "value_and_gradient": {
            "points": args.points,
            "python_batch": summary(batch), "python_batch_float32": summary(batch_f32),
            "rust_loop_parallel": summary(rust_par), "rust_loop_one_thread": summary(rust_one),
        },
    }
    paired = lambda py, rs: statistics.median(p / r for p, r in zip(py, rs))  # noqa: E731
    raw["paired_ratios"] = {
        "end_to_end": paired([r["wall"] for r in py_runs], [r["wall"] for r in cli_runs]),
        "sampling_stage": paired([r["stage"] for r in py_runs], [r["stage"] for r in cli_runs]),
        "value_and_gradient": paired(batch, rust_par),
    }
    b, v = raw["model"], raw["value_and_gradient"]
    med = lambda d: d["median"]  # noqa: E731
    rows = [
        (f"{name} end to end (read, prepare, build, sample, write PLY + JSON)",
         med(b["cli_wall"]), med(b["python_wall"])),
        (f"{name} MPU build (its own clock)", med(b["cli_build"]), med(b["python_build"])),
        (f"{name} sampling, seeding + relaxation (the sampler's clock)",
         med(b["cli_stage"]), med(b["python_stage"])),
        (f"{name} `psi.sample` call vs its own sampler's clock (adds the quality measurement, "
         "which the CLI does too, and the binding)",
         med(b["python_stage"]), med(b["python_sample_call"])),
        (f"value_and_gradient, {args.points} points: Rust loop (rayon map) vs Python",
         med(v["rust_loop_parallel"]), med(v["python_batch"])),
        ("… Rust loop on one thread vs Python", med(v["rust_loop_one_thread"]),
         med(v["python_batch"])),
        ("… Rust loop (rayon map) vs Python from float32", med(v["rust_loop_parallel"]),
         med(v["python_batch_float32"])),
    ]
    print(f"{b['particles']} particles; Python's PLY equals the CLI's: {same}\n")
    print("| what | Rust / CLI s | Python s | Python / Rust |")
    print("|---|---|---|---|")
    for what, rust, py in rows:
        print(f"| {what} | {rust:.4f} | {py:.4f} | {py / rust:.3f} |")
    print("\nMedians of the per-round ratios Python / Rust (runs interleaved): "
          + ", ".join(f"{k} {v:.3f}" for k, v in raw["paired_ratios"].items()))
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(raw, indent=2) + "\n")
        print(f"\nwrote {args.out}")


if __name__ == "__main__":
    if shutil.which("cargo") is None and not os.environ.get("PSI_CLI"):
        raise SystemExit("needs cargo (to build the CLI) or PSI_CLI")
    main()
