"""The sweep's progress bar on stderr: redrawn in place on a terminal, a line per job otherwise
(a log or CI keeps every line). It counts rows as they come back from the workers."""

from __future__ import annotations

import time

WIDTH = 30


class Progress:
    """`update(row)` after each finished job; `close()` ends the line."""

    def __init__(self, total: int, stream, *, skipped: int = 0, enabled: bool = True):
        self.total, self.stream, self.skipped, self.enabled = total, stream, skipped, enabled
        self.done = self.failed = 0
        self.start = time.perf_counter()
        self.tty = enabled and hasattr(stream, "isatty") and stream.isatty()
        if enabled and skipped:
            print(f"sweep: {skipped} job{'s' * (skipped != 1)} already in the table, skipped", file=stream)
        if self.tty:
            self._draw("")

    def update(self, row: dict) -> None:
        self.done += 1
        self.failed += row.get("error") is not None
        if not self.enabled:
            return
        job = (f"{row['domain']} {row['conductivity']} N={row['target_vertices']} seed={row['seed']}: "
               + (f"failed: {row['error']}" if row.get("error") else
                  f"N={row['n_vertices']} in {row['seconds']:.2f} s"))
        if self.tty:
            self._draw(job)
        else:
            print(f"{self._bar()}  {job}", file=self.stream, flush=True)

    def close(self) -> None:
        if self.tty:
            print(file=self.stream, flush=True)

    def _bar(self) -> str:
        filled = WIDTH * self.done // max(self.total, 1)
        failed = f", {self.failed} failed" if self.failed else ""
        return (f"[{'#' * filled}{'.' * (WIDTH - filled)}] {self.done}/{self.total}{failed} "
                f"{time.perf_counter() - self.start:.0f} s")

    def _draw(self, job: str) -> None:
        line = f"{self._bar()}  {job}"[:120]
        print(f"\r{line:<120}", end="", file=self.stream, flush=True)
