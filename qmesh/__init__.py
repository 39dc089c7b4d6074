"""qmesh — triangle meshes adapted to an anisotropic conductivity Q = adj ∇²s.

The Q-Delaunay connectivity, the generalised optimal-Delaunay vertex step and metric-quality
point insertion of the thesis chapter "Q-adapted meshes" (Section 2.3, Algorithm 2.1).

    >>> import qmesh
    >>> m = qmesh.mesh(qmesh.Disk(64), qmesh.Anisotropy.constant([[0.1, 0], [0, 10]]),
    ...                target_vertices=212, seed=0)
"""

from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.conductivity.field import TensorField
from qmesh.domain.domain import Disk, Domain, Polygon
from qmesh.errors import QmeshError, QmeshWarning
from qmesh.triangle_mesh import Mesh
from qmesh.meshing import iterate, mesh
from qmesh.mesher.step import Stats, Step
from qmesh import io, measure  # io imports meshio only when a file is read or written
from qmesh.domain import named as domains
from qmesh.mesher import diagnose
from qmesh import media   # heterogeneous media: a conductivity per region

__all__ = ["Anisotropy", "TensorField", "Disk", "Domain", "Polygon", "domains", "Mesh", "Step", "Stats", "QmeshError",
           "QmeshWarning", "iterate", "mesh", "io", "measure", "diagnose", "media"]
__version__ = "0.1.0"

CHAPTER_Q = ((0.1, 0.0), (0.0, 10.0))
"""The chapter's test conductivity (2.95): Q = diag(0.1, 10)."""
