"""The study file → jobs: the product of its lists in order, TOML and JSON alike, polygon files
read from the study's folder; every defect one QmeshError naming the key (and, through the CLI,
one `qmesh: error:` line with exit status 2)."""

import json
from pathlib import Path

import pytest
from hypothesis import given, settings, strategies as st

from qmesh import QmeshError
from qmesh.cli import main
from qmesh.sweep import study_jobs
from qmesh.sweep.conductivity import anisotropy_of

GOOD = '''
domains = ["disk", "L-shape", "shapes/tri.csv"]
conductivities = [{principal = [1, 100, 30]}, {Q = [[0.1, 0], [0, 10]]}, {s = "exp(x) + y**2"}]
target_vertices = [1000, 4000]
seeds = [0, 7]
'''
TRIANGLE = "x,y\n0,0\n2,0\n0,1\n"


def write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


@pytest.fixture
def shapes(tmp_path):
    write(tmp_path, "shapes/tri.csv", TRIANGLE)
    return tmp_path


def test_jobs_are_the_product_in_order(shapes):
    jobs = study_jobs(write(shapes, "s.toml", GOOD), shapes / "meshes")
    assert len(jobs) == 3 * 3 * 2 * 2
    assert [j.key for j in jobs[:3]] == [("disk", "principal=[1, 100, 30]", 1000, 0),
                                         ("disk", "principal=[1, 100, 30]", 1000, 7),
                                         ("disk", "principal=[1, 100, 30]", 4000, 0)]
    assert {j.conductivity for j in jobs} == {"principal=[1, 100, 30]", "Q=[[0.1, 0], [0, 10]]",
                                              "s=exp(x) + y**2"}
    # a polygon file keeps the study's spelling as its name and its absolute path for the worker
    tri = [j for j in jobs if j.domain == "shapes/tri.csv"]
    assert len(tri) == 12 and {j.domain_file for j in tri} == {str((shapes / "shapes/tri.csv").resolve())}
    assert all(j.domain_file is None for j in jobs if j.domain != "shapes/tri.csv")
    # one mesh file per job, .vtu by default, all in the meshes folder
    assert len({j.mesh for j in jobs}) == len(jobs)
    assert {Path(j.mesh).parent for j in jobs} == {(shapes / "meshes").resolve()}
    assert {Path(j.mesh).suffix for j in jobs} == {".vtu"}


@settings(max_examples=15, deadline=None, derandomize=True)
@given(domains=st.lists(st.sampled_from(["disk", "L-shape", "annulus", "notched square"]), min_size=1, unique=True),
       ks=st.lists(st.tuples(st.integers(1, 9), st.integers(1, 9), st.integers(0, 179)), min_size=1, max_size=3,
                   unique=True),
       targets=st.lists(st.integers(1, 10**6), min_size=1, max_size=4, unique=True),
       seeds=st.lists(st.integers(0, 2**32), min_size=1, max_size=3, unique=True))
def test_every_combination_is_one_job_with_its_own_mesh_file(tmp_path_factory, domains, ks, targets, seeds):
    folder = tmp_path_factory.mktemp("study")
    data = {"domains": domains, "conductivities": [{"principal": list(k)} for k in ks],
            "target_vertices": targets, "seeds": seeds}
    jobs = study_jobs(write(folder, "s.json", json.dumps(data)), folder)
    keys = [j.key for j in jobs]
    assert keys == [(d, f"principal={json.dumps(list(k))}", n, s)
                    for d in domains for k in ks for n in targets for s in seeds]
    assert len({j.mesh for j in jobs}) == len(jobs)


def test_json_study_gives_the_same_jobs(shapes):
    data = {"domains": ["disk", "L-shape", "shapes/tri.csv"],
            "conductivities": [{"principal": [1, 100, 30]}, {"Q": [[0.1, 0], [0, 10]]}, {"s": "exp(x) + y**2"}],
            "target_vertices": [1000, 4000], "seeds": [0, 7]}
    from_json = study_jobs(write(shapes, "s.json", json.dumps(data)), shapes / "m")
    from_toml = study_jobs(write(shapes, "s.toml", GOOD), shapes / "m")
    assert from_json == from_toml


def test_defaults_and_mesh_format(tmp_path):
    jobs = study_jobs(write(tmp_path, "s.toml", 'domains = ["annulus"]\nconductivities = [{s = "x**2 + y**2"}]\n'
                            'target_vertices = [300]\nmesh_format = "msh"\n'), tmp_path)
    assert [(j.seed, Path(j.mesh).suffix) for j in jobs] == [(0, ".msh")]


def test_conductivity_text_builds_the_same_anisotropy():
    import numpy as np
    import qmesh
    P = np.array([[0.1, -0.3], [0.5, 0.2]])
    for text, direct in [("principal=[1, 100, 30]", qmesh.Anisotropy.principal(1, 100, 30)),
                         ("Q=[[0.1, 0], [0, 10]]", qmesh.Anisotropy.constant([[0.1, 0], [0, 10]])),
                         ("s=exp(x) + y**2", qmesh.Anisotropy.from_expression("exp(x) + y**2"))]:
        assert np.allclose(anisotropy_of(text).Q(P), direct.Q(P), rtol=1e-14, atol=0)


