"""Domain files (qmesh.domain.polygon_file): CSV and GeoJSON rings read back exactly; every bad file is one clear error."""

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh import io
from qmesh.cli import main
from qmesh.errors import QmeshError
from qmesh.domain.polygon_file import domain_from_text, read_domain, read_rings

coordinate = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e12, max_value=1e12)
ring = st.lists(st.tuples(coordinate, coordinate), min_size=3, max_size=12, unique=True)
rings = st.lists(ring, min_size=1, max_size=4)
FAST = settings(max_examples=60, deadline=None, derandomize=True)


def csv_text(rs, header, close, comments):
    blocks = []
    for r in rs:
        rows = [f"{x!r},{y!r}" for x, y in (r + r[:1] if close else r)]
        if comments:
            rows.insert(1, "# a comment between points does not end the ring")
        blocks.append("\n".join(rows))
    return ("x,y\n" if header else "") + "\n\n".join(blocks) + "\n"


def geojson_polygon(rs, close=True):
    return {"type": "Polygon", "coordinates": [[list(p) for p in (r + r[:1] if close else r)] for r in rs]}


@FAST
@given(rs=rings, header=st.booleans(), close=st.booleans(), comments=st.booleans())
def test_csv_rings_read_back(tmp_path_factory, rs, header, close, comments):
    path = tmp_path_factory.mktemp("csv") / "domain.csv"
    path.write_text(csv_text(rs, header, close, comments))
    back = read_rings(path)
    assert len(back) == len(rs)
    for got, want in zip(back, rs):
        np.testing.assert_array_equal(got, np.array(want))


@FAST
@given(rs=rings, wrap=st.sampled_from(["polygon", "feature", "collection"]), close=st.booleans(),
       suffix=st.sampled_from([".geojson", ".json", ".GeoJSON"]))
def test_geojson_rings_read_back(tmp_path_factory, rs, wrap, close, suffix):
    doc = geojson_polygon(rs, close)
    if wrap != "polygon":
        doc = {"type": "Feature", "properties": {"name": "plate"}, "geometry": doc}
    if wrap == "collection":
        doc = {"type": "FeatureCollection", "features": [doc]}
    path = tmp_path_factory.mktemp("geojson") / f"domain{suffix}"
    path.write_text(json.dumps(doc))
    back = read_rings(path)
    assert len(back) == len(rs)
    for got, want in zip(back, rs):
        np.testing.assert_array_equal(got, np.array(want))


def test_geojson_altitude_is_dropped(tmp_path):
    path = tmp_path / "d.geojson"
    path.write_text(json.dumps({"type": "Polygon", "coordinates": [[[0, 0, 5], [1, 0, 5], [0, 1, 5], [0, 0, 5]]]}))
    np.testing.assert_array_equal(read_rings(path)[0], [[0, 0], [1, 0], [0, 1]])


GEO_SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}


