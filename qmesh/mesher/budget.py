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

import numpy as np

from qmesh.errors import QmeshError

BYTES_PER_VERTEX = {False: 600, True: 1600}
"""Peak bytes per vertex of `qmesh.mesh` (constant s: False, varying s: True), rounded up from
the largest figure `python benchmarks/bench_memory.py` measures on Disk(256) at N = 4e5, 1e6 and
2e6: 557, 531 and 510 for the constant Q (2.95), 1479 and 1230 for s = exp(x) + y² (at 1e6; the
figure falls as N grows, the run's fixed part spread over more vertices)."""
FIXED_BYTES = 128 * 2**20
"""Working memory of any run, whatever N (the first triangulation, caches, Qhull's buffers): it
covers the small runs' figures (varying s at N = 1e4: 101 MB above the baseline)."""
DEFAULT_FRACTION = 0.5
"""Share of the available memory a request may use when no budget is given."""
LIMIT_FRACTION = 0.8
"""Share of what a process limit (RLIMIT_AS, a memory cgroup) leaves that a request may use: the
address space also holds what a run maps without touching, so not all of it."""


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


def status_bytes(field: str) -> int | None:
    """A size field of /proc/self/status (VmSize:, VmRSS:) in bytes, or None."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith(field):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _read_int(path: str) -> int | None:
    try:
        with open(path, encoding="ascii") as f:
            text = f.read().strip()
    except OSError:
        return None
    return int(text) if text.isdigit() else None    # "max" (cgroup v2): no limit


def _cgroup_dirs() -> list[str]:
    """The memory cgroup folders of this process (v2's unified one, v1's memory controller)."""
    out = []
    try:
        with open("/proc/self/cgroup", encoding="ascii") as f:
            lines = f.read().splitlines()
    except OSError:
        return out
    for line in lines:
        parts = line.split(":", 2)
        if len(parts) != 3:
            continue
        _, controllers, rel = parts
        rel = rel.lstrip("/")
        if controllers == "":
            out.append(os.path.join("/sys/fs/cgroup", rel))
        elif "memory" in controllers.split(","):
            out.append(os.path.join("/sys/fs/cgroup/memory", rel))
    return out


def process_limits() -> list[tuple[int, str]]:
    """(bytes still free under the limit, the limit named) for each limit set on this process:
    the address-space limit (RLIMIT_AS, `ulimit -v`, `prlimit --as`) less the address space in
    use, and a memory cgroup's limit (v2 memory.max, v1 memory.limit_in_bytes) less its usage.
    Empty when no limit is set."""
    out: list[tuple[int, str]] = []
    try:
        import resource
        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        unlimited = resource.RLIM_INFINITY
    except (ImportError, OSError, ValueError, AttributeError):   # not a POSIX system
        soft = unlimited = -1
    if soft != unlimited and soft > 0:
        used = status_bytes("VmSize:") or 0
        out.append((max(0, soft - used), f"the process's address-space limit (RLIMIT_AS, ulimit -v) of "
                    f"{_gib(soft)}, {_gib(used)} of it in use"))
    for folder in _cgroup_dirs():
        for limit_file, usage_file in (("memory.max", "memory.current"),
                                       ("memory.limit_in_bytes", "memory.usage_in_bytes")):
            limit = _read_int(os.path.join(folder, limit_file))
            if limit is None or limit >= 2**60:          # v1's "no limit" is a huge number
                continue
            used = _read_int(os.path.join(folder, usage_file)) or 0
            out.append((max(0, limit - used), f"the memory cgroup's limit ({limit_file}) of {_gib(limit)}, "
                        f"{_gib(used)} of it in use"))
    return out


def default_budget_of() -> tuple[int, str]:
    """The budget when none is given, and what set it: DEFAULT_FRACTION of the available memory,
    or LIMIT_FRACTION of what a process limit (`process_limits`) leaves, whichever is smaller."""
    best = (int(DEFAULT_FRACTION * available_bytes()), "half the memory available now")
    for free, what in process_limits():
        if int(LIMIT_FRACTION * free) < best[0]:
            best = (int(LIMIT_FRACTION * free), f"{int(100 * LIMIT_FRACTION)}% of what {what} leaves")
    return best


def default_budget() -> int:
    """The budget when none is given (`default_budget_of`)."""
    return default_budget_of()[0]


def _gib(n: float) -> str:
    return f"{n / 2**30:.2f} GiB" if n < 10 * 2**30 else f"{n / 2**30:.0f} GiB"


def check(n_vertices, *, varying: bool, budget: int | None = None, what: str | None = None,
          field: bool = False) -> int:
    """Raise QmeshError when meshing `n_vertices` would need more than `budget` bytes (default:
    `default_budget_of`: half the memory available now, or less under a process limit);
    otherwise return the estimate in bytes. `what` names the input that implies the count;
    `field`: the conductivity is a tensor field (no s), as the message then says."""
    need = estimate_bytes(n_vertices, varying=varying)
    if budget is None:
        budget, whose = default_budget_of()
    else:
        try:
            budget = int(budget)
        except (TypeError, ValueError, OverflowError):
            raise QmeshError(f"budget must be a number of bytes, got {budget!r}") from None
        if budget <= 0:
            raise QmeshError(f"budget must be > 0 bytes, got {budget}")
        whose = "the memory budget"
    if need > budget:
        kind = "a field" if field else "a varying s" if varying else "a constant s"
        most = max_vertices(budget, varying=varying)
        advice = (f"ask for fewer vertices (at most about {most:.3g})" if most >= 3 else
                  f"any run needs about {_gib(FIXED_BYTES)}, so give a larger budget")
        count = f"{float(n_vertices):.3g} vertices with {kind} need"
        if what:
            count = f"{what} implies {float(n_vertices):.3g} vertices, which with {kind} need"
        raise QmeshError(f"{count} about {_gib(need)} of memory, more than {whose} ({_gib(budget)}); {advice}")
    return need


def max_vertices(budget: int, *, varying: bool) -> int:
    """The largest vertex count whose estimate fits in `budget` bytes (0 if none does)."""
    return max(0, int((int(budget) - FIXED_BYTES) // BYTES_PER_VERTEX[bool(varying)]))
