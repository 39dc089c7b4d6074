"""Validators for the arguments of qmesh's public functions.

Each one checks one argument where it is given and raises `QmeshError` whose message names the
argument and shows the value received, so a NaN, an infinity, a huge number, a string, a bool or
a None is refused with the same kind of error wherever it enters. Each returns
the value in the form the caller computes with (a float, an int, a float array…).
"""

from __future__ import annotations

import numbers
from collections.abc import Iterable, Mapping
from typing import Any, Literal, TypeVar, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from qmesh.errors import QmeshError
from qmesh.geometry.portable import eigvalsh2

_F = TypeVar("_F")

_EPS = np.finfo(float).eps


def describe(value: object) -> str:
    """A short text of `value` for an error message: its repr (cut at 60 characters) and type."""
    if isinstance(value, np.ndarray) and value.size > 4:
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    if value is None or isinstance(value, (bool, np.bool_, float, int)):
        return text
    return f"{text} ({type(value).__name__})"


def _bounds_text(low: float | None, high: float | None, low_open: bool, high_open: bool) -> str:
    if low is not None and high is not None:
        return f"in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
    if low is not None:
        return f"a finite number {'>' if low_open else '>='} {low:g}"
    if high is not None:
        return f"a finite number {'<' if high_open else '<='} {high:g}"
    return "a finite number"


def _scalar(value: Any, name: str, wanted: str, kinds: type | tuple[type, ...], none: bool) -> Any:
    """`value` unwrapped from a 0-d array; None passes when `none`; a bool or anything not of
    `kinds` is refused."""
    if value is None:
        if none:
            return None
        raise QmeshError(f"{name} must be {wanted}, got None")
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, kinds):
        raise QmeshError(f"{name} must be {wanted}, got {describe(value)}")
    return value


@overload
def real(value: object, name: str, *, low: float | None = ..., high: float | None = ...,
         low_open: bool = ..., high_open: bool = ..., none: Literal[False] = ...) -> float: ...
@overload
def real(value: object, name: str, *, low: float | None = ..., high: float | None = ...,
         low_open: bool = ..., high_open: bool = ..., none: bool) -> float | None: ...


def real(value: Any, name: str, *, low: float | None = None, high: float | None = None,
         low_open: bool = False, high_open: bool = False, none: bool = False) -> float | None:
    """`value` as a finite float within the bounds (open or closed); None passes when `none`.

    Refused: bools, strings, complex numbers, arrays of more than one value, NaN, ±inf, numbers
    too large for a float, and values outside the bounds.
    """
    wanted = _bounds_text(low, high, low_open, high_open)
    value = _scalar(value, name, wanted, numbers.Real, none)
    if value is None:
        return None
    try:
        x = float(value)
    except (OverflowError, ValueError, TypeError):
        raise QmeshError(f"{name} must be {wanted}, got {describe(value)} (too large for a float)") from None
    if not np.isfinite(x):
        raise QmeshError(f"{name} must be {wanted}, got {x}")
    if low is not None and (x <= low if low_open else x < low):
        raise QmeshError(f"{name} must be {wanted}, got {value!r}")
    if high is not None and (x >= high if high_open else x > high):
        raise QmeshError(f"{name} must be {wanted}, got {value!r}")
    return x


@overload
def integer(value: object, name: str, *, low: int | None = ..., high: int | None = ...,
            none: Literal[False] = ...) -> int: ...
@overload
def integer(value: object, name: str, *, low: int | None = ..., high: int | None = ...,
            none: bool) -> int | None: ...


def integer(value: Any, name: str, *, low: int | None = None, high: int | None = None,
            none: bool = False) -> int | None:
    """`value` as a Python int within [low, high]; None passes when `none`.

    Only ints and NumPy integers are accepted: a float (even 3.0), a bool, a string, NaN or inf
    is refused, as is anything above `high` (10**30 as a vertex count, say).
    """
    wanted = ("an integer" + (f" >= {low}" if low is not None else "")
              + (f" and <= {high:g}" if high is not None else ""))
    value = _scalar(value, name, wanted, (int, np.integer), none)
    if value is None:
        return None
    n = int(value)
    if (low is not None and n < low) or (high is not None and n > high):
        shown = repr(n) if abs(n) < 10**15 else f"about {float(min(abs(n), 10**300)):.3g}"
        raise QmeshError(f"{name} must be {wanted}, got {shown}")
    return n


