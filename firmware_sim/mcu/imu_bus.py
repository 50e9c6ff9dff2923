"""What the firmware's READ_INERTIAL reads: a source of raw MPU9150 registers.

A sensor source is indexed by sample number (0, 1, 2, … at the module's loop
rate); it hands back the raw int16 registers of every chip sampled at the same
instant. Sources: scripted values (tests), the simulated 4-IMU array on a
walking foot, and replays of recordings (see the sibling modules).

Nothing a host sends may make a source compute for long while a clock runs against
the host. A source whose registers depend on SET_IMU_BANDWIDTH (the simulated array)
computes the new setting's as they are read, a bounded block at a time, never the
whole record in ``set_dlpf``.
"""

from __future__ import annotations

from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np

from firmware_sim.board import MIMU22BT
from protocol.ids import NR_IMUS

#: Accelerometer LSB per g at ±16 g (the still board's registers).
_ACC_LSB_PER_G = 2048


class RawSample(NamedTuple):
    """One simultaneous read of all chips (raw register values, chip axes)."""

    imu: np.ndarray  #: int16 (NR_IMUS, 6): acc xyz, gyro xyz
    temp: np.ndarray  #: int16 (NR_IMUS,): temperature register
    mag: np.ndarray  #: int16 (NR_IMUS, 3): AK8975 registers


@runtime_checkable
class SensorSource(Protocol):
    """The interface READ_INERTIAL uses."""

    #: Sample rate [Hz] the source was made for (the module's loop rate should match).
    rate_hz: float

    def read(self, index: int) -> RawSample | None:
        """Sample *index*; None when a finite source (a replay) is exhausted."""
        ...

    def set_dlpf(self, cfg: int) -> None:
        """Apply MPU9150 DLPF_CFG 0..6 (SET_IMU_BANDWIDTH); sources may ignore it. Called by the
        command's handler inside one main loop: it computes no more than a bounded block of
        registers (nothing in proportion to the record's length)."""
        ...


def imu_block(source: object, start: int, n: int) -> np.ndarray | None:
    """Samples *start* … *start* + k − 1 (1 ≤ k ≤ *n*) of *source*'s IMU registers as one
    int16 (k, NR_IMUS, 6) array view, exactly what ``read`` gives for them; or None
    when the source cannot hand out a block (read it sample by sample then).

    From the source's own ``imu_block(start, n)`` if it has one, else from a whole-record
    ``imu`` array (simulated and replay sources) when the source also has a length.
    """
    block = getattr(source, "imu_block", None)
    if block is not None:
        imu = block(start, n)
    else:
        imu = getattr(source, "imu", None)
        if not hasattr(source, "__len__") or not isinstance(imu, np.ndarray):
            return None
        imu = imu[start:start + n]
    if imu is None:
        return None
    shape = imu.shape
    if imu.dtype is _INT16 and len(shape) == 3 and shape[0] and shape[1] == NR_IMUS and shape[2] == 6:
        return imu  # (the usual block: checked without making a dtype or a tuple, once a frame)
    if imu.dtype != np.int16 or imu.ndim != 3 or imu.shape[1:] != (NR_IMUS, 6) or not len(imu):
        return None
    return imu


_INT16 = np.dtype(np.int16)


class ScriptedSource:
    """Fixed raw register values, optionally a per-sample script (for tests).

    ``script`` is an int16 array (n, NR_IMUS, 6); after its end the last sample
    repeats, or ``read`` returns None when ``finite`` is set.
    """

    def __init__(self, script: np.ndarray | None = None, rate_hz: float = 1000.0,
                 finite: bool = False, temp: int = 0, mag: tuple[int, int, int] = (0, 0, 0)):
        if script is None:
            script = np.zeros((1, NR_IMUS, 6), dtype=np.int16)
        script = np.asarray(script)
        if script.ndim == 2:
            script = script[None]
        if script.shape[1:] != (NR_IMUS, 6) or script.dtype != np.int16:
            raise ValueError(f"script must be int16 (n, {NR_IMUS}, 6), got {script.dtype} {script.shape}")
        self.script = script
        self.rate_hz = rate_hz
        self.finite = finite
        self.dlpf_cfg = 0
        self._temp = np.full(NR_IMUS, temp, dtype=np.int16)
        self._mag = np.tile(np.asarray(mag, dtype=np.int16), (NR_IMUS, 1))

    def read(self, index: int) -> RawSample | None:
        if index >= len(self.script):
            if self.finite:
                return None
            index = len(self.script) - 1
        return RawSample(self.script[index], self._temp, self._mag)

    def set_dlpf(self, cfg: int) -> None:
        self.dlpf_cfg = cfg


def still_board(rate_hz: float = 1000.0) -> ScriptedSource:
    """Raw registers of a board lying still and level (f = (0, 0, −g) in board axes): what a
    module reads when no other sensor source is given."""
    f_board = np.array([0, 0, -_ACC_LSB_PER_G], dtype=np.int64)
    imu = np.zeros((1, NR_IMUS, 6), dtype=np.int16)
    for i in range(NR_IMUS):
        imu[0, i, 0:3] = MIMU22BT.mounting[i] @ f_board
    return ScriptedSource(imu, rate_hz=rate_hz)


#: DLPF_CFG values of the MPU9150 (SET_IMU_BANDWIDTH; the firmware ignores 7 and above).
DLPF_SETTINGS = range(7)
