"""``psi.sample_files``: out of core as ``psi sample --max-memory``, bit for bit; a list of
files read as one input; positions alone given normals tile by tile; the ceiling on spacing as
in core; resuming from the scratch files; bad sizes and too few points refused with the CLI's
messages."""

import json
import os
import platform
import subprocess
import sys

import numpy as np
import pytest

import psi
from conftest import cli_error, inward_noisy_model, model, run_cli


def write_xyz(path, points, normals):
    with open(path, "w") as f:
        for p, n in zip(points, normals):
            f.write(" ".join(repr(float(v)) for v in (*p, *n)) + "\n")


def test_sample_files_equals_the_cli_out_of_core_bitwise(cli, tmp_path):
    bunny = model("bunny.ply")
    out_py = tmp_path / "py.ply"
    report = psi.sample_files(bunny, out_py, max_memory="256MiB", scratch=tmp_path / "s1")
    out_cli = tmp_path / "cli.ply"
    run_cli(cli, "sample", bunny, "--max-memory", "256MiB", "-o", out_cli,
            "--scratch", tmp_path / "s2")
    assert out_py.read_bytes() == out_cli.read_bytes()
    tiles = report["tiles"]
    assert tiles["count"] >= 8 and tiles["resumed"] is False
    assert report["particles"]["count"] == len(psi.load_particles(out_py))
    # Again in the same scratch: resumed, the same file.
    again = psi.sample_files(bunny, tmp_path / "again.ply", max_memory=256 << 20,
                             scratch=tmp_path / "s1")
    assert again["tiles"]["resumed"] is True
    assert (tmp_path / "again.ply").read_bytes() == out_py.read_bytes()


def test_a_list_of_files_is_one_input_in_order(tmp_path):
    ps = psi.builtin_model(20_000)
    pts, nrm = np.asarray(ps.points), np.asarray(ps.normals)
    whole, a, b = tmp_path / "whole.xyz", tmp_path / "a.xyz", tmp_path / "b.xyz"
    write_xyz(whole, pts, nrm)
    write_xyz(a, pts[:7000], nrm[:7000])
    write_xyz(b, pts[7000:], nrm[7000:])
    one = psi.sample_files(whole, tmp_path / "one.ply", max_memory="128MiB")
    two = psi.sample_files([a, b], tmp_path / "two.ply", max_memory="128MiB")
    assert one["input"]["points"] == two["input"]["points"] == len(pts)
    assert (tmp_path / "one.ply").read_bytes() == (tmp_path / "two.ply").read_bytes()


def write_positions(path, points):
    with open(path, "w") as f:
        for p in points:
            f.write(" ".join(repr(float(v)) for v in p) + "\n")


def test_positions_alone_get_their_normals_tile_by_tile_as_the_cli_does(cli, tmp_path):
    # Two files read as one input: the normals file is indexed across both.
    pts = np.asarray(psi.builtin_model(20_000).points)
    whole, a, b = tmp_path / "whole.xyz", tmp_path / "a.xyz", tmp_path / "b.xyz"
    write_positions(whole, pts)
    write_positions(a, pts[:7000])
    write_positions(b, pts[7000:])
    one = psi.sample_files(whole, tmp_path / "one.ply", max_memory="64MiB")
    two = psi.sample_files([a, b], tmp_path / "two.ply", max_memory="64MiB")
    run_cli(cli, "sample", whole, "--max-memory", "64MiB", "-o", tmp_path / "cli.ply",
            "--scratch", tmp_path / "s")
    assert one["tiles"]["preprocessing"]["normals"] == "estimated and oriented tile by tile"
    assert one["input"]["points"] == two["input"]["points"]
    assert (tmp_path / "one.ply").read_bytes() == (tmp_path / "two.ply").read_bytes()
    assert (tmp_path / "one.ply").read_bytes() == (tmp_path / "cli.ply").read_bytes()
    # Files with normals and without, as one input: refused, naming the odd file.
    ps = psi.builtin_model(2_000)
    oriented = tmp_path / "oriented.xyz"
    write_xyz(oriented, np.asarray(ps.points), np.asarray(ps.normals))
    with pytest.raises(ValueError, match="oriented.xyz: has normals where the input's first"):
        psi.sample_files([a, oriented], tmp_path / "mixed.ply", max_memory="64MiB")
    assert not (tmp_path / "mixed.ply").exists()


