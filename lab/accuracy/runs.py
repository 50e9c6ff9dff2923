"""One replay of a recording or a simulated walk with the fusion host, summed as a host sums it.

:func:`replay_track` is the whole path a user runs: ``openshoe-emu replay --host fusion
[--height-compensation]`` (:func:`firmware_sim.app.batch.run_replay`) into the capture bytes,
then ``openshoe-host replay`` (:func:`hostlib.files.replay.replay_session`) into the track, the step
swing times and the module's serial number. The experiments run many of them through the
project's runner (:mod:`lab.runner`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Replayed", "fusion_capture", "replay_track", "height_profile", "stance_words"]


@dataclass
class Replayed:
    """A replayed walk as the host saw it."""

    track: Any  #: hostlib.track.steps.Track (with swing times)
    serial: bytes | None  #: the module's MCU serial number
    truth: Any = None  #: the simulated walk's GroundTruth (None for a recording)


def fusion_capture(source: Any, module: int | None = None, height_compensation: bool = False) -> bytes:
    """The bytes the module sends replaying *source* (a sensor source) with the fusion host
    (``openshoe-emu replay --host fusion``): each step packet carries the step's time, swing time,
    and the attitude and magnetometers at the end of its stance. *module* names the module's
    serial number (None: the emulator's default)."""
    from firmware_sim.app.batch import run_replay
    from firmware_sim.mcu.module import ModuleConfig
    from firmware_sim.transports.factory import module_serial

    config = ModuleConfig(rate_hz=float(source.rate_hz), mcu_serial=module_serial(module))
    return bytes(run_replay(source, config=config, announce=None, host="fusion",
                            height_compensation=height_compensation))


def replay_track(source: Any, height_compensation: bool, module: int | None = None,
                 truth: Any = None) -> Replayed:
    """Replay *source* (a sensor source) through the module with the fusion host."""
    from hostlib.files.replay import replay_session

    session = replay_session(fusion_capture(source, module, height_compensation))
    return Replayed(session.tracker.track, session.mcu_serial, truth)


def height_profile(track: Any) -> tuple[np.ndarray, np.ndarray]:
    """(distance walked [m], height [m], up positive) at every pose of *track*."""
    from firmware_sim.sensors.truth import walked_distance

    pos = track.positions
    return walked_distance(pos), -pos[:, 2]


def stance_words(rows: Sequence[dict[str, Any]]) -> str:
    """How the walks' stances moved, for a table's title, so that it can be reproduced whatever the
    simulation's default (:func:`firmware_sim.app.batch.stance_note` of the rows' ``stance_sway``)."""
    from firmware_sim.app.batch import stance_note

    return stance_note(any(r.get("stance_sway") for r in rows))
