"""The progress bar of a study (:func:`tumblemc.study.engine.run_study`)."""

from __future__ import annotations

import sys
from typing import Any


class Progress:
    """The progress bar of a study on stderr (tqdm): runs done of all, rate, elapsed and ETA."""

    def __init__(self, total: int, done: int = 0, enabled: bool = True, stream: Any = None) -> None:
        from tqdm import tqdm

        stream = stream or sys.stderr
        tty = bool(getattr(stream, "isatty", lambda: False)())
        self.bar = tqdm(
            total=total,
            initial=done,
            disable=not enabled,
            file=stream if tty else _Lines(stream),
            unit="run",
            smoothing=0.05,
            mininterval=0.2 if tty else 10.0,  # a log file gets a line every 10 s, not a stream of redraws
            dynamic_ncols=True,
            bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} runs [{elapsed}<{remaining}, {rate_fmt}]",
        )

    def expect(self, total: int) -> None:
        """The study now expects ``total`` runs in all (adaptive sampling closes cells early)."""
        self.bar.total = max(int(total), self.bar.n)
        self.bar.refresh()

    def update(self, n: int) -> None:
        """Count ``n`` more runs done."""
        self.bar.update(n)

    def close(self) -> None:
        """End the bar."""
        self.bar.close()


class _Lines:
    """A log file's view of a progress bar: each redraw on its own line instead of carriage-return overwrites."""

    def __init__(self, stream: Any) -> None:
        self.stream = stream

    def write(self, text: str) -> None:
        line = text.replace("\r", "").strip("\n")
        if line.strip():
            self.stream.write(line + "\n")

    def flush(self) -> None:
        self.stream.flush()


__all__ = ["Progress"]
