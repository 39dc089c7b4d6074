"""A certified mesh of a field checked against exact element means: what the certificate states
(the means the mesh stores and the error bound each carries) and what the exact means give.

The Mesh keeps its means (`Mesh.conductivity`) but not their bounds: `stated` records certify's
last assembly (`certify.shares` on the final mesh, the one its verdict is taken from) and its
Certificate while `qmesh.mesh` runs."""

from __future__ import annotations

import contextlib
import time
import warnings
from dataclasses import dataclass

import numpy as np

import qmesh
from qmesh.fields import certify as _certify
from qmesh.fields import mesher as _mesher
from qmesh.fields.shares import ROUND, shares
from tests.fields.exact_means import relative_q

NEGATIVE = 1e-9
"""An edge the certificate passes is false when q_ij / Σ|q_ij^T| < −NEGATIVE with the exact
means (round-off of the assembly is 1e-12 of Σ|q_ij^T|, the references' own error below 1e-11 of
‖Q̄‖). Which edges it passes is read again from its stored means and bounds, as certify
assembles them (`shares`, ROUND)."""
SQUARE = ((0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0))


@contextlib.contextmanager
def stated():
    """While open, what certify stated: {"P", "T", "Qbar", "err"} of its last assembly and
    "certificate" (the same Qbar and T as the Mesh it returns)."""
    seen: dict = {}
    shares, certify = _certify.shares, _mesher.certify

    def recording_shares(P, T, Qbar, err):
        seen.update(P=P, T=T, Qbar=Qbar, err=err)
        return shares(P, T, Qbar, err)

    def recording_certify(*args, **kwargs):
        m, cert = certify(*args, **kwargs)
        seen["certificate"] = cert
        return m, cert

    _certify.shares, _mesher.certify = recording_shares, recording_certify
    try:
        yield seen
    finally:
        _certify.shares, _mesher.certify = shares, certify


@dataclass
class Verdict:
    """One mesh against the exact means."""

    n: int                      # vertices
    triangles: int
    remaining: int              # edges the certificate itself says still fail
    false_interior: int         # edges it passes with exact q_ij / Σ|q_ij^T| < −NEGATIVE
    false_boundary: int
    worst: float                # the least exact q_ij / Σ|q_ij^T| over all edges (those it
                                # says fail too)
    outside: int                # triangles whose |exact − stored| exceeds the stated bound
    gap_over_bound: float       # the largest |exact − stored| / stated bound
    largest_gap: float          # the largest |exact − stored| / ‖exact‖
    largest_bound: float        # the largest stated bound / ‖stored‖
    reference_error: float      # the largest estimate of the exact means' own error / ‖exact‖
    seconds: float              # meshing (wall)
    sampled_at: float | None    # Mesh.means_sampled_at


def mesh_and_check(case, n: int, domain=None) -> tuple[qmesh.Mesh, Verdict]:
    """`case.field()` meshed at target n (on the unit square by default), its certificate
    checked against `case.means` (`hostile_fields.Case`)."""
    domain = qmesh.Polygon(SQUARE) if domain is None else domain
    F = case.field()
    start = time.perf_counter()
    with stated() as said, warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(domain, F, target_vertices=n)
    seconds = time.perf_counter() - start
    P, T = np.asarray(m.points), np.asarray(m.triangles)
    stored = np.asarray(m.conductivity)
    assert np.array_equal(said["T"], T) and np.array_equal(said["Qbar"], stored)
    return m, judge(P, T, stored, np.asarray(said["err"]), case, said["certificate"].remaining,
                    seconds, m.means_sampled_at)


def judge(P, T, stored, err, case, remaining, seconds=float("nan"), sampled_at=None) -> Verdict:
    """The stored means and their stated bounds `err` (M,) of the triangles T of P against the
    exact means of `case`."""
    exact, ref = case.means(P, T)
    (inner, bound), (ok_inner, ok_bound) = relative_q(P, T, exact, shares(P, T, stored, err), ROUND)
    size = np.linalg.norm(exact.reshape(-1, 4), axis=1)
    gap = np.linalg.norm((exact - stored).reshape(-1, 4), axis=1)
    room = err * (1 + 1e-9) + ref + 1e-13 * size
    with np.errstate(divide="ignore", invalid="ignore"):
        over = np.where(err > 0, gap / err, np.where(gap > 0, np.inf, 0.0))
    both = np.concatenate([inner, bound])
    return Verdict(len(P), len(T), int(remaining), int(np.sum((inner < -NEGATIVE) & ok_inner)),
                   int(np.sum((bound < -NEGATIVE) & ok_bound)), float(both.min()),
                   int(np.sum(gap > room)),
                   float(over.max()), float((gap / size).max()),
                   float((err / np.linalg.norm(stored.reshape(-1, 4), axis=1)).max()),
                   float((ref / size).max()), seconds, sampled_at)
