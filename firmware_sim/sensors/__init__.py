"""Sensor sources for READ_INERTIAL: scripted, simulated 4-IMU array on a walking foot, replay.

Entry points: :func:`make_source` / :func:`list_scenarios` (simulation, with
ground truth in ``source.truth``), :class:`ReplaySource` /
:func:`load_recording` (recorded walks), :class:`SensorConfig` (every number
of the sensor model; ``SensorConfig.ideal()`` switches all errors off).
Submodules are imported lazily so that ``sensors.base`` stays light.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

_EXPORTS = {
    "RawSample": "base", "SensorSource": "base", "ScriptedSource": "base",
    "SensorConfig": "config", "DEFAULT_CONFIG": "config", "IDEAL_CONFIG": "config",
    "make_source": "array", "SimulatedSource": "array",
    "list_scenarios": "scenarios", "trajectory": "scenarios", "SCENARIOS": "scenarios",
    "GaitBuilder": "gait", "GaitParams": "gait", "GroundTruth": "truth",
    "Recording": "replay", "RecordingFormatError": "replay", "ReplaySource": "replay",
    "load_recording": "replay", "save_csv": "replay",
}  # fmt: skip

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(import_module(f"{__name__}.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
