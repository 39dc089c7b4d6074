"""qmesh — triangle meshes adapted to an anisotropic conductivity Q = adj ∇²s.

The Q-Delaunay connectivity, the generalised optimal-Delaunay vertex step and metric-quality
point insertion of the thesis chapter "Q-adapted meshes" (Section 2.3, Algorithm 2.1).

    >>> import qmesh
    >>> m = qmesh.mesh(qmesh.Disk(64), qmesh.Anisotropy.constant([[0.1, 0], [0, 10]]),
    ...                target_vertices=212, seed=0)

The names below are imported on first use (PEP 562), so `qmesh --version` and `qmesh --help`
load neither NumPy nor SciPy.
"""

from __future__ import annotations

import importlib
import importlib.util
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:   # for type checkers and IDEs; at run time `__getattr__` loads them
    from qmesh.conductivity.anisotropy import Anisotropy
    from qmesh.conductivity.field import TensorField
    from qmesh.domain.domain import Disk, Domain, Polygon
    from qmesh.errors import QmeshError, QmeshWarning
    from qmesh.triangle_mesh import Mesh
    from qmesh.meshing import iterate, mesh
    from qmesh.mesher.step import Stats, Step
    from qmesh import io, measure, media
    from qmesh.domain import named as domains
    from qmesh.mesher import diagnose

_LAZY = {
    "Anisotropy": ("qmesh.conductivity.anisotropy", "Anisotropy"),
    "TensorField": ("qmesh.conductivity.field", "TensorField"),
    "Disk": ("qmesh.domain.domain", "Disk"),
    "Domain": ("qmesh.domain.domain", "Domain"),
    "Polygon": ("qmesh.domain.domain", "Polygon"),
    "QmeshError": ("qmesh.errors", "QmeshError"),
    "QmeshWarning": ("qmesh.errors", "QmeshWarning"),
    "Mesh": ("qmesh.triangle_mesh", "Mesh"),
    "iterate": ("qmesh.meshing", "iterate"),
    "mesh": ("qmesh.meshing", "mesh"),
    "Stats": ("qmesh.mesher.step", "Stats"),
    "Step": ("qmesh.mesher.step", "Step"),
    "io": ("qmesh.io", None),            # io imports meshio only when a file is read or written
    "measure": ("qmesh.measure", None),
    "media": ("qmesh.media", None),      # heterogeneous media: a conductivity per region
    "domains": ("qmesh.domain.named", None),
    "diagnose": ("qmesh.mesher.diagnose", None),
}
"""Public name → (module, attribute in it; None: the module itself)."""

__all__ = ["Anisotropy", "TensorField", "Disk", "Domain", "Polygon", "domains", "Mesh", "Step", "Stats", "QmeshError",
           "QmeshWarning", "iterate", "mesh", "io", "measure", "diagnose", "media"]
__version__ = "0.1.0"

CHAPTER_Q = ((0.1, 0.0), (0.0, 10.0))
"""The chapter's test conductivity (2.95): Q = diag(0.1, 10)."""


def __getattr__(name: str) -> Any:
    """Import a public name, or a subpackage (`qmesh.geometry` after `import qmesh`), on first
    use and keep it on the package."""
    if name not in _LAZY:
        if name.startswith("_") or importlib.util.find_spec(f"qmesh.{name}") is None:
            raise AttributeError(f"module 'qmesh' has no attribute {name!r}")
        return importlib.import_module(f"qmesh.{name}")
    module, attribute = _LAZY[name]
    value = importlib.import_module(module)
    if attribute is not None:
        value = getattr(value, attribute)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
