"""How a served module plays a finite sensor source: from its first read, then standing still.

A module serving a scenario or a recording keeps running after the source ends;
these wrappers make that well defined for every transport (``serve``, the
``openshoe://`` URL, the demo).
"""

from __future__ import annotations

from .base import RawSample, SensorSource


class HoldLastSource:
    """A finite sensor source that, once it has run out, repeats its last sample forever.

    A served module keeps running after its scenario or recording ends; the
    wearer then stands still where the route ended (every scenario ends at
    rest), instead of the sensors going silent.
    """

    def __init__(self, source: SensorSource):
        self.source = source
        self.rate_hz = source.rate_hz
        self._last: RawSample | None = None
        #: sample index at which the wrapped source ran out (None while it has not)
        self.ended_at: int | None = None

    def read(self, index: int) -> RawSample | None:
        if self.ended_at is None or index < self.ended_at:
            sample = self.source.read(index)
            if sample is not None:
                self._last = sample
                return sample
            if self.ended_at is None:
                self.ended_at = index
        return self._last

    def set_dlpf(self, cfg: int) -> None:
        self.source.set_dlpf(cfg)

    def __repr__(self) -> str:
        return f"HoldLastSource({self.source!r}, ended_at={self.ended_at})"


class StartOnFirstRead:
    """A sensor source whose sample 0 is the first one the module reads, not the one at boot.

    Nothing reads the sensors until a host starts a mode (e.g. step-wise dead
    reckoning); from then on the scenario plays from its beginning — so the
    initial stand still is there for the alignment however late the host came.
    ``start`` is the module sample index the scenario began at (None before).
    """

    def __init__(self, source: SensorSource):
        self.source = source
        self.rate_hz = source.rate_hz
        self.start: int | None = None

    def read(self, index: int) -> RawSample | None:
        if self.start is None:
            self.start = index
        return self.source.read(max(0, index - self.start))

    def set_dlpf(self, cfg: int) -> None:
        self.source.set_dlpf(cfg)

    def __repr__(self) -> str:
        return f"StartOnFirstRead({self.source!r}, start={self.start})"


def served_source(source: SensorSource) -> HoldLastSource:
    """A scenario or recording as a served module plays it: from its first read, then standing still."""
    return HoldLastSource(StartOnFirstRead(source))
