"""Region files: a domain and its regions, with a conductivity per region, from GeoJSON.

A FeatureCollection of Polygon Features, each with a `region` property:

- `"region": 0` — the domain Ω (its first ring the outline, the others holes); exactly one;
- any other value (a name, or a number) — a region; region tags follow the order of the
  features (1, 2, …), the value is the region's name; its Polygon's other rings are the
  region's own holes.

Any feature may carry its conductivity as `"Q": [Q11, Q12, Q22]`, `"principal": [K1, K2,
ANGLE]` (degrees) or `"s": "text of s(x, y)"` (parsed safely, GEOMETRY.md §4). Rings are read
by `qmesh.domain.polygon_file`'s GeoJSON ring reader (positions, closing points).
"""

from __future__ import annotations

import json
import math

from qmesh.domain.polygon_file import _checked_ring, _path, load_json, rings_from_polygon
from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.domain.domain import Domain
from qmesh.errors import QmeshError

MAX_BYTES = 200_000_000


def read_regions(path):
    """(Domain with regions, {region tag: Anisotropy} for the features that carry one)."""
    p = _path(path)
    try:
        if p.stat().st_size > MAX_BYTES:
            raise QmeshError(f"{p}: larger than {MAX_BYTES // 1_000_000} MB")
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise QmeshError(f"{p}: not UTF-8 text") from None
    return regions_from_text(text, str(p))


def regions_from_text(text: str, where: str):
    doc = load_json(text, where)
    if not isinstance(doc, dict) or doc.get("type") != "FeatureCollection" \
            or not isinstance(doc.get("features"), list):
        raise QmeshError(f"{where}: a region file is a GeoJSON FeatureCollection of Polygon "
                         "Features with a 'region' property")
    outer, regions, names, cond = None, [], {}, {}
    for k, feature in enumerate(doc["features"], start=1):
        what = f"{where}: feature {k}"
        if not isinstance(feature, dict) or feature.get("type") != "Feature":
            raise QmeshError(f"{what} is not a Feature")
        props = feature.get("properties") or {}
        if not isinstance(props, dict) or "region" not in props:
            raise QmeshError(f"{what} has no 'region' property (0 for the domain, a name for a region)")
        geometry = feature.get("geometry")
        if not isinstance(geometry, dict) or geometry.get("type") != "Polygon":
            raise QmeshError(f"{what}: its geometry must be a Polygon")
        rings = [_checked_ring(r, i, what) for i, r in enumerate(rings_from_polygon(geometry, what))]
        region = props["region"]
        if region == 0 and not isinstance(region, bool):
            if outer is not None:
                raise QmeshError(f"{what}: a second feature with region 0 (the domain); give one")
            outer, tag = rings, 0
        else:
            regions.append(rings[0] if len(rings) == 1 else Domain(rings[0], rings[1:]))
            tag = len(regions)
            names[tag] = str(region)
        A = _conductivity(props, what)
        if A is not None:
            cond[tag] = A
    if outer is None:
        raise QmeshError(f"{where}: no feature with region 0 (the domain)")
    return Domain(outer[0], outer[1:], regions=regions, region_names=names), cond


def _conductivity(props: dict, what: str):
    given = [k for k in ("Q", "principal", "s") if k in props]
    if len(given) > 1:
        raise QmeshError(f"{what}: give one of Q, principal, s; got {', '.join(given)}")
    if not given:
        return None
    v = props[given[0]]
    if given[0] == "s":
        if not isinstance(v, str):
            raise QmeshError(f"{what}: 's' must be the text of s(x, y)")
        return Anisotropy.from_expression(v)
    ok = isinstance(v, list) and len(v) == 3 and all(
        isinstance(c, (int, float)) and not isinstance(c, bool) for c in v)
    if not ok:
        raise QmeshError(f"{what}: '{given[0]}' must be three numbers, got {json.dumps(v)[:60]}")
    if given[0] == "Q":
        return Anisotropy.constant([[v[0], v[1]], [v[1], v[2]]])
    return Anisotropy.principal(*v)


def conductivity_per_region(domain, from_file: dict, region_q, region_principal, default) -> dict:
    """{tag: Anisotropy} for every region of `domain`: `--region-Q TAG Q11 Q12 Q22` and
    `--region-principal TAG K1 K2 ANGLE` (lists of 4 numbers) over the file's, over `default`."""
    cond = {r: default for r in range(len(domain.regions) + 1)}
    cond.update(from_file)
    for flag, given in (("--region-Q", region_q or []), ("--region-principal", region_principal or [])):
        for tag, a, b, c in given:
            if not (math.isfinite(tag) and tag == int(tag) and 0 <= int(tag) <= len(domain.regions)):
                raise QmeshError(f"{flag} {tag:g}: the region tags are 0 to {len(domain.regions)}")
            try:
                cond[int(tag)] = (Anisotropy.constant([[a, b], [b, c]]) if flag == "--region-Q"
                                  else Anisotropy.principal(a, b, c))
            except QmeshError as e:
                raise QmeshError(f"{flag} {int(tag)}: {e}") from None
    return cond
