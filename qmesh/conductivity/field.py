"""The conductivity as a field Q(x): a formula, a callable or a raster, and its element means.

FIELDS.md §1–2: what users hold is a tensor that changes from point to point — a rotating
anisotropy, a field-aligned conductivity, a raster of `k1, k2, angle` whose every cell differs —
and only its element means Q̄_T = (1/|T|) ∫_T Q enter the P1 stiffness matrix. `TensorField` holds
the field, checks it where it is evaluated (finite, symmetric, positive definite, naming the
point), and computes the means (`means`, `means_with_error`; numerics in `means.py`) and the
smoothed field the mesher sizes by (`box_means`).

Texts go through the safe parser of s(x, y) (`expression.function_of_xy`): never eval'd.
"""

from __future__ import annotations

import functools
import numbers
from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from qmesh.conductivity import means as _m
from qmesh.conductivity import sides
from qmesh.conductivity.expression import check, function_of_xy
from qmesh.conductivity.intervals import principal_forms
from qmesh.conductivity.point_cache import Evaluations, PointCache
from qmesh import checks
from qmesh.errors import QmeshError

Array = NDArray[np.float64]

SYMMETRY_RTOL = 1e-10
"""A callable's Q(x) counts as symmetric when |q12 − q21| ≤ SYMMETRY_RTOL (|q11| + |q22|); the
mean of the two is used."""

RASTER_SLACK = 1e-12
"""A point outside a raster by at most this fraction of its size (a vertex computed on its
boundary) counts as on the boundary: it takes the boundary cell."""

_Scalar = Callable[[Array, Array], Array]


def _fmt(v: float) -> str:
    return repr(float(v))


def _point(X: Array, Y: Array, k: int) -> str:
    return f"(x, y) = ({_fmt(X[k])}, {_fmt(Y[k])})"


def _scalar(v: Any, name: str) -> tuple[float | None, _Scalar, str, tuple]:
    """A number or a text in x, y → (the number or None, a vectorised g(X, Y) on 1-D arrays, its
    text for labels, its checked form for enclosures). Texts are checked by the s(x, y) parser,
    messages naming `name`."""
    if isinstance(v, str):
        form = check(v, f"{name}(x, y)")
        if form[0] == "num":
            c = float(form[1])
            return c, (lambda X, Y: np.full(X.shape, c)), v.strip(), form
        return None, function_of_xy(v, f"{name}(x, y)", form), v.strip(), form
    scalar = isinstance(v, numbers.Real) or (isinstance(v, np.ndarray) and v.ndim == 0 and v.dtype.kind in "iuf")
    if isinstance(v, (bool, np.bool_)) or not scalar:
        raise QmeshError(f"{name} must be a number or a text in x and y, got {v!r:.80}")
    try:
        c = float(v)
    except OverflowError:                   # an int beyond any float: 10**400
        raise QmeshError(f"{name} must be finite, got an integer of {len(str(abs(int(v))))} digits, "
                         "beyond any float") from None
    if not np.isfinite(c):
        raise QmeshError(f"{name} must be finite, got {c}")
    return c, (lambda X, Y: np.full(X.shape, c)), f"{c:g}", ("num", c)


def _value_checked(g: _Scalar, X: Array, Y: Array, name: str, text: str) -> Array:
    """g at the points, refusing the first point where it is not finite."""
    v = g(X, Y)
    bad = ~np.isfinite(v)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise QmeshError(f"{name}(x, y) = {text!r} is {v[k]} at {_point(X, Y, k)}: not finite")
    return v


