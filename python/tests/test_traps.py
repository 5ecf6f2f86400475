"""Calls that used to surprise: ``k`` with ``count``, a picture path that is not a PNG, the
shapes ``value`` takes and gives, and normals that point inward as a whole (flipped with a
warning unless kept; never for an open surface), in the package and the CLI."""

import json
import re
import subprocess
import warnings

import numpy as np
import pytest

import psi
from conftest import sphere


@pytest.fixture(scope="module")
def mpu():
    return psi.Mpu(psi.builtin_model(20000))


@pytest.fixture(scope="module")
def particles(mpu):
    return psi.sample(mpu, iterations=3)


# k and count.


def test_k_with_count_is_refused_naming_both(mpu):
    with pytest.raises(ValueError) as e:
        psi.sample(mpu, k=2, count=5)
    message = str(e.value)
    assert re.search(r"\bk\b", message) and "count" in message, message


def test_k_defaults_to_none_meaning_one(mpu):
    default = psi.sample(mpu, iterations=2)
    for k in (None, 1):
        same = psi.sample(mpu, iterations=2, k=k)
        assert np.array_equal(same.positions, default.positions), k
    assert len(psi.sample(mpu, iterations=2, k=2)) > len(default)
    assert len(psi.sample(mpu, iterations=2, k=None, count=300)) == 300
    scene = psi.Scene(psi.builtin_model(5000), iterations=2, k=None)
    assert np.array_equal(
        scene.particles.positions,
        psi.Scene(psi.builtin_model(5000), iterations=2, k=1).particles.positions,
    )


# Picture formats: PNG only.


@pytest.mark.parametrize("name", ["x.jpg", "x.jpeg", "x.bmp", "x.tiff", "x", "x.png.txt"])
def test_render_writes_png_only(tmp_path, particles, mpu, name):
    vertices, faces = mpu.mesh(resolution=32)
    draws = [
        lambda path: psi.render(particles, path, size=32),
        lambda path: psi.render_mesh(vertices, faces, path, size=32),
    ]
    for draw in draws:
        with pytest.raises(ValueError) as e:
            draw(tmp_path / name)
        message = str(e.value)
        assert "PNG" in message, message
        extension = name.rsplit(".", 1)[1] if "." in name else None
        if extension is not None:
            assert extension in message, message
        assert list(tmp_path.iterdir()) == [], "something was written"
    for i, draw in enumerate(draws):
        path = tmp_path / f"ok{i}.png"
        draw(path)
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# Query shapes.


def test_one_point_gives_a_float(mpu):
    x = np.array([0.3, -0.2, 0.1])
    batch_f, batch_g = mpu.value_and_gradient(x[None])
    for given in (x, tuple(x), list(x), np.asfortranarray(x), x.astype(">f8")):
        f = mpu.value(given)
        assert type(f) is np.float64 and isinstance(f, float), type(f)
        assert f == batch_f[0]
        f, g = mpu.value_and_gradient(given)
        assert isinstance(f, float) and f == batch_f[0]
        assert isinstance(g, np.ndarray) and g.shape == (3,) and np.array_equal(g, batch_g[0])


@pytest.mark.parametrize("shape", [(0,), (1,), (7,), (1, 1), (4, 5), (2, 0), (3, 2, 4), (64, 64, 64)])
def test_any_leading_shape_gives_that_shape(mpu, shape):
    rng = np.random.default_rng(sum(shape) + len(shape))
    x = rng.uniform(-1.3, 1.3, shape + (3,))
    f, g = mpu.value_and_gradient(x)
    assert f.shape == shape and g.shape == shape + (3,)
    assert f.dtype == g.dtype == np.float64
    flat_f, flat_g = mpu.value_and_gradient(x.reshape(-1, 3))
    assert np.array_equal(f.reshape(-1), flat_f) and np.array_equal(g.reshape(-1, 3), flat_g)
    v = mpu.value(x)
    assert v.shape == shape and np.array_equal(v.reshape(-1), mpu.value(x.reshape(-1, 3)))
    # Any layout: a transposed (non-contiguous) view gives the same.
    if len(shape) == 2:
        t = np.ascontiguousarray(np.swapaxes(x, 0, 1))
        view = np.swapaxes(t, 0, 1)
        assert not view.flags.c_contiguous or 0 in shape or 1 in shape
        fv, gv = mpu.value_and_gradient(view)
        assert np.array_equal(fv, f) and np.array_equal(gv, g)


