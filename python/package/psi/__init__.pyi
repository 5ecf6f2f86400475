"""psi — point-set implicits: an MPU surface from oriented points, adaptive particles on it.

Units: positions, distances, sigma and f are in the input's (world) units; the MPU error
threshold ``error`` is relative to the input's bounding-box diagonal D. Arrays going in may have
any real dtype and any C- or F-ordered layout (copied once; a float64 C-ordered query of
``value`` or ``value_and_gradient`` is read in place); arrays coming out are new float64
(uint8 for depth, uint32 for faces) arrays. Defaults are the ``psi`` command line's. Bad input
raises ``ValueError``; a file that cannot be opened or written raises ``OSError``
(``FileNotFoundError``, ``PermissionError``, ...); messages are the CLI's.
"""

from os import PathLike
from typing import Any, Literal, Optional, Tuple, Union, final, overload

import numpy as np
import numpy.typing as npt

__version__: str
__all__ = [
    "Mpu",
    "Particles",
    "PointSet",
    "Scene",
    "__version__",
    "builtin_model",
    "load_points",
    "render",
    "render_mesh",
    "sample",
    "save_particles",
]

_Path = Union[str, "PathLike[str]"]
_Points = npt.ArrayLike
_F64 = npt.NDArray[np.float64]

@final
class PointSet:
    """Oriented points prepared for the MPU, as ``psi sample`` prepares its input.

    ``PointSet(points, normals=None, ...)`` reads arrays: ``points`` (N, 3) positions and
    ``normals`` (N, 3) (normalised; rows with a zero normal dropped) or ``None`` (estimated and
    oriented), as an XYZ file of them would be read. Then, unless ``preprocess=False`` (every
    step off, normals required), as the CLI's flags of the same names say: stray points left
    out (``keep_outliers``), missing normals estimated (``estimate_normals``) and oriented by
    propagation or toward ``viewpoint`` (3,), given normals reoriented (``orient_normals``),
    the noise estimated (``estimate_noise``) and taken out where it would matter
    (``denoise``), a coarse mesh given more points (``densify``).
    """

    def __new__(
        cls,
        points: _Points,
        normals: Optional[_Points] = None,
        *,
        preprocess: bool = True,
        keep_outliers: bool = False,
        estimate_normals: bool = True,
        orient_normals: bool = False,
        viewpoint: Optional[_Points] = None,
        estimate_noise: bool = True,
        denoise: bool = True,
        densify: bool = True,
    ) -> PointSet: ...
    @property
    def points(self) -> _F64:
        """Positions after preprocessing, (N, 3) float64, world units."""
    @property
    def normals(self) -> _F64:
        """Unit normals after preprocessing, (N, 3) float64."""
    @property
    def points_read(self) -> int:
        """Points read, before preprocessing."""
    @property
    def error(self) -> float:
        """The suggested MPU error threshold ε0/D (paper's 0.005, or 4× the noise left)."""
    @property
    def name(self) -> str:
        """The file as given, ``"builtin"``, or ``"points"`` for arrays."""
    @property
    def report(self) -> dict[str, Any]:
        """The ``input`` object of the CLI's JSON report (``psi info --json``)."""
    def __len__(self) -> int: ...

def load_points(
    path: _Path,
    per_vertex: bool = False,
    *,
    preprocess: bool = True,
    keep_outliers: bool = False,
    estimate_normals: bool = True,
    orient_normals: bool = False,
    viewpoint: Optional[_Points] = None,
    estimate_noise: bool = True,
    denoise: bool = True,
    densify: bool = True,
) -> PointSet:
    """Reads a PLY, OBJ or XYZ file and prepares its points as ``psi sample FILE`` does.

    A mesh gives one point per triangle (centroid, face normal), or per vertex with
    area-weighted normals when ``per_vertex``. The other options are ``PointSet``'s.
    Raises ``OSError`` when the file cannot be read, ``ValueError`` when it is malformed.
    """

def builtin_model(points: Optional[int] = None) -> PointSet:
    """The built-in model (80 000 points unless ``points``, 1 to 50 000 000), prepared as
    ``psi sample`` without an input does."""

