"""Sensor sources for READ_INERTIAL: the simulated 4-IMU array on a walking foot, and replay.

They implement the µC's IMU bus (:mod:`firmware_sim.mcu.imu_bus`: ``SensorSource``,
``RawSample``, the scripted source for tests).

Entry points: :func:`make_source` / :func:`list_scenarios` (simulation, with
ground truth in ``source.truth``), :class:`ReplaySource` /
:func:`load_recording` (recorded walks), :class:`SensorConfig` (every number
of the sensor model; ``SensorConfig.ideal()`` switches all errors off),
:func:`warm_up_compiled_loops` (the simulation's compiled loops, :mod:`.compiled`, readied at once).
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

__all__ = sorted([*_EXPORTS, "warm_up_compiled_loops"])


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(import_module(f"{__name__}.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def warm_up_compiled_loops() -> bool:
    """Ready every compiled loop of the simulation now (from numba's cache, or compiled) rather than
    in the first long walk; whether they are compiled (:mod:`.compiled`)."""
    from . import mpu9150, sines

    return all([sines.warm_up(), mpu9150.warm_up_scan()])
