"""Measurements with one conductivity per triangle — the element means Q̄_T a mesh carries
(FIELDS.md §2–3): K_ij = Σ_T |T| ∇φ_iᵀ Q̄_T ∇φ_j, q_ij = −K_ij = ½ Σ_T √det Q̄_T cot θ_k^T with θ
measured in H_T = adj Q̄_T, the quality in each triangle's own H_T. Expected values come from a
naive loop over triangles written here (∇φ from the inverse of each triangle's [1 x y] matrix),
from the cotangent formula, and by hand."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial import Delaunay

import qmesh
from qmesh import QmeshError, measure
from qmesh.cli import main

CHAPTER_Q = np.array([[0.1, 0.0], [0.0, 10.0]])


def disk_mesh(n: int, seed: int, regions: int = 1) -> qmesh.Mesh:
    rng = np.random.default_rng(seed)
    t = 2 * np.pi * np.arange(24) / 24
    r, a = np.sqrt(rng.random(n)) * 0.95, rng.random(n) * 2 * np.pi
    P = np.r_[np.c_[np.cos(t), np.sin(t)], np.c_[r * np.cos(a), r * np.sin(a)]]
    T = Delaunay(P).simplices
    tags = rng.integers(0, regions, len(T)) if regions > 1 else None
    return qmesh.Mesh(P, T, region_tags=tags)


def random_q(rng, m: int, max_ratio: float = 1e3) -> np.ndarray:
    """m random SPD matrices: random axes, eigenvalues 10^U(-1, 2) with ratio up to max_ratio."""
    t = rng.random(m) * np.pi
    R = np.stack([np.stack([np.cos(t), -np.sin(t)], -1), np.stack([np.sin(t), np.cos(t)], -1)], -2)
    k1 = 10.0 ** rng.uniform(-1, 2, m)
    k2 = k1 / rng.uniform(1, max_ratio, m)
    return np.einsum("mij,mj,mkj->mik", R, np.stack([k1, k2], -1), R)


def naive_stiffness(P, T, Q) -> np.ndarray:
    """Σ_T |T| ∇φ_iᵀ Q_T ∇φ_j, triangle by triangle, dense."""
    K = np.zeros((len(P), len(P)))
    for t, tri in enumerate(T):
        X = np.c_[np.ones(3), P[tri]]
        area = abs(np.linalg.det(X)) / 2
        G = np.linalg.inv(X)[1:, :]                   # column a: ∇φ_a
        K[np.ix_(tri, tri)] += area * G.T @ Q[t] @ G
    return K


def naive_edges(T, tags):
    """{(i, j): kind} by counting each edge's triangles and their regions."""
    seen: dict = {}
    for t, tri in enumerate(T):
        for a, b in ((0, 1), (1, 2), (2, 0)):
            seen.setdefault(tuple(sorted((int(tri[a]), int(tri[b])))), []).append(int(tags[t]))
    return {e: ("boundary" if len(r) == 1 else "interface" if r[0] != r[1] else "interior")
            for e, r in seen.items()}


def cot_q(P, T, Q, edges) -> np.ndarray:
    """½ Σ_T √det Q_T cot θ_k^T, the angle opposite each edge measured in adj Q_T (FIELDS.md §3)."""
    out = dict.fromkeys(map(tuple, edges.tolist()), 0.0)
    for t, tri in enumerate(T):
        H = np.array([[Q[t][1, 1], -Q[t][0, 1]], [-Q[t][1, 0], Q[t][0, 0]]])
        for k in range(3):
            i, j = int(tri[(k + 1) % 3]), int(tri[(k + 2) % 3])
            u, v = P[i] - P[tri[k]], P[j] - P[tri[k]]
            cot = (u @ H @ v) / (np.sqrt(np.linalg.det(H)) * abs(u[0] * v[1] - u[1] * v[0]))
            out[tuple(sorted((i, j)))] += 0.5 * np.sqrt(np.linalg.det(Q[t])) * cot
    return np.array(list(out.values()))


# --------------------------------------------------------------------------- by hand

# the unit square cut along the diagonal (1, 0)–(0, 1); lower-left triangle T1 with
# Q1 = [[2, .5], [.5, 1]], upper-right T2 with Q2 = [[1, .2], [.2, 3]]
SQUARE_P = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
SQUARE_T = np.array([[0, 1, 2], [1, 3, 2]])
Q1, Q2 = np.array([[2.0, 0.5], [0.5, 1.0]]), np.array([[1.0, 0.2], [0.2, 3.0]])


