"""READ_INERTIAL (ProcId 0x13): sample the IMU array into the raw states (firmware.md §3).

Reads sample number ``module.clock.sample_index`` (the loop number) from the
module's :class:`~firmware_sim.mcu.imu_bus.SensorSource` and writes:

* IMU i raw registers → states 0x40+i (6 × int16). The **accelerometer triple
  is delayed by one sample** (it holds the previous read's values, matching the
  gyro's internal filter delay); on the very first read, with no previous
  sample, the accelerometer gets the current values.
* temperature → 0x60+i, magnetometer → 0x90+i;
* IMU_TS (0x01) ← the 32-bit cycle counter at the read.

A finite source (a replay) that has run out returns None: nothing is written
and ``module.sensors_exhausted`` becomes True, which batch runners watch.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from firmware_sim.mcu.sequence import processing_function
from protocol.ids import NR_IMUS, ProcId, StateId

from .records import WorkRecord

if TYPE_CHECKING:  # pragma: no cover
    from firmware_sim.mcu.module import Module

#: Modelled CPU cost of reading four MPU9150s: the chips sit on their own TWI buses and
#: are read by DMA, so the CPU only starts the transfers, waits for the last one to
#: complete and copies 4 × 20 register bytes (a model, not a measurement).
READ_INERTIAL_CYCLES = 3_000


class InertialWork(WorkRecord):
    """READ_INERTIAL's private state: the last read's accelerometer registers (the one-sample delay)."""

    FIELDS = (("prev_acc", np.int16, (NR_IMUS, 3)), ("have_prev", np.bool_, (1,)))


def inertial_work(module: Module) -> InertialWork:
    """The module's READ_INERTIAL state (created on first use)."""
    return module.work("inertial", InertialWork)


def latch_registers(imu: np.ndarray, raw: np.ndarray, prev_acc: np.ndarray, have_prev: np.ndarray) -> None:
    """One read's int16 registers *imu* (chips, 6) into the raw states *raw*: the gyro as read,
    the accelerometer the previous read's (*prev_acc*, then updated), or, on the very first
    read (*have_prev* false), the current one."""
    if have_prev[0]:
        raw[:NR_IMUS, 0:3] = prev_acc
    else:
        raw[:NR_IMUS, 0:3] = imu[:, 0:3]
        have_prev[0] = True
    prev_acc[:, :] = imu[:, 0:3]
    raw[:NR_IMUS, 3:6] = imu[:, 3:6]


@processing_function(ProcId.READ_INERTIAL, cycles=READ_INERTIAL_CYCLES)
def read_inertial(module: Module) -> None:
    sample = module.sensors.read(module.clock.sample_index)
    if sample is None:
        module.sensors_exhausted = True
        return
    w = inertial_work(module)
    memory = module.memory
    latch_registers(sample.imu, memory.imu_raw, w.prev_acc, w.have_prev)
    memory.imu_temp[:NR_IMUS] = sample.temp
    memory.imu_mag[:NR_IMUS] = sample.mag
    memory[StateId.IMU_TS][...] = module.clock.now_cycles & 0xFFFFFFFF
