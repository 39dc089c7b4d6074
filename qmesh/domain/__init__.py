"""Where to mesh: an outline with holes and tagged segments (`domain`), the named shapes
(`named`, also `qmesh.domains`) and polygon files (`polygon_file`)."""

from qmesh.domain.domain import Disk, Domain, Polygon, as_domain

__all__ = ["Disk", "Domain", "Polygon", "as_domain"]