def boolean(value: object, name: str) -> bool:
    """`value` as a bool; only True, False and NumPy bools are accepted (not 0, 1 or "yes")."""
    if not isinstance(value, (bool, np.bool_)):
        raise QmeshError(f"{name} must be True or False, got {describe(value)}")
    return bool(value)


def function(value: _F, name: str) -> _F:
    """`value` itself when it is callable."""
    if not callable(value):
        raise QmeshError(f"{name} must be a callable, got {describe(value)}")
    return value


def text(value: object, name: str) -> str:
    """`value` when it is a str."""
    if not isinstance(value, str):
        raise QmeshError(f"{name} must be a string, got {describe(value)}")
    return value


def choice(value: object, name: str, options: Iterable[str]) -> str:
    """`value` when it is one of the strings `options`."""
    if not isinstance(value, str) or value not in options:
        listed = ", ".join(repr(o) for o in options)
        raise QmeshError(f"{name} must be one of {listed}, got {describe(value)}")
    return value


_KINDS = {"b": "a boolean", "c": "a complex", "M": "a datetime64", "m": "a timedelta64",
          "U": "a string", "S": "a bytes", "O": "an object", "V": "a structured"}


def real_dtype(dtype: Any, name: str) -> np.dtype:
    """`dtype` when it holds real numbers (integers or floats); else QmeshError naming `name` and
    what it holds ("a complex array (dtype complex128)"): a cast would drop an imaginary part,
    turn dates into counts or booleans into 0 and 1 without a word."""
    dtype = np.dtype(dtype)
    if dtype.kind not in "iuf" or dtype.names is not None:
        raise QmeshError(f"{name} must hold real numbers, got {_KINDS.get(dtype.kind, 'a non-numeric')} "
                         f"array (dtype {dtype})")
    return dtype


def real_values(value: ArrayLike, name: str) -> NDArray[np.float64]:
    """`value` (a number or an array) as floats, refusing by name what a cast would change
    silently (`real_dtype`) and Python integers beyond any float."""
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as e:
        raise QmeshError(f"{name} must be a number or an array of real numbers: {e}") from None
    if raw.dtype.kind == "O":                         # Python ints beyond int64 are held as objects
        try:
            return np.asarray(raw, dtype=float)
        except OverflowError:
            raise QmeshError(f"{name} holds an integer beyond any float") from None
        except (TypeError, ValueError):
            pass                                      # not numbers: refused by their kind below
    real_dtype(raw.dtype, name)
    return raw.astype(float, copy=False)       # floats as given: a raster is not held twice


def real_array(value: ArrayLike, name: str, shape: tuple[int | None, ...]) -> NDArray[np.float64]:
    """`value` as a finite float array of `shape` (None in `shape` matches any length).

    Refused: strings, objects, complex and bool arrays, ragged lists, wrong shapes, NaN and ±inf
    (the message gives the first offending row).
    """
    wanted = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
    try:
        raw = np.asarray(value)
    except (ValueError, TypeError) as e:
        raise QmeshError(f"{name} must be an array of real numbers of shape {wanted}: {e}") from None
    if raw.dtype.kind not in "iuf":
        raise QmeshError(f"{name} must be an array of real numbers of shape {wanted}, "
                         f"got {describe(value)} (dtype {raw.dtype})")
    if raw.ndim != len(shape) or any(s is not None and s != r for s, r in zip(shape, raw.shape)):
        raise QmeshError(f"{name} must have shape {wanted}, got shape {raw.shape}")
    A = raw.astype(float)
    bad = ~np.isfinite(A)
    if bad.any():
        first = np.unravel_index(np.flatnonzero(bad)[0], A.shape)
        where = f" at row {first[0]}" if A.ndim > 1 else ""
        raise QmeshError(f"{name} has non-finite entries{where}: {A[first[0]].tolist()}")
    return A


