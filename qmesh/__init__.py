"""qmesh — triangle meshes adapted to an anisotropic conductivity Q = adj ∇²s.

The Q-Delaunay connectivity, the generalised optimal-Delaunay vertex step and metric-quality
point insertion of the thesis chapter "Q-adapted meshes" (Section 2.3, Algorithm 2.1).

    >>> import qmesh
    >>> m = qmesh.mesh(qmesh.Disk(64), qmesh.Anisotropy.constant([[0.1, 0], [0, 10]]),
    ...                target_vertices=212, seed=0)
"""

from .anisotropy import Anisotropy
from .domain import Disk, Domain, Polygon
from .errors import QmeshError
from .mesh import Mesh, Stats, Step
from .mesher import iterate, mesh
from . import domains, measure

__all__ = ["Anisotropy", "Disk", "Domain", "Polygon", "domains", "Mesh", "Step", "Stats", "QmeshError",
           "iterate", "mesh", "measure"]
__version__ = "0.1.0"

CHAPTER_Q = ((0.1, 0.0), (0.0, 10.0))
"""The chapter's test conductivity (2.95): Q = diag(0.1, 10)."""
