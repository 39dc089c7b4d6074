"""The boundary and the regions as a file carries them: oriented edges with tags, and names
that every reader accepts.

A solver needs to know which boundary edge gets which condition (Dirichlet on the outline,
Neumann on a hole…) and which triangle belongs to which region: `Mesh.boundary_edges` (k, 2)
with `boundary_tags` (k,) and `tag_names`, `Mesh.region_tags` (M,) with `region_names`. In a
file the edges are line cells next to the triangles, each with its tag (the registry,
`qmesh.io.registry`, says how each format keeps them).

Group names in files are plain identifiers (`identifier`: "outer wall" → "outer_wall"), since
gmsh readers such as NGSolve's cut a name at its first space; the exact names travel in qmesh's
metadata (`qmesh.io.metadata`). Readers that look a group up by its number alone (scikit-fem's
gmsh path) need the numbers of edge groups and triangle groups to differ: triangles of region r
carry the *cell tag* r + `region_offset` in gmsh files and "gmsh:physical" arrays.
"""

from __future__ import annotations

import re

import numpy as np

from qmesh.errors import QmeshError
from qmesh.geometry import topology

_NOT_WORD = re.compile(r"[^A-Za-z0-9_]+")


def boundary_of(mesh) -> tuple[np.ndarray, np.ndarray, dict[int, str]]:
    """(edges, tags, names) of `mesh`, edges oriented with their triangle on the left.

    Tags default to 1 and names to {} for a Mesh that has none (meshes from other programs).
    """
    E = np.asarray(mesh.boundary_edges, dtype=np.int64).reshape(-1, 2)
    tags = getattr(mesh, "boundary_tags", None)
    tags = np.ones(len(E), np.int64) if tags is None else np.asarray(tags, dtype=np.int64)
    if tags.shape != (len(E),):
        raise QmeshError(f"mesh: boundary_tags has shape {tags.shape}, expected ({len(E)},)")
    if len(tags) and (tags.min() < 1 or tags.max() > np.iinfo(np.int32).max):
        raise QmeshError(f"mesh: boundary_tags must be integers from 1 to 2**31 - 1 (0 marks the triangles "
                         f"in files), got {tags.min()} to {tags.max()}")
    names = {int(k): str(v) for k, v in (getattr(mesh, "tag_names", None) or {}).items()}
    return _oriented(mesh.triangles, E, mesh.n_vertices), tags, names


def _oriented(T: np.ndarray, E: np.ndarray, n: int) -> np.ndarray:
    """Edges turned so each runs as in its (counter-clockwise) triangle: Ω on the left.

    Only the half-edges between two of the edges' vertices can match one: those are sorted,
    not the mesh's 3M."""
    on = np.zeros(max(n, 1), bool)
    on[E.ravel()] = True
    a, b = T.ravel(), T[:, [1, 2, 0]].ravel()
    near = on[a] & on[b]
    half = np.sort(a[near] * np.int64(n) + b[near])
    key = E[:, 0] * np.int64(n) + E[:, 1]
    at = np.minimum(np.searchsorted(half, key), max(len(half) - 1, 0))
    backwards = ~(half[at] == key) if len(half) else np.ones(len(E), bool)
    E = E.copy()
    E[backwards] = E[backwards][:, ::-1]
    return E


def filler(a: np.ndarray, k: int) -> np.ndarray:
    """Values for `k` line cells of a per-triangle data array: NaN for floats, 0 otherwise."""
    return np.full((k,) + a.shape[1:], np.nan if a.dtype.kind == "f" else 0, dtype=a.dtype)


def tags_on(mesh, E: np.ndarray, tags: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The boundary edges of `mesh`'s triangles (Ω on the left) and the tag of the file's line
    cell on each (1 where the file has none, or a tag ≤ 0: gmsh's "no physical group").

    Line cells that are not boundary edges of the triangles are ignored.
    """
    n = np.int64(max(mesh.n_vertices, 1))
    B = np.asarray(mesh.boundary_edges)  # from the triangles, Ω on the left
    kb, kf = edge_keys(B, n), edge_keys(E, n)
    order = np.argsort(kf, kind="stable")
    pos = np.minimum(np.searchsorted(kf[order], kb), max(len(kf) - 1, 0))
    hit = (kf[order][pos] == kb) if len(kf) else np.zeros(len(kb), bool)
    out = np.ones(len(B), np.int64)
    out[hit] = tags[order[pos[hit]]]
    out[out <= 0] = 1
    return B, out




def edge_keys(E: np.ndarray, n) -> np.ndarray:
    """One int64 per undirected edge of an edge array (k, 2) (`topology.edge_keys`)."""
    E = np.asarray(E, dtype=np.int64).reshape(-1, 2)
    return topology.edge_keys(E[:, 0], E[:, 1], int(n))


def regions_of(mesh) -> tuple[np.ndarray, dict[int, str]]:
    """(region tag per triangle, region names) of `mesh`, with the tags checked for files."""
    regions = np.asarray(getattr(mesh, "region_tags", None) if getattr(mesh, "region_tags", None) is not None
                         else np.zeros(mesh.n_triangles, np.int64), dtype=np.int64)
    if len(regions) and (regions.min() < 0 or regions.max() > np.iinfo(np.int32).max // 2):
        raise QmeshError(f"mesh: region_tags must be integers from 0 to 2**30 - 1, got {regions.min()} "
                         f"to {regions.max()}")
    names = {int(k): str(v) for k, v in (getattr(mesh, "region_names", None) or {}).items()}
    return regions, names


def region_offset(tags: np.ndarray, regions: np.ndarray) -> int:
    """What to add to a region tag to make it a file's cell tag: 0 when every region tag is
    already ≥ 1 and differs from every boundary tag, else one past the largest boundary tag."""
    used = distinct(regions)
    if len(used) and used.min() >= 1 and not np.isin(used, tags).any():
        return 0
    return int(tags.max(initial=0)) + 1 - (int(used.min()) if len(used) else 0)


def distinct(tags: np.ndarray) -> np.ndarray:
    """`np.unique(tags)` of integer tags; over a range of values no longer than the array, by
    counting (the regions of a million triangles: no sort)."""
    tags = np.asarray(tags).ravel()
    if not len(tags) or tags.dtype.kind not in "iu":
        return np.unique(tags)
    low, high = int(tags.min()), int(tags.max())
    if high - low > len(tags):
        return np.unique(tags)
    return (np.flatnonzero(np.bincount(tags - low, minlength=1)) + low).astype(tags.dtype)


def identifier(name: str, fallback: str) -> str:
    """`name` as a plain identifier (letters, digits, _; not starting with a digit)."""
    text = _NOT_WORD.sub("_", name).strip("_")
    if not text:
        return fallback
    return f"_{text}" if text[0].isdigit() else text


def file_names(tags, names: dict[int, str], kind: str) -> dict[int, str]:
    """{tag: identifier} for every tag in `tags`: the user's name made an identifier, or
    `kind`_tag; a name that two tags would share gets its tag appended."""
    out, seen = {}, set()
    for t in distinct(np.asarray(tags, dtype=np.int64)).tolist():       # sorted, distinct
        name = identifier(names[t], f"{kind}_{t}") if t in names else f"{kind}_{t}"
        if name in seen:
            name = f"{name}_{t}"
        seen.add(name)
        out[t] = name
    return out
