"""The package against the ``psi`` command line: for the same input and options the same
particles bit for bit, the same report, the same edits and the same pictures."""

import json

import numpy as np
import pytest

import psi
from conftest import columns, model, read_ply, run_cli

TIMING = ("seconds", "peak_memory_bytes")


def without_timings(value):
    """``value`` with every timing (a key ending in ``seconds``, the peak memory) left out."""
    if isinstance(value, dict):
        return {
            k: without_timings(v)
            for k, v in value.items()
            if not any(k.endswith(t) for t in TIMING)
            and k != "simulate_seconds_per_particle_iteration"
        }
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


def assert_same_particles(particles, ply):
    pos, nor, depth, sigma = columns(ply)
    assert len(particles) == len(pos)
    # Bitwise: the PLY stores the doubles as computed.
    assert np.array_equal(particles.positions, pos)
    assert np.array_equal(particles.normals, nor)
    assert np.array_equal(particles.depth.astype(np.float64), depth)
    assert np.array_equal(particles.sigma, sigma)


def test_builtin_model_sample_equals_the_cli_bitwise_with_the_same_report(
    cli, tmp_path, builtin_particles
):
    out, report = tmp_path / "p.ply", tmp_path / "r.json"
    run_cli(cli, "sample", "-o", out, "--json", report)
    assert_same_particles(builtin_particles, read_ply(out))
    theirs = json.loads(report.read_text())
    ours = builtin_particles.report
    # The CLI adds its run's stage timings (`stage_seconds`, from reading to writing).
    assert sorted(ours) == ["input", "mpu", "particles", "peak_memory_bytes"]
    assert sorted(theirs) == sorted([*ours, "stage_seconds"])
    assert without_timings(ours) == without_timings(theirs)
    assert ours["particles"]["simulate_seconds"] > 0


def test_saved_particles_are_the_file_the_cli_writes(cli, tmp_path, builtin_particles):
    out = tmp_path / "cli.ply"
    run_cli(cli, "sample", "-o", out)
    mine = tmp_path / "py.ply"
    psi.save_particles(mine, builtin_particles)
    assert mine.read_bytes() == out.read_bytes()


def test_options_reach_the_sampler_as_the_cli_passes_them(cli, tmp_path):
    mpu = psi.Mpu(psi.builtin_model(20000), max_depth=6, smooth=True, error=0.01)
    particles = psi.sample(mpu, iterations=5, k=2, seed=11)
    out = tmp_path / "p.ply"
    run_cli(
        cli, "sample", "--builtin-points", "20000", "--max-depth", "6", "--smooth",
        "--mpu-error", "0.01", "--iterations", "5", "--k", "2", "--seed", "11", "-o", out,
    )
    assert_same_particles(particles, read_ply(out))
    assert mpu.error_source == "user" and mpu.max_depth <= 6


def test_uniform_count_is_exact_on_the_builtin_model(builtin_mpu):
    particles = psi.sample(builtin_mpu, count=10000, uniform=True)
    assert len(particles) == 10000
    assert particles.report["particles"]["count"] == 10000


def test_bunny_particles_equal_the_cli(cli, tmp_path):
    bunny = model("bunny.ply")
    out, report = tmp_path / "p.ply", tmp_path / "r.json"
    run_cli(cli, "sample", bunny, "-o", out, "--json", report)
    particles = psi.sample(psi.Mpu(psi.load_points(str(bunny))))
    assert_same_particles(particles, read_ply(out))
    assert without_timings(particles.report) == without_timings(json.loads(report.read_text()))


def test_bunny_uniform_ten_thousand_is_exact_and_equals_the_cli(cli, tmp_path):
    bunny = model("bunny.ply")
    out = tmp_path / "p.ply"
    run_cli(cli, "sample", bunny, "--uniform", "--count", "10000", "-o", out)
    particles = psi.sample(psi.Mpu(psi.load_points(bunny)), count=10000, uniform=True)
    assert len(particles) == 10000
    assert_same_particles(particles, read_ply(out))


def test_arrays_are_read_as_an_xyz_file_of_them(cli, tmp_path):
    rng = np.random.default_rng(5)
    pts = psi.builtin_model(6000).points + rng.normal(0, 2e-3, (6000, 3))
    xyz = tmp_path / "scan.xyz"
    np.savetxt(xyz, pts, fmt="%.17g")
    out = tmp_path / "p.ply"
    run_cli(cli, "sample", xyz, "-o", out, "--iterations", "4")
    from_file = psi.sample(psi.Mpu(psi.load_points(xyz)), iterations=4)
    from_arrays = psi.sample(psi.Mpu(np.loadtxt(xyz)), iterations=4)
    assert_same_particles(from_file, read_ply(out))
    assert np.array_equal(from_arrays.positions, from_file.positions)
    assert from_file.report["input"]["normals"]["source"] == "estimated"


def test_scene_edits_equal_psi_edit(cli, tmp_path):
    brush, remove = "0.3,0.3,0.3,0.2,0,0,0.02", "1.3,0,0,0.1"
    before, after = tmp_path / "before.ply", tmp_path / "after.ply"
    run_cli(
        cli, "edit", f"--brush={brush}", f"--remove={remove}", "--iterations", "10",
        "--before", before, "-o", after,
    )
    scene = psi.Scene(psi.builtin_model(), iterations=10)
    assert_same_particles(scene.particles, read_ply(before))
    b = [float(v) for v in brush.split(",")]
    r = [float(v) for v in remove.split(",")]
    first = scene.brush(b[:3], b[3], b[4:])
    second = scene.remove(r[:3], r[3])
    assert_same_particles(scene.particles, read_ply(after))
    assert first["particles_regenerated"] > 0 and second["points"] == len(scene.points)
    assert not first["full_rebuild"]


def test_a_picture_is_the_png_psi_render_writes(cli, tmp_path, builtin_particles):
    ply, theirs, ours = tmp_path / "p.ply", tmp_path / "cli.png", tmp_path / "py.png"
    psi.save_particles(ply, builtin_particles)
    run_cli(cli, "render", ply, "-o", theirs, "--size", "200", "--view", "iso")
    assert psi.render(builtin_particles, ours, size=200, view="iso") is None
    assert ours.read_bytes() == theirs.read_bytes()


@pytest.mark.parametrize("color", ["sigma", "normal"])
def test_pictures_by_sigma_and_normal_match_the_cli(cli, tmp_path, builtin_particles, color):
    ply, theirs, ours = tmp_path / "p.ply", tmp_path / "cli.png", tmp_path / "py.png"
    psi.save_particles(ply, builtin_particles)
    run_cli(cli, "render", ply, "-o", theirs, "--size", "96", "--color", color, "--style", "disks")
    psi.render(builtin_particles, ours, size=96, color=color, style="disks")
    assert ours.read_bytes() == theirs.read_bytes()
