"""``progress=``: a callable sees every long call's stages in order, each rising to its total, in
the calling thread, without changing the result; an exception it raises stops the call and
propagates; ``progress=True`` draws on stderr (tqdm's bars or psi's own line) and closes its bar
once, whatever happens."""

import sys
import threading

import numpy as np
import pytest

import psi
import psi._progress as progress_module
from conftest import torus


class Recorder:
    """A progress callable keeping every call and the thread it came from."""

    def __init__(self):
        self.calls = []
        self.threads = set()

    def __call__(self, stage, done, total):
        self.calls.append((stage, done, total))
        self.threads.add(threading.get_ident())

    def stages(self):
        """The stage names in order of first appearance."""
        out = []
        for stage, _, _ in self.calls:
            if stage not in out:
                out.append(stage)
        return out

    def check(self):
        """The protocol: types, one block per stage, done rising to total, the caller's thread."""
        assert self.calls, "the progress callable was never called"
        assert self.threads == {threading.get_ident()}, "called from another thread"
        blocks = [self.calls[0][0]]
        for stage, done, total in self.calls:
            assert isinstance(stage, str) and stage, stage
            assert isinstance(done, int) and isinstance(total, int), (done, total)
            assert 0 <= done <= total, (stage, done, total)
            if stage != blocks[-1]:
                assert stage not in blocks, f"stage {stage!r} came back after {blocks[-1]!r}"
                blocks.append(stage)
        for stage in blocks:
            calls = [(d, t) for s, d, t in self.calls if s == stage]
            dones = [d for d, _ in calls]
            assert dones == sorted(dones), f"{stage}: done went down: {dones}"
            assert calls[-1][0] == calls[-1][1], f"{stage}: the last call is {calls[-1]}"
        return blocks


@pytest.fixture(scope="module")
def small():
    """A small torus, its XYZ file, its MPU (arrays in, no progress) and that MPU's particles."""
    points, normals = torus(3000, seed=21)
    return points, normals


def xyz_file(tmp_path, points, normals=None):
    path = tmp_path / "small.xyz"
    data = points if normals is None else np.hstack([points, normals])
    np.savetxt(path, data, fmt="%.17g")
    return path


def calls(tmp_path, points, normals):
    """Each call taking ``progress``, by name: (what it must show, the call given a progress)."""
    mpu = psi.Mpu(points, normals)
    path = xyz_file(tmp_path, points)
    return {
        # A file of positions only: read, stray points, normals estimated and oriented, noise.
        "load_points": (["read", "outliers", "normals", "orient", "noise"],
                        lambda p: psi.load_points(path, progress=p)),
        # The built-in model carries its normals: the same stages.
        "builtin_model": (["read", "outliers", "normals", "noise"],
                          lambda p: psi.builtin_model(20000, progress=p)),
        "PointSet": (["read", "outliers", "normals", "orient", "noise"],
                     lambda p: psi.PointSet(points, progress=p)),
        "Mpu": ("mpu", lambda p: psi.Mpu(points, normals, progress=p)),
        "sample": (["seed", "relax", "cover", "measure"],
                   lambda p: psi.sample(mpu, iterations=5, progress=p)),
        "mesh": (["mesh"], lambda p: mpu.mesh(resolution=32, progress=p)),
        "Scene": ("mpu", lambda p: psi.Scene(points, normals, iterations=3, progress=p)),
    }


NAMES = ["load_points", "builtin_model", "PointSet", "Mpu", "sample", "mesh", "Scene"]


@pytest.mark.parametrize("name", NAMES)
def test_a_callable_sees_every_stage_rise_to_its_total(tmp_path, small, name):
    must_show, call = calls(tmp_path, *small)[name]
    recorder = Recorder()
    result = call(recorder)
    blocks = recorder.check()
    if isinstance(must_show, list):
        assert blocks == must_show, blocks
    else:
        assert must_show in blocks, blocks
    if name == "Scene":  # a scene builds its MPU, then samples: relaxation after the build
        assert "relax" in blocks and blocks.index("relax") > blocks.index("mpu"), blocks
    # The result is the one without progress.
    plain = call(None)
    if name == "mesh":
        assert all(np.array_equal(a, b) for a, b in zip(result, plain))
    elif name == "sample":
        assert np.array_equal(result.positions, plain.positions)
    elif name == "Scene":
        assert np.array_equal(result.particles.positions, plain.particles.positions)
    elif name == "Mpu":
        x = small[0][:200] * 1.02
        assert np.array_equal(result.value(x), plain.value(x))
    else:
        assert np.array_equal(result.points, plain.points)
        assert np.array_equal(result.normals, plain.normals)


class Stop(Exception):
    pass


@pytest.mark.parametrize("name", NAMES)
def test_an_exception_in_the_callable_stops_the_call_and_propagates(tmp_path, small, name):
    must_show, call = calls(tmp_path, *small)[name]
    if isinstance(must_show, list):  # stop in the call's first stage
        must_show = must_show[0]
    seen = []

    def raising(stage, done, total):
        seen.append(stage)
        # Stop within the stage the call is about when there is one, else at once.
        if must_show is None or stage == must_show:
            raise Stop(f"stop at {stage} {done}/{total}")

    with pytest.raises(Stop, match="stop at"):
        call(raising)
    if must_show is not None:
        assert must_show in seen
        stop = seen.index(must_show)
        # Nothing reported after the raise.
        assert seen[stop:] == [must_show], seen


