"""The stub types real programs: examples/python/typed_example.py passes ``mypy --strict`` with
no cast or ``type: ignore`` and runs; the overloads make a point's value a ``float`` and an
array's an ``NDArray[float64]``, so mixing them up is a type error."""

import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "python" / "typed_example.py"


def mypy(tmp_path, *files):
    """``mypy --strict`` on ``files`` with this interpreter (so on the installed package)."""
    pytest.importorskip("mypy.api", reason="mypy is not installed: the typing checks need it")
    done = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-error-summary", "--show-error-codes",
         "--cache-dir", str(tmp_path / "mypy-cache"), *map(str, files)],
        capture_output=True, text=True, cwd=tmp_path,
    )
    assert "error: Cannot find implementation or library stub" not in done.stdout, done.stdout
    return done


def test_the_typed_example_passes_mypy_strict_without_escape_hatches(tmp_path):
    if not EXAMPLE.is_file():
        pytest.skip(f"{EXAMPLE} is absent (the package installed away from its sources)")
    source = EXAMPLE.read_text()
    assert not re.search(r"#\s*type:\s*ignore|\bcast\(", source), "no escape hatches"
    done = mypy(tmp_path, EXAMPLE)
    assert done.returncode == 0, done.stdout + done.stderr


def test_the_typed_example_runs(tmp_path):
    if not EXAMPLE.is_file():
        pytest.skip(f"{EXAMPLE} is absent (the package installed away from its sources)")
    done = subprocess.run([sys.executable, str(EXAMPLE), "-o", str(tmp_path)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert (tmp_path / "particles.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "edit 0:" in done.stdout, done.stdout


REVEAL = """
import numpy as np
import psi

m = psi.Mpu(np.zeros((20, 3)), np.ones((20, 3)))
reveal_type(m.value((1.0, 2.0, 3.0)))
reveal_type(m.value([1.0, 2.0, 3.0]))
reveal_type(m.value(np.zeros((4, 3))))
reveal_type(m.value([[1.0, 2.0, 3.0]]))
reveal_type(m.value_and_gradient((1.0, 2.0, 3.0)))
reveal_type(m.value_and_gradient(np.zeros((4, 3))))
reveal_type(psi.Particles(np.zeros((4, 3))).depth)
reveal_type(psi.load_particles("p.ply"))
reveal_type(psi.Scene(np.zeros((20, 3)), k=None).mpu)
reveal_type(m.frame["root_half"])
"""


def test_the_overloads_give_a_float_for_a_point_and_an_array_for_arrays(tmp_path):
    (tmp_path / "reveal.py").write_text(textwrap.dedent(REVEAL))
    done = mypy(tmp_path, "reveal.py")
    types = re.findall(r'Revealed type is "(.*)"', done.stdout)
    assert len(types) == 10, done.stdout
    float_ = r"(builtins\.)?float"
    array = r"numpy\.ndarray\[.*numpy\.dtype\[numpy\.float64\]\]"
    expected = [
        float_, float_, array, array,
        rf"tuple\[{float_}, {array}\]", rf"tuple\[{array}, {array}\]",
        r"numpy\.ndarray\[.*numpy\.unsignedinteger\[.*\]\]\] \| None|Union\[numpy\.ndarray.*None\]",
        r"psi\.Particles", r"psi\.Mpu", float_,
    ]
    for got, pattern in zip(types, expected):
        # mypy < 1.? writes Tuple/builtins.tuple; accept those spellings too.
        got = re.sub(r"^(builtins\.)?[Tt]uple\[", "tuple[", got)
        assert re.fullmatch(pattern, got), (got, pattern)
    assert done.returncode == 0, done.stdout


MISTAKES = """
import numpy as np
import numpy.typing as npt
import psi

m = psi.Mpu(np.zeros((20, 3)), np.ones((20, 3)))
a: float = m.value(np.zeros((4, 3)))
b: npt.NDArray[np.float64] = m.value((1.0, 2.0, 3.0))
c: int = psi.Particles(np.zeros((4, 3))).depth
psi.sample(m, progress="yes")
psi.Mpu(np.zeros((20, 3)), progress=lambda stage: None)
"""


def test_mixing_up_points_and_arrays_is_a_type_error(tmp_path):
    (tmp_path / "mistakes.py").write_text(textwrap.dedent(MISTAKES))
    done = mypy(tmp_path, "mistakes.py")
    assert done.returncode == 1, done.stdout
    lines = {int(n) for n in re.findall(r"^mistakes\.py:(\d+): error:", done.stdout, re.M)}
    assert lines == {7, 8, 9, 10, 11}, done.stdout
