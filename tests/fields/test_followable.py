"""A formula field no mesh of the asked size can follow — turning faster than an element, changing
below the means' quadrature, or not integrable on Ω — is refused at once, naming why and the
vertices that would follow it; smooth and integrable fields pass the check."""

import re

import pytest
from hypothesis import given, settings, strategies as st

import qmesh
from qmesh.fields import followable
from qmesh.fields.metric import smoothing_width

UNIT = qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)])
WIDTH = smoothing_width(UNIT, 200, None)


def refusal(field, target=200) -> str:
    with pytest.raises(qmesh.QmeshError) as e:
        qmesh.mesh(UNIT, field, target_vertices=target)
    return str(e.value)


@pytest.mark.timeout(60)
def test_an_angle_in_the_wrong_unit_is_refused_as_turning():
    """1e6 degrees per unit length: unfinished after 1 500 s at N = 200 before."""
    text = refusal(qmesh.TensorField.principal(100, 1, "1e6*x"))
    assert "varies faster than a mesh of 200 vertices can follow" in text
    assert "directions turn" in text and "no mesh of a usable size would follow it" in text


@pytest.mark.timeout(60)
def test_a_size_asked_for_is_refused_as_a_size():
    with pytest.raises(qmesh.QmeshError, match=r"than a mesh of this size \(about [0-9]+ vertices\)"):
        qmesh.mesh(UNIT, qmesh.TensorField.principal(100, 1, "1e6*x"), size=0.05)


@pytest.mark.timeout(60)
def test_an_oscillation_below_the_means_quadrature_is_refused():
    """A period of 6e-6: the means' quadrature (pieces of 3e-4) cannot resolve it; 102 s before."""
    text = refusal(qmesh.TensorField.from_expressions("2 + sin(1e6*x)", 0, 2))
    assert "no element mean can be computed to a bound" in text
    assert "no mesh of a usable size would follow it" in text


@pytest.mark.timeout(60)
def test_a_field_infinite_on_an_edge_is_refused_as_not_integrable():
    """1 + 1/x is infinite on x = 0: 1 108 s and 67 935 failing edges before."""
    text = refusal(qmesh.TensorField.from_expressions("1 + 1/x", 0, 1))
    assert "is not integrable on the domain" in text and "for any number of vertices" in text
    assert re.search(r"at \(0, [0-9.]+\)", text)          # a point of the edge x = 0


@pytest.mark.timeout(120)
def test_the_advised_vertices_mesh_the_field():
    """1 000 degrees per unit at N = 200 turns about 70° an element: refused naming a count, and
    that count meshes."""
    field = qmesh.TensorField.principal(100, 1, "1000*x")
    text = refusal(field)
    follow = float(re.search(r"about ([0-9.e+]+) vertices would follow it", text).group(1))
    assert 400 <= follow <= 20_000
    with pytest.warns(qmesh.QmeshWarning):       # the repair's vertices beyond the target, said
        m = qmesh.mesh(UNIT, field, target_vertices=int(follow))
    assert m.n_vertices >= follow


@settings(max_examples=12, deadline=None)
@given(rate=st.floats(1e5, 1e9), k1=st.floats(20, 1e4))
def test_fast_turning_is_refused_by_the_check(rate, k1):
    field = qmesh.TensorField.principal(k1, 1, f"{rate!r}*x")
    with pytest.raises(qmesh.QmeshError, match="directions turn"):
        followable.check(UNIT, field, WIDTH, 200)


@settings(max_examples=12, deadline=None)
@given(rate=st.floats(0, 150), k1=st.floats(1, 1e4), wave=st.floats(0, 60))
def test_smooth_fields_pass_the_check(rate, k1, wave):
    followable.check(UNIT, qmesh.TensorField.principal(k1, 1, f"{rate!r}*x*y"), WIDTH, 200)
    followable.check(UNIT, qmesh.TensorField.from_expressions(f"2 + sin({wave!r}*x)", 0, 2),
                     WIDTH, 200)


@settings(max_examples=12, deadline=None)
@given(power=st.floats(0.05, 0.9))
def test_an_integrable_singularity_on_the_boundary_passes(power):
    followable.check(UNIT, qmesh.TensorField.from_expressions(f"1 + x**(-{power!r})", 0, 1),
                     WIDTH, 200)


@settings(max_examples=12, deadline=None)
@given(power=st.floats(1.0, 3.0))
def test_a_singularity_of_power_one_or_more_is_not_integrable(power):
    field = qmesh.TensorField.from_expressions(1, 0, f"1 + y**(-{power!r})")
    with pytest.raises(qmesh.QmeshError, match=r"not integrable on the domain: towards the "
                                               r"boundary at \([0-9.]+, 0\)"):
        followable.check(UNIT, field, WIDTH, 200)
