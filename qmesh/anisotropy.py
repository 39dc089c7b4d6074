"""The conductivity Q and its convex parametrisation s(x), with Q = adj ∇²s.

Chapter Section 2.3 (MATH.md "Notation"): the mesher needs s, ∇s and the Hessian H = ∇²s;
the stiffness matrix needs Q = adj H. For a constant SPD Q, s(x) = ½ xᵀ adj(Q) x.
All callables are vectorised over (n, 2) arrays of points.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .errors import QmeshError

Field = Callable[[np.ndarray], np.ndarray]


def adj2(M: np.ndarray) -> np.ndarray:
    """Adjugate of 2×2 matrices (…, 2, 2): [[d, -b], [-c, a]]."""
    out = np.empty_like(M)
    out[..., 0, 0] = M[..., 1, 1]
    out[..., 1, 1] = M[..., 0, 0]
    out[..., 0, 1] = -M[..., 0, 1]
    out[..., 1, 0] = -M[..., 1, 0]
    return out


def _check_spd(Q: np.ndarray, what: str) -> np.ndarray:
    Q = np.asarray(Q, dtype=float)
    if Q.shape != (2, 2):
        raise QmeshError(f"{what} must be a 2x2 matrix, got shape {Q.shape}")
    if not np.all(np.isfinite(Q)):
        raise QmeshError(f"{what} has non-finite entries: {Q.tolist()}")
    if not np.isclose(Q[0, 1], Q[1, 0], rtol=1e-12, atol=1e-14 * np.abs(Q).max()):
        raise QmeshError(f"{what} must be symmetric, got {Q.tolist()}")
    Q = 0.5 * (Q + Q.T)
    if Q[0, 0] <= 0 or np.linalg.det(Q) <= 0:
        raise QmeshError(f"{what} must be symmetric positive definite, got {Q.tolist()}")
    return Q


@dataclass(frozen=True)
class Anisotropy:
    """s, ∇s, ∇²s and Q = adj ∇²s as vectorised callables.

    Build it with `constant`, `principal`, `from_s` or `from_expression` (s typed as text,
    kept in `expression`). `H` is the constant Hessian when Q is
    constant (None otherwise); code paths that can exploit a constant metric check it.
    """

    s: Field
    grad: Field
    hessian: Field
    H: np.ndarray | None = None
    label: str = ""
    expression: str | None = None

    def Q(self, P: np.ndarray) -> np.ndarray:
        """Conductivity at points P (n, 2) → (n, 2, 2): Q = adj ∇²s."""
        return adj2(self.hessian(P))

    @property
    def is_constant(self) -> bool:
        return self.H is not None

    @classmethod
    def constant(cls, Q) -> "Anisotropy":
        """A constant SPD conductivity Q; s(x) = ½ xᵀ adj(Q) x, so ∇²s = adj Q and adj ∇²s = Q."""
        Q = _check_spd(Q, "Q")
        H = adj2(Q)
        H.setflags(write=False)

        def s(P):
            P = np.asarray(P, dtype=float)
            return 0.5 * np.einsum("ni,ij,nj->n", P, H, P)

        def grad(P):
            return np.asarray(P, dtype=float) @ H  # H symmetric

        def hessian(P):
            return np.broadcast_to(H, (len(P), 2, 2))

        label = f"Q = [[{Q[0, 0]:.4g}, {Q[0, 1]:.4g}], [{Q[1, 0]:.4g}, {Q[1, 1]:.4g}]]"
        return cls(s, grad, hessian, H, label)

    @classmethod
    def principal(cls, k1: float, k2: float, angle_deg: float = 0.0) -> "Anisotropy":
        """Principal conductivities k1, k2 > 0, with k1's axis at angle_deg from the x axis."""
        vals = np.array([k1, k2, angle_deg], dtype=float)
        if not np.all(np.isfinite(vals)):
            raise QmeshError(f"principal conductivities and angle must be finite, got {vals.tolist()}")
        if k1 <= 0 or k2 <= 0:
            raise QmeshError(f"principal conductivities must be > 0, got k1={k1}, k2={k2}")
        t = np.deg2rad(angle_deg)
        R = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
        return cls.constant(R @ np.diag([k1, k2]) @ R.T)

    @classmethod
    def from_s(cls, s: Field, grad: Field, hessian: Field, label: str = "s(x)") -> "Anisotropy":
        """A varying convex s given as vectorised callables: s (n,)→, grad (n,2), hessian (n,2,2).

        Convexity is checked where the mesher evaluates s (`check_convex`), not here: the
        domain is not known yet.
        """
        for f, name in ((s, "s"), (grad, "grad"), (hessian, "hessian")):
            if not callable(f):
                raise QmeshError(f"{name} must be callable")
        return cls(s, grad, hessian, None, label)

    @classmethod
    def from_expression(cls, text: str) -> "Anisotropy":
        """s(x, y) typed as text, e.g. "exp(x) + y**2": exact s, ∇s, ∇²s (qmesh.expression).

        The text is parsed against a whitelist, never run; QmeshError points at what is refused.
        A Hessian that is constant and not SPD is refused here; one that varies is checked on
        the domain by `check_convex`. A constant Hessian makes this a constant-Q anisotropy.
        """
        from .expression import parse_s

        e = parse_s(text)
        return cls(e.s, e.grad, e.hessian, e.H, label=text, expression=text)

    def check_convex(self, P: np.ndarray) -> None:
        """Raise QmeshError unless ∇²s is finite and SPD at every point of P."""
        Hs = np.asarray(self.hessian(P), dtype=float)
        if Hs.shape != (len(P), 2, 2):
            raise QmeshError(f"hessian must return shape (n, 2, 2), got {Hs.shape}")
        if not np.all(np.isfinite(Hs)):
            raise QmeshError("the Hessian of s is not finite on the domain")
        det = Hs[:, 0, 0] * Hs[:, 1, 1] - Hs[:, 0, 1] * Hs[:, 1, 0]
        if np.any(Hs[:, 0, 0] <= 0) or np.any(det <= 0):
            raise QmeshError("s must be strictly convex on the domain (its Hessian is not SPD somewhere)")
