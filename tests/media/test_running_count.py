"""The running vertex count of the finished face meshes (`FaceMeshes`) against a full
recount, and the partition's KD-tree shared by all faces (`partition.points_on_edges`)."""

import warnings

import numpy as np
from scipy.spatial import cKDTree

import qmesh
from qmesh.domain import media_cases
from qmesh.media import mesher
from qmesh.domain.partition import points_on_edges
from qmesh.media.plan import FaceMeshes, MediaPlan
from tests.media.cases import hexagons

P = qmesh.Anisotropy.principal
INSIDE, OUTSIDE = P(10.0, 1.0, 30.0), P(1.0, 4.0, -20.0)


def recount(meshes) -> int:
    """The stitched vertex count from scratch: interior vertices of each, boundary points once."""
    inner, bounds = 0, [np.zeros((0, 2))]
    for m in meshes:
        b = np.unique(m.boundary_edges)
        inner += m.n_vertices - len(b)
        bounds.append(m.points[b])
    return inner + len(np.unique(np.concatenate(bounds), axis=0))


def test_running_count_equals_a_full_recount_at_every_change(monkeypatch):
    """30 inclusions of conductivities all different (so each is meshed on its own), and the
    inclusion case at N 1500 (whose outside hands points over to a finished face, replacing its
    mesh): after every face added or replaced, and at every call, the running count is the
    recount."""
    seen = {"calls": 0, "replaced": 0}

    class Checked(FaceMeshes):
        def __setitem__(self, i, m):
            seen["replaced"] += i in self and self[i] is not m
            super().__setitem__(i, m)
            assert FaceMeshes.vertex_count(self) == recount(self.values())

        def add(self, faces, meshes):
            super().add(faces, meshes)
            assert FaceMeshes.vertex_count(self) == recount(self.values())

        def vertex_count(self, *adding):
            seen["calls"] += 1
            assert super().vertex_count() == recount(self.values())
            return super().vertex_count(*adding)

    monkeypatch.setattr(mesher, "FaceMeshes", Checked)
    domain = qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)], regions=hexagons(30))
    cond = {0: OUTSIDE, **{k: P(10.0 + k, 1.0, 30.0) for k in range(1, 31)}}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = qmesh.mesh(domain, cond, target_vertices=1500)
        assert seen["calls"] >= 30      # before every face but the first, and for the last
        assert m.n_vertices > 1000
        dom, cond, _ = media_cases.inclusion()
        qmesh.mesh(dom, cond, target_vertices=1500)
    assert seen["replaced"] > 0         # the replacing path ran too


def test_a_replaced_face_gives_back_its_points():
    """Replacing a face's mesh by another and back restores the count; a face mesh replaced by
    itself changes nothing."""
    domain = qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)], regions=hexagons(4))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = qmesh.mesh(domain, {0: OUTSIDE, **{k: INSIDE for k in range(1, 5)}}, target_vertices=300)
        b = qmesh.mesh(domain, {0: OUTSIDE, **{k: INSIDE for k in range(1, 5)}}, target_vertices=150)
    f = FaceMeshes()
    f[0] = a
    f[1] = a                            # the same boundary points twice: counted once
    assert f.vertex_count() == recount([a, a]) == 2 * a.n_vertices - len(np.unique(a.boundary_edges))
    f[1] = b
    assert f.vertex_count() == recount([a, b]) != recount([a, a])
    f[1] = f[1]
    f[1] = a
    assert f.vertex_count() == recount([a, a])
    assert list(f) == [0, 1]
    # points they hold add nothing; the others add one each (a's interior: not held)
    assert f.vertex_count(a.points[np.unique(a.boundary_edges)]) == f.vertex_count()
    assert f.vertex_count(a.points) == recount([a, a]) + recount([a]) - len(np.unique(a.boundary_edges))


