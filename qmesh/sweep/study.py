"""The study file → the list of jobs: every domain × conductivity × target_vertices × seed.

    domains = ["disk", "L-shape", "shapes/plate.csv"]    # names in qmesh.domains.NAMED, or polygon files
    conductivities = [{principal = [1, 100, 30]}, {Q = [[0.1, 0], [0, 10]]}, {s = "exp(x) + y**2"}]
    target_vertices = [1000, 4000]
    seeds = [0]                 # optional, default [0]
    mesh_format = "vtu"         # optional, the mesh files' format (qmesh.io.FORMATS), default vtu

TOML (`.toml`, read by `tomllib`) or the same keys in JSON (`.json`). Every defect is one
QmeshError naming the file and the key; nothing runs before the whole study is accepted.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import re
from pathlib import Path

from qmesh import io
from qmesh.errors import QmeshError
from qmesh.sweep.conductivity import label_of
from qmesh.sweep.domain import domain_file
from qmesh.sweep.job import Job

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the same parser as the package tomli (the sweep extra)
    import tomli as tomllib

REQUIRED = ("domains", "conductivities", "target_vertices")
OPTIONAL = {"seeds": [0], "mesh_format": "vtu"}
MAX_JOBS = 100_000
"""The most jobs a study may have unless the caller raises it (`qmesh sweep --max-jobs`): the
product is counted before any job is made."""
INT64_MAX = 2**63 - 1
"""target_vertices and seeds go to the results table as int64 (Parquet): none may exceed it."""


def read_study(path) -> dict:
    """The study file's content as a dict (TOML or JSON by extension), not yet checked."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".toml", ".json"):
        raise QmeshError(f"a study file is .toml or .json, got {str(path)!r}")
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise QmeshError(f"cannot read the study file {str(path)!r}: {e.strerror or e}") from e
    try:
        data = tomllib.loads(raw.decode("utf-8")) if suffix == ".toml" else json.loads(raw)
    except UnicodeDecodeError as e:
        raise QmeshError(f"{path}: not UTF-8 text: {e}") from e
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as e:
        raise QmeshError(f"{path}: not valid {suffix[1:].upper()}: {e}") from e
    except (ValueError, RecursionError) as e:      # a number of more digits than Python converts, deep nesting
        raise QmeshError(f"{path}: not a usable {suffix[1:].upper()} study: {str(e)[:200]}") from e
    if not isinstance(data, dict):
        raise QmeshError(f"{path}: a study is a table of keys ({', '.join(REQUIRED)}), "
                         f"got a JSON {type(data).__name__}")
    return data


def study_jobs(path, meshes, max_jobs: int = MAX_JOBS) -> list[Job]:
    """Every job of the study file at `path`, in the order domains × conductivities × N × seeds;
    mesh files go into the folder `meshes`. A study of more than `max_jobs` jobs is refused from
    the lengths of its lists, before any entry is checked or any job made."""
    path = Path(path)
    data = read_study(path)
    name = str(path)
    unknown = sorted(set(data) - set(REQUIRED) - set(OPTIONAL))
    if unknown:
        raise QmeshError(f"{name}: unknown key {', '.join(map(repr, unknown))} "
                         f"(a study has {', '.join(REQUIRED + tuple(OPTIONAL))})")
    for key in REQUIRED:
        if key not in data:
            raise QmeshError(f"{name}: no {key!r} (a study needs {', '.join(REQUIRED)})")
    study = {**OPTIONAL, **data}
    lists = {key: _list(study[key], f"{name}: {key}") for key in (*REQUIRED, "seeds")}
    count = 1
    for key in (*REQUIRED, "seeds"):
        count *= len(lists[key])
    if count > max_jobs:
        sizes = " × ".join(f"{len(lists[k])} {k}" for k in (*REQUIRED, "seeds"))
        raise QmeshError(f"{name}: {sizes} make {count} jobs, more than the limit of {max_jobs}; "
                         "split the study, or raise the limit (qmesh sweep --max-jobs N)")

    files = {d: domain_file(d, path.parent, f"{name}: domains[{i}]")
             for i, d in _unique(lists["domains"], f"{name}: domains", _text)}
    conductivities = [label_of(c, f"{name}: conductivities[{i}]") for i, c in enumerate(lists["conductivities"])]
    _unique(conductivities, f"{name}: conductivities", _text)
    targets = [n for _, n in _unique(lists["target_vertices"], f"{name}: target_vertices", _positive)]
    seeds = [s for _, s in _unique(lists["seeds"], f"{name}: seeds", _non_negative)]
    suffix = _format(study["mesh_format"], f"{name}: mesh_format")

    folder = Path(meshes).resolve()
    return [Job(d, files[d], c, n, s, str(folder / _mesh_name(d, c, n, s, suffix)))
            for d, c, n, s in itertools.product(files, conductivities, targets, seeds)]


def _list(value, where: str) -> list:
    if not isinstance(value, list) or not value:
        raise QmeshError(f"{where} must be a non-empty list, got {json.dumps(value, default=repr)}")
    return value


def _unique(values: list, where: str, check) -> list[tuple[int, object]]:
    """(index, checked value) for each entry; a repeated entry would run the same job twice."""
    out, seen = [], set()
    for i, v in enumerate(values):
        v = check(v, f"{where}[{i}]")
        if v in seen:
            raise QmeshError(f"{where} lists {json.dumps(v)} twice")
        seen.add(v)
        out.append((i, v))
    return out


def _text(value, where: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise QmeshError(f"{where} must be a non-empty text, got {json.dumps(value, default=repr)}")
    return value


def _integer(value, where: str, low: int, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise QmeshError(f"{where} must be {what}, got {json.dumps(value, default=repr)}")
    if value > INT64_MAX:          # the table's int64 column could not hold it
        shown = str(value) if value < 10**40 else f"a number of {len(str(value))} digits"
        raise QmeshError(f"{where} must be {what} up to {INT64_MAX}, got {shown}")
    return value


def _positive(value, where: str) -> int:
    return _integer(value, where, 1, "a positive integer")


def _non_negative(value, where: str) -> int:
    return _integer(value, where, 0, "a non-negative integer")


def _format(value, where: str) -> str:
    suffix = "." + value.lower().lstrip(".") if isinstance(value, str) else None
    if suffix not in io.FORMATS:
        raise QmeshError(f"{where} must be one of {', '.join(f[1:] for f in io.FORMATS)}, got {value!r}")
    return suffix


def _mesh_name(domain: str, conductivity: str, n: int, seed: int, suffix: str) -> str:
    """A readable, unique file name: the domain's slug, N, the seed and a digest of the whole key."""
    slug = re.sub(r"[^A-Za-z0-9]+", "-", Path(domain).stem if "/" in domain or "." in domain else domain)
    digest = hashlib.sha1(json.dumps([domain, conductivity, n, seed]).encode()).hexdigest()[:8]
    return f"{slug.strip('-').lower() or 'domain'}-N{n}-seed{seed}-{digest}{suffix}"
