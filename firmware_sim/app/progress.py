"""Progress bars for long work (replay, demo, benchmarks), from tqdm.

A bar shows the rate and an ETA. It is drawn on stderr only when both stdout
and stderr are terminals and the user did not ask for quiet: a log file or a
pipe gets no carriage returns and no bar, just the lines the command prints
anyway. tqdm is imported only for a bar that is drawn.
"""

from __future__ import annotations

import sys
from typing import Any

__all__ = ["HiddenBar", "interactive", "progress_bar", "say"]


def interactive() -> bool:
    """Whether stdout and stderr are both terminals (a person is watching)."""
    return all(getattr(stream, "isatty", lambda: False)() for stream in (sys.stdout, sys.stderr))


class HiddenBar:
    """The bar nobody sees: a disabled tqdm bar's calls, doing nothing (``n`` stays 0, as there)."""

    n = 0

    def __enter__(self) -> HiddenBar:
        return self

    def __exit__(self, *exc: object) -> None:
        return None

    def update(self, n: float = 1) -> None:
        """Nothing."""

    def close(self) -> None:
        """Nothing."""


def progress_bar(total: float | None, desc: str, unit: str, *, quiet: bool = False, **kw: Any) -> Any:
    """A tqdm bar on stderr; a :class:`HiddenBar` when *quiet* or when nobody watches a terminal.

    Use as a context manager and call ``update(n)``; a hidden bar accepts the
    same calls and prints nothing.
    """
    if quiet or not interactive():
        return HiddenBar()
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, dynamic_ncols=True, leave=False, **kw)


def say(text: str) -> None:
    """One line on stderr that a running bar does not overwrite (the bar is redrawn below it)."""
    if "tqdm" in sys.modules:  # a bar may be drawn
        from tqdm import tqdm

        tqdm.write(text, file=sys.stderr)
    else:
        print(text, file=sys.stderr)
