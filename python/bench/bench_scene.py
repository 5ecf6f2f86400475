"""What a stroke from Python costs over the Rust it calls (a benchmark, not a test).

A brush applied forth and back on a model (default: the bunny) through ``psi.Scene.brush(...,
settle=False)``, each stroke timed around the call and compared with the stroke's own clock in
its report (``seconds``, measured inside ``Scene::apply_deferred``); then settled. The
difference is the binding: the worker thread, the lock, the report dict. Issue 29 asks for at
most 1 ms.

    python python/bench/bench_scene.py [--model PLY] [--strokes 41]
"""

import argparse
import statistics
import time

import psi


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="../shared/models/bunny.ply")
    parser.add_argument("--strokes", type=int, default=41)
    args = parser.parse_args()
    scene = psi.Scene(psi.load_points(args.model))
    centre = scene.points[len(scene.points) // 3]
    diagonal = scene.mpu.diagonal
    over = []
    for k in range(args.strokes):
        sign = 1.0 if k % 2 == 0 else -1.0
        t = time.perf_counter()
        report = scene.brush(centre, 0.05 * diagonal, (0.0, 0.0, sign * 0.003 * diagonal),
                             settle=False)
        wall = time.perf_counter() - t
        scene.settle()
        if k > 0:
            over.append(wall - report["seconds"])
    print(f"| model | strokes | binding ms per stroke (median) | worst |\n|---|---|---|---|\n"
          f"| {args.model} | {len(over)} | {1e3 * statistics.median(over):.3f} "
          f"| {1e3 * max(over):.3f} |")


if __name__ == "__main__":
    main()
