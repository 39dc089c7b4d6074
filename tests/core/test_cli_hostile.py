"""Hostile command lines end in one `qmesh: error:` line and exit status 2, never a traceback:
numbers Python cannot convert, JSON nested beyond its parser, tags that are not integers."""

import pytest

from qmesh.cli import main

DOMAIN = ('{"type": "FeatureCollection", "features": [{"type": "Feature", "properties": '
          '{"region": 0}, "geometry": {"type": "Polygon", "coordinates": [[[0, 0], [%s, 0], '
          '[1, 1], [0, 1], [0, 0]]]}}]}')


@pytest.mark.parametrize("text, message", [
    (DOMAIN % ("1" + "0" * 5000), "not valid JSON"),
    ("[" * 100000 + "]" * 100000, "nested too deeply"),
])
def test_hostile_region_files(tmp_path, capsys, text, message):
    path = tmp_path / "r.geojson"
    path.write_text(text)
    assert main(["mesh", "--regions", str(path), "-o", str(tmp_path / "x.vtu")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("qmesh: error:") and message in err and "Traceback" not in err


@pytest.mark.parametrize("args, message", [
    (["--region-Q", "1e400", "1", "0", "1"], "--region-Q inf: the region tags are"),
    (["--region-Q", "nan", "1", "0", "1"], "--region-Q nan: the region tags are"),
    (["--region-Q", "0", "nan", "1", "0"], "--region-Q 0: Q has non-finite entries"),
    (["--region-principal", "0", "inf", "1", "0"], "--region-principal 0:"),
])
def test_hostile_region_conductivities(tmp_path, capsys, args, message):
    assert main(["mesh", *args, "-o", str(tmp_path / "x.vtu")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("qmesh: error:") and message in err and err.count("\n") == 1