@pytest.mark.parametrize("shape", [(), (2,), (4,), (4, 2), (2, 3, 4)])
def test_a_last_axis_other_than_3_is_refused(mpu, shape):
    x = np.zeros(shape)
    for call in (mpu.value, mpu.value_and_gradient):
        with pytest.raises(ValueError, match="shape"):
            call(x)


# Inward normals.


def quiet(make):
    """``make()``, failing on any warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return make()


def test_inward_normals_are_flipped_with_a_warning():
    points, normals = sphere(3000, seed=51)
    with pytest.warns(UserWarning, match="inward"):
        flipped = psi.PointSet(points, -normals)
    assert flipped.report["inward_normals_flipped"] is True
    kept = quiet(lambda: psi.PointSet(points, -normals, keep_inward_normals=True))
    assert kept.report["inward_normals_flipped"] is False
    outward = quiet(lambda: psi.PointSet(points, normals))
    assert outward.report["inward_normals_flipped"] is False
    # Flipped: exactly the kept normals negated, and outward (along the radius).
    assert np.array_equal(flipped.normals, -kept.normals)
    assert np.array_equal(flipped.points, kept.points)
    assert np.einsum("ij,ij->i", flipped.normals, normals).min() > 0.99
    assert np.einsum("ij,ij->i", kept.normals, normals).max() < -0.99
    assert np.array_equal(flipped.normals, outward.normals)


def test_an_mpu_of_inward_normals_is_positive_outside():
    points, normals = sphere(3000, seed=52)
    with pytest.warns(UserWarning, match="inward"):
        mpu = psi.Mpu(points, -normals)
    assert mpu.value((0.0, 0.0, 0.0)) < 0 < mpu.value((0.0, 0.0, 0.8))


def test_inward_normals_in_a_file(tmp_path):
    points, normals = sphere(3000, seed=53, centre=(2.0, -1.0, 0.5))
    path = tmp_path / "inward.xyz"
    np.savetxt(path, np.hstack([points, -normals]), fmt="%.17g")
    with pytest.warns(UserWarning, match="inward"):
        flipped = psi.load_points(path)
    assert flipped.report["inward_normals_flipped"] is True
    assert np.einsum("ij,ij->i", flipped.normals, normals).min() > 0.99
    kept = quiet(lambda: psi.load_points(path, keep_inward_normals=True))
    assert kept.report["inward_normals_flipped"] is False
    assert np.einsum("ij,ij->i", kept.normals, normals).max() < -0.99
    with pytest.raises(TypeError):
        psi.builtin_model(1000, keep_inward_normals=True)


def open_surfaces():
    points, normals = sphere(4000, seed=54)
    bowl = points[:, 2] > 0.0
    rng = np.random.default_rng(55)
    plane = np.c_[rng.uniform(-1, 1, (2000, 2)), np.zeros(2000)]
    up = np.tile([0.0, 0.0, 1.0], (2000, 1))
    return {
        "hemisphere, normals inward": (points[bowl], -normals[bowl]),
        "dome open at the bottom, seen from inside": (
            points[points[:, 2] > -0.3], -normals[points[:, 2] > -0.3]),
        "hemisphere, normals outward": (points[bowl], normals[bowl]),
        "plane, normals down": (plane, -up),
        "plane, normals up": (plane, up),
    }


@pytest.mark.parametrize("case", list(open_surfaces()))
def test_an_open_surface_is_never_flipped(case):
    points, normals = open_surfaces()[case]
    ps = quiet(lambda: psi.PointSet(points, normals))
    assert ps.report["inward_normals_flipped"] is False
    assert np.einsum("ij,ij->i", ps.normals, normals).min() > 0.99


def find_key(obj, key):
    """The values of ``key`` anywhere in a JSON object."""
    if isinstance(obj, dict):
        return ([obj[key]] if key in obj else []) + [
            v for x in obj.values() for v in find_key(x, key)]
    if isinstance(obj, list):
        return [v for x in obj for v in find_key(x, key)]
    return []


def test_the_cli_flips_with_a_notice_unless_told_to_keep(tmp_path, cli):
    points, normals = sphere(3000, seed=56)
    inward, outward = tmp_path / "inward.xyz", tmp_path / "outward.xyz"
    np.savetxt(inward, np.hstack([points, -normals]), fmt="%.17g")
    np.savetxt(outward, np.hstack([points, normals]), fmt="%.17g")

    def info(*args):
        done = subprocess.run([str(cli), "info", *map(str, args), "--json"],
                              capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        return done.stderr, find_key(json.loads(done.stdout), "inward_normals_flipped")

    stderr, flags = info(inward)
    assert "inward" in stderr and set(flags) == {True}, (stderr, flags)
    stderr, flags = info(inward, "--keep-inward-normals")
    assert "inward" not in stderr and set(flags) == {False}, (stderr, flags)
    stderr, flags = info(outward)
    assert "inward" not in stderr and set(flags) == {False}, (stderr, flags)


# Options that contradict each other are refused, not silently dropped.


def test_k_with_uniform_is_refused(mpu):
    with pytest.raises(ValueError) as e:
        psi.sample(mpu, k=5, uniform=True)
    assert "k=5" in str(e.value) and "uniform" in str(e.value)
    with pytest.raises(ValueError):
        psi.Scene(psi.builtin_model(3000), k=2, count=100)


@pytest.mark.parametrize("flag", [{"keep_outliers": True}, {"orient_normals": True},
                                  {"viewpoint": (0, 0, 5)}, {"denoise": False},
                                  {"keep_inward_normals": True}])
def test_preprocess_false_refuses_a_preprocessing_flag(flag):
    points, normals = sphere(500, seed=57)
    with pytest.raises(ValueError) as e:
        psi.PointSet(points, normals, preprocess=False, **flag)
    assert next(iter(flag)) in str(e.value)


def test_the_cli_refuses_k_with_count_and_pictures_not_named_png(tmp_path, cli):
    done = subprocess.run([str(cli), "sample", "--k", "2", "--count", "50", "--builtin-points",
                           "3000"], capture_output=True, text=True)
    assert done.returncode == 2 and "--count" in done.stderr, done.stderr
    out = tmp_path / "p.ply"
    subprocess.run([str(cli), "--quiet", "sample", "--builtin-points", "3000", "--iterations",
                    "1", "-o", str(out)], check=True)
    for args in (["render", str(out), "-o", str(tmp_path / "x.jpg")],
                 ["sample", "--builtin-points", "3000", "--png", str(tmp_path / "y.jpg")]):
        done = subprocess.run([str(cli), *args], capture_output=True, text=True)
        assert done.returncode != 0 and "PNG" in done.stderr, done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.ply"]


def test_given_normals_are_made_unit_and_zero_ones_refused():
    points, normals = sphere(300, seed=58)
    p = psi.Particles(points, 3.0 * normals)
    assert np.allclose(np.linalg.norm(p.normals, axis=1), 1.0, atol=1e-12)
    assert np.allclose(p.normals, normals, atol=1e-12)
    bad = normals.copy()
    bad[7] = 0.0
    with pytest.raises(ValueError) as e:
        psi.Particles(points, bad)
    assert "row 7" in str(e.value)