@final
class Mpu:
    """The MPU implicit f of oriented points (Ohtake et al. 2003): f > 0 outside, f < 0
    inside, about the signed distance (world units) near the surface.

    ``points`` is a ``PointSet`` (``normals`` must then be ``None``) or an (N, 3) array with
    ``normals`` (N, 3) or ``None``, prepared as ``PointSet(points, normals,
    preprocess=preprocess)``. ``error``: ε0/D in (0, 1], default the points' suggestion
    (``PointSet.error``); ``max_depth``: octree depth limit, 0 to 16; ``smooth``: no sharp
    edge or corner fits; ``scale_invariant``: fits solved in each cell's units. Raises
    ``ValueError`` for too few (fewer than 16) or unusable points.
    """

    def __new__(
        cls,
        points: Union[PointSet, _Points],
        normals: Optional[_Points] = None,
        *,
        error: Optional[float] = None,
        max_depth: int = 12,
        smooth: bool = False,
        scale_invariant: bool = False,
        preprocess: bool = True,
    ) -> Mpu: ...
    @overload
    def value_and_gradient(self, x: Tuple[float, float, float]) -> Tuple[float, _F64]: ...
    @overload
    def value_and_gradient(self, x: _Points) -> Tuple[Union[float, _F64], _F64]:
        """f and ∇f at ``x``: (3,) gives ``(float, (3,))``, (M, 3) gives ``((M,), (M, 3))``.

        World units; |∇f| ≈ 1 near the surface. Evaluated in parallel with the interpreter
        released. Raises ``ValueError`` for another shape or a NaN or infinite coordinate.
        """
    def value(self, x: _Points) -> Union[float, _F64]:
        """f at ``x`` (3,) → float, or (M, 3) → (M,) float64."""
    def mesh(
        self, resolution: int = 256
    ) -> Tuple[_F64, npt.NDArray[np.uint32]]:
        """The zero set near the data (what ``psi mesh`` writes): vertices (V, 3) float64,
        faces (F, 3) uint32, counter-clockwise seen from outside. ``resolution``: grid cells
        across the root cube, 2 to 2048."""
    @property
    def leaves(self) -> int:
        """Number of octree leaves (each a local fit)."""
    @property
    def surface_leaves(self) -> int:
        """Leaves whose cube holds an input point."""
    @property
    def max_depth(self) -> int:
        """Depth of the deepest leaf (root = 0)."""
    @property
    def bbox(self) -> _F64:
        """The input's bounding box, (2, 3): minimum and maximum corners."""
    @property
    def diagonal(self) -> float:
        """D, the bounding-box diagonal, world units."""
    @property
    def error(self) -> float:
        """The error threshold ε0/D used."""
    @property
    def error_source(self) -> Literal["user", "noise", "paper"]:
        """Where ε0 came from."""
    @property
    def params(self) -> dict[str, Any]:
        """Every build parameter (``MpuParams``)."""
    @property
    def report(self) -> dict[str, Any]:
        """The build's diagnostics (``BuildReport``)."""
    @property
    def points(self) -> _F64:
        """The points the MPU was built from, (N, 3) float64."""
    @property
    def normals(self) -> _F64:
        """Their unit normals, (N, 3) float64."""

@final
class Particles:
    """Particles on an MPU surface; arrays are new copies on each access."""

    @property
    def positions(self) -> _F64:
        """Positions, (n, 3) float64, world units."""
    @property
    def normals(self) -> _F64:
        """Unit normals ∇f/|∇f|, (n, 3) float64."""
    @property
    def depth(self) -> npt.NDArray[np.uint8]:
        """Octree depth of each particle's leaf, (n,) uint8."""
    @property
    def sigma(self) -> _F64:
        """Repulsion radius σ (about half the local spacing), (n,) float64, world units."""
    @property
    def report(self) -> Optional[dict[str, Any]]:
        """The dict ``psi sample --json`` writes (``input``, ``mpu``, ``particles``,
        ``peak_memory_bytes``); ``None`` for a scene's particles."""
    def __len__(self) -> int: ...

