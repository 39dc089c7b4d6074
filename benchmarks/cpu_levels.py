"""Every benchmark mesh under every CPU dispatch: the same bits, or where they differ.

NumPy sends its transcendental functions to per-CPU SIMD kernels and OpenBLAS picks its BLAS
and LAPACK kernels by the CPU, so a mesher that decides on their last bits makes another mesh on
another machine. This script meshes every case of the benchmark scripts at their benchmark
sizes (their own builders: `bench_fields.CASES`, `bench_media`, `bench_corners`, `bench_domains`,
`bench_regions`, `bench_varying`, `bench_thin`, `bench_quality`, `bench_mesher`), all cases of
one setting in one subprocess, and hashes each mesh's points, triangles and conductivity
(`tests/cpu/meshes.py`'s digest; a refusal hashes its message). The settings: the default; each
narrower SIMD level NumPy offers on the machine (`NPY_DISABLE_CPU_FEATURES`, as
`tests/cpu/test_same_mesh_on_every_cpu.py` sets it); OpenBLAS's Sandybridge and Haswell kernels
(`OPENBLAS_CORETYPE`); and the one-ulp harness (`meshes.nudge`: every CPU-dependent NumPy result
moved one unit in the last place), which shows on any machine what the others show on this one.

The inputs are built once here, under the default setting, and each subprocess meshes those same
inputs (a builder that itself calls a CPU-dependent function, such as a raster drawn through
`np.exp`, would otherwise hand each setting another input); each subprocess also builds every
case itself, and the page marks a case whose own input came out different ("input differs").

    python benchmarks/cpu_levels.py [--groups fields media ...] [--settings default "one ulp" ...]
                                    [--jobs 1] [--no-page]
"""

from __future__ import annotations

import argparse
import ctypes
import glob
import hashlib
import json
import os
import pickle
import subprocess
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]
import report_page  # noqa: E402 — beside this script; the run's start time is taken on import

CELL_SIZES = (25, 50)           # bench_media's page of cell maps: --cells 25 50
SLOW = 60.0                     # a case slower than this (seconds, default setting) is skipped
SKIPPED = [("fields", "raster512 at 1000000", "98 s on the bench_fields page (--big)")]
NOT_MESHES = ("bench_regions' `Domain.from_cells` on 50², 100² and 200² cells and the "
              "overlapping inclusions build (or refuse) a domain and mesh nothing")


# ------------------------------------------------------------------------------------ cases

@dataclass
class Case:
    """One mesh of a benchmark: build() → (domain, conductivity, options of qmesh.mesh)."""
    group: str
    name: str
    target: int
    build: Callable[[], tuple]

    @property
    def key(self) -> str:
        return f"{self.group}: {self.name} at {self.target}"


def _fields() -> list[Case]:
    import bench_fields as bf
    out = [Case("fields", name, n, lambda c=c: (c.domain(), c.field(), {}))
           for name, c in bf.CASES.items() for n in bf.NS]
    raster = bf.CASES["raster512"]
    out += [Case("fields", "raster512", n, lambda: (raster.domain(), raster.field(), {}))
            for n in bf.BIG if not any(s[1] == f"raster512 at {n}" for s in SKIPPED)]
    return out


def _media() -> list[Case]:
    import bench_media as bm
    import qmesh
    out = [Case("media", name, n, lambda fn=fn: (*fn()[:2], {})) for name, fn in bm.SHORT.items()
           for n in bm.NS]
    for n in CELL_SIZES:
        for kind in bm.cell_maps(n):
            def build(n=n, kind=kind):
                x = bm.cell_edges(n)
                return (*qmesh.Domain.from_cells(x, x, *bm.cell_maps(n)[kind]), {})
            out.append(Case("media", f"{n} × {n} cells, {kind}", bm.VERTICES_PER_CELL * n * n, build))
    return out


def _corners() -> list[Case]:
    import bench_corners as bc
    import qmesh

    def alone(theta):
        P, A = bc.polygon(theta)
        return qmesh.Polygon(P), A, {}
    out = [Case("corners", f"{t:g}°", n, lambda t=t: alone(t)) for t in bc.ANGLES for n in bc.TARGETS]
    out += [Case("corners", f"{where} {t:g}°", n, lambda t=t, w=where: (*bc.medium(t, w), {}))
            for where in ("inside", "outline") for t in bc.MEDIA_ANGLES for n in bc.TARGETS]
    return out


