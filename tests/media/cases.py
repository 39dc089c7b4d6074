"""Random multi-region domains and the checks every mesh of one must pass (MEDIA.md §4)."""

import numpy as np
import scipy.sparse.linalg as spla
from hypothesis import strategies as st

import qmesh
from qmesh import measure
from qmesh.geometry import rings
from qmesh.mesher.components import Components


def joined(parts: list) -> Components:
    """Domains as one Components, as a run of several faces meshes them."""
    return Components([R for d in parts for R in d.rings], [d.segment_tags for d in parts],
                      [len(d.seeds) for d in parts])


def rectangle(w, notched=False):
    """The w × 1 box; `notched`: with a V-notch down to y = 0.85 in the top side (non-convex)."""
    if notched:
        return np.array([(0.0, 0.0), (w, 0.0), (w, 1.0), (0.55 * w, 1.0), (0.5 * w, 0.85),
                         (0.45 * w, 1.0), (0.0, 1.0)])
    return np.array([(0.0, 0.0), (w, 0.0), (w, 1.0), (0.0, 1.0)])


def hexagons(n: int) -> list:
    """n hexagons on a grid in the unit square, radius a third of the spacing (bench_regions)."""
    k = int(np.ceil(np.sqrt(n)))
    t = np.pi / 3 * np.arange(6)
    unit = np.column_stack([np.cos(t), np.sin(t)]) / (3 * k)
    c = (np.stack(np.meshgrid(np.arange(k), np.arange(k)), -1).reshape(-1, 2)[:n] + 0.5) / k
    return [ci + unit for ci in c]


def star(center, radius, n, rng):
    """A star-shaped polygon with n corners around `center`, radii in [0.6, 1] × radius."""
    t = 2 * np.pi * np.arange(n) / n + rng.uniform(-0.3, 0.3, n) * np.pi / n
    r = radius * rng.uniform(0.6, 1.0, n)
    return np.asarray(center) + np.column_stack([r * np.cos(t), r * np.sin(t)])


@st.composite
def media(draw):
    """(domain, {tag: Anisotropy}): a w × 1 rectangle (convex, or notched) cut by a straight (oblique) cut, a band,
    a polygonal inclusion inside or touching the outline, or several of them."""
    w = draw(st.floats(0.8, 2.0))
    rng = np.random.default_rng(draw(st.integers(0, 2**31)))
    kinds = draw(st.lists(st.sampled_from(["cut", "band", "inclusion", "notch"]), min_size=1,
                          max_size=2, unique=True))
    regions = []
    if "cut" in kinds:            # right part of an oblique cut, touching the outline
        x0, x1 = rng.uniform(0.55 * w, 0.75 * w, 2)
        regions.append([(x0, 0.0), (w, 0.0), (w, 1.0), (x1, 1.0)])
    if "band" in kinds:           # a band from the left side to the cut (or the right side)
        y = np.sort(rng.uniform(0.3, 0.7, 2)) + [0, 0.1]
        xr = min(r[0][0] for r in regions) if regions else w
        xr1 = min(r[3][0] for r in regions) if regions else w
        # the band's right end lies on the cut, so its corners split the cut's segment
        ya, yb = y
        xa = xr + (xr1 - xr) * ya if regions else w
        xb = xr + (xr1 - xr) * yb if regions else w
        regions.append([(0.0, ya), (xa, ya), (xb, yb), (0.0, yb)])
    if "inclusion" in kinds:      # strictly inside, left of everything else
        # left of the notch (x ≤ 0.3w) and below the band (y ≤ 0.25) when there is one
        regions.append(star((0.2 * w, 0.17 if "band" in kinds else 0.5), 0.08, int(rng.integers(3, 7)), rng))
    if "notch" in kinds:          # a triangle on the bottom side
        a = rng.uniform(0.3, 0.4) * w
        regions.append([(a, 0.0), (a + 0.1 * w, 0.0), (a + 0.05 * w, rng.uniform(0.1, 0.2))])
    domain = qmesh.Domain(rectangle(w, draw(st.booleans())), regions=regions)
    cond = {}
    for k in range(len(regions) + 1):
        ratio = 10 ** draw(st.floats(0, 3))
        size = 10 ** draw(st.floats(-2, 2))
        angle = draw(st.floats(0, 180))
        cond[k] = qmesh.Anisotropy.principal(size * ratio, size, angle)
    return domain, cond


def region_of(domain, X) -> np.ndarray:
    """The region tag of points X (strictly inside, as triangle centroids are)."""
    tag = np.zeros(len(X), np.int64)
    for k, reg in enumerate(domain.regions, start=1):
        A, B = reg.segment_ends
        tag[rings.inside(X, A, B)] = k
    return tag


def check_mesh(domain, cond, m, tol=1e-9, signs=True):
    """Regions, areas, input points and interfaces kept; with `signs`, q_ij ≥ 0 on every edge and
    the discrete maximum principle."""
    P, T = m.points, m.triangles
    # every triangle inside one region and tagged with it
    cen = P[T].mean(axis=1)
    assert np.array_equal(region_of(domain, cen), m.region_tags)
    # area preserved, region by region
    u, v = P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]
    area = 0.5 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
    assert area.sum() == np.float64(domain.area) or abs(area.sum() - domain.area) < 1e-9 * domain.area
    for k, reg in enumerate(domain.regions, start=1):
        assert abs(area[m.region_tags == k].sum() - reg.area) < 1e-9 * domain.area
    # input points kept, bit for bit
    pts = {tuple(x) for x in P}
    for reg in (domain,) + domain.regions:
        assert all(tuple(x) in pts for x in reg.seeds)
    # no edge crosses an interface: a mesh edge meets an interface segment only at a vertex
    part = domain.partition
    inter = part.edges[part.interface]
    if len(inter):
        a, b = part.points[inter[:, 0]], part.points[inter[:, 1]]
        E = np.unique(np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1), axis=0)
        c, d = P[E[:, 0]], P[E[:, 1]]

        def orient(p, q, r):
            u, v = q - p, r - p
            return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
        o1 = orient(a[None], b[None], c[:, None]); o2 = orient(a[None], b[None], d[:, None])
        o3 = orient(c[:, None], d[:, None], a[None]); o4 = orient(c[:, None], d[:, None], b[None])
        eps = 1e-10 * domain.diameter ** 2
        crossing = (o1 * o2 < -eps * eps) & (o3 * o4 < -eps * eps) & (np.abs(o1) > eps) & (np.abs(o2) > eps)
        assert not crossing.any()
    if not signs:
        return
    # q_ij ≥ 0 on interior, interface and boundary edges
    r_in, r_b, r_if = measure._relative_q(m, cond, split=True)
    assert (r_in >= -tol).all() and (r_b >= -tol).all() and (r_if >= -tol).all()
    assert len(r_if) or not len(domain.regions)
    # the discrete maximum principle on a random Dirichlet problem
    rng = np.random.default_rng(0)
    K = measure.stiffness(m, cond).tocsr()
    bnd = m.boundary
    g = rng.random(int(bnd.sum()))
    u_b = np.zeros(m.n_vertices)
    u_b[bnd] = g
    I = np.flatnonzero(~bnd)
    if len(I):
        rhs = -(K[I][:, np.flatnonzero(bnd)] @ g)
        u = spla.spsolve(K[I][:, I].tocsc(), rhs)
        span = g.max() - g.min()
        assert u.min() >= g.min() - 1e-9 * span and u.max() <= g.max() + 1e-9 * span
