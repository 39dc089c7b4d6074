"""Region files (GeoJSON with a 'region' property) and conductivities per region on the CLI."""

import json

import numpy as np
import pytest

import qmesh
from qmesh.cli import main
from qmesh.domain.region_file import read_regions, regions_from_text


def feature(region, ring, **props):
    return {"type": "Feature", "properties": {"region": region, **props},
            "geometry": {"type": "Polygon", "coordinates": [ring + ring[:1]]}}


SQUARE = [[0, 0], [1, 0], [1, 1], [0, 1]]
RIGHT = [[0.5, 0], [1, 0], [1, 1], [0.5, 1]]
LENS = [[0.1, 0.1], [0.3, 0.1], [0.2, 0.3]]


def collection(*features):
    return json.dumps({"type": "FeatureCollection", "features": list(features)})


def test_a_region_file_gives_regions_names_and_conductivities(tmp_path):
    path = tmp_path / "m.geojson"
    path.write_text(collection(feature(0, SQUARE, Q=[1, 0, 1]),
                               feature("fault", RIGHT, principal=[100, 1, 30]),
                               feature("lens", LENS, s="x**2 + 2*y**2")))
    d, cond = read_regions(path)
    assert d.region_names == {1: "fault", 2: "lens"} and len(d.regions) == 2
    assert sorted(cond) == [0, 1, 2]
    assert np.allclose(cond[1].Q(np.zeros((1, 2)))[0],
                       qmesh.Anisotropy.principal(100, 1, 30).Q(np.zeros((1, 2)))[0])


@pytest.mark.parametrize("text, words", [
    (collection(feature("a", RIGHT)), "no feature with region 0"),
    (collection(feature(0, SQUARE), feature(0, SQUARE)), "second feature with region 0"),
    (collection(feature(0, SQUARE), {"type": "Feature", "properties": {},
                                     "geometry": {"type": "Polygon", "coordinates": [SQUARE]}}), "no 'region'"),
    (collection(feature(0, SQUARE, Q=[1, 0], )), "three numbers"),
    (collection(feature(0, SQUARE, Q=[1, 0, 1], s="x**2")), "one of Q, principal, s"),
    (collection(feature(0, SQUARE), feature("x", [[0.5, 0.5], [2, 0.5], [2, 2]])), "region 1"),
    ('{"type": "Polygon"}', "FeatureCollection"),
])
def test_bad_region_files_are_refused(text, words):
    with pytest.raises(qmesh.QmeshError, match=words):
        regions_from_text(text, "f.geojson")


def test_cli_meshes_regions_with_a_conductivity_per_region(tmp_path, capsys):
    path = tmp_path / "m.geojson"
    path.write_text(collection(feature(0, SQUARE), feature("fault", RIGHT), feature("lens", LENS)))
    out = tmp_path / "m.vtu"
    code = main(["mesh", "--regions", str(path), "--region-principal", "1", "100", "1", "30",
                 "--region-Q", "2", "0.01", "0", "0.01", "--target-vertices", "400", "-o", str(out),
                 "--json", "--quiet"])
    stdout, _ = capsys.readouterr()
    assert code == 0
    summary = json.loads(stdout)
    assert summary["q_nonnegative_fraction_interface"] == 1.0
    assert summary["q_nonnegative_fraction"] == summary["q_nonnegative_fraction_boundary"] == 1.0
    assert out.exists()
    code = main(["mesh", "--regions", str(path), "--region-Q", "3", "1", "0", "1", "-o", str(out)])
    _, err = capsys.readouterr()
    assert code == 2 and "region tags are 0 to 2" in err


def test_the_mesh_file_keeps_each_regions_conductivity_and_report_measures_with_them(tmp_path, capsys):
    path = tmp_path / "m.geojson"
    path.write_text(collection(feature(0, SQUARE, principal=[1, 100, 30]), feature("fault", RIGHT, Q=[5, 0, 0.05])))
    out = tmp_path / "m.vtu"
    assert main(["mesh", "--regions", str(path), "--target-vertices", "300", "-o", str(out), "--quiet"]) == 0
    capsys.readouterr()
    stored = qmesh.io.read_anisotropy(out)
    assert sorted(stored) == [0, 1]
    np.testing.assert_allclose(stored[1].H, qmesh.Anisotropy.constant([[5, 0], [0, 0.05]]).H)
    assert main(["report", str(out), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["conductivity_source"] == "file" and "region 1: Q = [[5" in rep["conductivity"]
    assert rep["q_nonnegative_fraction_interface"] == 1.0
    assert (qmesh.io.read(out).region_tags == 1).any()
