"""The state table: id → name, size and big-endian element type (protocol.md §4).

A state is a fixed-size piece of µC memory copied raw to the wire; the module is
big-endian, so every multi-byte element is big-endian here. The payload codec
that splits a packet's payload by the ids it carries is in :mod:`protocol.codec`.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .ids import (
    IMU_MAG_BASE,
    IMU_RAW_BASE,
    IMU_TEMP_BASE,
    MAX_IMU_IDS,
    NR_SLOTS,
    PS_DT_BASE,
    STATE_ID_LIMIT,
    StateId,
)


@dataclass(frozen=True)
class StateSpec:
    """One state: its id, name, wire dtype (big-endian) and element shape."""

    id: int
    name: str
    dtype: np.dtype  #: big-endian element type as on the wire
    shape: tuple[int, ...]  #: () for a scalar
    doc: str = ""

    @cached_property
    def size(self) -> int:
        """Bytes on the wire."""
        return int(self.dtype.itemsize * int(np.prod(self.shape, dtype=np.int64)))

    @cached_property
    def native_dtype(self) -> np.dtype:
        """The same element type in the host's byte order (for live memory)."""
        return self.dtype.newbyteorder("=")

    def __repr__(self) -> str:
        return f"StateSpec(0x{self.id:02X} {self.name}, {self.size} B, {self.dtype.str}{list(self.shape)})"


def _spec(sid: int, name: str, dtype: str, shape: tuple[int, ...] = (), doc: str = "") -> StateSpec:
    return StateSpec(sid, name, np.dtype(dtype), shape, doc)


#: Rate [Hz] of the timestamps the states carry (IMU_TS, T_INT_K, GP_DT, PS_DT…): the
#: AT32UC3C2512's CPU cycle counter, a uint32 that wraps every ~67 s.
TIMESTAMP_HZ = 64_000_000

_NAMED: list[StateSpec] = [
    _spec(StateId.IMU_TS, "IMU_TS", ">u4", doc="CPU cycle counter (64 MHz) when the IMUs were read"),
    _spec(StateId.INTERRUPT_COUNTER, "INTERRUPT_COUNTER", ">u4", doc="timer interrupts since boot"),
    _spec(StateId.GP_DT, "GP_DT", ">u4", doc="cycles the last main loop took"),
    _spec(StateId.MCU_ID, "MCU_ID", "u1", (15,), doc="the µC's serial number"),
    _spec(StateId.GP_ID, "GP_ID", "u1", doc="free for the user"),
    _spec(StateId.U_NEW, "U_NEW", ">i4", (6,), doc="combined array measurement, fixed point"),
    _spec(StateId.U_INT_K, "U_INT_K", ">i4", (6,), doc="measurement the filter processes now"),
    _spec(StateId.T_INT_K, "T_INT_K", ">u4", doc="timestamp of U_INT_K"),
    _spec(StateId.U_K, "U_K", ">f4", (6,), doc="acc [m/s²], gyro [rad/s], bias-compensated"),
    _spec(StateId.DT, "DT", ">f4", doc="time step [s]"),
    _spec(StateId.T1S2F, "T1S2F", ">u4", doc="zero-velocity test statistic"),
    _spec(StateId.T2S2F, "T2S2F", ">u4", doc="zero-angular-rate test statistic"),
    _spec(StateId.ZUPT, "ZUPT", "?", doc="zero velocity detected"),
    _spec(StateId.ZARU, "ZARU", "?", doc="zero angular rate detected"),
    _spec(StateId.TH_ZUPT, "TH_ZUPT", ">u4", doc="ZUPT threshold (settable)"),
    _spec(StateId.TH_ZARU, "TH_ZARU", ">u4", doc="ZARU threshold (settable)"),
    _spec(StateId.U_INT16_K, "U_INT16_K", ">i2", (6,), doc="U_K scaled to int16"),
    _spec(StateId.POSITION, "POSITION", ">f4", (3,), doc="position [m], navigation frame"),
    _spec(StateId.VELOCITY, "VELOCITY", ">f4", (3,), doc="velocity [m/s]"),
    _spec(StateId.QUATERNION, "QUATERNION", ">f4", (4,), doc="attitude quaternion"),
    _spec(StateId.P, "P", ">f4", (45,), doc="upper triangle of the 9×9 covariance, row by row"),
    _spec(StateId.INIT_DONE, "INIT_DONE", "?", doc="initial alignment finished"),
    _spec(StateId.DX, "DX", ">f4", (4,), doc="dx, dy, dz [m], dψ [rad]"),
    _spec(StateId.DP, "DP", ">f4", (10,), doc="upper triangle of the 4×4 covariance of DX"),
    _spec(StateId.STEP_COUNTER, "STEP_COUNTER", ">u2", doc="steps since 0x34"),
    _spec(StateId.FILTER_RESET_FLAG, "FILTER_RESET_FLAG", "?", doc="true in the cycle of a reset"),
    # emulator extensions (free ids; a real module answers them as unknown states)
    _spec(StateId.SWING_TIME, "SWING_TIME", ">f4",
          doc="seconds without ZUPT between the last two resets: the swing time of the step in DX"),
    _spec(StateId.THETA_INIT, "THETA_INIT", ">f4", (2,),
          doc="foot pitch, roll [rad] standing on level ground, from the initial alignment (settable)"),
    _spec(StateId.THETA_GROUND, "THETA_GROUND", ">f4", (2,),
          doc="the ground's slope [rad] along and across the foot, low-passed from stance to stance"),
]


