"""Particles from arrays and from files (``psi.Particles``, ``load_particles``), saved with only
the columns they have and drawn like sampled ones; and the arrays objects hold: read-only and
the same object on each access (a Scene's: fresh writable copies)."""

import numpy as np
import pytest

import psi
from conftest import read_ply, sphere, torus


@pytest.fixture(scope="module")
def sampled():
    return psi.sample(psi.Mpu(psi.builtin_model(8000)), iterations=5)


def header(path):
    data = path.read_bytes()
    return data[: data.index(b"end_header\n")].decode("ascii").splitlines()


def vertex_properties(path):
    return [line.split()[2] for line in header(path) if line.startswith("property ")]


def test_particles_from_every_array_equal_the_sampled_ones(sampled):
    p = psi.Particles(
        sampled.positions, sampled.normals, depth=sampled.depth, sigma=sampled.sigma
    )
    assert len(p) == len(sampled) and p.report is None
    for name in ("positions", "normals", "depth", "sigma"):
        a, b = getattr(p, name), getattr(sampled, name)
        assert a.dtype == b.dtype and np.array_equal(a, b), name
    # Drawn exactly as the sampled particles, in every colouring.
    for color in ("depth", "sigma", "normal"):
        assert np.array_equal(psi.render(p, size=64, color=color),
                              psi.render(sampled, size=64, color=color)), color


def test_any_dtype_and_layout_goes_in():
    points, normals = sphere(500, seed=41)
    depth = np.arange(500) % 256
    sigma = np.full(500, 0.01)
    p = psi.Particles(np.asfortranarray(points).astype(np.float32), normals.tolist(),
                      depth=depth.astype(np.int64), sigma=sigma.astype(np.float32))
    assert p.positions.dtype == np.float64 and p.depth.dtype == np.uint8
    assert p.sigma.dtype == np.float64 and p.normals.dtype == np.float64
    assert np.array_equal(p.positions, points.astype(np.float32).astype(np.float64))
    assert np.array_equal(p.depth, depth) and np.allclose(p.sigma, 0.01)
    assert np.allclose(p.normals, normals, atol=1e-12)


def test_missing_columns_are_none_and_normals_are_estimated():
    points, normals = sphere(2000, seed=42)
    p = psi.Particles(points)
    assert p.depth is None and p.sigma is None and p.report is None and len(p) == 2000
    assert np.array_equal(p.positions, points)
    assert p.normals.shape == (2000, 3)
    assert np.allclose(np.linalg.norm(p.normals, axis=1), 1)
    # Estimated from the positions: along the sphere's radius (up to sign).
    assert np.abs(np.einsum("ij,ij->i", p.normals, normals)).min() > 0.95
    only_depth = psi.Particles(points, normals, depth=np.zeros(2000, np.uint8))
    assert only_depth.sigma is None and np.array_equal(only_depth.depth, np.zeros(2000))


BAD = {
    "positions 2 columns": (lambda x, n: psi.Particles(x[:, :2], n)),
    "positions 1-D": (lambda x, n: psi.Particles(x[:, 0], n)),
    "normals shape": (lambda x, n: psi.Particles(x, n[:-1])),
    "depth shape": (lambda x, n: psi.Particles(x, n, depth=np.zeros(len(x) - 1, int))),
    "sigma shape": (lambda x, n: psi.Particles(x, n, sigma=np.ones((len(x), 1)))),
    "NaN position": (lambda x, n: psi.Particles(np.where(np.eye(len(x), 3) > 0, np.nan, x), n)),
    "inf normal": (lambda x, n: psi.Particles(x, np.where(np.eye(len(x), 3) > 0, np.inf, n))),
    "NaN sigma": (lambda x, n: psi.Particles(x, n, sigma=np.r_[np.nan, np.ones(len(x) - 1)])),
    "negative sigma": (lambda x, n: psi.Particles(x, n, sigma=np.r_[-1.0, np.ones(len(x) - 1)])),
    "depth 256": (lambda x, n: psi.Particles(x, n, depth=np.r_[256, np.zeros(len(x) - 1, int)])),
    "depth -1": (lambda x, n: psi.Particles(x, n, depth=np.r_[-1, np.zeros(len(x) - 1, int)])),
}


@pytest.mark.parametrize("case", BAD, ids=list(BAD))
def test_bad_arrays_raise_value_error(case):
    points, normals = sphere(100, seed=43)
    with pytest.raises(ValueError):
        BAD[case](points, normals)


def test_saved_particles_load_back_bitwise(tmp_path, sampled):
    path = tmp_path / "p.ply"
    psi.save_particles(path, sampled)
    assert vertex_properties(path) == ["x", "y", "z", "nx", "ny", "nz", "depth", "sigma"]
    loaded = psi.load_particles(path)
    assert len(loaded) == len(sampled) and loaded.report is None
    for name in ("positions", "normals", "depth", "sigma"):
        a, b = getattr(loaded, name), getattr(sampled, name)
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), name
    assert np.array_equal(psi.render(loaded, size=64), psi.render(sampled, size=64))
    # A str path too.
    assert np.array_equal(psi.load_particles(str(path)).positions, sampled.positions)


def test_the_cli_s_particles_load_back_bitwise(tmp_path, cli):
    from conftest import columns, run_cli

    out = tmp_path / "cli.ply"
    run_cli(cli, "sample", "--iterations", "3", "-o", out)
    positions, normals, depth, sigma = columns(read_ply(out))
    loaded = psi.load_particles(out)
    assert np.array_equal(loaded.positions, positions)
    assert np.array_equal(loaded.normals, normals)
    assert np.array_equal(loaded.depth, depth) and loaded.depth.dtype == np.uint8
    assert np.array_equal(loaded.sigma, sigma)


