"""What a replay of a simulated walk writes beside its wire capture OUT: what the simulation knows
and a host can only estimate.

* ``OUT.truth.csv``: the ground truth (:meth:`firmware_sim.sensors.truth.GroundTruth.to_csv`);
* ``OUT.iron.json``: the shoe's hard and soft iron as simulated, written as the host's
  magnetometer calibration of this module (:class:`hostlib.calibration.magcal.MagCalibration`, with the
  module's serial number). It is the calibration an in-situ fit aims at, so that
  ``openshoe-host replay OUT --compass --mag-cal OUT.iron.json`` measures the compass and the
  other aids apart from the calibration's own error. It holds the iron's rotation too, which no
  ellipsoid fit sees.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from hostlib.calibration.magcal import MagCalibration

__all__ = ["shoe_iron", "write_truth_files"]


def shoe_iron(source, serial: bytes | None = None) -> MagCalibration:
    """The hard and soft iron of *source*'s shoe as simulated, as the host's calibration of the
    module with MCU serial number *serial* (None: of no module in particular)."""
    from hostlib.calibration.drift import serial_text
    from hostlib.calibration.magcal import MagCalibration

    iron = source.magnetic
    return MagCalibration(np.array(iron.hard_iron, dtype=np.float64), np.linalg.inv(iron.soft_iron),
                          serial_text(serial) if serial is not None else "")


def write_truth_files(source, wire: Path, serial: bytes) -> None:
    """``OUT.truth.csv`` and ``OUT.iron.json`` beside the capture *wire* of a simulated *source*
    replayed by the module with MCU serial number *serial*."""
    source.truth.to_csv(wire.with_name(wire.name + ".truth.csv"))
    shoe_iron(source, serial).save(wire.with_name(wire.name + ".iron.json"))