@pytest.mark.parametrize("name, content, message", [
    ("missing.csv", None, r"cannot read polygon file '.*missing.csv'"),
    ("bin.csv", b"\xff\xfe\x00\x81", r"cannot read polygon file '.*bin.csv'"),
    ("empty.csv", "# only a comment\n\n", r"polygon file '.*empty.csv' has no points"),
    ("three.csv", "0,0\n1,0\n1,1,1\n", r"'.*three.csv', line 3: expected two columns x,y, got 3"),
    ("words.csv", "x,y\n0,0\n1,zero\n", r"'.*words.csv' is not a CSV of x,y numbers: line 3 reads '1,zero'"),
    ("late_header.csv", "0,0\n1,0\nx,y\n", r"not a CSV of x,y numbers: line 3 reads 'x,y'"),
    # a typo in the first row is an error, not a header (it used to be dropped silently)
    ("typo.csv", "1O,0\n1,0\n1,1\n0,1\n", r"typo.csv' is not a CSV of x,y numbers: line 1 reads '1O,0' \('1O' is not a number\)"),
    ("huge.csv", "0,0\n1e300,0\n0,1\n", r"line 2: coordinates must be finite numbers within ±1e\+100"),
    ("nan.csv", "0,0\nnan,0\n0,1\n", r"line 2: coordinates must be finite"),
    ("digits.csv", "0,0\n" + "9" * 5000 + ",0\n0,1\n", r"line 2: coordinates must be finite"),
    ("nested.geojson", "[" * 100000, r"nested.geojson'.*(nested too deeply|not valid JSON)"),
    ("digits.geojson", '{"type": "Polygon", "coordinates": [[[0, 0], [' + "9" * 5000 + ', 0], [0, 1]]]}',
     r"digits.geojson': not valid JSON"),
    ("big.geojson", '{"type": "Polygon", "coordinates": [[[0, 0], [' + "9" * 400 + ', 0], [0, 1]]]}',
     r"point 2: a position must be 2 or 3 finite numbers within ±1e\+100"),
    ("nan.csv", "0,0\n1,nan\n0,1\n", r"'.*nan.csv', line 2: coordinates must be finite"),
    ("short_hole.csv", "0,0\n4,0\n4,4\n0,4\n\n1,1\n2,1\n1,1\n",
     r"'.*short_hole.csv': ring 2 \(hole 1\) has 2 distinct points; a ring needs at least 3 points"),
    ("bad.json", '{"type": "Polygon",\n "coordinates": [[0, 0], }', r"'.*bad.json', line 2 column \d+: not valid JSON"),
    ("list.geojson", "[1, 2]", "a GeoJSON document must be an object, got list"),
    ("multi.geojson", {"type": "MultiPolygon", "coordinates": []}, "a MultiPolygon .* is not supported"),
    ("line.geojson", {"type": "LineString", "coordinates": [[0, 0], [1, 1]]}, "got type 'LineString'"),
    ("two.geojson", {"type": "FeatureCollection", "features": [{"type": "Feature", "geometry": GEO_SQUARE}] * 2},
     "exactly one Feature .* it holds 2"),
    ("none.geojson", {"type": "FeatureCollection", "features": []}, "it holds 0"),
    ("nogeom.geojson", {"type": "Feature", "geometry": None}, "the Feature has no geometry"),
    ("nocoords.geojson", {"type": "Polygon"}, "needs 'coordinates'"),
    ("strpoint.geojson", {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], ["1", 1], [0, 0]]]},
     r"ring 1 \(the outline\), point 3: a position must be 2 or 3 finite numbers"),
    ("4d.geojson", {"type": "Polygon", "coordinates": [GEO_SQUARE["coordinates"][0], [[0, 0, 0, 0]]]},
     r"ring 2 \(hole 1\), point 1"),
    ("bool.geojson", {"type": "Polygon", "coordinates": [[[0, 0], [1, True], [0, 1]]]}, "point 2"),
])
def test_bad_files(tmp_path, name, content, message):
    path = tmp_path / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    elif isinstance(content, dict):
        path.write_text(json.dumps(content))
    elif content is not None:
        path.write_text(content)
    with pytest.raises(QmeshError, match=message):
        read_rings(path)


def test_bad_path_argument():
    with pytest.raises(QmeshError, match="path must be a file name"):
        read_rings(42)


def test_geometry_errors_name_the_file(tmp_path):
    path = tmp_path / "bowtie.csv"
    path.write_text("0,0\n1,1\n1,0\n0,1\n")
    with pytest.raises(QmeshError, match=r"polygon file '.*bowtie.csv': "):
        read_domain(path)


def test_outline_alone_is_a_domain(tmp_path):
    path = tmp_path / "square.geojson"
    path.write_text(json.dumps(GEO_SQUARE))
    d = read_domain(path)
    assert d.area == pytest.approx(1.0)
    assert sorted(map(tuple, np.asarray(d.seeds).tolist())) == [(0, 0), (0, 1), (1, 0), (1, 1)]


def test_holes_make_a_domain(tmp_path):
    path = tmp_path / "plate.csv"
    path.write_text("# a plate with a hole\nx,y\n0,0\n4,0\n4,4\n0,4\n\n1,1\n1,2\n2,2\n2,1\n")
    d = read_domain(path)
    assert isinstance(d, qmesh.Domain) and len(d.rings) == 2
    assert d.area == pytest.approx(15.0)
    assert d.tag_names == {1: "outline", 2: "hole 1"}
    assert sorted(set(d.segment_tags.tolist())) == [1, 2]


