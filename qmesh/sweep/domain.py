"""A study's domains: a name in `qmesh.domains.NAMED` (e.g. "disk", "L-shape") or a polygon
file (CSV or GeoJSON, `qmesh.domain.polygon_file`), a relative path read from the study file's
folder. The study checks each once; a worker builds it again from the name or the absolute path.
"""

from __future__ import annotations

from pathlib import Path

from qmesh import Domain, domains
from qmesh.domain.polygon_file import read_domain
from qmesh.errors import QmeshError


def domain_file(entry, folder: Path, where: str) -> str | None:
    """None for a named domain, else the polygon file's absolute path (checked by reading it)."""
    if not isinstance(entry, str) or not entry.strip():
        raise QmeshError(f"{where} must be a domain name or a polygon file, got {entry!r}")
    if entry in domains.NAMED:
        return None
    path = (folder / entry).resolve()
    if not path.is_file():
        raise QmeshError(f"{where}: {entry!r} is neither a named domain ({', '.join(domains.NAMED)}) "
                         f"nor a polygon file (no file {str(path)!r})")
    read_domain(path)   # a bad file is refused now, with its line, rather than in every job
    return str(path)


def build_domain(name: str, file: str | None) -> Domain:
    """The Domain of one job: the named factory's, or the polygon file's."""
    return domains.NAMED[name]() if file is None else read_domain(file)
