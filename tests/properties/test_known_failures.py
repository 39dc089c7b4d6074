"""K1–K26: every minimal reproducer the property suite has found, kept as regression tests.

Each entry is meshed and checked with the property suite's evaluator (`invariants.run`: no
broken invariant, no exception, no warning other than a QmeshWarning, a QmeshError only when it
names the option it cannot meet), or, for the invariance entries K9–K11, compared with its
moved / rescaled twin (`invariants.difference`); K12 runs every invalid call of
`bad_calls.CALLS`. An entry's `did` says what it did when it was found; all are fixed (a fixed
entry that regresses fails here, with its reproducer). KNOWN_FAILURES.md says how new entries are
found and added.
"""

from __future__ import annotations

import numpy as np
import pytest

import bad_calls
import invariants
import qmesh
from strategies import Case, ConductivitySpec, DomainSpec, polygon_spec, smooth_s

I = np.eye(2)
TRIANGLE = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]


def disk(vb, radius=1.0, center=(0.0, 0.0)) -> DomainSpec:
    return DomainSpec("regular", f"qmesh.Disk({vb}, radius={radius!r}, center={center!r})",
                      lambda: qmesh.Disk(vb, radius=radius, center=center), vb, None, center, radius)


def polygon(points) -> DomainSpec:
    return polygon_spec("convex", np.asarray(points, dtype=float))


def principal(k1, k2, angle=0.0) -> ConductivitySpec:
    R = np.array([[np.cos(np.radians(angle)), -np.sin(np.radians(angle))],
                  [np.sin(np.radians(angle)), np.cos(np.radians(angle))]])
    return ConductivitySpec(f"qmesh.Anisotropy.principal({k1}, {k2}, {angle})",
                            lambda: qmesh.Anisotropy.principal(k1, k2, angle), R @ np.diag([k1, k2]) @ R.T)


def constant(Q) -> ConductivitySpec:
    Q = np.asarray(Q, dtype=float)
    return ConductivitySpec(f"qmesh.Anisotropy.constant({Q.tolist()})", lambda: qmesh.Anisotropy.constant(Q), Q)


def medium(outline, regions) -> DomainSpec:
    outline, regions = np.asarray(outline, dtype=float), tuple(np.asarray(r, dtype=float) for r in regions)
    return DomainSpec("media", f"qmesh.Domain({outline.tolist()}, [], regions={[r.tolist() for r in regions]})",
                      lambda: qmesh.Domain(outline, [], regions=list(regions)),
                      len(outline) + sum(map(len, regions)), (outline,), regions=regions)


def text_field(k1, k2, angle) -> ConductivitySpec:
    """TensorField.principal of texts; its Q at points (the evaluator's corner angles) is the
    field's own."""
    build = (lambda: qmesh.TensorField.principal(k1, k2, angle))
    return ConductivitySpec(f"qmesh.TensorField.principal({k1!r}, {k2!r}, {angle!r})", build, None,
                            {0: lambda P: np.asarray(build()(P))})


def expression(text: str) -> ConductivitySpec:
    return ConductivitySpec(f"qmesh.Anisotropy.from_expression({text!r})",
                            lambda: qmesh.Anisotropy.from_expression(text))


def expressions_per_region(texts: dict) -> ConductivitySpec:
    """{tag: TensorField.from_expressions(*texts[tag])}."""
    def build():
        return {t: qmesh.TensorField.from_expressions(*q) for t, q in texts.items()}
    fields = build()
    code = "{" + ", ".join(f"{t}: qmesh.TensorField.from_expressions{q!r}" for t, q in texts.items()) + "}"
    return ConductivitySpec(code, build, None, {t: (lambda P, f=f: np.asarray(f(P))) for t, f in fields.items()})


K25_OUTLINE = [[-1.423318954422863, -1.43109811878279], [1.9345389743169232, -0.37427395804549785],
               [1.4102470015998292, 1.2915641472590862], [-1.947610927139957, 0.2347399865217939]]