def test_two_triangles_by_hand():
    """T1: ∇φ_(0,0) = (−1, −1), ∇φ_(1,0) = (1, 0), ∇φ_(0,1) = (0, 1), |T1| = ½;
    T2: ∇φ_(1,0) = (0, −1), ∇φ_(1,1) = (1, 1), ∇φ_(0,1) = (−1, 0), |T2| = ½. So
    K_(1,0),(0,1) = ½·Q1_12 + ½·Q2_21 = 0.25 + 0.1: the diagonal's q = −0.35;
    K_(0,0),(1,0) = ½ (−1, −1)·Q1·(1, 0) = ½ (−2 − 0.5): q = 1.25;
    K_(0,0),(0,1) = ½ (−1, −1)·Q1·(0, 1) = ½ (−0.5 − 1): q = 0.75;
    K_(1,0),(1,1) = ½ (0, −1)·Q2·(1, 1) = ½ (−0.2 − 3): q = 1.6;
    K_(1,1),(0,1) = ½ (1, 1)·Q2·(−1, 0) = ½ (−1 − 0.2): q = 0.6."""
    mesh = qmesh.Mesh(SQUARE_P, SQUARE_T, conductivity=[Q1, Q2])
    edges, q, kind = measure.edge_q(mesh)
    got = {tuple(e): (w, k) for e, w, k in zip(edges.tolist(), q, kind)}
    expected = {(1, 2): (-0.35, "interior"), (0, 1): (1.25, "boundary"), (0, 2): (0.75, "boundary"),
                (1, 3): (1.6, "boundary"), (2, 3): (0.6, "boundary")}
    assert set(got) == set(expected)
    for e, (w, k) in expected.items():
        assert got[e][0] == pytest.approx(w, abs=1e-14) and got[e][1] == k, e
    K = measure.stiffness(mesh, None).toarray()
    assert K[1, 2] == pytest.approx(0.35) and np.allclose(K.sum(axis=1), 0.0, atol=1e-14)
    assert q == pytest.approx(cot_q(SQUARE_P, SQUARE_T, np.array([Q1, Q2]), edges), abs=1e-14)
    # in two regions, the diagonal is an interface edge
    two = qmesh.Mesh(SQUARE_P, SQUARE_T, conductivity=[Q1, Q2], region_tags=[0, 1])
    assert dict(zip(map(tuple, measure.edge_q(two)[0].tolist()), measure.edge_q(two)[2]))[(1, 2)] == "interface"


# --------------------------------------------------------------------------- constant Q

def test_a_constant_q_per_triangle_assembles_as_the_anisotropy():
    mesh = disk_mesh(300, 1)
    A = qmesh.Anisotropy.constant(CHAPTER_Q)
    Q = np.broadcast_to(CHAPTER_Q, (mesh.n_triangles, 2, 2))
    carried = qmesh.Mesh(mesh.points, mesh.triangles, conductivity=Q)
    for K in (measure.stiffness(mesh, Q), measure.stiffness(carried, None)):
        assert abs(K - measure.stiffness(mesh, A)).max() <= 1e-13 * abs(K).max()
    e0, q0, i0 = measure.edge_weights(mesh, A)
    e1, q1, kind = measure.edge_q(carried)
    assert np.array_equal(e0, e1) and np.array_equal(kind == "interior", i0)
    assert q1 == pytest.approx(q0, rel=1e-12, abs=1e-14 * np.abs(q0).max())
    assert measure.quality(carried) == pytest.approx(measure.quality(mesh, A), rel=1e-12)
    assert measure.condition_number(carried) == pytest.approx(measure.condition_number(mesh, A), rel=1e-9)
    assert measure.q_nonnegative_fractions(carried, None) == measure.q_nonnegative_fractions(mesh, A)


# --------------------------------------------------------------------------- random Q per triangle

