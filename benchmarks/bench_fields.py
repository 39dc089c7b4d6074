"""Conductivity fields Q(x): qmesh vs MMG2D vs Triangle at equal N, measured on element means
computed here.

Cases (each Q checked symmetric positive definite where it is evaluated):
- fvca5: FVCA5 test 5 (Herbin & Hubert 2008), K = [[δx² + y², (δ−1)xy], [(δ−1)xy, x² + δy²]] /
  (x² + y²), δ = 1e-3, on the unit square, u = sin πx sin πy; singular at the corner (0, 0);
- plasma: field-aligned, Q = εI + (1−ε) b bᵀ, ε = 1e-4, b the unit vector along the level lines
  of ψ = (x − ½)² + 2(y − ½)² (ellipses around the O-point (½, ½)), on the unit square minus a
  32-gon of radius 0.15 around the O-point (where b is undefined); u = sin 2πψ, constant along
  the field lines, so f = −ε Δu and the error is the parallel diffusion's pollution;
- layers: layers whose dip varies smoothly, 1 : 1000: `TensorField.principal(1, 1e-3,
  "30*sin(pi*x)")` (k1 = 1 along the layer, dipping 0° at x = 0, 1 and 30° at x = ½) on the unit
  square, u = sin πx sin πy;
- spiral: a text formula, 1 : 1000, on the unit square minus a 32-gon of radius 0.15 around
  (½, ½): `TensorField.principal(1, 1e-3, angle)`, k1 along the direction at 4π·r radians from
  the radial one (r the distance to (½, ½): two turns across the square), the angle text
  180/π·(atan((y − ½)/(x − ½)) + 4π·r) (the polar angle mod π is a direction); SymPy gets the same
  Q written through cos 2θ and sin 2θ; u = sin πx sin πy;
- islands: magnetic islands as a CALLABLE f(x, y) (NumPy), Q = εI + (1 − ε) b bᵀ/|b|², ε = 1e-4,
  b = (ψ_y, −ψ_x) = (y − ½, 0.1π cos 2πx) along the level lines of ψ = (y − ½)²/2 − 0.05 sin 2πx,
  on the unit square: an O-point (¼, ½) and an X-point (¾, ½) inside it, where b = 0 and Q has
  no limit; u = sin 8πψ, constant along the field lines; every
  call, point and second spent in the callable is counted;
- raster64, raster512: a 64² / 512² raster on the unit square, every cell different (NumPy
  default_rng(20240 + cells), cells independent): k1 lognormal (ln k1 ~ N(0, 1)), k2 = k1 / r with
  log10 r ~ U(0, 2), angle ~ U(0°, 180°) (`TensorField.from_raster`, MODFLOW's convention);
- media: a medium whose regions hold a field and a constant: the unit square with a ten-pointed
  star (radii 0.22 and 0.12 around (0.35, 0.6)) holding the constant 1000 : 1 at 45°, in layers
  of 1 : 100 dipping 30·sin πx degrees — `qmesh.mesh(domain, {0: TensorField, 1: Anisotropy})`; qmesh only (no peer meshes regions with a field), no L2 (Q jumps across the
  star, so no f makes a smooth u exact). Each triangle's region is found here (its centroid
  against the star, even-odd), and an interface edge counts as positive when either side's
  share K_ij^T is, on its own (what a medium guarantees, MEDIA.md §2).

Meshers, each at the same N:
- qmesh: `qmesh.mesh(domain, field, target_vertices=N)`;
- MMG2D (mmgpy): the per-vertex metric adj Q / √det Q (the shape of Q, as qmesh meshes) scaled
  to the same N (`qmesh.compare.field_peers.mmg2d`: Q at the vertex for formulas, Q averaged over
  qmesh's own one-element square for rasters);
- Triangle: isotropic (`pq30a`, area calibrated to N).

Every measurement uses element means Q̄_T computed HERE, not the mesh's: formulas by a collapsed
(Duffy) Gauss–Legendre 6 × 6 rule on the 16 congruent quarters-of-quarters of each triangle
(4⁵ pieces for triangles within 0.05 of a singular point), the formula lambdified from SymPy
(not qmesh's parser); rasters by exact clipping of each triangle against each cell of its box
(vectorised Sutherland–Hodgman, in coordinates centred on the triangle). Columns:
- N;
- positive off-diagonals K_ij > 1e-9 Σ_T |K_ij^T| of the P1 stiffness matrix, interior /
  boundary edges;
- maximum principle: −div(Q∇u) = 0, u = 1 on the boundary where x < ½, 0 elsewhere: vertices
  outside [0, 1] by more than 1e-10, and the worst excess;
- L2 error of P1 against the manufactured u (formulas only): f = −div(Q∇u) exact by SymPy, the
  load by a collapsed Gauss 4 × 4 rule per triangle, the error by a 6 × 6 one, Dirichlet data u
  at the boundary vertices, scipy.sparse spsolve;
- κ2 of the Dirichlet matrix (`qmesh.measure.conditioning` with the means computed here);
- min metric quality (2.94) in each triangle's own H_T = adj Q̄_T / √det Q̄_T (`measure.quality`);
- seconds: qmesh, the whole run (`qmesh.iterate` to its last Step, which is `qmesh.mesh`), a
  new TensorField each run (what qmesh kept of one run's field never serves the next); peers,
  their final calibrated run (wall clock). qmesh and the constant Q run 5 times in their process
  up to N = 2000, twice up to 20 000 and once above, the same mesh each time, and the run of
  least CPU seconds is reported (the first run also pays one-time set-ups such as compiling the
  field's formula; other processes sharing the cores slow some runs, most of all the short
  ones);
- peak memory: every mesher runs in a fresh subprocess (this script with --worker); its peak RSS
  (VmHWM of /proc/self/status) and, in brackets, the growth over the RSS it had after its imports and
  building the field (the peers' over all their calibration runs);
- for qmesh, the seconds of a constant Q on the same domain at the same N, Q̄ the area mean of
  the field over Ω (by the means computed here): as `qmesh.Anisotropy.constant(Q̄)`, the
  baseline a user would pick, and as a constant `TensorField`; a table gives the field's
  seconds over the constant Anisotropy's (wall and CPU) against the targets, 5× at N = 2000
  and 3× at N ≥ 20 000;
- qmesh's seconds per stage, from the Steps of `qmesh.iterate` (`STAGES`): set-up (the field's
  metric and checks: the first Step's wall time less its Stats.seconds), the first
  triangulation, the loop's adjust, insert and triangulate stages, certify and repair (the
  last Step); for the callable, the user evaluations in that run: its calls, the points it was
  given (each once: the TensorField keeps their values), in brackets the points qmesh asked
  for, and its seconds.

raster512 also runs at 2e5 and 1e6 vertices (--big; seconds and peak RSS against MMG2D at 2e5,
against 60 s and 2 GB at 1e6). MMG2D, Triangle and the constant TensorField run up to
a target of 200 000 only (MMG2D calibrates N by whole runs), and above it κ2 and the maximum
principle are not computed (each factorises the whole matrix; left out to keep the run short):
positive off-diagonals, quality and N are.

    python benchmarks/bench_fields.py [--cases fvca5 ...] [--n 2000 20000]
                                      [--big 200000 1000000] [--no-mmg] [--no-page]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass, field as dfield
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import qmesh
from qmesh import measure

try:
    import report_page
except ImportError:                                   # imported from the tests
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import report_page
from corners import corner_bound  # noqa: E402 — beside report_page, found the same way

DELTA = 1e-3
EPSILON = 1e-4
SEED = 20240            # a raster of k × k cells draws from default_rng(SEED + k)
ROUND = 1e-9            # K_ij > ROUND Σ_T |K_ij^T| counts as positive (round-off of the assembly)
MP_TOL = 1e-10          # a vertex beyond [min g, max g] by more than this violates the principle
SINGULAR_REACH = 0.05   # triangles this close to a singular point get 4⁵ pieces


# ------------------------------------------------------------------------------------ cases

@dataclass
class Case:
    """One benchmark case: how to build its domain and field, and (formulas) the texts of Q and
    u for SymPy, or (rasters) its cell arrays."""
    name: str
    kind: str                                    # "formula", "callable", "raster" or "media"
    q_texts: tuple[str, str, str] | None = None  # q11, q12, q22 for SymPy
    u_text: str | None = None
    singular: list[tuple[float, float]] = dfield(default_factory=list)
    cells: int = 0
    hole: bool = False

    def domain(self):
        outline = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
        if self.kind == "media":
            return qmesh.Domain(outline, regions=[STAR])
        if self.hole:
            return qmesh.Domain(outline, [qmesh.Disk(32, radius=0.15, center=(0.5, 0.5))])
        return qmesh.Polygon(outline)

    def raster(self):
        """Cell edges and (k1, k2, angle) arrays (ny, nx) of a raster case."""
        k = self.cells
        rng = np.random.default_rng(SEED + k)
        k1 = np.exp(rng.normal(0.0, 1.0, (k, k)))
        k2 = k1 / 10.0 ** rng.uniform(0.0, 2.0, (k, k))
        angle = rng.uniform(0.0, 180.0, (k, k))
        edges = np.linspace(0.0, 1.0, k + 1)
        return edges, edges, k1, k2, angle

    def field(self):
        """The qmesh TensorField (texts through qmesh's own parser)."""
        if self.kind == "raster":
            return qmesh.TensorField.from_raster(*self.raster())
        if self.kind == "media":
            return {0: qmesh.TensorField.principal(1.0, MEDIA_K2, "30*sin(pi*x)"),
                    1: qmesh.Anisotropy.principal(*STAR_Q)}
        if self.name == "layers":
            return qmesh.TensorField.principal(1.0, 1e-3, "30*sin(pi*x)")
        if self.name == "spiral":
            return qmesh.TensorField.principal(1.0, SPIRAL_K2, SPIRAL_ANGLE)
        if self.kind == "callable":
            return qmesh.TensorField(ISLANDS)
        return qmesh.TensorField.from_expressions(*self.q_texts)


def _fvca5() -> Case:
    d = DELTA
    return Case("fvca5", "formula",
                (f"({d}*x**2 + y**2)/(x**2 + y**2)", f"({d} - 1)*x*y/(x**2 + y**2)",
                 f"(x**2 + {d}*y**2)/(x**2 + y**2)"),
                "sin(pi*x)*sin(pi*y)", singular=[(0.0, 0.0)])


def _plasma() -> Case:
    e = EPSILON
    tx, ty = "(-4*(y - 0.5))", "(2*(x - 0.5))"           # (−ψ_y, ψ_x): along the level lines
    r = f"({tx}**2 + {ty}**2)"
    return Case("plasma", "formula",
                (f"{e} + {1 - e}*{tx}**2/{r}", f"{1 - e}*{tx}*{ty}/{r}", f"{e} + {1 - e}*{ty}**2/{r}"),
                "sin(2*pi*((x - 0.5)**2 + 2*(y - 0.5)**2))", hole=True)


def _layers(k2: str = "0.001", name: str = "layers", kind: str = "formula") -> Case:
    a = "(pi/6*sin(pi*x))"                                 # 30·sin(πx) degrees
    c, s = f"cos{a}", f"sin{a}"
    k1 = "1"
    return Case(name, kind,
                (f"{k1}*{c}**2 + {k2}*{s}**2", f"({k1} - {k2})*{c}*{s}", f"{k1}*{s}**2 + {k2}*{c}**2"),
                "sin(pi*x)*sin(pi*y)")


_STAR_T = 2 * np.pi * np.arange(10) / 10
STAR = np.array([0.35, 0.6]) + (np.where(np.arange(10) % 2 == 0, 0.22, 0.12)[:, None]
                                 * np.column_stack([np.cos(_STAR_T), np.sin(_STAR_T)]))
STAR_Q = (1e3, 1.0, 45.0)          # the star's constant: k1, k2, angle (degrees)
MEDIA_K2 = 0.01                    # the layers around it: 1 : 100


def _media() -> Case:
    return _layers(str(MEDIA_K2), "media", "media")


SPIRAL_K2 = 1e-3                   # the spiral's 1 : 1000
SPIRAL_ANGLE = ("180/pi*(atan((y - 0.5)/(x - 0.5))"     # the polar angle mod π (a direction)
                " + 4*pi*sqrt((x - 0.5)**2 + (y - 0.5)**2))")   # turned by 4π·r


def _spiral() -> Case:
    """k1 = 1 along the direction at 4π·r radians from the radial one, r the distance to (½, ½):
    qmesh reads `principal(1, 1e-3, SPIRAL_ANGLE)`; SymPy the same Q written through cos 2θ and
    sin 2θ (no arctangent), Q = m I + d [[cos 2θ, sin 2θ], [sin 2θ, −cos 2θ]]."""
    dx, dy = "(x - 0.5)", "(y - 0.5)"
    r2 = f"({dx}**2 + {dy}**2)"
    a2 = f"(8*pi*sqrt{r2})"                                 # 2 · 4π·r
    c2 = f"((({dx}**2 - {dy}**2)*cos{a2} - 2*{dx}*{dy}*sin{a2})/{r2})"
    s2 = f"((2*{dx}*{dy}*cos{a2} + ({dx}**2 - {dy}**2)*sin{a2})/{r2})"
    m, d = (1 + SPIRAL_K2) / 2, (1 - SPIRAL_K2) / 2
    return Case("spiral", "formula", (f"{m} + {d}*{c2}", f"{d}*{s2}", f"{m} - {d}*{c2}"),
                "sin(pi*x)*sin(pi*y)", hole=True)


ISLAND_PSI = "((y - 0.5)**2/2 - 0.05*sin(2*pi*x))"     # ψ: an O-point (¼, ½), an X-point (¾, ½)


class Counted:
    """A user's callable f(x, y), counting its calls, the points it was asked for and the
    seconds spent in it."""

    def __init__(self, f):
        self.f, self.__name__ = f, f.__name__
        self.reset()

    def reset(self) -> None:
        self.calls, self.points, self.seconds = 0, 0, 0.0

    def __call__(self, x, y):
        t0 = time.perf_counter()
        try:
            return self.f(x, y)
        finally:
            self.calls += 1
            self.points += int(np.size(x))
            self.seconds += time.perf_counter() - t0


def islands(x, y):
    """Magnetic islands, as a user would write them: Q = εI + (1 − ε) b bᵀ/|b|², b = (ψ_y, −ψ_x)
    = (y − ½, 0.1π cos 2πx) along the level lines of ψ = (y − ½)²/2 − 0.05 sin 2πx. At the O-
    and X-points b is round-off (cos 2πx is never 0 in floating point), not 0."""
    bx, by = y - 0.5, 0.1 * np.pi * np.cos(2 * np.pi * x)
    b2 = bx * bx + by * by
    e = EPSILON
    q11, q12, q22 = e + (1 - e) * bx * bx / b2, (1 - e) * bx * by / b2, e + (1 - e) * by * by / b2
    return np.stack([np.stack([q11, q12], -1), np.stack([q12, q22], -1)], -2)


ISLANDS = Counted(islands)
"""The islands' callable as qmesh is given it: its counts are reset before each run."""


def _islands() -> Case:
    e = EPSILON
    bx, by = "(y - 0.5)", "(0.1*pi*cos(2*pi*x))"
    r = f"({bx}**2 + {by}**2)"
    return Case("islands", "callable",
                (f"{e} + {1 - e}*{bx}**2/{r}", f"{1 - e}*{bx}*{by}/{r}", f"{e} + {1 - e}*{by}**2/{r}"),
                f"sin(8*pi*{ISLAND_PSI})", singular=[(0.25, 0.5), (0.75, 0.5)])


CASES = {"fvca5": _fvca5(), "plasma": _plasma(), "layers": _layers(), "spiral": _spiral(),
         "islands": _islands(), "raster64": Case("raster64", "raster", cells=64),
         "raster512": Case("raster512", "raster", cells=512), "media": _media()}


# ------------------------------------------------------------------------------ SymPy pieces

def sympy_problem(case: Case):
    """(Q(x, y) → (..., 2, 2), u(x, y), f(x, y)) as NumPy functions lambdified from SymPy, f =
    −div(Q∇u) exact."""
    import sympy
    x, y = sympy.symbols("x y", real=True)
    ns = {"x": x, "y": y}
    q11, q12, q22 = (sympy.sympify(t, locals=ns) for t in case.q_texts)
    u = sympy.sympify(case.u_text, locals=ns)
    ux, uy = sympy.diff(u, x), sympy.diff(u, y)
    f = -(sympy.diff(q11 * ux + q12 * uy, x) + sympy.diff(q12 * ux + q22 * uy, y))
    lq = [sympy.lambdify((x, y), q, "numpy") for q in (q11, q12, q22)]

    def Q(X, Y):
        X, Y = np.broadcast_arrays(np.asarray(X, float), np.asarray(Y, float))
        a, b, c = (np.broadcast_to(g(X, Y), X.shape) for g in lq)
        return np.stack([np.stack([a, b], -1), np.stack([b, c], -1)], -2)

    lu, lf = sympy.lambdify((x, y), u, "numpy"), sympy.lambdify((x, y), f, "numpy")
    return (Q, lambda X, Y: np.broadcast_to(lu(X, Y), np.shape(X)),
            lambda X, Y: np.broadcast_to(lf(X, Y), np.shape(X)))


# ------------------------------------------------------------------- element means, by hand

def collapsed_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre n × n on the reference triangle by the Duffy collapse: points (n², 2) in
    (u, v) (the point A + u(B − A) + v(C − A)) and weights summing to 1."""
    t, w = np.polynomial.legendre.leggauss(n)
    t, w = 0.5 * (t + 1), 0.5 * w
    u, v = np.meshgrid(t, t, indexing="ij")
    W = np.outer(w, w) * (1 - u)
    return np.column_stack([u.ravel(), (v * (1 - u)).ravel()]), 2 * W.ravel()


def _pieces(A, B, C, levels):
    for _ in range(levels):
        ab, bc, ca = (A + B) / 2, (B + C) / 2, (C + A) / 2
        A, B, C = (np.stack(z, axis=1).reshape(-1, 2) for z in
                   ((A, ab, ca, ab), (ab, B, bc, bc), (ca, bc, C, ca)))
    return A, B, C


def formula_means(Q, P, T, singular=(), levels=2, n=6, chunk=4000) -> np.ndarray:
    """Element means of Q(x, y) → (..., 2, 2): the collapsed n × n rule on 4**levels congruent
    pieces of each triangle; 4⁵ pieces for triangles within SINGULAR_REACH of a singular
    point."""
    uv, w = collapsed_rule(n)
    out = np.empty((len(T), 2, 2))

    def means(idx, lev):
        for s in range(0, len(idx), chunk):
            t = idx[s:s + chunk]
            A, B, C = _pieces(P[T[t, 0]], P[T[t, 1]], P[T[t, 2]], lev)
            X = A[:, None] + uv[None, :, 0, None] * (B - A)[:, None] + uv[None, :, 1, None] * (C - A)[:, None]
            q = Q(X[..., 0], X[..., 1])
            out[t] = np.einsum("r,krij->kij", w, q).reshape(len(t), -1, 2, 2).mean(axis=1)

    near = np.zeros(len(T), bool)
    for p in singular:
        near |= np.hypot(*(P[T] - np.asarray(p)).transpose(2, 0, 1)).min(axis=1) < SINGULAR_REACH
    means(np.flatnonzero(~near), levels)
    means(np.flatnonzero(near), 5)
    return out


def _clip(poly, count, axis, value, keep_above):
    """Sutherland–Hodgman on many convex polygons at once: poly (K, C, 2) with `count` (K,)
    valid vertices, kept where coordinate `axis` ≥ value (keep_above) or ≤ value."""
    K, C, _ = poly.shape
    k = np.arange(C)
    valid = k[None] < count[:, None]
    nxt = np.where(k[None] + 1 < count[:, None], k[None] + 1, 0)
    after = np.take_along_axis(poly, nxt[..., None], axis=1)
    sign = 1.0 if keep_above else -1.0
    value = np.broadcast_to(value, (K,))[:, None]
    d0, d1 = sign * (poly[..., axis] - value), sign * (after[..., axis] - value)
    in0, in1 = d0 >= 0, d1 >= 0
    cross = valid & (in0 != in1)
    t = np.where(cross, d0 / np.where(cross, d0 - d1, 1.0), 0.0)
    X = poly + t[..., None] * (after - poly)
    X[..., axis] = np.where(cross, value, X[..., axis])       # exactly on the cut line
    cand = np.stack([poly, X], axis=2).reshape(K, 2 * C, 2)
    keep = np.stack([valid & in0, cross], axis=2).reshape(K, 2 * C)
    order = np.argsort(~keep, axis=1, kind="stable")[:, :C]
    return np.take_along_axis(cand, order[..., None], axis=1), keep.sum(axis=1)


def _polygon_areas(poly, count):
    C = poly.shape[1]
    k = np.arange(C)
    valid = k[None] < count[:, None]
    nxt = np.where(k[None] + 1 < count[:, None], k[None] + 1, 0)
    after = np.take_along_axis(poly, nxt[..., None], axis=1)
    cross = poly[..., 0] * after[..., 1] - after[..., 0] * poly[..., 1]
    return 0.5 * np.abs(np.where(valid, cross, 0.0).sum(axis=1))


def raster_means(xe, ye, Qc, P, T, chunk=200_000) -> tuple[np.ndarray, float]:
    """Exact area-weighted means of the cells' Q (ny, nx, 2, 2) over every triangle, by clipping
    each triangle against each cell of its bounding box; and the worst |covered − |T|| / |T|."""
    X = P[T]
    o = X.mean(axis=1)
    lo, hi = X.min(axis=1), X.max(axis=1)
    i0 = np.clip(np.searchsorted(xe, lo[:, 0], "right") - 1, 0, len(xe) - 2)
    i1 = np.clip(np.searchsorted(xe, hi[:, 0], "left"), 1, len(xe) - 1)
    j0 = np.clip(np.searchsorted(ye, lo[:, 1], "right") - 1, 0, len(ye) - 2)
    j1 = np.clip(np.searchsorted(ye, hi[:, 1], "left"), 1, len(ye) - 1)
    ni, nj = i1 - i0, j1 - j0
    per = ni * nj
    tri = np.repeat(np.arange(len(T)), per)
    r = np.arange(len(tri)) - np.repeat(np.cumsum(per) - per, per)
    ci = i0[tri] + r % ni[tri]
    cj = j0[tri] + r // ni[tri]
    total = np.zeros((len(T), 3))
    covered = np.zeros(len(T))
    q3 = np.stack([Qc[..., 0, 0], Qc[..., 0, 1], Qc[..., 1, 1]], axis=-1)
    for s in range(0, len(tri), chunk):
        t, i, j = tri[s:s + chunk], ci[s:s + chunk], cj[s:s + chunk]
        poly = np.zeros((len(t), 8, 2))
        poly[:, :3] = X[t] - o[t, None]
        count = np.full(len(t), 3)
        for axis, value, above in ((0, xe[i] - o[t, 0], True), (0, xe[i + 1] - o[t, 0], False),
                                   (1, ye[j] - o[t, 1], True), (1, ye[j + 1] - o[t, 1], False)):
            poly, count = _clip(poly, count, axis, value, above)
        a = _polygon_areas(poly, count)
        np.add.at(covered, t, a)
        for c in range(3):
            total[:, c] += np.bincount(t, a * q3[j, i, c], minlength=len(T))
    area = 0.5 * np.abs((X[:, 1, 0] - X[:, 0, 0]) * (X[:, 2, 1] - X[:, 0, 1])
                        - (X[:, 1, 1] - X[:, 0, 1]) * (X[:, 2, 0] - X[:, 0, 0]))
    q = total / area[:, None]
    out = np.empty((len(T), 2, 2))
    out[:, 0, 0], out[:, 0, 1], out[:, 1, 0], out[:, 1, 1] = q[:, 0], q[:, 1], q[:, 1], q[:, 2]
    return out, float(np.max(np.abs(covered - area) / area))


def cell_tensors(k1, k2, angle) -> np.ndarray:
    """Q per cell (ny, nx, 2, 2) = R diag(k1, k2) Rᵀ, R the rotation by `angle` degrees."""
    t = np.deg2rad(angle)
    c, s = np.cos(t), np.sin(t)
    out = np.empty(k1.shape + (2, 2))
    out[..., 0, 0] = k1 * c * c + k2 * s * s
    out[..., 0, 1] = out[..., 1, 0] = (k1 - k2) * c * s
    out[..., 1, 1] = k1 * s * s + k2 * c * c
    return out


def independent_means(case: Case, P, T, problem=None) -> np.ndarray:
    """The element means this benchmark measures with (module docstring)."""
    if case.kind == "raster":
        xe, ye, k1, k2, angle = case.raster()
        return raster_means(xe, ye, cell_tensors(k1, k2, angle), P, T)[0]
    Q = (problem or sympy_problem(case))[0]
    if case.kind == "media":
        star = in_star(P[T].mean(axis=1))
        out = np.empty((len(T), 2, 2))
        out[star] = cell_tensors(*(np.array([v]) for v in STAR_Q))[0]
        out[~star] = formula_means(Q, P, T[~star], case.singular)
        return out
    return formula_means(Q, P, T, case.singular)


def in_star(X) -> np.ndarray:
    """Which points lie inside STAR: even-odd crossings of a ray towards +x."""
    A, B = STAR, np.roll(STAR, -1, axis=0)
    y = X[:, 1, None]
    straddle = (A[None, :, 1] > y) != (B[None, :, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = A[None, :, 0] + (y - A[None, :, 1]) * (B - A)[None, :, 0] / (B - A)[None, :, 1]
    return (straddle & (xc > X[:, 0, None])).sum(axis=1) % 2 == 1


# ---------------------------------------------------------------------- P1 pieces, by hand

def element_matrices(P, T, Qbar) -> tuple[np.ndarray, np.ndarray]:
    """P1 element stiffness matrices (M, 3, 3) with the means Qbar, and the areas (M,):
    K_ij^T = e_iᵀ adj(Q̄_T) e_j / (4|T|), e_i the edge opposite corner i."""
    X = P[T]
    E = X[:, [2, 0, 1]] - X[:, [1, 2, 0]]
    area = 0.5 * ((X[:, 1, 0] - X[:, 0, 0]) * (X[:, 2, 1] - X[:, 0, 1])
                  - (X[:, 1, 1] - X[:, 0, 1]) * (X[:, 2, 0] - X[:, 0, 0]))
    adj = np.empty_like(Qbar)
    adj[:, 0, 0], adj[:, 1, 1] = Qbar[:, 1, 1], Qbar[:, 0, 0]
    adj[:, 0, 1] = adj[:, 1, 0] = -0.5 * (Qbar[:, 0, 1] + Qbar[:, 1, 0])
    area = np.abs(area)
    return np.einsum("mki,mij,mlj->mkl", E, adj, E) / (4.0 * area[:, None, None]), area


def edges_of(T) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unique edges (E, 2), the edge of each half-edge 3t + j (corner j → j + 1), and how many
    triangles each edge has (1 on the boundary)."""
    a, b = T.ravel(), T[:, [1, 2, 0]].ravel()
    keys = np.sort(np.column_stack([a, b]), axis=1)
    E, inv, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    return E, inv.ravel(), counts


def positive_off_diagonals(P, T, Qbar, tags=None) -> tuple[int, int, np.ndarray]:
    """(interior, boundary) edges with K_ij > ROUND Σ_T |K_ij^T|, and every edge's q_ij
    relative to Σ|K_ij^T| with the edge of each half-edge (for the figure). With the triangles'
    region `tags`, an edge between two regions also counts when either side's K_ij^T > ROUND
    |K_ij^T| on its own."""
    Ke, _ = element_matrices(P, T, Qbar)
    half = Ke[:, [0, 1, 2], [1, 2, 0]].ravel()
    E, inv, counts = edges_of(T)
    k = np.bincount(inv, half, minlength=len(E))
    scale = np.bincount(inv, np.abs(half), minlength=len(E))
    bad = k > ROUND * scale
    if tags is not None:
        t = np.repeat(np.asarray(tags, float), 3)
        lo = np.full(len(E), np.inf)
        hi = np.full(len(E), -np.inf)
        np.minimum.at(lo, inv, t)
        np.maximum.at(hi, inv, t)
        side = np.zeros(len(E), bool)
        np.logical_or.at(side, inv, half > ROUND * np.abs(half))
        bad |= (lo < hi) & side
    rel = -k / np.where(scale > 0, scale, 1.0)
    return int((bad & (counts == 2)).sum()), int((bad & (counts == 1)).sum()), rel[inv].reshape(-1, 3)


def assemble(P, T, Qbar) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
    """The global stiffness matrix, the boundary vertices' mask, the areas."""
    Ke, area = element_matrices(P, T, Qbar)
    rows = np.repeat(T, 3, axis=1).ravel()
    cols = np.tile(T, (1, 3)).ravel()
    K = sp.csr_matrix((Ke.ravel(), (rows, cols)), shape=(len(P), len(P)))
    E, _, counts = edges_of(T)
    bnd = np.zeros(len(P), bool)
    bnd[E[counts == 1].ravel()] = True
    return K, bnd, area


def median_stretch(P, T) -> float:
    """Median over the triangles of longest edge / its altitude, over an equilateral's (1)."""
    X = P[T]
    L2 = (np.diff(X[:, [0, 1, 2, 0]], axis=1) ** 2).sum(axis=2).max(axis=1)
    area = 0.5 * np.abs((X[:, 1, 0] - X[:, 0, 0]) * (X[:, 2, 1] - X[:, 0, 1])
                        - (X[:, 1, 1] - X[:, 0, 1]) * (X[:, 2, 0] - X[:, 0, 0]))
    return float(np.median(L2 / (2 * area)) * np.sqrt(3) / 2)


def maximum_principle(P, T, Qbar) -> tuple[int, float]:
    """−div(Q∇u) = 0, u = 1 on the boundary where x < ½, else 0: vertices outside [0, 1] by more
    than MP_TOL and the worst excess."""
    K, bnd, _ = assemble(P, T, Qbar)
    I, B = np.flatnonzero(~bnd), np.flatnonzero(bnd)
    g = (P[B, 0] < 0.5).astype(float)
    u = spla.spsolve(K[I][:, I].tocsc(), -(K[I][:, B] @ g))
    excess = np.maximum(u - 1.0, -u)
    return int(np.sum(excess > MP_TOL)), float(max(excess.max(initial=0.0), 0.0))


def l2_error(P, T, Qbar, u, f) -> float:
    """‖u_h − u‖_L2 of the P1 solution with the means Qbar, f's load by a collapsed 4 × 4 rule,
    the error by a 6 × 6 one, u at the boundary vertices."""
    K, bnd, area = assemble(P, T, Qbar)
    A, B_, C = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]

    def at(uv):
        return (A[:, None] + uv[None, :, 0, None] * (B_ - A)[:, None]
                + uv[None, :, 1, None] * (C - A)[:, None])

    def basis(uv):
        return np.column_stack([1 - uv[:, 0] - uv[:, 1], uv[:, 0], uv[:, 1]])

    uv, w = collapsed_rule(4)
    X = at(uv)
    fx = f(X[..., 0], X[..., 1])
    load = area[:, None] * np.einsum("q,mq,qi->mi", w, fx, basis(uv))
    b = np.bincount(T.ravel(), load.ravel(), minlength=len(P))
    I, Bd = np.flatnonzero(~bnd), np.flatnonzero(bnd)
    U = np.zeros(len(P))
    U[Bd] = u(P[Bd, 0], P[Bd, 1])
    U[I] = spla.spsolve(K[I][:, I].tocsc(), b[I] - K[I][:, Bd] @ U[Bd])
    uv, w = collapsed_rule(6)
    X = at(uv)
    uh = np.einsum("mi,qi->mq", U[T], basis(uv))
    err = (uh - u(X[..., 0], X[..., 1])) ** 2
    return float(np.sqrt(np.sum(area * (err @ w))))


