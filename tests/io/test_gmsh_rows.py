"""The MSH 2.2 writer's integer rows (`gmsh22._int_rows`): a column holding one value is written
into the row's format, and the text is the same as formatting every number of every row."""

import io

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from qmesh.io import gmsh22


def _every_number(columns) -> str:
    cols = [np.asarray(c, dtype=np.int64) for c in columns]
    n = max(len(c) for c in cols if c.ndim)
    table = np.column_stack([np.full(n, c) if c.ndim == 0 else c for c in cols])
    return "".join(" ".join(str(int(v)) for v in row) + "\n" for row in table)


@st.composite
def _columns(draw):
    n = draw(st.integers(0, 40))
    values = st.integers(-2**40, 2**40)
    out = []
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.sampled_from(["number", "alike", "varying", "pair"]))
        if kind == "number":
            out.append(draw(values))
        elif kind == "alike":
            out.append(np.full(n, draw(values), dtype=np.int64))
        elif kind == "varying":
            out.append(np.array(draw(st.lists(values, min_size=n, max_size=n)), dtype=np.int64))
        else:
            out.append(np.array(draw(st.lists(st.tuples(values, values), min_size=n,
                                              max_size=n)), dtype=np.int64).reshape(n, 2))
    out.append(np.arange(1, n + 1))                 # the element ids: at least one array
    return out


@given(_columns())
@settings(max_examples=200, deadline=None)
def test_integer_rows_are_every_number_formatted(columns):
    f = io.BytesIO()
    gmsh22._int_rows(f, columns)
    assert f.getvalue().decode("ascii") == _every_number(columns)
