"""Heterogeneous media: a conductivity per region, q_ij ≥ 0 on interior, interface and boundary
edges alike (MEDIA.md). `mesh(domain, {tag: Anisotropy}, ...)` and `iterate(...)`."""

from qmesh.media.mesher import iterate, mesh

__all__ = ["iterate", "mesh"]