# ------------------------------------------------------------------------------ the meshers

def peak_rss_kb() -> int:
    """This process's peak resident set size in kB: VmHWM of /proc/self/status (getrusage's
    ru_maxrss is no use in a child: Linux carries the parent's high-water mark through fork and
    exec), ru_maxrss where there is no /proc."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)


NS = (2_000, 20_000)   # the target N of every case (--n)
BIG = (200_000, 1_000_000)   # raster512 alone also at these (--big)
REPEATS = ((2_000, 5), (20_000, 2))   # qmesh's and the constant Q's runs, each timed this many
                        # times in its process up to this N, once above (the least CPU seconds: the
                        # first run also pays one-time set-ups, and other processes sharing the
                        # cores slow some runs, most of all the short ones: a constant Q at 2000
                        # takes 0.15 s)
PEERS_UP_TO = 200_000   # MMG2D, Triangle and the constant TensorField run up to this N (MMG2D
                        # calibrates N by whole runs: at 1e6 they would take most of the page's time)
LIGHT_ABOVE = 200_000   # above this target N, no κ2 and no maximum-principle solve (minutes at 1e6)

STAGES = ("set-up", "first triangulation", "adjust", "insert", "triangulate", "certify")
"""The parts of a qmesh run: set-up (the field's metric, checks: the first Step's wall time less
its own stage's), the first triangulation (its Stats.seconds; every face's in a medium), the
loop's adjust / insert / triangulate stages (wall time between Steps), certify and repair (the
last Step)."""


def stage_seconds(records, stamps) -> dict[str, float]:
    """Seconds per STAGES part from each Step's (stage, iteration, Stats.seconds) and the wall
    clock before the run and at every Step; the parts sum to the whole run."""
    out = dict.fromkeys(STAGES, 0.0)
    gaps = np.diff(stamps)
    for k, ((stage, iteration, own), gap) in enumerate(zip(records, gaps)):
        if k == len(records) - 1:
            out["certify"] += gap
        elif iteration == 0 and stage == "triangulate":
            out["first triangulation"] += min(own, gap)
            out["set-up"] += gap - min(own, gap)
        else:
            out[stage] += gap
    return out


def _field_run(domain, fld, n) -> tuple[object, dict]:
    """qmesh.iterate to its last Step (which is qmesh.mesh), timed per stage."""
    records, stamps = [], [time.perf_counter()]
    for step in qmesh.iterate(domain, fld, target_vertices=n):
        stamps.append(time.perf_counter())
        records.append((step.stage, step.iteration, step.stats.seconds))   # not the Step: its mesh
    return step.mesh, stage_seconds(records, stamps)


def run_mesher(case: Case, mesher: str, n: int, Q=None, repeats: int | None = None) -> dict:
    """One mesher on one case at target N, in this process: the mesh's arrays, seconds, runs,
    and the QmeshWarnings said. mesher: qmesh, MMG2D, Triangle, constQ (Anisotropy.constant(Q)),
    constfield (a constant TensorField Q); timed the least of `repeats` runs (by default
    REPEATS's count for N). qmesh gets a new field each run (nothing it kept of the last run's
    field is reused) and its seconds per stage; a callable's calls, points and seconds."""
    from qmesh.compare import field_peers
    domain = case.domain()
    fld = case.field() if mesher in ("qmesh", "MMG2D") else None
    base = peak_rss_kb()
    out = {"runs": 1, "warnings": [], "base_kb": base}
    if repeats is None:
        repeats = next((k for up_to, k in REPEATS if n <= up_to), 1) \
            if mesher in ("qmesh", "constQ", "constfield") else 1
    best = None
    for k in range(repeats):                   # the same mesh each time: the least CPU counts
        if mesher == "qmesh" and k > 0:
            fld = case.field()
        ISLANDS.reset()
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always", qmesh.QmeshWarning)
            t0, c0 = time.perf_counter(), time.process_time()
            extra = {}
            if mesher == "qmesh":              # qmesh.mesh is iterate's last Step: certified
                m, stages = _field_run(domain, fld, n)
                extra["stages"] = stages
                if case.kind == "callable":
                    extra["callable"] = {"calls": ISLANDS.calls, "points": ISLANDS.points,
                                         "asked": fld.evaluations.asked, "seconds": ISLANDS.seconds}
            elif mesher == "constQ":
                m = qmesh.mesh(domain, qmesh.Anisotropy.constant(np.asarray(Q)), target_vertices=n)
            elif mesher == "constfield":
                m = qmesh.mesh(domain, qmesh.TensorField.from_expressions(Q[0][0], Q[0][1], Q[1][1]),
                               target_vertices=n)
            elif mesher in ("MMG2D", "Triangle"):
                pm = field_peers.mmg2d(domain, fld, n) if mesher == "MMG2D" else field_peers.triangle(domain, n)
                m = pm.mesh
                out.update(runs=pm.runs, final_seconds=pm.seconds)
            else:
                raise ValueError(mesher)
            seconds = time.perf_counter() - t0
            cpu = time.process_time() - c0
        if best is None or cpu < best[0]:
            best = (cpu, seconds, extra)
    cpu, seconds, extra = best
    out.update(extra)
    if "stages" in out:
        out["certify_seconds"] = out["stages"]["certify"]
    out.update(cpu_seconds=cpu, points=np.asarray(m.points), triangles=np.asarray(m.triangles),
               fixed=np.asarray(m.fixed), seconds=out.get("final_seconds", seconds),
               total_seconds=seconds, peak_kb=peak_rss_kb(), repeats=repeats,
               warnings=[str(w.message) for w in said if issubclass(w.category, qmesh.QmeshWarning)])
    if mesher == "qmesh":
        out["conductivity"] = np.asarray(m.conductivity)
    return out


