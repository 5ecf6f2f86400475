"""psi — point-set implicits: an MPU surface from oriented points, adaptive particles on it.

Read and prepare points (``load_points``, ``PointSet``, ``builtin_model``), build the MPU
implicit (``Mpu``), sample particles (``sample``), edit locally (``Scene``), save, read and
draw particles (``save_particles``, ``load_particles``, ``Particles``, ``render``,
``render_mesh``), and sample files larger than memory (``sample_files``). NumPy arrays in and out; every result equals the ``psi`` command line's for
the same input and options. See ``help(psi.Mpu)`` and the others.
"""

from functools import wraps as _wraps
from typing import Any as _Any

from ._psi import (
    Mpu,
    Particles,
    PointSet,
    Scene,
    __version__,
    builtin_model,
    load_particles,
    load_points,
    render,
    render_mesh,
    sample,
    save_particles,
)
from ._psi import sample_files as _sample_files
from ._allocator import limit_arenas as _limit_arenas

__all__ = [
    "Mpu",
    "Particles",
    "PointSet",
    "Scene",
    "__version__",
    "builtin_model",
    "load_particles",
    "load_points",
    "render",
    "render_mesh",
    "sample",
    "sample_files",
    "save_particles",
]


@_wraps(_sample_files)
def sample_files(*args: _Any, **kwargs: _Any) -> _Any:
    # (The budget is the process's peak: glibc's arenas limited first, as the CLI does,
    # psi/_allocator.py.)
    _limit_arenas()
    return _sample_files(*args, **kwargs)


# (`wraps` copied the extension's module; pickle finds the function by this one.)
sample_files.__module__ = __name__
