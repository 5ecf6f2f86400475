"""``pickle`` round trips of PointSet, Mpu, Particles and Scene are bitwise: the same arrays
(values and dtypes), the same f and ∇f at random points (``==``, not a tolerance), the same
reports, lengths and reprs; a scene after edits comes back with the same points, particles
and MPU (a scene's MPU is bitwise a build from scratch of its points), and edits the same way
afterwards."""

import pickle

import numpy as np
import pytest

import psi
from conftest import sphere, torus

PROTOCOLS = [2, pickle.HIGHEST_PROTOCOL]


def round_trip(obj, protocol=pickle.HIGHEST_PROTOCOL):
    again = pickle.loads(pickle.dumps(obj, protocol=protocol))
    assert type(again) is type(obj) and again is not obj
    return again


def same_array(a, b):
    assert isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape
    assert np.array_equal(a, b)
    assert a.tobytes() == b.tobytes()  # bitwise, -0.0 and all


def queries(mpu, n=500, seed=7):
    """Random points in and around the MPU's bounding box."""
    lo, hi = mpu.bbox
    pad = 0.1 * (hi - lo)
    return np.random.default_rng(seed).uniform(lo - pad, hi + pad, (n, 3))


def same_mpu(a, b, same_build=True):
    """``a`` and ``b`` evaluate and describe alike; with ``same_build`` (a round trip) their
    build reports (timings included) are equal too."""
    x = queries(a)
    same_array(a.value(x), b.value(x))
    fa, ga = a.value_and_gradient(x)
    fb, gb = b.value_and_gradient(x)
    same_array(fa, fb)
    same_array(ga, gb)
    assert a.value(tuple(x[0])) == b.value(tuple(x[0]))
    for name in ("points", "normals", "bbox"):
        same_array(getattr(a, name), getattr(b, name))
    for name in ("leaves", "surface_leaves", "max_depth", "diagonal", "error", "error_source",
                 "params", "frame"):
        assert getattr(a, name) == getattr(b, name), name
    assert repr(a) == repr(b)
    if same_build:
        assert a.report == b.report
    else:
        assert {k: v for k, v in a.report.items() if not k.endswith("seconds")} == {
            k: v for k, v in b.report.items() if not k.endswith("seconds")}


@pytest.mark.parametrize("protocol", PROTOCOLS)
def test_point_set(tmp_path, protocol):
    points, normals = torus(3000, seed=31)
    np.savetxt(tmp_path / "t.xyz", points[:2000], fmt="%.17g")
    for ps in (psi.PointSet(points, normals), psi.load_points(tmp_path / "t.xyz"),
               psi.builtin_model(5000)):
        again = round_trip(ps, protocol)
        same_array(ps.points, again.points)
        same_array(ps.normals, again.normals)
        assert again.report == ps.report and again.error == ps.error
        assert (len(again), again.points_read, again.name) == (len(ps), ps.points_read, ps.name)
        assert repr(again) == repr(ps)
        # The PointSet is as good as new: the same MPU from both.
        if ps.name == "points":
            same_mpu(psi.Mpu(ps), psi.Mpu(again), same_build=False)


@pytest.mark.parametrize("protocol", PROTOCOLS)
def test_mpu_with_default_and_given_options(protocol):
    points, normals = torus(4000, seed=32)
    for mpu in (
        psi.Mpu(points, normals),
        psi.Mpu(points, normals, error=0.01, max_depth=8, smooth=True, scale_invariant=True),
        # Normals of any length, not preprocessed: rebuilt from the points as given.
        psi.Mpu(points, 2.5 * normals, preprocess=False),
        psi.Mpu(psi.builtin_model(6000)),
    ):
        same_mpu(mpu, round_trip(mpu, protocol))


def test_mpu_built_in_another_frame_keeps_it():
    points, normals = sphere(3000, seed=33)
    wide = psi.Mpu(np.vstack([points, 3 * points]), np.vstack([normals, normals]))
    mpu = psi.Mpu(points, normals, frame=wide.frame)
    assert mpu.frame == wide.frame != psi.Mpu(points, normals).frame
    same_mpu(mpu, round_trip(mpu))


def same_particles(a, b):
    assert len(a) == len(b) and repr(a) == repr(b) and a.report == b.report
    for name in ("positions", "normals", "depth", "sigma"):
        x, y = getattr(a, name), getattr(b, name)
        if x is None:
            assert y is None, name
        else:
            same_array(x, y)


@pytest.mark.parametrize("protocol", PROTOCOLS)
def test_particles(protocol):
    mpu = psi.Mpu(psi.builtin_model(6000))
    sampled = psi.sample(mpu, iterations=5)
    assert sampled.report is not None
    given = psi.Particles(sampled.positions, sampled.normals, depth=sampled.depth,
                          sigma=sampled.sigma)
    bare = psi.Particles(sampled.positions[:500])  # normals estimated, no depth or sigma
    scene = psi.Scene(psi.builtin_model(6000), iterations=3).particles
    for p in (sampled, given, bare, scene):
        same_particles(p, round_trip(p, protocol))


