"""Figures 2.15–2.18 of the chapter, redrawn from a comparison table (matplotlib, log-log PNG).

2.15  ‖e_s‖_L2 against N     (chapter: both ~ N⁻¹, adapted ~4× lower)
2.16  |e_s|_h1 against N     (chapter: both ~ N^-½, adapted ~3× lower)
2.17  κ2 against N           (chapter: both ~ N, adapted ~5× lower)
2.18  N against VB           (chapter: isotropic ~ VB^1.9, adapted ~ VB^1.1)
Every mesher in the table gets markers and its least-squares power law, slope in the legend;
the chapter's printed values are drawn as hollow reference markers (its L2 column ×√2, see
`chapter.L2_FACTOR`). Regenerate from a CSV written by `qmesh table`:

    python -m qmesh.compare.figures results/table.csv docs/figures
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from qmesh.compare import chapter, require

FIGURES = {
    "fig2_15_l2.png": ("n_vertices", "l2_error", "N (vertices)", "‖s_h − s‖_L2",
                       "Figure 2.15: L2 interpolation error"),
    "fig2_16_h1.png": ("n_vertices", "h1_error", "N (vertices)", "|s_h − s|_h1",
                       "Figure 2.16: h1 interpolation error"),
    "fig2_17_kappa2.png": ("n_vertices", "kappa2", "N (vertices)", "κ2 (Dirichlet stiffness matrix)",
                           "Figure 2.17: condition number"),
    "fig2_18_n_vs_vb.png": ("vb", "n_vertices", "VB (boundary seed points)", "N (vertices)",
                            "Figure 2.18: vertices against boundary vertices"),
}
STYLE = {"isotropic": ("tab:blue", "o"), "qmesh": ("tab:red", "s"),
         "bamg": ("tab:green", "^"), "mmg2d": ("tab:purple", "D")}
LABEL = {"isotropic": "isotropic (Triangle)", "qmesh": "qmesh (adapted)",
         "bamg": "BAMG (gmsh)", "mmg2d": "MMG2D (mmgpy)"}


def slope(x, y) -> float | None:
    """Least-squares exponent p of y ~ x^p, or None with fewer than two distinct x."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    if len(np.unique(x[ok])) < 2:
        return None
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


def _number(v) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


def _chapter_points(xkey: str, ykey: str):
    """The chapter's printed points (isotropic, adapted) for one figure."""
    out = {}
    for kind, table in (("isotropic", chapter.ISOTROPIC), ("adapted", chapter.ADAPTED)):
        x = np.array(chapter.VB if xkey == "vb" else table[xkey], dtype=float)
        y = np.array(table[ykey], dtype=float)
        if ykey == "l2_error":
            y = y * chapter.L2_FACTOR
        out[kind] = (x, y)
    return out


def plot(rows: list[dict], out_dir: str | Path, chapter_reference: bool = True) -> list[Path]:
    """Write the four PNGs into out_dir from table rows (dicts with mesher, vb and measurements)."""
    require("matplotlib", "the figures")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FixedLocator, NullFormatter, ScalarFormatter

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    meshers = [m for m in STYLE if any(r["mesher"] == m for r in rows)]
    meshers += sorted({r["mesher"] for r in rows} - set(meshers))
    written = []
    for name, (xkey, ykey, xlabel, ylabel, title) in FIGURES.items():
        fig, ax = plt.subplots(figsize=(6.4, 4.8), dpi=100)
        for mesher in meshers:
            sel = [r for r in rows if r["mesher"] == mesher]
            x = np.array([_number(r[xkey]) for r in sel])
            y = np.array([_number(r[ykey]) for r in sel])
            order = np.argsort(x)
            x, y = x[order], y[order]
            color, marker = STYLE.get(mesher, ("tab:gray", "x"))
            p = slope(x, y)
            label = LABEL.get(mesher, mesher) + (f", slope {p:.2f}" if p is not None else "")
            ax.loglog(x, y, marker=marker, color=color, linestyle="none", label=label)
            if p is not None:
                ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
                c = np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)
                xs = np.array([x[ok].min(), x[ok].max()])
                ax.loglog(xs, np.exp(np.polyval(c, np.log(xs))), color=color, linewidth=1)
        if chapter_reference:
            for kind, (x, y) in _chapter_points(xkey, ykey).items():
                color = STYLE["isotropic" if kind == "isotropic" else "qmesh"][0]
                p = slope(x, y)
                note = " ×√2" if ykey == "l2_error" else ""
                ax.loglog(x, y, marker="o", markerfacecolor="none", color=color, alpha=0.55,
                          linestyle=":", linewidth=0.8,
                          label=f"chapter {kind}{note}, slope {p:.2f}")
        if xkey == "vb":                      # plain VB labels instead of crowded 3×10¹ …
            vbs = sorted({int(_number(r["vb"])) for r in rows} | set(chapter.VB))
            ax.xaxis.set_major_locator(FixedLocator(vbs))
            ax.xaxis.set_major_formatter(ScalarFormatter())
            ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        path = out_dir / name
        fig.savefig(path)
        plt.close(fig)
        written.append(path)
    return written


def read_csv(path: str | Path) -> list[dict]:
    """Rows of a table.csv written by `run_table`."""
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def main(argv=None) -> int:
    """`python -m qmesh.compare.figures TABLE.csv OUT_DIR`: redraw the figures from a table."""
    parser = argparse.ArgumentParser(prog="python -m qmesh.compare.figures", description=main.__doc__)
    parser.add_argument("csv", help="table.csv written by `qmesh table`")
    parser.add_argument("out", help="directory for the PNGs (e.g. docs/figures)")
    args = parser.parse_args(argv)
    for path in plot(read_csv(args.csv), args.out):
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
