"""Mesh in normalised coordinates, so position, scale and the size of Q do not matter.

GEOMETRY.md §3: the mesher works on y = (x − c)/d, c the centre of the outline's bounding box
and d its larger side, with s divided by d²·k (k a typical size of ∇²s), so ∇²s is about 1 in
norm and Ω about 1 across. Qhull, shoelace areas and the "repeated point" tests then see
numbers of order one whatever the domain's position or size, and c·Q meshes like Q. Results
are mapped back once per stage; the domain's input points are put back bit-exactly.
"""

from __future__ import annotations

import numpy as np

from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.errors import QmeshError
from qmesh.geometry.portable import dot2, gauss_legendre

CANCELLATION = 1e6   # |s(c)| + d|∇s(c)| over d²·|∇²s| beyond which s − its tangent plane
                     # is taken by quadrature (the difference would lose 6 of 16 digits)
GAUSS = 6            # Gauss–Legendre points of that quadrature


def hessian_scale(anisotropy, X: np.ndarray) -> float:
    """A typical spectral norm of ∇²s: exact for constant Q, the median over X otherwise."""
    H = anisotropy.H if anisotropy.is_constant else np.asarray(anisotropy.hessian(X), dtype=float)
    H = np.asarray(H, dtype=float).reshape(-1, 2, 2)
    # spectral norm of a symmetric 2×2 matrix: |mean| + radius, scaled first so nothing overflows
    m = np.abs(H).max(axis=(1, 2))
    m = np.where(m > 0, m, 1.0)
    a, b, c = H[:, 0, 0] / m, H[:, 0, 1] / m, H[:, 1, 1] / m
    norm = m * (np.abs(0.5 * (a + c)) + np.hypot(0.5 * (a - c), b))
    k = float(np.median(norm))
    if not (np.isfinite(k) and k > 0):
        raise QmeshError(f"{metric_name(anisotropy)} has norm {k:g} on the domain; it must be finite "
                         f"and > 0{metric_advice(anisotropy)}")
    return k


def metric_name(anisotropy) -> str:
    """What the metric is called in a message: the Hessian of s, or a tensor field's metric (a
    field has no s)."""
    if getattr(anisotropy, "potential", True):
        return "the Hessian of s"
    return f"the metric adj Q / √det Q of the field ({anisotropy.label})"


def metric_advice(anisotropy) -> str:
    """What to change when a field's metric overflows: a field meshes by Q's shape alone."""
    if getattr(anisotropy, "potential", True):
        return ""
    return ("; Q and det Q must be finite floats > 0 everywhere: rescale Q (its mesh depends on "
            "its shape, not its size) or lower its anisotropy")


def hessian_scales(anisotropies: list, point_sets: list) -> list[float]:
    """`hessian_scale` of each anisotropy over its points; a constant Q's, which does not depend
    on the points, is taken once per Anisotropy (a thousand regions of one Q: once)."""
    known: dict[int, float] = {}
    out = []
    for a, X in zip(anisotropies, point_sets):
        if not a.is_constant:
            out.append(hessian_scale(a, X))
            continue
        if id(a) not in known:
            known[id(a)] = hessian_scale(a, X)
        out.append(known[id(a)])
    return out


class Normalisation:
    """The map x = c + d·y, and s scaled by 1/(d²k): the domain and anisotropy the mesher sees."""

    def __init__(self, domain, anisotropy):
        lo, hi = domain.bounds
        self.center = 0.5 * lo + 0.5 * hi        # no overflow near the largest floats
        self.scale = float((hi - lo).max())
        self.k = hessian_scale(anisotropy, domain.seeds)
        self.user_domain, self.user_anisotropy = domain, anisotropy
        self.domain = domain.scaled(self.center, self.scale)
        self.anisotropy = self._anisotropy(anisotropy)

    def _anisotropy(self, A) -> Anisotropy:
        c, d, k = self.center, self.scale, self.k
        if A.is_constant:
            H = np.asarray(A.H, dtype=float) / k
            return Anisotropy.constant([[H[1, 1], -H[0, 1]], [-H[1, 0], H[0, 0]]])   # Q = adj H
        if not A.potential:
            return Anisotropy.metric_only(lambda Y: np.asarray(A.hessian(c + d * np.asarray(Y, dtype=float)),
                                                                dtype=float) / k, A.label)
        s0 = float(np.asarray(A.s(c[None]), dtype=float)[0])
        g0 = np.asarray(A.grad(c[None]), dtype=float)[0]

        def x(Y):
            return c + d * np.asarray(Y, dtype=float)

        def hessian(Y):
            return np.asarray(A.hessian(x(Y)), dtype=float) / k

        if (abs(s0) + d * float(np.abs(g0).sum())) > CANCELLATION * d * d * k:
            return self._remainder_anisotropy(A, x, hessian)

        def s(Y):      # the affine part at c removed: it changes no hull, and keeps s small
            Y = np.asarray(Y, dtype=float)
            return (np.asarray(A.s(x(Y)), dtype=float) - s0 - d * dot2(Y, g0)) / (d * d * k)

        def grad(Y):
            return (np.asarray(A.grad(x(Y)), dtype=float) - g0) / (d * k)

        return Anisotropy(s, grad, hessian, None, A.label)

    @staticmethod
    def _remainder_anisotropy(A, x, hessian) -> Anisotropy:
        """s less its tangent plane at c as the Taylor remainder ∫₀¹ (1−t) Yᵀ∇²s(c + t·dY) Y dt
        (and ∇s likewise, ∫₀¹ ∇²s(c + t·dY) Y dt), by Gauss–Legendre on [0, 1]: no difference
        of nearly equal values, where s(x) − s(c) − ∇s(c)·(x − c) would keep none of its digits
        (a domain 1e-7 across: s − s(c) ~ 1e-14·s). Exact for s of degree ≤ 2·GAUSS + 1."""
        t, w = gauss_legendre(GAUSS)
        t, w = 0.5 * (t + 1.0), 0.5 * w

        def s(Y):
            Y = np.asarray(Y, dtype=float)
            out = np.zeros(len(Y))
            for tk, wk in zip(t, w):
                out += wk * (1.0 - tk) * np.einsum("ni,nij,nj->n", Y, hessian(tk * Y), Y)
            return out

        def grad(Y):
            Y = np.asarray(Y, dtype=float)
            out = np.zeros_like(Y)
            for tk, wk in zip(t, w):
                out += wk * np.einsum("nij,nj->ni", hessian(tk * Y), Y)
            return out

        return Anisotropy(s, grad, hessian, None, A.label)

    # lengths and areas measured in the metric ∇²s
    def metric_length(self, h_user: float) -> float:
        return h_user / (self.scale * np.sqrt(self.k))

    def metric_area(self, a_user: float) -> float:
        return a_user / (self.scale**2 * self.k)

    def to_user(self, Y: np.ndarray, fixed: np.ndarray | None = None) -> np.ndarray:
        """Points mapped back; the first len(seeds) fixed points become the input points exactly."""
        X = self.center + self.scale * Y
        seeds = self.user_domain.seeds
        X[:len(seeds)] = seeds
        return X