def test_false_and_none_are_silent(capfd, small):
    points, normals = small
    capfd.readouterr()
    psi.Mpu(points, normals, progress=False)
    psi.Mpu(points, normals, progress=None)
    psi.Mpu(points, normals)
    out, err = capfd.readouterr()
    assert out == "" and err == ""


def test_true_draws_psis_own_line_on_stderr_without_tqdm(capfd, monkeypatch, small):
    monkeypatch.setitem(sys.modules, "tqdm", None)  # `import tqdm` raises ImportError
    points, normals = small
    capfd.readouterr()
    mpu = psi.Mpu(points, normals, progress=True)
    psi.sample(mpu, iterations=5, progress=True)
    out, err = capfd.readouterr()
    assert out == ""
    # One line per call: rewritten with \r, ended by one newline.
    lines = err.split("\n")
    assert len(lines) == 3 and lines[2] == "", repr(err)
    for line, stage in zip(lines, ["mpu", "relax"]):
        assert line.startswith("\rpsi: "), repr(line)
        frames = [f.rstrip() for f in line.split("\r")[1:]]
        assert all(f.startswith("psi: ") for f in frames), frames
        assert any(f"psi: {stage:>10} [" in f for f in frames), frames
        # The last report of the last stage is complete.
        done, total = frames[-1].rsplit(" ", 1)[1].split("/")
        assert done == total, frames[-1]
        assert "[" + "=" * progress_module.WIDTH + "]" in frames[-1], frames[-1]


def test_true_draws_tqdm_bars_on_stderr_when_tqdm_is_there(capfd, small):
    pytest.importorskip("tqdm", reason="tqdm is not installed")
    points, normals = small
    capfd.readouterr()
    psi.Mpu(points, normals, progress=True)
    out, err = capfd.readouterr()
    assert out == "" and "psi: mpu" in err and "100%" in err, err


class FakeBar:
    """What ``stderr_bar`` returns, counting calls and closes; raises when told to."""

    made = []

    def __init__(self, fail_at=None):
        self.calls, self.closed, self.fail_at = [], 0, fail_at
        FakeBar.made.append(self)

    def __call__(self, stage, done, total):
        assert self.closed == 0, "called after close"
        self.calls.append((stage, done, total))
        if stage == self.fail_at:
            raise Stop(stage)

    def close(self):
        self.closed += 1


@pytest.mark.parametrize("fail_at", [None, "mpu"])
def test_true_calls_stderr_bar_and_closes_it_once(monkeypatch, small, fail_at):
    points, normals = small
    FakeBar.made = []
    monkeypatch.setattr(progress_module, "stderr_bar", lambda: FakeBar(fail_at))
    if fail_at is None:
        psi.Mpu(points, normals, progress=True)
    else:
        with pytest.raises(Stop):
            psi.Mpu(points, normals, progress=True)
    assert len(FakeBar.made) == 1
    bar = FakeBar.made[0]
    assert bar.closed == 1 and "mpu" in [s for s, _, _ in bar.calls]


def test_a_failing_call_closes_its_bar(monkeypatch):
    FakeBar.made = []
    monkeypatch.setattr(progress_module, "stderr_bar", lambda: FakeBar())
    with pytest.raises(ValueError, match="too few"):
        psi.Mpu(np.eye(3), np.eye(3), progress=True)
    assert all(bar.closed == 1 for bar in FakeBar.made), [b.closed for b in FakeBar.made]


# The fallback bar itself (no extension involved).


def test_bar_text_is_the_documented_line():
    assert progress_module.bar_text("relax", 5, 10, width=10) == "psi:      relax [====>     ] 5/10"
    assert progress_module.bar_text("mpu", 0, 4, width=4) == "psi:        mpu [    ] 0/4"
    assert progress_module.bar_text("mesh", 7, 7, width=4) == "psi:       mesh [====] 7/7"
    assert progress_module.bar_text("seed", 0, 0, width=4) == "psi:       seed [====] 0/0"


def test_the_line_bar_rewrites_one_line_and_ends_it_at_close(capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "tqdm", None)
    bar = progress_module.stderr_bar()
    assert isinstance(bar, progress_module.LineBar)
    for i in range(1001):
        bar("normals", i, 1000)
    bar("noise", 0, 1)
    bar("noise", 1, 1)
    bar.close()
    bar.close()  # a second close adds nothing
    err = capsys.readouterr().err
    assert err.endswith("\n") and err.count("\n") == 1
    frames = err[:-1].split("\r")[1:]
    # Throttled: far fewer redraws than reports, but each stage's first and last are there.
    assert 3 <= len(frames) < 100, len(frames)
    texts = [f.rstrip() for f in frames]
    assert texts[0].endswith(" 0/1000") and "1000/1000" in texts[-3]
    assert texts[-2].endswith(" 0/1") and texts[-1].endswith(" 1/1")
    # A shorter text blanks out what the longer one before it left.
    assert len(frames[-2]) >= len(frames[-3])


def test_a_bar_closed_before_any_report_writes_nothing(capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "tqdm", None)
    bar = progress_module.stderr_bar()
    bar.close()
    assert capsys.readouterr().err == ""
    # A report after close starts a new line, which the next close ends.
    bar("late", 1, 1)
    bar.close()
    assert capsys.readouterr().err == "\rpsi:       late [" + "=" * progress_module.WIDTH + "] 1/1\n"
