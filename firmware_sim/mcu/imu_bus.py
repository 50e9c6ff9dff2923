"""What the firmware's READ_INERTIAL reads: a source of raw MPU9150 registers.

A sensor source is indexed by sample number (0, 1, 2, … at the module's loop
rate); it hands back the raw int16 registers of every chip sampled at the same
instant. Sources: scripted values (tests), the simulated 4-IMU array on a
walking foot, and replays of recordings (see the sibling modules).

Nothing a host sends may make a source compute for long while a clock runs against
the host. A source whose SET_IMU_BANDWIDTH recomputes its whole record of registers
(the simulated array: a second or more for a few minutes of walking) is served inside
:class:`PreparedBandwidths`, which computes every DLPF setting once, before the clock
starts (:func:`prepare_sensors`, called by the real-time pacer); the command then only
picks one of them.
"""

from __future__ import annotations

import copy
from typing import Any, NamedTuple, Protocol, runtime_checkable

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
        """Apply MPU9150 DLPF_CFG 0..6 (SET_IMU_BANDWIDTH); sources may ignore it."""
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
    if imu is None or imu.dtype != np.int16 or imu.ndim != 3 or imu.shape[1:] != (NR_IMUS, 6) or not len(imu):
        return None
    return imu


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


class PreparedBandwidths:
    """*source* with its registers at every DLPF setting computed ahead, once :meth:`prepare` ran.

    *source* keeps its whole record of registers in an int16 (n, NR_IMUS, 6) array ``imu``
    and recomputes it in ``set_dlpf`` (the simulated array: the same noise draws through
    another filter). Before :meth:`prepare` this is *source* itself: ``set_dlpf`` recomputes
    as it always did (in virtual time no host waits on it). :meth:`prepare` computes the
    other six settings on a shallow copy of *source* (which it leaves as it is) and keeps
    the seven arrays; from then on ``set_dlpf`` only picks one — the registers are those
    *source* would give after the same ``set_dlpf``, bit for bit — and ``read`` hands out
    the picked array's sample with *source*'s temperature and magnetometer. Everything else
    is *source*'s (``truth``, ``chips``, …). Costs the memory of seven register arrays.
    """

    def __init__(self, source: Any):
        self.source = source
        self.rate_hz = source.rate_hz
        self.sensor = getattr(source, "sensor", None)
        #: The DLPF setting the registers are read at.
        self.dlpf_cfg: int = getattr(source, "dlpf_cfg", 0)
        self._registers: dict[int, np.ndarray] = {}

    @property
    def prepared(self) -> bool:
        """Whether every DLPF setting's registers are ready (``set_dlpf`` computes nothing)."""
        return bool(self._registers)

    def prepare(self) -> None:
        """Compute the registers of every DLPF setting now (once; before a clock starts)."""
        if self._registers:
            return
        current = self.source.dlpf_cfg
        registers = {current: self.source.imu}
        scratch = copy.copy(self.source)  # set_dlpf rebinds the copy's arrays, never the source's
        for cfg in DLPF_SETTINGS:
            if cfg not in registers:
                scratch.set_dlpf(cfg)
                registers[cfg] = scratch.imu
        self._registers = registers
        self.dlpf_cfg = current

    @property
    def imu(self) -> np.ndarray:
        """The registers at the current DLPF setting, int16 (n, NR_IMUS, 6)."""
        return self._registers[self.dlpf_cfg] if self._registers else self.source.imu

    def __len__(self) -> int:
        return len(self.source)

    def read(self, index: int) -> RawSample | None:
        sample = self.source.read(index)
        if sample is None or not self._registers:
            return sample
        return RawSample(self._registers[self.dlpf_cfg][index], sample.temp, sample.mag)

    def set_dlpf(self, cfg: int) -> None:
        """DLPF_CFG *cfg*: once prepared, a choice among the computed registers."""
        if not self._registers:
            self.source.set_dlpf(cfg)
        elif cfg not in self._registers:
            raise ValueError(f"DLPF_CFG must be 0..6, got {cfg}")
        self.dlpf_cfg = cfg

    def __getattr__(self, name: str) -> Any:
        if name == "source":  # not set yet (a copy being made): no recursion
            raise AttributeError(name)
        return getattr(self.source, name)

    def __repr__(self) -> str:
        state = "prepared" if self._registers else "not prepared"
        return f"PreparedBandwidths({self.source!r}, dlpf_cfg={self.dlpf_cfg}, {state})"


def prepare_sensors(source: object) -> int:
    """Call ``prepare()`` of *source* and of every source it wraps (its ``source``, and so
    on): what a command could otherwise make a source compute is computed now, before a
    clock starts. Returns how many sources prepared."""
    prepared = 0
    for _ in range(16):  # wrappers are a few deep
        if source is None:
            break
        prepare = getattr(type(source), "prepare", None)
        if callable(prepare):
            prepare(source)
            prepared += 1
        source = getattr(source, "source", None)
    return prepared
