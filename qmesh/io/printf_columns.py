"""Rows of numbers as printf's `%d` and `%.17g` write them, built by NumPy passes.

Formatting every number with Python's `%` operator costs a microsecond or so a number, most of
the time a million-vertex `.msh` takes to write. Here each number becomes a row of a byte
matrix (one column per possible character, unused ones NUL), a chunk of rows at a time, and
the matrix without its NULs is the text: the SAME text as `"%d" % v` and `"%.17g" % v`.

`%.17g` is the exact binary value rounded to 17 significant digits. With an x87 80-bit long
double (64-bit mantissa), y = |v|·10^k (10^k exact for |k| ≤ 27) is rounded once, by at most
half a unit in its last place: 2^-8 at y < 10^17 < 2^57. Its nearest integer is those 17
digits unless y's fraction lies within 1/128 of one half, or y lies outside [10^16, 10^17) or
rounds up to 10^17 (v near a power of ten, where log10 may miss the exponent by one). Those
numbers, non-finite ones, those outside [1e-11, 1e43), and every number where long double has
no 64-bit mantissa are formatted by Python's `%` and put in their rows.
"""

from __future__ import annotations

import numpy as np

CHUNK = 16384
"""Rows per matrix: a few MB at a time, whatever the mesh's size."""

_LONG = np.finfo(np.longdouble).nmant >= 63        # x87 extended precision: the fast route
_K = 27                                            # 10**27 < 2**64: exact in a 64-bit mantissa
_POW10 = [np.longdouble(1)]
for _ in range(_K):
    _POW10.append(_POW10[-1] * 10)                 # each product exact: no rounding on the way
_POW10 = np.array(_POW10, dtype=np.longdouble)
_LOW, _HIGH = -11, 42                              # the decimal exponents of the fast route
_MARGIN = 1 / 128                                  # fraction this close to 1/2: Python decides
_WIDTH = 28                                        # columns of a float's characters


def _group_tables() -> tuple[np.ndarray, np.ndarray]:
    """Four characters per group of four digits: zero-padded (rows 0…9999), and without the
    leading zeros of a number's first group (rows 10000…19999: NULs instead; 0 is "0" in the
    last group's table, no characters in the other)."""
    pad = "".join(f"{g:04d}" for g in range(10_000))
    first = "".join(str(g).rjust(4, "\0") for g in range(10_000))
    tables = [np.frombuffer((pad + first).encode(), np.uint8).reshape(-1, 4).copy()
              for _ in range(2)]
    tables[0][10_000] = 0                          # an inner group: a leading 0000 is nothing
    return tables[0], tables[1]


_INNER, _LAST = _group_tables()
_INNER32, _LAST32 = _INNER.view(np.uint32).ravel(), _LAST.view(np.uint32).ravel()
_TRAILING = np.array([4 - len(f"{g:04d}".rstrip("0")) for g in range(10_000)], np.int64)


def _float_layouts() -> tuple[np.ndarray, np.ndarray]:
    """For each decimal exponent X in [_LOW, _HIGH] and count of significant digits u (17 at
    most, trailing zeros dropped), row (X - _LOW)·17 + u - 1: the characters `%.17g` puts
    around the digits (sign aside), and which of digits 1…16 it writes. Columns: sign | "0." |
    three zeros | d0, a point, d1 … d16 | "e" ± and two exponent digits; a number of 1 or more
    in fixed notation has its point after digit X (`_BIG_ORDER`)."""
    template = np.zeros(((_HIGH - _LOW + 1) * 17, _WIDTH), np.uint8)
    keep = np.zeros((len(template), 17), np.uint8)         # digit 0 is always written
    for X in range(_LOW, _HIGH + 1):
        for used in range(1, 18):
            row, t = (X - _LOW) * 17 + used - 1, template[(X - _LOW) * 17 + used - 1]
            if -4 <= X < 0:                        # 0.000ddd
                t[1:3] = b"0."[0], b"0."[1]
                t[3:3 - X - 1] = ord("0")
                keep[row, :used] = 1
            elif 0 <= X < 17:                      # ddd.ddd, or ddd
                keep[row, :max(used, X + 1)] = 1
            else:                                  # d.ddde±XX
                keep[row, :used] = 1
                if used > 1:
                    t[7] = ord(".")
                t[24:28] = np.frombuffer(f"e{X:+03d}".encode(), np.uint8)
    return template, keep[:, 1:].copy()


_BIG_ORDER = np.array([list(range(X + 1)) + [17] + list(range(X + 1, 17)) for X in range(17)])
"""Columns 6…23 of a number ≥ 1 in fixed notation: digits 0…X, the point (17), the others."""
_TEMPLATE, _KEEP = _float_layouts()


def write_rows(f, parts, n: int) -> None:
    """Write `n` rows to the binary file `f`: `parts` are bytes written as they are (separators,
    constant columns) and 1-D arrays of n numbers, integer dtypes as `%d`, floats as `%.17g`."""
    for start in range(0, n, CHUNK):
        stop = min(start + CHUNK, n)
        blocks = [np.broadcast_to(np.frombuffer(p, np.uint8), (stop - start, len(p)))
                  if isinstance(p, bytes) else _chars(np.asarray(p)[start:stop]) for p in parts]
        M = np.hstack(blocks).ravel()
        f.write(np.compress(M != 0, M).tobytes())


