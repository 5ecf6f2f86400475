"""``psi.distributed.sample_files`` on a ``LocalCluster`` of two worker processes: bitwise the
command line's particles, also when a worker is killed while tile tasks run."""

import json
import os
import platform
import re
import signal
import subprocess
import sys
import threading
import time

import pytest

import psi
from conftest import inward_noisy_model, model, run_cli

distributed = pytest.importorskip("dask.distributed")

#: A tile's decisions file (the pass above the tiles writes cells-top, cells-upper, cells-group-*).
TILE_FILE = re.compile(r"cells-\d+-\d+-\d+\.bin$")
import psi.distributed  # noqa: E402


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None)
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def test_the_cluster_writes_the_clis_particles(cli, client, tmp_path):
    bunny = model("bunny.ply")
    out = tmp_path / "dask.ply"
    # Two threads per task here (one by default): the particles do not depend on it.
    report = psi.distributed.sample_files(bunny, out, client, max_memory="256MiB",
                                          scratch=tmp_path / "s-dask", threads=2)
    ref = tmp_path / "cli.ply"
    run_cli(cli, "sample", bunny, "--max-memory", "256MiB", "-o", ref,
            "--scratch", tmp_path / "s-cli")
    assert out.read_bytes() == ref.read_bytes()
    assert report["tiles"]["count"] >= 8
    # Every tile's decisions were made by the cluster's tasks before the last one.
    assert report["tiles"]["resumed"] is True


def test_a_worker_killed_during_tile_tasks_costs_a_retry_not_the_result(client, tmp_path):
    # Large enough that the tile tasks take a while; written once, from the built-in model.
    ps = psi.builtin_model(300_000)
    src = tmp_path / "big.xyz"
    with open(src, "w") as f:
        for p, n in zip(ps.points, ps.normals):
            f.write("%r %r %r %r %r %r\n" % (*map(float, p), *map(float, n)))
    ref = tmp_path / "ref.ply"
    # 96 MiB holds about a third of the points in the relaxation beside the MPU's 21 000 cells
    # (64 MiB holds too few cells): its thinned data comes from the seed tasks (with the whole
    # input's footprint), as on a large input.
    ref_report = psi.sample_files(src, ref, max_memory="96MiB", scratch=tmp_path / "s-ref")
    assert 0 < ref_report["tiles"]["sampling"]["relax_points"] < 300_000
    pids = list(client.run(os.getpid).values())
    out = tmp_path / "dask.ply"
    tiles = tmp_path / "s-dask" / "tiles"
    killed = {}

    def kill_during_tile_tasks():
        # Kill one worker process as soon as the first tile's decisions are written, while the
        # other tile tasks run (the nanny starts a new worker).
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline:
            done = [p for p in tiles.glob("cells-*.bin") if TILE_FILE.match(p.name)]
            if done:
                killed["tiles done"] = len(done)
                killed["output written"] = out.exists()
                os.kill(pids[0], signal.SIGKILL)
                return
            time.sleep(0.005)

    killer = threading.Thread(target=kill_during_tile_tasks, daemon=True)
    killer.start()
    psi.distributed.sample_files(src, out, client, max_memory="96MiB",
                                 scratch=tmp_path / "s-dask")
    killer.join(timeout=60)
    # The kill came while tile tasks were left to run, before the output was written.
    manifest = json.loads((tiles / "manifest.json").read_text())
    assert killed and not killed["output written"], killed
    assert killed["tiles done"] < len(manifest["tiles"]), killed
    client.wait_for_workers(2, timeout=60)
    assert pids[0] not in client.run(os.getpid).values()
    assert out.read_bytes() == ref.read_bytes()


def test_positions_alone_get_the_clis_normals_and_particles_on_the_cluster(cli, client,
                                                                          tmp_path):
    # Normals estimated and oriented tile by tile (one task), then the tasks as ever; a
    # ceiling on spacing below the coarse levels' spacing, so that darts are thrown.
    plain = tmp_path / "plain.xyz"
    pts = psi.builtin_model(20_000).points
    plain.write_text("".join(" ".join(repr(float(v)) for v in p) + "\n" for p in pts))
    report = psi.distributed.sample_files(plain, tmp_path / "dask.ply", client=client,
                                          max_memory="64MiB", scratch=tmp_path / "s1",
                                          max_spacing=0.1)
    run_cli(cli, "sample", plain, "--max-memory", "64MiB", "--max-spacing", "0.1",
            "-o", tmp_path / "cli.ply", "--scratch", tmp_path / "s2")
    assert report["tiles"]["preprocessing"]["normals"] == "estimated and oriented tile by tile"
    assert report["particles"]["added_by_ceiling"] > 100, report["particles"]
    assert (tmp_path / "dask.ply").read_bytes() == (tmp_path / "cli.ply").read_bytes()


def test_inward_noisy_normals_get_the_clis_checks_on_the_cluster(cli, client, tmp_path):
    # The checks' task flips the normals, denoises the points and sets ε0 from the noise left;
    # the later tasks read the denoised store and ε0.
    src = tmp_path / "inward.xyz"
    inward_noisy_model(src)
    report = psi.distributed.sample_files(src, tmp_path / "dask.ply", client=client,
                                          max_memory="64MiB", scratch=tmp_path / "s1")
    run_cli(cli, "sample", src, "--max-memory", "64MiB", "-o", tmp_path / "cli.ply",
            "--scratch", tmp_path / "s2")
    assert report["tiles"]["preprocessing"]["inward_normals_flipped"] is True
    assert report["tiles"]["preprocessing"]["denoised"]["moved"] > 15_000
    assert (tmp_path / "dask.ply").read_bytes() == (tmp_path / "cli.ply").read_bytes()


def test_the_seed_tasks_refuse_more_cells_than_the_budget_holds(client, tmp_path):
    # ε0 far below the noise: a tile's task, or the first task that holds all the cells,
    # stops with the CLI's message.
    src = tmp_path / "noisy.xyz"
    inward_noisy_model(src)
    with pytest.raises(ValueError, match=r"more than --max-memory 64 MiB holds"):
        psi.distributed.sample_files(src, tmp_path / "dask.ply", client=client,
                                     max_memory="64MiB", mpu_error=1e-4,
                                     scratch=tmp_path / "s")
    assert not (tmp_path / "dask.ply").exists()


FAULTS = """
import resource, sys
import psi.distributed
if sys.argv[1] == "tuned":
    psi.distributed._tune_allocator()
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(100):
    block = bytearray(4 << 20)  # 4 MiB, written whole
    del block
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


@pytest.mark.skipif(
    not (sys.platform.startswith("linux") and platform.libc_ver()[0] == "glibc"),
    reason="the allocator tuning is for glibc",
)
def test_tasks_undo_the_mmap_threshold_dasks_worker_environment_fixes():
    # Dask's nanny sets MALLOC_TRIM_THRESHOLD_; glibc then maps every block above 128 KiB
    # afresh, so 100 blocks of 4 MiB fault in about 100 × 1024 pages. A tuned process reuses
    # the first block's pages.
    env = dict(os.environ, MALLOC_TRIM_THRESHOLD_="65536")
    env.pop("MALLOC_MMAP_THRESHOLD_", None)

    def faults(mode):
        out = subprocess.run([sys.executable, "-c", FAULTS, mode], env=env, check=True,
                             capture_output=True, text=True)
        return int(out.stdout)

    plain, tuned = faults("plain"), faults("tuned")
    assert plain > 50 * 1024, plain
    assert tuned < plain / 10, (tuned, plain)