def _worker(spec: str) -> None:
    s = json.loads(spec)
    r = run_mesher(CASES[s["case"]], s["mesher"], s["n"], s.get("Q"))
    arrays = {k: r.pop(k) for k in ("points", "triangles", "fixed", "conductivity") if k in r}
    np.savez(s["out"], meta=json.dumps(r), **arrays)


def in_subprocess(case: Case, mesher: str, n: int, Q=None) -> dict:
    """run_mesher in a fresh Python (this script with --worker), for its own peak RSS."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "mesh.npz")
        spec = json.dumps({"case": case.name, "mesher": mesher, "n": int(n), "out": out,
                           "Q": None if Q is None else np.asarray(Q).tolist()})
        done = subprocess.run([sys.executable, os.path.abspath(__file__), "--worker", spec],
                              capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"{mesher} on {case.name} at N = {n} failed:\n{done.stderr[-3000:]}")
        with np.load(out) as z:
            r = json.loads(str(z["meta"]))
            r.update({k: z[k] for k in z.files if k != "meta"})
    return r


# ---------------------------------------------------------------------------- measurements

def measure_mesh(case: Case, P, T, fixed, problem=None, light=False) -> dict:
    """Every column of one mesh, with the means computed here (`light`: no κ2, no maximum
    principle)."""
    Qbar = independent_means(case, P, T, problem)
    mesh = qmesh.Mesh(P, T, fixed)
    tags = in_star(P[T].mean(axis=1)) if case.kind == "media" else None
    n_in, n_b, rel = positive_off_diagonals(P, T, Qbar, tags)
    quality = measure.quality(mesh, Qbar)
    v, worst = (None, None) if light else maximum_principle(P, T, Qbar)
    out = {"N": int(len(P)), "pos_in": n_in, "pos_b": n_b, "mp": v, "mp_worst": worst,
           "kappa2": "not computed" if light else measure.conditioning(mesh, Qbar).kappa2,
           "min_q": float(np.nanmin(quality)), "stretch": median_stretch(P, T),
           "corner_bound": corner_bound(P, T, Qbar, tags),
           "worst_at": P[T[int(np.nanargmin(quality))]].mean(axis=0).round(3).tolist(),
           "Qbar": Qbar, "rel": rel}
    if case.kind in ("formula", "callable"):
        out["l2"] = l2_error(P, T, Qbar, problem[1], problem[2])
    return out


def run(case_names, ns, big, mmg=True, figure_case="fvca5") -> tuple[list[dict], dict]:
    """Every mesher on every case at every N in ns, then raster512 at each N of `big` (the
    largest last)."""
    rows, kept, problems = [], {}, {}
    meshers = ["qmesh"] + (["MMG2D"] if mmg else []) + ["Triangle"]
    plan = [(name, n) for name in case_names for n in ns]
    plan += [("raster512", n) for n in big if "raster512" in case_names]
    for name, n in plan:
        case = CASES[name]
        if name not in problems:
            problems[name] = sympy_problem(case) if case.kind != "raster" else None
        problem = problems[name]
        peers = meshers if n <= PEERS_UP_TO else ["qmesh"]
        for mesher in (peers if case.kind != "media" else ["qmesh"]):
            r = in_subprocess(case, mesher, n)
            P, T = r["points"], r["triangles"]
            row = {"case": name, "mesher": mesher, "target": n, "seconds": r["seconds"],
                   "total_seconds": r["total_seconds"], "runs": r["runs"],
                   "peak_mb": r["peak_kb"] / 1024, "grow_mb": (r["peak_kb"] - r["base_kb"]) / 1024,
                   "warnings": r["warnings"], "certify_s": r.get("certify_seconds"),
                   "stages": r.get("stages"), "callable": r.get("callable")}
            row.update(measure_mesh(case, P, T, r["fixed"], problem, light=n > LIGHT_ABOVE))
            if mesher == "qmesh":
                Qm = r["conductivity"]
                row["means_diff"] = float(np.max(np.linalg.norm(Qm - row["Qbar"], axis=(1, 2))
                                                 / np.linalg.norm(row["Qbar"], axis=(1, 2))))
                _, area = element_matrices(P, T, row["Qbar"])
                Qmean = np.einsum("m,mij->ij", area, row["Qbar"]) / area.sum()
                row["cpu_s"] = r["cpu_seconds"]
                c = in_subprocess(case, "constQ", n, Qmean)
                row["const_s"], row["const_cpu"] = c["seconds"], c["cpu_seconds"]
                if n <= PEERS_UP_TO:
                    c = in_subprocess(case, "constfield", n, Qmean)
                    row["constfield_s"], row["constfield_cpu"] = c["seconds"], c["cpu_seconds"]
            if name == figure_case and n == min(ns):
                kept[mesher] = (P, T, row["rel"])
            del row["Qbar"], row["rel"]
            rows.append(row)
            print(_line(row), flush=True)
            for w in row["warnings"]:
                print(f"    {mesher} warned: {w}", flush=True)
    return rows, kept


# ------------------------------------------------------------------------------------ table

HEADERS = ["case", "mesher", "target N", "N", "K_ij > 0 interior / boundary",
           "max-principle violations (worst)", "L2 error", "κ2", "min quality", "s",
           "peak RSS MB (growth)", "s, Anisotropy.constant(Q̄)", "s, constant TensorField Q̄"]


def _cells(r) -> list[str]:
    k = r["kappa2"]
    return [r["case"], r["mesher"], str(r["target"]), str(r["N"]), f"{r['pos_in']} / {r['pos_b']}",
            "not computed" if r["mp"] is None else f"{r['mp']} ({r['mp_worst']:.1e})",
            f"{r['l2']:.3e}" if "l2" in r else "n/a",
            "undefined" if k is None else k if isinstance(k, str) else f"{k:.3g}",
            f"{r['min_q']:.3f}", f"{r['seconds']:.2f}", f"{r['peak_mb']:.0f} ({r['grow_mb']:.0f})",
            f"{r['const_s']:.2f}" if "const_s" in r else "",
            f"{r['constfield_s']:.2f}" if "constfield_s" in r else ""]


def _line(r) -> str:
    return "| " + " | ".join(_cells(r)) + " |"


HEADER = "| " + " | ".join(HEADERS) + " |\n" + "|" + "---|" * len(HEADERS)


def target_ratio(n: int) -> float:
    """The most a field's seconds may be of a constant Anisotropy's on the same domain at the
    same N: 5× at N = 2 000, 3× at N ≥ 20 000."""
    return 3.0 if n >= 20_000 else 5.0


RATIO_HEADERS = ["case", "target N", "qmesh s", "Anisotropy.constant(Q̄) s", "field / constant",
                 "target", "CPU field / constant", "constant TensorField Q̄ s",
                 "field / constant TensorField"]


def ratio_rows(rows) -> list[list[str]]:
    """Each field's seconds over a constant Anisotropy's (the area mean Q̄ of the field) on the
    same domain at the same N, wall and CPU, against the target; and over a constant
    TensorField's."""
    out = []
    for r in rows:
        if r["mesher"] != "qmesh" or "const_s" not in r:
            continue
        x, goal = r["seconds"] / r["const_s"], target_ratio(r["target"])
        cf = r.get("constfield_s")
        out.append([r["case"], str(r["target"]), f"{r['seconds']:.2f}", f"{r['const_s']:.2f}",
                    f"{x:.1f}×", f"≤ {goal:.0f}×: " + ("met" if x <= goal else "not met"),
                    f"{r['cpu_s'] / r['const_cpu']:.1f}×",
                    "not run" if cf is None else f"{cf:.2f}",
                    "" if cf is None else f"{r['seconds'] / cf:.1f}×"])
    return out


