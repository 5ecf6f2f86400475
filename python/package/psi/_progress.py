"""The progress bar behind ``progress=True`` (not API).

The extension calls ``stderr_bar()`` once per call given ``progress=True``, then the object it
returns with ``(stage, done, total)`` as the work goes on (in the calling thread, stages in
pipeline order, ``done`` rising to ``total`` within a stage) and ``close()`` once at the end,
after success or failure. With ``tqdm`` importable that is one tqdm bar per stage on stderr;
without it, one line on stderr rewritten in place with ``"\\r"``::

    psi:      relax [===============>              ] 10/20

ended with a newline by ``close()``. Redraws are limited to about ten a second, bar a stage's
first and last report, so a fast stream of reports costs little. A report after ``close()``
starts a new line (or bar), which the next ``close()`` ends.
"""

import importlib
import sys
import time
from typing import Any, Optional

__all__ = ["stderr_bar"]

#: Characters between the brackets of the fallback bar.
WIDTH = 30
#: Least time between two redraws within a stage, seconds.
INTERVAL = 0.1


def stderr_bar() -> Any:
    """A new bar on ``sys.stderr``: tqdm's when tqdm is importable, else a line of its own."""
    try:
        tqdm = importlib.import_module("tqdm").tqdm
    except ImportError:
        return LineBar()
    return TqdmBar(tqdm)


def bar_text(stage: str, done: int, total: int, width: int = WIDTH) -> str:
    """``psi: {stage:>10} [=====>     ] done/total`` (a full bar when ``total`` is 0)."""
    if total <= 0:
        filled = width
    else:
        filled = max(0, min(width, width * done // total))
    if filled >= width:
        inside = "=" * width
    elif filled == 0:
        inside = " " * width
    else:
        inside = "=" * (filled - 1) + ">" + " " * (width - filled)
    return f"psi: {stage:>10} [{inside}] {done}/{total}"


class LineBar:
    """One line on stderr, rewritten with ``"\\r"`` for each report; a newline at ``close``."""

    def __init__(self) -> None:
        self.stage: Optional[str] = None
        self.last = 0.0  # time of the last redraw
        self.drawn = 0  # length of the text on the line; 0: no line started

    def __call__(self, stage: str, done: int, total: int) -> None:
        now = time.monotonic()
        new_stage = stage != self.stage
        if not (new_stage or done >= total or now - self.last >= INTERVAL):
            return
        self.stage = stage
        self.last = now
        text = bar_text(stage, done, total)
        # Spaces over what a longer earlier text left on the line.
        self.write("\r" + text + " " * max(0, self.drawn - len(text)))
        self.drawn = len(text)

    def close(self) -> None:
        if self.drawn:
            self.write("\n")
        self.stage = None
        self.drawn = 0

    @staticmethod
    def write(text: str) -> None:
        stream = sys.stderr
        if stream is None:  # pythonw: no console
            return
        try:
            stream.write(text)
            stream.flush()
        except (OSError, ValueError):  # a closed or broken stderr never stops the work
            pass


class TqdmBar:
    """One ``tqdm`` bar per stage on stderr, each closed when the next stage starts."""

    def __init__(self, tqdm: Any) -> None:
        self.tqdm = tqdm
        self.stage: Optional[str] = None
        self.bar: Any = None

    def __call__(self, stage: str, done: int, total: int) -> None:
        if stage != self.stage or self.bar is None:
            self.finish()
            self.stage = stage
            self.bar = self.tqdm(
                total=total, desc=f"psi: {stage}", file=sys.stderr, leave=True,
                dynamic_ncols=True,
            )
        bar = self.bar
        if bar.total != total:
            bar.total = total
            bar.refresh()
        if done > bar.n:
            bar.update(done - bar.n)

    def finish(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def close(self) -> None:
        self.finish()
        self.stage = None
