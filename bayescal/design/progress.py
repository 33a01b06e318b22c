"""A one-line progress bar on stderr for the plan designer's long steps."""

from __future__ import annotations

import sys

__all__ = ["Progress"]


class Progress:
    """A one-line progress bar on stderr."""

    WIDTH = 30

    def __init__(self, total: int, label: str, enabled: bool) -> None:
        self.total, self.label, self.enabled, self.done = max(total, 1), label, enabled, 0

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