def test_particles_save_only_the_columns_they_have(tmp_path, sampled):
    cases = [
        ({}, ["x", "y", "z", "nx", "ny", "nz"]),
        ({"depth": sampled.depth}, ["x", "y", "z", "nx", "ny", "nz", "depth"]),
        ({"sigma": sampled.sigma}, ["x", "y", "z", "nx", "ny", "nz", "sigma"]),
    ]
    for i, (extra, properties) in enumerate(cases):
        p = psi.Particles(sampled.positions, sampled.normals, **extra)
        path = tmp_path / f"p{i}.ply"
        psi.save_particles(path, p)
        assert vertex_properties(path) == properties
        ply = read_ply(path)
        assert np.array_equal(ply["x"], sampled.positions[:, 0])
        loaded = psi.load_particles(path)
        assert np.array_equal(loaded.positions, sampled.positions)
        assert np.array_equal(loaded.normals, sampled.normals)
        assert (loaded.depth is None) == ("depth" not in extra)
        assert (loaded.sigma is None) == ("sigma" not in extra)
        if "depth" in extra:
            assert np.array_equal(loaded.depth, sampled.depth)
        if "sigma" in extra:
            assert np.array_equal(loaded.sigma, sampled.sigma)


def test_xyz_files_load_as_particles_without_depth_or_sigma(tmp_path):
    points, normals = torus(1500, seed=44)
    np.savetxt(tmp_path / "n.xyz", np.hstack([points, normals]), fmt="%.17g")
    np.savetxt(tmp_path / "p.xyz", points, fmt="%.17g")
    with_normals = psi.load_particles(tmp_path / "n.xyz")
    assert with_normals.depth is None and with_normals.sigma is None
    assert np.array_equal(with_normals.positions, points)
    assert np.allclose(with_normals.normals, normals, atol=1e-12)
    bare = psi.load_particles(tmp_path / "p.xyz")
    assert bare.depth is None and bare.sigma is None
    assert np.array_equal(bare.positions, points)


def test_positions_alone_load_with_estimated_normals(tmp_path):
    # As ``Particles(positions)``: unit normals estimated from the positions.
    points, normals = torus(1500, seed=44)
    np.savetxt(tmp_path / "p.xyz", points, fmt="%.17g")
    bare = psi.load_particles(tmp_path / "p.xyz")
    assert np.allclose(np.linalg.norm(bare.normals, axis=1), 1)
    assert np.abs(np.einsum("ij,ij->i", bare.normals, normals)).min() > 0.9
    assert np.array_equal(bare.normals, psi.Particles(points).normals)


def test_load_particles_errors(tmp_path):
    with pytest.raises(FileNotFoundError):
        psi.load_particles(tmp_path / "missing.ply")
    (tmp_path / "bad.ply").write_bytes(b"ply\nformat ascii 1.0\nelement vertex 3\nend_header\n")
    with pytest.raises(ValueError):
        psi.load_particles(tmp_path / "bad.ply")


def test_render_needs_depth_only_to_colour_by_depth(tmp_path):
    points, normals = sphere(3000, seed=45)
    p = psi.Particles(points, normals, sigma=np.full(3000, 0.01))
    image = psi.render(p, size=64, color="normal")
    assert image.shape == (64, 64, 4) and len(np.unique(image.reshape(-1, 4), axis=0)) > 10
    with pytest.raises(ValueError, match="depth"):
        psi.render(p, size=64)  # color="depth" is the default
    with pytest.raises(ValueError, match="depth"):
        psi.render(p, tmp_path / "d.png", size=64, color="depth")
    assert not (tmp_path / "d.png").exists()
    psi.render(p, tmp_path / "n.png", size=64, color="normal")
    assert (tmp_path / "n.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # Without sigma either: still drawn by normal.
    bare = psi.Particles(points, normals)
    assert psi.render(bare, size=32, color="normal").shape == (32, 32, 4)


# Read-only arrays.


def read_only_and_cached(obj, names):
    for name in names:
        a = getattr(obj, name)
        assert isinstance(a, np.ndarray), name
        assert a.flags.writeable is False, name
        assert getattr(obj, name) is a, f"{name}: a new array on each access"
        with pytest.raises(ValueError):
            a[0] = 0
        # A copy is the user's to change.
        b = a.copy()
        b[0] = 0
        assert b.flags.writeable


def test_arrays_of_point_sets_mpus_and_particles_are_read_only_and_cached(sampled):
    points, normals = torus(2000, seed=46)
    ps = psi.PointSet(points, normals)
    read_only_and_cached(ps, ["points", "normals"])
    read_only_and_cached(psi.Mpu(ps), ["points", "normals"])
    read_only_and_cached(sampled, ["positions", "normals", "depth", "sigma"])
    read_only_and_cached(psi.Particles(points, normals, depth=np.zeros(2000, int),
                                       sigma=np.ones(2000)),
                         ["positions", "normals", "depth", "sigma"])
    # The arrays given stay the caller's: changing them changes nothing held.
    given = points.copy()
    p = psi.Particles(given, normals)
    given[:] = 0
    assert np.array_equal(p.positions, points)


def test_a_scene_gives_fresh_writable_copies():
    scene = psi.Scene(psi.builtin_model(5000), iterations=3)
    for name in ("points", "normals"):
        a, b = getattr(scene, name), getattr(scene, name)
        assert a is not b and a.flags.writeable and np.array_equal(a, b)
        a[:] = 0  # the scene is not affected
        assert np.array_equal(getattr(scene, name), b)