def test_the_ceiling_on_spacing_covers_a_sheet_out_of_core_as_in_core(cli, tmp_path):
    # A 2 m square sheet, positions alone (seeded): one big cell fits it, so the particles
    # there are the ceiling's darts, thrown tile by tile out of core.
    rng = np.random.default_rng(8)
    pts = np.column_stack([2.0 * rng.random(20_000), 2.0 * rng.random(20_000),
                           1e-4 * rng.standard_normal(20_000)])
    src = tmp_path / "sheet.xyz"
    write_positions(src, pts)
    report = psi.sample_files(src, tmp_path / "py.ply", max_memory="64MiB", max_spacing=0.1)
    parts = report["particles"]
    assert parts["max_spacing"] == 0.1 and parts["added_by_ceiling"] > 300, parts
    assert report["tiles"]["sampling"]["cover"]["passes"] >= 3
    # The CLI out of core and in core: the same bytes.
    run_cli(cli, "sample", src, "--max-memory", "64MiB", "--max-spacing", "0.1",
            "-o", tmp_path / "ooc.ply", "--scratch", tmp_path / "s")
    run_cli(cli, "sample", src, "--max-spacing", "0.1", "-o", tmp_path / "core.ply")
    py = (tmp_path / "py.ply").read_bytes()
    assert py == (tmp_path / "ooc.ply").read_bytes()
    assert py == (tmp_path / "core.ply").read_bytes()
    # No ceiling: a handful of particles.
    none = psi.sample_files(src, tmp_path / "none.ply", max_memory="64MiB",
                            max_spacing=float("inf"))
    assert none["particles"]["max_spacing"] is None
    assert none["particles"]["count"] < 20
    with pytest.raises(ValueError, match="max_spacing"):
        psi.sample_files(src, tmp_path / "bad.ply", max_memory="64MiB", max_spacing=0.0)


def test_inward_normals_the_noise_threshold_and_denoising_out_of_core_as_in_core(cli, tmp_path):
    # Normals flipped outward, the points denoised and ε0 set from the noise left, as in core;
    # a given threshold is the run's.
    src = tmp_path / "inward.xyz"
    inward_noisy_model(src)
    with pytest.warns(UserWarning, match="pointed inward"):
        report = psi.sample_files(src, tmp_path / "py.ply", max_memory="64MiB")
    pre = report["tiles"]["preprocessing"]
    assert pre["inward_normals_flipped"] is True, pre
    assert pre["denoised"]["moved"] > 15_000 and pre["noise_rel_after"] < pre["noise_rel"], pre
    core = tmp_path / "core.json"
    run_cli(cli, "sample", src, "-o", tmp_path / "core.ply", "--json", core)
    assert (tmp_path / "py.ply").read_bytes() == (tmp_path / "core.ply").read_bytes()
    core_report = json.loads(core.read_text())
    assert core_report["input"]["denoised"] == pre["denoised"]
    assert core_report["mpu"]["error_threshold"]["relative"] == report["mpu"]["error_rel"]
    with pytest.warns(UserWarning, match="pointed inward"):
        given = psi.sample_files(src, tmp_path / "given.ply", max_memory="64MiB",
                                 mpu_error=0.006)
    assert given["mpu"]["error_threshold"] == {"relative": 0.006, "source": "user"}
    run_cli(cli, "sample", src, "--mpu-error", "0.006", "-o", tmp_path / "core-given.ply")
    assert (tmp_path / "given.ply").read_bytes() == (tmp_path / "core-given.ply").read_bytes()


def test_normals_that_point_every_way_warn_and_are_not_denoised_as_in_core(cli, tmp_path):
    ps = psi.builtin_model(12_000)
    pts, nrm = np.asarray(ps.points), np.asarray(ps.normals)
    diagonal = np.linalg.norm(pts.max(axis=0) - pts.min(axis=0))
    noisy = pts + 0.003 * diagonal * np.random.default_rng(8).standard_normal(pts.shape)
    nrm = np.where((np.arange(len(nrm)) % 3 == 0)[:, None], -nrm, nrm)
    src = tmp_path / "every-way.xyz"
    write_xyz(src, noisy, nrm)
    with pytest.warns(UserWarning, match="opposite sides, so the points were not denoised"):
        report = psi.sample_files(src, tmp_path / "py.ply", max_memory="64MiB")
    pre = report["tiles"]["preprocessing"]
    assert pre["denoised"] is None and pre["normal_consistency"]["opposed_fraction"] > 0.05, pre
    run_cli(cli, "sample", src, "-o", tmp_path / "core.ply")
    assert (tmp_path / "py.ply").read_bytes() == (tmp_path / "core.ply").read_bytes()


def test_an_mpu_with_more_cells_than_the_budget_holds_is_refused(tmp_path):
    # ε0 far below the noise splits cells down to a few points each.
    src = tmp_path / "noisy.xyz"
    inward_noisy_model(src)
    out = tmp_path / "out.ply"
    with pytest.raises(ValueError, match=r"more than --max-memory 64 MiB holds") as e:
        psi.sample_files(src, out, max_memory="64MiB", mpu_error=1e-4)
    assert "mpu_error=" in str(e.value)
    assert not out.exists()


