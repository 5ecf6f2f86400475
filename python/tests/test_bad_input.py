"""Every bad input raises ValueError or OSError — with the CLI's message where the CLI can be
given the same input — and nothing crashes the interpreter."""

import numpy as np
import pytest

import psi
from conftest import cli_error, run_cli, torus


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("bad")
    (d / "empty.xyz").write_text("")
    (d / "nan.xyz").write_text("0 0 0 0 0 1\n1 0 nan 0 0 1\n")
    (d / "zero.xyz").write_text("0 0 0 0 0 0\n1 0 0 0 0 0\n")
    (d / "three.xyz").write_text("0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n")
    (d / "coincide.xyz").write_text("1 1 1 0 0 1\n" * 40)
    (d / "broken.ply").write_bytes(b"ply\nformat ascii 1.0\nelement vertex 3\nend_header\n")
    (d / "truncated.ply").write_bytes(
        b"ply\nformat binary_little_endian 1.0\nelement vertex 9\nproperty float x\n"
        b"property float y\nproperty float z\nend_header\n\x00\x00"
    )
    return d


@pytest.mark.parametrize("name", ["no-such-file.ply", "no/such/dir/x.xyz"])
def test_a_missing_file_raises_file_not_found_with_the_cli_message(cli, files, name):
    path = files / name
    with pytest.raises(FileNotFoundError) as e:
        psi.load_points(path)
    assert str(e.value) == cli_error(cli, "info", path)
    assert isinstance(e.value, OSError) and e.value.errno == 2


def test_a_directory_raises_os_error_with_the_cli_message(cli, files):
    with pytest.raises(OSError) as e:
        psi.load_points(files)
    assert str(e.value) == cli_error(cli, "info", files)


@pytest.mark.parametrize("name", ["empty.xyz", "nan.xyz", "zero.xyz", "broken.ply", "truncated.ply"])
def test_a_malformed_file_raises_value_error_with_the_cli_message(cli, files, name):
    with pytest.raises(ValueError) as e:
        psi.load_points(files / name)
    assert str(e.value) == cli_error(cli, "info", files / name)


@pytest.mark.parametrize("name", ["three.xyz", "coincide.xyz"])
def test_too_few_or_coincident_points_raise_value_error_with_the_cli_message(cli, files, name):
    with pytest.raises(ValueError) as e:
        psi.Mpu(psi.load_points(files / name))
    assert str(e.value) == cli_error(cli, "sample", files / name)
    with pytest.raises(ValueError) as e:
        psi.Scene(psi.load_points(files / name))
    assert str(e.value) == cli_error(cli, "edit", files / name, "--remove=0,0,0,1", "-o",
                                     files / "out.ply")


def test_bad_options_raise_value_error_with_the_cli_reasons(cli, files):
    mpu = psi.Mpu(psi.builtin_model(3000))
    for call, flag, value in [
        (lambda: psi.sample(mpu, k=0), "--k", "0"),
        (lambda: psi.sample(mpu, k=65), "--k", "65"),
        (lambda: psi.sample(mpu, count=0), "--count", "0"),
        (lambda: psi.sample(mpu, iterations=100001), "--iterations", "100001"),
    ]:
        with pytest.raises(ValueError) as e:
            call()
        # The CLI's parser says `error: invalid value 'V' for '--flag <F>': <reason>`.
        done = run_cli(cli, "sample", f"{flag}={value}", expect_ok=False)
        line = next(l for l in done.stderr.splitlines() if l.startswith("error: "))
        assert done.returncode == 2
        assert line.endswith(": " + str(e.value).split(": ", 1)[1]), (line, str(e.value))


