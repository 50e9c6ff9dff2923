"""How a served module plays a finite sensor source: from its first read, then standing still.

A module serving a scenario or a recording keeps running after the source ends;
these wrappers make that well defined for every transport (``serve``, the
``openshoe://`` URL, the demo).
"""

from __future__ import annotations

import numpy as np

from firmware_sim.mcu.imu_bus import RawSample, SensorSource, imu_block

#: Samples of the held last sample handed out at once (HoldLastSource.imu_block).
_HELD_BLOCK = 256


class HoldLastSource:
    """A finite sensor source that, once it has run out, repeats its last sample forever.

    A served module keeps running after its scenario or recording ends; the
    wearer then stands still where the route ended (every scenario ends at
    rest), instead of the sensors going silent.
    """

    def __init__(self, source: SensorSource):
        self.source = source
        self.rate_hz = source.rate_hz
        self.sensor = getattr(source, "sensor", None)
        self._last: RawSample | None = None
        #: sample index at which the wrapped source ran out (None while it has not)
        self.ended_at: int | None = None
        self._held: np.ndarray | None = None

    def read(self, index: int) -> RawSample | None:
        if self.ended_at is None or index < self.ended_at:
            sample = self.source.read(index)
            if sample is not None:
                self._last = sample
                return sample
            if self.ended_at is None:
                self.ended_at = index
        return self._last

    def imu_block(self, start: int, n: int) -> np.ndarray | None:
        """Samples from *start* as one block (see :func:`~firmware_sim.mcu.imu_bus.imu_block`):
        the wrapped source's until it ends, then the held last sample repeated."""
        if self.ended_at is None or start < self.ended_at:
            return imu_block(self.source, start, n)
        last = self._last
        if last is None:
            return None
        held = self._held
        if held is None or not np.array_equal(held[0], last.imu):
            held = self._held = np.repeat(last.imu[None], _HELD_BLOCK, axis=0)
        return held[:n]

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
        self.sensor = getattr(source, "sensor", None)
        self.start: int | None = None

    def read(self, index: int) -> RawSample | None:
        if self.start is None:
            self.start = index
        return self.source.read(max(0, index - self.start))

    def imu_block(self, start: int, n: int) -> np.ndarray | None:
        """Samples from *start* as one block (see :func:`~firmware_sim.mcu.imu_bus.imu_block`);
        None before the first read (that read fixes where the source starts)."""
        if self.start is None or start < self.start:
            return None
        return imu_block(self.source, start - self.start, n)

    def set_dlpf(self, cfg: int) -> None:
        self.source.set_dlpf(cfg)

    def __repr__(self) -> str:
        return f"StartOnFirstRead({self.source!r}, start={self.start})"


def served_source(source: SensorSource) -> HoldLastSource:
    """A scenario or recording as a served module plays it: from its first read, then standing still."""
    return HoldLastSource(StartOnFirstRead(source))
