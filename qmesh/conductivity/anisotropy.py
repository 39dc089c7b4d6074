"""The conductivity Q and its convex parametrisation s(x), with Q = adj ∇²s.

Chapter Section 2.3 (MATH.md "Notation"): the mesher needs s, ∇s and the Hessian H = ∇²s;
the stiffness matrix needs Q = adj H. For a constant SPD Q, s(x) = ½ xᵀ adj(Q) x.
All callables are vectorised over (n, 2) arrays of points.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Union

import numpy as np
from numpy.typing import ArrayLike, NDArray

from qmesh import checks
from qmesh.conductivity.expression import parse_s
from qmesh.errors import QmeshError
from qmesh.geometry.portable import eigvalsh2, matmul2, times2

Field = Callable[[NDArray[np.float64]], NDArray[np.float64]]
"""s, ∇s or ∇²s as the mesher calls it: points (n, 2) → values (n,), (n, 2) or (n, 2, 2)."""

UserField = Callable[[NDArray[np.float64]], ArrayLike]
"""A user's s, ∇s or ∇²s (`Anisotropy.from_s`): any array-like result of the right shape."""


def adj2(M: NDArray[np.float64]) -> NDArray[np.float64]:
    """Adjugate of 2×2 matrices (…, 2, 2): [[d, -b], [-c, a]]."""
    out = np.empty_like(M)
    out[..., 0, 0] = M[..., 1, 1]
    out[..., 1, 1] = M[..., 0, 0]
    out[..., 0, 1] = -M[..., 0, 1]
    out[..., 1, 0] = -M[..., 1, 0]
    return out


