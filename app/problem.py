"""What is meshed: the domain and the conductivity named by the parameters, in one place.

The session asks here for the `qmesh.Domain` (the VB-gon, a named shape or an uploaded polygon
file) and the `qmesh.Anisotropy` (constant Q from k1, k2, angle, or s(x, y) typed as text) of a
parameter set. The media presets (`MEDIA`: "layered", "inclusion", from `qmesh.domain.media_cases`)
bring their own regions and a conductivity per region, `{region tag: Anisotropy}`: for them
k1, k2, angle and s(x, y) do not apply.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

import qmesh
from qmesh import domains
from qmesh.conductivity.anisotropy import principal_matrix
from qmesh.domain import polygon_file
from qmesh.errors import QmeshError
from qmesh.domain import media_cases as cases

MEDIA = {"layered": (cases.layered, {0: "layer 1 (bottom)", 1: "layer 2", 2: "layer 3",
                                     3: "layer 4", 4: "layer 5 (top)"}),
         "inclusion": (cases.inclusion, {0: "background", 1: "star", 2: "lens"})}
"""Media presets: the `qmesh.domain.media_cases` builder and the names the viewer gives their regions
(the case's own `region_names` win where it has them)."""

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
    return list(domains.NAMED) + list(MEDIA) + [FILE_PREFIX + name for name in uploads]


def make_domain(p, uploads: dict) -> qmesh.Domain:
    """The domain named by the parameters `p`: the VB-gon, a named shape or an uploaded file.

    QmeshError when the name is unknown or the target does not exceed the domain's seeds.
    """
    if p.domain == DISK:
        domain = qmesh.Disk(p.vb)
    elif p.domain in domains.NAMED:
        domain = domains.NAMED[p.domain]()
    elif p.domain in MEDIA:
        domain = MEDIA[p.domain][0]()[0]
    elif p.domain.startswith(FILE_PREFIX) and p.domain[len(FILE_PREFIX):] in uploads:
        domain = uploads[p.domain[len(FILE_PREFIX):]]
    else:
        raise QmeshError(f"domain must be one of {domain_names(uploads)}, got {p.domain!r}")
    seeds = len(domain.seeds)
    if p.target_vertices <= seeds:
        raise QmeshError(f"target_vertices ({p.target_vertices}) must exceed the "
                         f"{seeds} seed points of the domain {p.domain!r}")
    return domain


def make_anisotropy(p):
    """Constant Q from k1, k2, angle; or s(x, y) from its text (parsed, never run: a bad text
    raises QmeshError pointing at the offending part); for a media preset its
    `{region tag: Anisotropy}`."""
    if is_medium(p):
        return dict(MEDIA[p.domain][0]()[1])
    if p.q_mode == "expression":
        return qmesh.Anisotropy.from_expression(p.s_text)
    return qmesh.Anisotropy.constant(q_matrix(p.k1, p.k2, p.angle))


def varying(p) -> bool:
    """True when the conductivity varies smoothly over the domain (s given as text)."""
    return p.q_mode == "expression" and not is_medium(p)


def is_medium(p) -> bool:
    """True when the parameters name a media preset (a conductivity per region)."""
    return p.domain in MEDIA


def region_name(domain_name: str, tag: int, mesh_names=None) -> str:
    """The name shown for region `tag`: the mesh's own, else the preset's, else "region k"."""
    names = dict(mesh_names or {})
    if tag in names and names[tag]:
        return str(names[tag])
    preset = MEDIA.get(domain_name, (None, {}))[1]
    return preset.get(tag, "background" if tag == 0 else f"region {tag}")


def regions(domain_name: str, anisotropy, mesh_names=None) -> list[dict]:
    """One row per region of a medium: tag, name and its constant Q (q11, q12, q22; None when
    the region's Q varies); [] for a single conductivity."""
    if not isinstance(anisotropy, Mapping):
        return []
    rows = []
    for tag in sorted(int(t) for t in anisotropy):
        A = anisotropy[tag]
        Q = np.asarray(A.matrix, dtype=float) if A.is_constant else None
        rows.append({"tag": tag, "name": region_name(domain_name, tag, mesh_names),
                     "q11": None if Q is None else float(Q[0, 0]),
                     "q12": None if Q is None else float(Q[0, 1]),
                     "q22": None if Q is None else float(Q[1, 1])})
    return rows


def q_text(row: dict) -> str:
    """A region's Q as one short line: "Q = [[q11, q12], [q12, q22]]" (3 significant digits)."""
    if row["q11"] is None:
        return "Q varies"
    return f"Q = [[{row['q11']:.3g}, {row['q12']:.3g}], [{row['q12']:.3g}, {row['q22']:.3g}]]"


def regions_text(rows: list[dict]) -> str:
    """The Q readout of a medium: every region's name and Q, one line; "" for none."""
    if not rows:
        return ""
    return ("k1, k2, angle and s(x, y) do not apply: one Q per region · "
            + " · ".join(f"{r['name']}: {q_text(r)}" for r in rows))


def read_upload(name: str, content) -> qmesh.Domain:
    """A polygon file (CSV or GeoJSON, by its name's suffix) as a domain; QmeshError if bad."""
    return polygon_file.domain_from_text(content, name)