STAGE_HEADERS = (["case", "target N", *(f"{s} s" for s in STAGES), "whole run s",
                  "user evaluations: calls / points (asked) / s"])


def stage_rows(rows) -> list[list[str]]:
    """qmesh's seconds per stage (STAGES) in the run the page reports, and a callable's
    evaluations in that run (calls, points given, points asked, seconds)."""
    out = []
    for r in rows:
        if r["mesher"] != "qmesh" or not r.get("stages"):
            continue
        c = r.get("callable")
        out.append([r["case"], str(r["target"]), *(f"{r['stages'][s]:.2f}" for s in STAGES),
                    f"{r['total_seconds']:.2f}",
                    "" if not c else
                    f"{c['calls']} / {c['points']} ({c['asked']}) / {c['seconds']:.2f}"])
    return out


BIG_HEADERS = ["mesher", "target N", "N", "s", "peak RSS MB", "target"]


def big_rows(rows, case="raster512", smallest=200_000) -> list[list[str]]:
    """The large raster runs: each mesher's seconds and peak RSS, qmesh's against its targets
    (MMG2D's seconds in the same run at 2e5; 60 s and 2 GB at 1e6)."""
    out = []
    by = {(r["target"], r["mesher"]): r for r in rows if r["case"] == case}
    for (n, mesher), r in sorted(by.items(), key=lambda kv: (kv[0][0], kv[0][1] != "qmesh")):
        if n < smallest:
            continue
        goal = ""
        if mesher == "qmesh":
            if n >= 1_000_000:
                ok = r["seconds"] <= 60 and r["peak_mb"] <= 2048
                goal = f"≤ 60 s and ≤ 2 GB: {'met' if ok else 'not met'}"
            elif (n, "MMG2D") in by:
                mmg = by[(n, "MMG2D")]["seconds"]
                goal = f"≤ MMG2D's {mmg:.1f} s: {'met' if r['seconds'] <= mmg else 'not met'}"
        out.append([mesher, str(n), str(r["N"]), f"{r['seconds']:.1f}", f"{r['peak_mb']:.0f}", goal])
    return out


