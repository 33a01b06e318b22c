"""The plan designer's progress on its long steps, through tqdm: on stderr, only when stderr is a terminal."""

from __future__ import annotations

import math
import sys

__all__ = ["Progress", "best_text"]


class Progress:
    """A one-line progress bar on stderr, drawn only when asked for and stderr is a terminal.

    Redrawn with carriage returns, a bar written to a log file or a pipe is a
    single line of hundreds of overwritten states; the command line also turns it
    off in ``--json`` runs.
    """

    def __init__(self, total: int, label: str, enabled: bool) -> None:
        self._bar = None
        if enabled and sys.stderr.isatty():
            # tqdm loads only for a bar drawn (0.02-0.03 s of a command's start-up)
            from tqdm import tqdm

            self._bar = tqdm(total=max(total, 1), desc=label, file=sys.stderr, leave=True)

    def step(self, note: str = "") -> None:
        """One more step done; ``note`` is shown after the count (e.g. the best plan so far)."""
        if self._bar is None:
            return
        if note:
            self._bar.set_postfix_str(note, refresh=False)
        self._bar.update(1)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


def best_text(score: float, criterion: str, law: tuple[str, ...] = ("K_c", "s0")) -> str:
    """The note on the best plan so far, ending with the criterion's unit (``score`` as
    :func:`bayescal.design.prediction.criterion_value` gives it; ``law`` the compensator law's parameters)."""
    if criterion == "test-pose":
        return f"best: ρ0 = {score * 1e6:.2f} μm"
    if criterion == "compensator":
        return f"best: {' and '.join(law)} to {100 * math.sqrt(max(score, 0.0)):.0f} % (1 sd, combined)"
    return f"best: -log det of the information = {score:.1f}"
