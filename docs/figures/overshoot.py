"""The picture on the guide's first page: an isotropic mesh's P1 solution overshooting its data
beside qmesh's, which stays within it.

The problem is the one `benchmarks/bench_fields.py` checks the maximum principle with:
−div(Q∇u) = 0 on the unit square, u = 1 on the boundary where x < ½ and 0 elsewhere, so the
exact u lies in [0, 1]. Q is a constant 100 : 1 turned by 30° (`Anisotropy.principal(1, 0.01,
30)`). The isotropic mesh is Shewchuk's Triangle (`pq30a`, the area set so that it has about
the vertices qmesh is asked for); both are solved by the same P1 solve
(`qmesh.compare.solve.dirichlet`). Vertices whose value leaves [0, 1] by more than 1e-10 are
marked. The title of each panel gives its counts; they are printed too.

    python docs/figures/overshoot.py            # writes docs/figures/overshoot.png
"""

from __future__ import annotations

import argparse
import io
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.tri import Triangulation  # noqa: E402
from PIL import Image  # noqa: E402

import qmesh  # noqa: E402
import triangle  # noqa: E402
from qmesh.compare.solve import dirichlet  # noqa: E402

TARGET = 500
Q = qmesh.Anisotropy.principal(1.0, 0.01, 30.0)
SQUARE = qmesh.Polygon([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)])
TOLERANCE = 1e-10


def data(points: np.ndarray) -> np.ndarray:
    """The Dirichlet data: 1 where x < ½, 0 elsewhere."""
    return (points[:, 0] < 0.5).astype(float)


def solve(mesh: qmesh.Mesh) -> np.ndarray:
    """The P1 solution with the data on every boundary vertex."""
    fixed = np.flatnonzero(mesh.boundary)
    return dirichlet(mesh, Q, fixed, data(mesh.points[fixed]))


def triangle_mesh(target: int) -> qmesh.Mesh:
    """Triangle's isotropic quality mesh of the square (`pq30a`, boundary points allowed) with
    about `target` vertices: the largest area that gives at least that many, by bisection."""
    corners = np.array([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)])
    segments = np.array([(0, 1), (1, 2), (2, 3), (3, 0)])
    low, high = 1e-5, 1e-1
    for _ in range(40):
        area = np.sqrt(low * high)
        out = triangle.triangulate({"vertices": corners, "segments": segments},
                                   "pq30a" + np.format_float_positional(area, trim="-") + "Q")
        low, high = (area, high) if len(out["vertices"]) >= target else (low, area)
    out = triangle.triangulate({"vertices": corners, "segments": segments},
                               "pq30a" + np.format_float_positional(low, trim="-") + "Q")
    return qmesh.Mesh(out["vertices"], out["triangles"])


def outside(u: np.ndarray) -> tuple[np.ndarray, float]:
    """Indices of the vertices outside [0, 1] and the worst excess."""
    excess = np.maximum(u - 1.0, -u)
    return np.flatnonzero(excess > TOLERANCE), float(max(excess.max(), 0.0))


def panel(ax, mesh: qmesh.Mesh, u: np.ndarray, name: str) -> str:
    tri = Triangulation(mesh.points[:, 0], mesh.points[:, 1], mesh.triangles)
    colours = plt.get_cmap("viridis").with_extremes(over="red", under="white")
    shade = ax.tripcolor(tri, u, shading="gouraud", cmap=colours, vmin=0.0, vmax=1.0)
    ax.triplot(tri, color="white", lw=0.2, alpha=0.45)
    bad, worst = outside(u)
    over, under = bad[u[bad] > 1.0], bad[u[bad] < 0.0]
    ax.plot(*mesh.points[over].T, "o", ms=4, mfc="red", mec="black", mew=0.4, ls="none",
            label="above 1")
    ax.plot(*mesh.points[under].T, "o", ms=4, mfc="white", mec="black", mew=0.4, ls="none",
            label="below 0")
    line = (f"{name}: {mesh.n_vertices} vertices, {len(bad)} outside [0, 1]"
            + (f", worst by {worst:.2g}" if len(bad) else ""))
    ax.set_title(line.replace(": ", ":\n", 1), fontsize=10)
    ax.set_xlim(-0.02, 1.02)
    ax.set_ylim(-0.02, 1.02)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    return line, shade


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", default=str(Path(__file__).with_name("overshoot.png")))
    args = parser.parse_args(argv)
    adapted = qmesh.mesh(SQUARE, Q, target_vertices=TARGET)
    isotropic = triangle_mesh(TARGET)
    fig, axes = plt.subplots(1, 2, figsize=(10, 5.4), constrained_layout=True)
    lines = []
    for ax, (mesh, name) in zip(axes, [(isotropic, "Triangle, isotropic"), (adapted, "qmesh")]):
        line, shade = panel(ax, mesh, solve(mesh), name)
        lines.append(line)
    axes[0].legend(loc="lower left", fontsize=8, framealpha=0.9)
    fig.colorbar(shade, ax=axes, shrink=0.8, extend="both",
                 label="u_h (red > 1, white < 0)")
    fig.suptitle("−div(Q∇u) = 0, Q 100 : 1 at 30°; u = 1 on the boundary where x < ½, 0 elsewhere",
                 fontsize=11)
    buffer = io.BytesIO()
    fig.savefig(buffer, dpi=110)
    buffer.seek(0)
    with Image.open(buffer) as picture:       # 256 colours: a tenth of the bytes, the same look
        picture.convert("RGB").quantize(256).save(args.output, optimize=True)
    print("\n".join(lines))
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