def shape_metric(Q: NDArray[np.float64]) -> NDArray[np.float64]:
    """H = adj Q / √det Q of conductivities (…, 2, 2): the metric of Q's shape, det H = 1, in
    which a triangle's share of q_ij is ½ cot of its opposite angle (FIELDS.md §3); NaN where Q
    is not positive definite."""
    Q = np.asarray(Q, dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):        # past the floats: refused by the caller
        det = Q[..., 0, 0] * Q[..., 1, 1] - Q[..., 0, 1] * Q[..., 1, 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(det > 0, 1.0 / np.sqrt(np.where(det > 0, det, 1.0)), np.nan)
    H = np.empty_like(Q)
    H[..., 0, 0], H[..., 1, 1] = Q[..., 1, 1] * scale, Q[..., 0, 0] * scale
    H[..., 0, 1] = H[..., 1, 0] = -0.5 * (Q[..., 0, 1] + Q[..., 1, 0]) * scale
    return H


class _UserField:
    """A user's s, ∇s or ∇²s as the mesher calls it: NumPy warnings raised inside it stay quiet,
    an exception inside it becomes a QmeshError naming it, and its result is checked for shape."""

    def __init__(self, f: UserField, name: str, tail: tuple[int, ...]):
        self.f, self.name, self.tail = f, name, tail
        self.__doc__ = getattr(f, "__doc__", None)

    def __call__(self, P: ArrayLike) -> NDArray[np.float64]:
        P = np.asarray(P, dtype=float)
        want = (len(P),) + self.tail
        try:
            with np.errstate(all="ignore"):
                raw = self.f(P)
                out = np.asarray(raw)
        except QmeshError:
            raise
        except Exception as e:
            raise QmeshError(f"{self.name} raised {type(e).__name__} at {len(P)} points "
                             f"(the first {P[0].tolist() if len(P) else []}): {e}") from e
        if out.dtype.kind not in "biuf":
            raise QmeshError(f"{self.name} must return an array of real numbers, "
                             f"got {checks.describe(raw)}")
        out = out.astype(float, copy=False)
        if out.shape != want:
            try:   # a constant (2, 2) Hessian or (2,) gradient stands for every point
                out = np.broadcast_to(out, want)
            except ValueError:
                shape = "(n" + "".join(f", {t}" for t in self.tail) + ")"
                raise QmeshError(f"{self.name} must return shape {shape}, got {out.shape} "
                                 f"for n = {len(P)} points") from None
        return out


def principal_matrix(k1: float, k2: float, angle_deg: float) -> NDArray[np.float64]:
    """Q = R diag(k1, k2) Rᵀ, R the rotation by angle_deg: k1 along the direction at that angle."""
    t = np.deg2rad(angle_deg)
    R = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    return matmul2(matmul2(R, np.diag([k1, k2])), R.T)


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
    H: NDArray[np.float64] | None = None
    label: str = ""
    expression: str | None = None
    potential: bool = True
    """False for a metric without an s (a tensor field's, `metric_only`): the mesher then tests
    flips and encroachment in the local metric and moves vertices by the shape step."""

    def Q(self, P: NDArray[np.float64]) -> NDArray[np.float64]:
        """Conductivity at points P (n, 2) → (n, 2, 2): Q = adj ∇²s."""
        return adj2(self.hessian(P))

    @property
    def is_constant(self) -> bool:
        """True when s is quadratic: ∇²s is the one matrix `H`, so Q = adj H is constant."""
        return self.H is not None

    @property
    def matrix(self) -> NDArray[np.float64]:
        """The constant conductivity Q as a plain 2×2 float array (for a FEM code's assembly);
        QmeshError for a varying Q, which has no single matrix (use `Q(P)`)."""
        if self.H is None:
            raise QmeshError(f"Anisotropy.matrix: {self.label or 'this'} Q varies over the domain and has "
                             "no single matrix; evaluate it at points with Q(P)")
        return adj2(np.asarray(self.H, dtype=float))

    @classmethod
    def constant(cls, Q: ArrayLike) -> Anisotropy:
        """A constant SPD conductivity Q; s(x) = ½ xᵀ adj(Q) x, so ∇²s = adj Q and adj ∇²s = Q."""
        return cls._of(checks.spd_matrix(Q, "Q"))

    @classmethod
    def _of(cls, Q: NDArray[np.float64]) -> Anisotropy:
        """`constant(Q)` for a Q already checked (and symmetrised) by `checks.spd_matrix`."""
        H = adj2(Q)
        H.setflags(write=False)

        def s(P: NDArray[np.float64]) -> NDArray[np.float64]:
            P = np.asarray(P, dtype=float)
            return 0.5 * np.einsum("ni,ij,nj->n", P, H, P)

        def grad(P: NDArray[np.float64]) -> NDArray[np.float64]:
            return times2(P, H)  # H symmetric

        def hessian(P: NDArray[np.float64]) -> NDArray[np.float64]:
            return np.broadcast_to(H, (len(P), 2, 2))

        label = f"Q = [[{Q[0, 0]:.4g}, {Q[0, 1]:.4g}], [{Q[1, 0]:.4g}, {Q[1, 1]:.4g}]]"
        return cls(s, grad, hessian, H, label)

    @classmethod
    def principal(cls, k1: float, k2: float, angle_deg: float = 0.0) -> Anisotropy:
        """Principal conductivities k1, k2 > 0, with k1's axis at angle_deg from the x axis."""
        k1 = checks.real(k1, "k1", low=0.0, low_open=True)
        k2 = checks.real(k2, "k2", low=0.0, low_open=True)
        angle_deg = checks.real(angle_deg, "angle_deg")
        if min(k1, k2) <= 4 * np.finfo(float).eps * max(k1, k2):
            raise QmeshError(f"k1 = {k1:g} and k2 = {k2:g} are too far apart: the smaller is "
                             f"round-off next to the larger, so Q would be singular")
        return cls.constant(principal_matrix(k1, k2, angle_deg))

    @classmethod
    def principals(cls, params: Sequence[tuple[float, float, float]]) -> list[Anisotropy | None]:
        """`principal(k1, k2, angle)` of many (k1, k2, angle) (a grid's zones) at once: the same
        matrices and checks, on stacks of 2×2 matrices (a call per zone costs more than its
        matrix). None where a check fails or comes near failing: principal itself then decides."""
        p = np.asarray(params, dtype=float).reshape(-1, 3)
        k1, k2, angle = p[:, 0], p[:, 1], p[:, 2]
        eps = np.finfo(float).eps
        with np.errstate(all="ignore"):
            ok = np.isfinite(p).all(axis=1) & (k1 > 0) & (k2 > 0)
            ok &= np.minimum(k1, k2) > 8 * eps * np.maximum(k1, k2)
            t = np.deg2rad(angle)                           # principal_matrix, stacked
            c, s = np.cos(t), np.sin(t)
            R = np.stack([np.stack([c, -s], axis=-1), np.stack([s, c], axis=-1)], axis=1)
            D = np.zeros((len(p), 2, 2))
            D[:, 0, 0], D[:, 1, 1] = k1, k2
            Q = matmul2(matmul2(R, D), R.transpose(0, 2, 1))
            m = np.abs(Q).max(axis=(1, 2))                  # checks.spd_matrix, stacked
            Qn = Q / np.where(m > 0, m, 1.0)[:, None, None]
            a, b = Qn[:, 0, 1], Qn[:, 1, 0]
            ok &= (m > 0) & np.isfinite(Q).all(axis=(1, 2))
            ok &= np.abs(a - b) <= 0.5 * (1e-12 * np.maximum(np.abs(a), np.abs(b)) + 1e-14)
            lo_hi = eigvalsh2(np.where(ok[:, None, None], 0.5 * (Qn + Qn.transpose(0, 2, 1)), np.eye(2)))
            ok &= lo_hi[:, 0] > 8 * eps * lo_hi[:, 1]
        Q = 0.5 * Q + 0.5 * Q.transpose(0, 2, 1)
        return [cls._of(Q[i].copy()) if good else None for i, good in enumerate(ok.tolist())]

    @classmethod
    def from_s(cls, s: UserField, grad: UserField, hessian: UserField,
               label: str = "s(x)") -> Anisotropy:
        """A varying convex s given as vectorised callables: s (n,)→, grad (n,2), hessian (n,2,2).

        Convexity is checked where the mesher evaluates s (`check_convex`), not here: the
        domain is not known yet.
        """
        for f, name in ((s, "s"), (grad, "grad"), (hessian, "hessian")):
            checks.function(f, name)
        checks.text(label, "label")
        return cls(_UserField(s, "s", ()), _UserField(grad, "grad", (2,)),
                   _UserField(hessian, "hessian", (2, 2)), None, label)

    @classmethod
    def metric_only(cls, hessian: Field, label: str = "metric") -> Anisotropy:
        """A varying metric H(x) with no s behind it (FIELDS.md §4): what the mesher meshes a
        tensor field by. Its s and ∇s refuse to be called."""
        def none(P: NDArray[np.float64]) -> NDArray[np.float64]:
            raise QmeshError(f"{label} is a metric without a potential s: s and ∇s are not defined")
        return cls(none, none, hessian, None, label, potential=False)

    @classmethod
    def from_expression(cls, text: str) -> Anisotropy:
        """s(x, y) typed as text, e.g. "exp(x) + y**2": exact s, ∇s, ∇²s (qmesh.expression).

        The text is parsed against a whitelist, never run; QmeshError points at what is refused.
        A Hessian that is constant and not SPD is refused here; one that varies is checked on
        the domain by `check_convex`. A constant Hessian makes this a constant-Q anisotropy.
        """

        e = parse_s(text)
        return cls(e.s, e.grad, e.hessian, e.H, label=text, expression=text)

    def check_convex(self, P: ArrayLike) -> None:
        """Raise QmeshError unless ∇²s is finite, symmetric and positive definite at every point of P.

        The message names the first point where it fails and how. The SPD test is made on each
        Hessian divided by its largest |entry|, so it does not depend on the Hessian's size.
        """
        P = checks.real_array(P, "points", (None, 2))
        try:
            with np.errstate(all="ignore"):
                Hs = np.asarray(self.hessian(P), dtype=float)
        except QmeshError:
            raise
        except Exception as e:
            raise QmeshError(f"hessian raised {type(e).__name__}: {e}") from e
        if Hs.shape != (len(P), 2, 2):
            raise QmeshError(f"hessian must return shape (n, 2, 2), got {Hs.shape} for n = {len(P)}")
        bad = ~np.isfinite(Hs).all(axis=(1, 2))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise QmeshError(f"the Hessian of s is not finite at {bad.sum()} of {len(P)} points; "
                             f"the first: {P[i].tolist()} where it is {Hs[i].tolist()}")
        m = np.abs(Hs).max(axis=(1, 2))
        Hn = Hs / np.where(m > 0, m, 1.0)[:, None, None]
        asym = np.abs(Hn[:, 0, 1] - Hn[:, 1, 0]) > 1e-8
        a, b, c = Hn[:, 0, 0], 0.5 * (Hn[:, 0, 1] + Hn[:, 1, 0]), Hn[:, 1, 1]
        not_spd = (m == 0) | (a <= 0) | (a * c - b * b <= 0)
        for mask, what in ((asym, "not symmetric"),
                           (not_spd, "not SPD (s must be strictly convex on the domain)")):
            if mask.any():
                i = int(np.flatnonzero(mask)[0])
                raise QmeshError(f"the Hessian of s is {what} at {mask.sum()} of {len(P)} points; "
                                 f"the first: {P[i].tolist()} where it is {Hs[i].tolist()}")


Conductivity = Union[Anisotropy, Mapping[int, Anisotropy]]
"""One conductivity for the whole domain, or one per region {region tag: Anisotropy} (MEDIA.md)."""
