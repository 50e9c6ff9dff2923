"""Progress bars for long work (replay, demo, benchmarks), from tqdm.

A bar shows the rate and an ETA. It is drawn on stderr only when both stdout
and stderr are terminals and the user did not ask for quiet: a log file or a
pipe gets no carriage returns and no bar, just the lines the command prints
anyway.
"""

from __future__ import annotations

import sys
from typing import Any

from tqdm import tqdm

__all__ = ["interactive", "progress_bar", "say"]


def interactive() -> bool:
    """Whether stdout and stderr are both terminals (a person is watching)."""
    return all(getattr(stream, "isatty", lambda: False)() for stream in (sys.stdout, sys.stderr))


def progress_bar(total: float | None, desc: str, unit: str, *, quiet: bool = False, **kw: Any) -> tqdm:
    """A tqdm bar on stderr, disabled when *quiet* or when nobody watches a terminal.

    Use as a context manager and call ``update(n)``; a disabled bar accepts the
    same calls and prints nothing.
    """
    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, dynamic_ncols=True,
                disable=quiet or not interactive(), leave=False, **kw)


def say(text: str) -> None:
    """One line on stderr that a running bar does not overwrite (the bar is redrawn below it)."""
    tqdm.write(text, file=sys.stderr)
