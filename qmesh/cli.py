"""The `qmesh` command: mesh a domain, report on any mesh file, reproduce the chapter's tables.

    qmesh mesh   [--Q Q11 Q12 Q22 | --principal K1 K2 ANGLE | --s TEXT | --field-Q Q11 Q12 Q22
                  | --field-principal K1 K2 ANGLE | --raster FILE.npz]
                 [--disk VB | --polygon FILE | --regions FILE] [--region-Q TAG Q11 Q12 Q22]
                 [--region-principal TAG K1 K2 ANGLE] [--target-vertices N | --size H]
                 [--alpha A] [--seed S] [--max-iterations K] -o OUT [--progress] [--quiet] [--json]
    qmesh report MESHFILE [--Q ... | --principal ... | --s TEXT] [--json]
                 (default Q: the one stored in the file)
    qmesh table  [--vb VB ...] [--out DIR] [--peers] [--solve] [--workers N | --scheduler ADDRESS]
    qmesh setup  [--check] [--test | --all]
    qmesh sweep  STUDY -o RESULTS [--scheduler ADDRESS | --workers N]   (qmesh.sweep.cli)

Defaults are the chapter's case: Q = diag(0.1, 10) (2.95) on the regular 64-gon. Bad input
(any QmeshError, or an OSError on a file) ends with one line `qmesh: error: ...` on stderr,
exit status 2 and no output file.
"""

from __future__ import annotations

import argparse
import inspect
import json
import os
import sys
import time
import warnings
from contextlib import nullcontext

import numpy as np

from qmesh import CHAPTER_Q, __version__, io, measure
from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.conductivity.field import TensorField
from qmesh.domain import domain as domain_types
from qmesh.domain.domain import Disk, Polygon
from qmesh.mesher import sizing
from qmesh.errors import QmeshError, QmeshWarning
from qmesh.geometry.folds import folded_triangles
from qmesh.io.conductivity import PREFIX as RECORD_PREFIX, record_of
from qmesh.mesher import budget
from qmesh.meshing import iterate
from qmesh.meshing import mesh as run_mesher
from qmesh.domain.polygon_file import read_domain
from qmesh.domain.region_file import conductivity_per_region, read_regions
from qmesh.sweep.cli import add_dask_options, add_parser as add_sweep_parser

_MESHER_DEFAULTS = {k: v.default for k, v in inspect.signature(iterate).parameters.items()}


# --------------------------------------------------------------------------- inputs

def _non_negative_int(text: str) -> int:
    """argparse type for --seed (numpy's generators take no negative seed)."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer, got {text!r}")
    return value


def _vertex_count(text: str) -> int:
    """argparse type for --target-vertices: an integer, also written with an exponent (2e7,
    1.5e4) when its value is integral; the memory budget then says whether it fits."""
    from decimal import Decimal, InvalidOperation
    try:
        value = Decimal(str(text).strip())
    except InvalidOperation:
        value = None
    if value is None or not value.is_finite() or value != value.to_integral_value():
        raise argparse.ArgumentTypeError(f"must be an integer (e.g. 20000 or 2e4), got {text!r}")
    if value.adjusted() > 30:
        raise argparse.ArgumentTypeError(f"is far too large: {text!r}")
    return int(value)


def anisotropy_from(args) -> Anisotropy | TensorField:
    """--Q Q11 Q12 Q22, --principal K1 K2 ANGLE or --s TEXT, or a field (--field-Q, --field-principal,
    --raster); the chapter's Q = diag(0.1, 10) by default."""
    if getattr(args, "field_Q", None) is not None:
        return TensorField.from_expressions(*args.field_Q)
    if getattr(args, "field_principal", None) is not None:
        return TensorField.principal(*args.field_principal)
    if getattr(args, "raster", None) is not None:
        return raster_from(args.raster)
    if args.Q is not None:
        q11, q12, q22 = args.Q
        return Anisotropy.constant([[q11, q12], [q12, q22]])
    if args.principal is not None:
        return Anisotropy.principal(*args.principal)
    if args.s is not None:
        return Anisotropy.from_expression(args.s)
    return Anisotropy.constant(CHAPTER_Q)


RASTER_KEYS = ("x", "y", "k1", "k2")


DISK = 64
"""--disk's VB when no domain is given (and no raster, whose rectangle is then the domain)."""


def raster_rectangle(field: TensorField) -> Polygon:
    """The rectangle a raster's cells cover: where its conductivity is known."""
    assert field.bounds is not None
    (x0, y0), (x1, y1) = field.bounds
    return Polygon([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])


