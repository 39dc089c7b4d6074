"""Mesh files: `write` a qmesh `Mesh` with its tags and conductivity, `read` any triangle mesh
back as one, `read_anisotropy` the conductivity a file remembers (`formats`; tags in `boundary`,
the conductivity record in `conductivity`). meshio is imported only when a file is used."""

from qmesh.io.formats import (FORMATS, KEEPS_CONDUCTIVITY, KEEPS_DATA, KEEPS_FIXED, KEEPS_TAG_NAMES,
                              KEEPS_TAGS, check_writable, read, read_anisotropy, write)

__all__ = ["FORMATS", "KEEPS_CONDUCTIVITY", "KEEPS_DATA", "KEEPS_FIXED", "KEEPS_TAG_NAMES",
           "KEEPS_TAGS", "check_writable", "read", "read_anisotropy", "write"]