BASE = {"domains": '["disk"]', "conductivities": '[{principal = [1, 100, 30]}]', "target_vertices": "[300]"}


def toml(**change) -> str:
    keys = {**BASE, **change}
    return "".join(f"{k} = {v}\n" for k, v in keys.items() if v is not None)


BAD = [
    ("s.toml", "domains = [\n", "not valid TOML"),
    ("s.json", "{", "not valid JSON"),
    ("s.json", "[1, 2]", "a study is a table of keys"),
    ("s.yaml", toml(), "a study file is .toml or .json"),
    ("s.toml", toml(domain='["disk"]'), "unknown key 'domain'"),
    ("s.toml", toml(target_vertices=None), "no 'target_vertices'"),
    ("s.toml", toml(domains="[]"), "domains must be a non-empty list"),
    ("s.toml", toml(domains='"disk"'), "domains must be a non-empty list"),
    ("s.toml", toml(domains="[3]"), "domains[0] must be a non-empty text"),
    ("s.toml", toml(domains='["disk", "circle"]'), "domains[1]: 'circle' is neither a named domain"),
    ("s.toml", toml(domains='["bad.csv"]'), "bad.csv"),
    ("s.toml", toml(domains='["disk", "disk"]'), "domains lists \"disk\" twice"),
    ("s.toml", toml(conductivities='[{K = 1}]'), "conductivities[0] must be one of {principal"),
    ("s.toml", toml(conductivities='[{Q = [[1, 0], [0, 1]], s = "x"}]'), "conductivities[0] must be one of"),
    ("s.toml", toml(conductivities='[{principal = [1, 100]}]'), "principal must be three numbers"),
    ("s.toml", toml(conductivities='[{principal = [1, -100, 0]}]'), "conductivities[0]: "),
    ("s.toml", toml(conductivities='[{Q = [[1, 2], [3]]}]'), "Q must be a 2×2 matrix"),
    ("s.toml", toml(conductivities='[{Q = [[1, 0], [0, -1]]}]'), "conductivities[0]: "),
    ("s.toml", toml(conductivities='[{s = ""}]'), "s must be a non-empty text"),
    ("s.toml", toml(conductivities='[{s = "__import__(\'os\')"}]'), "conductivities[0]: "),
    ("s.toml", toml(conductivities='[{s = "x**2+y**2"}, {s = "x**2+y**2"}]'), "twice"),
    ("s.toml", toml(target_vertices="[0]"), "target_vertices[0] must be a positive integer, got 0"),
    ("s.toml", toml(target_vertices="[1.5]"), "target_vertices[0] must be a positive integer"),
    ("s.toml", toml(target_vertices="[true]"), "target_vertices[0] must be a positive integer, got true"),
    ("s.toml", toml(target_vertices="[300, 300]"), "target_vertices lists 300 twice"),
    ("s.toml", toml(seeds="[-1]"), "seeds[0] must be a non-negative integer, got -1"),
    ("s.toml", toml(mesh_format='"png"'), "mesh_format must be one of vtu"),
]


@pytest.mark.parametrize("name, text, message", BAD, ids=[m for _, _, m in BAD])
def test_bad_study_is_one_error_naming_what(tmp_path, name, text, message):
    write(tmp_path, "bad.csv", "x,y\n0,0\n1,zero\n")
    path = write(tmp_path, name, text)
    with pytest.raises(QmeshError) as e:
        study_jobs(path, tmp_path)
    assert message in str(e.value)


@pytest.mark.parametrize("name, text, message", BAD[:8:3], ids=[m for _, _, m in BAD[:8:3]])
def test_cli_bad_study_is_one_error_line_and_exit_2(tmp_path, capsys, name, text, message):
    path = write(tmp_path, name, text)
    code = main(["sweep", str(path), "-o", str(tmp_path / "r.csv")])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("qmesh: error: ") and message in err
    assert not (tmp_path / "r.csv").exists()


@pytest.mark.parametrize("args, message", [
    (["-o", "r.txt"], "must end in .csv or .parquet"),
    (["-o", "no/such/folder/r.csv"], "no folder"),
    (["-o", "r.csv", "--workers", "0"], "must be a positive integer"),
    (["-o", "r.csv", "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "not allowed with argument"),
    (["-o", "table.csv"], "is not a results table of qmesh sweep"),
])
def test_cli_bad_options_exit_2(tmp_path, capsys, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    write(tmp_path, "table.csv", "a,b\n1,2\n")
    path = write(tmp_path, "s.toml", toml())
    code = main(["sweep", str(path), *args])
    err = capsys.readouterr().err
    assert code == 2 and message in err
    assert (tmp_path / "table.csv").read_text() == "a,b\n1,2\n"   # an unrelated table is not overwritten