def spd_matrix(value: ArrayLike, name: str) -> NDArray[np.float64]:
    """`value` as a symmetric positive definite 2x2 float matrix (symmetrised).

    The test does not depend on the matrix's size: it is made on Q / max|Q_ij|, so 1e-200·I and
    1e200·I pass. An eigenvalue ratio below 4 machine epsilons counts as singular: at that
    ratio the smaller eigenvalue is round-off.
    """
    Q = real_array(value, name, (2, 2))
    m = np.abs(Q).max()
    if m == 0.0:
        raise QmeshError(f"{name} must be symmetric positive definite, got the zero matrix")
    Qn = Q / m
    if abs(Qn[0, 1] - Qn[1, 0]) > 1e-12 * max(abs(Qn[0, 1]), abs(Qn[1, 0])) + 1e-14:
        raise QmeshError(f"{name} must be symmetric, got {Q.tolist()}")
    Qn = 0.5 * (Qn + Qn.T)
    lo, hi = eigvalsh2(Qn)
    if lo <= 4 * _EPS * hi:
        raise QmeshError(f"{name} must be symmetric positive definite, got {Q.tolist()} "
                         f"(eigenvalues in the ratio {lo / hi:.3g})")
    return 0.5 * Q + 0.5 * Q.T


def _is(value: object, qualified: str) -> bool:
    """`value` is an instance of the class named `qualified` (module.Class), found by name so
    that checks imports none of the types it checks (they import checks)."""
    return any(f"{c.__module__}.{c.__qualname__}" == qualified for c in type(value).__mro__)


def anisotropy(value: Any, name: str = "anisotropy") -> Any:
    """`value` when it is a qmesh.Anisotropy (an array or a list is not: it says how to make one)."""
    if _is(value, "qmesh.conductivity.anisotropy.Anisotropy"):
        return value
    hint = (" (for a constant matrix Q use qmesh.Anisotropy.constant(Q))"
            if isinstance(value, (np.ndarray, list, tuple)) else "")
    raise QmeshError(f"{name} must be a qmesh.Anisotropy, got {describe(value)}{hint}")


def anisotropy_or_none(value: Any, name: str = "anisotropy") -> Any:
    """`value` when it is a qmesh.Anisotropy or None (None: the Laplacian, Q = I)."""
    return None if value is None else anisotropy(value, name)


def mesh(value: Any, name: str = "mesh") -> Any:
    """`value` when it is a qmesh.Mesh (whose constructor refused non-finite coordinates)."""
    if not _is(value, "qmesh.triangle_mesh.Mesh"):
        raise QmeshError(f"{name} must be a qmesh.Mesh, got {describe(value)}")
    return value


def tag_names(value: Mapping[Any, Any], name: str, tags: range | None = None) -> dict[int, str]:
    """A mapping integer tag → name (boundary tags, regions), or QmeshError naming the entry;
    with `tags`, every key must be one of them."""
    out: dict[int, str] = {}
    for k, v in value.items():
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not isinstance(v, str):
            raise QmeshError(f"{name} must map integer tags to strings, got {k!r}: {v!r}")
        if tags is not None and int(k) not in tags:
            raise QmeshError(f"{name} names region {k}; the tags are {tags.start} to {tags.stop - 1}")
        out[int(k)] = v
    return out


def polygon_list(value: Any, name: str) -> list[Any]:
    """`value` as a list of polygons (holes, regions): a sequence, not an array or a string."""
    if value is None or isinstance(value, (str, bytes, np.ndarray)):
        raise QmeshError(f"{name} must be a list of polygons, got {type(value).__name__}")
    try:
        return list(value)
    except TypeError:
        raise QmeshError(f"{name} must be a list of polygons, got {type(value).__name__}") from None
