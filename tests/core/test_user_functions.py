"""A user's s, ∇s and ∇²s (Anisotropy.from_s): their failures become QmeshErrors that name the
function and the point, and no NumPy warning reaches the user on valid input."""

import warnings

import numpy as np
import pytest

import qmesh
from qmesh import QmeshError


def r3_anisotropy() -> qmesh.Anisotropy:
    """s = |x|³/3 + |x|²/2, convex everywhere; its Hessian (1 + r) I + x xᵀ / r is written the
    natural way, which divides 0 by 0 at the origin (where the limit is I) and so warns there."""
    def s(P):
        r = np.hypot(P[:, 0], P[:, 1])
        return r ** 3 / 3 + r ** 2 / 2

    def grad(P):
        r = np.hypot(P[:, 0], P[:, 1])
        return (1 + r)[:, None] * P

    def hessian(P):
        r = np.hypot(P[:, 0], P[:, 1])
        outer = P[:, :, None] * P[:, None, :] / r[:, None, None]
        return (1 + r)[:, None, None] * np.eye(2) + np.where(np.isfinite(outer), outer, 0.0)

    return qmesh.Anisotropy.from_s(s, grad, hessian)


def barrier_anisotropy(R: float) -> qmesh.Anisotropy:
    """s = −log(R² − |x|²) + 0.3 x²: convex on |x| < R only. On the unit disk with R just above 1
    the mesher tries vertex moves whose triangles reach outside R, where ∇²s is not SPD."""
    R2 = R * R

    def s(P):
        return -np.log(R2 - np.einsum("ni,ni->n", P, P)) + 0.3 * P[:, 0] ** 2

    def grad(P):
        g = 2 * P / (R2 - np.einsum("ni,ni->n", P, P))[:, None]
        g[:, 0] += 0.6 * P[:, 0]
        return g

    def hessian(P):
        d = R2 - np.einsum("ni,ni->n", P, P)
        H = 2 * np.eye(2) / d[:, None, None] + 4 * P[:, :, None] * P[:, None, :] / (d * d)[:, None, None]
        H[:, 0, 0] += 0.6
        return H

    return qmesh.Anisotropy.from_s(s, grad, hessian)


def test_the_r3_hessian_does_warn_when_called_directly():
    """The premise of the next test: called by hand at the origin, the user's function warns."""
    raw = r3_anisotropy().hessian.f
    with pytest.warns(RuntimeWarning):
        H = raw(np.zeros((1, 2)))
    assert np.array_equal(H[0], np.eye(2))


@pytest.mark.parametrize("make, domain, options", [
    (r3_anisotropy, lambda: qmesh.Disk(16), {"target_vertices": 120}),
    (r3_anisotropy, lambda: qmesh.Disk(6), {"target_vertices": 60, "boundary_refinement": False}),
    (lambda: barrier_anisotropy(1.0005), lambda: qmesh.Disk(48),
     {"target_vertices": 60, "boundary_refinement": False}),
    (lambda: barrier_anisotropy(1.005), lambda: qmesh.Disk(6),
     {"target_vertices": 300, "boundary_refinement": False}),
    (lambda: barrier_anisotropy(1.05), lambda: qmesh.Disk(6),
     {"target_vertices": 300, "boundary_refinement": False}),
])
def test_no_numpy_warning_reaches_the_user_on_valid_input(make, domain, options):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = qmesh.mesh(domain(), make(), **options)
        report = qmesh.measure.report(m, make())
    assert np.isfinite(m.points).all()
    assert abs(m.n_vertices - options["target_vertices"]) <= 0.1 * options["target_vertices"]
    assert report["inverted_triangles"] == 0


def _quadratic(hessian):
    return qmesh.Anisotropy.from_s(lambda P: 0.5 * np.einsum("ni,ni->n", P, P), lambda P: P, hessian)


def test_an_exception_inside_s_is_a_qmesh_error_naming_s():
    A = qmesh.Anisotropy.from_s(lambda P: 1 / 0, lambda P: P, lambda P: np.broadcast_to(np.eye(2), (len(P), 2, 2)))
    with pytest.raises(QmeshError, match=r"^s raised ZeroDivisionError at \d+ points .*division by zero"):
        qmesh.mesh(qmesh.Disk(8), A, target_vertices=30)


