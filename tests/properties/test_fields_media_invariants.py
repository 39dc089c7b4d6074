"""Fields, media and random sharp polygons satisfy the evaluator's invariants.

Every q_ij ≥ 0 with the mesh's own element means (each interface share on its own), a valid
conforming mesh, N within 10% of the target or a warning, no exception but a QmeshError that
says what to change, and a corner refused only below 0.1° in the metric (`invariants.run`).
Few examples each, at targets up to 600: the wide runs are `benchmarks/stress.py --fields
--media --polygons`.
"""

from hypothesis import given

import invariants
from field_strategies import field_cases
from media_strategies import media_cases
from polygon_strategies import polygon_cases
from strategies import convex_domains, examples, holed_domains, named_domains, regular_domains

MAX_TARGET = 600


def check(case):
    outcome = invariants.run(case)
    assert not outcome.defects, "\n".join(outcome.defects) + f"\nreproducer: {case.reproducer()}"


@examples(0.06)
@given(field_cases(regular_domains() | convex_domains() | holed_domains() | named_domains(),
                   max_target=MAX_TARGET))
def test_fields_on_any_domain(case):
    check(case)


@examples(0.06)
@given(media_cases(MAX_TARGET))
def test_media_of_constants_and_fields(case):
    check(case)


@examples(0.06)
@given(polygon_cases(MAX_TARGET))
def test_random_sharp_polygons(case):
    check(case)
