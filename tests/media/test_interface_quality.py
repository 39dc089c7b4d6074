"""Quality beside an interface a neighbour refined: the finished face is graded again.

Three layers at up to 1000:1 in the unit square: the middle layer's run finishes first, then its
neighbours' runs put fans of points on their shared edges next to its corners, finer than its
own spacing. Inserted as they are, those points leave slivers (metric quality 0.066 at N 2000);
the face meshed again with them fixed grades down to them, so its worst triangle is the one its
corners force.
"""

import warnings

import numpy as np

import qmesh
from qmesh import measure

P = qmesh.Anisotropy.principal
LAYERS = {0: P(1, 100, 30), 1: P(1000, 1, -45), 2: P(1, 10, 70)}


def _layers():
    third = 1 / 3
    return qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)],
                        regions=[[(0, third), (1, third), (1, 2 * third), (0, 2 * third)],
                                 [(0, 2 * third), (1, 2 * third), (1, 1), (0, 1)]])


def _corner_bound(Q):
    """The most a triangle in a right-angled corner of axis-parallel sides can score in the metric
    adj Q: its angle at the corner is at most the corner's in that metric (the narrower of the
    two kinds of corner a horizontal layer has), and an angle α < 60° caps quality (2.94) at the
    isosceles triangle's 2√3 sin α / (2 + 4 sin²(α/2))."""
    H = np.array([[Q[1, 1], -Q[0, 1]], [-Q[1, 0], Q[0, 0]]])
    cos = H[0, 1] / np.sqrt(H[0, 0] * H[1, 1])
    alpha = min(np.arccos(cos), np.pi - np.arccos(cos))
    return min(1.0, 2 * np.sqrt(3) * np.sin(alpha) / (2 + 4 * np.sin(alpha / 2) ** 2))


def test_layers_at_1000_to_1_keep_the_quality_their_corners_allow():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(_layers(), LAYERS, target_vertices=2000)
    q = measure.quality(m, LAYERS)
    bound = min(_corner_bound(a.matrix) for a in LAYERS.values())
    assert 0.1 < bound < 0.3                          # the 1000:1 layer's corners: about 0.109
    assert q.min() >= bound - 1e-3
    assert min(measure.q_nonnegative_fractions(m, LAYERS).values()) == 1.0
    assert abs(m.n_vertices - 2000) <= 0.1 * 2000
