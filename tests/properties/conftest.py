"""Hypothesis profiles of the property suite, and its `properties` marker.

    "ci"   (default) deterministic (derandomize), about 400 examples over the whole suite, no
           shrinking, so a failure costs no more than the examples it ran (a few minutes at most);
    "long" HYPOTHESIS_PROFILE=long: 20× the examples, random, with shrinking to a minimal case,
           for runs by hand.

Deterministic means: the same cases for the same set of collected test modules (Hypothesis
also draws constants it finds in loaded source, so running this folder alone and the whole
suite may draw different cases).

Each test takes a share of the profile's max_examples (`strategies.examples`). The profiles
are registered, not loaded, so the rest of the test suite keeps its own settings. Every test
in this folder is marked `properties`: `pytest -m "not properties"` leaves them out.
"""

import pytest
from hypothesis import HealthCheck, Phase, settings

_QUIET = [HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much,
          HealthCheck.large_base_example]

settings.register_profile("ci", max_examples=100, derandomize=True, deadline=None, database=None,
                          phases=[Phase.explicit, Phase.generate], suppress_health_check=_QUIET,
                          print_blob=False)
settings.register_profile("long", max_examples=2000, derandomize=False, deadline=None,
                          suppress_health_check=_QUIET, print_blob=True)


def pytest_configure(config):
    config.addinivalue_line("markers", "properties: the property-based suite of tests/properties")


def pytest_collection_modifyitems(config, items):
    here = __file__.rsplit("/", 1)[0]
    for item in items:
        if str(item.fspath).startswith(here):
            item.add_marker(pytest.mark.properties)
