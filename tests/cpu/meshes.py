"""Meshes of every kind of input, hashed: run as a script (in a subprocess, under whatever CPU
dispatch the environment selects) it prints one JSON object {case: hash}. With --nudge, every
NumPy function whose last bits depend on the CPU (the transcendental ufuncs that NumPy sends to
per-CPU SIMD kernels, the BLAS products and LAPACK calls) first has its results moved by one unit
in the last place: a mesh that reads those bits anywhere it decides changes."""

import functools
import hashlib
import json
import sys
import warnings

import numpy as np

# NumPy functions with per-CPU kernels (measured: NPY_DISABLE_CPU_FEATURES and OPENBLAS_CORETYPE
# change their last bits); sin, cos, sqrt, hypot give the same bits at every SIMD level
DISPATCHED = ("tan arcsin arccos arctan arctan2 sinh cosh tanh arcsinh arccosh arctanh exp expm1 "
              "exp2 log log2 log10 log1p cbrt power float_power matmul dot inner vdot").split()
LINALG = "cholesky eigh eigvalsh eig eigvals inv det slogdet solve lstsq pinv svd norm".split()


def _up(x):
    if isinstance(x, tuple):
        moved = [_up(v) for v in x]
        return type(x)(*moved) if hasattr(x, "_fields") else tuple(moved)
    a = np.asarray(x)
    if a.dtype.kind == "f":
        return np.nextafter(x, np.inf)
    return x


def _nudged(f):
    @functools.wraps(f)
    def g(*args, **kwargs):
        out = f(*args, **kwargs)
        if kwargs.get("out") is not None:
            target = kwargs["out"][0] if isinstance(kwargs["out"], tuple) else kwargs["out"]
            target[...] = _up(target)
            return target
        return _up(out)
    return g


def nudge() -> None:
    """Move every CPU-dependent NumPy result by one ulp (before qmesh is imported)."""
    for name in DISPATCHED:
        setattr(np, name, _nudged(getattr(np, name)))
    for name in LINALG:
        setattr(np.linalg, name, _nudged(getattr(np.linalg, name)))


def digest(mesh) -> str:
    h = hashlib.sha256()
    for a in (mesh.points, mesh.triangles, mesh.conductivity):
        if a is not None:
            h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


def _islands(x, y):
    """A user's callable (magnetic islands, 1000 : 1 along the level lines of
    ψ = (y − ½)²/2 − 0.05 sin 2πx): NumPy arithmetic and cos, the same bits on every CPU."""
    bx, by = y - 0.5, 0.1 * np.pi * np.cos(2 * np.pi * x)
    b2 = bx * bx + by * by
    e = 1e-3
    q11, q12, q22 = e + (1 - e) * bx * bx / b2, (1 - e) * bx * by / b2, e + (1 - e) * by * by / b2
    return np.stack([np.stack([q11, q12], -1), np.stack([q12, q22], -1)], -2)


def cases():
    """(name, function → Mesh): a constant Q, s as text, principal axes, a formula field, a raster
    field, a medium, a grid of cells each its own Q, a field region, a callable field, a power of
    a field, a corner under half a degree (alone and as a region), a strip a few elements wide."""
    import qmesh
    from qmesh.conductivity.power import power

    A = qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)
    square = qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)])
    plate = qmesh.Domain([[0, 0], [2, 0], [2, 1], [0, 1]], holes=[qmesh.Disk(24, radius=0.25, center=(0.6, 0.5))])
    d = 1e-3
    fvca5 = qmesh.TensorField.from_expressions(f"({d}*x**2 + y**2)/(x**2 + y**2)", f"({d} - 1)*x*y/(x**2 + y**2)",
                                               f"(x**2 + {d}*y**2)/(x**2 + y**2)")
    x = np.linspace(0, 1, 9)
    c = 0.5 * (x[1:] + x[:-1])
    X, Y = np.meshgrid(c, c, indexing="ij")
    raster = qmesh.TensorField.from_raster(x, x, 1 + 99 * X, 1 + Y, 40 * X + 20 * Y)
    halves = qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)], regions=[[(0.5, 0), (1, 0), (1, 1), (0.5, 1)]])
    cells, by_cell = qmesh.Domain.from_cells(np.linspace(0, 1, 5), np.linspace(0, 1, 5),
                                             np.arange(1.0, 17.0).reshape(4, 4), 1.0,
                                             np.arange(16.0).reshape(4, 4) * 11.0)
    sharp = [(0, 0), (1, 0), (1, 1), (0.5, 0.004)]        # 0.46° at the origin
    around = qmesh.Domain([(-0.5, -0.5), (1.5, -0.5), (1.5, 1.5), (-0.5, 1.5)], regions=[sharp])
    return [
        ("disk", lambda: qmesh.mesh(qmesh.Disk(64), A, target_vertices=2000)),
        ("s_text", lambda: qmesh.mesh(qmesh.domains.lshape(), qmesh.Anisotropy.from_expression(
            "exp(x) + y**2 + 0.05*(x - y)**4 + cosh(0.5*y)"), target_vertices=600)),
        ("principal", lambda: qmesh.mesh(plate, qmesh.Anisotropy.principal(1, 50, 30), target_vertices=800)),
        ("formula_field", lambda: qmesh.mesh(square, fvca5, target_vertices=600)),
        ("angle_text", lambda: qmesh.mesh(square, qmesh.TensorField.principal(
            "20*exp(x)", 1, "atan(y - 0.3)*57 + tanh(x)*20"), target_vertices=500)),
        ("raster_field", lambda: qmesh.mesh(square, raster, target_vertices=600)),
        ("media", lambda: qmesh.mesh(halves, {0: qmesh.Anisotropy.constant([[1, 0], [0, 1]]),
                                              1: qmesh.Anisotropy.principal(100, 1, 30)}, target_vertices=800)),
        ("cells", lambda: qmesh.mesh(cells, by_cell, target_vertices=800)),
        ("field_region", lambda: qmesh.mesh(halves, {0: qmesh.Anisotropy.constant([[1, 0], [0, 1]]),
                                                     1: fvca5}, target_vertices=600)),
        ("callable", lambda: qmesh.mesh(square, qmesh.TensorField(_islands), target_vertices=600)),
        ("power", lambda: qmesh.mesh(square, power(fvca5, 0.5), target_vertices=600)),
        ("sharp_corner", lambda: qmesh.mesh(qmesh.Polygon(sharp), qmesh.Anisotropy.principal(1, 30, 20),
                                            target_vertices=600)),
        ("corner_region", lambda: qmesh.mesh(around, {0: qmesh.Anisotropy.principal(1, 5, 70),
                                                      1: qmesh.Anisotropy.principal(1, 30, 20)}, target_vertices=800)),
        ("thin", lambda: qmesh.mesh(qmesh.Polygon([(0, 0), (1, 0), (1, 0.005), (0, 0.005)]),
                                    qmesh.Anisotropy.principal(1, 1000, 30), target_vertices=8000)),
    ]


def hashes() -> dict:
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, make in cases():
            out[name] = digest(make())
    return out


if __name__ == "__main__":
    if "--nudge" in sys.argv:
        nudge()
    print(json.dumps(hashes()))