def _build_table() -> dict[int, StateSpec]:
    table = {s.id: s for s in _NAMED}
    for i in range(MAX_IMU_IDS):
        table[IMU_RAW_BASE + i] = _spec(IMU_RAW_BASE + i, f"IMU{i}_RAW", ">i2", (6,),
                                        doc=f"IMU {i} raw acc xyz, gyro xyz")
        table[IMU_TEMP_BASE + i] = _spec(IMU_TEMP_BASE + i, f"IMU{i}_TEMP", ">i2",
                                         doc=f"IMU {i} temperature register")
        table[IMU_MAG_BASE + i] = _spec(IMU_MAG_BASE + i, f"IMU{i}_MAG", ">i2", (3,),
                                        doc=f"IMU {i} magnetometer")
    for j in range(NR_SLOTS):
        table[PS_DT_BASE + j] = _spec(PS_DT_BASE + j, f"PS_DT{j}", ">u4",
                                      doc=f"cycles process-sequence slot {j} took")
    assert all(0 < k < STATE_ID_LIMIT for k in table)
    return dict(sorted(table.items()))


#: Every state that exists, by id (ascending). An id not here has no state.
STATES: dict[int, StateSpec] = _build_table()


def state_spec(state_id: int) -> StateSpec:
    """The spec of a state id; KeyError with a hex id if it has no state."""
    try:
        return STATES[state_id]
    except KeyError:
        raise KeyError(f"no state with id 0x{state_id:02X}") from None


def exists(state_id: int) -> bool:
    return state_id in STATES


#: Order of DP's 10 numbers in the 4×4 covariance (upper triangle, row by row).
DP_INDEX: tuple[tuple[int, int], ...] = tuple((r, c) for r in range(4) for c in range(r, 4))
#: Order of P's 45 numbers in the 9×9 covariance (upper triangle, row by row).
P_INDEX: tuple[tuple[int, int], ...] = tuple((r, c) for r in range(9) for c in range(r, 9))


@functools.cache
def _triu_indices(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``np.triu_indices(n)``, made once per size (a host expands one matrix per step packet)."""
    rows, cols = np.triu_indices(n)
    rows.flags.writeable = cols.flags.writeable = False
    return rows, cols


def upper_to_symmetric(values: np.ndarray, n: int) -> np.ndarray:
    """Expand an upper triangle stored row by row into a symmetric n×n matrix."""
    values = np.asarray(values)
    if values.shape != (n * (n + 1) // 2,):
        raise ValueError(f"expected {n * (n + 1) // 2} values, got shape {values.shape}")
    out = np.zeros((n, n), dtype=values.dtype)
    rows, cols = _triu_indices(n)
    out[rows, cols] = values
    out[cols, rows] = values
    return out


def symmetric_to_upper(matrix: np.ndarray) -> np.ndarray:
    """The upper triangle of a square matrix, row by row (inverse of the above)."""
    matrix = np.asarray(matrix)
    n = matrix.shape[0]
    if matrix.shape != (n, n):
        raise ValueError(f"expected a square matrix, got shape {matrix.shape}")
    return matrix[np.triu_indices(n)]