def _check_components(X: Array, Y: Array, q11: Array, q12: Array, q21: Array, q22: Array,
                      label: str, finite: bool = False) -> Array:
    """(n, 3) components of a checked Q: finite (unless the caller checked each, `finite`),
    symmetric (SYMMETRY_RTOL), positive definite; else QmeshError naming the first point that
    fails and Q there."""
    def refuse(bad: NDArray[np.bool_], why: str) -> None:
        k = int(np.flatnonzero(bad)[0])
        Q = [[float(q11[k]), float(q12[k])], [float(q21[k]), float(q22[k])]]
        raise QmeshError(f"{label}: Q is {why} at {_point(X, Y, k)}: Q = {Q}")

    if not finite:
        ok = np.isfinite(q11) & np.isfinite(q12) & np.isfinite(q21) & np.isfinite(q22)
        if not ok.all():
            refuse(~ok, "not finite")
    if q12 is not q21:          # one array for both: symmetric by construction
        asym = np.abs(q12 - q21) > SYMMETRY_RTOL * (np.abs(q11) + np.abs(q22))
        if asym.any():
            refuse(asym, "not symmetric")
    q = np.empty((len(q11), 3))
    q[:, 0], q[:, 1], q[:, 2] = q11, 0.5 * (q12 + q21), q22
    with np.errstate(over="ignore", invalid="ignore"):   # det past the floats: refused later, named
        spd = (q[:, 0] > 0) & (q[:, 2] > 0) & (q[:, 0] * q[:, 2] - q[:, 1] ** 2 > 0)
    if not spd.all():
        refuse(~spd, "not positive definite")
    return q


def _at(tol: float | Array, k: NDArray) -> float | Array:
    """A tolerance given per triangle (an array) taken at the triangles k; one number as is."""
    return tol[k] if isinstance(tol, np.ndarray) else tol


def _points(P: ArrayLike, name: str = "points") -> Array:
    return checks.real_array(P, name, (None, 2))


def _triangles(triangles: ArrayLike, n_points: int) -> NDArray[np.intp]:
    T = np.asarray(triangles)
    if T.ndim != 2 or T.shape[1] != 3 or (T.size and T.dtype.kind not in "iu"):
        raise QmeshError(f"triangles must be integer indices of shape (M, 3), got {T.dtype} {T.shape}")
    T = T.astype(np.intp, copy=False)
    if T.size and (T.min() < 0 or T.max() >= n_points):
        raise QmeshError(f"triangles index points 0..{n_points - 1}, got indices from {T.min()} to {T.max()}")
    return T


def _raster_array(v: ArrayLike, shape: tuple[int, int], name: str, x: Array, y: Array,
                  positive: bool) -> Array:
    """One per-cell array (a number stands for every cell); QmeshError naming the first bad cell."""
    a = checks.real_values(v, name)
    try:
        a = np.broadcast_to(a, shape)
    except ValueError:
        raise QmeshError(f"{name} must be a number or an array of real numbers of shape {shape} "
                         f"(ny, nx) = (rows, columns), got shape {a.shape}") from None
    ok = np.isfinite(a) & (a > 0) if positive else np.isfinite(a)
    if not ok.all():
        j, i = (int(c) for c in np.argwhere(~ok)[0])
        need = "a finite number > 0" if positive else "a finite number"
        raise QmeshError(f"{name} is {a[j, i]} in cell (row {j}, column {i}) (x in [{x[i]:g}, "
                         f"{x[i + 1]:g}], y in [{y[j]:g}, {y[j + 1]:g}]): every cell needs {need} "
                         "(NaN cells are not holes: cut holes out of the domain instead)")
    return a


def _axis(v: ArrayLike, name: str) -> Array:
    a = checks.real_values(v, name)
    if a.ndim != 1 or len(a) < 2 or not np.all(np.isfinite(a)) or not np.all(np.diff(a) > 0):
        raise QmeshError(f"{name} must be at least two increasing finite cell edges, got {v!r:.80}")
    return a


