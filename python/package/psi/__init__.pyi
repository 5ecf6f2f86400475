"""psi — point-set implicits: an MPU surface from oriented points, adaptive particles on it.

Units: positions, distances, sigma and f are in the input's (world) units; the MPU error
threshold ``error`` is relative to the input's bounding-box diagonal D. Arrays going in may have
any real dtype and any C- or F-ordered layout (copied once; a float64 C-ordered query of
``value`` or ``value_and_gradient`` of fewer than 65 536 points is read in place; more are
copied once and can be stopped by Ctrl-C); arrays coming out are float64 (uint8 for depth,
uint32 for faces); those of PointSet, Mpu and Particles are read-only and made once. Defaults are the ``psi`` command line's. Bad input
raises ``ValueError``; a file that cannot be opened or written raises ``OSError``
(``FileNotFoundError``, ``PermissionError``, ...); messages are the CLI's.

Arrays held by an object (``PointSet.points``, ``Mpu.normals``, ``Particles.positions``, ...)
are read-only and the same object on each access; a ``Scene``'s arrays are fresh, writable
copies. ``PointSet``, ``Mpu``, ``Particles`` and ``Scene`` pickle (an ``Mpu`` is rebuilt from
its points on unpickling, bitwise the same).

``progress`` (keyword, on every call that can take long): ``None`` or ``False`` for silence,
``True`` for a bar on stderr (tqdm's when tqdm is installed), or a callable ``(stage, done,
total)`` called in the calling thread as the work goes on: stages in pipeline order (``"read"``,
..., ``"mpu"``, ``"seed"``, ``"relax"``, ``"mesh"``), ``done`` rising to ``total`` within each;
an exception it raises stops the work and propagates. Ctrl-C (``KeyboardInterrupt``) stops any
long call within a fraction of a second, creating nothing.
"""

from os import PathLike
from typing import (
    Any,
    Callable,
    Dict,
    List,
    Literal,
    Mapping,
    Optional,
    Tuple,
    TypedDict,
    Union,
    final,
    overload,
)

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
    "load_particles",
    "load_points",
    "render",
    "render_mesh",
    "sample",
    "sample_files",
    "save_particles",
]

_Path = Union[str, "PathLike[str]"]
_Points = npt.ArrayLike
_F64 = npt.NDArray[np.float64]
_Vec3 = Tuple[float, float, float]
_One = Union[Tuple[float, float, float], List[float]]
_Progress = Union[bool, Callable[[str, int, int], object], None]
_Frame = TypedDict(
    "_Frame",
    {"origin": _Vec3, "root_center": _Vec3, "root_half": float, "diagonal": float},
)

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
    (``denoise``), a coarse mesh given more points (``densify``). Normals that point inward
    as a whole (judged on the convex hull; never for an open surface) are flipped outward
    with a ``UserWarning`` unless ``keep_inward_normals`` (the CLI's
    ``--keep-inward-normals``); ``report["inward_normals_flipped"]`` says whether they were.
    """

    def __new__(
        cls,
        points: _Points,
        normals: Optional[_Points] = None,
        *,
        colors: Optional[npt.ArrayLike] = None,
        intensity: Optional[npt.ArrayLike] = None,
        classification: Optional[npt.ArrayLike] = None,
        preprocess: bool = True,
        keep_outliers: bool = False,
        estimate_normals: bool = True,
        orient_normals: bool = False,
        viewpoint: Optional[_Points] = None,
        estimate_noise: bool = True,
        denoise: bool = True,
        densify: bool = True,
        keep_inward_normals: bool = False,
        progress: _Progress = None,
    ) -> PointSet: ...
    @property
    def points(self) -> _F64:
        """Positions after preprocessing, (N, 3) float64, world units; read-only."""
    @property
    def normals(self) -> _F64:
        """Unit normals after preprocessing, (N, 3) float64; read-only."""
    @property
    def colors(self) -> Optional[npt.NDArray[np.uint8]]:
        """Colours of the points, (N, 3) uint8, read-only; ``None`` when the input had none
        (PointSet(..., colors=...), or a file's colours: LAS/LAZ, E57, PCD, PLY)."""
    @property
    def intensity(self) -> Optional[npt.NDArray[np.float32]]:
        """Return intensities, (N,) float32, read-only; ``None`` without."""
    @property
    def classification(self) -> Optional[npt.NDArray[np.uint8]]:
        """LAS classification codes, (N,) uint8, read-only; ``None`` without."""
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
        """The ``input`` object of the CLI's JSON report (``psi info --json``), with
        ``"inward_normals_flipped"`` (bool)."""
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
    keep_inward_normals: bool = False,
    progress: _Progress = None,
) -> PointSet:
    """Reads a PLY, OBJ or XYZ file and prepares its points as ``psi sample FILE`` does.

    A mesh gives one point per triangle (centroid, face normal), or per vertex with
    area-weighted normals when ``per_vertex``. The other options are ``PointSet``'s.
    Raises ``OSError`` when the file cannot be read, ``ValueError`` when it is malformed.
    """