def raster_from(path: str) -> TensorField:
    """A raster field from a NumPy .npz file holding arrays x (nx+1,), y (ny+1,) (cell edges),
    k1, k2 (ny, nx) and optionally angle (ny, nx; degrees, default 0): what numpy.savez writes
    from the arrays a MODFLOW or geostatistics script already holds. Read without pickles."""
    import numpy as np
    try:
        data = np.load(path, allow_pickle=False)
    except (ValueError, EOFError):
        data = None
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise QmeshError(f"{path}: not a NumPy .npz file (numpy.savez writes one from named "
                         "arrays x, y, k1, k2, angle)")
    with data:
        files = list(data.files)
        arrays = {k: data[k] for k in (*RASTER_KEYS, "angle") if k in files}
    missing = [k for k in RASTER_KEYS if k not in arrays]
    if missing:
        raise QmeshError(f"{path}: a raster file needs arrays {', '.join(RASTER_KEYS)} (and "
                         f"optionally angle); it has no {', '.join(missing)} (it has "
                         f"{', '.join(files) or 'no arrays'})")
    return TensorField.from_raster(arrays["x"], arrays["y"], arrays["k1"], arrays["k2"],
                                   arrays.get("angle", 0.0))


def disk_vertices(vb: int, anisotropy, *, target_vertices: int | None = None, size: float | None = None) -> float:
    """The fewest vertices a mesh of the regular `vb`-gon (`qmesh.Disk(vb)`) can have, known
    before its `vb` points are made: each of them is a vertex, a target is at least that, and
    with neither a target nor a size the default size (the mean metric length of its edges,
    about 2π/vb of the circle's metric perimeter) fills the disk with about vb² vertices,
    computed here on a 64-gon whose edges are scaled down to the vb-gon's."""
    n = float(max(vb, target_vertices or 0))
    if target_vertices is not None or size is not None or vb <= 64:
        return n
    if not isinstance(anisotropy, Anisotropy):
        return n                      # a field or one conductivity per region: the plan sizes it
    small = domain_types.Disk(64)          # not the name the command builds its domain with
    lengths = sizing.metric_edge_lengths(small, anisotropy)
    h = float(lengths.mean()) * np.sin(np.pi / vb) / np.sin(np.pi / 64)   # the vb-gon's mean edge
    area = sizing.metric_area(small, anisotropy)
    return max(n, sizing.vertices_from_counts(area, h, vb))



# --------------------------------------------------------------------------- commands

def _stage(step) -> str:
    """The stage a Step ends, as the progress names it: a field's last Step is its certified mesh
    (its stage, "triangulate", would read as one more triangulation)."""
    return "certified" if step.converged and step.mesh.conductivity is not None else step.stage


def _progress(step, out) -> None:
    s = step.stats
    energy = f"{s.energy:.4e}" if np.isfinite(s.energy) else "n/a"       # a field has no s
    print(f"iteration {step.iteration:3d}  {_stage(step):<11s}  N={s.n_vertices:<8d}  E={energy:<10s}  "
          f"min q={s.min_quality:.3f}", file=out, flush=True)


BAR = {"delay": 1.0, "disable": None}
"""tqdm's options for `qmesh mesh`'s bar: shown once a run has taken a second, and only when
stderr is a terminal (disable=None), so a log or a pipe gets nothing."""


def _progress_bar(out):
    """A tqdm bar on `out` that counts the stages; `_advance` moves it on by one Step."""
    from tqdm import tqdm
    return tqdm(file=out, desc="qmesh mesh", unit=" stages", leave=False, dynamic_ncols=True, **BAR)


def _advance(bar, step) -> None:
    # n_vertices only: the Step's energy and quality cost a pass over the triangles
    bar.set_postfix_str(f"iteration {step.iteration} {_stage(step)} N={step.stats.n_vertices}", refresh=False)
    bar.update(1)


