"""Progress that shows in a log. On a terminal a long job draws a progress bar (rich); where standard error is not a
terminal (``nohup``, a CI log, a pipe) it prints one plain line per finished unit instead: what finished, the time
elapsed and the estimated time left. Train, reproduce, ``dataset build``, the demo and
``evaluate`` (lines on a terminal too) report through it."""

from __future__ import annotations

import sys
import time


def to_log() -> bool:
    """Whether progress goes to a log (standard error is not a terminal)."""
    return not sys.stderr.isatty()


class LogLines:
    """One line per finished unit (at most one per ``every`` units, and the last) when ``enabled`` and writing to a
    log (or, ``terminal`` too, where no bar is drawn): ``name: what  elapsed N s  left ~M s``. Costs may weigh units
    (an epoch vs an evaluation)."""

    def __init__(self, name: str, total: float, done: float = 0.0, every: float = 1.0, enabled: bool = True,
                 terminal: bool = False):
        self.name, self.total, self.done0, self.every = name, total, done, every
        self.enabled = enabled and (terminal or to_log())
        self.t0, self.next = time.time(), done + every

    def __call__(self, done: float, what: str) -> None:
        if not self.enabled or (done < self.next and done < self.total):
            return
        self.next = done + self.every
        spent = time.time() - self.t0
        left = spent / max(done - self.done0, 1e-9) * max(self.total - done, 0.0)
        print(f"{self.name}: {what}  elapsed {spent:.0f} s  left ~{left:.0f} s", file=sys.stderr, flush=True)
