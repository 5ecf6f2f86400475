"""``psi.distributed.sample_files`` on a ``LocalCluster`` of two worker processes: bitwise the
command line's particles, also when a worker is killed while tile tasks run."""

import os
import signal
import threading

import pytest

import psi
from conftest import model, run_cli

distributed = pytest.importorskip("dask.distributed")
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
    psi.sample_files(src, ref, max_memory="128MiB", scratch=tmp_path / "s-ref")
    pids = list(client.run(os.getpid).values())
    # Kill one worker process shortly after the tasks start (the nanny starts a new one).
    killer = threading.Timer(2.0, os.kill, args=(pids[0], signal.SIGKILL))
    killer.start()
    try:
        out = tmp_path / "dask.ply"
        psi.distributed.sample_files(src, out, client, max_memory="128MiB",
                                     scratch=tmp_path / "s-dask")
    finally:
        killer.cancel()
    # The kill happened while the run was going: the timer fired before it ended.
    client.wait_for_workers(2, timeout=60)
    assert pids[0] not in client.run(os.getpid).values()
    assert out.read_bytes() == ref.read_bytes()
