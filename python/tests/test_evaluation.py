"""f and ∇f from Python: ∇f against central finite differences of f, the batch against the
Rust evaluation behind the sampler's own report, every dtype and layout against float64 C
order, and the interpreter released while Rust works."""

import threading
import time

import numpy as np
import pytest

import psi
from conftest import torus


def central_differences(mpu, x, h):
    """∇f at the rows of ``x`` by central differences of ``mpu.value`` with step ``h``."""
    grad = np.empty_like(x)
    for axis in range(3):
        step = np.zeros(3)
        step[axis] = h
        grad[:, axis] = (mpu.value(x + step) - mpu.value(x - step)) / (2 * h)
    return grad


def near_surface(points, normals, n, spread, seed):
    """``n`` query points within ``spread`` of the sampled surface along its normals."""
    rng = np.random.default_rng(seed)
    pick = rng.integers(0, len(points), n)
    offset = rng.uniform(-spread, spread, n)
    return points[pick] + offset[:, None] * normals[pick]


@pytest.fixture(scope="module")
def smooth_torus():
    points, normals = torus(20000, seed=3)
    return psi.Mpu(points, normals, smooth=True), points, normals


def test_gradient_is_the_derivative_of_the_value(smooth_torus):
    mpu, points, normals = smooth_torus
    x = near_surface(points, normals, 400, 0.05, seed=4)
    _, grad = mpu.value_and_gradient(x)
    h = 1e-6 * mpu.diagonal
    fd = central_differences(mpu, x, h)
    # f is C1 (quadratic B-spline weights): where f'' jumps the differences are only O(h)
    # exact, elsewhere O(h²).
    err = np.linalg.norm(grad - fd, axis=1)
    assert err.max() < 1e-6, err.max()
    assert np.median(err) < 1e-9


