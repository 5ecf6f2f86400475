"""The ceiling on spacing from Python: ``max_spacing=`` reaches the sampler as the CLI's
``--max-spacing`` does (the same particles bit for bit), a flat sheet is covered at about the
ceiling (oracle: brute-force distances), and bad values are refused as the CLI refuses them."""

import math

import numpy as np
import pytest

import psi
from conftest import columns, read_ply, run_cli


def sheet(n, seed, side=2.0):
    """``n`` points of a flat square in z = 0 with normals +z (seeded)."""
    rng = np.random.default_rng(seed)
    points = np.zeros((n, 3))
    points[:, :2] = side * rng.random((n, 2))
    normals = np.tile([0.0, 0.0, 1.0], (n, 1))
    return points, normals


def nearest(a, b):
    """For every row of ``a``, the distance to the nearest row of ``b`` (brute force)."""
    return np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(-1)).min(1)


def test_a_flat_sheet_is_covered_at_the_ceiling():
    points, normals = sheet(8000, 1)
    mpu = psi.Mpu(points, normals, preprocess=False)
    particles = psi.sample(mpu)
    ceiling = particles.report["particles"]["max_spacing"]
    assert ceiling == pytest.approx(0.025 * math.sqrt(8.0), rel=0.01)
    assert particles.report["particles"]["added_by_ceiling"] > 100
    pos = particles.positions
    spacing = np.sqrt(((pos[:, None] - pos[None]) ** 2).sum(-1) + np.eye(len(pos)) * 1e9).min(1)
    assert np.median(spacing) <= ceiling
    assert spacing.std() / spacing.mean() <= 0.15
    assert nearest(points[::7], pos).max() <= ceiling
    # Without the ceiling the sheet is one cell: a particle or two.
    assert len(psi.sample(mpu, max_spacing=math.inf)) < 10


def test_max_spacing_equals_the_cli_bitwise(cli, tmp_path):
    points, normals = sheet(6000, 2)
    xyz = tmp_path / "sheet.xyz"
    np.savetxt(xyz, np.hstack([points, normals]), fmt="%.17g")
    mpu = psi.Mpu(psi.load_points(xyz))
    mine = psi.sample(mpu, max_spacing=0.15, iterations=5)
    out = tmp_path / "p.ply"
    run_cli(cli, "sample", xyz, "--max-spacing", "0.15", "--iterations", "5", "-o", out)
    pos, nor, depth, sigma = columns(read_ply(out))
    assert np.array_equal(mine.positions, pos)
    assert np.array_equal(mine.normals, nor)
    assert np.array_equal(mine.sigma, sigma)
    assert mine.report["particles"]["max_spacing"] == 0.15


@pytest.mark.parametrize(
    "kwargs",
    [
        {"max_spacing": 0.0},
        {"max_spacing": -1.0},
        {"max_spacing": math.nan},
        {"max_spacing": 0.1, "count": 100},
        {"max_spacing": 0.1, "uniform": True},
    ],
)
def test_bad_ceilings_are_refused(builtin_mpu, kwargs):
    with pytest.raises(ValueError, match="max_spacing"):
        psi.sample(builtin_mpu, **kwargs)


def test_a_scene_keeps_a_flat_region_covered_through_strokes():
    points, normals = sheet(8000, 3)
    scene = psi.Scene(points, normals, preprocess=False, iterations=8, max_spacing=0.12)
    assert scene.report["density"]["ceiling"] == 0.12
    assert scene.report["added_by_ceiling"] > 0
    before = len(scene.particles)
    assert before > 200
    scene.brush([1.0, 1.0, 0.0], 0.4, [0.0, 0.0, 0.05])
    scene.brush([1.2, 0.9, 0.0], 0.4, [0.05, 0.0, 0.0], settle=False)
    scene.settle()
    pos = scene.particles.positions
    # Every control point within the ceiling of a particle, the count kept within 10 %.
    assert nearest(scene.points[::5], pos).max() <= 0.12
    assert abs(len(pos) - before) <= 0.1 * before
    with pytest.raises(ValueError, match="max_spacing"):
        psi.Scene(points, normals, preprocess=False, max_spacing=-1.0)
