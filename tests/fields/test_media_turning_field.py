"""A medium whose field region turns across an element at the size the target gives: its run
adds the points its shapes need, and the warning says so, naming the region, instead of blaming
the regions' widths (1 : 1000 layers whose dip varies, around the inclusion preset's star and
lens, took 3109 vertices for 2000: the same layers at a constant dip take 2000)."""

import warnings

import qmesh
from qmesh.domain import media_cases


def meshed(angle, target):
    domain, conductivity, _ = media_cases.inclusion()
    c = {**conductivity, 0: qmesh.TensorField.principal(1, 1e-3, angle)}
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        m = qmesh.mesh(domain, c, target_vertices=target)
    return m, [str(w.message) for w in said if issubclass(w.category, qmesh.QmeshWarning)]


def test_a_turning_field_region_is_named_when_n_overshoots():
    m, said = meshed("30*sin(pi*x)", 2000)
    over = [w for w in said if w.startswith("target_vertices = 2000")]
    assert m.n_vertices > 2200 and len(over) == 1
    assert "region 0 holds a field that turns across an element" in over[0]
    assert "their widths" not in over[0]


def test_the_same_layers_at_a_constant_dip_land_on_the_target_unwarned():
    m, said = meshed("30", 2000)
    assert abs(m.n_vertices - 2000) <= 200 and not said
