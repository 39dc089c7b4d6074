"""Everything a writer puts in a file, checked once: the `Payload` of a Mesh.

`payload(mesh, anisotropy, point_data, cell_data)` validates the mesh, the tags, the regions
and the caller's data before any file is touched; every writer (`qmesh.io.registry`) then
only lays the arrays out in its format.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from qmesh.errors import QmeshError
from qmesh.io import boundary, conductivity, metadata
from qmesh.measure import quality
from qmesh.triangle_mesh import Mesh

MEANS = ("Q11", "Q12", "Q22")
"""The cell data names of the element means Q̄_T (`Mesh.conductivity`), one float per triangle each."""
RESERVED = {"fixed", "quality", "boundary_tag", "region", "medit:ref", "gmsh:physical", "gmsh:geometrical",
            "gmsh:dim_tags", "qmesh:vertex", "cell_tags", *MEANS}
"""Data names qmesh's own arrays use in files."""


@dataclass(frozen=True)
class Payload:
    points: np.ndarray          # (N, 2)
    triangles: np.ndarray       # (M, 3), counter-clockwise
    fixed: np.ndarray           # (N,) int32
    edges: np.ndarray           # (k, 2), Ω on the left
    tags: np.ndarray            # (k,) boundary tags ≥ 1
    regions: np.ndarray         # (M,) region tags ≥ 0
    offset: int                 # region tag + offset = the file's cell tag (gmsh numbering)
    tag_ids: dict               # {boundary tag: identifier}
    region_ids: dict            # {region tag: identifier}
    point_data: dict            # {name: (N, …)}
    cell_data: Mapping          # {name: (M, …)} per triangle; "quality" measured when read
    meta: str                   # qmesh's metadata line (JSON)
    has_conductivity: bool
    means: dict                 # {"Q11": (M,), "Q12": (M,), "Q22": (M,)} float64, or {} without element means

    @property
    def cell_tags(self) -> np.ndarray:
        """The triangles' tags in gmsh numbering (distinct from every boundary tag, ≥ 1)."""
        return (self.regions + self.offset).astype(np.int32)

    def field_data(self) -> dict[str, np.ndarray]:
        """meshio's named groups {identifier: [tag, dim]}: edges dim 1, triangles dim 2 (gmsh numbering)."""
        out = {name: np.array([t, 1]) for t, name in self.tag_ids.items()}
        out.update({name: np.array([r + self.offset, 2]) for r, name in self.region_ids.items()
                    if name not in out})
        return out


def payload(mesh, anisotropy=None, point_data=None, cell_data=None) -> Payload:
    if not isinstance(mesh, Mesh):
        raise QmeshError(f"mesh must be a qmesh.Mesh, got {type(mesh).__name__}")
    stored = None if anisotropy is None else conductivity.to_json(anisotropy)
    pdata = _per_item(point_data, mesh.n_vertices, "point data")
    cdata = _per_item(cell_data, mesh.n_triangles, "cell data")
    reserved = (RESERVED & pdata.keys()) | (RESERVED & cdata.keys())
    if reserved:
        raise QmeshError(f"data names {sorted(reserved)} are reserved for qmesh's own fields")
    E, tags, tag_names = boundary.boundary_of(mesh)
    regions, region_names = boundary.regions_of(mesh)
    if anisotropy is not None:      # (2.94), measured when a writer reads it (.msh 2.2 does not)
        _check_regions(anisotropy, regions)
        cdata = _WithQuality(cdata, lambda: _quality(mesh, anisotropy, regions))
    offset = boundary.region_offset(tags, regions)
    doc = {"tag_names": {str(k): v for k, v in sorted(tag_names.items())},
           "region_names": {str(k): v for k, v in sorted(region_names.items())}, "region_offset": offset}
    if stored is not None:
        doc["conductivity"] = stored
    if not region_names and np.all(regions == 0):
        region_names = {0: "domain"}  # one group for the whole mesh, named for the clients
    return Payload(points=np.asarray(mesh.points, float), triangles=np.asarray(mesh.triangles, np.int64),
                   fixed=mesh.fixed.astype(np.int32), edges=E, tags=tags, regions=regions, offset=offset,
                   tag_ids=boundary.file_names(tags, tag_names, "boundary"),
                   region_ids=boundary.file_names(regions, region_names, "region"),
                   point_data=pdata, cell_data=cdata, meta=metadata.dumps(doc),
                   has_conductivity=stored is not None, means=means_of(mesh))


