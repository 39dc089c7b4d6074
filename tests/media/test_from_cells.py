"""Domain.from_cells: per-cell k1, k2, angle merged into regions of equal conductivity."""

import warnings

import numpy as np
import pytest

import qmesh
from qmesh.geometry import portable
from tests.media.cases import check_mesh


def layered():
    x, y = np.linspace(0, 3, 16), np.linspace(0, 1, 9)
    k1, k2, ang = np.ones((8, 15)), np.ones((8, 15)), np.zeros((8, 15))
    k1[2:4] = 100.0                    # a conductive tilted layer
    ang[2:4] = 20.0
    k1[5:7, 5:10] = k2[5:7, 5:10] = 1e-2   # a barrier lens
    return x, y, k1, k2, ang


def test_cells_of_equal_conductivity_become_one_region():
    x, y, k1, k2, ang = layered()
    d, cond = qmesh.Domain.from_cells(x, y, k1, k2, ang)
    assert len(d.regions) == 3 and sorted(cond) == [0, 1, 2, 3]
    assert sum(r.area for r in d.regions) < d.area == pytest.approx(3.0)
    # straight runs merged: the layer is a rectangle of 4 points
    assert sorted(len(r.rings[0]) for r in d.regions) == [4, 4, 4]


def test_each_triangle_gets_the_conductivity_of_its_cell():
    x, y, k1, k2, ang = layered()
    d, cond = qmesh.Domain.from_cells(x, y, k1, k2, ang)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(d, cond, target_vertices=800)
    check_mesh(d, cond, m)
    c = m.points[m.triangles].mean(axis=1)
    i = np.searchsorted(x, c[:, 0]) - 1
    j = np.searchsorted(y, c[:, 1]) - 1
    for r, A in cond.items():
        sel = m.region_tags == r
        want = qmesh.Anisotropy.principal(k1[j[sel], i[sel]][0], k2[j[sel], i[sel]][0],
                                          ang[j[sel], i[sel]][0]).Q(c[sel][:1])
        assert np.allclose(A.Q(c[sel][:1]), want)
        assert len(np.unique(np.stack([k1[j[sel], i[sel]], k2[j[sel], i[sel]]]), axis=1).T) == 1


def test_a_zone_pinched_at_a_corner_is_refused():
    # the 3-zone touches itself diagonally at (2, 2): cells (row 1, col 2) and (row 2, col 1)
    pinch = np.array([[3.0, 3.0, 3.0], [3.0, 2.0, 3.0], [3.0, 3.0, 2.0]])
    with pytest.raises(qmesh.QmeshError, match="corner \\[2.0, 2.0\\]"):
        qmesh.Domain.from_cells([0, 1, 2, 3], [0, 1, 2, 3], pinch, pinch)
    # two zones touching only at a corner are two regions, which is fine
    chess = np.array([[1.0, 2.0], [2.0, 1.0]])
    d, cond = qmesh.Domain.from_cells([0, 1, 2], [0, 1, 2], chess, chess)
    assert len(d.regions) == 3 and len(cond) == 4


def test_bad_cell_arrays_are_refused():
    with pytest.raises(qmesh.QmeshError, match="k1"):
        qmesh.Domain.from_cells([0, 1, 2], [0, 1], [[1.0, -1.0]], 1.0)
    with pytest.raises(qmesh.QmeshError, match="increasing"):
        qmesh.Domain.from_cells([0, 2, 1], [0, 1], 1.0, 1.0)


def _rotating(n, delta=1e-3):
    """FVCA5 test 5's tensor at the centres of n × n cells of the unit square: (x, k1, k2, angle)."""
    x = np.linspace(0, 1, n + 1)
    c = 0.5 * (x[1:] + x[:-1])
    X, Y = np.meshgrid(c, c)
    r2 = X * X + Y * Y
    K = np.empty(X.shape + (2, 2))
    K[..., 0, 0] = (delta * X * X + Y * Y) / r2
    K[..., 0, 1] = K[..., 1, 0] = (delta - 1) * X * Y / r2
    K[..., 1, 1] = (X * X + delta * Y * Y) / r2
    w, v = portable.eigh2(K)                     # not numpy.linalg: the same input on every CPU
    return x, w[..., 1], w[..., 0], np.degrees(portable.arctan2(v[..., 1, 1], v[..., 0, 1]))


def test_all_different_cells_follow_the_target_monotonically():
    x, k1, k2, ang = _rotating(6)
    d, cond = qmesh.Domain.from_cells(x, x, k1, k2, ang)
    counts, targets = [], (1000, 4000, 5000, 10000)
    for n in targets:
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            m = qmesh.mesh(d, cond, target_vertices=n)
        assert len(said) <= 4                      # the faces' warnings summed up, not one per zone
        fr = qmesh.measure.q_nonnegative_fractions(m, cond)
        assert min(fr.values()) == 1.0
        counts.append(m.n_vertices)
        if n == targets[0]:                        # below the zones' least: said once, with it
            least = [str(w.message) for w in said if "about the least" in str(w.message)]
            assert len(least) == 1 and str(m.n_vertices) in least[0]
    assert counts == sorted(counts)
    for n, c in zip(targets[1:], counts[1:]):      # above the least: within 10% of the target
        assert counts[0] < n and abs(c - n) <= 0.1 * n, (n, c)
