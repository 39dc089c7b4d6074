"""The exact test of what `measure.monotonicity` certifies, and the random meshes it is run on.

`exact` decides by a dense inverse whether the Dirichlet system A u_I + B u_Γ = f keeps the
discrete maximum principle with its boundary couplings: A⁻¹ ≥ 0 and −A⁻¹B ≥ 0 (with K1 = 0
these are the row conditions: every interior value is a convex combination of the boundary
values plus a non-negative multiple of f). For a few thousand unknowns at most.

`python tests/core/monotone_oracle.py --cases 1000` runs the random meshes and prints how often
the certificate and the exact test agree.
"""

from __future__ import annotations

import argparse
from collections import Counter
from typing import NamedTuple

import numpy as np
import scipy.linalg
from scipy.spatial import Delaunay

import qmesh
from qmesh import measure

EPS = np.finfo(float).eps


class Exact(NamedTuple):
    monotone: bool
    min_inverse: float        # min A⁻¹ / ‖A⁻¹‖₂
    min_harmonic: float       # min (−A⁻¹B) / ‖A⁻¹‖₂‖B‖₂
    tolerance: float          # what "≥ 0" allowed, relative as these


def exact(mesh: qmesh.Mesh, conductivity, perturbation: float = 0.0) -> Exact:
    """A⁻¹ ≥ −τ and −A⁻¹B ≥ −τ by LU solves of the dense A.

    τ (relative to ‖A⁻¹‖₂, and ‖A⁻¹‖₂‖B‖₂ for −A⁻¹B): the solve's round-off, 64·n·ε·κ₂ (a
    backward-stable solve's forward error), plus what the certificate may move: it certifies
    K + Σ w_ij (e_i − e_j)(e_i − e_j)ᵀ with w_ij ≤ perturbation·max|K_ij| on positive entries,
    a change ΔK with ‖ΔK‖₂ ≤ 2·degree·w, which moves A⁻¹ by at most ‖A⁻¹‖₂²‖ΔK‖₂/(1 − ‖A⁻¹‖₂‖ΔK‖₂)
    and −A⁻¹B by ‖A⁻¹‖₂‖ΔK‖₂(1 + that·‖B‖₂): 0 when nothing was moved.
    """
    K = measure.stiffness(mesh, conductivity).tocsr()
    free = measure.free_vertices(mesh)
    used = np.zeros(mesh.n_vertices, bool)
    used[mesh.triangles.ravel()] = True
    gamma = np.flatnonzero(used & mesh.boundary)
    A = K[free][:, free].toarray()
    B = K[free][:, gamma].toarray()
    w = scipy.linalg.eigvalsh(A)
    kappa = w[-1] / w[0]
    norm_inv = 1.0 / w[0]
    norm_b = max(np.linalg.norm(B, 2), 1e-300) if B.size else 1e-300
    lu = scipy.linalg.lu_factor(A)
    X = scipy.linalg.lu_solve(lu, np.eye(len(A)))
    H = -scipy.linalg.lu_solve(lu, B) if B.size else np.zeros((len(A), 0))
    off = K - scipy.sparse.diags(K.diagonal())
    scale = np.abs(off.data).max()
    degree = int(np.diff(K.indptr).max())
    dk = 2 * degree * perturbation * scale
    moved = norm_inv * dk / max(1.0 - norm_inv * dk, 1e-300)
    tau = 64 * len(A) * EPS * kappa + moved
    tau_h = 64 * len(A) * EPS * kappa + moved * (1.0 + norm_inv * norm_b) / max(norm_inv * norm_b, 1e-300)
    min_x = float(X.min()) / norm_inv
    min_h = float(H.min()) / (norm_inv * norm_b) if H.size else 0.0
    return Exact(min_x >= -tau and min_h >= -tau_h, min_x, min_h, tau)


def exact_schur_positive(mesh: qmesh.Mesh, conductivity, rtol: float = 1e-9) -> bool:
    """Whether S = A_CC − A_CF A_FF⁻¹ A_FC (C: the interior vertices with a positive coupling,
    F: the others), by dense solves, keeps a positive off-diagonal: then no path through F,
    however long, dominates it."""
    K = measure.stiffness(mesh, conductivity).toarray()
    free = measure.free_vertices(mesh)
    used = np.zeros(mesh.n_vertices, bool)
    used[mesh.triangles.ravel()] = True
    gamma = np.flatnonzero(used & mesh.boundary)
    A, B = K[np.ix_(free, free)], K[np.ix_(free, gamma)]
    off = A - np.diag(np.diag(A))
    tol = rtol * max(np.abs(off).max(), np.abs(B).max(initial=0.0))
    C = (off > tol).any(axis=1) | (B > tol).any(axis=1)
    F = ~C
    S = A[np.ix_(C, C)] - A[np.ix_(C, F)] @ np.linalg.solve(A[np.ix_(F, F)], A[np.ix_(F, C)])
    BS = B[C] - A[np.ix_(C, F)] @ np.linalg.solve(A[np.ix_(F, F)], B[F])
    return bool(((S - np.diag(np.diag(S))) > tol).any() or (BS > tol).any())


