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
    qmesh sweep  STUDY -o RESULTS [--scheduler ADDRESS | --workers N] [--meshes DIR] [--max-jobs N]
                 [--quiet]   (qmesh.sweep.cli)

Defaults are the chapter's case: Q = diag(0.1, 10) (2.95) on the regular 64-gon. Bad input
(any QmeshError, or an OSError on a file) ends with one line `qmesh: error: ...` on stderr,
exit status 2 and no output file.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
import time
import warnings
from contextlib import nullcontext
from typing import TYPE_CHECKING

from qmesh import CHAPTER_Q, __version__
from qmesh.allocator import keep_freed_memory
from qmesh.errors import QmeshError, QmeshWarning

if TYPE_CHECKING:
    from qmesh.conductivity.anisotropy import Anisotropy
    from qmesh.conductivity.field import TensorField
    from qmesh.domain.domain import Polygon

# The mesher, NumPy and SciPy are imported by the commands that use them, so that
# `qmesh --version` and a usage error answer at once.


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
    from qmesh.conductivity.anisotropy import Anisotropy
    from qmesh.conductivity.field import TensorField
    if getattr(args, "field_Q", None) is not None:
        return TensorField.from_expressions(*args.field_Q)
    if getattr(args, "field_principal", None) is not None:
        return TensorField.principal(*args.field_principal)
    if getattr(args, "raster", None) is not None:
        from qmesh.raster_file import read_raster
        return read_raster(args.raster)
    if args.Q is not None:
        q11, q12, q22 = args.Q
        return Anisotropy.constant([[q11, q12], [q12, q22]])
    if args.principal is not None:
        return Anisotropy.principal(*args.principal)
    if args.s is not None:
        return Anisotropy.from_expression(args.s)
    return Anisotropy.constant(CHAPTER_Q)


DISK = 64
"""--disk's VB when no domain is given (and no raster, whose rectangle is then the domain)."""


def raster_rectangle(field: TensorField) -> Polygon:
    """The rectangle a raster's cells cover: where its conductivity is known."""
    from qmesh.domain.domain import Polygon
    assert field.bounds is not None
    (x0, y0), (x1, y1) = field.bounds
    return Polygon([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])


def disk_vertices(vb: int, anisotropy, *, target_vertices: int | None = None, size: float | None = None) -> float:
    """The fewest vertices a mesh of the regular `vb`-gon (`qmesh.Disk(vb)`) can have, known
    before its `vb` points are made: each of them is a vertex, a target is at least that, and
    with neither a target nor a size the default size (the mean metric length of its edges,
    about 2π/vb of the circle's metric perimeter) fills the disk with about vb² vertices,
    computed here on a 64-gon whose edges are scaled down to the vb-gon's."""
    import numpy as np

    from qmesh.conductivity.anisotropy import Anisotropy
    from qmesh.domain import domain as domain_types
    from qmesh.mesher import sizing
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


def _progress(step, out, fields=()) -> None:
    """A line per Step; the certified mesh's also says how often the `fields` were evaluated."""
    s = step.stats
    energy = f"{s.energy:.4e}" if math.isfinite(s.energy) else "n/a"       # a field has no s
    said = ""
    if fields and _stage(step) == "certified":
        e = [f.evaluations for f in fields]
        said = (f"  Q(x) at {sum(v.points for v in e)} points in {sum(v.calls for v in e)} calls "
                f"({sum(v.asked for v in e)} asked)")
    print(f"iteration {step.iteration:3d}  {_stage(step):<11s}  N={s.n_vertices:<8d}  E={energy:<10s}  "
          f"min q={s.min_quality:.3f}{said}", file=out, flush=True)


BAR = {"delay": 1.0, "disable": None}
"""tqdm's options for `qmesh mesh`'s bar: shown once a run has taken a second, and only when
stderr is a terminal (disable=None), so a log or a pipe gets nothing."""


def _progress_bar(out):
    """A tqdm bar on `out` that counts the stages; `_advance` moves it on by one Step. None where
    tqdm would disable itself (`out` is no terminal): tqdm is then not imported."""
    if BAR.get("disable", False) is None and not (hasattr(out, "isatty") and out.isatty()):
        return None
    from tqdm import tqdm
    return tqdm(file=out, desc="qmesh mesh", unit=" stages", leave=False, dynamic_ncols=True, **BAR)


def _advance(bar, step) -> None:
    # n_vertices only: the Step's energy and quality cost a pass over the triangles
    bar.set_postfix_str(f"iteration {step.iteration} {_stage(step)} N={step.stats.n_vertices}", refresh=False)
    bar.update(1)