def _chars(a: np.ndarray) -> np.ndarray:
    """The characters of each number of `a` as a row of a uint8 matrix, NUL where none."""
    if a.dtype.kind in "iub":
        if a.dtype.kind == "u" and a.size and a.max() > np.iinfo(np.int64).max:
            return _python_chars(a, "%d")                  # beyond int64: Python's text
        return int_chars(a.astype(np.int64))
    return float17_chars(a.astype(np.float64))


def int_chars(a: np.ndarray) -> np.ndarray:
    """`"%d" % v` for each v of the int64 array `a`, one row of characters each."""
    if a.size and a.min() == np.iinfo(np.int64).min:       # |v| does not fit: Python's text
        return _python_chars(a, "%d")
    rest = np.abs(a)
    width = len(str(int(rest.max()))) if a.size else 1
    if width < 10:
        rest = rest.astype(np.int32)                       # the same digits, quicker arithmetic
    groups = -(-width // 4)                                # 4-digit groups, 4 characters a uint32
    out = np.empty((len(a), groups), np.uint32)
    for g in range(groups - 1, -1, -1):                    # the last group first
        above = rest // 10_000
        index = rest - above * 10_000 + (above == 0) * 10_000    # the number's first group: no zeros ahead
        out[:, g] = np.take(_LAST32 if g == groups - 1 else _INNER32, index)
        rest = above
    # without the leading columns no row uses
    chars = out.view(np.uint8)[:, 4 * groups - width:]
    if a.size and a.min() < 0:
        return np.concatenate([((a < 0) * ord("-")).astype(np.uint8)[:, None], chars], axis=1)
    return chars


def float17_chars(x: np.ndarray) -> np.ndarray:
    """`"%.17g" % v` for each v of the float64 array `x`, one row of characters each."""
    n = len(x)
    a = np.abs(x)
    fast = (np.isfinite(a) & (a >= 10.0 ** _LOW) & (a < 10.0 ** (_HIGH + 1)) if _LONG
            else np.zeros(n, bool))
    a = np.where(fast, a, 1.0)                             # no inf, nan or 0 in the arithmetic
    X = np.floor(np.log10(a)).astype(np.int64)            # the exponent, but near a power of ten
    k = 16 - X                                             # y = |x|·10^k: 17 digits before its point
    y = a.astype(np.longdouble) * _POW10[np.maximum(k, 0)]
    if (k < 0).any():
        y /= _POW10[np.maximum(-k, 0)]
    whole = y.astype(np.int64)                             # y ≥ 1 > 0: truncation is the floor
    frac = (y - whole.astype(np.longdouble)).astype(np.float64)
    r = whole + (frac > 0.5)
    fast &= (np.abs(frac - 0.5) > _MARGIN) & (whole >= 10 ** 16) & (r < 10 ** 17)
    r = np.where(fast, r, 10 ** 16)
    # the 17 digits: the first, then four groups of four (a uint32 of characters each), from
    # two int32 halves of 9 and 8 digits
    high = r // 10 ** 8
    low = (r - high * 10 ** 8).astype(np.int32)
    high = high.astype(np.int32)
    first = (high // 10 ** 8 + ord("0")).astype(np.uint8)
    high = high % 10 ** 8
    groups = np.empty((n, 4), np.int32)
    groups[:, 0], groups[:, 1] = high // 10_000, high % 10_000
    groups[:, 2], groups[:, 3] = low // 10_000, low % 10_000
    tail = np.take(_INNER32, groups).view(np.uint8)        # (n, 16): digits 1…16
    # the significant digits up to the last nonzero one: the last group's zeros, and for the
    # few numbers whose last group is 0000, the groups before it
    used = 17 - np.take(_TRAILING, groups[:, 3])
    rows = np.flatnonzero((groups[:, 3] == 0) & fast)
    if len(rows):
        used[rows] = 1
        for g in range(4):
            group = groups[rows, g]
            used[rows] = np.where(group != 0, 5 + 4 * g - _TRAILING[group], used[rows])
    layout = (np.minimum(np.maximum(X, _LOW), _HIGH) - _LOW) * 17 + used - 1
    out = np.take(_TEMPLATE, layout, axis=0)
    out[:, 0] = np.signbit(x) * ord("-")
    out[:, 6] = first                                      # every number has its first digit
    out[:, 8:24] = tail * np.take(_KEEP, layout, axis=0)
    rows = np.flatnonzero(fast & (X >= 0) & (X < 17))      # ddd.ddd: the point after digit X
    if len(rows):
        point = np.where(used[rows] > X[rows] + 1, ord("."), 0).astype(np.uint8)
        body = np.concatenate([first[rows, None], out[rows, 8:24], point[:, None]], axis=1)
        out[rows, 6:24] = np.take_along_axis(body, _BIG_ORDER[X[rows]], axis=1)
    zero = np.flatnonzero(x == 0)                          # "0", "-0": common enough to be quick
    out[zero, 1:] = 0
    out[zero, 6] = ord("0")
    fast[zero] = True
    slow = np.flatnonzero(~fast)
    if len(slow):
        out[slow] = _python_chars(x[slow], "%.17g", _WIDTH)
    return out


def _python_chars(a: np.ndarray, fmt: str, width: int | None = None) -> np.ndarray:
    """Python's own `fmt % v` of each v, left-aligned in rows of `width` characters."""
    texts = [(fmt % v).encode("ascii") for v in a.tolist()]
    width = max(map(len, texts), default=1) if width is None else width
    return np.frombuffer(b"".join(t.ljust(width, b"\0") for t in texts), np.uint8).reshape(len(a), width)
