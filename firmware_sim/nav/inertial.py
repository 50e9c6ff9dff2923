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

if TYPE_CHECKING:  # pragma: no cover
    from firmware_sim.mcu.module import Module

#: Modelled CPU cost of reading four MPU9150s: the chips sit on their own TWI buses and
#: are read by DMA, so the CPU only starts the transfers, waits for the last one to
#: complete and copies 4 × 20 register bytes (a model, not a measurement).
READ_INERTIAL_CYCLES = 3_000


def _work() -> dict[str, np.ndarray]:
    return {
        "prev_acc": np.zeros((NR_IMUS, 3), dtype=np.int16),  # last read's accelerometer
        "have_prev": np.zeros(1, dtype=np.bool_),
    }


@processing_function(ProcId.READ_INERTIAL, cycles=READ_INERTIAL_CYCLES)
def read_inertial(module: Module) -> None:
    sample = module.sensors.read(module.clock.sample_index)
    if sample is None:
        module.sensors_exhausted = True
        return
    w = module.work("inertial", _work)
    memory = module.memory
    raw = memory.imu_raw
    prev = w["prev_acc"]
    imu = sample.imu
    if w["have_prev"][0]:
        raw[:NR_IMUS, 0:3] = prev
    else:
        raw[:NR_IMUS, 0:3] = imu[:, 0:3]
        w["have_prev"][0] = True
    prev[...] = imu[:, 0:3]
    raw[:NR_IMUS, 3:6] = imu[:, 3:6]
    memory.imu_temp[:NR_IMUS] = sample.temp
    memory.imu_mag[:NR_IMUS] = sample.mag
    memory[StateId.IMU_TS][...] = module.clock.now_cycles & 0xFFFFFFFF
