"""What the stage on screen changed, in one line for the mesh view's legend.

On the chapter's case most stages move the vertices by a few hundredths of an element, too
little to see: the line says how many moved and how far, how many points were inserted, how many
edges a re-triangulation flipped, read from the Step's own statistics (`qmesh.Step.stats`).
"""

from __future__ import annotations

import numpy as np


def moved_vertices(step) -> int | None:
    """How many vertices an adjust stage moved (None when the Step does not record its moves)."""
    if step.moved is None:
        return None
    return int(np.count_nonzero(np.any(np.asarray(step.moved) != 0.0, axis=1)))


def what_changed(step) -> str:
    """One line: "adjust: 120 vertices moved, rms 0.043 of an element (largest 0.11)",
    "insert: +11 points", "triangulate: 5 edges flipped", "first triangulation: 201 vertices".
    A medium's faces record no moves, insertions or flips: their line gives N."""
    st, n = step.stats, step.stats.n_vertices
    if step.stage == "triangulate" and step.iteration == 0:
        return f"first triangulation: {n} vertices"
    if step.stage == "adjust":
        moved = moved_vertices(step)
        if moved is None:
            return f"adjust: moves not recorded (N = {n})"
        if moved == 0:
            return "adjust: no vertex moved"
        return (f"adjust: {moved} vertices moved, rms {st.rms_move:.2g} of an element "
                f"(largest {st.max_move:.2g})")
    if step.stage == "insert":
        added = st.added or (0 if step.added is None else len(step.added))
        return f"insert: +{added} points (N = {n})" if added else f"insert: none needed (N = {n})"
    if st.flips:
        return f"{step.stage}: {st.flips} edges flipped to keep the mesh Q-Delaunay"
    return f"{step.stage}: no edge flipped (N = {n})"