ARRAY_CASES = {
    "too few": (np.eye(3), np.eye(3), "3 oriented points are too few for an MPU; at least 16"),
    "none": (np.zeros((0, 3)), None, "no usable oriented points"),
    "coincident": (np.ones((30, 3)), np.ones((30, 3)), "all points coincide"),
    "2 columns": (np.zeros((30, 2)), None, "points must have shape (N, 3), got (30, 2)"),
    "1-D": (np.zeros(30), None, "points must have shape (N, 3), got (30,)"),
    "3-D": (np.zeros((2, 5, 3)), None, "points must have shape (N, 3), got (2, 5, 3)"),
    "normals shape": (np.random.rand(30, 3), np.zeros((29, 3)), "normals must have the shape"),
    "normals 2-D": (np.random.rand(30, 3), np.zeros(3), "normals must have shape (N, 3)"),
    "NaN": (np.where(np.eye(30, 3) > 0, np.nan, 1.0), None, "point 0 has a NaN or infinite position"),
    "inf normal": (np.random.rand(30, 3), np.full((30, 3), np.inf), "point 0 has a NaN or infinite normal"),
    "zero normals": (np.random.rand(30, 3), np.zeros((30, 3)), "30 points with zero normal"),
    "complex": (np.zeros((30, 3), complex), None, "must hold real numbers"),
    "bool": (np.zeros((30, 3), bool), None, "must hold real numbers"),
    "text": ("abc", None, "points is not an array of numbers"),
    "ragged": ([[0, 0, 0], [1, 1]], None, "points is not an array of numbers"),
}


@pytest.mark.parametrize("case", ARRAY_CASES, ids=list(ARRAY_CASES))
def test_bad_arrays_raise_value_error_everywhere(case):
    points, normals, message = ARRAY_CASES[case]
    # A PointSet of too few or coincident points is fine; the MPU refuses it.
    makers = (psi.Mpu, psi.Scene) if case in ("too few", "coincident") else (
        psi.Mpu, psi.Scene, psi.PointSet)
    for make in makers:
        with pytest.raises(ValueError, match=None) as e:
            make(points, normals)
        assert message in str(e.value), (make, str(e.value))


def test_normals_are_required_without_preprocessing():
    points, _ = torus(100, seed=1)
    with pytest.raises(ValueError, match="the points have no normals"):
        psi.Mpu(points, preprocess=False)
    with pytest.raises(ValueError, match="the points have no normals"):
        psi.PointSet(points, estimate_normals=False)
    with pytest.raises(ValueError, match="a PointSet carries its normals"):
        psi.Mpu(psi.PointSet(*torus(100, seed=1)), np.zeros((100, 3)))


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"error": 0.0}, "error: 0 is not in (0, 1]"),
        ({"error": 1.5}, "error: 1.5 is not in (0, 1]"),
        ({"error": float("nan")}, "error: NaN is not in (0, 1]"),
        ({"max_depth": 17}, "max_depth: 17 is not in 0..=16"),
        ({"max_depth": -1}, "max_depth: -1 is not in 0..=16"),
    ],
)
def test_bad_mpu_options_raise_value_error(kwargs, message):
    with pytest.raises(ValueError) as e:
        psi.Mpu(psi.builtin_model(2000), **kwargs)
    assert str(e.value) == message


def test_bad_queries_and_sampling_options_raise_value_error():
    mpu = psi.Mpu(psi.builtin_model(3000))
    for x, message in [
        (np.zeros((4, 2)), "x must have shape (3,) or (..., 3), got (4, 2)"),
        (np.zeros(4), "x must have shape (3,) or (..., 3), got (4,)"),
        (np.zeros((1, 3, 2)), "x must have shape (3,) or (..., 3), got (1, 3, 2)"),
        (np.zeros(()), "x must have shape (3,) or (..., 3), got ()"),
        (np.array([[0, 0, 0], [0, np.nan, 0]]), "x: point 1 has a NaN or infinite coordinate"),
        (np.array([0, np.inf, 0]), "x: point 0 has a NaN or infinite coordinate"),
    ]:
        for f in (mpu.value_and_gradient, mpu.value):
            with pytest.raises(ValueError) as e:
                f(x)
            assert str(e.value) == message
    for kwargs, message in [
        ({"seed": -1}, "seed: -1 is not in 0..=18446744073709551615"),
        ({"k": -3}, "k: -3 is not in 1..=64"),
        ({"count": -1}, "count: -1 is not in 1..=50000000"),
    ]:
        with pytest.raises(ValueError) as e:
            psi.sample(mpu, **kwargs)
        assert str(e.value) == message
    with pytest.raises(ValueError, match="resolution: 1 is not in 2..=2048"):
        mpu.mesh(resolution=1)
    with pytest.raises(ValueError, match="points: 0 is not in 1..=50000000"):
        psi.builtin_model(0)


