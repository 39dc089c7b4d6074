"""Domain files: a polygon outline with holes, from CSV or GeoJSON, for `qmesh mesh --polygon`.

- CSV (any extension but .geojson/.json): one `x,y` row per point; an optional header line
  first, recognised by its content (names such as `x,y`, not numbers); `#` starts a comment
  line; a blank line ends a ring. The first ring is the outline, the others are holes. Any
  other row that is not two numbers is an error naming its line.
- GeoJSON (`.geojson`, `.json`, RFC 7946): a Polygon (its first ring the outline, the others
  holes), a Feature whose geometry is one, or a FeatureCollection holding exactly one such
  Feature. Refused, each with its reason: MultiPolygon and other geometry types, several or
  no features, a Feature without geometry, positions that are not 2 or 3 finite numbers (a
  third coordinate, the altitude, is dropped), nesting too deep for a parser, integers of
  more digits than Python converts.

Coordinates must lie within ±1e100 (`MAX_COORDINATE`): beyond, areas and metric lengths
overflow. `rings_from_polygon` and `ring_from_positions` read a GeoJSON Polygon's rings, for any
caller that finds Polygons elsewhere (a region property, a FeatureCollection of regions).

`read_domain(path)` reads a file; `domain_from_text(content, name)` takes its content (an
upload in the viewer). In both formats, a ring's last point is dropped when it repeats the
first (GeoJSON rings are closed that way). Every defect raises one QmeshError naming the file
and, where it can, the line (CSV, JSON syntax) or the ring and point.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np

from qmesh.domain.domain import Domain
from qmesh.errors import QmeshError

GEOJSON_SUFFIXES = {".geojson", ".json"}
MAX_COORDINATE = 1e100
_HEADER_FIELD = re.compile(r"[A-Za-z_][\w .()\[\]/-]*")


def read_domain(path) -> Domain:
    """The domain a polygon file describes (a `qmesh.Domain` of the outline and its holes)."""
    path = _path(path)
    return domain_from_rings(read_rings(path), path)


def read_rings(path) -> list[np.ndarray]:
    """The rings of a polygon file, (k, 2) float arrays, outline first, closing points dropped."""
    path = _path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as e:
        raise QmeshError(f"cannot read polygon file {str(path)!r}: {e}") from e
    return _rings_from_text(text, str(path))


def domain_from_text(content, name: str) -> Domain:
    """The domain in a polygon file's content (str or UTF-8 bytes, e.g. a browser upload);
    `name`, the file's name, chooses GeoJSON or CSV by its suffix and names it in errors."""
    if not isinstance(name, str):
        raise QmeshError(f"name must be the file's name (a str), got {type(name).__name__}")
    if isinstance(content, (bytes, bytearray)):
        try:
            content = bytes(content).decode("utf-8-sig")
        except UnicodeDecodeError as e:
            raise QmeshError(f"cannot read polygon file {name!r}: {e}") from e
    if not isinstance(content, str):
        raise QmeshError(f"content must be text or bytes, got {type(content).__name__}")
    return domain_from_rings(_rings_from_text(content.removeprefix("\ufeff"), name), name)


def _rings_from_text(text: str, name: str) -> list[np.ndarray]:
    where = f"polygon file {name!r}"
    geojson = Path(name).suffix.lower() in GEOJSON_SUFFIXES
    rings = _geojson_rings(text, where) if geojson else _csv_rings(text, where)
    return [_checked_ring(r, i, where) for i, r in enumerate(rings)]


def domain_from_rings(rings: list[np.ndarray], path) -> Domain:
    """`qmesh.Domain(outline, holes)` with the default tags (1 the outline, 2, 3, … the holes)
    named "outline", "hole 1", "hole 2", …; the file is named in any geometry error."""
    names = {1: "outline", **{k + 2: f"hole {k + 1}" for k in range(len(rings) - 1)}}
    try:
        return Domain(rings[0], holes=rings[1:], names=names)
    except QmeshError as e:
        raise QmeshError(f"polygon file {str(path)!r}: {e}") from e


# --------------------------------------------------------------------------- CSV

def _csv_rings(text: str, where: str) -> list[np.ndarray]:
    rings, ring, seen_data = [], [], False
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if line.startswith("#"):
            continue
        if not line:
            if ring:
                rings.append(np.array(ring))
                ring = []
            continue
        fields = [f.strip() for f in line.split(",")]
        first, seen_data = not seen_data, True
        if first and _is_header(fields):
            continue  # only the first line with content may be a header, and only a line of names
        if len(fields) != 2:
            raise QmeshError(f"{where}, line {number}: expected two columns x,y, got {len(fields)}: {line[:80]!r}")
        ring.append(tuple(_coordinate(f, where, number, line) for f in fields))
    if ring:
        rings.append(np.array(ring))
    if not rings:
        raise QmeshError(f"{where} has no points")
    return rings


