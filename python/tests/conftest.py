"""Shared fixtures: the repository, the paper's models, the ``psi`` binary (the CLI the
package must agree with) and a reader of the binary PLY files it writes (numpy only)."""

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import psi

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT.parent / "shared" / "models"


def model(name):
    """The path of a paper model, or a skip when ../shared/models does not hold it."""
    path = MODELS / name
    if not path.is_file():
        pytest.skip(f"{path} is absent (the paper's models live in ../shared/models)")
    return path


@pytest.fixture(scope="session")
def cli():
    """The ``psi`` binary of this checkout (``$PSI_CLI`` if set): the one the workspace's tests
    run (``cargo test --workspace``, which the README runs first, so here nothing is built
    again; a release build would add minutes of link-time optimisation to every CI run, and
    the two builds write the same bytes: Rust does not reorder floating-point operations
    between optimisation levels). A skip when neither is available (the package installed
    away from its sources)."""
    given = os.environ.get("PSI_CLI")
    if given:
        return Path(given)
    if not (ROOT / "Cargo.toml").is_file() or shutil.which("cargo") is None:
        pytest.skip("no psi checkout with cargo to build the CLI from (set PSI_CLI)")
    built = subprocess.run(
        ["cargo", "test", "--workspace", "--no-run", "--message-format=json", "--quiet"],
        cwd=ROOT,
        check=True,
        stdout=subprocess.PIPE,
        text=True,
    )
    for line in built.stdout.splitlines():
        message = json.loads(line)
        target = message.get("target", {})
        if (
            message.get("reason") == "compiler-artifact"
            and target.get("name") == "psi"
            and target.get("kind") == ["bin"]
            and not message["profile"]["test"]
        ):
            return Path(message["executable"])
    raise AssertionError("cargo test --workspace --no-run built no psi binary")


def run_cli(cli, *args, expect_ok=True):
    """Runs the CLI quietly; returns the completed process."""
    done = subprocess.run([str(cli), "--quiet", *map(str, args)], capture_output=True, text=True)
    if expect_ok:
        assert done.returncode == 0, done.stderr
    return done


def cli_error(cli, *args):
    """The CLI's error message for ``args`` (its stderr line after ``psi: error: ``)."""
    done = run_cli(cli, *args, expect_ok=False)
    assert done.returncode == 2, done.stderr
    line = done.stderr.strip().splitlines()[-1]
    assert line.startswith("psi: error: "), line
    return line[len("psi: error: "):]


def read_ply(path):
    """The ``vertex`` columns of a binary little-endian PLY of doubles, as a dict of arrays."""
    data = Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    assert header[1] == "format binary_little_endian 1.0", header
    count = next(int(l.split()[2]) for l in header if l.startswith("element vertex"))
    names = [l.split()[2] for l in header if l.startswith("property double")]
    rows = np.frombuffer(data, dtype=[(n, "<f8") for n in names], count=count, offset=end)
    return {n: rows[n].copy() for n in names}


def columns(ply):
    """Positions, normals, depth and sigma of a particle PLY read by ``read_ply``."""
    pos = np.stack([ply["x"], ply["y"], ply["z"]], axis=1)
    nor = np.stack([ply["nx"], ply["ny"], ply["nz"]], axis=1)
    return pos, nor, ply["depth"], ply["sigma"]


@pytest.fixture(scope="session")
def builtin_mpu():
    """The built-in model's MPU, as ``psi sample`` builds it without an input."""
    return psi.Mpu(psi.builtin_model())


@pytest.fixture(scope="session")
def builtin_particles(builtin_mpu):
    """The built-in model's particles with the CLI's defaults."""
    return psi.sample(builtin_mpu)


def torus(n, seed, big=1.0, small=0.35):
    """``n`` points of a torus about z with their outward normals (the test's own oracle)."""
    rng = np.random.default_rng(seed)
    u, v = rng.uniform(0, 2 * np.pi, (2, n))
    ring = np.stack([np.cos(u), np.sin(u), np.zeros(n)], axis=1)
    normal = np.cos(v)[:, None] * ring + np.sin(v)[:, None] * np.array([0.0, 0.0, 1.0])
    return big * ring + small * normal, normal


def sphere(n, seed, radius=0.5, centre=(0.0, 0.0, 0.0)):
    """``n`` points of a sphere with their outward unit normals (random, seeded)."""
    rng = np.random.default_rng(seed)
    normal = rng.normal(size=(n, 3))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    return np.asarray(centre) + radius * normal, normal


def inward_noisy_model(path, n=20_000):
    """The built-in model with its normals turned inward and seeded noise of 0.3 % of its
    diagonal, written to ``path`` (x y z nx ny nz)."""
    ps = psi.builtin_model(n)
    pts, nrm = np.asarray(ps.points), np.asarray(ps.normals)
    diagonal = np.linalg.norm(pts.max(axis=0) - pts.min(axis=0))
    rng = np.random.default_rng(4)
    noisy = pts + 0.003 * diagonal * rng.standard_normal(pts.shape)
    with open(path, "w") as f:
        for p, q in zip(noisy, -nrm):
            f.write(" ".join(repr(float(v)) for v in (*p, *q)) + "\n")