K25_TRIANGLE = [[0.18084398751203734, -0.9262172718934535], [0.6697458211582702, -0.7723443919232112],
                [-0.4290760390192471, -0.681522370322582]]
_U, _V = "((x + 0.0065359764115169175)/1.760119823784643)", "((y + 0.06976698576185199)/1.760119823784643)"
K25_FIELDS = {0: (f"1 + 0.9696634117474656*{_U}**2", f"14.58790843420034*tanh({_U}*{_V})",
                  f"951.2486812167652*(1 + 0.6931471803691238*{_V}**2)"),
              1: (f"1 + 0.9696634117474656*{_U}**2", f"0.015335536040418572*tanh({_U}*{_V})",
                  f"0.0010512498148442905*(1 + 0.6931471803691238*{_V}**2)")}

K26_OUTLINE = [[-55912.05489183997, 104645.39405162391], [-55891.58903199436, 104645.39405162391],
               [-55891.58903199436, 104654.05372109576], [-55912.05489183997, 104654.05372109576]]
K26_REGIONS = [[[-55911.648618373845, 104645.39405162391], [-55910.914794339405, 104645.39405162391],
                [-55910.914794339405, 104654.05372109576], [-55911.648618373845, 104654.05372109576]],
               [[-55903.01328412957, 104645.39405162391], [-55901.81799348269, 104645.39405162391],
                [-55901.81799348269, 104654.05372109576], [-55903.01328412957, 104654.05372109576]],
               [[-55894.76970372113, 104651.62876178634], [-55895.3781886836, 104651.58913876356],
                [-55895.885340607536, 104651.25058173803], [-55896.15526854447, 104650.70380679132],
                [-55896.1156455217, 104650.09532182886], [-55895.777088496165, 104649.58816990492],
                [-55895.23031354945, 104649.318241968], [-55894.62182858698, 104649.35786499076],
                [-55894.11467666305, 104649.69642201629], [-55893.844748726115, 104650.24319696301],
                [-55893.88437174889, 104650.85168192547], [-55894.22292877443, 104651.35883384942]]]


def k26_fields() -> ConductivitySpec:
    """K26's four fields: field_strategies' swirl and raster, and principal texts."""
    from field_strategies import raster, swirl
    c, L = (-55901.821961917165, 104649.72388635983), 10.232929922807541
    U, V = f"((x - ({c[0]!r}))/{L!r})", f"((y - ({c[1]!r}))/{L!r})"
    texts = (f"2.5008737469550963*(1 + 0.13332876556647819*sin(1.840406430346063*{U} + 1.0))",
             f"2.5008737469550963*exp(-0.9436029379727513*{V})",
             f"62.50456522995921 + -1.4365592223320023e-43*{U}")

    def build():
        return {0: qmesh.TensorField(swirl(c, L, 1.0, 29.496761512082745, 2.9569675875193363e-151, 34.18773467110063, 1.9,
                                           5.420985129522903), resolution=0.3685197155455158),
                1: qmesh.TensorField.from_raster(*raster((-55912.05489183997, 104645.39405162391),
                                                         (-55891.58903199436, 104654.05372109576), 5, 8,
                                                         1.0, 127.43170017505719, 0.3825196080902461,
                                                         True, 4246)),
                2: qmesh.TensorField.principal(*texts),
                3: qmesh.TensorField(swirl(c, L, 1.0, 424.5864563992726, 78.5066688743445,
                                           45.47847177375497, 1.3057579498604184, 0.697843403554332))}
    fields = build()
    return ConductivitySpec("K26's fields (test_known_failures.k26_fields)", build, None,
                            {t: (lambda P, f=f: np.asarray(f(P))) for t, f in fields.items()})


# --------------------------------------------------------------------------- the entries

