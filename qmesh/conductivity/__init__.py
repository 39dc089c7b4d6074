"""The conductivity Q = adj ∇²s and its potential s: constant, principal, user callables, or the
text of s(x, y) parsed safely (`expression`)."""

from qmesh.conductivity.anisotropy import Anisotropy

__all__ = ["Anisotropy"]
