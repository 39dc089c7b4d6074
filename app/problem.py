"""What is meshed: the domain and the conductivity named by the parameters, in one place.

The session asks here for the `qmesh.Domain` (the VB-gon, a named shape or an uploaded polygon
file) and the `qmesh.Anisotropy` (constant Q from k1, k2, angle, or s(x, y) typed as text) of a
parameter set; media (regions with their own conductivity) belong here too.
"""

from __future__ import annotations

import numpy as np

import qmesh
from qmesh import domains
from qmesh.conductivity.anisotropy import principal_matrix
from qmesh.domain import polygon_file
from qmesh.errors import QmeshError

DISK = "disk"
FILE_PREFIX = "file: "
"""Uploaded polygon files are domains named "file: <file name>"."""
Q_MODES = ("constant", "expression")
"""How the conductivity is given: constant Q (k1, k2, angle) or s(x, y) as text."""
S_PRESETS = ("exp(x) + y**2", "cosh(3*x) + 0.02*y**2", "x**4 + y**4 + x**2 + y**2",
             "log(exp(2*x) + exp(-2*x) + exp(2*y))")


def q_matrix(k1: float, k2: float, angle: float) -> np.ndarray:
    """Q = R diag(k1, k2) Rᵀ, R the rotation by `angle` degrees; round-off below 1e-12·max zeroed."""
    Q = principal_matrix(k1, k2, angle)
    Q[np.abs(Q) < 1e-12 * np.abs(Q).max()] = 0.0
    return 0.5 * (Q + Q.T)


def domain_names(uploads=()) -> list[str]:
    """The domains on offer: the named shapes of `qmesh.domains` (the disk first), then uploads."""
    return list(domains.NAMED) + [FILE_PREFIX + name for name in uploads]


def make_domain(p, uploads: dict) -> qmesh.Domain:
    """The domain named by the parameters `p`: the VB-gon, a named shape or an uploaded file.

    QmeshError when the name is unknown or the target does not exceed the domain's seeds.
    """
    if p.domain == DISK:
        domain = qmesh.Disk(p.vb)
    elif p.domain in domains.NAMED:
        domain = domains.NAMED[p.domain]()
    elif p.domain.startswith(FILE_PREFIX) and p.domain[len(FILE_PREFIX):] in uploads:
        domain = uploads[p.domain[len(FILE_PREFIX):]]
    else:
        raise QmeshError(f"domain must be one of {domain_names(uploads)}, got {p.domain!r}")
    seeds = len(domain.seeds)
    if p.target_vertices <= seeds:
        raise QmeshError(f"target_vertices ({p.target_vertices}) must exceed the "
                         f"{seeds} seed points of the domain {p.domain!r}")
    return domain


def make_anisotropy(p) -> qmesh.Anisotropy:
    """Constant Q from k1, k2, angle; or s(x, y) from its text (parsed, never run: a bad text
    raises QmeshError pointing at the offending part)."""
    if p.q_mode == "expression":
        return qmesh.Anisotropy.from_expression(p.s_text)
    return qmesh.Anisotropy.constant(q_matrix(p.k1, p.k2, p.angle))


def varying(p) -> bool:
    """True when the conductivity varies over the domain (s given as text)."""
    return p.q_mode == "expression"


def read_upload(name: str, content) -> qmesh.Domain:
    """A polygon file (CSV or GeoJSON, by its name's suffix) as a domain; QmeshError if bad."""
    return polygon_file.domain_from_text(content, name)
