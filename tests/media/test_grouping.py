"""The faces a media run takes together (`media.mesher._group`, batched) against the rule taken
face by face: each next face (not the last) small, of the first's constant Q and sizing, and
touching no face before it."""

import warnings

import numpy as np
import pytest

import qmesh
from qmesh.domain.faces import face_domain
from qmesh.media import mesher
from qmesh.media.plan import MediaPlan
from qmesh.mesher.components import Components
from qmesh.mesher.diagnose import thin_face, thin_faces
from qmesh.mesher import sizing
from qmesh.mesher.face_meshes import FaceMeshes
from qmesh.mesher.plan import BOUNDARY_FACTOR
from tests.media.cases import hexagons

P = qmesh.Anisotropy.principal
INSIDE, OUTSIDE = P(10.0, 1.0, 30.0), P(1.0, 4.0, -20.0)


def one_by_one(plan, at, extra, meshes, alone):
    """The faces of the run from the plan's at-th face on, their point counts and sizing, each
    face looked at on its own (the rule `_group` batches)."""
    faces, sizes, taken, first = [], [], set(), None
    for i in plan.order[at:]:
        if faces and not (plan.small([faces[0]], alone, faces[0])[0] and plan.small([i], alone, faces[0])[0]
                          and i != plan.order[-1]):
            break
        if faces:
            rings, tags, _ = plan.part.face_rings(plan.faces[i], extra)
            dom = Components(rings, tags, [sum(map(len, rings))])
        else:
            dom = face_domain(plan.part, plan.faces[i], extra, plan.face_name(i))
        pts, size = set(map(tuple, dom.seeds.tolist())), plan.sizing_of(i, dom, meshes)
        if faces and (taken & pts or size != first):
            break
        first = size if not faces else first
        faces.append(i)
        sizes.append(len(dom.seeds))
        taken |= pts
    return faces, sizes, first


def media():
    x = np.linspace(0, 1, 7)
    k1 = np.where(np.add.outer(np.arange(6), np.arange(6)) % 2 == 0, 1.0, 10.0)   # a checkerboard
    cells, cells_cond = qmesh.Domain.from_cells(x, x, k1, 1.0, 0.0)
    yield qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)], regions=hexagons(70)), \
        {0: OUTSIDE, **{k: INSIDE for k in range(1, 71)}}
    yield qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)], regions=hexagons(30)), \
        {0: OUTSIDE, **{k: INSIDE if k % 7 else P(10.0, 2.0, 30.0) for k in range(1, 31)}}
    yield cells, cells_cond


@pytest.mark.parametrize("case", range(3))
@pytest.mark.parametrize("near", [False, True])
def test_batched_groups_are_the_groups_taken_face_by_face(case, near):
    """At every face of the order: the same faces, point counts and sizing; `near`: h set to a
    face's interface pieces, where each face's sizing is taken alone (round-off decides)."""
    domain, cond = list(media())[case]
    plan = MediaPlan(domain, cond, 3000, None)
    if near:
        i = plan.order[0]
        dom = face_domain(plan.part, plan.faces[i], plan.extra, "")
        L = sizing.metric_edge_lengths(dom, plan.anis[i], plan.k[i])[plan.part.interface[dom.segment_tags - 1]]
        plan.h_rest = L.max() / BOUNDARY_FACTOR / (1 + 2e-6)
    groups = 0
    for at in range(len(plan.order)):
        for alone in (set(), set(plan.order[at + 2:at + 4])):
            faces, dom, sizes, size = mesher._group(plan, at, plan.extra, FaceMeshes(), alone)
            assert (faces, sizes, size) == one_by_one(plan, at, plan.extra, FaceMeshes(), alone)
            assert len(dom.seeds) == sum(sizes) and (len(faces) == 1) != isinstance(dom, Components)
            groups += len(faces) > 1
    assert groups > 0


def test_thin_faces_says_what_thin_face_says_of_each():
    """A run's faces checked at once: the message (or None) thin_face gives each, a face with no
    interior vertex among them."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        meshes = [qmesh.mesh(qmesh.Domain(h), INSIDE, size=s) for h, s in zip(hexagons(12), [1.0, 0.1, 0.03] * 4)]
    assert any(m.boundary.all() for m in meshes)
    said = thin_faces(meshes, INSIDE, 3.0)
    assert said == [thin_face(m, INSIDE, 3.0) for m in meshes]
    assert any(s is None for s in said) and any(s is not None for s in said)


@pytest.mark.parametrize("n", [3, 6, 14, 17, 64, 500])
def test_stacked_segment_lengths_have_the_bits_of_a_call_per_polyline(n):
    """The plan measures a thousand faces at once: each face's lengths must be those its own
    call gives, bit for bit (its sizing and so its mesh depend on them), for a constant Q and a
    varying s."""
    rng = np.random.default_rng(n)
    A, B = rng.random((40, n, 2)), rng.random((40, n, 2))
    varying = qmesh.Anisotropy.from_expression("exp(x) + y**2 + x*y/4")
    for a in (INSIDE, varying):
        got = sizing.stacked_segment_lengths(A, B, a, 3.7)
        assert all(np.array_equal(got[f], sizing.segment_lengths(A[f], B[f], a, 3.7)) for f in range(40))
