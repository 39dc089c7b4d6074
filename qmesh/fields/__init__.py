"""A conductivity field Q(x) meshed at the N the user picks, every q_ij ≥ 0 certified on the
element means (FIELDS.md): `mesh(domain, TensorField, ...)` and `iterate(...)`."""

from qmesh.fields.mesher import iterate, mesh

__all__ = ["iterate", "mesh"]
