"""qmesh.measure: the share of q_ij ≥ 0 is given for interior and for boundary edges separately,
None when there is no edge of that kind; its argument checks are in
tests/properties/bad_calls.py. Expected weights come from the cotangent formula
q_ij = ½(cot θ_k + cot θ_l) for Q = I, computed here by hand, not by the code under test."""

import json

import numpy as np
import pytest

import qmesh
from qmesh import QmeshError, measure
from qmesh.cli import main

A = qmesh.Anisotropy.constant(np.eye(2))
# one triangle whose angle at (0.5, 0.1) is obtuse: the edge opposite it has q = ½ cot θ < 0
OBTUSE = qmesh.Mesh([[0.0, 0.0], [1.0, 0.0], [0.5, 0.1]], [[0, 1, 2]])
# the unit square cut along its diagonal: four boundary edges (q = ½ cot 45° = ½) and one
# interior diagonal (q = cot 90° = 0)
SQUARE = qmesh.Mesh([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], [[0, 1, 2], [0, 2, 3]])


def _cot(a, b, c):
    """Cotangent of the angle at a in the triangle (a, b, c)."""
    u, v = np.subtract(b, a), np.subtract(c, a)
    return float(np.dot(u, v) / abs(u[0] * v[1] - u[1] * v[0]))


def test_hand_computed_weights_of_the_obtuse_triangle():
    """The premise: two positive boundary weights and one negative."""
    P = OBTUSE.points
    assert _cot(P[2], P[0], P[1]) < 0 < min(_cot(P[0], P[1], P[2]), _cot(P[1], P[2], P[0]))
    edges, q, interior = measure.edge_weights(OBTUSE, A)
    assert not interior.any()
    by_edge = {tuple(e): w for e, w in zip(edges.tolist(), q)}
    assert by_edge[(0, 1)] == pytest.approx(0.5 * _cot(P[2], P[0], P[1]))
    assert by_edge[(1, 2)] == pytest.approx(0.5 * _cot(P[0], P[1], P[2]))


def test_boundary_share_and_no_interior_edge():
    assert measure.q_nonnegative_fraction(OBTUSE, A) is None
    assert measure.q_nonnegative_fraction_boundary(OBTUSE, A) == pytest.approx(2 / 3)
    r = measure.report(OBTUSE, A)
    assert r["q_nonnegative_fraction"] is None and r["min_q_ij_relative"] is None
    assert r["q_nonnegative_fraction_boundary"] == pytest.approx(2 / 3)
    P = OBTUSE.points
    q = 0.5 * np.array([_cot(P[2], P[0], P[1]), _cot(P[0], P[1], P[2]), _cot(P[1], P[2], P[0])])
    assert r["min_q_ij_relative_boundary"] == pytest.approx(q.min() / np.abs(q).max())


def test_square_interior_zero_weight_counts_as_nonnegative():
    assert measure.q_nonnegative_fraction(SQUARE, A) == 1.0
    assert measure.q_nonnegative_fraction_boundary(SQUARE, A) == 1.0
    _, q, interior = measure.edge_weights(SQUARE, A)
    assert np.allclose(q[interior], 0.0, atol=1e-15) and np.allclose(q[~interior], 0.5)


def test_boundary_weights_follow_q():
    """Q = diag(100, 1): the metric H = adj Q = diag(1, 100) stretches y tenfold, so the flat
    triangle's apex angle turns acute and every boundary q_ij ≥ 0. Hand formula: q_ab = −|T| ∇φ_aᵀ Q ∇φ_b with
    ∇φ_a = (y_b − y_c, x_c − x_b) / (2|T|) for a counter-clockwise (a, b, c)."""
    Q = np.diag([100.0, 1.0])
    P = OBTUSE.points
    area = 0.5 * ((P[1, 0] - P[0, 0]) * (P[2, 1] - P[0, 1]) - (P[1, 1] - P[0, 1]) * (P[2, 0] - P[0, 0]))
    grads = [np.array([P[b, 1] - P[c, 1], P[c, 0] - P[b, 0]]) / (2 * area)
             for b, c in ((1, 2), (2, 0), (0, 1))]
    q = [-area * grads[a] @ Q @ grads[b] for a, b in ((0, 1), (1, 2), (2, 0))]
    assert min(q) > 0
    stretched = qmesh.Anisotropy.constant(Q)
    assert measure.q_nonnegative_fraction_boundary(OBTUSE, stretched) == 1.0
    edges, weights, _ = measure.edge_weights(OBTUSE, stretched)
    by_edge = {tuple(e): w for e, w in zip(edges.tolist(), weights)}
    assert [by_edge[(0, 1)], by_edge[(1, 2)], by_edge[(0, 2)]] == pytest.approx(q)


