"""What is meshed: the domain and the conductivity named by the parameters, in one place.

The session asks here for the `qmesh.Domain` (the VB-gon, a named shape or an uploaded polygon
file) and the `qmesh.Anisotropy` (constant Q from k1, k2, angle, or s(x, y) typed as text) of a
parameter set. The media presets (`MEDIA`: "layered", "inclusion", from `qmesh.domain.media_cases`)
bring their own regions and a conductivity per region, `{region tag: Anisotropy}`; the field
presets (`FIELDS`: "rotating", "raster") the unit square and a conductivity field
`qmesh.TensorField` Q(x), which has no s. For both, k1, k2, angle and s(x, y) do not apply.
"""

from __future__ import annotations

import threading
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

FVCA5_TEST5 = ("(0.001*x**2 + y**2)/(x**2 + y**2)", "(0.001 - 1)*x*y/(x**2 + y**2)",
               "(x**2 + 0.001*y**2)/(x**2 + y**2)")
"""FVCA5 test 5 (Herbin & Hubert 2008), δ = 1e-3: Q11, Q12, Q22 rotating about the origin."""
RASTER_CELLS = 64
RASTER_SEED = 0


def rotating_field() -> qmesh.TensorField:
    """FVCA5 test 5: K = [[δx² + y², (δ−1)xy], [(δ−1)xy, x² + δy²]] / (x² + y²), δ = 1e-3: a
    1000 : 1 anisotropy whose weak axis points at the origin (a corner of the unit square)."""
    return qmesh.TensorField.from_expressions(*FVCA5_TEST5)


def raster_field() -> qmesh.TensorField:
    """A 64 × 64 raster on the unit square, every cell different: k1, k2 = exp(N(0, 1)) and the
    angle of k1 uniform in [0, 180) degrees, drawn with `numpy.random.default_rng(0)`."""
    rng = np.random.default_rng(RASTER_SEED)
    n = RASTER_CELLS
    edges = np.linspace(0.0, 1.0, n + 1)
    k1, k2 = np.exp(rng.normal(size=(n, n))), np.exp(rng.normal(size=(n, n)))
    return qmesh.TensorField.from_raster(edges, edges, k1, k2, rng.uniform(0.0, 180.0, (n, n)))


def unit_square() -> qmesh.Domain:
    return qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)])


FIELDS = {"rotating": (rotating_field, "FVCA5 test 5, a rotating 1000 : 1 anisotropy"),
          "raster": (raster_field, "a 64 × 64 lognormal raster of k1, k2 with random angles, "
                                   "every cell different")}
"""Field presets: the conductivity field's builder and what the viewer says it is. Their domain
is the unit square."""

DISK = "disk"
CHAPTER_TARGET = 212
"""The default target N: the chapter's case (2.95)."""
PRESET_TARGETS = {"layered": 800, "inclusion": 1000, "rotating": 500}
"""The presets whose own default target differs from the chapter's: at 212 vertices the thinnest
layers and the star get no interior vertex (the mesher warns), and the rotating field's
certification ends over 10% above the target; at these each meshes without a warning."""
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
    return (list(domains.NAMED) + list(MEDIA) + list(FIELDS)
            + [FILE_PREFIX + name for name in uploads])


def default_target(domain_name: str) -> int:
    """The target N a domain opens with: its preset's own (`PRESET_TARGETS`), else 212."""
    return PRESET_TARGETS.get(domain_name, CHAPTER_TARGET)


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
    elif p.domain in FIELDS:
        domain = unit_square()
    elif p.domain.startswith(FILE_PREFIX) and p.domain[len(FILE_PREFIX):] in uploads:
        domain = uploads[p.domain[len(FILE_PREFIX):]]
    else:
        raise QmeshError(f"domain must be one of {domain_names(uploads)}, got {p.domain!r}")
    seeds = len(domain.seeds)
    target = default_target(p.domain) if p.target_vertices is None else p.target_vertices
    if target <= seeds:
        raise QmeshError(f"target_vertices ({target}) must exceed the "
                         f"{seeds} seed points of the domain {p.domain!r}")
    return domain


