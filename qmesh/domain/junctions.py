"""Points where regions meet: whether a mesh can keep q_ij ≥ 0 on every side of them.

MEDIA.md §2: each side of an interface keeps its share of q_ij ≥ 0 when its apex lies outside
the edge's diametral ellipse in that side's own metric. Around a point where several regions
meet inside Ω, the first subsegments of the interfaces must satisfy all the wedges at once;
`check_junctions` refuses, before any meshing, the points where no lengths can.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from qmesh.errors import QmeshError
from qmesh.geometry.portable import arctan2, dot2, log, times2

CROWD = 1e-10    # a split point this near an end of its edge (× the face's extent) is refused


def check_junctions(part: Any, anis: list, face_name: Callable[[int], str]) -> None:
    """Refuse a point inside Ω where regions meet and no mesh can keep each side's q_ij ≥ 0.

    Around such a point the faces' wedges alternate with the interface edges e_0 … e_{n-1}. The
    first vertex on e_i lies at some distance ℓ_i; a wedge of metric angle θ < 90° between e_i
    and e_{i+1} (metric stretches a_i, a_{i+1} along them) keeps its two first subsegments
    unencroached only if their metric lengths are within a factor 1/cos θ of each other:
    |log ℓ_{i+1} − log ℓ_i + log(a_{i+1}/a_i)| ≤ −log cos θ. Around the point the log ℓ
    differences sum to zero, so some ℓ exist exactly when |Σ log(a_{i+1}/a_i)| ≤ Σ −log cos θ."""
    V, E, ef = part.points, part.edges, part.edge_faces
    deg = np.bincount(E.ravel(), minlength=len(V))
    on_boundary = np.zeros(len(V), bool)
    on_boundary[E[~part.interface].ravel()] = True
    inner = (deg >= 3) & ~on_boundary
    for v in np.flatnonzero(inner):
        es = np.flatnonzero((E == v).any(axis=1))
        first = E[es, 0] == v
        d = V[np.where(first, E[es, 1], E[es, 0])] - V[v]
        d = d / np.hypot(d[:, 0], d[:, 1])[:, None]
        order = np.argsort(arctan2(d[:, 1], d[:, 0]))
        es, first, d = es[order], first[order], d[order]
        face = np.where(first, ef[es, 0], ef[es, 1])          # the wedge left of v → e_i
        shift, slack, what = 0.0, 0.0, []
        for i in range(len(es)):
            a, b, f = d[i], d[(i + 1) % len(es)], int(face[i])
            A = anis[f]
            H = np.asarray(A.H if A.is_constant else A.hessian(V[v][None])[0], float)
            H = H / np.abs(H).max()
            la, lb = np.sqrt(dot2(a, times2(a, H))), np.sqrt(dot2(b, times2(b, H)))
            cos = dot2(times2(a, H), b) / (la * lb)
            reflex = a[0] * b[1] - a[1] * b[0] <= 0
            if reflex or cos <= 0:
                break            # a wedge of 90° or more absorbs any mismatch
            shift += float(log(lb / la))
            slack += -float(log(cos))
            what.append(f"{face_name(f)} {np.degrees(np.arccos(min(cos, 1.0))):.3g}°")   # measures only
        else:
            if abs(shift) > slack * (1 + 1e-9):
                raise QmeshError(
                    f"regions meet at the point {V[v].tolist()} with angles "
                    f"{', '.join(what)} in their own metrics: no mesh keeps every q_ij ≥ 0 "
                    "on both sides of the interfaces there (splitting them towards the point "
                    "never ends); move a corner off that point, or let the regions meet along "
                    "an edge (e.g. a thin region between them)")


def crowded_junction(x: np.ndarray, a: np.ndarray, b: np.ndarray, corners: np.ndarray,
                     extent: float) -> None:
    """QmeshError naming the point where regions meet when a split point x of an edge a→b comes
    within round-off (CROWD × the face's `extent`) of an end of its edge: around that point the
    splits that keep each side's q_ij ≥ 0 chase each other towards it — wedges whose first
    lengths must match more closely than the splits land, though `check_junctions` finds such
    lengths exist."""
    d = np.minimum(np.hypot(*(x - a).T), np.hypot(*(x - b).T))
    near = d <= CROWD * extent
    if not near.any() or not len(corners):
        return
    c = corners[np.argmin(np.hypot(*(corners - x[np.argmax(near)]).T))].tolist()
    raise QmeshError(f"regions meet at the point {c} at angles whose interfaces' splits run towards "
                     "it without end: the points that keep every q_ij ≥ 0 on both sides come closer "
                     "together than floating point resolves; move a corner off that point, or let "
                     "the regions meet along an edge (e.g. a thin region between them)")
