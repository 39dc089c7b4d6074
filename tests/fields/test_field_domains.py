"""A field on every kind of domain the core takes (regular, convex, thin, holed, named; turned,
scaled and moved over twelve orders of magnitude, with random options): a valid triangulation
of Ω with every input point, and every q_ij ≥ 0 on element means recomputed here, or the edges
left counted in a warning, or a refusal that says how many vertices to ask for."""

import re

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import qmesh
from tests.fields.reference import principal
from tests.fields.test_field_mesh import ASKED, meshed, positive_off_diagonals, reference_means
from tests.properties.invariants import defects
from tests.properties.strategies import any_domain, options

ALLOW = "allow boundary_refinement to add boundary vertices"


@st.composite
def fields_on(draw):
    """A domain, a field turning across it (the angle in coordinates relative to the domain's
    centre and size, so it turns as much at any scale or place), its ratio, and options."""
    spec = draw(any_domain())
    ratio = 10.0 ** draw(st.floats(0.0, 4.0))
    turns, tilt = draw(st.floats(0.0, 1.0)), draw(st.floats(0.0, 180.0))
    return spec, ratio, turns, tilt, draw(options(spec.n_points, max_target=1500))


@pytest.mark.slow(20)
@settings(max_examples=8, deadline=None)
@given(fields_on())
def test_a_turning_field_on_any_domain_is_certified_or_says_what_fails(case):
    spec, ratio, turns, tilt, opts = case
    (cx, cy), size = spec.center, spec.size
    u = f"((x - {cx!r})/{size!r})"
    angle = f"{tilt!r} + {180.0 * turns!r}*{u}"
    field = qmesh.TensorField.principal(ratio, 1.0, angle)
    target = opts.pop("target_vertices")
    try:
        m, failing = meshed(spec.build(), field, target, **opts)
    except qmesh.QmeshError as e:    # too few for the boundary (a count to ask for), or too
        asked = re.search(ASKED, str(e))      # many without boundary refinement (to allow it)
        if opts["boundary_refinement"] is False and ALLOW in str(e):
            return
        assert asked is not None and int(next(g for g in asked.groups() if g)) > target, str(e)
        return
    rings = spec.rings if spec.rings is not None else (np.asarray(spec.build().points),)
    assert defects(m, rings) == []

    def f(x, y):
        return principal(ratio, 1.0, tilt + 180.0 * turns * (x - cx) / size)
    ref = reference_means(f, m.points, m.triangles)
    assert positive_off_diagonals(m.points, m.triangles, ref) <= failing
    if ratio <= 100:
        assert failing == 0


THIN = ([(2.0, 0.0), (0.6771195952285536, 0.0029929053513511363),
         (0.5427576766953612, -0.0028123468096573298), (1.1093712083778744, -0.003143307078186863),
         (1.8339978178898777, -0.0017448428002399593)],
        [(2.0, 0.0), (0.627908552874936, 0.00928196075716966),
         (0.2769040900472486, -0.006907476420586628), (1.9102070542141327, -0.004141534962532983)])


@pytest.mark.parametrize("outline", THIN)
def test_a_field_on_a_thin_polygon_is_refused_with_a_count_that_meshes(outline):
    """Polygons 150–300 times longer than wide, the points of their sides nearly in line: Qhull
    folded their 2-D triangulation in the field's map, and the run was refused for a sharp
    corner (to be blunted) where a constant Q names the count to ask for. Now the field's
    refusal names it too, and that count meshes."""
    domain, field = qmesh.Polygon(outline), qmesh.TensorField.principal(1.0, 1.0, 0.0)
    with pytest.raises(qmesh.QmeshError, match=r"ask for at least (\d+)") as refused:
        qmesh.mesh(domain, field, target_vertices=100, boundary_refinement=False)
    asked = int(re.search(r"ask for at least (\d+)", str(refused.value)).group(1))
    m, failing = meshed(domain, field, asked, boundary_refinement=False)
    assert abs(m.n_vertices - asked) <= 0.1 * asked and failing == 0
    assert defects(m, [np.array(outline)]) == []
