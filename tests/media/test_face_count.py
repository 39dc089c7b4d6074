"""The faces' vertex count (`mesher.face_count`): a face sharing an interface with a finer face
is counted with the points it receives there and the grading toward them, so the faces sized
after the first end at the h they were given. The inclusion at N 2000: its star puts about 330
points on an interface 67 h long in the outside's metric; counted at its own 72, the outside
ended 5% coarser than its h, the lens (sized with it) too fine, and κ2 was 8.55e6 (7.58e6 before
the media path was rewritten)."""

import warnings

import numpy as np
import pytest

import qmesh
from qmesh import measure
from qmesh.domain import media_cases
from qmesh.media.plan import MediaPlan
from qmesh.mesher import face_count
from qmesh.mesher.face_count import SharedPoints, graded_triangles


def test_grading_is_nothing_where_a_face_puts_its_own_pieces():
    own = np.array([1.0, 3.0, 7.0, 40.0])
    assert (graded_triangles(own, own, np.full(4, 1e9), 0.37) == 0.0).all()


def test_grading_is_the_layer_integral_and_a_thin_face_holds_less():
    """Spacing s = h·own/c growing by GRADING per unit distance up to h:
    c·s·∫ 4/(√3 x²) − 4/(√3 h²) = (4/√3)·(c/GRADING)·(1 − own/c)² triangles; a face shallower
    than that layer (its area over its perimeter) has fewer, and more pieces give more."""
    h, c, own = 0.2, np.array([10.0, 20.0, 50.0]), np.full(3, 5.0)
    deep = graded_triangles(c, own, np.full(3, 1e9), h)
    np.testing.assert_allclose(deep, 4 / np.sqrt(3) * c / face_count.GRADING * (1 - own / c) ** 2, rtol=1e-12)
    shallow = graded_triangles(c, own, np.full(3, 0.05 * h), h)
    assert (shallow > 0).all() and (shallow < deep).all() and (np.diff(deep) > 0).all()


def test_shared_points_count_each_edges_pieces():
    s = SharedPoints({2: np.zeros((3, 2))}, 5)
    s[4] = np.zeros((1, 2))
    s[2] = np.zeros((6, 2))
    assert s.pieces.tolist() == [1, 1, 7, 1, 2] and sorted(s) == [2, 4]


def test_the_faces_after_the_star_end_at_their_size(monkeypatch):
    """Each face sized after the star (the lens, then the outside given the count that remains)
    has its median metric edge within 3% of the h it was sized at (the outside 5.4% coarser
    before), and κ2 is within 2% of the 7.58e6 of the media path before its rewrite."""
    sized, size_rest = {}, MediaPlan.size_rest

    def recorded(self, rest, n_done, *args):
        size_rest(self, rest, n_done, *args)
        sized[rest[0]] = (self, self.h_rest)

    monkeypatch.setattr(MediaPlan, "size_rest", recorded)
    domain, cond, _ = media_cases.inclusion()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(domain, cond, target_vertices=2000)
    assert len(sized) == 2
    for i, (plan, h) in sized.items():
        a, k, region = plan.anis[i], plan.k[i], plan.faces[i].region
        T = m.triangles[m.region_tags == region]
        E = np.unique(np.sort(T[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
        d = m.points[E[:, 1]] - m.points[E[:, 0]]
        median = np.median(np.sqrt(np.einsum("ni,ij,nj->n", d, a.H / k, d)))
        assert median == pytest.approx(h, rel=0.03), plan.face_name(i)
    assert m.n_vertices == 2000
    assert measure.conditioning(m, cond).kappa2 <= 1.02 * 7.58e6
