"""The `regions` argument of `qmesh.Domain`: each region checked as a domain of its own, then
all of them cut against Ω (partition.py), so a bad region is refused when the domain is made.
"""

from __future__ import annotations

import numpy as np

from qmesh.errors import QmeshError
from qmesh.media.partition import Ring, partition

MAX_REGIONS = 1_000_000


def as_region(obj, k: int):
    """Region k as a `Domain` (its outline and holes), or QmeshError naming it."""
    from qmesh.domain.domain import Domain
    if isinstance(obj, Domain):
        if obj.regions:
            raise QmeshError(f"region {k} has regions of its own; give them to the outer domain")
        return obj
    try:
        return Domain(obj)
    except QmeshError as e:
        raise QmeshError(f"region {k}: {e}".replace("the outline", "its outline")) from None


def _names(region_names, n: int) -> dict[int, str]:
    if region_names is None:
        return {}
    if isinstance(region_names, dict):
        out = {}
        for k, v in region_names.items():
            if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not isinstance(v, str):
                raise QmeshError(f"region_names must map integer tags to strings, got {k!r}: {v!r}")
            if not 0 <= int(k) <= n:
                raise QmeshError(f"region_names names region {k}; the tags are 0 to {n}")
            out[int(k)] = v
        return out
    if isinstance(region_names, str):
        raise QmeshError("region_names must be a dict tag → name or one name per region, got a string")
    names = list(region_names)
    if len(names) != n:
        raise QmeshError(f"region_names must have one entry per region ({n}), got {len(names)}")
    if not all(isinstance(v, str) for v in names):
        raise QmeshError("region_names must be strings")
    return {k + 1: v for k, v in enumerate(names)}


def attach(domain, regions, region_names, ring_tags) -> None:
    """Check `regions` against `domain` and store them, their names and the partition on it."""
    if isinstance(regions, (str, bytes, np.ndarray)):
        raise QmeshError("regions must be a list of polygons (one entry per region), "
                         f"got {type(regions).__name__}")
    try:
        regions = list(regions)
    except TypeError:
        raise QmeshError(f"regions must be a list of polygons, got {type(regions).__name__}") from None
    if len(regions) > MAX_REGIONS:
        raise QmeshError(f"{len(regions)} regions; the limit is {MAX_REGIONS}")
    regs = tuple(as_region(r, k + 1) for k, r in enumerate(regions))
    rings = [Ring(np.asarray(R), 0, "the outline" if j == 0 else f"hole {j}")
             for j, R in enumerate(domain.rings)]
    # Ω's rings keep the user's segment order for their tags: domain.segment_tags follows rings
    tags = [domain.segment_tags[o:o + len(R)] for o, R in
            zip(np.cumsum([0] + [len(R) for R in domain.rings]), domain.rings)]
    for k, reg in enumerate(regs, start=1):
        for j, R in enumerate(reg.rings):
            rings.append(Ring(np.asarray(R), k, f"region {k}" if j == 0 else f"region {k} hole {j}"))
    domain._regions = regs
    domain._region_names = _names(region_names, len(regs))
    domain._partition = partition(rings, tags, domain.diameter)