def cmd_mesh(args) -> int:
    out = io.check_writable(args.output)
    anisotropy = anisotropy_from(args)
    raster_box = args.raster is not None and args.disk is None and not (args.polygon or args.regions)
    args.disk = DISK if args.disk is None else args.disk
    if not (args.polygon or args.regions or raster_box):   # the disk's own count, before its VB points
        budget.check(disk_vertices(args.disk, anisotropy, target_vertices=args.target_vertices,
                                          size=args.size),
                     varying=not (isinstance(anisotropy, Anisotropy) and anisotropy.is_constant),
                     what=f"--disk {args.disk}" + ("" if args.target_vertices or args.size else " at the default size"))
    domain = (read_domain(args.polygon) if args.polygon else
              raster_rectangle(anisotropy) if raster_box else Disk(args.disk))
    if args.regions or args.region_Q or args.region_principal:      # a conductivity per region
        domain, from_file = read_regions(args.regions) if args.regions else (domain, {})
        anisotropy = conductivity_per_region(domain, from_file, args.region_Q, args.region_principal, anisotropy)
    lines = args.progress and not args.quiet       # a line per stage; else tqdm's bar on a terminal
    bar = None if args.quiet or lines else _progress_bar(sys.stderr)

    start = time.perf_counter()
    steps = []

    def on_step(step):
        steps[:] = [step]
        if lines:
            _progress(step, sys.stderr)
        elif bar is not None:
            _advance(bar, step)

    # the API's mesh(): the same checks of the options and of the vertex count it lands on;
    # its thin-domain warning is kept and printed below as one line (not measured again)
    with warnings.catch_warnings(record=True) as caught, nullcontext() if bar is None else bar:
        warnings.simplefilter("always", QmeshWarning)
        mesh = run_mesher(domain, anisotropy, target_vertices=args.target_vertices, size=args.size,
                          alpha=args.alpha, max_iterations=args.max_iterations, seed=args.seed,
                          progress=on_step)
    seconds = time.perf_counter() - start
    last = steps[-1]
    field = isinstance(anisotropy, TensorField)      # measured and stored by its element means
    io.write(out, mesh, anisotropy=None if field else anisotropy)   # one Q, or one per region
    given = None if field else anisotropy
    q = measure.quality(mesh, given)
    # with no interior vertex there is no Dirichlet matrix whose signs q_ij would matter: n/a
    shares = measure.q_nonnegative_fractions(mesh, given)
    summary = {
        "output": str(out),
        "n_vertices": mesh.n_vertices,
        "n_triangles": mesh.n_triangles,
        "iterations": last.iteration,
        "min_quality": float(q.min()),
        "mean_quality": float(q.mean()),
        "q_nonnegative_fraction": shares["q_nonnegative_fraction"],
        "q_nonnegative_fraction_boundary": shares["q_nonnegative_fraction_boundary"],
        "seconds": seconds,
    }
    if isinstance(anisotropy, dict):
        summary["q_nonnegative_fraction_interface"] = shares["q_nonnegative_fraction_interface"]
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"{out}: N={summary['n_vertices']} triangles={summary['n_triangles']} "
              f"iterations={summary['iterations']} quality min={summary['min_quality']:.3f} "
              f"mean={summary['mean_quality']:.3f} "
              f"q_ij>=0: interior {_percent(summary['q_nonnegative_fraction'])} "
              f"boundary {_percent(summary['q_nonnegative_fraction_boundary'])}"
              + (f" interface {_percent(summary['q_nonnegative_fraction_interface'])}"
                 if "q_nonnegative_fraction_interface" in summary else "") + f" time={seconds:.2f}s")
    for w in caught:
        if not issubclass(w.category, QmeshWarning):          # not ours: shown as it would be
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
        elif not args.quiet:           # a thin domain, a medium's or a field's added vertices
            print(f"qmesh: warning: {w.message}", file=sys.stderr)
    return 0


def _percent(share: float | None) -> str:
    """A share as a percentage, "n/a" when there is nothing to count."""
    return "n/a" if share is None else f"{100 * share:.1f}%"


def conductivity_for_report(args, mesh=None) -> tuple[Anisotropy | None, str]:
    """The Q to measure a mesh file with, and where it came from.

    The command line's --Q/--principal/--s when given; else the element means the file stores
    per triangle (`mesh.conductivity`: None, which `measure.report` takes as those means); else
    the conductivity the file stores (`qmesh.io.read_anisotropy`); else the chapter's Q (2.95),
    which the caller must announce.
    """
    given = any(getattr(args, name, None) is not None for name in ("Q", "principal", "s"))
    if given:
        return anisotropy_from(args), "command line"
    if mesh is not None and mesh.conductivity is not None:
        return None, "means"
    stored = io.read_anisotropy(args.meshfile)      # one Anisotropy, or {region tag: Anisotropy}
    if stored is not None:
        return stored, "file"
    return Anisotropy.constant(CHAPTER_Q), "default"


def _conductivity_text(anisotropy) -> str:
    if anisotropy is None:                     # the element means stored per triangle
        return "element means Q11 Q12 Q22 per triangle"
    if isinstance(anisotropy, dict):           # a conductivity per region
        return "; ".join(f"region {tag}: {_conductivity_text(a)}" for tag, a in sorted(anisotropy.items()))
    record = record_of(anisotropy)
    return record[len(RECORD_PREFIX):] if record else anisotropy.label