@pytest.mark.parametrize("seed", [0, 1])
def test_random_q_per_triangle_against_the_naive_loop(seed):
    rng = np.random.default_rng(seed)
    mesh = disk_mesh(150, seed, regions=3)
    Q = random_q(rng, mesh.n_triangles)
    carried = qmesh.Mesh(mesh.points, mesh.triangles, region_tags=mesh.region_tags, conductivity=Q)
    K_ref = naive_stiffness(mesh.points, mesh.triangles, Q)
    scale = np.abs(K_ref).max()
    assert np.abs(measure.stiffness(carried, None).toarray() - K_ref).max() <= 1e-12 * scale
    free = measure.free_vertices(mesh)
    assert np.abs(measure.stiffness_interior(carried, None).toarray()
                  - K_ref[np.ix_(free, free)]).max() <= 1e-12 * scale
    edges, q, kind = measure.edge_q(carried)
    assert q == pytest.approx(-K_ref[edges[:, 0], edges[:, 1]], abs=1e-12 * scale)
    assert q == pytest.approx(cot_q(mesh.points, mesh.triangles, Q, edges), abs=1e-11 * scale)
    ref_kind = naive_edges(mesh.triangles, mesh.region_tags)
    assert dict(zip(map(tuple, edges.tolist()), kind.tolist())) == ref_kind
    assert {"interior", "interface", "boundary"} == set(kind.tolist())
    # the same through an explicit array argument, for a mesh without means
    assert np.array_equal(measure.edge_q(mesh, Q)[1], q)
    # κ2 of the Dirichlet block, and the quality in each triangle's own H_T = adj Q̄_T / √det Q̄_T
    w = np.linalg.eigvalsh(K_ref[np.ix_(free, free)])
    assert measure.condition_number(carried, method="sparse") == pytest.approx(w[-1] / w[0], rel=1e-8)
    quality = []
    for t, tri in enumerate(mesh.triangles):
        H = np.array([[Q[t][1, 1], -Q[t][0, 1]], [-Q[t][1, 0], Q[t][0, 0]]])
        H /= np.sqrt(np.linalg.det(H))
        E = mesh.points[tri[[1, 2, 0]]] - mesh.points[tri]
        area = 0.5 * (E[0, 0] * E[1, 1] - E[0, 1] * E[1, 0])
        quality.append(4 * np.sqrt(3) * area / np.einsum("ki,ij,kj->", E, H, E))
    assert measure.quality(carried) == pytest.approx(np.array(quality), rel=1e-10)


def test_a_tensor_field_is_measured_by_its_element_means():
    mesh = disk_mesh(120, 3)
    field = qmesh.TensorField.from_expressions("1 + x**2", "0.3*x*y", "2 + y**2")
    means = field.means(mesh.points, mesh.triangles)
    assert np.array_equal(measure.edge_q(mesh, field)[1], measure.edge_q(mesh, means)[1])
    assert measure.condition_number(mesh, field) == measure.condition_number(mesh, means)


# --------------------------------------------------------------------------- report, the CLI

def test_report_of_a_mesh_carrying_its_means():
    rng = np.random.default_rng(4)
    base = disk_mesh(200, 4)
    Q = random_q(rng, base.n_triangles, max_ratio=10)
    mesh = qmesh.Mesh(base.points, base.triangles, conductivity=Q)
    r = measure.report(mesh)
    assert json.loads(json.dumps(r, allow_nan=False)) == r
    assert r["energy"] is None and r["l2_error"] is None and r["h1_error"] is None
    assert r["kappa2"] == pytest.approx(measure.condition_number(base, Q), rel=1e-12)
    assert r["kappa2_laplacian"] == pytest.approx(measure.condition_number(base, None), rel=1e-12)
    assert r["min_quality"] == pytest.approx(measure.quality(base, Q).min())
    shares = measure.q_nonnegative_fractions(base, Q)
    assert r["q_nonnegative_fraction"] == shares["q_nonnegative_fraction"]
    # an explicit conductivity is what is measured, also for a mesh that carries means
    A = qmesh.Anisotropy.constant(CHAPTER_Q)
    assert measure.report(mesh, A)["kappa2"] == measure.report(base, A)["kappa2"]
    assert measure.report(mesh, A)["energy"] == pytest.approx(measure.energy(base, A))
    with pytest.raises(QmeshError, match="needs s"):
        measure.energy(mesh, None)
    with pytest.raises(QmeshError, match="no element means"):
        measure.report(base)


def test_wrong_shapes_of_a_per_triangle_q_are_refused():
    mesh = disk_mesh(50, 5)
    with pytest.raises(QmeshError, match="Anisotropy.constant"):
        measure.edge_q(mesh, np.eye(2))
    with pytest.raises(QmeshError, match=r"shape \(\d+, 2, 2\)"):
        measure.stiffness(mesh, np.ones((3, 2, 2)))
    with pytest.raises(QmeshError, match="non-finite"):
        measure.quality(mesh, np.full((mesh.n_triangles, 2, 2), np.nan))


def test_qmesh_report_measures_a_file_with_the_stored_means(tmp_path, capsys):
    pytest.importorskip("meshio")
    import qmesh.io
    rng = np.random.default_rng(6)
    base = disk_mesh(150, 6)
    Q = random_q(rng, base.n_triangles, max_ratio=10)
    mesh = qmesh.Mesh(base.points, base.triangles, conductivity=Q)
    path = tmp_path / "means.vtu"
    qmesh.io.write(path, mesh)
    back = qmesh.io.read(path)
    assert back.conductivity is not None
    assert main(["report", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["conductivity_source"] == "means"
    assert out["energy"] is None and out["l2_error"] is None
    assert out["kappa2"] == pytest.approx(measure.condition_number(base, Q), rel=1e-9)
    assert out["q_nonnegative_fraction"] == measure.q_nonnegative_fraction(base, Q)
    assert main(["report", str(path)]) == 0
    text = capsys.readouterr().out
    assert "element means" in text and "energy" in text
