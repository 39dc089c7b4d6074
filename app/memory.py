"""What a whole viewer request costs in memory, and its refusal before anything is allocated.

`qmesh.mesher.budget` counts `qmesh.mesh` alone. A request in the viewer costs more: the run
keeps every Step of its history, the status line measures every stage (κ2 factorises the
stiffness matrix), and the three views build and render their scenes. And while it is built the
run on screen (its history, its scenes) is still held, so that a refusal leaves it in place.
`benchmarks/bench_view_memory.py` measures a request run to its end in a fresh process, every
stage measured and drawn as the app does; the figures below are its largest per vertex, rounded
up.

The budget is the memory the whole process may hold (`--memory-budget`): a request fits when
its cost and what the process holds now (resident: the interpreter, VTK, the run on screen) stay
within it. Without a budget, `qmesh.mesher.budget.default_budget_of` says what may be used (half
the memory available, or less under a process limit), already net of what is in use. Under an
address-space limit (RLIMIT_AS) the request's address space is counted, not its resident pages:
a run maps much more than it touches.
"""

from __future__ import annotations

from qmesh.errors import QmeshError
from qmesh.mesher import budget

BYTES_PER_VERTEX = {"constant": 5600, "varying": 6000, "medium": 6000, "field": 7500}
"""Peak resident bytes per vertex of a whole request (the run to its end, every stage kept,
measured and drawn), by kind of conductivity, rounded up from the largest figure
`python benchmarks/bench_view_memory.py` measured at N = 5e4, 1e5 and 2e5: constant Q 5,120 (the
mesher alone 840), s = exp(x) + y² 5,754, the inclusion medium 5,479, the rotating field 7,116
(about 2,400 of each are the views' scenes, about 1,000 the kept stages)."""
VIRTUAL_BYTES_PER_VERTEX = {"constant": 10000, "varying": 10000, "medium": 10000, "field": 12000}
"""The same for the address space (VmPeak), what RLIMIT_AS counts: 9,178, 9,593, 9,658 and
11,208 measured."""
FIXED_BYTES = 96 * 2**20
"""What any request adds whatever its size (the first triangulation's working arrays, the
mesher's and the views' caches): covers the small requests' figures."""
VIEWS_BASE_BYTES = 320 * 2**20
"""Resident memory that loading the views (VTK, trame, three plotters, their first render: 311 MiB
measured) adds to a process; counted when the views are not loaded yet (the command line checks
its first request before it loads them)."""


def kind_of(p) -> str:
    """"medium", "field", "varying" (s as text) or "constant": the row of the figures above."""
    from .problem import is_field, is_medium
    if is_medium(p):
        return "medium"
    if is_field(p):
        return "field"
    return "varying" if p.q_mode == "expression" else "constant"


def request_bytes(n_vertices: int, kind: str, *, virtual: bool = False) -> int:
    """Estimated peak memory of a request of `n_vertices` vertices (its address space when
    `virtual`)."""
    per = (VIRTUAL_BYTES_PER_VERTEX if virtual else BYTES_PER_VERTEX)[kind]
    return int(FIXED_BYTES + per * max(0, int(n_vertices)))


def largest_target(room: int, kind: str, *, virtual: bool = False) -> int:
    """The largest vertex count whose request fits in `room` bytes (0 if none)."""
    per = (VIRTUAL_BYTES_PER_VERTEX if virtual else BYTES_PER_VERTEX)[kind]
    return max(0, int((room - FIXED_BYTES) // per))


def held_bytes() -> int:
    """Resident memory of this process now (VmRSS), with the views' own when not loaded yet."""
    import sys
    views = 0 if "vtkmodules" in sys.modules else VIEWS_BASE_BYTES
    return (budget.status_bytes("VmRSS:") or 0) + views


def _address_space_limit() -> int | None:
    try:
        import resource
        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft != resource.RLIM_INFINITY and soft > 0:
            return int(soft)
    except (ImportError, OSError, ValueError, AttributeError):
        pass
    return None


def rooms(memory_budget: int | None) -> list[tuple[int, bool, str]]:
    """(bytes a request may use, whether they are address space, what sets them) for each
    bound in force: the budget given (less what the process holds) or, without one, the
    default's share of the available memory; an address-space limit; a memory cgroup."""
    out: list[tuple[int, bool, str]] = []
    held = held_bytes()
    if memory_budget is not None:
        out.append((int(memory_budget) - held, False,
                    f"the memory budget ({gib(memory_budget)}) less the {gib(held)} the viewer holds now"))
    else:
        out.append((int(budget.DEFAULT_FRACTION * budget.available_bytes()), False,
                    "half the memory available now"))
    limits = budget.process_limits()
    limit = _address_space_limit()
    if limit is not None and limits:                 # process_limits lists RLIMIT_AS first
        free, what = limits.pop(0)
        out.append((int(budget.LIMIT_FRACTION * free), True,
                    f"{int(100 * budget.LIMIT_FRACTION)}% of what {what} leaves"))
    for free, what in limits:
        out.append((int(budget.LIMIT_FRACTION * free), False,
                    f"{int(100 * budget.LIMIT_FRACTION)}% of what {what} leaves"))
    return out


def check(n_vertices: int, kind: str, memory_budget: int | None = None) -> int:
    """Refuse (QmeshError) a request of `n_vertices` vertices whose whole cost exceeds any bound
    of `rooms`, naming the bound and the largest target that fits; else return its resident
    estimate in bytes."""
    if memory_budget is not None and int(memory_budget) <= 0:
        raise QmeshError(f"the memory budget must be > 0 bytes, got {memory_budget}")
    need = request_bytes(n_vertices, kind)
    for room, virtual, what in rooms(memory_budget):
        cost = request_bytes(n_vertices, kind, virtual=virtual)
        if cost > room:
            most = _round_down(largest_target(room, kind, virtual=virtual))
            advice = (f"the largest target that fits is about {most}" if most >= 3 else
                      "no target fits: give a larger budget")
            space = "address space" if virtual else "memory"
            raise QmeshError(
                f"a target of {float(n_vertices):.3g} vertices ({kind_label(kind)}) would need about "
                f"{gib(cost)} of {space} in the viewer (the mesher, its kept stages, the measures "
                f"and the views), more than {what} ({gib(max(room, 0))} left); {advice}")
    return need


def _round_down(n: int) -> int:
    """`n` rounded down to 3 significant digits (a target to type, safely under the bound)."""
    if n < 1000:
        return n
    step = 10 ** (len(str(n)) - 3)
    return n // step * step


def kind_label(kind: str) -> str:
    return {"constant": "constant Q", "varying": "s as text", "medium": "a medium",
            "field": "a field"}[kind]


def gib(n: float) -> str:
    """Bytes as GiB, two decimals below 10 GiB."""
    return f"{n / 2**30:.2f} GiB" if abs(n) < 10 * 2**30 else f"{n / 2**30:.0f} GiB"


__all__ = ["BYTES_PER_VERTEX", "VIRTUAL_BYTES_PER_VERTEX", "FIXED_BYTES", "VIEWS_BASE_BYTES",
           "kind_of", "request_bytes", "largest_target", "held_bytes", "rooms", "check"]