def summary(rows) -> list[str]:
    notes = []
    q = [r for r in rows if r["mesher"] == "qmesh"]
    by = {(r["case"], r["target"], r["mesher"]): r for r in rows}
    notes.append(f"qmesh: {sum(r['pos_in'] + r['pos_b'] for r in q)} positive off-diagonals in "
                 f"{len(q)} meshes (means computed here); {sum(r['mp'] for r in q if r['mp'] is not None)} "
                 f"maximum-principle violations (target N ≤ {LIGHT_ABOVE}); min quality {min(r['min_q'] for r in q):.3f}; "
                 f"N off the target by up to {max(abs(r['N'] - r['target']) / r['target'] for r in q):.1%}; "
                 f"the mesh's own means differ from those computed here by at most "
                 f"{max(r['means_diff'] for r in q):.1e} (relative, Frobenius)")
    ratios = []
    for r in q:
        if "l2" not in r:
            continue
        parts = []
        for peer in ("MMG2D", "Triangle"):
            p = by.get((r["case"], r["target"], peer))
            if p is not None:
                parts.append(f"{r['l2'] / p['l2']:.2f}× {peer}'s (stretch "
                             f"{r['stretch'] / p['stretch']:.1f}×)")
        ratios.append(f"{r['case']} at {r['target']}: " + ", ".join(parts))
    if ratios:
        notes.append("L2 error of qmesh, and in brackets the ratio of the median stretches (P1's L2 "
                     "error of a smooth u is about h_max² |u|_2 per triangle, and h_max² is "
                     "proportional to stretch × area: at equal N it grows as the stretch, which "
                     "qmesh takes from Q's shape, as q_ij ≥ 0 needs): "
                     + "; ".join(ratios))
    notes.append("where qmesh's worst triangle (min quality) lies, its centroid: " + "; ".join(
        f"{r['case']} at {r['target']}: {r['min_q']:.3f} at ({r['worst_at'][0]}, {r['worst_at'][1]})"
        for r in q))
    notes.append("the min quality the corners of Ω allow on qmesh's mesh (in a medium, the corners "
                 "of each region, the star's tips; a triangle's angle at a "
                 "corner is at most the corner's angle in the triangle's own metric; an angle α "
                 "< 60° allows at most 2√3 sin α / (2 + 4 sin²(α/2))), and qmesh's min quality: " + "; ".join(
                     f"{r['case']} at {r['target']}: {r['corner_bound']:.3f} / {r['min_q']:.3f}" for r in q))
    notes.append("median stretch of the triangles (longest edge / its altitude, 1 for an "
                 "equilateral), qmesh / MMG2D / Triangle: " + "; ".join(
                     f"{r['case']} at {r['target']}: " + " / ".join(
                         f"{by[(r['case'], r['target'], m)]['stretch']:.1f}"
                         for m in ("qmesh", "MMG2D", "Triangle") if (r['case'], r['target'], m) in by)
                     for r in q))
    warned = [f"{r['case']} at {r['target']}: " + " / ".join(r["warnings"]) for r in q if r["warnings"]]
    notes.append("qmesh's warnings: " + ("; ".join(warned) if warned else "none"))
    return notes


