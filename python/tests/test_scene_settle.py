"""Edits as interactive frames: ``settle=False`` runs a few relaxation iterations, ``settle()``
the rest; a session of such edits gives bitwise the particles of the same session settled at
once (the oracle), and a pickle holds the settled scene."""

import pickle

import numpy as np

import psi


def bits(scene):
    p = scene.particles
    return p.positions.tobytes() + p.normals.tobytes() + p.depth.tobytes()


STROKES = [((0.3, 0.3, 0.3), 0.25, (0.0, 0.0, 0.02)), ((0.35, 0.3, 0.28), 0.25, (0.0, 0.01, 0.0))]


def test_deferred_edits_equal_settled_ones_bitwise():
    eager = psi.Scene(psi.builtin_model(6000), iterations=10)
    for s in STROKES:
        report = eager.brush(*s)
        assert report["pending_iterations"] == 0
    deferred = psi.Scene(psi.builtin_model(6000), iterations=10)
    before = bits(deferred)
    first = deferred.brush(*STROKES[0], settle=False, frame_iterations=3)
    assert first["pending_iterations"] == 7 == deferred.pending_iterations
    assert first["particles_regenerated"] > 0 and bits(deferred) != before
    step = deferred.settle(2)
    assert step["iterations"] == 2 and step["pending_iterations"] == 5
    # The next edit first finishes what is left of this one.
    second = deferred.brush(*STROKES[1], settle=False, frame_iterations=1)
    assert second["settle_seconds"] > 0 and second["pending_iterations"] == 9
    rest = deferred.settle()
    assert rest["iterations"] == 9 and deferred.pending_iterations == 0
    assert deferred.settle()["iterations"] == 0
    assert bits(deferred) == bits(eager)


def test_a_pickle_of_a_settling_scene_holds_it_settled():
    scene = psi.Scene(psi.builtin_model(6000), iterations=6)
    settled = psi.Scene(psi.builtin_model(6000), iterations=6)
    scene.brush(*STROKES[0], settle=False, frame_iterations=2)
    settled.brush(*STROKES[0])
    again = pickle.loads(pickle.dumps(scene))
    assert again.pending_iterations == 0 == scene.pending_iterations
    assert bits(again) == bits(settled) == bits(scene)
    assert np.array_equal(again.points, settled.points)
