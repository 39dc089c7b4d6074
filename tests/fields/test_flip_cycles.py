"""A field's metric has no s: its flips (the in-ellipse test in the metric at each
quadrilateral's centre) may cycle. `restore` keeps an edge flipped away a second time past
WATCH rounds, so a cycle costs a few rounds more, not METRIC_ROUNDS; the mesh stays certified."""

import numpy as np
import pytest

import qmesh
import qmesh.mesher.triangulate as triangulate
from tests.fields.reference import cell_tensors
from tests.fields.test_field_mesh import (meshed, positive_off_diagonals, raster_reference_means,
                                          uneven_cells)


def irregular_smooth_raster(seed):
    """A raster of 1 : 10⁴ or less whose angle turns smoothly, on irregular cell lines, and a
    star-shaped polygon inside it (the random search's generator, one of its cases)."""
    rng = np.random.default_rng(seed)
    xe, ye, off, W, H, ratio = uneven_cells(rng)
    ny, nx = len(ye) - 1, len(xe) - 1
    rng.choice(3)                                  # the kind of field (kept: the draws in order)
    X, Y = np.meshgrid((xe[:-1] + xe[1:]) / 2, (ye[:-1] + ye[1:]) / 2)
    angle = rng.uniform(0, 360) * ((X - off[0]) / W) + rng.uniform(0, 180) * ((Y - off[1]) / H)
    k1, k2 = np.ones((ny, nx)), np.full((ny, nx), 1 / ratio)
    rng.choice(2)
    n = int(rng.integers(5, 14))
    rng.uniform(0, 2 * np.pi, n)
    t = np.linspace(0, 2 * np.pi, n, endpoint=False) + rng.uniform(-0.25, 0.25, n) * (2 * np.pi / n)
    r = rng.uniform(0.4, 1.0, n)
    c = np.array([(xe[0] + xe[-1]) / 2, (ye[0] + ye[-1]) / 2])
    outline = c + np.column_stack([r * np.cos(t), r * np.sin(t)]) * np.array([W, H]) * 0.49
    target = int(10 ** rng.uniform(np.log10(150), np.log10(5000)))
    return xe, ye, k1, k2, angle, outline, target


@pytest.mark.slow(12)
def test_a_flip_cycle_ends_a_few_rounds_past_watch(monkeypatch):
    """This raster (1 : 9604, 39 × 16 cells, target 3331) cycled to the cap in 24 of its
    triangulations, one flip a round."""
    rounds, real = [], triangulate._violation

    def counted(*args, **kwargs):
        rounds[-1] += 1
        return real(*args, **kwargs)

    real_restore = triangulate.restore

    def restore(*args, **kwargs):
        rounds.append(0)
        return real_restore(*args, **kwargs)

    monkeypatch.setattr(triangulate, "_violation", counted)
    monkeypatch.setattr(triangulate, "restore", restore)
    for user in ("qmesh.mesher.stages", "qmesh.mesher.conform"):   # each call counted on its own
        monkeypatch.setattr(f"{user}.restore", restore)
    x, y, k1, k2, angle, outline, target = irregular_smooth_raster(20067)
    m, failing = meshed(qmesh.Polygon(outline), qmesh.TensorField.from_raster(x, y, k1, k2, angle),
                        target)
    assert max(rounds) <= triangulate.WATCH + 20, sorted(rounds)[-5:]
    assert failing == 0
    ref = raster_reference_means(x, y, cell_tensors(k1, k2, angle), m.points, m.triangles)
    assert positive_off_diagonals(m.points, m.triangles, ref) == 0