def test_a_hole_crossing_the_outline_names_the_file_and_the_hole(tmp_path):
    path = tmp_path / "cross.csv"
    path.write_text("0,0\n4,0\n4,4\n0,4\n\n3,1\n5,1\n5,2\n3,2\n")
    with pytest.raises(QmeshError, match=r"polygon file '.*cross.csv': hole 1 crosses the outline"):
        read_domain(path)


def test_cli_meshes_a_geojson_file(tmp_path, capsys):
    path = tmp_path / "square.geojson"
    path.write_text(json.dumps({"type": "Feature", "geometry": GEO_SQUARE}))
    out = tmp_path / "sq.vtu"
    code = main(["mesh", "--polygon", str(path), "--Q", "1", "0", "1", "--target-vertices", "30", "-o", str(out)])
    assert code == 0, capsys.readouterr().err
    m = io.read(out)
    assert sorted(map(tuple, m.points[m.fixed].round(12).tolist())) == [(0, 0), (0, 1), (1, 0), (1, 1)]


def test_cli_bad_file_is_one_error_line(tmp_path, capsys):
    path = tmp_path / "multi.geojson"
    path.write_text(json.dumps({"type": "MultiPolygon", "coordinates": []}))
    code = main(["mesh", "--polygon", str(path), "-o", str(tmp_path / "m.vtu")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and err.startswith("qmesh: error: polygon file ")
    assert not (tmp_path / "m.vtu").exists()


json_values = st.recursive(st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=5),
                           lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=5), inner, max_size=4),
                           max_leaves=20)
polygonish = st.fixed_dictionaries({"type": st.sampled_from(["Polygon", "Feature", "FeatureCollection", "Point"]),
                                    "coordinates": json_values, "geometry": json_values, "features": json_values})


@settings(max_examples=80, deadline=None, derandomize=True)
@given(content=st.one_of(st.text(max_size=200), st.binary(max_size=100),
                         json_values.map(json.dumps), polygonish.map(json.dumps)),
       suffix=st.sampled_from([".csv", ".geojson", ".txt"]))
def test_any_file_gives_rings_or_one_qmesh_error(tmp_path_factory, content, suffix):
    path = tmp_path_factory.mktemp("fuzz") / f"f{suffix}"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8", errors="surrogatepass")
    try:
        rs = read_rings(path)
    except QmeshError as e:
        assert str(path) in str(e) and "\n" not in str(e)
        return
    assert rs and all(r.ndim == 2 and r.shape[1] == 2 and len(r) >= 3 and np.isfinite(r).all() for r in rs)


def test_uploaded_content_makes_the_same_domain(tmp_path):
    text = "x,y\n0,0\n4,0\n4,4\n0,4\n\n1,1\n1,2\n2,2\n2,1\n"
    (tmp_path / "plate.csv").write_text(text)
    from_file = read_domain(tmp_path / "plate.csv")
    for content in (text, text.encode(), "\ufeff".encode() + text.encode()):
        d = domain_from_text(content, "plate.csv")
        assert len(d.rings) == 2 and all(np.array_equal(a, b) for a, b in zip(d.rings, from_file.rings))
    d = domain_from_text(json.dumps(GEO_SQUARE).encode(), "upload.GEOJSON")
    assert d.area == pytest.approx(1.0)
    with pytest.raises(QmeshError, match=r"polygon file 'up.json': a MultiPolygon"):
        domain_from_text('{"type": "MultiPolygon", "coordinates": []}', "up.json")
    with pytest.raises(QmeshError, match=r"cannot read polygon file 'bad.csv'"):
        domain_from_text(b"\xff\xfe0,0", "bad.csv")
    with pytest.raises(QmeshError, match="content must be text or bytes"):
        domain_from_text(None, "x.csv")
    with pytest.raises(QmeshError, match="name must be the file's name"):
        domain_from_text("0,0\n1,0\n0,1\n", None)
