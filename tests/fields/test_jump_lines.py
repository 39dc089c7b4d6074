"""A text's jump evaluated on its own line: c·abs(u)/u and a step (α·abs(u) + β·u)/(m·u) are
0/0 where u = 0, and a sample there refused the whole field as "not finite". A line has no
area, so no element mean depends on the value there: it is the mean of the two sides, and off
the line the sides' values exactly."""

import numpy as np
import pytest

from qmesh.conductivity.expression import parse_function
from tests.fields import hostile_fields as hf
from tests.fields import truth


@pytest.mark.parametrize("text, on, below, above", [
    ("45*abs(x - 0.3)/(x - 0.3)", 0.0, -45.0, 45.0),
    ("abs(x - 0.3)/(x - 0.3)", 0.0, -1.0, 1.0),
    ("((x - 0.3) + abs(x - 0.3))/(2*(x - 0.3))", 0.5, 0.0, 1.0),
    ("sqrt((x - 0.3)**2)/(4*(x - 0.3))", 0.0, -0.25, 0.25),
])
def test_a_jump_is_finite_on_its_line_and_each_side_s_value_off_it(text, on, below, above):
    P = np.array([[0.3, 0.2], [0.1, 0.7], [0.123456789, 0.1], [0.31, 0.0], [0.987654321, 0.5]])
    assert np.array_equal(parse_function(text, "f")(P), [on, below, below, above, above])


def test_a_jump_along_the_square_s_diagonal_meshes_certified_and_true():
    """The mesher's samples lie on x + y = 1 (its points are symmetric about it): the field
    was refused ("angle … is nan at (x, y) = …: not finite")."""
    _, v = truth.mesh_and_check(hf.diagonal_jump(), 300)
    assert v.remaining == 0 and v.false_interior == v.false_boundary == v.outside == 0
