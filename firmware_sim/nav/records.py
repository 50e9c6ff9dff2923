"""Typed records: a set of arrays kept in one numpy record, so a compiled kernel takes it as one
argument (and numba reaches every array in it by name, at a fixed offset).

* :class:`WorkRecord` — a processing function's private per-module arrays (the front end's
  ring buffer and running sums, the INS's timers, …). A subclass declares them in ``FIELDS``;
  each is an attribute — a view into :attr:`WorkRecord.record` — so the reference functions
  read and write the attributes as plain arrays, and the compiled path hands the record over.
* :data:`STATE_RECORD` — a module's state memory seen as one record (``memory.arena.view(
  STATE_RECORD)``): every state a field named after it in lower case (``position``, ``u_k``,
  ``filter_reset_flag``, and the blocks ``imu_raw``, ``imu_temp``, ``imu_mag``, ``ps_dt``) at
  its byte offset in the arena. A scalar state is a one-element array (a kernel writes
  ``s.dt[0]``).

numba has no bool fields in records: a bool array is stored as uint8 (the same byte, as a C
bool holds it); a work record's attribute shows it as bool again.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from firmware_sim.mcu.memory import StateMemory
from protocol.ids import IMU_MAG_BASE, IMU_RAW_BASE, IMU_TEMP_BASE, MAX_IMU_IDS, NR_SLOTS, PS_DT_BASE
from protocol.states import STATES

__all__ = ["STATE_RECORD", "Field", "WorkRecord"]

#: One array of a record: name, element type, shape.
Field = tuple[str, type, tuple[int, ...]]


def _stored(dtype: type | np.dtype) -> np.dtype:
    """The element type a record holds for *dtype* (bool as uint8)."""
    dt = np.dtype(dtype)
    return np.dtype(np.uint8) if dt == np.bool_ else dt


class WorkRecord:
    """Arrays declared in ``FIELDS`` (name, dtype, shape), zeroed, living in one record."""

    FIELDS: ClassVar[tuple[Field, ...]] = ()
    #: The record's numpy dtype (made from FIELDS for each subclass).
    DTYPE: ClassVar[np.dtype]

    def __init_subclass__(cls, **kwargs: object) -> None:
        super().__init_subclass__(**kwargs)
        cls.DTYPE = np.dtype([(name, _stored(dt), shape) for name, dt, shape in cls.FIELDS], align=True)

    def __init__(self) -> None:
        #: Every array of FIELDS, as one record (a one-element numpy.recarray).
        self.record = np.zeros(1, self.DTYPE).view(np.recarray)
        for name, dt, _shape in self.FIELDS:
            view = self.record[name][0]
            setattr(self, name, view.view(np.bool_) if np.dtype(dt) == np.bool_ else view)


def _state_record_dtype() -> np.dtype:
    memory = StateMemory()
    blocks = {"imu_raw": (IMU_RAW_BASE, MAX_IMU_IDS), "imu_temp": (IMU_TEMP_BASE, MAX_IMU_IDS),
              "imu_mag": (IMU_MAG_BASE, MAX_IMU_IDS), "ps_dt": (PS_DT_BASE, NR_SLOTS)}
    names, formats, offsets = [], [], []
    for sid, spec in STATES.items():
        if any(base <= sid < base + n for base, n in blocks.values()):
            continue
        names.append(spec.name.lower())
        formats.append((_stored(spec.native_dtype), spec.shape or (1,)))
        offsets.append(memory.offsets[sid])
    for name in blocks:
        block = getattr(memory, name)  # memory.imu_raw, …: the whole block's array
        names.append(name)
        formats.append((block.dtype, block.shape))
        offsets.append(memory.block_offsets[name])
    return np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": len(memory.arena)})


#: A module's state memory as one record (the arena's layout is the same in every module).
STATE_RECORD = _state_record_dtype()
