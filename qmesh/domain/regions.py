"""The `regions` argument of `qmesh.Domain`: each region checked as a domain of its own, then
all of them cut against Ω (partition.py), so a bad region is refused when the domain is made.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from qmesh import checks
from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.errors import QmeshError
from qmesh.domain.partition import Ring, partition

MAX_REGIONS = 1_000_000


def as_region(obj, k: int, Domain):
    """Region k as a `Domain` (its outline and holes), or QmeshError naming it. `Domain` is the
    class regions are made of (passed in: domain.py imports this module)."""
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
        return checks.tag_names(region_names, "region_names", range(n + 1))
    if isinstance(region_names, str):
        raise QmeshError("region_names must be a dict tag → name or one name per region, got a string")
    names = list(region_names)
    if len(names) != n:
        raise QmeshError(f"region_names must have one entry per region ({n}), got {len(names)}")
    if not all(isinstance(v, str) for v in names):
        raise QmeshError("region_names must be strings")
    return {k + 1: v for k, v in enumerate(names)}


def attach(domain, regions, region_names, ring_tags, Domain) -> None:
    """Check `regions` against `domain` and store them, their names and the partition on it
    (`Domain` the class regions are made of: domain.py passes it, as it imports this module)."""
    regions = checks.polygon_list(regions, "regions")
    if len(regions) > MAX_REGIONS:
        raise QmeshError(f"{len(regions)} regions; the limit is {MAX_REGIONS}")
    # plain rings checked together; any that fails (or a large one) checked one by one, to name it
    plain = [k for k, r in enumerate(regions) if not isinstance(r, Domain)]
    many = Domain._many([regions[k] for k in plain]) if len(plain) > 1 else None
    made = dict(zip(plain, many)) if many is not None else {}
    regs = tuple(made[k] if k in made else as_region(r, k + 1, Domain) for k, r in enumerate(regions))
    domain._regions = regs
    domain._region_names = _names(region_names, len(regs))
    domain._partition = faces_of(domain, regs)


def faces_of(domain, regions=()):
    """The planar partition of Ω's rings and the regions' rings (partition.py): one face per
    connected piece of a region, or of Ω when there are no regions."""
    rings = [Ring(np.asarray(R), 0, "the outline" if j == 0 else f"hole {j}")
             for j, R in enumerate(domain.rings)]
    # Ω's rings keep the user's segment order for their tags: domain.segment_tags follows rings
    tags = [domain.segment_tags[o:o + len(R)] for o, R in
            zip(np.cumsum([0] + [len(R) for R in domain.rings]), domain.rings)]
    for k, reg in enumerate(regions, start=1):
        for j, R in enumerate(reg.rings):
            rings.append(Ring(np.asarray(R), k, f"region {k}" if j == 0 else f"region {k} hole {j}"))
    return partition(rings, tags, domain.diameter)


def conductivity_of_regions(domain, conductivity) -> dict:
    """{region tag: Anisotropy} for every region that has a face; QmeshError for a missing
    region, an unknown tag or a value that is not an Anisotropy."""
    present = sorted({f.region for f in domain.partition.faces})
    if isinstance(conductivity, Anisotropy):
        return {r: conductivity for r in present}
    if not isinstance(conductivity, Mapping):
        raise QmeshError("the conductivity must be a qmesh.Anisotropy or a mapping {region tag: "
                         f"Anisotropy}}, got {type(conductivity).__name__}")
    out = {}
    for k, v in conductivity.items():
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
            raise QmeshError(f"conductivity keys must be region tags (integers), got {k!r}")
        if not isinstance(v, Anisotropy):
            raise QmeshError(f"the conductivity of region {k} must be a qmesh.Anisotropy, "
                             f"got {type(v).__name__}")
        if not 0 <= int(k) <= len(domain.regions):
            raise QmeshError(f"the conductivity names region {k}, but the domain has regions "
                             f"0 to {len(domain.regions)}")
        out[int(k)] = v
    missing = [r for r in present if r not in out]
    if missing:
        names = domain.region_names
        what = ", ".join(f"{r}" + (f" ({names[r]})" if r in names else "") for r in missing)
        raise QmeshError(f"no conductivity for region {what}: give one Anisotropy per region "
                         f"(tags {present})")
    return out
