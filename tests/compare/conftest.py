"""The comparison layer needs Triangle and matplotlib (the [compare] extra)."""

import pytest

pytest.importorskip("triangle", reason="tests/compare need the [compare] extra (triangle)")
pytest.importorskip("matplotlib", reason="tests/compare need the [compare] extra (matplotlib)")