# id: (what it did when found, the case checked by invariants.run)
MESHED = {
    "K1": ("right triangle, no boundary refinement, target 4: N = 3 and no error (now refused, "
           "naming target_vertices)",
           Case(polygon(TRIANGLE), constant(I), dict(target_vertices=4, boundary_refinement=False))),
    "K2": ("right triangle, no boundary refinement, target 5: triangle [1, 3, 3], flat triangles, "
           "area 0.068 of 0.5",
           Case(polygon(TRIANGLE), constant(I), dict(target_vertices=5, boundary_refinement=False))),
    "K3": ("Disk(3), principal(14, 0.05, 176), size 0.3, no refinement: 8 of 10 vertices NaN, a "
           "fixed corner too",
           Case(disk(3), principal(14, 0.05, 176), dict(size=0.3, boundary_refinement=False))),
    "K4": ("Disk(3), Q = I, target 10, no refinement: 3 of 3 boundary q_ij < 0",
           Case(disk(3), constant(I), dict(target_vertices=10, boundary_refinement=False))),
    "K5": ("Disk(16), principal(1, 1000, 30), target 200: 9 of 146 boundary q_ij < 0",
           Case(disk(16), principal(1, 1000, 30), dict(target_vertices=200))),
    "K6": ("Disk(8) of radius 1e-6 at (1e5, -3e4), target 100: OverflowError and a RuntimeWarning",
           Case(disk(8, 1e-6, (1e5, -3e4)), constant(I), dict(target_vertices=100))),
    "K7": ("Disk(64) of radius 1e-6 at (1e5, -3e4), target 500: 'polygon has repeated consecutive "
           "points'",
           Case(disk(64, 1e-6, (1e5, -3e4)), constant(I), dict(target_vertices=500))),
    "K8": ("Disk(32) at (1e6, 0), target 500: '227 points are not vertices of the triangulation'",
           Case(disk(32, 1.0, (1e6, 0.0)), constant(I), dict(target_vertices=500))),
    "K13": ("a thin triangle, principal(1, 1e4, 90), target 2000, no refinement: 37 s and 1.9 GB, "
            "later '3 points are not vertices' (now refused, naming target_vertices)",
            Case(polygon(np.array([[0, 0], [1, 0], [0.5, 1e-3]])
                         @ np.array([[0.75**0.5, 0.5], [-0.5, 0.75**0.5]])),
                 principal(1, 1e4, 90), dict(target_vertices=2000, boundary_refinement=False))),
    "K14": ("Disk(3), s = |x|²/2 by from_s, target 4: a corrupt mesh (a repeated vertex, area 0.11 "
            "of 1.30)",
            Case(disk(3),
                 ConductivitySpec("qmesh.Anisotropy.from_s(lambda P: 0.5 * (P ** 2).sum(1), "
                                  "lambda P: P, lambda P: np.eye(2))",
                                  lambda: qmesh.Anisotropy.from_s(lambda P: 0.5 * (P ** 2).sum(1),
                                                                  lambda P: P, lambda P: np.eye(2))),
                 dict(target_vertices=4))),
    "K15": ("Disk(3), principal(1, 1e-4, 0), target 4: '1 points are not vertices of the "
            "triangulation'",
            Case(disk(3), principal(1, 1e-4, 0), dict(target_vertices=4))),
    "K16": ("Disk(3), principal(1, 600, 70), target 1911, no refinement: 'the conforming "
            "triangulation did not settle'",
            Case(disk(3), principal(1, 600, 70), dict(target_vertices=1911, boundary_refinement=False))),
    "K17": ("a 3.6e-6 hexagon 391141 from the origin, a varying s, target 637: 'edge flipping did "
            "not converge'",
            Case(polygon([[391141.21409125667, -1.8127932369907489e-06],
                          [391141.21409057284, -3.1002556635390102e-06],
                          [391141.21409215446, -4.604483849033876e-07],
                          [391141.2140933857, 1.6823944061968088e-06],
                          [391141.214093995, 2.7767472426882864e-06],
                          [391141.2140935888, 2.2043960958708955e-06]]),
                 ConductivitySpec("strategies.smooth_s((391141.214092358, 0.0), 3.622783081005091e-06, "
                                  "2.154434690031884, 0.20793988626016788, 0.0, 4.058039595611165, "
                                  "(0.0, 2.5218515203656295), 0.6564205448619959)",
                                  lambda: smooth_s((391141.214092358, 0.0), 3.622783081005091e-06,
                                                   2.154434690031884, 0.20793988626016788, 0.0,
                                                   4.058039595611165, (0.0, 2.5218515203656295),
                                                   0.6564205448619959)),
                 dict(target_vertices=637, alpha=0.5364646753662948, quality_threshold=0.17724404287167994,
                      seed=7073392, boundary_refinement=False))),
    "K18": ("the L-shape, Q = I, target 3000, no refinement: 'did not settle'",
            Case(DomainSpec("named", "qmesh.domains.lshape()", lambda: qmesh.domains.lshape(), 6,
                            (np.array([[-1, -1], [1, -1], [1, 0], [0, 0], [0, 1], [-1, 1]], dtype=float),)),
                 constant(I), dict(target_vertices=3000, boundary_refinement=False))),
    "K19": ("a quadrilateral, Q = I, target 5, no refinement: Qhull's 'QH6154 initial simplex is "
            "flat' (the same corners rounded to 1-3 decimals were refused with a reason)",
            Case(polygon([[-0.7706259881144901, -0.6372876795000557],
                          [-0.2535717890140863, -0.9673165706304196],
                          [0.9810003343335807, 0.1940060412394492],
                          [-0.9977212827349182, -0.06747030441453072]]),
                 constant(I), dict(target_vertices=5, boundary_refinement=False))),
    "K20": ("Disk(8), s = exp(x) + y², target 16: ValueError 'zero-size array to reduction "
            "operation minimum' in the varying-s start (a one-point patch)",
            Case(disk(8), expression("exp(x) + y**2"), dict(target_vertices=16))),
    "K21": ("the unit square, s = x⁴ + y⁴ + x² + y², target 1000, no refinement: 'the conforming "
            "triangulation did not settle' (a conformity loop that emptied the square)",
            Case(polygon([[0, 0], [1, 0], [1, 1], [0, 1]]), expression("x**4 + y**4 + x**2 + y**2"),
                 dict(target_vertices=1000, boundary_refinement=False))),
    "K22": ("a thin triangle with a 0.022° corner in the metric of principal(1, 100), target 1000: "
            "refused as too sharp for the 4053 vertices reached, advising fewer vertices without "
            "naming target_vertices (fewer are refused as too few: only blunting the corner helps)",
            Case(polygon([[1.5403023058681398, 0.8414709848078965], [0.7291201118165391, -0.420267576881343],
                          [0.7305775823153211, -0.42120340792655375]]), principal(1.0, 100.0, 0.0),
                 dict(target_vertices=1000, alpha=0.5, quality_threshold=0.5, seed=0,
                      boundary_refinement=False))),
    "K23": ("a field text exp(1000·(y − 13448.1345)) on a disk there: SymPy split it into "
            "exp(−13448134.5)·exp(1000·y), 0·∞, refused as 'nan at (x, y) = …: not finite'",
            Case(disk(8, 1e-3, (0.0, 13448.1345)), text_field(1.0, "exp(1000*(y - 13448.1345))", 30.0),
                 dict(target_vertices=100))),
    "K24": ("a rectangle with a triangle standing on its side, one field in both regions, target 8: "
            "refused as 'region 1: size = 0.303 is too large', an option the user never gave",
            Case(medium([[-6.32, -2.59], [8.32, -2.59], [8.32, 2.59], [-6.32, 2.59]],
                        [[[-2.18, -2.59], [3.42, -2.59], [3.55, -1.47]]]),
                 text_field(863.0, 1.6, "91.5 + 0.6*sin(y/15)"), dict(target_vertices=8))),
    "K25": ("a quadrilateral with a triangle standing on its side, a from_expressions field in "
            "each region, target 946: both faces split beside the triangle's corner and put their "
            "own point a few ulps apart ('two face meshes put vertices … a round-off apart')",
            Case(medium(K25_OUTLINE, [K25_TRIANGLE]), expressions_per_region(K25_FIELDS),
                 dict(target_vertices=946, alpha=0.4826270115570559, quality_threshold=0.4826270115570559,
                      seed=84384492))),
    "K26": ("a rectangle 1e5 from the origin with two strips and a disk, four fields (callables, a "
            "raster, texts), target 3000: a strip's run halved its size again and again "
            "(each quadrupling it): 1 142 505 vertices after six minutes",
            Case(medium(K26_OUTLINE, K26_REGIONS), k26_fields(),
                 dict(target_vertices=3000, quality_threshold=0.8560538344042152, seed=137494))),
}