def make_anisotropy(p):
    """Constant Q from k1, k2, angle; or s(x, y) from its text (parsed, never run: a bad text
    raises QmeshError pointing at the offending part); for a media preset its
    `{region tag: Anisotropy}`, for a field preset its `qmesh.TensorField`."""
    if is_medium(p):
        return dict(MEDIA[p.domain][0]()[1])
    if is_field(p):
        return FIELDS[p.domain][0]()
    if p.q_mode == "expression":
        return qmesh.Anisotropy.from_expression(p.s_text)
    return qmesh.Anisotropy.constant(q_matrix(p.k1, p.k2, p.angle))


def varying(p) -> bool:
    """True when the conductivity varies over the domain (s given as text, or a field): the
    memory budget counts such a run at its larger figure per vertex."""
    return is_field(p) or (p.q_mode == "expression" and not is_medium(p))


def is_medium(p) -> bool:
    """True when the parameters name a media preset (a conductivity per region)."""
    return p.domain in MEDIA


def is_field(p) -> bool:
    """True when the parameters name a field preset (a conductivity field Q(x), no s)."""
    return p.domain in FIELDS


def field_text(domain_name: str, field) -> str:
    """The Q readout of a field preset: what it is and the field's label, one line; "" for
    anything else."""
    if domain_name not in FIELDS:
        return ""
    return (f"k1, k2, angle and s(x, y) do not apply: Q(x) is a field · {domain_name}: "
            f"{FIELDS[domain_name][1]} · {field.label}")


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


def is_field_conductivity(conductivity) -> bool:
    """True for a conductivity field `qmesh.TensorField` (no s: no lifted surface)."""
    return isinstance(conductivity, qmesh.TensorField)


SHOWN_RTOL = 1e-6
"""The quadrature tolerance of the means shown for a stage before the last (the repair's own,
`qmesh.fields.cache.RTOL`): they colour the pictures and count the q_ij signs of a mesh that is
replaced a moment later; at the field's own 1e-10 they took four fifths of a Run on the rotating
preset. Their error bounds are not proven (`bound_rtol=None`): the last Step carries the certified
means."""
_MEANS: dict = {}
_MEANS_KEPT = 8
_MEANS_LOCK = threading.Lock()      # the app draws on its loop and measures in a worker


def element_means(mesh, field) -> np.ndarray:
    """Each triangle's own mean Q̄_T (M, 2, 2) of a field on `mesh`: the means the mesh carries
    (`mesh.conductivity`: a field's last Step, the means it was certified with), else the field's
    means at `SHOWN_RTOL` (a stage before it). Kept for the last few meshes: the quality
    view, the q_ij signs and the status line all ask for the same ones."""
    if mesh.conductivity is not None:
        return np.asarray(mesh.conductivity, dtype=float)
    key = (id(mesh), id(field))
    with _MEANS_LOCK:
        hit = _MEANS.get(key)
    if hit is None or hit[0] is not mesh or hit[1] is not field:
        Q = field.means_with_error(mesh.points, mesh.triangles, rtol=SHOWN_RTOL,
                                   bound_rtol=None)[0]    # shown, not certified: no proof
        hit = (mesh, field, np.asarray(Q, dtype=float))
        with _MEANS_LOCK:
            while len(_MEANS) >= _MEANS_KEPT:
                _MEANS.pop(next(iter(_MEANS)))
            _MEANS[key] = hit
    return hit[2]


def means_source(mesh) -> str:
    """Where a field mesh's element means come from: "certified" (carried by the mesh, the last
    Step) or "field" (computed from the field for a stage before it)."""
    return "certified" if mesh.conductivity is not None else "field"
