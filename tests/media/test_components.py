"""Small faces of one constant Q meshed in one run (`qmesh.mesher.components`): the joined domain,
its mesh cut back one per face, and a medium of many inclusions meshed that way."""

import warnings

import numpy as np
import pytest

import qmesh
from qmesh import measure
from qmesh.media import mesher as media_mesher
from qmesh.media import plan as media_plan
from qmesh.mesher import loop
from qmesh.mesher.components import Components, split
from tests.media.cases import hexagons, joined

P = qmesh.Anisotropy.principal
INSIDE, OUTSIDE = P(10.0, 1.0, 30.0), P(1.0, 4.0, -20.0)


def parts() -> list:
    ring = qmesh.Domain([(2, 0), (3, 0), (3, 1), (2, 1)], [[(2.4, 0.4), (2.4, 0.6), (2.6, 0.6), (2.6, 0.4)]],
                        tags=[5, 6])
    return [qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)]), ring, qmesh.Domain(hexagons(1)[0] + [0, 2])]


def test_the_joined_domain_covers_its_parts():
    ps = parts()
    C = joined(ps)
    assert isinstance(C, Components)
    assert C.area == pytest.approx(sum(d.area for d in ps), rel=1e-15)
    assert np.array_equal(C.seeds, np.concatenate([d.seeds for d in ps]))
    assert np.array_equal(C.segment_tags, np.concatenate([d.segment_tags for d in ps]))
    lo, hi = C.bounds
    assert np.array_equal(lo, [0, 0]) and hi[0] == 3 and hi[1] > 2
    S = C.scaled(np.array([1.0, 1.0]), 2.0)
    assert isinstance(S, Components) and S.area == pytest.approx(C.area / 4, rel=1e-15)
    inside = C.contains([(0.5, 0.5), (2.5, 0.5), (2.2, 0.5), (1.5, 0.5), *hexagons(1)[0].mean(axis=0, keepdims=True) + [0, 2]])
    assert inside.tolist() == [True, False, True, False, True]


@pytest.mark.parametrize("A", [INSIDE, qmesh.Anisotropy.constant(np.eye(2))])
def test_one_run_on_the_parts_cuts_back_into_one_mesh_per_part(A):
    """Each part's mesh has its own input points first, bit for bit, every triangle inside it,
    its boundary edges tagged with its segments' tags, and q_ij >= 0 on every edge."""
    ps = parts()
    last = list(loop.iterate(joined(ps), A, size=0.08))[-1].mesh
    meshes = split(last, [len(d.seeds) for d in ps])
    assert sum(m.n_vertices for m in meshes) == last.n_vertices
    assert sum(m.n_triangles for m in meshes) == last.n_triangles
    for d, m in zip(ps, meshes):
        assert np.array_equal(m.points[:len(d.seeds)], d.seeds) and m.fixed.sum() == len(d.seeds)
        centroids = m.points[m.triangles].mean(axis=1)
        assert d.contains(centroids, tol=0).all()
        assert set(m.boundary_tags.tolist()) == set(d.segment_tags.tolist())
        r = measure.report(m, A)
        assert r["q_nonnegative_fraction"] == r["q_nonnegative_fraction_boundary"] == 1.0


def test_a_mesh_joining_two_parts_is_refused():
    ps = parts()[:1] + [qmesh.Domain([(1, 0), (2, 0), (2, 1), (1, 1)])]
    m = list(loop.iterate(qmesh.Domain([(0, 0), (2, 0), (2, 1), (0, 1)]), INSIDE, size=0.2))[-1].mesh
    with pytest.raises(qmesh.QmeshError, match="one per domain"):
        split(m, [len(d.seeds) for d in ps])


def runs(monkeypatch, fail: bool = False) -> list:
    """The sizes of the media runs (faces per run); with `fail`, every run of several fails."""
    sizes, iterate = [], loop.iterate

    def counted(domain, anisotropy, **kw):
        n = len(domain.sizes) if isinstance(domain, Components) else 1
        sizes.append(n)
        if fail and n > 1:
            raise qmesh.QmeshError("a run of several faces failed")
        return iterate(domain, anisotropy, **kw)

    monkeypatch.setattr(media_mesher.loop, "iterate", counted)
    return sizes


