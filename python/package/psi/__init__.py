"""psi — point-set implicits: an MPU surface from oriented points, adaptive particles on it.

Read and prepare points (``load_points``, ``PointSet``, ``builtin_model``), build the MPU
implicit (``Mpu``), sample particles (``sample``), edit locally (``Scene``), save, read and
draw particles (``save_particles``, ``load_particles``, ``Particles``, ``render``,
``render_mesh``), and sample files larger than memory (``sample_files``). NumPy arrays in and out; every result equals the ``psi`` command line's for
the same input and options. See ``help(psi.Mpu)`` and the others.
"""

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
    sample_files,
    save_particles,
)

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