def cmd_mesh(args) -> int:
    from qmesh import io, measure
    from qmesh.conductivity.anisotropy import Anisotropy
    from qmesh.conductivity.field import TensorField
    from qmesh.domain.domain import Disk
    from qmesh.domain.polygon_file import read_domain
    from qmesh.domain.region_file import conductivity_per_region, read_regions
    from qmesh.meshing import mesh as run_mesher
    from qmesh.mesher import budget

    out = io.check_writable(args.output)
    anisotropy = anisotropy_from(args)
    raster_box = args.raster is not None and args.disk is None and not (args.polygon or args.regions)
    args.disk = DISK if args.disk is None else args.disk
    if not (args.polygon or args.regions or raster_box):   # the disk's own count, before its VB points
        budget.check(disk_vertices(args.disk, anisotropy, target_vertices=args.target_vertices,
                                          size=args.size),
                     varying=not (isinstance(anisotropy, Anisotropy) and anisotropy.is_constant),
                     field=isinstance(anisotropy, TensorField),
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
    held = list(anisotropy.values()) if isinstance(anisotropy, dict) else [anisotropy]
    fields = [a for a in held if isinstance(a, TensorField)]

    def on_step(step):
        steps[:] = [step]
        if lines:
            _progress(step, sys.stderr, fields)
        elif bar is not None:
            _advance(bar, step)

    # the API's mesh(): the same checks of the options and of the vertex count it lands on;
    # its thin-domain warning is kept and printed below as one line (not measured again)
    # the writer's too (a format that drops the element means warns): one line each, or none
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", QmeshWarning)
        with nullcontext() if bar is None else bar:
            mesh = run_mesher(domain, anisotropy, target_vertices=args.target_vertices,
                              size=args.size, alpha=args.alpha, max_iterations=args.max_iterations,
                              seed=args.seed, progress=on_step)
        seconds = time.perf_counter() - start
        # one Q, or one per region, as JSON; with a field anywhere, the element means alone (a
        # field has no stored form; the file keeps the means, which the mesh carries)
        stored = None if fields else anisotropy
        io.write(out, mesh, anisotropy=stored)
    last = steps[-1]
    field = isinstance(anisotropy, TensorField)      # measured and stored by its element means
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
    from qmesh import io
    from qmesh.conductivity.anisotropy import Anisotropy

    given = any(getattr(args, name, None) is not None for name in ("Q", "principal", "s"))
    if given:
        return anisotropy_from(args), "command line"
    if mesh is not None and mesh.conductivity is not None:
        return None, "means"
    stored = io.read_anisotropy(args.meshfile)      # one Anisotropy, or {region tag: Anisotropy}
    if stored is not None:
        return stored, "file"
    return Anisotropy.constant(CHAPTER_Q), "default"


def _conductivity_text(anisotropy, exact: bool = True) -> str:
    """The conductivity as the report names it: a constant Q's entries exact (as the file stores
    them, for --json) or to 6 significant digits (the table)."""
    if anisotropy is None:                     # the element means stored per triangle
        return "element means Q11 Q12 Q22 per triangle"
    if isinstance(anisotropy, dict):           # a conductivity per region
        return "; ".join(f"region {tag}: {_conductivity_text(a, exact)}"
                         for tag, a in sorted(anisotropy.items()))
    from qmesh.io.conductivity import to_json
    value = to_json(anisotropy)               # {"Q": 2×2}, {"s": text}, or None for a callable s
    if value is None:
        return anisotropy.label
    if "s" in value:
        return f"s(x, y) = {value['s']}"
    (a, b), (c, d) = (map(repr if exact else _short, row) for row in value["Q"])
    return f"Q = [[{a}, {b}], [{c}, {d}]]"


def _short(value: float) -> str:
    """A number to 6 significant digits, written as Python writes floats (0.1, 10.0, 3.08941):
    a Q from --principal is a rotation's cos and sin, 17 digits that say nothing more."""
    return repr(float(f"{value:.6g}"))


def _table_value(key: str, value) -> str:
    """One value of the report's table: 6 significant digits, "n/a" for None; a min_q_ij_relative
    within the shares' tolerance below 0 (−Q_RTOL ≤ value < 0, rounding in the assembly) is
    printed as 0, as the shares count it (`--json` gives the value as computed)."""
    from qmesh.measure import Q_RTOL
    if value is None:
        return "n/a"
    if not isinstance(value, float):
        return str(value)
    if key.startswith("min_q_ij_relative") and -Q_RTOL <= value < 0:
        return "0"
    return f"{value:.6g}"


def _check_means(Q, path) -> None:
    """QmeshError unless every stored element mean is positive definite, as `qmesh mesh`
    refuses a Q that is not: a report on a zero or indefinite conductivity would count its
    q_ij and print figures that mean nothing."""
    import numpy as np
    q11, q12, q22 = Q[:, 0, 0], 0.5 * (Q[:, 0, 1] + Q[:, 1, 0]), Q[:, 1, 1]
    bad = ~((q11 > 0) & (q22 > 0) & (q11 * q22 - q12 * q12 > 0))
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise QmeshError(f"{path}: the element means it stores (cell data Q11 Q12 Q22) must be "
                         f"symmetric positive definite; {int(bad.sum())} of {len(Q)} are not, the "
                         f"first that of triangle {k}: Q = [[{q11[k]:g}, {q12[k]:g}], "
                         f"[{q12[k]:g}, {q22[k]:g}]]")


def cmd_report(args) -> int:
    from qmesh import io, measure
    from qmesh.geometry.folds import folded_triangles

    mesh = io.read(args.meshfile)
    anisotropy, source = conductivity_for_report(args, mesh)
    if source == "means":
        _check_means(mesh.conductivity, args.meshfile)
    where = {"file": "stored in the file", "command line": "from the command line",
             "means": "stored in the file; no s, so no energy or interpolation errors",
             "default": "the chapter's default: the file stores none"}[source]
    rep = measure.report(mesh, anisotropy)
    rep["folded_triangles"] = folded_triangles(mesh)  # a file's folds and overlaps, not re-oriented away
    if args.json:
        print(json.dumps({"file": str(args.meshfile), "conductivity": _conductivity_text(anisotropy),
                          "conductivity_source": source, **rep}, indent=2))
        return 0
    why = rep.pop("kappa2_undefined", None)
    width = max(map(len, rep))
    print(f"{args.meshfile}: conductivity {_conductivity_text(anisotropy, exact=False)} ({where})")
    for key, value in rep.items():
        print(f"  {key:<{width}}  {_table_value(key, value)}")
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

class _Parser(argparse.ArgumentParser):
    """argparse, except that an argument starting with "-" that no option name can be — it holds
    an operator, a bracket or a point: "-1+x", "-x**2", "-exp(y)" — is a value, as argparse
    already takes "-2" or an argument holding a space. The subcommands' parsers are of this
    class too (argparse makes them of their parent's)."""

    def _parse_optional(self, arg_string):
        short = [o for o in self._option_string_actions if not o.startswith("--")]   # -o OUT, -oOUT
        if (arg_string.startswith("-") and re.search(r"[^\w-]", arg_string.split("=", 1)[0])
                and not any(arg_string.startswith(o) for o in short)):
            return None
        return super()._parse_optional(arg_string)


FIELD_TEXT = ("a text may start with - (e.g. '-1 + x', '-x**2'); write a lone -x as '(-x)'")
"""What the field options' help says about texts starting with "-"."""


def _add_anisotropy(p, fields: bool = False) -> None:
    g = p.add_mutually_exclusive_group()
    if fields:
        g.add_argument("--field-Q", nargs=3, metavar=("Q11", "Q12", "Q22"),
                       help="a conductivity field: each entry a number or a text in x, y (as --s), "
                       "e.g. --field-Q '1 + x**2' 0 2; the mesh is certified q_ij >= 0 on its element means; "
                       + FIELD_TEXT)
        g.add_argument("--field-principal", nargs=3, metavar=("K1", "K2", "ANGLE"),
                       help="a conductivity field by principal values and the angle of K1's axis in "
                       "degrees, each a number or a text in x, y; " + FIELD_TEXT)
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
    """The `qmesh` command's parser with every subcommand (it imports the file formats, the
    mesher's defaults and the sweep's options to describe them)."""
    import inspect

    from qmesh import io
    from qmesh.meshing import iterate
    from qmesh.sweep.cli import add_dask_options, add_parser as add_sweep_parser

    defaults = {k: v.default for k, v in inspect.signature(iterate).parameters.items()}
    parser = _Parser(prog="qmesh", description="Triangle meshes adapted to an anisotropic "
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
        default = defaults[flag[2:].replace("-", "_")]
        p.add_argument(flag, type=kind, default=default, metavar=meta, help=f"{text} (default: {default})")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="output mesh file")
    p.add_argument("--progress", action="store_true", help="print a line per stage on stderr, also when it is not "
                   "a terminal (without it, a terminal shows a progress bar once a run takes over a "
                   "second); a field's last line counts its evaluations")
    p.add_argument("--quiet", action="store_true", help="no progress bar or lines and no warning")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(handler=cmd_mesh)

    p = sub.add_parser("report", help="measure a mesh file (q_ij, κ2, errors, quality)",
                       description="Print qmesh.measure.report of a mesh file, written by qmesh or any other "
                       "program. Without --Q/--principal it measures with the conductivity the file stores "
                       "(qmesh mesh stores it), else with the chapter's Q = diag(0.1, 10) and a note; "
                       "the 'conductivity' line says which. The shares of q_ij >= 0 count q_ij >= -1e-9 "
                       "max|q_ij| (rounding), and a min_q_ij_relative in that band prints as 0 "
                       "(--json: as computed).")
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


def _asks_version(argv) -> bool:
    """True when `qmesh --version` (or an abbreviation, as argparse takes) comes before any
    subcommand: answered before `build_parser`, which imports the mesher to describe it."""
    for arg in argv:
        if not isinstance(arg, str) or not arg.startswith("-") or arg in ("-h", "--help", "--"):
            return False
        if len(arg) > 2 and "--version".startswith(arg):
            return True
    return False


def main(argv=None) -> int:
    """Run the command line; returns the exit status (2 for bad input, with one error line).

    Run as the program (`argv` None: the `qmesh` command, `python -m qmesh`), it owns its process
    and keeps freed memory for reuse (`qmesh.allocator`); called with `argv`, nothing changes."""
    if argv is None:
        keep_freed_memory()
    if _asks_version(sys.argv[1:] if argv is None else argv):
        print(f"qmesh {__version__}")
        return 0
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
