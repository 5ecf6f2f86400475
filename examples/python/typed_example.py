"""A small, fully typed program using the package: it passes ``mypy --strict`` with no cast and
no ``type: ignore`` (python/tests/test_typing.py checks that, and runs it).

    python examples/python/typed_example.py [-o DIR]

Points of a sphere made with NumPy go in (as arrays and as an XYZ file), an MPU is built and
evaluated at one point (a float) and at many (an array), particles are sampled, rebuilt from
arrays and drawn to a PNG, the MPU survives a pickle round trip bitwise, and a scene takes a
brush edit that a build from scratch in the scene's frame agrees with. Writes into ``DIR``
(default: a temporary directory, removed at the end).
"""

from __future__ import annotations

import argparse
import pickle
import tempfile
from pathlib import Path
from typing import Optional

import numpy as np
import numpy.typing as npt

import psi

F64 = npt.NDArray[np.float64]


def sphere(n: int, seed: int, radius: float = 0.5) -> tuple[F64, F64]:
    """``n`` points of a sphere about the origin and their outward unit normals."""
    rng = np.random.default_rng(seed)
    normals: F64 = rng.normal(size=(n, 3))
    normals /= np.sqrt((normals**2).sum(axis=1))[:, None]
    points: F64 = radius * normals
    return points, normals


def write_xyz(path: Path, points: F64, normals: F64) -> None:
    """An XYZ file ``x y z nx ny nz``, one point a line."""
    np.savetxt(path, np.hstack([points, normals]), fmt="%.17g")


class Stages:
    """A progress callable remembering the stages it saw, in order."""

    def __init__(self) -> None:
        self.seen: list[str] = []

    def __call__(self, stage: str, done: int, total: int) -> None:
        if not self.seen or self.seen[-1] != stage:
            self.seen.append(stage)


def run(out: Path) -> None:
    points, normals = sphere(6000, seed=1)
    from_arrays = psi.PointSet(points, normals)
    write_xyz(out / "sphere.xyz", points, normals)
    from_file = psi.load_points(out / "sphere.xyz")
    print(f"{len(from_arrays)} points from arrays, {len(from_file)} from {from_file.name}")

    stages = Stages()
    mpu = psi.Mpu(from_file, progress=stages)
    print(f"MPU: {mpu.leaves} leaves, depth {mpu.max_depth}; stages {', '.join(stages.seen)}")

    # One point gives a float, an array of points an array.
    f: float = mpu.value((0.6, 0.0, 0.0))
    assert abs(f - 0.1) < 0.01, f
    outside: F64 = mpu.value(1.2 * points[:50])
    assert outside.shape == (50,) and bool((outside > 0).all())
    f0, grad0 = mpu.value_and_gradient([0.0, 0.0, 0.5])
    fs, grads = mpu.value_and_gradient(points[:10])
    assert abs(f0) < 0.01 and grad0.shape == (3,) and fs.shape == (10,) == grads.shape[:1]

    particles = psi.sample(mpu, count=3000, uniform=True, iterations=5)
    depth: Optional[npt.NDArray[np.uint8]] = particles.depth
    deepest = int(depth.max()) if depth is not None else -1
    print(f"{len(particles)} particles, deepest leaf {deepest}")

    # Particles from arrays (no depth: colour by normal) drawn to a PNG.
    mine = psi.Particles(particles.positions, particles.normals, sigma=particles.sigma)
    assert mine.depth is None and mine.report is None
    png = out / "particles.png"
    psi.render(mine, png, size=96, color="normal")
    image: npt.NDArray[np.uint8] = psi.render(particles, size=96)
    assert png.read_bytes()[:4] == b"\x89PNG" and image.shape == (96, 96, 4)
    print(f"wrote {png}")

    # A pickle round trip rebuilds the MPU bitwise.
    again: psi.Mpu = pickle.loads(pickle.dumps(mpu))
    x: F64 = np.random.default_rng(2).uniform(-0.7, 0.7, (100, 3))
    assert np.array_equal(again.value(x), mpu.value(x))

    # A brush edit, and the same surface built from scratch in the scene's frame.
    scene = psi.Scene(from_arrays, iterations=5)
    report = scene.brush((0.5, 0.0, 0.0), 0.2, (0.02, 0.0, 0.0))
    current: psi.Mpu = scene.mpu
    fresh = psi.Mpu(scene.points, scene.normals, preprocess=False, frame=current.frame)
    gap = float(np.abs(fresh.value(x) - current.value(x)).max())
    print(f"edit {report['edit']}: {report['refit_cells']} cells refitted; "
          f"|scene - scratch| {gap:.1e}")
    assert gap < 1e-12


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("-o", "--output", type=Path, default=None)
    args = parser.parse_args()
    output: Optional[Path] = args.output
    if output is not None:
        output.mkdir(parents=True, exist_ok=True)
        run(output)
        return
    with tempfile.TemporaryDirectory() as tmp:
        run(Path(tmp))


if __name__ == "__main__":
    main()
