"""The finished meshes of a medium's faces, with the vertex count of their stitched whole."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from typing import Any

import numpy as np

from qmesh.triangle_mesh import Mesh


class FaceMeshes(dict[int, Mesh]):
    """The finished face meshes {face: Mesh}, in the order they were meshed, with the vertex count
    of their stitched whole kept as they are added or replaced (a recount before each face would
    be quadratic in the faces): their interior vertices, and their boundary points once."""

    def __init__(self) -> None:
        super().__init__()
        self._inner = 0                               # interior vertices of all faces
        self._held: Counter[tuple] = Counter()        # boundary point -> faces holding it
        self.rank: dict[int, int] = {}                # face -> when it was first meshed (0, 1, …)

    def __setitem__(self, i: int, m: Mesh) -> None:
        old = self.get(i)
        if old is m:
            return
        if old is not None:                           # out with the old
            gone = _boundary_points(old)
            self._inner -= old.n_vertices - len(gone)
            self._held.subtract(gone)
            for x in gone:
                if not self._held[x]:
                    del self._held[x]
        self.add([i], [m])

    def add(self, faces: Iterable[int], meshes: list[Mesh]) -> None:
        """New faces and their meshes, counted all at once (a run's thousand small faces)."""
        for i, m in zip(faces, meshes):
            self.rank.setdefault(i, len(self.rank))
            super().__setitem__(i, m)
        held = _boundary_points(*meshes)
        self._inner += sum(m.n_vertices for m in meshes) - len(held)
        self._held.update(held)

    def without(self, i: int) -> FaceMeshes:
        """The other faces' meshes, counted afresh (a face meshed again is sized without its old mesh)."""
        out, faces = FaceMeshes(), [f for f in self if f != i]
        out.add(faces, [self[f] for f in faces])
        return out

    def vertex_count(self, adding: Any = ()) -> int:
        """Vertices of the face meshes stitched together, and of the points `adding` they lack."""
        rows = list(map(tuple, np.reshape(adding, (-1, 2)).tolist()))
        return self._inner + len(self._held) + len(rows) - sum(map(self._held.__contains__, rows))


def _boundary_points(*meshes: Mesh) -> list[tuple]:
    """Every mesh's boundary points, each once per mesh, as float tuples (equal as np.unique
    finds them)."""
    if not meshes:
        return []
    off = np.cumsum([0] + [m.n_vertices for m in meshes[:-1]])
    b = np.unique(np.concatenate([m.boundary_edges.ravel() + o for m, o in zip(meshes, off)]))
    return list(map(tuple, np.concatenate([m.points for m in meshes])[b].tolist()))