def _domains() -> list[Case]:
    import bench_domains as bd
    import qmesh
    return [Case("domains", f"{d}, {q}", bd.N, lambda d=d, A=A: (qmesh.domains.NAMED[d](), A, {"seed": bd.SEED}))
            for d in bd.DOMAINS for q, A in bd.ANISOTROPIES.items()]


def _regions() -> list[Case]:
    import bench_regions as br
    import qmesh
    box = qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)])
    out = []
    for n, N in zip(br.INCLUSIONS, br.TARGETS):
        build = (lambda n=n: (br.box(br.hexagons(n)), br.conductivity(n), {}))
        out += [Case("regions", f"{n} inclusions", br.FEW * n, build), Case("regions", f"{n} inclusions", N, build),
                Case("regions", "plain box", N, lambda: (box, br.OUTSIDE, {}))]
    return out


def _varying() -> list[Case]:
    import bench_varying as bv
    import qmesh
    return [Case("varying", e, n, lambda e=e: (qmesh.domains.NAMED[bv.DOMAIN](),
                                               qmesh.Anisotropy.from_expression(e), {"seed": bv.SEED}))
            for e in bv.EXPRESSIONS for n in bv.NS]


def _thin() -> list[Case]:
    import bench_thin as bt
    return [Case("thin", f"{a:g}°, " + ("box" if w == 1.0 else f"w {w:g}"), n,
                 lambda w=w, a=a: (*bt.strip(w, a), {}))
            for a in bt.ANGLES for n in bt.TARGETS for w in (1.0, *bt.WIDTHS)]


def _chapter() -> list[Case]:
    import bench_mesher as bme
    import bench_quality as bq
    import qmesh
    out = [Case("chapter", f"Disk({vb})", n, lambda vb=vb: (qmesh.Disk(vb), qmesh.Anisotropy.constant(qmesh.CHAPTER_Q),
                                                          {"seed": bq.SEED, "alpha": bq.ALPHA}))
           for vb, (n, *_) in bq.CHAPTER.items()]
    out += [Case("chapter", f"Disk({bme.VB})", int(n), lambda: (bme._domain(str(bme.VB)),
                                                                qmesh.Anisotropy.constant(bme.CHAPTER_Q), {"seed": 0}))
            for n in bme.BIG]
    return out


GROUPS = {"fields": _fields, "media": _media, "corners": _corners, "domains": _domains,
          "regions": _regions, "varying": _varying, "thin": _thin, "chapter": _chapter}


def cases(groups=tuple(GROUPS)) -> list[Case]:
    """Every case of the groups, once (bench_regions meshes its plain box at 5000 twice)."""
    return list({c.key: c for g in groups for c in GROUPS[g]()}.values())


# --------------------------------------------------------------------------------- the inputs

def _parts(conductivity) -> list:
    return sorted(conductivity.items()) if isinstance(conductivity, dict) else [(None, conductivity)]


def _canonical(x) -> bytes:
    """x's pickle after one round trip: an object and its unpickled copy pickle alike then (a
    first pickle also records which of its strings are one object, which a copy does not)."""
    return pickle.dumps(pickle.loads(pickle.dumps(x)))


def _part_payload(c) -> tuple:
    """How a subprocess gets this conductivity's very bits: a constant's matrix, a picklable
    field's pickle, or (a text or a callable's formula, CPU-independent to build) its own."""
    import qmesh
    if isinstance(c, qmesh.Anisotropy) and c.is_constant:
        return "matrix", c.matrix
    try:
        return "pickle", _canonical(c)
    except (pickle.PicklingError, AttributeError, TypeError):
        return "own", type(c).__name__ + ":" + str(getattr(c, "expression", "") or "")


def _fingerprint(domain, conductivity, options) -> str:
    h = hashlib.sha256(_canonical(domain))
    for tag, c in _parts(conductivity):
        kind, value = _part_payload(c)
        h.update(f"{tag}:{kind}".encode())
        h.update(value.tobytes() if kind == "matrix" else value if kind == "pickle" else value.encode())
    h.update(json.dumps(options, sort_keys=True).encode())
    return h.hexdigest()


