"""The options of `qmesh.mesh` and `qmesh.iterate`: one frozen record, checked before any work.

`Options.checked` refuses a wrong type, None where a value is needed, a bool given for a number,
NaN, ±inf and absurdly large values, each with a QmeshError naming the option and the value
received. `check_keywords` names any keyword the mesher does not know.
"""

from __future__ import annotations

import inspect
from dataclasses import asdict, dataclass

from qmesh import checks
from qmesh.mesher import sizing
from qmesh.errors import QmeshError

MAX_ITERATIONS = 1_000_000
"""Cap on max_iterations: the loop converges in tens of iterations; more is a mistake."""


@dataclass(frozen=True)
class Options:
    """The options of one run, as `iterate` documents them (its defaults are these)."""

    target_vertices: int | None = None
    size: float | None = None
    alpha: float = 0.5
    quality_threshold: float = 0.5
    min_area: float | None = None
    max_iterations: int = 40
    seed: int | None = 0
    boundary_refinement: bool = True

    @classmethod
    def checked(cls, **values) -> "Options":
        """The record of `values`, or QmeshError naming the first option that is unusable."""
        options = cls(**values)
        _check(**asdict(options))
        return options


def _check(target_vertices, size, alpha, quality_threshold, min_area, max_iterations,
           seed, boundary_refinement) -> None:
    """Raise QmeshError unless every option has a usable type and value."""
    checks.integer(target_vertices, "target_vertices", low=1, none=True)
    checks.real(size, "size", low=0.0, low_open=True, none=True)
    if target_vertices is not None and size is not None:
        raise QmeshError("give either target_vertices or size, not both")
    if target_vertices is not None:
        n = min(int(target_vertices), 10**300)      # a float even for 10**400
        sizing.check_vertex_count(float(n), f"target_vertices = {n:.3g}" if n > 10**15
                                  else f"target_vertices = {n}")
    checks.real(alpha, "alpha", low=0.0, high=1.0, low_open=True)
    checks.real(quality_threshold, "quality_threshold", low=0.0, high=1.0, high_open=True)
    checks.real(min_area, "min_area", low=0.0, none=True)
    checks.integer(max_iterations, "max_iterations", low=0, high=MAX_ITERATIONS)
    checks.integer(seed, "seed", low=0, none=True)
    checks.boolean(boundary_refinement, "boundary_refinement")


def check_keywords(given: dict, function, where: str) -> None:
    """Raise QmeshError naming the keywords in `given` that `function` does not take."""
    known = [p.name for p in inspect.signature(function).parameters.values()
             if p.kind is inspect.Parameter.KEYWORD_ONLY]
    unknown = sorted(set(given) - set(known))
    if unknown:
        raise QmeshError(f"{where}() got unknown option{'s' if len(unknown) > 1 else ''} "
                         f"{', '.join(map(repr, unknown))}; its options are {', '.join(known)}")
