"""Scanner formats read through ``psi.load_points``, checked against independent writers:
LAS and LAZ written by laspy (LAZ through lazrs), E57 written by pye57, PCD written by hand.

The package does not expose colours or intensities yet, so these tests check positions and
counts only: every point read (``points_read``), and, with the steps that move or drop points
turned off, the positions equal (as sets: preprocessing works in Morton order) to the file's
quantised ones. A writer that is not installed skips its tests with the reason given.
"""

import numpy as np
import pytest

import psi
from conftest import sphere

# Normals are estimated (the files have none); nothing is moved or left out.
KEEP = dict(keep_outliers=True, denoise=False)


def sorted_rows(a):
    a = np.asarray(a, dtype=np.float64)
    return a[np.lexsort(a.T[::-1])]


def georeferenced_sphere(n=3000, seed=27):
    points, _ = sphere(n, seed, radius=10.0)
    return points + np.array([5e5, 5e6, 100.0])


@pytest.mark.parametrize(
    "suffix, version, point_format",
    [(".las", "1.2", 3), (".las", "1.4", 7), (".laz", "1.2", 3), (".laz", "1.4", 7)],
)
def test_las_and_laz_written_by_laspy_read_back(tmp_path, suffix, version, point_format):
    laspy = pytest.importorskip(
        "laspy", reason="laspy (PyPI) writes the LAS/LAZ files psi must read back"
    )
    if suffix == ".laz":
        pytest.importorskip("lazrs", reason="lazrs (PyPI) is laspy's LAZ backend")
    points = georeferenced_sphere()
    header = laspy.LasHeader(point_format=point_format, version=version)
    header.offsets = [5e5, 5e6, 100.0]
    header.scales = [0.001, 0.001, 0.001]
    las = laspy.LasData(header)
    las.x, las.y, las.z = points[:, 0], points[:, 1], points[:, 2]
    rgb = (np.arange(len(points)) % 256).astype(np.uint16) * 256
    las.red, las.green, las.blue = rgb, rgb[::-1], rgb
    las.intensity = np.arange(len(points), dtype=np.uint16)
    path = tmp_path / f"sphere{suffix}"
    las.write(path)

    back = laspy.read(path)
    expected = np.stack([back.x, back.y, back.z], axis=1)
    assert np.abs(expected - points).max() <= 0.0005 + 1e-9

    ps = psi.load_points(path, **KEEP)
    assert ps.points_read == len(points) == len(ps)
    np.testing.assert_allclose(sorted_rows(ps.points), sorted_rows(expected), rtol=0, atol=1e-9)
    assert ps.report["points_read"] == len(points)


def test_e57_written_by_pye57_reads_every_scan_under_its_pose(tmp_path):
    pye57 = pytest.importorskip("pye57", reason="pye57 (PyPI) writes the E57 files psi must read")
    a, _ = sphere(1500, 1, radius=2.0)
    b, _ = sphere(1500, 2, radius=2.0)
    shift = np.array([10.0, -4.0, 1.5])
    path = tmp_path / "two_scans.e57"
    e57 = pye57.E57(str(path), mode="w")
    for points, translation in [(a, np.zeros(3)), (b, shift)]:
        data = {
            "cartesianX": points[:, 0].copy(),
            "cartesianY": points[:, 1].copy(),
            "cartesianZ": points[:, 2].copy(),
        }
        e57.write_scan_raw(data, rotation=np.array([1.0, 0.0, 0.0, 0.0]), translation=translation)
    e57.close()

    ps = psi.load_points(path, **KEEP)
    assert ps.points_read == len(a) + len(b) == len(ps)
    # pye57 stores the coordinates as 32-bit floats: what psi must read is those values, exactly
    # (up to the pose's f64 translation).
    stored = [p.astype(np.float32).astype(np.float64) for p in (a, b)]
    expected = np.concatenate([stored[0], stored[1] + shift])
    np.testing.assert_allclose(sorted_rows(ps.points), sorted_rows(expected), rtol=0, atol=1e-12)


@pytest.mark.parametrize("encoding", ["ascii", "binary"])
def test_pcd_written_by_hand_reads_back(tmp_path, encoding):
    points, normals = sphere(2000, 3, radius=1.0)
    points = points.astype(np.float32)
    normals = normals.astype(np.float32)
    header = (
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
        "FIELDS x y z normal_x normal_y normal_z\nSIZE 4 4 4 4 4 4\nTYPE F F F F F F\n"
        f"COUNT 1 1 1 1 1 1\nWIDTH {len(points)}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n"
        f"POINTS {len(points)}\nDATA {encoding}\n"
    ).encode()
    rows = np.concatenate([points, normals], axis=1).astype("<f4")
    if encoding == "ascii":
        body = "".join(" ".join(repr(float(v)) for v in row) + "\n" for row in rows).encode()
    else:
        body = rows.tobytes()
    path = tmp_path / f"sphere_{encoding}.pcd"
    path.write_bytes(header + body)

    ps = psi.load_points(path, preprocess=False)
    assert ps.points_read == len(points) == len(ps)
    np.testing.assert_array_equal(sorted_rows(ps.points), sorted_rows(points.astype(np.float64)))


def test_an_unknown_binary_extension_is_named(tmp_path):
    path = tmp_path / "scan.bin"
    path.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(ValueError, match=r"unknown file extension `\.bin`"):
        psi.load_points(path)
