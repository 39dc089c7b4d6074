"""qmesh.measure.conditioning / condition_number: κ2 is a finite number ≥ 1 or None with the
reason, never a negative or absurd figure (a mesh still being built, Q not positive definite, a
numerically singular matrix); the Lanczos path agrees with eigvalsh and with ARPACK."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
from scipy.spatial import Delaunay

import qmesh
from qmesh import QmeshError, measure
from qmesh.domain import media_cases

CHAPTER = qmesh.Anisotropy.constant([[0.1, 0.0], [0.0, 10.0]])


def disk_mesh(n: int, seed: int, outline: int = 24, inner: float = 0.95) -> qmesh.Mesh:
    """The Delaunay mesh of an `outline`-gon and n random points within radius `inner`."""
    rng = np.random.default_rng(seed)
    t = 2 * np.pi * np.arange(outline) / outline
    r, a = np.sqrt(rng.random(n)) * inner, rng.random(n) * 2 * np.pi
    P = np.r_[np.c_[np.cos(t), np.sin(t)], np.c_[r * np.cos(a), r * np.sin(a)]]
    T = Delaunay(P).simplices
    return qmesh.Mesh(P, T)


def two_pieces(n: int = 60) -> qmesh.Mesh:
    """A disk mesh and, far away, a second disk mesh whose boundary edges are not given as the
    mesh's boundary: its vertices are all free and touch no boundary vertex (as a medium's face
    meshed alone before the outer one)."""
    a, b = disk_mesh(n, 1), disk_mesh(n, 2)
    P = np.r_[a.points, b.points + 5.0]
    T = np.r_[a.triangles, b.triangles + a.n_vertices]
    return qmesh.Mesh(P, T, boundary_edges=a.boundary_edges)


def test_a_part_with_no_boundary_vertex_has_no_kappa2_and_says_why():
    mesh = two_pieces()
    c = measure.conditioning(mesh, CHAPTER)
    assert c.kappa2 is None and "touch no boundary vertex" in c.reason
    assert str(disk_mesh(60, 2).n_vertices) in c.reason            # how many vertices float
    with pytest.raises(QmeshError, match="touch no boundary vertex"):
        measure.condition_number(mesh, CHAPTER)
    r = measure.report(mesh, CHAPTER)
    assert r["kappa2"] is None and "touch no boundary vertex" in r["kappa2_undefined"]
    assert json.loads(json.dumps(r, allow_nan=False)) == r


def test_no_interior_vertex_gives_the_reason():
    one = qmesh.Mesh([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    c = measure.conditioning(one)
    assert c.kappa2 is None and "no interior vertex" in c.reason
    assert measure.report(one, CHAPTER)["kappa2_undefined"] == c.reason


def test_q_not_positive_definite_on_a_triangle_gives_no_kappa2():
    mesh = disk_mesh(80, 3)
    Q = np.broadcast_to(np.eye(2), (mesh.n_triangles, 2, 2)).copy()
    Q[5] = [[1.0, 0.0], [0.0, -1.0]]
    c = measure.conditioning(mesh, Q)
    assert c.kappa2 is None and "not positive definite on 1 of" in c.reason


def test_a_numerically_singular_matrix_is_not_given_a_figure():
    """Every triangle around one interior vertex conducts 1e-20 of the rest: its row of K is
    round-off beside the others, κ2 ~ 1e20 is no figure."""
    mesh = disk_mesh(300, 4)
    v = measure.free_vertices(mesh)[0]
    Q = np.broadcast_to(np.eye(2), (mesh.n_triangles, 2, 2)).copy()
    Q[(mesh.triangles == v).any(axis=1)] *= 1e-20
    for method in ("dense", "sparse"):
        c = measure.conditioning(mesh, Q, method=method)
        assert c.kappa2 is None and "numerically singular" in c.reason, method


@pytest.mark.parametrize("method", ["dense", "sparse"])
def test_kappa2_is_the_eigenvalue_ratio_with_its_eigenvalues(method):
    mesh = disk_mesh(400, 5)
    w = np.linalg.eigvalsh(measure.stiffness_interior(mesh, CHAPTER).toarray())
    c = measure.conditioning(mesh, CHAPTER, method=method)
    assert c.reason is None
    assert (c.kappa2, c.lambda_min, c.lambda_max) == pytest.approx((w[-1] / w[0], w[0], w[-1]), rel=1e-9)


def test_lanczos_hands_over_to_arpack_when_it_runs_out_of_steps(monkeypatch):
    mesh = disk_mesh(400, 6)
    exact = measure.condition_number(mesh, CHAPTER, method="dense")
    monkeypatch.setattr(measure, "LANCZOS_STEPS", 2)
    assert measure.condition_number(mesh, CHAPTER, method="sparse") == pytest.approx(exact, rel=1e-9)


def test_the_largest_eigenvalue_by_lanczos_on_a_known_spectrum():
    """A diagonal operator (any symmetric one is, in its eigenvector basis) whose top
    eigenvalue is close to the rest: the recurrence alone, no reorthogonalisation."""
    w = np.r_[np.linspace(1.0, 50.0, 20000), 50.5]
    v0 = np.random.default_rng(0).random(len(w))
    assert measure._largest_eigenvalue(lambda x: w * x, v0, 1e-10) == pytest.approx(50.5, rel=1e-12)


def test_every_stage_of_a_medium_has_a_kappa2_of_at_least_one_or_a_reason():
    domain, conductivity, _ = media_cases.inclusion()
    seen = {"defined": 0, "undefined": 0}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        steps = list(qmesh.iterate(domain, conductivity, target_vertices=212, seed=0))
    assert [s.converged for s in steps] == [False] * (len(steps) - 1) + [True]
    for step in steps:
        c = measure.conditioning(step.mesh, conductivity)
        if c.kappa2 is None:
            assert c.reason
            seen["undefined"] += 1
        else:
            assert np.isfinite(c.kappa2) and c.kappa2 >= 1.0
            seen["defined"] += 1
    assert seen["undefined"] and seen["defined"]          # the lens or star meshed alone first
    assert measure.conditioning(steps[-1].mesh, conductivity).kappa2 is not None