def test_report_keys_and_json_null(tmp_path, capsys):
    path = tmp_path / "one.vtu"
    qmesh.io.write(path, OBTUSE)
    assert main(["report", str(path), "--Q", "1", "0", "1", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["q_nonnegative_fraction"] is None
    assert data["q_nonnegative_fraction_boundary"] == pytest.approx(2 / 3)
    assert main(["report", str(path), "--Q", "1", "0", "1"]) == 0
    lines = capsys.readouterr().out.splitlines()
    row = {ln.split()[0]: ln.split()[1] for ln in lines[1:]}
    assert row["q_nonnegative_fraction"] == "n/a"
    assert float(row["q_nonnegative_fraction_boundary"]) == pytest.approx(2 / 3, rel=1e-5)


def test_mesh_command_prints_both_shares(tmp_path, capsys):
    out = tmp_path / "m.vtu"
    assert main(["mesh", "--disk", "16", "--target-vertices", "80", "--Q", "1", "0", "1", "-o", str(out)]) == 0
    line = capsys.readouterr().out
    assert "q_ij>=0: interior 100.0% boundary " in line
    assert main(["mesh", "--disk", "16", "--target-vertices", "80", "--Q", "1", "0", "1",
                 "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    m = qmesh.io.read(out)
    assert summary["q_nonnegative_fraction_boundary"] == measure.q_nonnegative_fraction_boundary(m, A)




def test_a_mesh_with_nan_coordinates_cannot_be_made():
    """So no measurement ever sees one (the Mesh constructor checks)."""
    with pytest.raises(QmeshError, match=r"points has non-finite entries at row 1"):
        qmesh.Mesh([[0.0, 0.0], [1.0, np.nan], [0.0, 1.0]], [[0, 1, 2]])




def test_edge_sums_and_interfaces_match_a_triangle_by_triangle_count(delaunay_mesh):
    """edge_weights and interface_edges (summed by a sparse matrix) against a plain dict over
    the triangles' edges, with region tags that are large, negative and unordered."""
    rng = np.random.default_rng(3)
    m = delaunay_mesh
    tags = rng.choice([-7, 4, 10**12], size=m.n_triangles)
    regions = qmesh.Mesh(m.points, m.triangles, m.fixed, region_tags=tags)
    K = measure.stiffness(m, A).toarray()
    seen: dict = {}
    for t, tri in enumerate(m.triangles.tolist()):
        for a, b in ((0, 1), (1, 2), (2, 0)):
            seen.setdefault(tuple(sorted((tri[a], tri[b]))), []).append(tags[t])
    edges, q, interior = measure.edge_weights(m, A)
    assert [tuple(e) for e in edges.tolist()] == sorted(seen)
    assert interior.tolist() == [len(seen[e]) == 2 for e in sorted(seen)]
    inner = [i for i, e in enumerate(sorted(seen)) if len(seen[e]) == 2]
    np.testing.assert_allclose(q[inner], [-K[i, j] for i, j in np.array(sorted(seen))[inner]], rtol=1e-12)
    e2, inter = measure.interface_edges(regions)
    assert np.array_equal(e2, edges)
    assert inter.tolist() == [len(set(seen[e])) == 2 for e in sorted(seen)]


def test_the_shares_at_once_are_the_shares_one_by_one(delaunay_mesh):
    m = delaunay_mesh
    tags = (m.points[m.triangles].mean(axis=1)[:, 0] > 0).astype(int)
    regions = qmesh.Mesh(m.points, m.triangles, m.fixed, region_tags=tags)
    Q = {0: A, 1: qmesh.Anisotropy.principal(1, 50, 30)}
    for mesh, anisotropy in ((m, A), (regions, Q), (OBTUSE, A)):
        shares = measure.q_nonnegative_fractions(mesh, anisotropy)
        assert shares["q_nonnegative_fraction_boundary"] == measure.q_nonnegative_fraction_boundary(mesh, anisotropy)
        if len(measure.free_vertices(mesh)):
            assert shares["q_nonnegative_fraction"] == measure.q_nonnegative_fraction(mesh, anisotropy)
        else:
            assert shares["q_nonnegative_fraction"] is None
        assert ("q_nonnegative_fraction_interface" in shares) == (anisotropy is Q)
        if anisotropy is Q:
            assert shares["q_nonnegative_fraction_interface"] == measure.q_nonnegative_fraction_interface(mesh, Q)
            assert shares["q_nonnegative_fraction_interface"] < 1.0       # anisotropic neighbour: some q < 0
