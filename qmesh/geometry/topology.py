"""Half-edge adjacency of a triangle array, and the local edits the mesher makes to it.

Half-edge `h = 3 t + e` runs from `T[t, e]` to `T[t, (e + 1) % 3]`; `twin[h]` is the opposite
half-edge in the neighbouring triangle, or -1 on the boundary. Edge flips, splits, removals and
relocations are applied to whole batches at once: each batch says which half-edges moved to
which slots, and only those entries of the twin array (and their twins') are rewritten, with no
sort. This is what lets the mesher keep its connectivity between iterations instead of
re-triangulating from scratch.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

NXT = np.array([1, 2, 0])
PRV = np.array([2, 0, 1])


def find_half_edges(T: np.ndarray, n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Half-edge id of a→b in T (n vertices), or -1 where there is none. Only the half-edges
    that start at a vertex among a are sorted (a few thousand boundary ones in a mesh of 1e6)."""
    start = np.zeros(n, bool)
    start[a] = True
    hs = np.flatnonzero(start[T.ravel()])
    e = hs % 3
    key = T.ravel()[hs].astype(np.int64) * n + T.ravel()[hs - e + NXT[e]]
    order = np.argsort(key, kind="stable")
    want = a.astype(np.int64) * n + b
    if not len(key):
        return np.full(len(want), -1, np.int64)
    pos = np.minimum(np.searchsorted(key[order], want), len(key) - 1)
    hit = key[order][pos] == want
    return np.where(hit, hs[order[pos]], -1)