def cmd_report(args) -> int:
    mesh = io.read(args.meshfile)
    anisotropy, source = conductivity_for_report(args, mesh)
    conductivity = _conductivity_text(anisotropy)
    where = {"file": "stored in the file", "command line": "from the command line",
             "means": "stored in the file; no s, so no energy or interpolation errors",
             "default": "the chapter's default: the file stores none"}[source]
    rep = measure.report(mesh, anisotropy)
    rep["folded_triangles"] = folded_triangles(mesh)  # a file's folds and overlaps, not re-oriented away
    if args.json:
        print(json.dumps({"file": str(args.meshfile), "conductivity": conductivity,
                          "conductivity_source": source, **rep}, indent=2))
        return 0
    why = rep.pop("kappa2_undefined", None)
    width = max(map(len, rep))
    print(f"{args.meshfile}: conductivity {conductivity} ({where})")
    for key, value in rep.items():
        text = "n/a" if value is None else f"{value:.6g}" if isinstance(value, float) else str(value)
        print(f"  {key:<{width}}  {text}")
    if why:                                 # beside the table, which stays two columns
        print(f"qmesh: kappa2 is undefined: {why}", file=sys.stderr)
    return 0


def cmd_setup(args) -> int:
    from qmesh.setup import setup
    return setup(check_only=args.check, everything=args.all, tests=args.test)


def cmd_table(args) -> int:
    try:
        from .compare.table import run_table
    except ImportError as e:
        raise QmeshError(f"qmesh table needs the compare extra (pip install qmesh[compare]): {e}") from e
    print(run_table(vb=args.vb, out=args.out, peers=args.peers, solve=args.solve,
                    progress=lambda line: print(line, file=sys.stderr, flush=True),
                    scheduler=args.scheduler, workers=args.workers))
    return 0


# --------------------------------------------------------------------------- parser