def test_gradient_matches_finite_differences_with_the_cli_defaults():
    rng = np.random.default_rng(8)
    normals = rng.normal(size=(20000, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    points = 0.7 * normals + [0.2, -0.1, 0.3]
    mpu = psi.Mpu(points, normals)
    # A sphere's normals turn slowly: no sharp (piecewise) fits, so f is C1 everywhere.
    assert mpu.report["fits"]["edge"] == 0 and mpu.report["fits"]["corner"] == 0
    x = near_surface(points, normals, 200, 0.02, seed=9)
    _, grad = mpu.value_and_gradient(x)
    fd = central_differences(mpu, x, 1e-6 * mpu.diagonal)
    assert np.linalg.norm(grad - fd, axis=1).max() < 1e-8  # O(h²) with h = 1e-6 D


def test_the_value_is_a_distance_near_the_surface(smooth_torus):
    mpu, points, normals = smooth_torus
    rng = np.random.default_rng(6)
    pick = rng.integers(0, len(points), 300)
    d = rng.uniform(-0.02, 0.02, 300)
    f, grad = mpu.value_and_gradient(points[pick] + d[:, None] * normals[pick])
    assert np.abs(f - d).max() < 2e-3
    assert np.abs(np.linalg.norm(grad, axis=1) - 1).max() < 0.1
    assert (np.einsum("ij,ij->i", grad, normals[pick]) > 0.9).all()


def test_batch_equals_the_rust_evaluation_in_the_sampling_report(
    builtin_mpu, builtin_particles
):
    # The sampler measured max and mean |f|/|∇f|/D over its particles in Rust.
    after = builtin_particles.report["particles"]["after"]
    f, grad = builtin_mpu.value_and_gradient(builtin_particles.positions)
    length = np.sqrt(grad[:, 0] ** 2 + grad[:, 1] ** 2 + grad[:, 2] ** 2)
    adherence = np.abs(f) / np.maximum(length, 1e-300) / builtin_mpu.diagonal
    assert adherence.max() == pytest.approx(after["max_surface_distance"], rel=1e-12)
    assert adherence.mean() == pytest.approx(after["mean_surface_distance"], rel=1e-9)


def test_one_point_and_a_batch_agree_and_value_is_the_first_half(builtin_mpu):
    x = np.random.default_rng(1).uniform(-1.5, 1.5, (50, 3))
    f, grad = builtin_mpu.value_and_gradient(x)
    for i in (0, 17, 49):
        fi, gi = builtin_mpu.value_and_gradient(x[i])
        assert isinstance(fi, float) and fi == f[i]
        assert gi.shape == (3,) and np.array_equal(gi, grad[i])
        assert builtin_mpu.value(x[i]) == pytest.approx(fi, rel=1e-12, abs=1e-15)
        assert builtin_mpu.value_and_gradient(tuple(x[i]))[0] == fi
    assert np.allclose(builtin_mpu.value(x), f, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize(
    "convert",
    [
        lambda x: x.astype(np.float32),
        lambda x: np.asfortranarray(x),
        lambda x: x.astype(np.float32, order="F"),
        lambda x: np.repeat(x, 2, axis=0)[::2],
        lambda x: np.concatenate([np.zeros((1, 3)), x])[1:],
        lambda x: x.astype(">f8"),
        lambda x: x.tolist(),
        lambda x: np.round(x * 10).astype(np.int32),
    ],
    ids=["float32", "F-order", "float32-F", "strided", "offset-view", "big-endian", "list", "int32"],
)
def test_every_real_dtype_and_layout_gives_the_float64_result(builtin_mpu, convert):
    x = np.random.default_rng(2).uniform(-1.2, 1.2, (64, 3))
    given = convert(x)
    exact = np.asarray(given, dtype=np.float64)
    f, grad = builtin_mpu.value_and_gradient(given)
    # A fresh C-ordered float64 copy: never the array given, so a view is checked against it.
    f64, grad64 = builtin_mpu.value_and_gradient(exact.copy(order="C"))
    assert np.array_equal(f, f64) and np.array_equal(grad, grad64)


def test_points_of_any_layout_build_the_same_mpu():
    points, normals = torus(3000, seed=12)
    a = psi.Mpu(points, normals)
    b = psi.Mpu(np.asfortranarray(points), normals.astype(np.float32).astype(np.float64))
    c = psi.Mpu(points.tolist(), np.asfortranarray(normals))
    x = points[:100] * 1.01
    fa, ga = a.value_and_gradient(x)
    fc, gc = c.value_and_gradient(x)
    assert np.array_equal(fa, fc) and np.array_equal(ga, gc)
    fb, gb = b.value_and_gradient(x)  # normals rounded to float32: nearly the same surface
    assert np.allclose(fa, fb, atol=1e-5) and np.allclose(ga, gb, atol=1e-2)


def progress_while(work):
    """How many times the calling thread could count while ``work`` ran in another thread."""
    done = threading.Event()

    def run():
        try:
            work()
        finally:
            done.set()

    thread = threading.Thread(target=run)
    count = 0
    start = time.perf_counter()
    thread.start()
    while not done.is_set():
        count += 1
    thread.join()
    return count, time.perf_counter() - start


@pytest.mark.parametrize("what", ["build", "sample", "evaluate", "edit"])
def test_the_interpreter_runs_while_rust_works(builtin_mpu, what):
    model = psi.builtin_model()
    scene = psi.Scene(model, iterations=10) if what == "edit" else None
    x = np.random.default_rng(3).uniform(-1.2, 1.2, (300000, 3))
    work = {
        "build": lambda: psi.Mpu(model),
        "sample": lambda: psi.sample(builtin_mpu, iterations=40),
        "evaluate": lambda: builtin_mpu.value_and_gradient(x),
        "edit": lambda: scene.brush([0.3, 0.3, 0.3], 0.3, [0, 0, 0.03]),
    }[what]
    count, seconds = progress_while(work)
    # With the interpreter held, this thread could not count at all until the work ended
    # (bar the switch before the call); released, it counts freely, far more than 1000 times
    # per 10 ms.
    assert seconds > 0.005
    assert count > 1000 * seconds * 100, (count, seconds)