def sample(
    mpu: Mpu,
    *,
    iterations: int = 20,
    k: int = 1,
    count: Optional[int] = None,
    uniform: bool = False,
    seed: int = 2007,
) -> Particles:
    """Seeds ``k`` particles per surface-containing leaf (1 to 64), or exactly ``count`` (1 to
    50 000 000), depth-adaptive or ``uniform`` (one spacing, blue noise), and relaxes them for
    ``iterations`` steps (0 to 100 000); every random choice from ``seed`` (0 to 2**64 - 1).
    Bitwise the particles ``psi sample`` writes for the same input and options."""

def save_particles(path: _Path, particles: Particles) -> None:
    """Writes binary PLY ``x y z nx ny nz depth sigma`` (float64), as ``psi sample -o``;
    ``OSError`` when it cannot (an existing file is then untouched)."""

@final
class Scene:
    """Points, their MPU and particles, updated locally by edits (``psi edit``).

    The input and MPU options are ``Mpu``'s, the sampling options ``sample``'s. Each edit
    returns its report (``RegenReport``: ``marked_cells``, ``refit_cells``,
    ``particles_removed``, ``particles_regenerated``, ``points``, ``full_rebuild``,
    ``mpu_seconds``, ``particle_seconds``, ``seconds``); a refused edit raises ``ValueError``
    and leaves the scene unchanged. Particles outside the refitted cells stay bitwise equal.
    """

    def __new__(
        cls,
        points: Union[PointSet, _Points],
        normals: Optional[_Points] = None,
        *,
        error: Optional[float] = None,
        max_depth: int = 12,
        smooth: bool = False,
        scale_invariant: bool = False,
        preprocess: bool = True,
        iterations: int = 20,
        k: int = 1,
        count: Optional[int] = None,
        uniform: bool = False,
        seed: int = 2007,
    ) -> Scene: ...
    def brush(
        self, centre: _Points, radius: float, displacement: _Points
    ) -> dict[str, Any]:
        """Moves the points within ``radius`` of ``centre`` (3,) by ``displacement`` (3,) ×
        (1 − t²)², t = distance / radius."""
    def remove(self, centre: _Points, radius: float) -> dict[str, Any]:
        """Removes the points within ``radius`` of ``centre`` (3,)."""
    def insert(self, points: _Points, normals: _Points) -> dict[str, Any]:
        """Adds oriented points, (N, 3) each."""
    @property
    def particles(self) -> Particles:
        """The current particles (a copy)."""
    @property
    def points(self) -> _F64:
        """The current control points, (N, 3) float64."""
    @property
    def normals(self) -> _F64:
        """Their unit normals, (N, 3) float64."""
    @property
    def report(self) -> dict[str, Any]:
        """The first sampling's report (``SampleReport``)."""

@overload
def render(
    particles: Particles,
    path: None = None,
    *,
    size: int = 1024,
    view: Literal["front", "side", "top", "iso"] = "front",
    color: Literal["depth", "sigma", "normal"] = "depth",
    style: Literal["dots", "disks"] = "dots",
    splat_scale: float = 1.0,
    legend: bool = True,
) -> npt.NDArray[np.uint8]: ...
@overload
def render(
    particles: Particles,
    path: _Path,
    *,
    size: int = 1024,
    view: Literal["front", "side", "top", "iso"] = "front",
    color: Literal["depth", "sigma", "normal"] = "depth",
    style: Literal["dots", "disks"] = "dots",
    splat_scale: float = 1.0,
    legend: bool = True,
) -> None:
    """Draws particles as ``psi render`` does: to a PNG at ``path``, or without ``path`` as
    a (size, size, 4) uint8 RGBA image. ``size`` 16 to 8192 pixels."""
@overload
def render_mesh(
    vertices: _Points,
    faces: npt.ArrayLike,
    path: None = None,
    *,
    size: int = 1024,
    view: Literal["front", "side", "top", "iso"] = "front",
) -> npt.NDArray[np.uint8]: ...
@overload
def render_mesh(
    vertices: _Points,
    faces: npt.ArrayLike,
    path: _Path,
    *,
    size: int = 1024,
    view: Literal["front", "side", "top", "iso"] = "front",
) -> None:
    """Draws a triangle mesh (vertices (V, 3), faces (F, 3)) flat-shaded, as ``psi render``
    draws a mesh file."""