def test_many_inclusions_share_a_run_and_iterate_ends_on_mesh(monkeypatch):
    """60 inclusions of one Q: one run for all, the outside its own; q_ij >= 0 everywhere, and
    the last Step of iterate is mesh's mesh bit for bit."""
    domain = qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)], regions=hexagons(60))
    cond = {0: OUTSIDE, **{k: INSIDE for k in range(1, 61)}}
    sizes = runs(monkeypatch)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = qmesh.mesh(domain, cond, target_vertices=2000)
        assert sizes == [60, 1]
        last = list(qmesh.iterate(domain, cond, target_vertices=2000))[-1].mesh
    assert np.array_equal(last.points, m.points) and np.array_equal(last.triangles, m.triangles)
    assert np.array_equal(last.region_tags, m.region_tags)
    assert abs(m.n_vertices - 2000) <= 200 and set(m.region_tags.tolist()) == set(range(61))
    r = measure.report(m, cond)
    assert r["q_nonnegative_fraction"] == r["q_nonnegative_fraction_interface"] == 1.0
    assert r["q_nonnegative_fraction_boundary"] == 1.0


def test_a_run_of_several_that_fails_meshes_them_one_by_one(monkeypatch):
    """The faces of a failed run are meshed on their own: the mesh of a medium whose faces are
    never grouped (SMALL = 0), bit for bit."""
    domain = qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)], regions=hexagons(12))
    cond = {0: OUTSIDE, **{k: INSIDE for k in range(1, 13)}}
    sizes = runs(monkeypatch, fail=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = qmesh.mesh(domain, cond, target_vertices=800)
        assert sizes[0] == 12 and sizes[1:] == [1] * 13
        monkeypatch.setattr(media_plan, "SMALL", 0)
        alone = qmesh.mesh(domain, cond, target_vertices=800)
    assert np.array_equal(m.points, alone.points) and np.array_equal(m.triangles, alone.triangles)


def test_a_face_taken_as_the_partition_made_it_is_the_checked_face():
    """A run's faces after its first, taken many at once (`Partition.faces_rings`) and joined
    unchecked: the same rings, segments, tags and area as the Domain that checks each."""
    from qmesh.domain.faces import face_domain
    domain = qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)], regions=hexagons(4))
    part = domain.partition
    V, E = part.points, part.edges                    # points on every edge, ordered along it
    extra = {e: V[E[e, 0]] + np.array([[0.25], [0.5]]) * (V[E[e, 1]] - V[E[e, 0]]) for e in range(len(E))}
    many = part.faces_rings(list(part.faces), extra)
    assert np.array_equal(many.face_rings, [len(f.cycles) for f in part.faces]) and many.simple.all()
    for j, f in enumerate(part.faces):
        rings, tags = many.face(j)
        a, b = face_domain(part, f, extra, "x"), Components(rings, [tags], [len(tags)])
        assert len(b.rings) == len(a.rings) == len(f.cycles)
        assert all(np.array_equal(r, s) for r, s in zip(a.rings, b.rings))
        assert np.array_equal(a.segments, b.segments) and np.array_equal(a.segment_tags, b.segment_tags)
        assert b.area == pytest.approx(a.area, rel=1e-12)


def test_each_part_is_seeded_with_its_own_lattice():
    """Components.lattice_points: each part's metric lattice as seeding makes it for that part
    alone (the jitter drawn part after part), so a small part is seeded as it would be alone."""
    from qmesh.mesher.seeding import metric_lattice
    ps = parts()
    H = np.array([[2.0, 0.3], [0.3, 1.0]])
    got = joined(ps).lattice_points(H, 0.05, np.random.default_rng(3))
    rng = np.random.default_rng(3)
    alone = np.concatenate([metric_lattice(d, H, 0.05, rng).points for d in ps])
    assert len(alone) > 100 and np.array_equal(got, alone)


def test_inclusions_in_one_run_keep_their_interior_vertices():
    """300 inclusions 1.5 elements wide at N 5000: one lattice across all of them left most
    without an interior vertex (a thin-domain warning each); their own lattices, as alone, none."""
    domain = qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)], regions=hexagons(300))
    cond = {0: OUTSIDE, **{k: INSIDE for k in range(1, 301)}}
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        m = qmesh.mesh(domain, cond, target_vertices=5000)
    assert not said and abs(m.n_vertices - 5000) <= 500
    assert measure.report(m, cond)["q_nonnegative_fraction"] == 1.0