# --------------------------------------------------------------------------- random meshes

def ccw(P: np.ndarray, T: np.ndarray) -> np.ndarray:
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) < 0
    T = T.copy()
    T[cw] = T[cw][:, [0, 2, 1]]
    return T


def rotated(angle: float, ratio: float) -> np.ndarray:
    """Q = R diag(1, ratio) Rᵀ."""
    c, s = np.cos(angle), np.sin(angle)
    R = np.array([[c, -s], [s, c]])
    return R @ np.diag([1.0, ratio]) @ R.T


def random_delaunay(rng: np.random.Generator, n: int, stretch: float = 1.0) -> qmesh.Mesh:
    """scipy's Delaunay triangulation of the unit square's corners and n random points, the
    points first squeezed by `stretch` in y (then stretched back: obtuse, thin triangles)."""
    P = np.vstack([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], rng.random((n, 2))])
    T = Delaunay(P * [1.0, stretch]).simplices
    return qmesh.Mesh(P, ccw(P, T))


def perturbed_grid(rng: np.random.Generator, k: int, jitter: float) -> qmesh.Mesh:
    """A k×k grid of the unit square, its interior points moved by up to jitter·h, Delaunay."""
    x = np.linspace(0.0, 1.0, k)
    X, Y = np.meshgrid(x, x)
    P = np.column_stack([X.ravel(), Y.ravel()])
    inside = (P > 0).all(axis=1) & (P < 1).all(axis=1)
    P[inside] += jitter / (k - 1) * rng.uniform(-1, 1, (int(inside.sum()), 2))
    return qmesh.Mesh(P, ccw(P, Delaunay(P).simplices))


def random_case(rng: np.random.Generator, kind: str):
    """A (mesh, conductivity) of one of the kinds: "delaunay", "obtuse", "perturbed", "qmesh",
    "means" (Delaunay with a random SPD Q per triangle)."""
    Q = rotated(rng.uniform(0, np.pi), 10 ** rng.uniform(0, 3))
    if kind == "qmesh":                            # a ratio up to 100: enough vertices across
        A = qmesh.Anisotropy.constant(rotated(rng.uniform(0, np.pi), 10 ** rng.uniform(0, 2)))
        return qmesh.mesh(qmesh.Disk(12), A, target_vertices=int(rng.integers(150, 300)),
                          seed=int(rng.integers(1000))), A
    if kind == "perturbed":
        return perturbed_grid(rng, int(rng.integers(4, 9)), rng.uniform(0, 0.45)), qmesh.Anisotropy.constant(Q)
    if kind == "obtuse":
        return random_delaunay(rng, int(rng.integers(10, 50)), 10 ** rng.uniform(0.5, 1.5)), qmesh.Anisotropy.constant(Q)
    mesh = random_delaunay(rng, int(rng.integers(10, 50)))
    if kind == "means":
        M = mesh.n_triangles
        Qs = np.array([rotated(a, r) for a, r in zip(rng.uniform(0, np.pi, M),
                                                         10 ** rng.uniform(0, 2, M))])
        return mesh, Qs
    return mesh, qmesh.Anisotropy.constant(Q)


KINDS = ("delaunay", "obtuse", "perturbed", "qmesh", "means")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    table: Counter[tuple[str, str, bool]] = Counter()
    stuck: Counter[bool] = Counter()
    for i in range(args.cases):
        kind = KINDS[i % len(KINDS)]
        mesh, Q = random_case(rng, kind)
        cert = measure.monotonicity(mesh, Q)
        truth = exact(mesh, Q, cert.perturbation)
        table[(kind, str(cert), truth.monotone)] += 1
        if truth.monotone and str(cert) == "none":
            stuck[exact_schur_positive(mesh, Q)] += 1
    print(f"{args.cases} random meshes (seed {args.seed}): certificate vs exact test")
    print(f"{'kind':<10} {'certificate':<10} {'exact monotone':>15} {'exact not':>10}")
    for kind in KINDS:
        for cert in ("M-matrix", "monotone", "none"):
            yes, no = table[(kind, cert, True)], table[(kind, cert, False)]
            if yes or no:
                print(f"{kind:<10} {cert:<10} {yes:>15} {no:>10}")
    false = sum(v for (k, c, t), v in table.items() if c != "none" and not t)
    room = sum(v for (k, c, t), v in table.items() if c != "M-matrix" and t)
    seen = sum(v for (k, c, t), v in table.items() if c == "monotone" and t)
    print(f"false certificates: {false}; exactly monotone but not certified M-matrix: {room}, "
          f"of which certified monotone: {seen}")
    print(f"of those certified none, the exact Schur complement onto the vertices with a positive "
          f"entry keeps a positive off-diagonal in {stuck[True]}, in {stuck[False]} not")


if __name__ == "__main__":
    main()
