"""Disjoint domains meshed by one run of Algorithm 2.1, and its mesh cut back into one per domain.

A run has fixed costs (normalising, seeding, Qhull builds, the stages' passes) that a domain of a
few dozen vertices pays as much as one of a million. Domains that share one constant Q and one
size, and touch nowhere, can be meshed together: every stage is local to a triangle, an edge or a
vertex's star, Qhull's triangles outside Ω are dropped as for a domain with holes (Ω lies on the
left of every segment), and encroachment is tested on Ω's side of a segment only. The run sees
one domain whose rings are all the domains' rings; its input points come first, domain after
domain, so each domain's mesh keeps its own input points first (and bit for bit). Each domain
is seeded with its own metric lattice, placed on its own extent as it would be alone (one lattice
across all would leave a small domain's interior points to chance); what is the run's, not each
domain's: the lattices' jitter drawn in turn, one insertion budget, one test of convergence.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from qmesh.domain.domain import Domain
from qmesh.errors import QmeshError
from qmesh.geometry.rings import signed_area
from qmesh.mesher.seeding import metric_lattice
from qmesh.triangle_mesh import Mesh


class Components(Domain):
    """Disjoint domains as one Ω, from their `rings` (each outline counter-clockwise, each hole
    clockwise; checked before, as Domains or as the faces of a partition), the rings' segment
    `tags` and `sizes`, each domain's point count: the rings' signed areas summed, the bounding
    box of all their points."""

    def __init__(self, rings: Sequence[NDArray[np.float64]], tags: Sequence[NDArray[np.int64]],
                 sizes: Sequence[int]) -> None:
        self._store(list(rings), list(tags), float(sum(signed_area(R) for R in rings)))
        self._tag_names, self._regions, self._region_names, self._partition = {}, (), {}, None
        self.sizes = np.asarray(sizes)

    @property
    def bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return self.seeds.min(axis=0), self.seeds.max(axis=0)

    def lattice_points(self, H: NDArray[np.float64], h: float, rng: np.random.Generator) -> NDArray[np.float64]:
        """A run's first interior points (constant Q, a size): each domain's own metric lattice,
        placed on its own extent as it would be alone (`seeding.metric_lattice`), not one across
        all, whose place in a small domain would be left to chance."""
        first = np.cumsum([0] + [len(R) for R in self.rings])
        part = np.repeat(np.arange(len(self.sizes)), self.sizes)[first[:-1]]       # of each ring
        out = [np.zeros((0, 2))]
        for p in range(len(self.sizes)):
            r = np.flatnonzero(part == p)
            one = Components([self.rings[k] for k in r], [self.segment_tags[first[k]:first[k + 1]] for k in r],
                             [int(self.sizes[p])])
            out.append(metric_lattice(one, H, h, rng).points)
        return np.concatenate(out)

    def scaled(self, center: Any, scale: float) -> Domain:
        new = Domain.scaled(self, center, scale)        # the area of all outlines, not of one
        new._area = self._area / scale**2
        return new


def joined(parts: Sequence[Domain]) -> Domain:
    """The one domain of `parts`, or their `Components`."""
    if len(parts) == 1:
        return parts[0]
    return Components([R for d in parts for R in d.rings], [d.segment_tags for d in parts],
                      [len(d.seeds) for d in parts])


def split(mesh: Mesh, parts: Sequence[Domain]) -> list[Mesh]:
    """The mesh of `joined(parts)` as one mesh per part, each with its vertices in the order
    they have in `mesh`; QmeshError when a triangle joins two parts."""
    if len(parts) == 1:
        return [mesh]
    T, n, sizes = mesh.triangles, mesh.n_vertices, np.array([len(d.seeds) for d in parts])
    graph = coo_matrix((np.ones(2 * len(T)), (T[:, [0, 1]].ravel(), T[:, [1, 2]].ravel())), (n, n))
    _, label = connected_components(graph, directed=False)
    start = np.cumsum(sizes) - sizes
    part = np.full(label.max() + 1, -1)
    part[label[start]] = np.arange(len(sizes))
    of = part[label]                                        # the part of every vertex
    if (of < 0).any() or (of[:sizes.sum()] != np.repeat(np.arange(len(sizes)), sizes)).any():
        raise QmeshError("the domains' meshes do not fall apart one per domain")
    E = mesh.boundary_edges
    v, t, e = np.argsort(of, kind="stable"), np.argsort(of[T[:, 0]], kind="stable"), \
        np.argsort(of[E[:, 0]], kind="stable")
    new = np.empty(n, np.int64)
    cut_v, cut_t, cut_e = (np.searchsorted(np.sort(x), np.arange(len(sizes) + 1))
                           for x in (of, of[T[:, 0]], of[E[:, 0]]))
    new[v] = np.arange(n) - np.repeat(cut_v[:-1], np.diff(cut_v))
    out = []
    for p in range(len(sizes)):
        vs, ts, es = v[cut_v[p]:cut_v[p + 1]], t[cut_t[p]:cut_t[p + 1]], e[cut_e[p]:cut_e[p + 1]]
        out.append(Mesh(mesh.points[vs], new[T[ts]], mesh.fixed[vs], new[E[es]],
                        mesh.boundary_tags[es], mesh.tag_names))
    return out
