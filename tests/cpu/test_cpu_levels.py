"""benchmarks/cpu_levels.py's premises: it lists every case of the benchmarks it names, each
once, and a subprocess gets the very input the parent built (a builder's own may differ there)."""

import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"
sys.path.insert(0, str(BENCHMARKS))

import bench_fields  # noqa: E402
import bench_media  # noqa: E402
import cpu_levels  # noqa: E402


@pytest.fixture(scope="module")
def listed():
    return cpu_levels.cases()


def test_every_case_once(listed):
    keys = [c.key for c in listed]
    assert len(keys) == len(set(keys))
    assert {c.group for c in listed} == set(cpu_levels.GROUPS)


def test_every_field_and_medium_at_every_benchmark_size(listed):
    fields = {(c.name, c.target) for c in listed if c.group == "fields"}
    assert {(name, n) for name in bench_fields.CASES for n in bench_fields.NS} <= fields
    media = {(c.name, c.target) for c in listed if c.group == "media"}
    assert {(name, n) for name in bench_media.SHORT for n in bench_media.NS} <= media


@pytest.mark.parametrize("key", ["fields: raster64 at 2000", "fields: islands at 2000", "corners: 0.5° at 300",
                                 "media: inclusion at 2000", "varying: exp(x) + y**2 at 500"])
def test_a_subprocess_gets_the_parents_input_bit_for_bit(listed, key):
    """What `child` meshes when its own input differs: the parent's, rebuilt from the payload."""
    case = next(c for c in listed if c.key == key)
    given = cpu_levels.inputs([case])[key]
    restored = cpu_levels._restore(given, case.build()[1])
    assert cpu_levels._fingerprint(*restored) == given["fingerprint"]