def _add_anisotropy(p, fields: bool = False) -> None:
    g = p.add_mutually_exclusive_group()
    if fields:
        g.add_argument("--field-Q", nargs=3, metavar=("Q11", "Q12", "Q22"),
                       help="a conductivity field: each entry a number or a text in x, y (as --s), "
                       "e.g. --field-Q '1 + x**2' 0 2; the mesh is certified q_ij >= 0 on its element means")
        g.add_argument("--field-principal", nargs=3, metavar=("K1", "K2", "ANGLE"),
                       help="a conductivity field by principal values and the angle of K1's axis in "
                       "degrees, each a number or a text in x, y")
        g.add_argument("--raster", metavar="FILE.npz",
                       help="a raster field: a NumPy .npz with arrays x (nx+1), y (ny+1) (cell edges), "
                       "k1, k2 and optionally angle (ny, nx), MODFLOW's K, K22, ANGLEX")
    g.add_argument("--Q", nargs=3, type=float, metavar=("Q11", "Q12", "Q22"),
                   help="constant SPD conductivity [[Q11, Q12], [Q12, Q22]] (default: 0.1 0 10)")
    g.add_argument("--principal", nargs=3, type=float, metavar=("K1", "K2", "ANGLE"),
                   help="principal conductivities K1, K2 > 0 and the angle of K1's axis in degrees")
    g.add_argument("--s", metavar="TEXT",
                   help="a varying conductivity Q = adj ∇²s from a convex s(x, y) typed as text, "
                   "e.g. 'exp(x) + y**2': numbers, x, y, pi, e, + - * / **, and exp log log1p sqrt "
                   "sin cos tan sinh cosh tanh arctan abs (write --s=TEXT when TEXT starts with -)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="qmesh", description="Triangle meshes adapted to an anisotropic "
                                     "conductivity Q (the Q-adapted meshes of Algorithm 2.1).")
    parser.add_argument("--version", action="version", version=f"qmesh {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("mesh", help="mesh a domain and write the mesh file",
                       description="Mesh a domain for the conductivity Q and write OUT "
                       "(format from the extension: " + ", ".join(io.FORMATS) + ").")
    _add_anisotropy(p, fields=True)
    g = p.add_mutually_exclusive_group()
    g.add_argument("--disk", type=int, metavar="VB",
                   help="the regular VB-gon inscribed in the unit circle (default: 64; with --raster "
                   "and no domain given, the raster's rectangle)")
    g.add_argument("--polygon", metavar="FILE", help="a domain file: CSV of x,y rows (a blank line between "
                   "rings: the outline first, then holes) or GeoJSON (.geojson/.json: a Polygon, or a Feature "
                   "holding one)")
    g.add_argument("--regions", metavar="FILE", help="a region file: a GeoJSON FeatureCollection whose features "
                   "carry 'region' (0: the domain, else the region's name) and optionally 'Q', 'principal' or 's'")
    for flag, meta in (("--region-Q", ("TAG", "Q11", "Q12", "Q22")), ("--region-principal", ("TAG", "K1", "K2", "ANGLE"))):
        p.add_argument(flag, nargs=4, type=float, action="append", metavar=meta, help="the conductivity of region TAG "
                       "(repeatable; regions given none use --Q/--principal/--s)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--target-vertices", type=_vertex_count, metavar="N", help="aim for N vertices: the mesh ends on N, or near it where keeping q_ij >= 0 "
                   "on the boundary needs more vertices (a few percent; more for small N)")
    g.add_argument("--size", type=float, metavar="H", help="target edge length in the metric ∇²s "
                   "(default: the mean metric length of the domain's edges)")
    for flag, kind, meta, text in (("--alpha", float, "A", "relaxation of the vertex step"),
                                   ("--seed", _non_negative_int, "S", "random seed"),
                                   ("--max-iterations", int, "K", "iteration cap")):
        default = _MESHER_DEFAULTS[flag[2:].replace("-", "_")]
        p.add_argument(flag, type=kind, default=default, metavar=meta, help=f"{text} (default: {default})")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="output mesh file")
    p.add_argument("--progress", action="store_true", help="print a line per stage on stderr, also when it is not "
                   "a terminal (without it, a terminal shows a progress bar once a run takes over a second)")
    p.add_argument("--quiet", action="store_true", help="no progress bar or lines and no warning")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(handler=cmd_mesh)

    p = sub.add_parser("report", help="measure a mesh file (q_ij, κ2, errors, quality)",
                       description="Print qmesh.measure.report of a mesh file, written by qmesh or any other "
                       "program. Without --Q/--principal it measures with the conductivity the file stores "
                       "(qmesh mesh stores it), else with the chapter's Q = diag(0.1, 10) and a note; "
                       "the 'conductivity' line says which.")
    p.add_argument("meshfile", metavar="MESHFILE")
    _add_anisotropy(p)
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(handler=cmd_report)

    p = sub.add_parser("table", help="reproduce the chapter's Tables 2.2 and 2.3",
                       description="Mesh the chapter's case for each VB and print the comparison table (Markdown).")
    p.add_argument("--vb", type=int, nargs="+", metavar="VB", help="VB values (default: the chapter's nine)")
    p.add_argument("--out", default="results", metavar="DIR", help="folder for meshes and figures (default: results)")
    p.add_argument("--peers", action="store_true", help="also run the optional MMG2D/BAMG peers")
    p.add_argument("--solve", action="store_true", help="also solve the model problem on every mesh")
    add_dask_options(p, "to run the (VB, mesher) cells on (its workers need qmesh and the peers)",
                     "to run the cells on (default: neither, all in this process; sweep extra)")
    p.set_defaults(handler=cmd_table)

    p = sub.add_parser("setup", help="install the system libraries the installed extras need (Debian/Ubuntu)",
                       description="Check with dpkg that the system packages the installed extras load are "
                       "there (Mesa EGL for off-screen rendering, gmsh's X/GL libraries, NGSolve's Fortran "
                       "runtime) and install the missing ones with apt-get when run as root or with "
                       "password-less sudo; otherwise print the command to run and exit 1. --test: also "
                       "what the test suite needs (chromium for the browser tests).")
    p.add_argument("--check", action="store_true", help="only check; install nothing")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--test", action="store_true", help="every group the test suite needs (chromium too)")
    mode.add_argument("--all", action="store_true", help="every group, whether or not its extra is installed")
    p.set_defaults(handler=cmd_setup)

    add_sweep_parser(sub)
    return parser


def main(argv=None) -> int:
    """Run the command line; returns the exit status (2 for bad input, with one error line)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:  # argparse already printed usage and its error
        return e.code if isinstance(e.code, int) else 0
    try:
        code = args.handler(args)
        sys.stdout.flush()  # a closed stdout shows here, not at exit
        return code
    except BrokenPipeError:  # `qmesh report x | head -2`: the reader has gone; end quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except (QmeshError, OSError) as e:
        print(f"qmesh: error: {e}", file=sys.stderr)
        return 2
    except (OverflowError, RecursionError, MemoryError) as e:  # a hostile input's last resort
        print(f"qmesh: error: the input is too large or too deeply nested: {type(e).__name__}: "
              f"{str(e)[:200]}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("qmesh: interrupted", file=sys.stderr)
        return 130
