"""Every mesh satisfies the invariants of `invariants.defects` against its input.

One test per kind of input, so each kind's first failure is reported on its own. A failure
message is the list of defects and a `qmesh.mesh(...)` call that reproduces them.
"""

from hypothesis import given

import invariants
from strategies import (cases, convex_domains, examples, holed_domains, named_domains,
                        regular_domains, thin_domains)


def check(case):
    outcome = invariants.run(case)
    assert not outcome.defects, "\n".join(outcome.defects) + f"\nreproducer: {case.reproducer()}"


@examples(0.5)
@given(cases(regular_domains()))
def test_regular_polygons_constant_q(case):
    check(case)


@examples(0.5)
@given(cases(convex_domains()))
def test_random_convex_polygons_constant_q(case):
    check(case)


@examples(0.3)
@given(cases(thin_domains()))
def test_thin_polygons_constant_q(case):
    check(case)


@examples(0.3)
@given(cases(regular_domains() | convex_domains(), conductivity="varying", max_target=1500))
def test_varying_s(case):
    check(case)


@examples(0.4)
@given(cases(regular_domains(max_vb=16) | convex_domains(max_points=8), boundary_refinement=False))
def test_seed_only_boundary(case):
    """boundary_refinement=False: never a corrupt mesh, N within 10% or an error that says why."""
    check(case)


@examples(0.5)
@given(cases(holed_domains() | named_domains(), conductivity="any"))
def test_non_convex_domains_with_holes(case):
    """Star-shaped outlines with up to three holes, and the named domains, anywhere."""
    check(case)