class _WithQuality(Mapping):
    """The caller's cell data and "quality", computed on first reading and kept: a format that
    keeps no cell data never pays for the pass over the triangles."""

    def __init__(self, data: dict, quality) -> None:
        self._data, self._quality = dict(data), quality

    def __getitem__(self, name: str) -> np.ndarray:
        if name == "quality" and callable(self._quality):
            self._quality = self._quality()
        return self._quality if name == "quality" else self._data[name]

    def __iter__(self):
        return iter([*self._data, "quality"])

    def __len__(self) -> int:
        return len(self._data) + 1


def means_of(mesh: Mesh) -> dict[str, np.ndarray]:
    """The element means of `mesh` as {"Q11", "Q12", "Q22": (M,)}, or {} when it has none.

    The means of an SPD field are symmetric; a mesh whose means are not (beyond round-off) is
    refused rather than written as three numbers that would not give its matrices back.
    """
    Q = mesh.conductivity
    if Q is None:
        return {}
    Q = np.asarray(Q, dtype=np.float64)
    scale = np.abs(Q).max(axis=(1, 2)) if len(Q) else np.zeros(0)
    bad = np.flatnonzero(np.abs(Q[:, 0, 1] - Q[:, 1, 0]) > 1e-12 * scale)
    if len(bad):
        raise QmeshError(f"mesh.conductivity[{bad[0]}] is not symmetric ({Q[bad[0]].tolist()}); "
                         "files keep the element means as Q11 Q12 Q22")
    return {"Q11": Q[:, 0, 0].copy(), "Q12": 0.5 * (Q[:, 0, 1] + Q[:, 1, 0]), "Q22": Q[:, 1, 1].copy()}


def _quality(mesh, anisotropy, regions) -> np.ndarray:
    """Metric quality (2.94) of each triangle in its own region's metric."""
    if not isinstance(anisotropy, Mapping):
        return quality(mesh, anisotropy)
    q = np.empty(mesh.n_triangles)
    for tag, a in anisotropy.items():
        q[regions == tag] = quality(mesh, a)[regions == tag]
    return q


def _check_regions(anisotropy, regions) -> None:
    """A conductivity per region must name every region of the mesh (checked before any file)."""
    if isinstance(anisotropy, Mapping):
        missing = sorted(set(np.unique(regions).tolist()) - set(int(k) for k in anisotropy))
        if missing:
            raise QmeshError(f"anisotropy: no conductivity for region tags {missing} of the mesh")


def _per_item(data, n: int, what: str) -> dict[str, np.ndarray]:
    """Validate a name → numeric array mapping whose arrays have one row per vertex/triangle."""
    if data is None:
        return {}
    if not isinstance(data, Mapping):
        raise QmeshError(f"{what} must be a dict of name → array, got {type(data).__name__}")
    out = {}
    for name, values in data.items():
        if not isinstance(name, str) or not name.strip():
            raise QmeshError(f"{what} names must be non-empty strings, got {name!r}")
        try:
            a = np.asarray(values)
        except (ValueError, TypeError) as e:  # ragged lists
            raise QmeshError(f"{what}[{name!r}] is not an array: {e}") from e
        if a.dtype != bool and not np.issubdtype(a.dtype, np.number) or np.iscomplexobj(a):
            raise QmeshError(f"{what}[{name!r}] must hold real numbers, got dtype {a.dtype}")
        if a.ndim not in (1, 2) or a.shape[0] != n:
            raise QmeshError(f"{what}[{name!r}] must have {n} rows (shape ({n},) or ({n}, k)), got shape {a.shape}")
        if a.dtype == bool:
            a = a.astype(np.int32)
        out[name] = a
    return out