STIFF = Case(disk(32), principal(1, 1000, 0), dict(target_vertices=200))
SMALL = Case(disk(24), constant(I), dict(target_vertices=30))

# id: (what it did when found, the case, its twin's shift, scale and factor c on Q)
INVARIANT = {
    "K9": ("Disk(24) and Disk(24) moved by (1, 0), Q = I, target 30: 6 of 30 vertices 0.14 of the "
           "size apart", SMALL, (1.0, 0.0), 1.0, 1.0),
    "K10": ("the 32-gon scaled by 1000, principal(1, 1000, 0), target 200: 168 of 200 vertices "
            "elsewhere", STIFF, (0.0, 0.0), 1e3, 1.0),
    "K11": ("the 32-gon with 1e-4·Q, principal(1, 1000, 0), target 200: 168 of 200 vertices "
            "elsewhere", STIFF, (0.0, 0.0), 1.0, 1e-4),
}

K12 = ("invalid calls that raised something else than a QmeshError naming the argument: 147 of "
       "458 at first (Mesh with points 'abc', Disk(8, radius=10**400), iterate(..., target=10), "
       "io.write to a path that is neither str nor Path, iterate() checking nothing before the "
       "first next(), ...)")

ORDER = [f"K{k}" for k in range(1, 27)]
LIMIT = 60
"""Seconds an entry may take (each takes a few): K26 ran for six minutes."""


