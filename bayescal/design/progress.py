"""A one-line progress bar on stderr for the plan designer's long steps."""

from __future__ import annotations

import math
import sys

__all__ = ["Progress", "best_text"]


class Progress:
    """A one-line progress bar on stderr, drawn only when stderr is a terminal.

    Redrawn with carriage returns, a bar written to a log file or a pipe is a
    single line of hundreds of overwritten states.
    """

    WIDTH = 30

    def __init__(self, total: int, label: str, enabled: bool) -> None:
        self.total, self.label, self.done = max(total, 1), label, 0
        self.enabled = enabled and sys.stderr.isatty()

    def step(self, note: str = "") -> None:
        self.done += 1
        if self.enabled:
            filled = int(self.WIDTH * self.done / self.total)
            bar = "#" * filled + "." * (self.WIDTH - filled)
            sys.stderr.write(f"\r{self.label} [{bar}] {self.done}/{self.total} {note}".ljust(100))
            sys.stderr.flush()

    def close(self) -> None:
        if self.enabled:
            sys.stderr.write("\n")
            sys.stderr.flush()


def best_text(score: float, criterion: str) -> str:
    """The note on the best plan so far, ending with the criterion's unit (``score`` as
    :func:`bayescal.design.criteria.criterion_value` gives it)."""
    if criterion == "test-pose":
        return f"best: ρ0 = {score * 1e6:.2f} μm"
    if criterion == "compensator":
        return f"best: K_c and s0 to {100 * math.sqrt(max(score, 0.0)):.0f} % (1 sd, combined)"
    return f"best: -log det of the information = {score:.1f}"