def _is_header(fields: list[str]) -> bool:
    """A header names its columns: every field a word that is not a number ("x", "y [m]")."""
    return all(_HEADER_FIELD.fullmatch(f) and not _is_number(f) for f in fields)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _coordinate(text: str, where: str, number: int, line: str) -> float:
    """A finite coordinate within ±MAX_COORDINATE, or QmeshError naming the line and quoting it."""
    try:
        value = float(text)
    except ValueError:
        raise QmeshError(f"{where} is not a CSV of x,y numbers: line {number} reads {line[:80]!r} "
                         f"({text[:40]!r} is not a number)") from None
    if not math.isfinite(value) or abs(value) > MAX_COORDINATE:
        raise QmeshError(f"{where}, line {number}: coordinates must be finite numbers within "
                         f"±{MAX_COORDINATE:g}, got {text[:40]!r}")
    return value


# --------------------------------------------------------------------------- GeoJSON

def load_json(text: str, where: str):
    """The JSON document in `text`; QmeshError naming `where` and the line for bad JSON, a
    number of more digits than Python converts, or nesting deeper than its parser goes."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as e:
        raise QmeshError(f"{where}, line {e.lineno} column {e.colno}: not valid JSON: {e.msg}") from None
    except ValueError as e:  # an integer of more digits than Python converts
        raise QmeshError(f"{where}: not valid JSON: {str(e)[:120]}") from None
    except RecursionError:
        raise QmeshError(f"{where}: not valid GeoJSON: nested too deeply") from None


def _geojson_rings(text: str, where: str) -> list[np.ndarray]:
    return rings_from_polygon(_polygon_geometry(load_json(text, where), where), where)


def rings_from_polygon(geometry: dict, where: str) -> list[np.ndarray]:
    """The rings of a GeoJSON Polygon object, (k, 2) arrays, outline first (closing points kept)."""
    coords = geometry.get("coordinates")
    if not isinstance(coords, list) or not coords:
        raise QmeshError(f"{where}: a Polygon needs 'coordinates', a non-empty list of rings")
    return [ring_from_positions(ring, i, where) for i, ring in enumerate(coords)]


def _polygon_geometry(doc, where: str) -> dict:
    """The one Polygon geometry of a GeoJSON document, or QmeshError saying what was found."""
    if not isinstance(doc, dict):
        raise QmeshError(f"{where}: a GeoJSON document must be an object, got {type(doc).__name__}")
    kind = doc.get("type")
    if kind == "FeatureCollection":
        features = doc.get("features")
        if not isinstance(features, list) or len(features) != 1:
            count = len(features) if isinstance(features, list) else "no"
            raise QmeshError(f"{where}: a FeatureCollection must hold exactly one Feature (one domain), "
                             f"it holds {count}")
        doc, kind = features[0], features[0].get("type") if isinstance(features[0], dict) else None
        if kind != "Feature":
            raise QmeshError(f"{where}: the FeatureCollection's member is a {kind!r}, not a Feature")
    if kind == "Feature":
        geometry = doc.get("geometry")
        if not isinstance(geometry, dict):
            raise QmeshError(f"{where}: the Feature has no geometry")
        doc, kind = geometry, geometry.get("type")
    if kind == "MultiPolygon":
        raise QmeshError(f"{where}: a MultiPolygon (several domains) is not supported; give one Polygon")
    if kind != "Polygon":
        raise QmeshError(f"{where}: expected a Polygon, a Feature holding one, or a FeatureCollection "
                         f"of one such Feature; got type {kind!r}")
    return doc


def ring_from_positions(ring, index: int, where: str) -> np.ndarray:
    """One GeoJSON ring (a list of [x, y] or [x, y, z] positions) as a (k, 2) array; `index`
    names it in errors (0 the outline, k hole k)."""
    name = _ring_name(index)
    if not isinstance(ring, list):
        raise QmeshError(f"{where}: {name} must be a list of positions, got {type(ring).__name__}")
    out = np.empty((len(ring), 2))
    for k, position in enumerate(ring):
        ok = (isinstance(position, list) and len(position) in (2, 3)
              and all(isinstance(c, (int, float)) and not isinstance(c, bool)
                      and abs(c) <= MAX_COORDINATE for c in position))  # False for NaN, ±inf; exact for big ints
        if not ok:
            raise QmeshError(f"{where}: {name}, point {k + 1}: a position must be 2 or 3 finite numbers "
                             f"within ±{MAX_COORDINATE:g}, got {_short(position)}")
        out[k] = position[:2]
    return out


def _short(value) -> str:
    """A JSON value quoted in an error: at most 60 characters, whatever its size or depth."""
    try:
        return json.dumps(value)[:60]
    except (ValueError, RecursionError):
        return f"a {type(value).__name__}"


# --------------------------------------------------------------------------- rings

def _ring_name(index: int) -> str:
    return "ring 1 (the outline)" if index == 0 else f"ring {index + 1} (hole {index})"


def _checked_ring(P: np.ndarray, index: int, where: str) -> np.ndarray:
    if len(P) > 1 and np.array_equal(P[0], P[-1]):
        P = P[:-1]  # a closing point
    if len(P) < 3:
        raise QmeshError(f"{where}: {_ring_name(index)} has {len(P)} distinct points; a ring needs at least 3 points")
    return P


def _path(path) -> Path:
    if isinstance(path, bytes):
        path = path.decode()
    if not isinstance(path, (str, Path)) and not hasattr(path, "__fspath__"):
        raise QmeshError(f"path must be a file name (str or os.PathLike), got {type(path).__name__}")
    return Path(path)
