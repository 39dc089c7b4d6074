"""What the mesher yields after each stage of Algorithm 2.1: a `Step` and its `Stats`.

Arrays are read-only so consecutive Steps can share them: an `adjust` stage shares the triangles
of the step before it, a `triangulate` stage shares its points. Holding the whole history of a
run therefore costs little more than the final mesh per stage (the GUI scrubs through it).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from qmesh.errors import QmeshError, QmeshWarning
from qmesh.geometry.triangles import metric_hessians, metric_quality
from qmesh import measure
from qmesh.measure import triangle_energy
from qmesh.triangle_mesh import Mesh

if TYPE_CHECKING:
    from qmesh.conductivity.anisotropy import Anisotropy


class Stats:
    """What one stage of Algorithm 2.1 did and where it left the mesh.

    The energy and the quality figures cost a pass over the triangles, and `qmesh.mesh` never
    reads them: given a `source` (mesh, anisotropy) instead of values, they are computed on
    first access and kept.
    """

    __slots__ = ("n_vertices", "n_triangles", "max_move", "rms_move", "flips", "added",
                 "seconds", "_energy", "_min_quality", "_mean_quality", "_source")

    def __init__(self, n_vertices: int, n_triangles: int, energy: float | None = None,
                 min_quality: float | None = None, mean_quality: float | None = None, *,
                 max_move: float = 0.0, rms_move: float = 0.0, flips: int = 0, added: int = 0,
                 seconds: float = 0.0, source: tuple[Mesh, Anisotropy | Mapping[int, Anisotropy]] | None = None) -> None:
        self.n_vertices, self.n_triangles = int(n_vertices), int(n_triangles)
        self.max_move = max_move    # largest metric displacement / h in this stage (adjust)
        self.rms_move = rms_move    # root-mean-square metric displacement / h (adjust)
        self.flips = flips          # edges flipped to restore the Q-Delaunay property
        self.added = added          # points inserted (insert)
        self.seconds = seconds      # wall time of the stage (without these statistics)
        self._energy, self._min_quality, self._mean_quality = energy, min_quality, mean_quality
        self._source = source

    def _fill(self) -> tuple[float, float, float]:
        """Computes (and keeps) the energy, minimum and mean quality from `source`."""
        if self._source is None:
            raise TypeError("these Stats were given neither the figures nor a source to compute them from")
        mesh, anisotropy = self._source
        if isinstance(anisotropy, Mapping):        # a medium: each triangle in its region's s
            q = measure.quality(mesh, anisotropy)
            self._energy = measure.energy(mesh, anisotropy)
        else:
            P, T = mesh.points, mesh.triangles
            q = metric_quality(P, T, metric_hessians(anisotropy, P, T))
            self._energy = (float(triangle_energy(P, T, anisotropy).sum()) if anisotropy.potential
                            else float("nan"))       # no s: no ‖s − s_h‖ (FIELDS.md §4)
        self._min_quality, self._mean_quality = float(q.min()), float(q.mean())
        return self._energy, self._min_quality, self._mean_quality

    @property
    def energy(self) -> float:
        """E = ‖s_h − s‖_L1 (MATH.md "Vertex adjustment")."""
        return self._fill()[0] if self._energy is None else self._energy

    @property
    def min_quality(self) -> float:
        """Smallest metric quality (2.94); 1 = equilateral in metric space."""
        return self._fill()[1] if self._min_quality is None else self._min_quality

    @property
    def mean_quality(self) -> float:
        """Mean metric quality (2.94) over the triangles."""
        return self._fill()[2] if self._mean_quality is None else self._mean_quality

    def __repr__(self) -> str:
        return (f"Stats(N={self.n_vertices}, triangles={self.n_triangles}, E={self.energy:.4g}, "
                f"min_q={self.min_quality:.3f}, added={self.added}, flips={self.flips})")


@dataclass(frozen=True, eq=False)
class Step:
    """A snapshot after one stage of Algorithm 2.1.

    `stage` is "triangulate", "adjust" or "insert"; `iteration` counts the repeat loop
    (0 = the initial triangulation). `moved` holds per-vertex displacements after an adjust
    stage; `added` the indices of vertices inserted by an insert stage.
    """

    stage: str
    iteration: int
    mesh: Mesh
    stats: Stats
    moved: NDArray[np.float64] | None = field(default=None, repr=False)
    added: NDArray[np.int64] | None = field(default=None, repr=False)
    converged: bool = False

    def __repr__(self) -> str:
        s = self.stats
        return (f"Step({self.stage!r}, iteration={self.iteration}, N={s.n_vertices}, "
                f"E={s.energy:.4g}, min_q={s.min_quality:.3f})")


def last_step(steps: Iterable[Step], progress: Callable[[Step], object] | None = None) -> Step:
    """The last of `steps` (a run yields at least one), each given to `progress` first when it
    is given: the loop behind every `mesh` that runs an `iterate` to its end."""
    if progress is not None and not callable(progress):
        raise QmeshError(f"progress must be a function of one Step, got {type(progress).__name__}")
    last = None
    for last in steps:
        if progress is not None:
            progress(last)
    assert last is not None
    return last


def recording(steps: Iterator[Step], said: list) -> Iterator[Step]:
    """The steps, with the warnings raised while each is made kept in `said` (a driver of many
    runs says them once, summed up) instead of shown."""
    while True:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            step = next(steps, None)
        said += caught
        if step is None:
            return
        yield step


def summed_up(notes: list, most: int = 3) -> list:
    """Warnings (message, category) of many runs, each message "<name>: <what>": at most `most`
    of them, the first ones and then one line counting the rest by name (a zoned model warns
    once, not once per zone)."""
    if len(notes) <= most:
        return notes
    rest = notes[most - 1:]
    names = sorted({m.split(":")[0] for m, _ in rest}, key=lambda n: (len(n), n))
    shown = ", ".join(names[:5]) + (", …" if len(names) > 5 else "")
    return notes[:most - 1] + [(f"{len(rest)} more warnings of the same kinds from "
                                f"{len(names)} regions ({shown})", QmeshWarning)]
