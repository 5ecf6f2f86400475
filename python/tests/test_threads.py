"""A Scene used from several threads at once: no error ("Already borrowed" or any other), every
edit numbered once, and the final state is exactly the serial replay of the edits in the order
the scene numbered them."""

import threading
import time

import numpy as np

import psi

THREADS = 4
SECONDS = 2.0
DETERMINISTIC = ("marked_cells", "refit_cells", "particles_removed", "particles_regenerated",
                 "points", "full_rebuild", "edit")


def particles_of(scene):
    p = scene.particles
    return p.positions, p.normals, p.depth, p.sigma


def run_threads(work):
    """Runs ``work(i)`` in ``THREADS`` threads; returns the exceptions they raised."""
    errors = []

    def guarded(i):
        try:
            work(i)
        except BaseException as e:  # noqa: B036 - everything counts
            errors.append(e)

    threads = [threading.Thread(target=guarded, args=(i,), daemon=True) for i in range(THREADS)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=SECONDS + 120)
        assert not t.is_alive(), "a thread is stuck: deadlock?"
    return errors


def test_threads_brushing_and_reading_end_in_a_serial_order():
    model = psi.builtin_model(20000)
    scene = psi.Scene(model, iterations=5)
    anchors = scene.points  # brush centres on the surface
    applied = {}  # edit number -> (brush arguments, report)
    reads = [0] * THREADS
    lock = threading.Lock()
    end = time.monotonic() + SECONDS

    def work(i):
        rng = np.random.default_rng(100 + i)
        while time.monotonic() < end:
            if rng.random() < 0.5:
                direction = rng.normal(size=3)
                centre = anchors[rng.integers(len(anchors))]
                brush = (tuple(centre), 0.12, tuple(0.004 * direction / np.linalg.norm(direction)))
                report = scene.brush(*brush)
                with lock:
                    assert report["edit"] not in applied, report
                    applied[report["edit"]] = (brush, report)
            else:
                positions, normals, depth, sigma = particles_of(scene)
                n = len(positions)
                assert normals.shape == (n, 3) and depth.shape == sigma.shape == (n,)
                assert np.allclose(np.linalg.norm(normals, axis=1), 1)
                points, point_normals = scene.points, scene.normals
                assert points.shape[1] == point_normals.shape[1] == 3
                assert np.isfinite(scene.mpu.value(points[:50])).all()
                reads[i] += 1

    errors = run_threads(work)
    assert not errors, errors
    assert sorted(applied) == list(range(len(applied))), sorted(applied)
    assert len(applied) >= 4 and sum(reads) >= 4, (len(applied), reads)
    assert scene.edits == len(applied)

    # The same brushes, one after another in the scene's order, on a fresh scene.
    serial = psi.Scene(model, iterations=5)
    for number in range(len(applied)):
        brush, report = applied[number]
        again = serial.brush(*brush)
        assert {k: again[k] for k in DETERMINISTIC} == {k: report[k] for k in DETERMINISTIC}
    assert np.array_equal(serial.points, scene.points)
    assert np.array_equal(serial.normals, scene.normals)
    for a, b in zip(particles_of(serial), particles_of(scene)):
        assert a.dtype == b.dtype and np.array_equal(a, b)


def test_threads_reading_an_unchanged_scene_see_the_same_state():
    scene = psi.Scene(psi.builtin_model(10000), iterations=3)
    expected = particles_of(scene)
    points = scene.points
    x = points[::7] * 1.01
    f = scene.mpu.value(x)
    seen = []

    def work(i):
        for _ in range(20):
            got = particles_of(scene)
            assert all(np.array_equal(a, b) for a, b in zip(got, expected))
            assert np.array_equal(scene.points, points)
            assert np.array_equal(scene.mpu.value(x), f)
            seen.append(i)

    errors = run_threads(work)
    assert not errors, errors
    assert len(seen) == 20 * THREADS
