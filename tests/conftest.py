"""Fixtures shared by the test suites (the chapter's anisotropy, a small mesh made without qmesh's
mesher), the suite's Hypothesis profile and the shared browser's lifetime.

The suite runs on pytest-xdist in collection order with `--dist worksteal` (.ci/run): each
worker starts on its half of the tests, and one that runs out takes half of what another has
left, so the tests marked `slow` (over ~8 s: a server, a browser, a kernel) are shared out
without a hand-made order; `-m "not slow"` leaves them out. pytest-timeout ends any test after
the default `timeout` of pyproject.toml."""

import os
import sys

import numpy as np
import pytest
from hypothesis import settings
from scipy.spatial import Delaunay

import qmesh

# Every hypothesis test of the suite draws the same cases on every run (and keeps no database
# of failures between runs): a run of CI from a fresh clone must not fail on a case that no
# earlier run drew. Random exploration: HYPOTHESIS_PROFILE=long (tests/properties/conftest.py)
# and benchmarks/stress.py.
settings.register_profile("suite", derandomize=True, database=None)
if os.environ.get("HYPOTHESIS_PROFILE", "ci") == "ci":
    settings.load_profile("suite")


@pytest.fixture
def chapter_anisotropy():
    """The chapter's test case (2.95): Q = diag(0.1, 10), s = 5x² + 0.05y²."""
    return qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)


@pytest.fixture
def delaunay_mesh():
    """scipy's Delaunay triangulation of the 16-gon's corners (fixed) and 40 random interior points."""
    rng = np.random.default_rng(7)
    corners = qmesh.Disk(16).seeds
    r, t = 0.9 * np.sqrt(rng.random(40)), 2 * np.pi * rng.random(40)
    P = np.vstack([corners, np.column_stack([r * np.cos(t), r * np.sin(t)])])
    T = Delaunay(P).simplices
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) < 0
    T[cw] = T[cw][:, [0, 2, 1]]
    fixed = np.arange(len(P)) < len(corners)
    return qmesh.Mesh(P, T, fixed)


def pytest_runtest_setup(item):
    """The browser tests (marked `browser`) share one Chromium per worker
    (headless_browser.shared_browser). Playwright's sync API leaves its asyncio loop set as the
    thread's running loop while it is started, which breaks any later test that runs a loop
    (the widget's, nbclient's): the browser is closed before any other test."""
    if item.get_closest_marker("browser") is None:
        _close_the_shared_browser()


def pytest_sessionfinish(session):
    _close_the_shared_browser()


def _close_the_shared_browser():
    browsers = sys.modules.get("headless_browser")       # imported by the browser tests only
    if browsers is not None:
        browsers.close_shared_browser()