ARENA_COUNT = """
import ctypes, sys
import numpy as np
import psi
rng = np.random.default_rng(5)
n = rng.normal(size=(20000, 3))
n /= np.linalg.norm(n, axis=1)[:, None]
np.savetxt(sys.argv[1], np.hstack([n, n]))
run = psi.sample_files if sys.argv[3] == "wrapped" else psi._sample_files
run(sys.argv[1], sys.argv[2], max_memory="256MiB")
ctypes.CDLL(None).malloc_stats()
"""


def test_sample_files_keeps_two_malloc_arenas_as_the_cli_does(tmp_path):
    # The budget is the process's peak, and glibc's per-thread arenas keep freed pages
    # resident: psi.sample_files limits them as the CLI does (psi/_allocator.py). Counted by
    # glibc's own malloc_stats in a fresh interpreter with 4 psi threads, against the
    # extension's function called without the limit.
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        pytest.skip("malloc arenas are glibc's")
    env = {**os.environ, "RAYON_NUM_THREADS": "4"}
    env.pop("MALLOC_ARENA_MAX", None)

    def arenas(how):
        args = [tmp_path / f"{how}.xyz", tmp_path / f"{how}.ply", how]
        run = subprocess.run(
            [sys.executable, "-c", ARENA_COUNT, *map(str, args)],
            env=env,
            capture_output=True,
            text=True,
            check=True,
        )
        return run.stderr.count("Arena ")

    assert arenas("native") > 2
    assert 1 <= arenas("wrapped") <= 2


def test_sample_files_pickles_by_name():
    # (A wrapper in Python: pickle, and so a process pool's submit, must find it as psi's.)
    import pickle

    assert pickle.loads(pickle.dumps(psi.sample_files)) is psi.sample_files


def test_outliers_are_left_out_tile_by_tile_unless_kept(cli, tmp_path):
    # The builtin model with 60 points scattered through its box (seeded) and 5 repeats.
    ps = psi.builtin_model(20_000)
    pts, nrm = np.asarray(ps.points), np.asarray(ps.normals)
    rng = np.random.default_rng(4)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    stray = lo + (hi - lo) * rng.random((60, 3))
    pts = np.vstack([pts, stray, pts[:5]])
    nrm = np.vstack([nrm, np.tile([0.0, 0.0, 1.0], (60, 1)), nrm[:5]])
    src = tmp_path / "strays.xyz"
    write_xyz(src, pts, nrm)
    # (Its MPU needs more than 20 000 cells, more than 64 MiB holds beside the relaxation.)
    left = psi.sample_files(src, tmp_path / "left.ply", max_memory="96MiB")
    kept = psi.sample_files(src, tmp_path / "kept.ply", max_memory="96MiB", keep_outliers=True)
    out = left["tiles"]["preprocessing"]["outliers"]
    assert out["repeated"] == 5 and out["removed"] >= 5 + 50, out
    assert left["input"]["points"] == len(pts) - out["removed"]
    assert kept["tiles"]["preprocessing"]["outliers"] is None
    assert kept["input"]["points"] == len(pts)
    # The CLI's run with and without --keep-outliers: the same bytes.
    for name, flags in (("left", []), ("kept", ["--keep-outliers"])):
        cli_out = tmp_path / f"cli-{name}.ply"
        run_cli(cli, "sample", src, "--max-memory", "96MiB", "-o", cli_out,
                "--scratch", tmp_path / f"s-{name}", *flags)
        assert cli_out.read_bytes() == (tmp_path / f"{name}.ply").read_bytes(), name


def test_bad_sizes_and_too_few_points_are_refused_as_the_cli_refuses_them(cli, tmp_path):
    plain = tmp_path / "plain.xyz"
    plain.write_text("0 0 0\n1 0 0\n0 1 0\n0 0 1\n")
    with pytest.raises(ValueError, match="unknown unit"):
        psi.sample_files(plain, tmp_path / "x.ply", max_memory="12XB")
    with pytest.raises(ValueError, match="64 MiB"):
        psi.sample_files(plain, tmp_path / "x.ply", max_memory=1 << 20)
    with pytest.raises(ValueError) as e:
        psi.sample_files(plain, tmp_path / "x.ply", max_memory="1GiB")
    message = cli_error(cli, "sample", plain, "--max-memory", "1GiB", "-o", tmp_path / "y.ply")
    assert str(e.value) == message
    assert not (tmp_path / "x.ply").exists()
