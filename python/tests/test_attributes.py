"""Colours, intensities and LAS classes through the package: in with points (arrays or files),
carried by preprocessing, sampling (each particle the weighted mean of the input points near it
on its side), edits and pickles, out as read-only arrays, drawn by ``render(color="input")``.
The oracle for the colours is the noiseless function the points were coloured with."""

import pickle

import numpy as np
import pytest

import psi
from conftest import model, sphere


def truth(p):
    """Colour channels spanning 0-255 over the unit sphere."""
    return np.clip(127.5 * (1.0 + np.c_[p[:, 0], p[:, 1], -p[:, 2]]), 0, 255)


def noisy_colours(points, seed):
    rng = np.random.default_rng(seed)
    noise = rng.uniform(-20, 20, points.shape)
    return np.clip(np.round(truth(points) + noise), 0, 255).astype(np.uint8)


def test_colours_follow_the_noiseless_function_at_the_particles():
    # About 180 points per particle: the mean of a disk's points is then well inside 3 %.
    points, normals = sphere(100000, seed=61)
    colors = noisy_colours(points, 62)
    ps = psi.PointSet(points, normals, colors=colors, intensity=np.arange(len(points)),
                      classification=np.full(len(points), 2))
    assert ps.colors.dtype == np.uint8 and ps.colors.shape == (len(ps), 3)
    assert not ps.colors.flags.writeable
    p = psi.sample(psi.Mpu(ps))
    assert p.colors.shape == (len(p), 3) and p.colors.dtype == np.uint8
    error = np.abs(p.colors.astype(float) - truth(p.positions)) / 255.0
    assert np.quantile(error, 0.99) <= 0.03, np.quantile(error, 0.99)
    # Copying the nearest point's colour (brute force) must fail the same bound.
    nearest = np.concatenate([
        np.argmin(((chunk[:, None, :] - points[None, :, :]) ** 2).sum(-1), axis=1)
        for chunk in np.array_split(p.positions, max(1, len(p) // 16))
    ])
    copied = np.abs(colors[nearest].astype(float) - truth(p.positions)) / 255.0
    assert np.quantile(copied, 0.99) > 0.03
    assert p.classification is not None and set(np.unique(p.classification)) == {2}
    assert p.intensity.dtype == np.float32 and len(p.intensity) == len(p)


def test_two_halves_do_not_mix_away_from_their_boundary():
    points, normals = sphere(30000, seed=63)
    left = points[:, 0] < 0
    colors = np.where(left[:, None], [255, 0, 0], [0, 0, 255]).astype(np.uint8)
    p = psi.sample(psi.Mpu(psi.PointSet(points, normals, colors=colors)))
    spacing = 2.0 * p.sigma
    far = np.abs(p.positions[:, 0]) > spacing
    assert far.sum() > len(p) // 2
    want = np.where((p.positions[:, 0] < 0)[:, None], [255, 0, 0], [0, 0, 255])
    assert np.array_equal(p.colors[far], want[far])


def test_attributes_survive_pickles_scenes_and_rendering(tmp_path):
    points, normals = sphere(8000, seed=64)
    colors = noisy_colours(points, 65)
    ps = psi.PointSet(points, normals, colors=colors)
    again = pickle.loads(pickle.dumps(ps))
    assert np.array_equal(again.colors, ps.colors)
    p = psi.sample(psi.Mpu(ps), iterations=5)
    back = pickle.loads(pickle.dumps(p))
    assert np.array_equal(back.colors, p.colors)
    image = psi.render(p, color="input", size=64)
    assert image.shape == (64, 64, 4)
    with pytest.raises(ValueError):
        psi.render(psi.Particles(points[:100], normals[:100]), color="input", size=64)

    scene = psi.Scene(ps, iterations=3)
    assert scene.particles.colors.shape == (len(scene.particles), 3)
    scene.brush(points[0], 0.3, 0.02 * normals[0])
    assert scene.particles.colors.shape == (len(scene.particles), 3)
    scene.insert([[1.05, 0.0, 0.0]], [[1.0, 0.0, 0.0]], colors=[[0, 255, 0]])
    assert scene.mpu.points.shape[0] == len(points) + 1
    restored = pickle.loads(pickle.dumps(scene))
    assert np.array_equal(restored.particles.colors, scene.particles.colors)
    # Colours given for a different number of points are refused.
    with pytest.raises(ValueError):
        psi.PointSet(points, normals, colors=colors[:10])
    with pytest.raises(ValueError):
        psi.PointSet(points, normals, colors=colors.astype(float) + 0.5)


def test_a_laz_with_colours_gives_the_particles_of_its_points_as_xyz(tmp_path):
    laspy = pytest.importorskip("laspy", reason="laspy (PyPI) writes the LAZ file")
    pytest.importorskip("lazrs", reason="lazrs (PyPI) compresses LAZ for laspy")
    bunny = psi.load_points(model("bunny.ply"), keep_outliers=True)
    xyz = np.asarray(bunny.points)
    header = laspy.LasHeader(point_format=7, version="1.4")
    header.scales = np.array([1e-6, 1e-6, 1e-6])
    header.offsets = np.round(xyz.mean(axis=0), 3)
    las = laspy.LasData(header)
    las.x, las.y, las.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    rgb = (np.clip(127.5 * (1 + (xyz - xyz.mean(0)) / np.abs(xyz - xyz.mean(0)).max()), 0, 255)
           .astype(np.uint16))
    las.red, las.green, las.blue = rgb[:, 0] * 257, rgb[:, 1] * 257, rgb[:, 2] * 257
    laz = tmp_path / "bunny.laz"
    las.write(str(laz))
    read = laspy.read(str(laz))
    stored = np.c_[read.x, read.y, read.z]
    text = tmp_path / "bunny.xyz"
    np.savetxt(text, stored, fmt="%.17g")
    a = psi.load_points(laz)
    b = psi.load_points(text)
    assert np.array_equal(np.asarray(a.points), np.asarray(b.points))
    assert a.colors is not None and b.colors is None
    pa, pb = psi.sample(psi.Mpu(a)), psi.sample(psi.Mpu(b))
    assert np.array_equal(pa.positions, pb.positions)
    assert pa.colors is not None and pb.colors is None


def coloured_particles(n=20000, seed=66):
    points, normals = sphere(n, seed=seed)
    colors = noisy_colours(points, seed + 1)
    classes = np.where(points[:, 2] > 0, 6, 2)
    ps = psi.PointSet(points, normals, colors=colors, intensity=np.linspace(0, 1000, n),
                      classification=classes)
    return psi.sample(psi.Mpu(ps), iterations=5)


def test_particles_with_attributes_round_trip_through_ply(tmp_path):
    p = coloured_particles()
    path = tmp_path / "p.ply"
    psi.save_particles(path, p)
    back = psi.load_particles(path)
    assert np.array_equal(back.positions, p.positions)
    assert np.array_equal(back.colors, p.colors)
    assert np.array_equal(back.intensity, p.intensity)
    assert np.array_equal(back.classification, p.classification)


@pytest.mark.parametrize("suffix", ["las", "laz"])
def test_laspy_reads_psis_las_output(tmp_path, suffix):
    laspy = pytest.importorskip("laspy", reason="laspy (PyPI) reads psi's LAS/LAZ output")
    if suffix == "laz":
        pytest.importorskip("lazrs", reason="lazrs (PyPI) decompresses LAZ for laspy")
    p = coloured_particles()
    path = tmp_path / f"particles.{suffix}"
    psi.save_particles(path, p)
    las = laspy.read(str(path))
    assert len(las.points) == len(p)
    xyz = np.c_[las.x, las.y, las.z]
    half_scale = 0.5 * np.asarray(las.header.scales).max()
    assert np.abs(xyz - p.positions).max() <= half_scale * (1 + 1e-9)
    rgb = np.c_[las.red, las.green, las.blue]
    assert np.array_equal(rgb >> 8, p.colors.astype(np.uint16))
    assert np.array_equal(np.asarray(las.classification), p.classification)
    assert np.abs(np.asarray(las.intensity) - np.round(p.intensity)).max() == 0
    # And psi reads it back, colours exactly.
    back = psi.load_particles(path)
    assert np.array_equal(back.colors, p.colors)


def test_a_georeferenced_tile_samples_as_the_same_tile_at_the_origin(tmp_path):
    laspy = pytest.importorskip("laspy", reason="laspy (PyPI) writes the LAS tiles")
    points, _ = sphere(20000, seed=67, radius=20.0)
    scale = 0.001
    offset = np.array([5e5, 5e6, 100.0])
    records = np.round(points / scale).astype(np.int64)
    tiles = []
    for shift in (np.zeros(3), offset):
        header = laspy.LasHeader(point_format=3, version="1.2")
        header.scales = np.array([scale] * 3)
        header.offsets = shift
        las = laspy.LasData(header)
        las.X, las.Y, las.Z = records[:, 0], records[:, 1], records[:, 2]
        path = tmp_path / f"tile{len(tiles)}.las"
        las.write(str(path))
        tiles.append(psi.sample(psi.Mpu(psi.load_points(path))))
    at_origin, georeferenced = tiles
    assert len(at_origin) == len(georeferenced)
    d = psi.Mpu(psi.load_points(tmp_path / "tile0.las")).diagonal
    moved = georeferenced.positions - offset
    assert np.abs(moved - at_origin.positions).max() <= 1e-6 * d


@pytest.mark.parametrize("suffix", ["las", "laz"])
def test_colours_and_intensities_written_by_laspy_are_read_exactly(tmp_path, suffix):
    laspy = pytest.importorskip("laspy", reason="laspy (PyPI) writes the LAS/LAZ file")
    if suffix == "laz":
        pytest.importorskip("lazrs", reason="lazrs (PyPI) compresses LAZ for laspy")
    points, _ = sphere(5000, seed=68, radius=3.0)
    rng = np.random.default_rng(69)
    rgb = rng.integers(0, 256, (len(points), 3))
    intensity = rng.integers(0, 65536, len(points))
    classes = rng.integers(0, 32, len(points))
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.scales = np.array([1e-4] * 3)
    header.offsets = np.array([1000.0, 2000.0, 10.0])
    las = laspy.LasData(header)
    las.x, las.y, las.z = (points + header.offsets).T
    las.red, las.green, las.blue = (rgb * 256).T
    las.intensity = intensity
    las.classification = classes
    path = tmp_path / f"scan.{suffix}"
    las.write(str(path))
    stored = laspy.read(str(path))
    p = psi.load_particles(path)  # every record, in order
    assert np.array_equal(p.positions, np.c_[stored.x, stored.y, stored.z])
    assert np.array_equal(p.colors, rgb.astype(np.uint8))
    assert np.array_equal(p.intensity, intensity.astype(np.float32))
    assert np.array_equal(p.classification, classes.astype(np.uint8))


def test_colours_and_intensities_written_by_pye57_are_read_exactly(tmp_path):
    pye57 = pytest.importorskip("pye57", reason="pye57 (PyPI) writes the E57 file")
    points, _ = sphere(500, seed=70, radius=2.0)
    rng = np.random.default_rng(71)
    rgb = rng.integers(0, 256, (len(points), 3)).astype(np.uint8)
    intensity = rng.uniform(0, 1, len(points)).astype(np.float32)
    path = tmp_path / "scan.e57"
    e57 = pye57.E57(str(path), mode="w")
    e57.write_scan_raw({
        "cartesianX": points[:, 0].copy(), "cartesianY": points[:, 1].copy(),
        "cartesianZ": points[:, 2].copy(), "colorRed": rgb[:, 0].copy(),
        "colorGreen": rgb[:, 1].copy(), "colorBlue": rgb[:, 2].copy(), "intensity": intensity,
    })
    e57.close()
    stored = pye57.E57(str(path)).read_scan_raw(0)
    p = psi.load_particles(path)  # every record, in order
    assert np.array_equal(p.positions, np.c_[stored["cartesianX"], stored["cartesianY"],
                                             stored["cartesianZ"]])
    assert np.array_equal(p.colors, rgb)
    assert np.array_equal(p.intensity, intensity)
