"""A study's conductivity entries: `{principal = [k1, k2, angle]}`, `{Q = [[..], [..]]}` or
`{s = "text"}`, each checked once and kept as one line of text (the table's `conductivity`
column, e.g. `principal=[1, 100, 30]`) from which a worker builds its `qmesh.Anisotropy`.

Text travels rather than the Anisotropy itself: an `s` typed as text compiles to closures that
do not pickle, and the text is also what the table shows and what resuming compares.
"""

from __future__ import annotations

import json
import math

from qmesh import Anisotropy
from qmesh.errors import QmeshError

KINDS = ("principal", "Q", "s")


def label_of(entry, where: str) -> str:
    """The table's text for one study entry; QmeshError naming `where` for anything else."""
    if not isinstance(entry, dict) or len(entry) != 1 or next(iter(entry)) not in KINDS:
        raise QmeshError(f"{where} must be one of {{principal = [k1, k2, angle]}}, "
                         f"{{Q = [[q11, q12], [q21, q22]]}} or {{s = \"text\"}}, got {_show(entry)}")
    kind, value = next(iter(entry.items()))
    if kind == "s":
        if not isinstance(value, str) or not value.strip():
            raise QmeshError(f"{where}: s must be a non-empty text such as \"exp(x) + y**2\", got {_show(value)}")
        label = f"s={value.strip()}"
    elif kind == "principal":
        if not (isinstance(value, list) and len(value) == 3 and all(_number(v) for v in value)):
            raise QmeshError(f"{where}: principal must be three numbers [k1, k2, angle in degrees], "
                             f"got {_show(value)}")
        label = f"principal={json.dumps(value)}"
    else:
        if not (isinstance(value, list) and len(value) == 2 and all(
                isinstance(r, list) and len(r) == 2 and all(_number(v) for v in r) for r in value)):
            raise QmeshError(f"{where}: Q must be a 2×2 matrix of numbers [[q11, q12], [q21, q22]], "
                             f"got {_show(value)}")
        label = f"Q={json.dumps(value)}"
    try:
        anisotropy_of(label)
    except QmeshError as e:
        raise QmeshError(f"{where}: {e}") from e
    return label


def anisotropy_of(label: str) -> Anisotropy:
    """The Anisotropy a `label_of` text stands for (refusals are qmesh's own QmeshErrors)."""
    kind, _, value = label.partition("=")
    if kind == "s":
        return Anisotropy.from_expression(value)
    if kind == "principal":
        return Anisotropy.principal(*json.loads(value))
    if kind == "Q":
        return Anisotropy.constant(json.loads(value))
    raise QmeshError(f"not a conductivity of a study: {label!r}")


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _show(value) -> str:
    text = json.dumps(value, default=repr)
    return text if len(text) <= 80 else text[:77] + "..."
