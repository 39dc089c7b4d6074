"""The conductivity a mesh was made for, as plain JSON numbers that any reader can take.

A mesh is Q-adapted for one Q (or one Q per region): measuring it with another says little.
So `qmesh.io.write` stores the conductivity in the file's qmesh metadata
(`qmesh.io.metadata` says where each format keeps it) as a JSON value:

    {"Q": [[0.1, 0.0], [0.0, 10.0]]}                  a constant Q (exact: JSON keeps repr(float))
    {"s": "x**2 + 0.1*y**4"}                          a varying s given as text
    {"regions": {"1": {"Q": ...}, "2": {"s": ...}}}   one of those per region tag

`read_anisotropy` gives back an `Anisotropy`, or a {region tag: Anisotropy} mapping. A varying
s given only as Python callables (`Anisotropy.from_s`) has no such form and is not stored.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from qmesh.conductivity.anisotropy import Anisotropy, adj2
from qmesh.errors import QmeshError

PREFIX = "qmesh conductivity: "
"""What `record_of` puts before the text (the CLI's report strips it)."""


def _one(anisotropy: Anisotropy) -> dict[str, Any] | None:
    expression = getattr(anisotropy, "expression", None)
    if expression is not None:
        return {"s": " ".join(str(expression).split())}
    if anisotropy.is_constant:
        return {"Q": adj2(np.asarray(anisotropy.H, dtype=float)).tolist()}  # adj(adj Q) = Q exactly
    return None


def to_json(anisotropy: object) -> dict[str, Any] | None:
    """The JSON value for an Anisotropy or a {region tag: Anisotropy} mapping; None when it has
    no stored form (a callable s). QmeshError for anything else."""
    if isinstance(anisotropy, Anisotropy):
        return _one(anisotropy)
    if isinstance(anisotropy, Mapping):
        regions: dict[str, Any] = {}
        for tag, a in anisotropy.items():
            if isinstance(tag, bool) or not isinstance(tag, (int, np.integer)) or tag < 0:
                raise QmeshError(f"anisotropy: region tags must be integers >= 0, got {tag!r}")
            if not isinstance(a, Anisotropy):
                raise QmeshError(f"anisotropy[{tag}] must be a qmesh.Anisotropy, got {type(a).__name__}")
            value = _one(a)
            if value is None:
                return None
            regions[str(int(tag))] = value
        if not regions:
            raise QmeshError("anisotropy: the mapping region tag → Anisotropy is empty")
        return {"regions": regions}
    raise QmeshError("anisotropy must be a qmesh.Anisotropy, a mapping {region tag: Anisotropy}, or None, "
                     f"got {type(anisotropy).__name__}")


def from_json(value: Any, source: str) -> Anisotropy | dict[int, Anisotropy]:
    """The Anisotropy (or {region tag: Anisotropy}) a stored JSON value describes."""
    if isinstance(value, dict) and set(value) == {"regions"} and isinstance(value["regions"], dict):
        out: dict[int, Anisotropy] = {}
        for key, item in value["regions"].items():
            try:
                tag = int(key)
            except ValueError:
                raise QmeshError(f"{source}: the stored conductivity has region {key!r}, not an integer") from None
            out[tag] = _anisotropy(item, f"{source}, region {tag}")
        return out
    return _anisotropy(value, source)


def _anisotropy(value: Any, source: str) -> Anisotropy:
    if isinstance(value, dict) and set(value) == {"Q"}:
        Q = value["Q"]
        ok = (isinstance(Q, list) and len(Q) == 2 and all(isinstance(r, list) and len(r) == 2 for r in Q)
              and all(isinstance(c, (int, float)) and not isinstance(c, bool) for r in Q for c in r))
        if not ok or not all(math.isfinite(c) for r in Q for c in r):
            raise QmeshError(f"{source}: the stored conductivity Q must be 2×2 finite numbers, got {str(Q)[:80]}")
        try:
            return Anisotropy.constant(np.array(Q, dtype=float))
        except QmeshError as e:
            raise QmeshError(f"{source}: the stored conductivity is not valid: {e}") from e
    if isinstance(value, dict) and set(value) == {"s"} and isinstance(value["s"], str):
        from_expression = getattr(Anisotropy, "from_expression", None)
        if from_expression is None:
            raise QmeshError(f"{source} stores s(x, y) = {value['s']}, but this qmesh cannot read "
                             "expressions (Anisotropy.from_expression is missing)")
        try:
            return from_expression(value["s"])
        except QmeshError as e:
            raise QmeshError(f"{source}: the stored s(x, y) = {value['s']} is not valid: {e}") from e
    raise QmeshError(f"{source}: unreadable conductivity record {str(value)[:80]!r}")


def record_of(anisotropy: Anisotropy) -> str | None:
    """One line of text naming `anisotropy` exactly (`qmesh report` prints it), or None for a callable s."""
    value = _one(anisotropy)
    if value is None:
        return None
    if "s" in value:
        return f"{PREFIX}s(x, y) = {value['s']}"
    Q = value["Q"]
    return f"{PREFIX}Q = [[{Q[0][0]!r}, {Q[0][1]!r}], [{Q[1][0]!r}, {Q[1][1]!r}]]"
