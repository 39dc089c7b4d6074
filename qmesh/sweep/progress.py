"""The sweep's progress on stderr, drawn by tqdm: a bar redrawn in place on a terminal, the last
job beside it; elsewhere (a log, CI) one line per job, tqdm's meter in front, so every line is
kept. It counts rows as they come back from the workers."""

from __future__ import annotations

import time

from tqdm import tqdm


class Progress:
    """`update(row)` after each finished job; `close()` ends the bar."""

    def __init__(self, total: int, stream, *, skipped: int = 0, enabled: bool = True):
        self.total, self.stream, self.enabled = total, stream, enabled
        self.done = self.failed = 0
        if enabled and skipped:
            print(f"sweep: {skipped} job{'s' * (skipped != 1)} already in the table, skipped", file=stream)
        # disable=None: tqdm draws only when the stream is a terminal; otherwise a line per job
        self.bar = tqdm(total=total, file=stream, disable=None if enabled and total else True,
                        desc="sweep", unit="job", dynamic_ncols=True)
        self.lines = enabled and self.bar.disable
        self.start = time.perf_counter()

    def update(self, row: dict) -> None:
        self.done += 1
        self.failed += row.get("error") is not None
        if not self.enabled:
            return
        job = (f"{row['domain']} {row['conductivity']} N={row['target_vertices']} seed={row['seed']}: "
               + (f"failed: {row['error']}" if row.get("error") else
                  f"N={row['n_vertices']} in {row['seconds']:.2f} s"))
        failed = f"{self.failed} failed" if self.failed else None
        if self.lines:
            meter = tqdm.format_meter(self.done, self.total, time.perf_counter() - self.start,
                                      prefix="sweep", unit="job", ascii=True, postfix=failed)
            print(f"{meter}  {job}", file=self.stream, flush=True)
        else:
            self.bar.set_postfix_str(", ".join(filter(None, (failed, job))), refresh=False)
            self.bar.update(1)

    def close(self) -> None:
        self.bar.close()