def left_of(T: np.ndarray, twin: np.ndarray, h_in: np.ndarray) -> np.ndarray:
    """Mask of the triangles on the left of the cut half-edges h_in: connected components across
    the other edges, labelled by the side of a cut edge they touch. ValueError where a component
    touches both sides."""
    M = len(T)
    tw = twin[h_in]
    if not np.any(tw >= 0) and np.count_nonzero(twin < 0) == len(np.unique(h_in)):
        # the cut is the whole boundary (a convex domain's hull): every component has a
        # boundary edge (no finite planar triangulation is closed), so every triangle is left
        return np.ones(M, bool)
    cut = np.zeros(3 * M, bool)
    cut[h_in] = True
    cut[tw[tw >= 0]] = True
    h = np.flatnonzero((twin >= 0) & ~cut)
    index = np.int32 if M < 2**31 - 1 else np.int64          # a quarter of the bytes at 1e6 vertices
    g = sp.coo_matrix((np.ones(len(h), np.int8), ((h // 3).astype(index), (twin[h] // 3).astype(index))),
                      shape=(M, M))
    del h
    _, comp = connected_components(g, directed=False)
    label = np.zeros(comp.max() + 1 if M else 0, np.int8)
    np.maximum.at(label, comp[h_in // 3], 1)
    if np.any(label[comp[tw[tw >= 0] // 3]] == 1):
        raise ValueError("a region lies on both sides of the cut")
    return label[comp] == 1


def sorted_unique(x: np.ndarray) -> np.ndarray:
    """np.unique of an integer array, by a sort: NumPy 2.4's np.unique hashes integers first,
    which is many times slower than a sort on millions of distinct keys."""
    x = np.sort(x)
    return x[np.r_[True, x[1:] != x[:-1]]] if len(x) else x


def touching(T: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Mask of the triangles that have a corner in the vertex mask: mask[T].any(axis=1), from
    three column gathers (NumPy's reduction over the short axis is much slower, and this runs
    over the whole mesh several times a stage)."""
    return mask[T[:, 0]] | mask[T[:, 1]] | mask[T[:, 2]]


def edge_keys(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    """One int64 key per undirected edge a–b of a mesh of n vertices: min·n + max."""
    a, b = np.asarray(a, np.int64), np.asarray(b, np.int64)
    key = np.minimum(a, b)
    key *= np.int64(max(n, 1))
    key += np.maximum(a, b)
    return key


def twins(T: np.ndarray) -> np.ndarray:
    """Twin half-edge of every half-edge (-1 on the boundary); one sort, used once per mesh.

    Raises ValueError if an edge is shared by more than two triangles or a neighbour is
    inconsistently oriented.
    """
    M = len(T)
    a = T.ravel()
    n = int(T.max()) + 1 if M else 0
    key = edge_keys(a, T[:, NXT].ravel(), n)
    k, order = _sorted_with_order(key)
    del key                                 # (each of these is 48 MB at 1e6 vertices)
    same = k[1:] == k[:-1]
    del k
    if np.any(same[1:] & same[:-1]):
        raise ValueError("an edge is shared by more than two triangles")
    twin = np.full(3 * M, -1, dtype=np.int64)
    i = np.flatnonzero(same)
    h1, h2 = order[i], order[i + 1]
    if np.any(a[h1] == a[h2]):
        raise ValueError("two neighbouring triangles have opposite orientations")
    twin[h1] = h2
    twin[h2] = h1
    return twin


def _sorted_with_order(key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """np.sort(key) and np.argsort(key, kind="stable"), the same arrays, by one sort of the
    keys packed with their positions (key · len + position, unique, so any sort gives the stable
    order) where that fits in 63 bits: several times faster than the stable argsort of a
    triangulation in Qhull's order, and no random gather for the sorted keys."""
    m = len(key)
    if m and int(key.min()) >= 0 and int(key.max()) < (2**63 - 1) // m - 1:
        packed = key * np.int64(m)
        packed += np.arange(m, dtype=np.int64)
        packed.sort()
        k = packed // m
        packed -= k * m
        return k, packed
    order = np.argsort(key, kind="stable")
    return key[order], order


def _moved(twin: np.ndarray, src: np.ndarray, dst: np.ndarray, size: int,
           copy: bool = True) -> np.ndarray:
    """Twin array after half-edges `src` (distinct) moved to slots `dst`; cost O(len(src)) beyond
    the copy (none with copy=False where the size stays: `twin` itself is rewritten).

    Slots vacated and not refilled must be set by the caller (they hold stale values).
    """
    if copy or size != len(twin):
        k = min(size, len(twin))
        new = np.empty(size, dtype=np.int64)
        new[:k] = twin[:k]
        new[k:] = -1
    else:
        new = twin
    tw = twin[src]
    # where a twin moved too, its new slot: src looked up by a sort of the k moved half-edges
    order = np.argsort(src)
    pos = np.minimum(np.searchsorted(src[order], tw), max(len(src) - 1, 0))
    tw_new = tw.copy()
    if len(src):
        hit = (tw >= 0) & (src[order[pos]] == tw)
        tw_new[hit] = dst[order[pos[hit]]]
    new[dst] = tw_new
    ok = tw_new >= 0
    new[tw_new[ok]] = dst[ok]
    return new


def flip(T: np.ndarray, twin: np.ndarray, h: np.ndarray,
         copy: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Flip the edges of half-edges `h` (no two in the same triangle); returns new (T, twin),
    or T and twin themselves rewritten with copy=False (for arrays nobody else holds).

    Triangles t1 = (u, v, a) ∋ h and t2 = (v, u, b) ∋ twin[h] become (u, b, a) and (b, v, a);
    both keep their row numbers.
    """
    g = twin[h]
    t1, e1 = np.divmod(h, 3)
    t2, e2 = np.divmod(g, 3)
    u = T[t1, e1]
    v = T[t1, NXT[e1]]
    a = T[t1, PRV[e1]]
    b = T[t2, PRV[e2]]
    src = np.concatenate([3 * t1 + NXT[e1], 3 * t1 + PRV[e1], 3 * t2 + NXT[e2], 3 * t2 + PRV[e2]])
    dst = np.concatenate([3 * t2 + 1, 3 * t1 + 2, 3 * t1, 3 * t2])   # v→a, a→u, u→b, b→v
    if copy:
        T = T.copy()
    T[t1] = np.column_stack([u, b, a])
    T[t2] = np.column_stack([b, v, a])
    new = _moved(twin, src, dst, 3 * len(T), copy=copy)
    new[3 * t1 + 1] = 3 * t2 + 2              # b→a ↔ a→b
    new[3 * t2 + 2] = 3 * t1 + 1
    return T, new


def grow(T: np.ndarray, twin: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Copies of T and twin with room for k more triangles (rows of -1), for splits that write
    their new triangles into given `rows`: one copy for a stage's splits instead of one per
    kind of split (each copied T and twin, 96 MB at 1e6 vertices)."""
    M = len(T)
    T2 = np.empty((M + k, 3), np.int64)
    T2[:M] = T
    T2[M:] = -1
    tw = np.empty(3 * (M + k), np.int64)
    tw[:3 * M] = twin
    tw[3 * M:] = -1
    return T2, tw


def _placed(T: np.ndarray, rows: np.ndarray | None, k: int, *blocks: np.ndarray):
    """T with the (k, 3) `blocks` as new triangles, and their row numbers: appended to a copy of
    T, or, with `rows` (len(blocks)·k free rows of T, from `grow`), written into T itself."""
    if rows is None:
        rows = len(T) + np.arange(len(blocks) * k)
        return np.concatenate([T, *blocks]), rows
    for j, block in enumerate(blocks):
        T[rows[j * k:(j + 1) * k]] = block
    return T, rows


def split_triangles(T: np.ndarray, twin: np.ndarray, t: np.ndarray, p: np.ndarray,
                    rows: np.ndarray | None = None):
    """Split triangles `t` = (a, b, c) at new vertices `p` into (a,b,p), (b,c,p), (c,a,p).

    The new triangles are appended to copies of T and twin, or, with `rows` (2 len(t) free rows
    that `grow` made), written into T and twin themselves."""
    k = len(t)
    a, b, c = T[t, 0], T[t, 1], T[t, 2]
    T, new_rows = _placed(T, rows, k, np.column_stack([b, c, p]), np.column_stack([c, a, p]))
    t1, t2 = new_rows[:k], new_rows[k:]
    T[t] = np.column_stack([a, b, p])
    new = _moved(twin, np.concatenate([3 * t + 1, 3 * t + 2]),       # b→c, c→a
                 np.concatenate([3 * t1, 3 * t2]), 3 * len(T), copy=rows is None)
    for x, y in ((3 * t + 1, 3 * t1 + 2), (3 * t + 2, 3 * t2 + 1), (3 * t1 + 1, 3 * t2 + 2)):
        new[x] = y
        new[y] = x
    return T, new


def split_boundary_edges(T: np.ndarray, twin: np.ndarray, h: np.ndarray, p: np.ndarray,
                         rows: np.ndarray | None = None):
    """Split boundary half-edges `h` (u→v, at most one per triangle) at new vertices `p`.

    The triangle (u, v, w) becomes (u, p, w) and (p, v, w); the new ones are appended, or
    written into `rows` (as `split_triangles`).
    """
    k = len(h)
    t, e = np.divmod(h, 3)
    u, v, w = T[t, e], T[t, NXT[e]], T[t, PRV[e]]
    T, t1 = _placed(T, rows, k, np.column_stack([p, v, w]))
    T[t] = np.column_stack([u, p, w])
    new = _moved(twin, np.concatenate([3 * t + NXT[e], 3 * t + PRV[e]]),   # v→w, w→u
                 np.concatenate([3 * t1 + 1, 3 * t + 2]), 3 * len(T), copy=rows is None)
    new[3 * t] = -1                           # u→p is on the boundary
    new[3 * t + 1] = 3 * t1 + 2               # p→w ↔ w→p
    new[3 * t1 + 2] = 3 * t + 1
    return T, new


def remove_triangles(T: np.ndarray, twin: np.ndarray, t: np.ndarray):
    """Delete triangles `t`; their neighbours' shared half-edges become boundary half-edges.

    The last rows fill the holes, so only O(len(t)) half-edges move.
    """
    M, k = len(T), len(t)
    if k == 0:
        return T, twin
    gone = np.zeros(M, bool)
    gone[t] = True
    hr = (3 * t[:, None] + np.arange(3)).ravel()
    tw = twin[hr]
    twin = twin.copy()
    twin[tw[tw >= 0]] = -1
    tail = np.arange(M - k, M)
    tail = tail[~gone[tail]]
    holes = np.sort(t[t < M - k])
    T = T.copy()
    T[holes] = T[tail]
    src = (3 * tail[:, None] + np.arange(3)).ravel()
    dst = (3 * holes[:, None] + np.arange(3)).ravel()
    return T[:M - k], _moved(twin, src, dst, 3 * (M - k))


def split_edges(T: np.ndarray, twin: np.ndarray, h: np.ndarray, p: np.ndarray,
                rows: np.ndarray | None = None):
    """Split interior edges (half-edges `h`, no two touching one triangle) at new vertices `p`.

    t1 = (u, v, a) ∋ h and t2 = (v, u, b) ∋ twin[h] become (u, p, a), (p, v, a), (v, p, b)
    and (p, u, b); the first and third keep the rows of t1 and t2, the others are appended or
    written into `rows` (as `split_triangles`).
    """
    k = len(h)
    g = twin[h]
    t1, e1 = np.divmod(h, 3)
    t2, e2 = np.divmod(g, 3)
    u, v, a = T[t1, e1], T[t1, NXT[e1]], T[t1, PRV[e1]]
    b = T[t2, PRV[e2]]
    T, new_rows = _placed(T, rows, k, np.column_stack([p, v, a]), np.column_stack([p, u, b]))
    n1, n2 = new_rows[:k], new_rows[k:]
    T[t1] = np.column_stack([u, p, a])
    T[t2] = np.column_stack([v, p, b])
    src = np.concatenate([3 * t1 + NXT[e1], 3 * t1 + PRV[e1], 3 * t2 + NXT[e2], 3 * t2 + PRV[e2]])
    dst = np.concatenate([3 * n1 + 1, 3 * t1 + 2, 3 * n2 + 1, 3 * t2 + 2])  # v→a a→u u→b b→v
    new = _moved(twin, src, dst, 3 * len(T), copy=rows is None)
    for x, y in ((3 * t1, 3 * n2), (3 * t1 + 1, 3 * n1 + 2), (3 * n1, 3 * t2),
                 (3 * t2 + 1, 3 * n2 + 2)):
        new[x] = y
        new[y] = x
    return T, new


def relocate_vertices(T: np.ndarray, twin: np.ndarray, v: np.ndarray, star: np.ndarray,
                      target: np.ndarray):
    """Move degree-3 vertices `v` into triangles `target`, keeping the triangle count.

    `star` (k, 3) holds the three triangles around each v (stars and targets all disjoint).
    The star is merged into one triangle (a, b, c) in the first star row; the target triangle
    (x, y, z) becomes (x, y, v), and the two freed rows take (y, z, v) and (z, x, v).
    """
    k = len(v)
    if k == 0:
        return T, twin
    rows = star.ravel()
    local = np.argmax(T[rows] == np.repeat(v, 3)[:, None], axis=1)     # v's corner in each row
    first = T[rows, NXT[local]].reshape(k, 3)                          # a, b, c (unordered)
    second = T[rows, PRV[local]].reshape(k, 3)
    outer = (3 * rows + NXT[local]).reshape(k, 3)                      # outer half-edges
    # chain the three outer edges counter-clockwise: next one starts where this one ends
    order = np.zeros((k, 3), np.int64)
    for j in (1, 2):
        prev_end = second[np.arange(k), order[:, j - 1]]
        order[:, j] = np.argmax(first == prev_end[:, None], axis=1)
    pick = lambda a: np.take_along_axis(a, order, axis=1)             # noqa: E731
    first, outer, srow = pick(first), pick(outer), pick(star)
    r1, r2, r3 = srow[:, 0], srow[:, 1], srow[:, 2]
    x, y, z = T[target, 0], T[target, 1], T[target, 2]
    T = T.copy()
    T[r1] = first
    T[target] = np.column_stack([x, y, v])
    T[r2] = np.column_stack([y, z, v])
    T[r3] = np.column_stack([z, x, v])
    src = np.concatenate([outer[:, 0], outer[:, 1], outer[:, 2], 3 * target + 1, 3 * target + 2])
    dst = np.concatenate([3 * r1, 3 * r1 + 1, 3 * r1 + 2, 3 * r2, 3 * r3])
    new = _moved(twin, src, dst, len(twin))
    for p, q in ((3 * target + 1, 3 * r2 + 2), (3 * target + 2, 3 * r3 + 1), (3 * r2 + 1, 3 * r3 + 2)):
        new[p] = q
        new[q] = p
    return T, new
