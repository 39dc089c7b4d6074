"""The face meshes glued into one `qmesh.Mesh` with `region_tags`. Interface vertices are the same
floating-point numbers on both sides (an input point of a face mesh comes back bit-exactly,
`Normalisation.to_user`), so they merge by exact coordinates; a KD-tree then checks that no two
distinct vertices of one face are closer than round-off, which would mean a crack in the mesh.
Two faces can each compute a point of their interface on their own (each splits beside the
same sharp corner) and land a few ulps apart: the hand-over finds the other's point already
there within round-off (`insert_shared`), so both keep their own; such pairs, from different
faces, are one vertex (the first in coordinate order)."""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from qmesh.errors import QmeshError
from qmesh.mesher.conform import marked
from qmesh.triangle_mesh import Mesh


def stitch(part, face_meshes: dict, domain) -> Mesh:
    """One mesh from the face meshes {face: Mesh}."""
    meshes, face_regions = list(face_meshes.values()), [part.faces[i].region for i in face_meshes]
    offs = np.cumsum([0] + [m.n_vertices for m in meshes])
    P = np.concatenate([m.points for m in meshes])
    o = np.lexsort((P[:, 1], P[:, 0]))          # np.unique(P, axis=0), without its row records
    new = np.ones(len(P), bool)
    new[1:] = (P[o[1:]] != P[o[:-1]]).any(axis=1)
    U, vid = P[o[new]], np.empty(len(P), np.int64)
    vid[o] = np.cumsum(new) - 1
    pairs = cKDTree(U).query_pairs(1e-12 * domain.diameter, output_type="ndarray")
    if len(pairs):
        U, vid = _merged(U, vid, pairs, np.repeat(np.arange(len(meshes)), np.diff(offs)))
    T = np.concatenate([vid[m.triangles + o] for m, o in zip(meshes, offs)])
    regions = np.repeat(face_regions, [m.n_triangles for m in meshes])
    # fixed: the input points of the user's domain and regions (the partition's vertices)
    fixed = marked(U, part.points)
    # boundary edges: the face meshes' edges on ∂Ω, with the user's tags
    e = np.concatenate([m.boundary_tags for m in meshes]) - 1
    be = np.concatenate([vid[m.boundary_edges + off] for m, off in zip(meshes, offs)])
    on = (part.edge_tag[e] > 0) & (part.edge_faces[e] < 0).any(axis=1)
    return Mesh(U, T, fixed, be[on], part.edge_tag[e[on]], domain.tag_names, regions, domain.region_names)


def _merged(U, vid, pairs, face_of):
    """U and vid with each group of vertices a round-off apart made one (the lowest index: the
    first in coordinate order), when no face holds two of them; QmeshError when one face does
    (a crack no merge mends)."""
    n, faces = len(U), int(face_of.max()) + 1
    holds = coo_matrix((np.ones(len(vid), bool), (vid, face_of)), shape=(n, faces)).tocsr()
    shared = holds[pairs[:, 0]].multiply(holds[pairs[:, 1]]).getnnz(axis=1)
    if shared.any():
        a, b = pairs[np.flatnonzero(shared)[0]]
        raise QmeshError(f"two face meshes put vertices {U[a].tolist()} and {U[b].tolist()} a "
                         "round-off apart: the interface does not match")
    near = coo_matrix((np.ones(len(pairs), bool), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, group = connected_components(near, directed=False)
    first = np.full(group.max() + 1, n)
    np.minimum.at(first, group, np.arange(n))
    rep = first[group]
    keep = rep == np.arange(n)
    return U[keep], (np.cumsum(keep) - 1)[rep[vid]]
