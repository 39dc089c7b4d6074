"""How much memory a mesh of N vertices needs, and a refusal before it is allocated.

`qmesh.mesh` and the viewer's session ask `check(n, varying=...)` before meshing, so a request
that cannot fit (a target of 2e7 vertices would otherwise raise MemoryError deep in the mesher)
is refused with a message naming the estimate and the budget, while nothing has been allocated.

The figures are measured, not guessed: `benchmarks/bench_memory.py` runs `qmesh.mesh` in a
fresh process at several N and reports its peak resident memory above the interpreter's
baseline, divided by N. The largest measured figure is used, plus a fixed allowance for the
working arrays every run has whatever its size.
"""

from __future__ import annotations

import os

from qmesh.errors import QmeshError

BYTES_PER_VERTEX = {False: 1300, True: 6600}
"""Peak bytes per vertex of `qmesh.mesh` (constant s: False, varying s: True), rounded up from
the largest figure `python benchmarks/bench_memory.py` measures on Disk(256) at N = 1e4, 1e5 and
4e5 for the constant Q (2.95) and for s = exp(x) + y² (the figures: its page in docs/benchmarks/)."""
FIXED_BYTES = 64 * 2**20
"""Working memory of any run, whatever N (the first triangulation, caches, Qhull's buffers)."""
DEFAULT_FRACTION = 0.5
"""Share of the available memory a request may use when no budget is given."""


def estimate_bytes(n_vertices, *, varying: bool) -> int:
    """Peak memory in bytes of meshing `n_vertices` vertices (constant or varying s)."""
    try:
        n = float(n_vertices)
    except (TypeError, ValueError):
        raise QmeshError(f"n_vertices must be a number, got {n_vertices!r}") from None
    if not n >= 0 or n == float("inf"):
        raise QmeshError(f"n_vertices must be finite and ≥ 0, got {n_vertices!r}")
    return int(FIXED_BYTES + BYTES_PER_VERTEX[bool(varying)] * n)


def available_bytes() -> int:
    """Memory the system can give without swapping: MemAvailable of /proc/meminfo, else the
    free physical pages (os.sysconf), else the total."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024          # kB
    except (OSError, ValueError, IndexError):
        pass
    page = os.sysconf("SC_PAGE_SIZE")
    for name in ("SC_AVPHYS_PAGES", "SC_PHYS_PAGES"):
        try:
            return int(os.sysconf(name)) * int(page)
        except (ValueError, OSError):
            continue
    raise QmeshError("cannot tell how much memory is available on this system")


def default_budget() -> int:
    """The budget when none is given: DEFAULT_FRACTION of the available memory."""
    return int(DEFAULT_FRACTION * available_bytes())


def _gib(n: float) -> str:
    return f"{n / 2**30:.2f} GiB" if n < 10 * 2**30 else f"{n / 2**30:.0f} GiB"


def check(n_vertices, *, varying: bool, budget: int | None = None) -> int:
    """Raise QmeshError when meshing `n_vertices` would need more than `budget` bytes (default:
    half the memory available now); otherwise return the estimate in bytes."""
    need = estimate_bytes(n_vertices, varying=varying)
    if budget is None:
        budget, whose = default_budget(), "half the memory available now"
    else:
        try:
            budget = int(budget)
        except (TypeError, ValueError, OverflowError):
            raise QmeshError(f"budget must be a number of bytes, got {budget!r}") from None
        if budget <= 0:
            raise QmeshError(f"budget must be > 0 bytes, got {budget}")
        whose = "the memory budget"
    if need > budget:
        kind = "a varying" if varying else "a constant"
        most = max_vertices(budget, varying=varying)
        advice = (f"ask for fewer vertices (at most about {most:.3g})" if most >= 3 else
                  f"any run needs about {_gib(FIXED_BYTES)}, so give a larger budget")
        raise QmeshError(f"{float(n_vertices):.3g} vertices with {kind} s need about {_gib(need)} "
                         f"of memory, more than {whose} ({_gib(budget)}); {advice}")
    return need


def max_vertices(budget: int, *, varying: bool) -> int:
    """The largest vertex count whose estimate fits in `budget` bytes (0 if none does)."""
    return max(0, int((int(budget) - FIXED_BYTES) // BYTES_PER_VERTEX[bool(varying)]))
