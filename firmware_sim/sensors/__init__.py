"""Sensor sources for READ_INERTIAL: the simulated 4-IMU array on a walking foot, and replay.

They implement the µC's IMU bus (:mod:`firmware_sim.mcu.imu_bus`: ``SensorSource``,
``RawSample``, the scripted source for tests).

Entry points: :func:`make_source` / :func:`list_scenarios` (simulation, with
ground truth in ``source.truth``), :class:`ReplaySource` /
:func:`load_recording` (recorded walks), :class:`SensorConfig` (every number
of the sensor model; ``SensorConfig.ideal()`` switches all errors off).
Submodules are imported lazily, so importing one model does not load them all.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

_EXPORTS = {
    "SensorConfig": "config", "DEFAULT_CONFIG": "config", "IDEAL_CONFIG": "config",
    "make_source": "imu_array", "SimulatedSource": "imu_array",
    "list_scenarios": "scenarios", "trajectory": "scenarios", "SCENARIOS": "scenarios",
    "GaitBuilder": "gait_builder", "GaitParams": "gait", "GroundTruth": "truth",
    "Recording": "replay", "RecordingFormatError": "replay", "ReplaySource": "replay",
    "load_recording": "replay", "save_csv": "replay",
}  # fmt: skip

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(import_module(f"{__name__}.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
