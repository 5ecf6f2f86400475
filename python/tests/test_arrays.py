"""Shapes and dtypes of every array the package returns, and the rendered image against the
PNG the same call writes (decoded here with zlib and numpy alone)."""

import struct
import zlib

import numpy as np
import pytest

import psi
from conftest import torus


def check(array, shape, dtype):
    assert isinstance(array, np.ndarray)
    assert array.shape == shape, (array.shape, shape)
    assert array.dtype == dtype, (array.dtype, dtype)
    assert array.flags.c_contiguous


def test_point_set_arrays():
    points, normals = torus(4000, seed=1)
    ps = psi.PointSet(points, normals)
    n = len(ps)
    assert n == ps.points_read == 4000
    check(ps.points, (n, 3), np.float64)
    check(ps.normals, (n, 3), np.float64)
    assert np.allclose(np.linalg.norm(ps.normals, axis=1), 1)
    assert ps.name == "points" and ps.error == 0.005
    assert ps.report["points"] == n and ps.report["normals"]["source"] == "file"
    bare = psi.PointSet(points)
    assert bare.report["normals"]["source"] == "estimated"
    assert (np.einsum("ij,ij->i", bare.normals, normals) > 0.9).mean() > 0.99


def test_mpu_arrays(builtin_mpu):
    m = builtin_mpu
    n = len(psi.builtin_model())
    check(m.points, (n, 3), np.float64)
    check(m.normals, (n, 3), np.float64)
    check(m.bbox, (2, 3), np.float64)
    assert np.array_equal(m.bbox, [m.points.min(axis=0), m.points.max(axis=0)])
    assert m.diagonal == pytest.approx(np.linalg.norm(m.bbox[1] - m.bbox[0]))
    assert m.leaves == m.report["leaves"] >= m.surface_leaves > 0
    assert 0 < m.max_depth <= m.params["max_depth"] == 12
    assert m.error == 0.005 and m.error_source == "paper"
    f, g = m.value_and_gradient(np.zeros((7, 3)))
    check(f, (7,), np.float64)
    check(g, (7, 3), np.float64)
    check(m.value(np.zeros((7, 3))), (7,), np.float64)
    f1, g1 = m.value_and_gradient(np.zeros(3))
    assert isinstance(f1, float) and isinstance(m.value([0, 0, 0]), float)
    check(g1, (3,), np.float64)
    f0, g0 = m.value_and_gradient(np.zeros((0, 3)))
    check(f0, (0,), np.float64)
    check(g0, (0, 3), np.float64)
    vertices, faces = m.mesh(resolution=64)
    check(vertices, (len(vertices), 3), np.float64)
    check(faces, (len(faces), 3), np.uint32)
    assert len(faces) > 1000 and faces.max() < len(vertices)
    # The mesh lies on the zero set (its vertices are projected onto it).
    assert np.abs(m.value(vertices)).max() < 1e-3 * m.diagonal


def test_particle_arrays(builtin_particles):
    p = builtin_particles
    n = len(p)
    assert n == p.report["particles"]["count"] > 1000
    check(p.positions, (n, 3), np.float64)
    check(p.normals, (n, 3), np.float64)
    check(p.depth, (n,), np.uint8)
    check(p.sigma, (n,), np.float64)
    assert np.allclose(np.linalg.norm(p.normals, axis=1), 1)
    assert (p.sigma > 0).all() and p.depth.max() <= 12


def test_scene_arrays():
    scene = psi.Scene(psi.builtin_model(10000), iterations=5)
    n = len(scene.points)
    check(scene.points, (n, 3), np.float64)
    check(scene.normals, (n, 3), np.float64)
    particles = scene.particles
    assert particles.report is None and len(particles) == scene.report["count"]
    check(particles.depth, (len(particles),), np.uint8)
    report = scene.brush(np.array([0.3, 0.3, 0.3]), 0.2, (0.0, 0.0, 0.02))
    assert set(report) == {
        "marked_cells", "refit_cells", "particles_removed", "particles_regenerated", "points",
        "full_rebuild", "mpu_seconds", "particle_seconds", "seconds", "edit",
        "edit_seconds", "mark_seconds", "settle_seconds", "settle_cpu_seconds", "cpu_seconds",
        "pending_iterations",
    }
    added = scene.insert([[1.3, 0.0, 0.1]], [[2.0, 0.0, 0.0]])
    assert added["points"] == n + 1 == len(scene.points)
    assert np.array_equal(scene.normals[-1], [1.0, 0.0, 0.0])


def read_png(path):
    """The RGBA pixels of an 8-bit, non-interlaced RGBA PNG, as (H, W, 4) uint8."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, chunks = 8, {}
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind = data[pos + 4:pos + 8]
        chunks.setdefault(kind, []).append(data[pos + 8:pos + 8 + length])
        pos += 12 + length
    width, height, depth, color, _, _, interlace = struct.unpack(">IIBBBBB", chunks[b"IHDR"][0])
    assert (depth, color, interlace) == (8, 6, 0)
    raw = np.frombuffer(zlib.decompress(b"".join(chunks[b"IDAT"])), np.uint8)
    rows = raw.reshape(height, 1 + 4 * width)
    out = np.zeros((height, 4 * width), np.int32)
    for y in range(height):
        kind, line = rows[y, 0], rows[y, 1:].astype(np.int32)
        up = out[y - 1] if y else np.zeros(4 * width, np.int32)
        if kind in (0, 2):
            out[y] = (line + (up if kind == 2 else 0)) % 256
            continue
        for x in range(4 * width):  # sub, average, Paeth: left to right
            left = out[y, x - 4] if x >= 4 else 0
            corner = up[x - 4] if x >= 4 else 0
            if kind == 1:
                pred = left
            elif kind == 3:
                pred = (left + up[x]) // 2
            else:
                p = left + up[x] - corner
                pa, pb, pc = abs(p - left), abs(p - up[x]), abs(p - corner)
                pred = left if pa <= pb and pa <= pc else (up[x] if pb <= pc else corner)
            out[y, x] = (line[x] + pred) % 256
    return out.reshape(height, width, 4).astype(np.uint8)


def test_rendered_image_is_the_png_of_the_same_call(tmp_path, builtin_particles, builtin_mpu):
    image = psi.render(builtin_particles, size=48, view="iso")
    check(image, (48, 48, 4), np.uint8)
    assert (image[..., 3] == 255).all()
    assert len(np.unique(image.reshape(-1, 4), axis=0)) > 10  # not blank
    psi.render(builtin_particles, tmp_path / "p.png", size=48, view="iso")
    assert np.array_equal(read_png(tmp_path / "p.png"), image)
    vertices, faces = builtin_mpu.mesh(resolution=48)
    mesh = psi.render_mesh(vertices, faces, size=40, view="side")
    check(mesh, (40, 40, 4), np.uint8)
    psi.render_mesh(vertices, faces.astype(np.int64), tmp_path / "m.png", size=40, view="side")
    assert np.array_equal(read_png(tmp_path / "m.png"), mesh)