def inputs(all_cases: list[Case]) -> dict:
    """case key → its input as a subprocess rebuilds it bit for bit, and its fingerprint."""
    out = {}
    for case in all_cases:
        domain, conductivity, options = case.build()
        out[case.key] = {"fingerprint": _fingerprint(domain, conductivity, options),
                         "domain": pickle.dumps(domain), "options": options,
                         "parts": [(tag, _part_payload(c)) for tag, c in _parts(conductivity)]}
    return out


def _restore(given: dict, own_conductivity):
    """The parent's input, built from its payload (own_conductivity for what is rebuilt)."""
    import qmesh
    own = dict(_parts(own_conductivity))
    parts = {}
    for tag, (kind, value) in given["parts"]:
        parts[tag] = (qmesh.Anisotropy.constant(value) if kind == "matrix"
                      else pickle.loads(value) if kind == "pickle" else own[tag])
    conductivity = parts[None] if list(parts) == [None] else parts
    return pickle.loads(given["domain"]), conductivity, given["options"]


# ------------------------------------------------------------------------------ one setting

def child(path: str, out: str, nudge: bool) -> None:
    """Mesh every case of the inputs file in this process: {key: {hash, N, seconds, input}}."""
    if nudge:
        from tests.cpu.meshes import nudge as move_one_ulp
        move_one_ulp()
    from tests.cpu.meshes import digest
    import qmesh
    with open(path, "rb") as f:
        given_all, groups = pickle.load(f)
    by_key = {c.key: c for c in cases(groups)}
    # every input fingerprinted before any is meshed (a callable counts its calls)
    same = {key: _fingerprint(*by_key[key].build()) == given["fingerprint"] for key, given in given_all.items()}
    results = {}
    for key, given in given_all.items():
        own, same_input = by_key[key].build(), same[key]
        domain, conductivity, options = own if same_input else _restore(given, own[1])
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                m = qmesh.mesh(domain, conductivity, target_vertices=by_key[key].target, **options)
                h, n = digest(m), m.n_vertices
            except qmesh.QmeshError as e:
                h, n = hashlib.sha256(str(e).encode()).hexdigest()[:16], "refused"
        results[key] = {"hash": h, "N": n, "seconds": time.perf_counter() - t0, "input": same_input}
        print(f"  {key}: {n} in {results[key]['seconds']:.1f} s", file=sys.stderr, flush=True)
    Path(out).write_text(json.dumps(results))


def _levels() -> tuple[list[str], list[str]]:
    """NumPy's baseline and the dispatch targets above it that this CPU has, narrowest first."""
    from numpy._core._multiarray_umath import __cpu_baseline__, __cpu_dispatch__, __cpu_features__
    return list(__cpu_baseline__), [f for f in __cpu_dispatch__ if __cpu_features__.get(f)]


def settings() -> dict[str, dict]:
    """name → {env, nudge}: the default, each narrower SIMD level (keeping the k lowest dispatch
    targets, as the test does), two OpenBLAS kernels, the one-ulp harness."""
    baseline, above = _levels()
    out = {"default": {"env": {}, "nudge": False}}
    for keep in range(len(above)):
        top = above[keep - 1] if keep else f"{baseline[-1] if baseline else 'baseline'} (baseline)"
        out[f"up to {top}"] = {"env": {"NPY_DISABLE_CPU_FEATURES": " ".join(above[keep:])}, "nudge": False}
    for core in ("Sandybridge", "Haswell"):
        out[f"OpenBLAS {core}"] = {"env": {"OPENBLAS_CORETYPE": core}, "nudge": False}
    out["one ulp"] = {"env": {}, "nudge": True}
    return out


def _blas_core() -> str:
    """The kernel set NumPy's bundled OpenBLAS picked on this CPU."""
    import numpy as np
    for lib in glob.glob(os.path.join(os.path.dirname(np.__file__), os.pardir, "numpy.libs", "*openblas*.so*")):
        try:
            f = ctypes.CDLL(lib).scipy_openblas_get_corename64_
        except (OSError, AttributeError):
            continue
        f.restype = ctypes.c_char_p
        return f().decode()
    return "unknown"


