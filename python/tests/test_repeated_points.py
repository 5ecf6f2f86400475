"""A scan whose points all come many times is prepared as the points once (the CLI's and the
library's preprocessing: repeats of a position are left out before the outlier search, which
would otherwise find every neighbour at distance 0)."""

import numpy as np

import psi
from conftest import torus


def test_repeated_points_are_prepared_as_the_points_once():
    points, normals = torus(3000, seed=4)
    once = psi.PointSet(points)
    many = psi.PointSet(np.tile(points, (20, 1)))
    assert once.report["repeated_points"] == 0
    assert many.report["repeated_points"] == 19 * len(points)
    assert np.array_equal(many.points, once.points)
    assert np.array_equal(many.normals, once.normals)
    # With normals given: the first copy's normal is kept.
    flipped = np.concatenate([normals, -np.tile(normals, (19, 1))])
    given = psi.PointSet(np.tile(points, (20, 1)), flipped)
    assert given.report["repeated_points"] == 19 * len(points)
    reference = psi.PointSet(points, normals)
    assert np.array_equal(given.points, reference.points)
    assert np.array_equal(given.normals, reference.normals)
