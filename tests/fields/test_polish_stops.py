"""The polish's rounds run only while they pay (qmesh/fields/certify.py, `paying`): a round is
made only when the last IDLE rounds raised the worst quality or lowered the shortfall below
FLOOR by PROGRESS of itself, measured here afresh from each round's mesh and means; on the
benchmark's plasma, whose worst triangle is held from the first rounds on, the polish stops
long before POLISH rounds."""

import sys
import warnings
from pathlib import Path

import numpy as np
from hypothesis import given, settings, strategies as st

import qmesh
from qmesh.conductivity.anisotropy import shape_metric
from qmesh.fields import certify as certify_module
from qmesh.fields.certify import IDLE, POLISH, PROGRESS, paying
from qmesh.fields.shares import FLOOR
from qmesh.geometry.triangles import metric_quality

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
import bench_fields as bench  # noqa: E402


def _rounds(monkeypatch, case, n):
    """The worst quality and the shortfall below FLOOR before each polish round of `case` at n
    vertices (each triangle in its own means, measured here), and the same for the mesh the
    last round left."""
    seen = []
    polish = certify_module.polish

    def counted(state, movers, **kw):
        q = np.nan_to_num(metric_quality(state.P, state.T, shape_metric(state.Qbar)), nan=0.0)
        seen.append((float(q.min()), float(np.sum(np.maximum(0.0, FLOOR - q)))))
        return polish(state, movers, **kw)
    monkeypatch.setattr(certify_module, "polish", counted)
    c = bench.CASES[case]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        mesh = qmesh.mesh(c.domain(), c.field(), target_vertices=n)
    return seen, mesh


def test_the_plasma_polish_stops_once_its_rounds_stop_paying(monkeypatch):
    seen, mesh = _rounds(monkeypatch, "plasma", 20000)
    worst, short = [w for w, _ in seen], [s for _, s in seen]
    assert IDLE < len(seen) < POLISH // 2
    for r in range(len(seen)):                # every round made was paying before it ran
        assert r <= IDLE or worst[r] > worst[r - IDLE] or \
            short[r] < (1.0 - PROGRESS) * short[r - IDLE]
    shares = qmesh.measure.q_nonnegative_fractions(mesh, mesh.conductivity)
    assert shares["q_nonnegative_fraction"] == shares["q_nonnegative_fraction_boundary"] == 1.0


@settings(max_examples=50, deadline=None)
@given(worst=st.lists(st.floats(0.0, 1.0), min_size=1, max_size=20),
       short=st.lists(st.floats(0.0, 100.0), min_size=20, max_size=20))
def test_rounds_pay_while_the_worst_rises_or_the_shortfall_falls(worst, short):
    short = short[:len(worst)]
    r = len(worst) - 1
    gained = r >= IDLE and (worst[r] > worst[r - IDLE] or
                            short[r] < (1.0 - PROGRESS) * short[r - IDLE])
    assert paying(worst, short) == (r < IDLE or gained)
    # a window in which nothing moved never pays; one in which the worst rose always does
    if r >= IDLE:
        assert not paying(worst[:-1] + [worst[r - IDLE]], short[:-1] + [short[r - IDLE]])
        assert paying(worst[:-1] + [worst[r - IDLE] + 0.5], short)
