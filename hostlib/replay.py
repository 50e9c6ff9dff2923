"""Re-processing a captured byte stream (``openshoe-host log --raw``) offline into a track.

The capture holds what the module sent (command acks and state packets, with
any garbage and resends the link produced). The same :class:`HostSession`
that runs live decodes it here, without sending anything back, so a capture
gives the same steps, gaps and counters as the live session did.
"""

from __future__ import annotations

from pathlib import Path

from .session import HostSession, SessionStats
from .tracking import StepTracker, Track

__all__ = ["replay_bytes", "replay_capture"]


def replay_bytes(data: bytes, *, command_set: str = "2015", chunk: int = 4096,
                 tracker: StepTracker | None = None) -> tuple[Track, SessionStats]:
    """Sum the steps in a module → host byte stream; returns the track and the session counters.

    The step counter before the first step is taken as unknown (a capture may
    start mid-walk), so no gap is reported before the first step seen.
    """
    session = HostSession(command_set, ack_policy="never",
                          tracker=tracker if tracker is not None else StepTracker(last_counter=None))
    for i in range(0, len(data), chunk):
        session.feed(data[i : i + chunk])
    session.finish()
    return session.tracker.track, session.stats


def replay_capture(path: str | Path, **kwargs) -> tuple[Track, SessionStats]:
    """:func:`replay_bytes` of a capture file."""
    return replay_bytes(Path(path).read_bytes(), **kwargs)
