"""`Components.lattice_points` lays out every part's lattice at once: it must be each part's
`seeding.metric_lattice` alone, bit for bit, the jitter drawn part after part, whatever the
parts' shapes: compact or elongated in the metric (their own frame), of equal or different
sizes, with holes, with lattices of none or one point."""

import numpy as np
import pytest

import qmesh
from tests.media.cases import joined
from qmesh.mesher.seeding import metric_lattice


def polygon(rng, centre, radius, n, stretch, angle):
    t = np.sort(rng.uniform(0, 2 * np.pi, n)) if n > 3 else np.array([0.0, 2.0, 4.0])
    r = radius * rng.uniform(0.6, 1.0, n)
    c, s = np.cos(angle), np.sin(angle)
    P = np.column_stack([r * np.cos(t) * stretch, r * np.sin(t)])
    return centre + P @ np.array([[c, s], [-s, c]])


def parts(rng, k):
    out = []
    for i in range(k):
        centre = np.array([3.0 * i, rng.uniform(-1, 1)])
        n = 6 if rng.random() < 0.5 else int(rng.integers(3, 20))      # many of one size, as hexagons
        outer = polygon(rng, centre, rng.uniform(0.05, 1.0), n, rng.choice([1.0, 2.0, 2.05, 4.0, 0.2]),
                        rng.uniform(0, np.pi))
        holes = [polygon(rng, centre, 0.02, 5, 1.0, 0.0)[::-1]] if rng.random() < 0.2 else []
        try:
            out.append(qmesh.Domain(outer, holes))
        except qmesh.QmeshError:
            pass
    return out


@pytest.mark.parametrize("seed", range(6))
def test_lattice_points_are_each_parts_own_lattice(seed):
    rng = np.random.default_rng(seed)
    ps = parts(rng, 25)
    C = joined(ps)
    for H in (np.array([[30.0, 4.0], [4.0, 1.0]]), np.array([[2.0, 0.3], [0.3, 1.0]])):
        for h in (0.03, 0.2, 0.8):
            got = C.lattice_points(H, h, np.random.default_rng(seed))
            one = np.random.default_rng(seed)
            alone = np.concatenate([np.zeros((0, 2))] + [metric_lattice(d, H, h, one).points for d in ps])
            assert got.shape == alone.shape and np.array_equal(got, alone)