def test_the_entries_are_k1_to_k26():
    assert sorted([*MESHED, *INVARIANT, "K12"], key=ORDER.index) == ORDER


def twin_difference(case: Case, shift, scale: float, c: float) -> str | None:
    """None when `case` moved by shift, scaled by scale, with c·Q meshes to its mesh moved and
    scaled (invariants.difference), else what differs."""
    rings = case.domain.rings or (np.asarray(case.domain.build().points),)
    twin = Case(polygon(np.asarray(rings[0]) * scale + np.asarray(shift)), constant(c * case.conductivity.Q),
                case.options)
    a = qmesh.mesh(case.domain.build(), case.conductivity.build(), **case.options)
    b = qmesh.mesh(twin.domain.build(), twin.conductivity.build(), **twin.options)
    return invariants.difference(a, b, shift, scale)


@pytest.mark.parametrize("key", ORDER)
def test_known_failure_stays_fixed(key):
    if key in MESHED:
        did, case = MESHED[key]
        defects = invariants.run(case, time_limit=LIMIT).defects
        assert not defects, (f"{key} ({did}) is back:\n" + "\n".join(defects)
                             + f"\nreproducer: {case.reproducer()}")
    elif key in INVARIANT:
        did, case, shift, scale, c = INVARIANT[key]
        found = twin_difference(case, shift, scale, c)
        assert found is None, f"{key} ({did}) is back: {found}\nreproducer: {case.reproducer()}"
    else:
        problems = [f"{b.what}: {why}" for b in bad_calls.CALLS if (why := bad_calls.outcome(b)) is not None]
        assert len(bad_calls.CALLS) >= 458
        assert not problems, (f"K12 ({K12}) is back for {len(problems)} of {len(bad_calls.CALLS)} calls:\n"
                              + "\n".join(problems[:12]))