def same_scene(a, b):
    same_array(a.points, b.points)
    same_array(a.normals, b.normals)
    same_particles(a.particles, b.particles)
    assert a.report == b.report and repr(a) == repr(b)
    x = queries(a.mpu, 1000, seed=35)
    assert np.array_equal(a.mpu.value(x), b.mpu.value(x))
    fa, ga = a.mpu.value_and_gradient(x)
    fb, gb = b.mpu.value_and_gradient(x)
    assert np.array_equal(fa, fb) and np.array_equal(ga, gb)
    assert a.mpu.frame == b.mpu.frame
    assert a.mpu.report == b.mpu.report


def edits(scene):
    """Four edits of every kind; the same ones on scenes in the same state."""
    points = scene.points
    return [
        scene.brush((0.3, 0.3, 0.3), 0.25, (0.0, 0.0, 0.02)),
        scene.remove(points[len(points) // 3], 0.08),
        scene.insert([[1.3, 0.0, 0.1], [1.3, 0.02, 0.1]], [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]),
        scene.brush((-0.3, 0.5, 0.1), 0.2, (0.01, -0.01, 0.0)),
    ]


@pytest.mark.parametrize("protocol", PROTOCOLS)
def test_scene_after_edits(protocol):
    scene = psi.Scene(psi.builtin_model(8000), iterations=5)
    fresh = round_trip(scene, protocol)
    same_scene(scene, fresh)
    reports = edits(scene)
    assert [r["edit"] for r in reports] == [0, 1, 2, 3]
    again = round_trip(scene, protocol)
    same_scene(scene, again)
    assert again.edits == scene.edits == 4 and fresh.edits == 0
    # The same brush on both gives bitwise the same particles, and the next edit number.
    brush = ((0.1, -0.4, 0.2), 0.2, (0.0, 0.01, 0.0))
    a, b = scene.brush(*brush), again.brush(*brush)
    assert a["edit"] == b["edit"] == 4
    same_array(scene.points, again.points)
    same_particles(scene.particles, again.particles)
    # The scene pickled before the edits, edited the same way, arrives at the same state.
    edits(fresh)
    fresh.brush(*brush)
    same_array(scene.points, fresh.points)
    same_particles(scene.particles, fresh.particles)


def test_a_scene_mpu_pickles_in_the_scene_frame():
    scene = psi.Scene(psi.builtin_model(6000), iterations=3)
    scene.brush((0.3, 0.3, 0.3), 0.25, (0.0, 0.0, 0.02))
    mpu = scene.mpu
    again = round_trip(mpu)
    assert again.frame == mpu.frame
    x = queries(mpu, 1000, seed=36)
    assert np.array_equal(again.value(x), mpu.value(x))
    assert again.report == mpu.report
    same_array(mpu.points, again.points)


def test_a_scene_mpu_equals_a_build_from_scratch_in_its_frame():
    scene = psi.Scene(psi.builtin_model(8000), iterations=3)
    points = scene.points
    rng = np.random.default_rng(37)
    for i in range(5):
        centre = points[rng.integers(len(points))]
        scene.brush(centre, 0.2, 0.01 * rng.normal(size=3) / np.sqrt(3))
    mpu = scene.mpu
    assert isinstance(mpu, psi.Mpu)
    frame = mpu.frame
    assert set(frame) == {"origin", "root_center", "root_half", "diagonal"}
    scratch = psi.Mpu(scene.points, scene.normals, preprocess=False, frame=frame)
    assert scratch.frame == frame
    same_array(scratch.points, mpu.points)
    # Random points near the surface: the scene's particles moved off it a little.
    p = scene.particles
    near = p.positions + rng.uniform(-0.02, 0.02, (len(p), 1)) * p.normals
    assert np.abs(scratch.value(near) - mpu.value(near)).max() <= 1e-12
    # Not so without the frame: the points' own frame is another octree.
    own = psi.Mpu(scene.points, scene.normals, preprocess=False)
    assert own.frame != frame


def test_a_frame_is_a_dict_of_points_and_lengths():
    scene = psi.Scene(psi.builtin_model(5000), iterations=2)
    for mpu in (scene.mpu, psi.Mpu(*sphere(2000, seed=38))):
        frame = mpu.frame
        assert set(frame) == {"origin", "root_center", "root_half", "diagonal"}
        for key in ("origin", "root_center"):
            assert isinstance(frame[key], tuple) and len(frame[key]) == 3, frame
            assert all(isinstance(v, float) for v in frame[key]), frame
        assert isinstance(frame["root_half"], float) and frame["root_half"] > 0
        assert frame["diagonal"] == pytest.approx(mpu.diagonal, rel=0.1)
        # The root cube holds the points.
        local = mpu.points - np.asarray(frame["origin"]) - np.asarray(frame["root_center"])
        assert np.abs(local).max() <= frame["root_half"]