class TensorField:
    """Q(x): a symmetric positive definite 2×2 conductivity at every point.

    Build it from a vectorised callable `TensorField(f)` (f(x, y) with x, y arrays of one shape →
    (..., 2, 2), a function of each point alone; with `cache=True` f is asked for each point once,
    its values kept, `point_cache.PointCache`: worth it for a callable that costs well over a
    microsecond a point, since the mesher asks for under a tenth of its points again and a
    look-up costs more than a cheap formula), from texts or numbers
    (`from_expressions`, `principal`) or from a raster of cells (`from_raster`). The field is
    checked where it is evaluated: `field(P)`, `means` and `box_means` raise QmeshError naming the
    first point (in the caller's coordinates) where Q is not finite, not symmetric or not positive
    definite, or — for a raster — lies outside it.

    `means(points, triangles)` gives the element means Q̄_T = (1/|T|) ∫_T Q, the only thing of Q
    the P1 stiffness matrix sees (FIELDS.md §2): adaptive quadrature for formulas and callables,
    the exact area-weighted mean of the cells for rasters (`qmesh.conductivity.means`).

        >>> import qmesh
        >>> Q = qmesh.TensorField.principal(1.0, 0.01, "30 * x")
        >>> Q.means([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]]).shape
        (1, 2, 2)
    """

    label: str
    """What the field is, for messages and reports: e.g. "Q = [[1, x], [x, 2]]" or "raster 512 × 512"."""
    is_raster: bool
    """True for a field of raster cells (`from_raster`)."""
    bounds: tuple[Array, Array] | None
    """A raster's (lo, hi) corners; None for formulas and callables (defined everywhere they
    evaluate)."""
    resolution: float | None
    """A callable's sampling: its element means sample Q at least this finely (None: as finely
    as the adaptive rule reaches by itself, half a triangle's longest edge where Q looks smooth
    to it). None for texts and rasters, whose means are bounded or exact."""

    def __init__(self, f: Callable[..., ArrayLike], label: str | None = None, *,
                 cache: bool = False, resolution: float | None = None):
        if not callable(f):
            raise QmeshError(f"TensorField takes a callable f(x, y) → (..., 2, 2), got {f!r:.80}")
        if label is not None and not isinstance(label, str):
            raise QmeshError(f"label must be text, got {label!r:.80}")
        if not isinstance(cache, (bool, np.bool_)):
            raise QmeshError(f"cache must be True or False, got {cache!r:.80}")
        if resolution is not None:
            ok = isinstance(resolution, numbers.Real) and not isinstance(resolution, bool)
            if not ok or not (np.isfinite(float(resolution)) and float(resolution) > 0):
                raise QmeshError(f"resolution must be a finite length > 0 (or None), got {resolution!r:.80}")
            resolution = float(resolution)
        self.resolution = resolution
        self._forms: list[tuple] | None = None
        self._bound: _m.Bound | None = None
        self._line: sides.StepLine | None = None
        self._f = f
        self.label = label if label is not None else f"Q = {getattr(f, '__name__', type(f).__name__)}(x, y)"
        self.is_raster = False
        self.bounds = None
        # with `cache`, each point evaluated once; without, every point asked is still counted
        self._cache: PointCache | None = PointCache(
            functools.partial(self._callable_components, f, self.label),
            capacity=None if cache else 0)
        self._components: Callable[[Array, Array], Array] = self._cache
        self._constant: Array | None = None
        self._raster: _m.Raster | None = None

    def __repr__(self) -> str:
        return f"TensorField({self.label!r})"

    # ---------------------------------------------------------------- constructors

    @classmethod
    def from_expressions(cls, q11: Any, q12: Any, q22: Any) -> "TensorField":
        """Q = [[q11, q12], [q12, q22]], each a number or a text in x and y (e.g. "1 + x**2"),
        checked by the same whitelist parser as s(x, y) (messages name the component, e.g.
        "q12(x, y): column 3: …"). Numbers are checked at once (a constant Q must be SPD); texts
        where they are evaluated."""
        parts = [_scalar(v, n) for v, n in ((q11, "q11"), (q12, "q12"), (q22, "q22"))]
        texts = [p[2] for p in parts]
        label = f"Q = [[{texts[0]}, {texts[1]}], [{texts[1]}, {texts[2]}]]"
        for (c, *_), n in ((parts[0], "q11"), (parts[2], "q22")):
            if c is not None and c <= 0:
                raise QmeshError(f"{n} = {c:g}: a diagonal entry of a positive definite Q must be > 0")
        g = [p[1] for p in parts]
        forms = [p[3] for p in parts]

        def components(X: Array, Y: Array) -> Array:
            v = [_value_checked(gi, X, Y, n, t) for gi, n, t in zip(g, ("q11", "q12", "q22"), texts)]
            return _check_components(X, Y, v[0], v[1], v[1], v[2], label, finite=True)

        constant = None
        if parts[0][0] is not None and parts[1][0] is not None and parts[2][0] is not None:
            constant = [parts[0][0], parts[1][0], parts[2][0]]
        return cls._of_components(components, label, constant, forms)

    @classmethod
    def principal(cls, k1: Any, k2: Any, angle_deg: Any) -> "TensorField":
        """Q = R diag(k1, k2) Rᵀ, R the rotation by angle_deg counter-clockwise (k1 along the
        direction at that angle, as `qmesh.conductivity.anisotropy.principal_matrix`); each a
        number or a text in x and y. Numbers are checked at once (k1, k2 > 0); texts where they
        are evaluated (k1, k2 finite and > 0, the angle finite, naming the point)."""
        parts = [_scalar(v, n) for v, n in ((k1, "k1"), (k2, "k2"), (angle_deg, "angle"))]
        for (c, *_), n in ((parts[0], "k1"), (parts[1], "k2")):
            if c is not None and c <= 0:
                raise QmeshError(f"{n} = {c:g}: principal conductivities must be > 0")
        texts = [p[2] for p in parts]
        label = f"Q = principal(k1 = {texts[0]}, k2 = {texts[1]}, angle = {texts[2]} degrees)"
        g = [p[1] for p in parts]

        def components(X: Array, Y: Array) -> Array:
            a, b, t = (_value_checked(gi, X, Y, n, s) for gi, n, s in zip(g, ("k1", "k2", "angle"), texts))
            for v, n, s in ((a, "k1", texts[0]), (b, "k2", texts[1])):
                bad = v <= 0
                if bad.any():
                    k = int(np.flatnonzero(bad)[0])
                    raise QmeshError(f"{n}(x, y) = {s!r} is {v[k]} at {_point(X, Y, k)}: principal "
                                     "conductivities must be > 0")
            c, s_ = np.cos(np.deg2rad(t)), np.sin(np.deg2rad(t))
            q11, q12, q22 = a * c * c + b * s_ * s_, (a - b) * c * s_, a * s_ * s_ + b * c * c
            return _check_components(X, Y, q11, q12, q12, q22, label)

        constant = None
        if parts[0][0] is not None and parts[1][0] is not None and parts[2][0] is not None:
            a, b, t = parts[0][0], parts[1][0], np.deg2rad(parts[2][0])
            c, s_ = np.cos(t), np.sin(t)
            constant = [a * c * c + b * s_ * s_, (a - b) * c * s_, a * s_ * s_ + b * c * c]
        forms = principal_forms(parts[0][3], parts[1][3], parts[2][3])
        return cls._of_components(components, label, constant, forms)

    @classmethod
    def from_raster(cls, x: ArrayLike, y: ArrayLike, k1: ArrayLike, k2: ArrayLike,
                    angle: ArrayLike = 0.0) -> "TensorField":
        """A raster of cells, each with a constant Q = R diag(k1, k2) Rᵀ: cell edges x (nx+1,) and
        y (ny+1,) increasing; k1, k2, angle arrays (ny, nx) (row j between y[j] and y[j+1], column
        i between x[i] and x[i+1]) or numbers standing for every cell. MODFLOW's K, K22 and ANGLEX
        as `Domain.from_cells`: k1 along the direction at `angle` degrees counter-clockwise from
        the x axis, k2 across it, K22 given as a conductivity, not a ratio.

        Every cell must hold finite k1 > 0, k2 > 0 and a finite angle: a NaN or non-positive cell
        is REFUSED with a QmeshError naming the cell (row, column) — it is not made a hole (holes
        are the domain's: cut them out of it). The field is defined on the raster's rectangle
        `bounds` only; a point outside it is refused."""
        X, Y = _axis(x, "x"), _axis(y, "y")
        shape = (len(Y) - 1, len(X) - 1)
        a = _raster_array(k1, shape, "k1", X, Y, positive=True)
        b = _raster_array(k2, shape, "k2", X, Y, positive=True)
        t = _raster_array(angle, shape, "angle", X, Y, positive=False)
        R = _m.Raster.from_principal(X, Y, a, b, t)
        field = cls.__new__(cls)
        field._f = field._raster_call
        field.label = f"raster {shape[0]} × {shape[1]}"
        field.is_raster = True
        field.bounds = (np.array([X[0], Y[0]]), np.array([X[-1], Y[-1]]))
        field.resolution = None
        field._forms, field._bound, field._line = None, None, None
        field._cache = None
        field._components = field._raster_components
        field._constant = None
        field._raster = R
        return field

    @classmethod
    def _of_components(cls, components: Callable[[Array, Array], Array], label: str,
                       constant: list[float] | None, forms: list[tuple] | None = None
                       ) -> "TensorField":
        """A field from a checked components(X, Y) → (n, 3), of texts whose checked forms of
        q11, q12, q22 are `forms` (its means' error is bounded by their enclosures; None: its
        means are sampled, as a callable's); a constant one (its components q11, q12, q22
        given) is checked now."""
        if constant is not None:
            q11, q12, q22 = constant
            if not (q11 > 0 and q22 > 0 and q11 * q22 - q12 * q12 > 0):
                raise QmeshError(f"{label} is not positive definite: Q = [[{q11:g}, {q12:g}], "
                                 f"[{q12:g}, {q22:g}]], det Q = {q11 * q22 - q12 * q12:g}")
        def f(x: ArrayLike, y: ArrayLike) -> Array:
            X, Y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
            return _m.full_tensors(components(X.ravel(), Y.ravel())).reshape(X.shape + (2, 2))

        field = cls(f, label)
        field._cache = PointCache(components, capacity=0)       # counted, not kept
        field._components = field._cache
        field._forms = forms
        field._line = sides.step_line(forms, lambda X, Y, q: _check_components(
            X, Y, q[:, 0], q[:, 1], q[:, 1], q[:, 2], label))
        if constant is not None:
            field._constant = np.array(constant, dtype=float)
        return field

    # ---------------------------------------------------------------- evaluation

    @property
    def evaluations(self) -> Evaluations:
        """How often Q was evaluated at points since the field was made: the calls of its
        callable or formula, the points they were given, and the points asked for (the same
        unless a callable's points are kept, `cache=True`). A raster's means
        and box means read its cells: zeros."""
        return Evaluations() if self._cache is None else self._cache.evaluations

    @staticmethod
    def _callable_components(f: Callable[..., ArrayLike], label: str, X: Array, Y: Array) -> Array:
        """A user's f(x, y) at 1-D points → checked components (n, 3) (no reference to the
        field: the field's cache holds it)."""
        try:
            with np.errstate(all="ignore"):
                raw = np.asarray(f(X, Y))
            if raw.dtype.kind == "c" and np.any(raw.imag != 0):   # a cast would drop it silently
                where = ""
                if raw.ndim == 3 and len(raw) == len(X):
                    k = int(np.flatnonzero(np.any(raw.imag != 0, axis=(1, 2)))[0])
                    where = f" at {_point(X, Y, k)}"
                raise QmeshError(f"{label} returned a complex Q with an imaginary part{where}: "
                                 "a conductivity is real")
            Q = np.asarray(raw.real if raw.dtype.kind == "c" else raw, dtype=float)
        except QmeshError:
            raise
        except Exception as e:
            raise QmeshError(f"{label} raised {type(e).__name__} at {len(X)} points "
                             f"(the first {_point(X, Y, 0) if len(X) else 'none'}): {e}") from e
        try:
            Q = np.broadcast_to(Q, (len(X), 2, 2))
        except ValueError:
            raise QmeshError(f"{label} must return shape (n, 2, 2) for x, y of shape (n,), "
                             f"got {Q.shape} for n = {len(X)}") from None
        return _check_components(X, Y, Q[:, 0, 0], Q[:, 0, 1], Q[:, 1, 0], Q[:, 1, 1], label)

    def place(self, point: ArrayLike) -> str:
        """Where a point is, for messages: its raster cell (row, column) and coordinates."""
        p = np.asarray(point, dtype=float).reshape(2)
        at = f"({float(p[0]):.6g}, {float(p[1]):.6g})"
        if self._raster is None:
            return at
        j, i = self._raster.cell_of(p[:1], p[1:])
        return f"raster cell (row {int(j[0])}, column {int(i[0])}) at {at}"

    def _inside(self, X: Array, Y: Array, what: str = "point") -> None:
        """Refuse the first point outside the raster by more than RASTER_SLACK of its size."""
        assert self.bounds is not None
        lo, hi = self.bounds
        tol = RASTER_SLACK * float(np.max(hi - lo))
        out = (X < lo[0] - tol) | (X > hi[0] + tol) | (Y < lo[1] - tol) | (Y > hi[1] + tol)
        if out.any():
            k = int(np.flatnonzero(out)[0])
            raise QmeshError(f"the {what} {_point(X, Y, k)} is outside the {self.label} "
                             f"[{lo[0]:g}, {hi[0]:g}] × [{lo[1]:g}, {hi[1]:g}]")

    def _raster_components(self, X: Array, Y: Array) -> Array:
        assert self._raster is not None
        self._inside(X, Y)
        j, i = self._raster.cell_of(X, Y)
        return self._raster.q[j, i]

    def _raster_call(self, x: ArrayLike, y: ArrayLike) -> Array:
        X, Y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        return _m.full_tensors(self._raster_components(X.ravel(), Y.ravel())).reshape(X.shape + (2, 2))

    def _evaluate(self, P: Array) -> Array:
        """Checked components (n, 3) at points (n, 2): the quadratures' `Evaluate`."""
        return self._components(P[:, 0], P[:, 1])

    def __call__(self, P: ArrayLike) -> Array:
        """Q at points P (n, 2) → (n, 2, 2), checked: QmeshError naming the first point where Q is
        not finite, not symmetric or not positive definite, or (a raster) outside the raster. A
        point on a cell line takes either cell."""
        A = _points(P)
        return _m.full_tensors(self._evaluate(A))

    # ---------------------------------------------------------------- means

    @property
    def constant_matrix(self) -> Array | None:
        """Q as one 2×2 matrix when the field is constant (numbers only), else None: such a field
        is meshed as `Anisotropy.constant` of it (`qmesh.fields.mesher`)."""
        return None if self._constant is None else _m.full_tensors(self._constant)

    @property
    def means_exact(self) -> bool:
        """True for a constant field and a raster: their element means are exact (to round-off)
        whatever the quadrature's tolerance."""
        return self._constant is not None or self._raster is not None

    def means(self, points: ArrayLike, triangles: ArrayLike) -> Array:
        """Element means Q̄_T = (1/|T|) ∫_T Q (FIELDS.md §2) of the triangles (M, 3) over points
        (n, 2) → (M, 2, 2). See `means_with_error`."""
        return self.means_with_error(points, triangles)[0]

    def means_with_error(self, points: ArrayLike, triangles: ArrayLike, *, rtol: float = _m.RTOL,
                         max_depth: int = _m.MAX_DEPTH,
                         bound_rtol: float | ArrayLike | None = _m.BOUND_RTOL
                         ) -> tuple[Array, Array]:
        """Element means (M, 2, 2) and a bound of their error per triangle (M,) in the Frobenius
        norm; `rtol` and `max_depth` are the adaptive quadrature's (formulas and callables only),
        `bound_rtol` the proven bound's (texts only: a number or one per triangle; None leaves
        a text's bound the rule's estimate, as a callable's, for `enclosure_errors` to prove).

        - constant fields: Q itself, error 0;
        - formulas and callables: adaptive quadrature (`means.adaptive_means`: Dunavant's degree-5
          rule against its 4 midpoint children, subdivided where they differ by more than
          `means.RTOL` · ‖Q̄_T‖), exact to round-off for constant and linear fields;
        - texts: the bound is proven (`means.enclosure_bound`: interval enclosures of the
          components and their gradients over each piece), the pieces split until it is within
          `bound_rtol` · ‖Q̄_T‖ — a jump or a bump between the samples is in it;
        - callables: the bound is the rule's last difference, an estimate from samples: nothing
          bounds a callable between them (`sampled_at` says how finely they lie; `resolution`
          sets it);
        - rasters: the exact area-weighted mean of the cells T overlaps (`means.raster_means`,
          Green's theorem along the edges); the bound is the round-off's. A triangle reaching
          outside the raster is refused.
        Q is checked at every point it is evaluated (QmeshError naming the point)."""
        P = _points(points)
        T = _triangles(triangles, len(P))
        M = len(T)
        if self._constant is not None:
            return _m.full_tensors(np.broadcast_to(self._constant, (M, 3))), np.zeros(M)
        if M == 0:
            return np.zeros((0, 2, 2)), np.zeros(0)
        if self._raster is not None:
            used = np.unique(T)
            self._inside(P[used, 0], P[used, 1], "vertex")
            assert self.bounds is not None
            q, err = _m.raster_means(self._raster, np.clip(P, *self.bounds), T)
            return _m.full_tensors(q), err
        bound = None if bound_rtol is None else self._enclosure()
        btol: float | Array = 1.0          # unused without a bound
        if bound is not None and bound_rtol is not None:
            btol = np.asarray(bound_rtol, dtype=float)
            btol = btol.reshape(M) if btol.ndim else float(btol)
        A, B, C = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
        hit = self._near_line(A, B, C)
        if hit is None:
            q, err = _m.adaptive_means(self._evaluate, A, B, C, rtol=rtol, max_depth=max_depth,
                                       bound=bound, bound_rtol=btol, resolution=self.resolution)
            return _m.full_tensors(q), err
        line, near = hit
        far = np.flatnonzero(~near)
        q, err = np.empty((M, 3)), np.empty(M)
        q[near], err[near] = sides.side_means(line, A[near], B[near], C[near], rtol=rtol,
                                              max_depth=max_depth,
                                              bound_rtol=None if bound is None else _at(btol, near))
        if len(far):
            q[far], err[far] = _m.adaptive_means(self._evaluate, A[far], B[far], C[far], rtol=rtol,
                                                 max_depth=max_depth, bound=bound,
                                                 bound_rtol=_at(btol, far),
                                                 resolution=self.resolution)
        return _m.full_tensors(q), err

    def _near_line(self, A: Array, B: Array,
                   C: Array) -> tuple[sides.StepLine, NDArray[np.bool_]] | None:
        """A text's straight jump line and which triangles it meets the box of
        (`sides.StepLine.near`: their means are taken side by side); None when it meets none or
        the text has no such line."""
        line = self._line
        if line is None or not len(A):
            return None
        near = line.near(A, B, C)
        return (line, near) if near.any() else None

    def rule_means(self, points: ArrayLike, triangles: ArrayLike) -> Array:
        """The degree-5 rule's average of Q over each triangle (M, 3) of points (n, 2) →
        (M, 2, 2): Q at 7 points a triangle, no error estimate (`means.rule_averages`; exact for
        polynomials of degree ≤ 5), what the repair ranks its candidates by. Constant fields and
        rasters: their exact means (`means_with_error`)."""
        P = _points(points)
        T = _triangles(triangles, len(P))
        if self.means_exact or not len(T):
            return self.means_with_error(P, T)[0]
        A, B, C = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
        q = _m.rule_averages(self._evaluate, A, B, C)
        hit = self._near_line(A, B, C)
        if hit is not None:
            line, near = hit
            q[near] = sides.side_rule(line, A[near], B[near], C[near])
        return _m.full_tensors(q)

    def _enclosure(self) -> _m.Bound | None:
        """A text's `means.enclosure_bound`, built once; None for other fields."""
        if self._forms is not None and self._bound is None:
            self._bound = _m.enclosure_bound(self._forms)
        return self._bound

    def enclosure_errors(self, points: ArrayLike, triangles: ArrayLike) -> Array | None:
        """A text's proven bound (M,) of the error of its element means as `means_with_error`
        takes them, whatever their tolerances: None for other fields.

        Those means apply the degree-5 rule on each of the triangle's 4 midpoint children at
        least (`means.adaptive_means`), so on each child they are a rule with positive weights,
        exact for degree 3, whose points lie in it, however far the child was refined: the
        error is at most the mean of the children's `means.enclosure_bound` (∞ where the text is
        unbounded on one). Four enclosures a triangle; the field is not evaluated."""
        bound = None if self._constant is not None else self._enclosure()
        if bound is None:
            return None
        P = _points(points)
        T = _triangles(triangles, len(P))
        out = np.empty(len(T))
        hit = self._near_line(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]])
        rest = np.arange(len(T))
        if hit is not None:              # side by side, as `means_with_error` took them
            line, near = hit
            t = T[near]
            out[near] = sides.side_errors(line, P[t[:, 0]], P[t[:, 1]], P[t[:, 2]])
            rest = np.flatnonzero(~near)
        step = _m.CHUNK // 4
        for s in range(0, len(rest), step):
            k = rest[s:s + step]
            t = T[k]
            out[k] = _m.children_bound(bound, *_m._children(P[t[:, 0]], P[t[:, 1]], P[t[:, 2]]))
        return out

    @property
    def means_bounded(self) -> bool:
        """True when `means_with_error`'s bound is proven (constants, rasters, texts); False for
        a callable, whose values between samples nothing bounds (`sampled_at`)."""
        return self.means_exact or self._forms is not None

    def sampled_at(self, points: ArrayLike, triangles: ArrayLike) -> float | None:
        """The spacing h the element means of a callable sample Q at over the triangles: a jump
        or a bump narrower than h between samples can go unseen (None where the means are
        bounded or exact, `means_bounded`). The rule samples each piece's 4 children; a piece is
        split while its children's longest edge exceeds `resolution`, down to `means.BOUND_DEPTH`
        levels: h is the largest over the triangles T of max(min(ℓ_T / 2, resolution),
        ℓ_T / 2^(BOUND_DEPTH + 1)), ℓ_T the longest edge (ℓ_T / 2 without a resolution)."""
        if self.means_bounded:
            return None
        P = _points(points)
        T = _triangles(triangles, len(P))
        if not len(T):
            return None
        L = _m.longest_edges(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]])
        if self.resolution is None:
            return float(np.max(L) / 2)
        return float(np.max(np.maximum(np.minimum(L / 2, self.resolution), L / 2.0 ** (_m.BOUND_DEPTH + 1))))

    def check_covers(self, box: tuple[ArrayLike, ArrayLike], what: str = "the domain") -> None:
        """A raster knows Q only over its cells: QmeshError naming both rectangles when the box
        (lo, hi) of `what` reaches outside them (beyond round-off of the raster's size).
        Formulas and callables are defined everywhere: nothing to check."""
        if self.bounds is None:
            return
        lo, hi = (np.asarray(v, dtype=float) for v in box)
        rlo, rhi = self.bounds
        slack = 1e-12 * float(np.max(rhi - rlo))
        if np.all(lo >= rlo - slack) and np.all(hi <= rhi + slack):
            return

        def rect(a: Array, b: Array) -> str:
            return f"[{a[0]:.10g}, {b[0]:.10g}] × [{a[1]:.10g}, {b[1]:.10g}]"
        raise QmeshError(f"{what} {rect(lo, hi)} reaches outside the cells of the {self.label} "
                         f"{rect(rlo, rhi)}, where Q is not known: mesh a domain inside them "
                         "(qmesh mesh --raster with no domain meshes the raster's rectangle)")

    def box_means(self, P: ArrayLike, half_width: ArrayLike) -> Array:
        """Mean of Q over the axis-aligned square of half-width h (a number or (n,), > 0) around
        each point P (n, 2) → (n, 2, 2): the field smoothed at the mesher's target scale, so that a
        raster's cell-to-cell noise does not drive the mesh. Rasters: the exact area-weighted mean
        of the cells over the square clipped to the raster (`means.raster_box_means`, a
        summed-area table); a square that misses the raster is refused. Formulas and callables: a
        4 × 4 Gauss–Legendre rule over the square (`means.gauss_box_means`), Q checked at its
        points."""
        A = _points(P)
        try:
            h = np.broadcast_to(np.asarray(half_width, dtype=float), (len(A),))
        except (TypeError, ValueError):
            raise QmeshError(f"half_width must be a number or an array of shape ({len(A)},), "
                             f"got {np.shape(half_width)}") from None
        bad = ~(np.isfinite(h) & (h > 0))
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise QmeshError(f"half_width must be finite and > 0, got {h[k]} at point {k}")
        if self._constant is not None:
            return _m.full_tensors(np.broadcast_to(self._constant, (len(A), 3)))
        if self._raster is not None:
            assert self.bounds is not None
            lo, hi = self.bounds
            miss = ((A[:, 0] + h <= lo[0]) | (A[:, 0] - h >= hi[0])
                    | (A[:, 1] + h <= lo[1]) | (A[:, 1] - h >= hi[1]))
            if miss.any():
                k = int(np.flatnonzero(miss)[0])
                raise QmeshError(f"the square of half-width {h[k]:g} around {_point(A[:, 0], A[:, 1], k)} "
                                 f"does not meet the {self.label} [{lo[0]:g}, {hi[0]:g}] × "
                                 f"[{lo[1]:g}, {hi[1]:g}]")
            return _m.full_tensors(_m.raster_box_means(self._raster, A, np.array(h)))
        return _m.full_tensors(_m.gauss_box_means(self._evaluate, A, np.array(h)))
