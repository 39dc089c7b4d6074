"""Stages meshed before they are asked for: a generator wrapped so that its next items can be
computed while the page is idle, and handed over later exactly as if computed then.

The app's worker meshes a small run's next stages while the user looks at the picture, so Step
and Run show them without waiting. Each item is kept with what computing it said — the
warnings it raised, the exception or the end it reached — and `next()` replays them in that
order, so the session sees the same Steps, the same messages and the same errors at the same
action as without meshing ahead.
"""

from __future__ import annotations

import warnings
from collections import deque
from typing import Iterator


class Ahead:
    """An iterator over `source` whose next items `ahead()` computes early."""

    def __init__(self, source: Iterator):
        self._source = source
        self._kept: deque = deque()       # (item or None, exception or None, warnings caught)
        self._over = False                # the source has ended or raised (nothing more ahead)

    def __iter__(self):
        return self

    @property
    def kept(self) -> int:
        """Items computed ahead and not handed over yet (an end or an error counts as one)."""
        return len(self._kept)

    @property
    def exhausted(self) -> bool:
        """True once computing ahead has reached the source's end (or an error)."""
        return self._over

    def ahead(self) -> bool:
        """Compute the next item now and keep it with its warnings; False when there is none
        left to compute."""
        if self._over:
            return False
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                item, error = next(self._source), None
            except BaseException as e:            # noqa: BLE001  replayed at its turn
                item, error = None, e
                self._over = True
        self._kept.append((item, error, list(caught)))
        return not self._over

    def __next__(self):
        if not self._kept:
            return next(self._source)
        item, error, caught = self._kept.popleft()
        for w in caught:                          # said again now, to whoever listens now
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, source=w.source)
        if error is not None:
            raise error
        return item