def run_setting(name: str, setting: dict, path: str, timeout: float) -> subprocess.Popen:
    env = {**os.environ, **setting["env"],
           "PYTHONPATH": os.pathsep.join([str(HERE.parent), os.environ.get("PYTHONPATH", "")])}
    out = path + "." + "".join(ch if ch.isalnum() else "_" for ch in name) + ".json"
    cmd = [sys.executable, __file__, "--child", path, out] + (["--nudge"] if setting["nudge"] else [])
    proc = subprocess.Popen(cmd, env=env, stderr=subprocess.PIPE, text=True)
    proc.out, proc.name, proc.timeout = out, name, timeout
    return proc


def collect(proc) -> dict:
    _, err = proc.communicate(timeout=proc.timeout)
    if proc.returncode:
        raise RuntimeError(f"{proc.name} failed:\n{err[-3000:]}")
    return json.loads(Path(proc.out).read_text())


# ------------------------------------------------------------------------------------- page

def table(all_cases: list[Case], results: dict) -> tuple[list[str], list[list[str]], dict]:
    names = list(results)
    default = results["default"]
    headers = ["group", "case", "target", "N (default)", "s (default)", *names[1:]]
    rows, differs = [], dict.fromkeys(names[1:], 0)
    for c in all_cases:
        d = default[c.key]
        row = [c.group, c.name, c.target, d["N"], f"{d['seconds']:.1f}"]
        for name in names[1:]:
            r = results[name][c.key]
            same = r["hash"] == d["hash"]
            differs[name] += not same
            row.append(("same" if same else "DIFFERS") + ("" if r["input"] else " (input differs)"))
        rows.append(row)
    return headers, rows, differs


def main(argv=None) -> None:
    if argv is None and len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(sys.argv[2], sys.argv[3], "--nudge" in sys.argv[4:])
        return
    every = settings()
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--groups", nargs="+", choices=list(GROUPS), default=list(GROUPS))
    ap.add_argument("--settings", nargs="+", choices=list(every), default=list(every),
                    help="which settings to run (default always runs: the others compare with it)")
    ap.add_argument("--jobs", type=int, default=1, help="settings run at once")
    ap.add_argument("--timeout", type=float, default=1800.0, help="seconds per setting")
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    chosen = ["default"] + [s for s in args.settings if s != "default"]
    all_cases = cases(args.groups)
    print(f"{len(all_cases)} cases × {len(chosen)} settings", flush=True)
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "inputs.pickle")
        with open(path, "wb") as f:
            pickle.dump((inputs(all_cases), args.groups), f)
        queue, running = list(chosen), []
        while queue or running:
            while queue and len(running) < max(1, args.jobs):
                name = queue.pop(0)
                print(f"{name} …", flush=True)
                running.append((run_setting(name, every[name], path, args.timeout), time.perf_counter()))
            proc, t0 = running.pop(0)
            results[proc.name] = collect(proc)
            print(f"{proc.name}: {time.perf_counter() - t0:.0f} s", flush=True)
    results = {name: results[name] for name in chosen}
    headers, rows, differs = table(all_cases, results)
    baseline, above = _levels()
    features = (f"NumPy baseline {' '.join(baseline)}; dispatch targets this CPU has: "
                f"{' '.join(above) or 'none'}; OpenBLAS kernels: {_blas_core()}")
    bad = sum(any(r[5 + k].startswith("DIFFERS") for k in range(len(chosen) - 1)) for r in rows)
    inputs_differ = sum(any("input differs" in cell for cell in r[5:]) for r in rows)
    totals = "; ".join([f"{len(rows) - bad} of {len(rows)} meshes bit-identical under every setting",
                        *(f"{name}: {n} differ" for name, n in differs.items()),
                        f"{inputs_differ} cases whose builder gave another input under some setting"])
    print(report_page.markdown_table(headers, rows))
    print(features)
    print(totals)
    if not args.no_page:
        skipped = "; ".join(f"{g}: {name} ({why})" for g, name, why in SKIPPED)
        report_page.write_page(
            __file__, sys.argv, "The same mesh on every CPU", __doc__.split("\n\n", 1)[1].rsplit("\n\n", 1)[0],
            tables=[report_page.Table(headers, rows, "Each case's mesh hash against the default setting's")],
            notes=[f"**CPU features**: {features}.", f"**Totals**: {totals}.",
                   f"**Skipped** (over {SLOW:g} s): {skipped}. Not meshes: {NOT_MESHES}."])


if __name__ == "__main__":
    main()