def builtin_model(points: Optional[int] = None, *, progress: _Progress = None) -> PointSet:
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
    edge or corner fits; ``scale_invariant``: fits solved in each cell's units; ``frame``:
    another MPU's ``frame`` to build in (its octree root and length scale; by default the
    points' own), so that ``Mpu(scene.points, scene.normals, preprocess=False,
    frame=scene.mpu.frame)`` agrees with ``scene.mpu`` to rounding. Raises ``ValueError`` for
    too few (fewer than 16) or unusable points.
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
        frame: Optional[Mapping[str, Any]] = None,
        progress: _Progress = None,
    ) -> Mpu: ...
    @overload
    def value_and_gradient(self, x: _One) -> Tuple[float, _F64]:  # type: ignore[overload-overlap]
        ...
    @overload
    def value_and_gradient(self, x: _Points) -> Tuple[_F64, _F64]:
        """f and ∇f at ``x``: a point (3,) gives ``(float, (3,) float64)``, an array (..., 3)
        of any leading shape gives ``(f (...), ∇f (..., 3))`` (``(M, 3)`` → ``(M,)`` and
        ``(M, 3)``; ``(0, 3)`` → empty arrays).

        World units; |∇f| ≈ 1 near the surface. The float is a ``numpy.float64`` (so a
        ``float``); a (3,) ndarray also gives one at run time, though typed as the array
        overload. Evaluated in parallel with the interpreter released. Raises ``ValueError``
        for a last axis other than 3 or a NaN or infinite coordinate.
        """
    @overload
    def value(self, x: _One) -> float:  # type: ignore[overload-overlap]
        ...
    @overload
    def value(self, x: _Points) -> _F64:
        """f at ``x``: a point (3,) → float, an array (..., 3) → (...) float64 (see
        ``value_and_gradient``)."""
    def mesh(
        self, resolution: int = 256, *, progress: _Progress = None
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
    def frame(self) -> _Frame:
        """The frame the MPU lives in: ``origin`` (x, y, z), the world position of its local
        coordinates; ``root_center`` (x, y, z) and ``root_half``, the octree's root cube (local
        coordinates, world units); ``diagonal``, the length scale D. ``Mpu(..., frame=...)``
        builds in it."""
    @property
    def points(self) -> _F64:
        """The points the MPU was built from, (N, 3) float64; read-only."""
    @property
    def normals(self) -> _F64:
        """Their unit normals, (N, 3) float64; read-only."""

@final
class Particles:
    """Particles on a surface: from ``sample``, a ``Scene``, ``load_particles`` or arrays.

    ``Particles(positions, normals=None, *, depth=None, sigma=None)``: ``positions`` (n, 3),
    world units; ``normals`` (n, 3) or ``None`` (then estimated from the positions, unit
    length); ``depth`` (n,) integers 0 to 255 or ``None``; ``sigma`` (n,) positive, world
    units, or ``None``. Raises ``ValueError`` for a bad shape, a NaN or infinite value, a
    depth out of range or a sigma that is not positive. Arrays are read-only and the same
    object on each access.
    """

    def __new__(
        cls,
        positions: _Points,
        normals: Optional[_Points] = None,
        *,
        depth: Optional[npt.ArrayLike] = None,
        sigma: Optional[_Points] = None,
        colors: Optional[npt.ArrayLike] = None,
        intensity: Optional[npt.ArrayLike] = None,
        classification: Optional[npt.ArrayLike] = None,
    ) -> Particles: ...
    @property
    def colors(self) -> Optional[npt.NDArray[np.uint8]]:
        """Colours carried from the input points near each particle (weighted mean within
        one spacing, on its side of the surface), (n, 3) uint8; ``None`` without."""
    @property
    def intensity(self) -> Optional[npt.NDArray[np.float32]]:
        """Intensities carried likewise, (n,) float32; ``None`` without."""
    @property
    def classification(self) -> Optional[npt.NDArray[np.uint8]]:
        """LAS classes carried as the weighted majority, (n,) uint8; ``None`` without."""
    @property
    def positions(self) -> _F64:
        """Positions, (n, 3) float64, world units."""
    @property
    def normals(self) -> _F64:
        """Unit normals (∇f/|∇f| for sampled particles), (n, 3) float64."""
    @property
    def depth(self) -> Optional[npt.NDArray[np.uint8]]:
        """Octree depth of each particle's leaf, (n,) uint8; ``None`` when not known
        (particles from arrays or a file without it)."""
    @property
    def sigma(self) -> Optional[_F64]:
        """Repulsion radius σ (about half the local spacing), (n,) float64, world units;
        ``None`` when not known."""
    @property
    def report(self) -> Optional[dict[str, Any]]:
        """The dict ``psi sample --json`` writes (``input``, ``mpu``, ``particles``,
        ``peak_memory_bytes``); ``None`` for a scene's particles and particles from arrays or
        a file."""
    def __len__(self) -> int: ...

def sample(
    mpu: Mpu,
    *,
    iterations: int = 20,
    k: Optional[int] = None,
    count: Optional[int] = None,
    uniform: bool = False,
    max_spacing: Optional[float] = None,
    seed: int = 2007,
    progress: _Progress = None,
) -> Particles:
    """Seeds ``k`` particles per surface-containing leaf (1 to 64; ``None`` means 1), or
    exactly ``count`` (1 to 50 000 000; ``ValueError`` with ``k`` too), depth-adaptive or
    ``uniform`` (one spacing, blue noise), and relaxes them for ``iterations`` steps (0 to
    100 000); every random choice from ``seed`` (0 to 2**64 - 1). The adaptive spacing is
    never coarser than ``max_spacing`` (world units; ``None``: 2.5 % of the bounding-box
    diagonal, ``math.inf``: no ceiling; ``ValueError`` with ``count`` or ``uniform``):
    particles are added where the data has none near, so flat regions are covered. Bitwise
    the particles ``psi sample`` writes for the same input and options."""

def save_particles(path: _Path, particles: Particles) -> None:
    """Writes binary PLY ``x y z nx ny nz depth sigma`` (float64), as ``psi sample -o``, with
    only the columns the particles have (no ``depth``/``sigma`` when they are ``None``);
    ``OSError`` when it cannot (an existing file is then untouched)."""

def sample_files(
    inputs: Union[_Path, List[_Path]],
    output: _Path,
    *,
    max_memory: Union[int, str],
    scratch: Optional[_Path] = None,
    k: int = 1,
    iterations: int = 20,
    seed: int = 2007,
    mpu_error: Optional[float] = None,
    keep_outliers: bool = False,
    max_spacing: Optional[float] = None,
    progress: _Progress = None,
) -> Dict[str, Any]:
    """Samples ``inputs`` (a path, or a list of paths read as one input in that order) out of
    core within ``max_memory`` (bytes, or a size such as ``"4GiB"``; at least 64 MiB): the
    points streamed into tile files in ``scratch`` (default ``<output>.psi-scratch``), the MPU
    and the particles made tile by tile, the particles written to ``output`` (PLY, or LAS/LAZ by
    extension). As ``psi sample INPUT --max-memory SIZE``: bitwise its particles. Preprocessing
    tile by tile: repeated points, outliers and stray clumps left out (unless
    ``keep_outliers``), normals estimated and oriented where there are none, given normals that
    point inward flipped, the error threshold set from the noise (unless ``mpu_error``), the
    points denoised where the noise calls for it. The ceiling on spacing ``max_spacing`` as in ``psi.sample`` (world
    units; default 2.5 % of the diagonal, ``inf`` for none). A rerun with the same scratch
    resumes from its files. Returns the CLI's ``--json`` report (``tiles``: count, depth,
    points per tile, halos, seconds, ...). Stages ``"read"``, ``"noise"``, ``"tiles"``,
    ``"sample tiles"``, ``"relax"``, ``"cover"``. ``ValueError`` for a bad size, a budget too small (naming what is needed); ``OSError`` when a file cannot be read."""

def load_particles(path: _Path) -> Particles:
    """Reads particles from a PLY (as ``save_particles`` and ``psi sample -o`` write it,
    bitwise) or an XYZ file: ``x y z`` with ``nx ny nz`` (else estimated), ``depth`` and
    ``sigma`` when present (else ``None``). ``OSError`` when the file cannot be read
    (``FileNotFoundError`` when missing), ``ValueError`` when it is malformed."""

@final
class Scene:
    """Points, their MPU and particles, updated locally by edits (``psi edit``).

    The input and MPU options are ``Mpu``'s, the sampling options ``sample``'s. Each edit
    returns its report (``RegenReport``: ``marked_cells``, ``refit_cells``,
    ``particles_removed``, ``particles_regenerated``, ``points``, ``full_rebuild``,
    ``mpu_seconds``, ``particle_seconds``, ``seconds``); a refused edit raises ``ValueError``
    and leaves the scene unchanged. Particles outside the refitted cells stay bitwise equal.
    Each report also has ``"edit"``, the 0-based number of the edit in the scene's sequence
    of applied edits (a refused edit takes none). Methods take an internal lock: a scene may
    be used from any number of threads.
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
        k: Optional[int] = None,
        count: Optional[int] = None,
        uniform: bool = False,
        max_spacing: Optional[float] = None,
        seed: int = 2007,
        progress: _Progress = None,
    ) -> Scene: ...
    def brush(
        self,
        centre: _Points,
        radius: float,
        displacement: _Points,
        *,
        settle: bool = True,
        frame_iterations: int = 4,
    ) -> dict[str, Any]:
        """Moves the points within ``radius`` of ``centre`` (3,) by ``displacement`` (3,) ×
        (1 − t²)², t = distance / radius. ``settle=False``: only ``frame_iterations`` of the
        relaxation run now, ``settle()`` runs the rest."""
    def remove(
        self,
        centre: _Points,
        radius: float,
        *,
        settle: bool = True,
        frame_iterations: int = 4,
    ) -> dict[str, Any]:
        """Removes the points within ``radius`` of ``centre`` (3,)."""
    def settle(self, iterations: Optional[int] = None) -> dict[str, Any]:
        """Runs up to ``iterations`` (default all) more relaxation iterations of the last
        edit made with ``settle=False``."""
    @property
    def pending_iterations(self) -> int:
        """Relaxation iterations the last edit still has to run."""
    def insert(
        self,
        points: _Points,
        normals: _Points,
        *,
        colors: Optional[npt.ArrayLike] = None,
        intensity: Optional[npt.ArrayLike] = None,
        classification: Optional[npt.ArrayLike] = None,
        settle: bool = True,
        frame_iterations: int = 4,
    ) -> dict[str, Any]:
        """Adds oriented points, (N, 3) each, with their attributes (or the defaults)."""
    @property
    def particles(self) -> Particles:
        """The current particles (a copy)."""
    @property
    def edits(self) -> int:
        """Edits applied so far."""
    @property
    def mpu(self) -> Mpu:
        """The current MPU implicit, in the scene's frame (``Mpu.frame``)."""
    @property
    def points(self) -> _F64:
        """The current control points, (N, 3) float64; a new writable copy each access."""
    @property
    def normals(self) -> _F64:
        """Their unit normals, (N, 3) float64; a new writable copy each access."""
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
    color: Literal["depth", "sigma", "normal", "input"] = "depth",
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
    color: Literal["depth", "sigma", "normal", "input"] = "depth",
    style: Literal["dots", "disks"] = "dots",
    splat_scale: float = 1.0,
    legend: bool = True,
) -> None:
    """Draws particles as ``psi render`` does: to a PNG at ``path``, or without ``path`` as
    a (size, size, 4) uint8 RGBA image. ``size`` 16 to 8192 pixels. Only PNG is written: a
    ``path`` not ending in ``.png`` raises ``ValueError`` (nothing written); so does
    ``color="depth"`` for particles without depth (``color="normal"`` needs only normals)."""
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
    draws a mesh file; ``path`` as for ``render`` (PNG only)."""
