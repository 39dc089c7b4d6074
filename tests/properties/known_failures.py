"""The minimal reproducers of KNOWN_FAILURES.md, runnable: prints which still fail.

    python tests/properties/known_failures.py

Each entry is meshed and checked with the property suite's evaluator (`invariants.run`), or, for
the invariance entries, compared with its moved / rescaled twin. "fails" lists the defects
found; "ok" means the entry no longer reproduces (update KNOWN_FAILURES.md).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bad_calls  # noqa: E402
import invariants  # noqa: E402
from strategies import Case, ConductivitySpec, DomainSpec, polygon_spec, smooth_s  # noqa: E402

import qmesh  # noqa: E402

I = np.eye(2)


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


TRIANGLE = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]

# id: (case, what KNOWN_FAILURES.md says it shows)
CASES = {
    "K1": Case(polygon(TRIANGLE), constant(I), dict(target_vertices=4, boundary_refinement=False)),
    "K2": Case(polygon(TRIANGLE), constant(I), dict(target_vertices=5, boundary_refinement=False)),
    "K3": Case(disk(3), principal(14, 0.05, 176), dict(size=0.3, boundary_refinement=False)),
    "K4": Case(disk(3), constant(I), dict(target_vertices=10, boundary_refinement=False)),
    "K5": Case(disk(16), principal(1, 1000, 30), dict(target_vertices=200)),
    "K6": Case(disk(8, 1e-6, (1e5, -3e4)), constant(I), dict(target_vertices=100)),
    "K7": Case(disk(64, 1e-6, (1e5, -3e4)), constant(I), dict(target_vertices=500)),
    "K8": Case(disk(32, 1.0, (1e6, 0.0)), constant(I), dict(target_vertices=500)),
    "K14": Case(disk(3), ConductivitySpec("qmesh.Anisotropy.from_s(lambda P: 0.5 * (P ** 2).sum(1), "
                                          "lambda P: P, lambda P: np.eye(2))", lambda: qmesh.Anisotropy.from_s(
                                              lambda P: 0.5 * (P ** 2).sum(1), lambda P: P, lambda P: np.eye(2))),
                dict(target_vertices=4)),
    "K15": Case(disk(3), principal(1, 1e-4, 0), dict(target_vertices=4)),
    "K16": Case(disk(3), principal(1, 600, 70), dict(target_vertices=1911, boundary_refinement=False)),
    "K17": Case(polygon([[391141.21409125667, -1.8127932369907489e-06], [391141.21409057284, -3.1002556635390102e-06],
                         [391141.21409215446, -4.604483849033876e-07], [391141.2140933857, 1.6823944061968088e-06],
                         [391141.214093995, 2.7767472426882864e-06], [391141.2140935888, 2.2043960958708955e-06]]),
                ConductivitySpec("strategies.smooth_s((391141.214092358, 0.0), 3.622783081005091e-06, 2.154434690031884, "
                                 "0.20793988626016788, 0.0, 4.058039595611165, (0.0, 2.5218515203656295), "
                                 "0.6564205448619959)",
                                 lambda: smooth_s((391141.214092358, 0.0), 3.622783081005091e-06, 2.154434690031884,
                                                  0.20793988626016788, 0.0, 4.058039595611165,
                                                  (0.0, 2.5218515203656295), 0.6564205448619959)),
                dict(target_vertices=637, alpha=0.5364646753662948, quality_threshold=0.17724404287167994,
                     seed=7073392, boundary_refinement=False)),
    "K18": Case(DomainSpec("named", "qmesh.domains.lshape()", lambda: qmesh.domains.lshape(), 6,
                           (np.array([[-1, -1], [1, -1], [1, 0], [0, 0], [0, 1], [-1, 1]], dtype=float),)),
                constant(I), dict(target_vertices=3000, boundary_refinement=False)),
    "K19": Case(polygon([[-0.7706259881144901, -0.6372876795000557], [-0.2535717890140863, -0.9673165706304196],
                         [0.9810003343335807, 0.1940060412394492], [-0.9977212827349182, -0.06747030441453072]]),
                constant(I), dict(target_vertices=5, boundary_refinement=False)),
    "K20": Case(disk(8), ConductivitySpec('qmesh.Anisotropy.from_expression("exp(x) + y**2")',
                                          lambda: qmesh.Anisotropy.from_expression("exp(x) + y**2")),
                dict(target_vertices=16)),
    "K21": Case(polygon([[0, 0], [1, 0], [1, 1], [0, 1]]),
                ConductivitySpec('qmesh.Anisotropy.from_expression("x**4 + y**4 + x**2 + y**2")',
                                 lambda: qmesh.Anisotropy.from_expression("x**4 + y**4 + x**2 + y**2")),
                dict(target_vertices=1000, boundary_refinement=False)),
    "K13": Case(polygon(np.array([[0, 0], [1, 0], [0.5, 1e-3]]) @ np.array([[0.75**0.5, 0.5], [-0.5, 0.75**0.5]])),
                principal(1, 1e4, 90), dict(target_vertices=2000, boundary_refinement=False)),
}


def invariance(case: Case, shift, scale: float, c: float = 1.0) -> list[str]:
    """Defects of the twin of `case` moved by shift, scaled by scale, with c·Q."""
    rings = case.domain.rings or (np.asarray(case.domain.build().points),)
    twin_domain = polygon(np.asarray(rings[0]) * scale + np.asarray(shift))
    Q = c * case.conductivity.Q
    twin = Case(twin_domain, constant(Q), case.options)
    a = qmesh.mesh(case.domain.build(), case.conductivity.build(), **case.options)
    b = qmesh.mesh(twin.domain.build(), twin.conductivity.build(), **twin.options)
    found = invariants.difference(a, b, shift, scale)
    return [] if found is None else [f"invariance: {found}"]


STIFF = Case(disk(32), principal(1, 1000, 0), dict(target_vertices=200))
SMALL = Case(disk(24), constant(I), dict(target_vertices=30))
INVARIANCE = {
    "K9": ("the 24-gon moved by (1, 0)", lambda: invariance(SMALL, (1.0, 0.0), 1.0)),
    "K10": ("the 32-gon scaled by 1000", lambda: invariance(STIFF, (0.0, 0.0), 1e3)),
    "K11": ("the 32-gon with 1e-4·Q", lambda: invariance(STIFF, (0.0, 0.0), 1.0, c=1e-4)),
}


def main() -> int:
    still = 0
    for key, case in CASES.items():
        out = invariants.run(case)
        status = "fails" if out.defects else "ok"
        still += bool(out.defects)
        print(f"{key:<4} {status:<5} {case.reproducer()}")
        for d in out.defects:
            print(f"        {d[:200]}")
        if out.error and not out.defects:
            print(f"        refused with a reason: {out.error[:200]}")
    for key, (what, run) in INVARIANCE.items():
        found = run()
        still += bool(found)
        print(f"{key:<4} {'fails' if found else 'ok':<5} {what}: {found[0] if found else 'the same mesh'}")
    problems = [(b.what, bad_calls.outcome(b)) for b in bad_calls.CALLS]
    problems = [p for p in problems if p[1] is not None]
    print(f"K12  {'fails' if problems else 'ok':<5} {len(problems)} of {len(bad_calls.CALLS)} invalid calls "
          f"without a QmeshError naming the argument")
    for what, why in problems[:: max(1, len(problems) // 12)]:
        print(f"        {what}: {why[:120]}")
    return 1 if still or problems else 0


if __name__ == "__main__":
    sys.exit(main())