def test_bad_edits_raise_value_error_and_leave_the_scene_unchanged():
    scene = psi.Scene(psi.builtin_model(5000), iterations=5)
    before = scene.particles.positions
    for edit, message in [
        (lambda: scene.brush([0, 0, 0], -1.0, [0, 0, 1]), "applying an edit: bad edit: a brush needs"),
        (lambda: scene.brush([0, np.nan, 0], 0.2, [0, 0, 1]), "its centre is [0, NaN, 0]"),
        (lambda: scene.brush([0, 0, 0], 0.2, [0, np.inf, 1]), "its displacement is [0, inf, 1]"),
        (lambda: scene.brush([1.3, 0, 0], 0.3, [5, 0, 0]), "the brush folds the surface"),
        (lambda: scene.brush([0, 0], 0.3, [0, 0, 1]), "centre must have shape (3,), got (2,)"),
        (lambda: scene.remove([0, 0, 0], float("inf")), "a removal needs a finite centre"),
        (lambda: scene.remove([0, 0, 0], 100.0), "0 oriented points are too few"),
        (lambda: scene.insert([[0, 0, np.nan]], [[0, 0, 1]]), "point 0 has a NaN or infinite position"),
        (lambda: scene.insert([[0, 0, 0]], [[0, 0, 1], [0, 0, 1]]), "normals"),
    ]:
        with pytest.raises(ValueError) as e:
            edit()
        assert message in str(e.value), str(e.value)
    assert np.array_equal(scene.particles.positions, before)


def test_bad_render_arguments_and_unwritable_outputs(tmp_path, builtin_particles):
    p = builtin_particles
    for kwargs, message in [
        ({"size": 8}, "size: 8 is not in 16..=8192"),
        ({"view": "up"}, 'view: "up" is not one of'),
        ({"color": "red"}, 'color: "red" is not one of'),
        ({"style": "fog"}, 'style: "fog" is not one of'),
        ({"splat_scale": 0.0}, "splat_scale must be a positive number"),
    ]:
        with pytest.raises(ValueError, match=None) as e:
            psi.render(p, **kwargs)
        assert message in str(e.value)
    v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    with pytest.raises(ValueError, match="refers to vertex 7"):
        psi.render_mesh(v, [[0, 1, 7]])
    with pytest.raises(ValueError, match="face 0 has an index that is not a vertex number"):
        psi.render_mesh(v, [[0, 1, -2]])
    with pytest.raises(ValueError, match="vertex 1 has a NaN"):
        psi.render_mesh([[0, 0, 0], [np.nan, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    missing = tmp_path / "no" / "such" / "dir"
    with pytest.raises(FileNotFoundError, match="cannot write"):
        psi.save_particles(missing / "p.ply", p)
    with pytest.raises(FileNotFoundError, match="cannot write"):
        psi.render(p, missing / "p.png", size=16)
    existing = tmp_path / "keep.ply"
    existing.write_bytes(b"old")
    with pytest.raises(IsADirectoryError):
        psi.save_particles(tmp_path, p)
    assert existing.read_bytes() == b"old"


def test_a_panic_becomes_a_runtime_error():
    with pytest.raises(RuntimeError, match="psi: internal error"):
        psi._psi._panic_for_tests()
    # The interpreter and the package still work afterwards.
    assert len(psi.PointSet(*torus(500, seed=2))) == 500


def test_points_that_make_no_surface_say_so(cli, tmp_path):
    line = np.outer(np.arange(40.0), [1.0, 2.0, 3.0])
    for points, words in [(np.zeros((40, 3)), "all points coincide"),
                          (line, "all points lie on one straight line")]:
        for normals in (None, np.tile([0.0, 0.0, 1.0], (40, 1))):
            with pytest.raises(ValueError) as e:
                psi.PointSet(points, normals)
            assert words in str(e.value) and "too few" not in str(e.value)
        path = tmp_path / "degenerate.xyz"
        np.savetxt(path, points)
        assert words in cli_error(cli, "sample", path)