# ----------------------------------------------------------------------------------- figure

def figure(path, kept, rows) -> None:
    """FVCA5 test 5 at the smallest N: each mesher's mesh, triangles coloured by the sign of
    the worst q_ij = −K_ij of their edges (means computed here); and L2 error against N."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    names = [m for m in ("qmesh", "MMG2D", "Triangle") if m in kept]
    fig, axes = plt.subplots(2, 2, figsize=(13, 13.4))
    axes = axes.ravel()
    cmap = ListedColormap(["#d7301f", "#deebf7"])
    for ax, name in zip(axes, names):
        P, T, rel = kept[name]
        worst = rel.min(axis=1)
        neg = worst < -ROUND
        ax.tripcolor(P[:, 0], P[:, 1], T, facecolors=(~neg).astype(float), cmap=cmap, vmin=0, vmax=1)
        ax.triplot(P[:, 0], P[:, 1], T, lw=0.15, color="0.3")
        ax.set_title(f"{name}: N = {len(P)}\n{int(neg.sum())} triangles with an edge K_ij > 0 (red)")
        ax.set_aspect("equal")
        ax.set_axis_off()
    for ax in axes[len(names):-1]:
        ax.set_axis_off()
    ax = axes[-1]
    styles = {"qmesh": "o-", "MMG2D": "s--", "Triangle": "^:"}
    colours = {"fvca5": "C0", "plasma": "C1", "layers": "C2", "spiral": "C3", "islands": "C4"}
    for case in colours:
        for mesher, st in styles.items():
            pts = sorted((r["N"], r["l2"]) for r in rows
                         if r["case"] == case and r["mesher"] == mesher and "l2" in r)
            if pts:
                ax.loglog(*zip(*pts), st, color=colours[case], label=f"{case}, {mesher}", ms=5)
    ax.set_xlabel("N (vertices)")
    ax.set_ylabel("L2 error of P1")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title("L2 error against N (formula fields)")
    fig.suptitle("FVCA5 test 5: triangles touching an edge with a positive off-diagonal in red "
                 "(element means computed by the benchmark)")
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    fig.savefig(path, dpi=90)
    plt.close(fig)


# -------------------------------------------------------------------------------------- main

DESCRIPTION = __doc__.split("\n\n", 1)[1].rsplit("\n\n", 1)[0]


RATIO_CAPTION = ("What a user waits for: qmesh on the field against qmesh on the constant "
                 "Anisotropy.constant(Q̄) a user would pick, Q̄ the area mean of the field over Ω, on "
                 "the same domain at the same N (and against a constant TensorField Q̄)")
STAGE_CAPTION = ("qmesh's seconds per stage on the field (the run reported; a callable's "
                 "evaluations counted in it)")
BIG_CAPTION = "The 512² raster at 2e5 and 1e6 vertices: seconds and peak RSS"


def main(argv=None) -> None:
    if argv is None and len(sys.argv) > 2 and sys.argv[1] == "--worker":
        _worker(sys.argv[2])
        return
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    ap.add_argument("--n", type=int, nargs="+", default=list(NS))
    ap.add_argument("--big", type=int, nargs="*", default=list(BIG),
                    help="more N for raster512 alone (none: --big with no value)")
    ap.add_argument("--no-mmg", action="store_true")
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    print(HEADER, flush=True)
    with report_page.capture() as out:
        rows, kept = run(args.cases, args.n, args.big, mmg=not args.no_mmg)
        notes = summary(rows)
        for caption, headers, cells in ((RATIO_CAPTION, RATIO_HEADERS, ratio_rows(rows)),
                                        (STAGE_CAPTION, STAGE_HEADERS, stage_rows(rows)),
                                        (BIG_CAPTION, BIG_HEADERS, big_rows(rows))):
            print(f"\n{caption}\n" + report_page.markdown_table(headers, cells))
        print()
        for n in notes:
            print(n + ".")
    if not args.no_page:
        figures = []
        if kept:
            path = report_page.figure_path(__file__, "fvca5.png")
            figure(path, kept, rows)
            figures.append(report_page.Figure(
                path, f"FVCA5 test 5 at N = {min(args.n)}: qmesh, MMG2D and Triangle, triangles "
                      "touching an edge with K_ij > 0 in red; L2 error against N"))
        report_page.write_page(
            __file__, sys.argv, "Conductivity fields against MMG2D and Triangle", DESCRIPTION,
            tables=[report_page.Table(RATIO_HEADERS, ratio_rows(rows), RATIO_CAPTION),
                    report_page.Table(STAGE_HEADERS, stage_rows(rows), STAGE_CAPTION),
                    report_page.Table(BIG_HEADERS, big_rows(rows), BIG_CAPTION),
                    report_page.Table(HEADERS, [_cells(r) for r in rows], "Every mesh")],
            notes=[n + "." for n in notes], figures=figures, output=out())


if __name__ == "__main__":
    main()