def test_points_on_edges_with_the_shared_tree_is_the_per_face_answer(monkeypatch):
    """The plan's KD-tree of the partition's points gives what a tree built per run gave (the
    inclusions' conductivities all different, so each face has its own run)."""
    domain = qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)], regions=hexagons(4))
    cond = {0: OUTSIDE, **{k: P(10.0 + k, 1.0, 30.0) for k in range(1, 5)}}
    plan = MediaPlan(domain, cond, 400, None)
    found = []

    def both(mesh, corners, n_seeds):
        assert corners is plan.corners
        got = points_on_edges(mesh, corners, n_seeds)
        own = points_on_edges(mesh, cKDTree(np.array(plan.part.points)), n_seeds)
        assert got.keys() == own.keys() and all(np.array_equal(got[k], own[k]) for k in got)
        found.append(got)
        return got

    monkeypatch.setattr(mesher, "points_on_edges", both)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        list(mesher._run(plan, {}, False))
    assert len(found) >= len(plan.faces) == 5       # a face meshed again after a hand-over: once more
    assert any(len(p) for p in found)


def full_count(plan, h, faces, thin):
    """`MediaPlan.counter` over every face's segments and every interface edge, masked after."""
    from qmesh.mesher import sizing
    from qmesh.mesher.face_count import graded_triangles
    from qmesh.mesher.plan import BOUNDARY_FACTOR
    mine = np.isin(np.arange(len(plan.faces)), faces)
    step = np.minimum(BOUNDARY_FACTOR * h, plan._thin_step) if thin else BOUNDARY_FACTOR * h
    pieces = np.maximum(1, np.ceil(plan._seg_len / step))
    ef = plan.part.edge_faces[plan._inter]
    touched = mine[ef[:, 0]] | mine[ef[:, 1]]
    tri = plan.area[mine] / sizing.equilateral_area(h)
    if thin:
        nb = np.bincount(plan._seg_face, pieces, minlength=len(plan.faces))[mine]
        n = float(0.5 * (np.maximum(tri, nb - 2) + nb + 2).sum())
        both = np.minimum(pieces[plan._side[:, 0]], pieces[plan._side[:, 1]])
        return n - float(both[touched].sum())
    known = plan.extra.pieces[plan._inter]
    held = known * np.ceil(np.maximum(pieces[plan._side[:, 0]], pieces[plan._side[:, 1]]) / known)
    c = pieces.copy()
    on = plan._seg_inter >= 0
    c[on] = held[plan._seg_inter[on]]
    nb = np.bincount(plan._seg_face, c, minlength=len(plan.faces))[mine]
    depth = plan.area / np.bincount(plan._seg_face, plan._seg_len, minlength=len(plan.faces))
    graded = graded_triangles(c, pieces, depth[plan._seg_face], BOUNDARY_FACTOR * h)
    tri = tri + np.bincount(plan._seg_face, graded, minlength=len(plan.faces))[mine]
    n = float(0.5 * (tri + nb + 2).sum())
    return n - float(np.where(mine[ef].all(axis=1), held, known)[touched].sum())


def test_count_over_the_faces_own_segments_is_the_full_count_bit_for_bit():
    """The count the plan sizes the faces left with, at many h, thin or not, for the faces
    left at every turn of the run: exactly the full count (the run's h are the same)."""
    domain = qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)], regions=hexagons(30))
    cond = {0: OUTSIDE, **{k: INSIDE for k in range(1, 31)}}
    plan = MediaPlan(domain, cond, 1500, None)
    hs = plan.h * np.geomspace(1e-3, 1e3, 25)
    compared = 0
    for at in range(len(plan.order)):
        rest = plan.order[at:]
        for thin in (False, True):
            counter = plan.counter(rest, thin)
            for h in hs:
                assert counter(h) == full_count(plan, h, rest, thin)
                compared += 1
    assert compared == 31 * 2 * 25
    assert len({plan.counter(plan.order, True)(h) for h in hs}) > 5     # it does depend on h