def test_an_exception_inside_the_hessian_is_a_qmesh_error_naming_it():
    def hessian(P):
        raise KeyError("oops")
    with pytest.raises(QmeshError, match=r"^hessian raised KeyError .*oops"):
        qmesh.mesh(qmesh.Disk(8), _quadratic(hessian), target_vertices=30)


@pytest.mark.parametrize("hessian, message", [
    (lambda P: np.zeros((len(P), 3)), r"hessian must return shape \(n, 2, 2\), got \(\d+, 3\)"),
    (lambda P: "I", "hessian must return an array of real numbers, got 'I' \\(str\\)"),
    (lambda P: None, "hessian must return an array of real numbers, got None"),
    (lambda P: np.ones((len(P) + 1, 2, 2)), r"hessian must return shape \(n, 2, 2\), got \(\d+, 2, 2\)"),
])
def test_a_badly_shaped_result_is_a_qmesh_error(hessian, message):
    with pytest.raises(QmeshError, match=message):
        qmesh.mesh(qmesh.Disk(8), _quadratic(hessian), target_vertices=30)


def test_a_constant_hessian_may_be_returned_as_one_matrix():
    A = _quadratic(lambda P: np.eye(2))
    assert A.hessian(np.zeros((5, 2))).shape == (5, 2, 2)
    A.check_convex(np.zeros((5, 2)))


def test_check_convex_names_the_first_point_where_the_hessian_is_not_finite():
    def hessian(P):
        H = np.broadcast_to(np.eye(2), (len(P), 2, 2)).copy()
        H[P[:, 0] > 0.5] = np.nan
        return H
    P = np.array([[0.0, 0.0], [0.75, -0.25], [0.9, 0.0]])
    with pytest.raises(QmeshError, match=r"not finite at 2 of 3 points; the first: \[0.75, -0.25\]"):
        _quadratic(hessian).check_convex(P)


def test_check_convex_names_the_first_point_where_the_hessian_is_not_spd():
    def hessian(P):            # s = x² − y² + x⁴: a saddle wherever it matters
        H = np.zeros((len(P), 2, 2))
        H[:, 0, 0], H[:, 1, 1] = 2 + 12 * P[:, 0] ** 2, np.where(P[:, 1] > 0.1, -2.0, 2.0)
        return H
    P = np.array([[0.0, 0.0], [0.3, 0.2], [0.1, 0.5]])
    with pytest.raises(QmeshError, match=r"not SPD \(s must be strictly convex .* at 2 of 3 points; the first: \[0.3, 0.2\]"):
        _quadratic(hessian).check_convex(P)


def test_check_convex_refuses_a_non_symmetric_hessian():
    with pytest.raises(QmeshError, match="not symmetric"):
        _quadratic(lambda P: np.array([[1.0, 0.5], [0.0, 1.0]])).check_convex(np.zeros((2, 2)))


@pytest.mark.parametrize("c", [1e-200, 1e200])
def test_check_convex_does_not_depend_on_the_size_of_the_hessian(c):
    _quadratic(lambda P: c * np.array([[2.0, 1.0], [1.0, 1.0]])).check_convex(np.ones((3, 2)))


@pytest.mark.parametrize("points", [None, "P", [[0, 0, 0]], [[np.nan, 0]]])
def test_check_convex_checks_its_points(points):
    with pytest.raises(QmeshError, match="^points "):
        _quadratic(lambda P: np.eye(2)).check_convex(points)


def test_a_nan_hessian_inside_the_domain_is_refused_before_meshing():
    """The mesher checks convexity at the input points and at points inside: a NaN near the
    centre is caught before any work, and the message shows a point where it is."""
    def hessian(P):
        return np.where((np.hypot(P[:, 0], P[:, 1]) < 0.1)[:, None, None], np.nan, np.eye(2))
    with pytest.raises(QmeshError, match=r"Hessian of s is not finite at \d+ of \d+ points; the first: \[\S+, \S+\] "
                                         r"where it is \[\[nan, nan\], \[nan, nan\]\]"):
        qmesh.mesh(qmesh.Disk(8), _quadratic(hessian), target_vertices=40)
