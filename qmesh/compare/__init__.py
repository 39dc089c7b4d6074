"""Reproduce the chapter's Tables 2.2/2.3 and Figures 2.15–2.18, beside other mesh generators.

An optional layer on top of qmesh: nothing else in `qmesh` imports it, and its
third-party packages (`triangle`, `matplotlib`, and the peers `gmsh`, `mmgpy`) are imported
inside the functions that need them, through `require`, so a missing one gives a clear message.

    chapter    the chapter's printed Tables 2.2/2.3 as data, and Triangle's area per VB
    isotropic  the isotropic reference meshes (Shewchuk's Triangle, as in the chapter)
    peers      anisotropic peers: gmsh's BAMG and MMG2D (through mmgpy)
    solve      the solver payoff: P1 FEM of −div(Q∇u) = f and CG iteration counts
    figures    Figures 2.15–2.18 (matplotlib)
    table      run_table(): everything above as one Markdown/CSV table
"""

from __future__ import annotations

import importlib

from qmesh.errors import QmeshError

EXTRAS = {"triangle": "compare", "matplotlib": "compare", "gmsh": "peers", "mmgpy": "peers"}


def require(module: str, purpose: str):
    """Import an optional dependency, or raise QmeshError saying how to install it."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:  # also catches a broken native library
        extra = EXTRAS.get(module, "compare")
        raise QmeshError(f"{purpose} needs the optional package '{module}' "
                         f"(pip install {module}, or pip install 'qmesh[{extra}]'): {exc}") from exc
