"""The emulator's extensions of the protocol, and the commands a host sends to use them.

They live in the free id ranges firmware.md §2 leaves for new functions and states
(a real OpenShoe module does not have them, and answers their ids as unknown):

* processing function 0x25 HEIGHT_COMPENSATION — the step's height from the ground's slope
  (shared/spec/aids.md §5), a measurement in the module's own filter;
* state 0x34 SWING_TIME — seconds without ZUPT in the step just reported (float32);
* state 0x35 THETA_INIT — the foot's pitch and roll [rad] on level ground, from the initial
  alignment (2 × float32; a host may set it);
* state 0x36 THETA_GROUND — the ground's slope along and across the foot [rad], low-passed
  from stance to stance (2 × float32).

A host uses them through the ordinary commands, as it would any function or state; this
module declares those commands once, for the host SDK and the emulator's replayed host:

* :func:`height_compensation_on` — RUN_PROC putting HEIGHT_COMPENSATION in the last-but-one
  free slot of the tracking sequence (:data:`HEIGHT_COMPENSATION_SLOT`). It acts on the
  *running* sequence, so a host sends it once tracking runs, i.e. when the first step packet
  after 0x34 arrives (before, the alignment sequence runs and the tracking sequence waits in
  storage).
* :func:`fusion_output_setup` — STATE_IF_SETUP that makes every step packet carry what the
  host-side aids need besides DX, DP and the step counter: the swing time (drift correction),
  and the attitude quaternion and three IMUs' magnetometers at the reset, i.e. at the end of the
  stance (the per-step compass, shared/spec/aids.md §1; the magnetometers are the ordinary IMU
  states 0x90+i, so a real module answers them too).
  Sent right after 0x34, which sets up the plain step output.
* :data:`FUSION_SETUP` — everything a host using the host-side aids sends after the ack of
  0x34, one command at a time (each after the ack of the one before): that STATE_IF_SETUP, then
  MCU_ID (the module's serial number, which a per-module calibration is checked against).
  ``openshoe-host track --fusion`` and the emulator's replayed host (``--host fusion``) send
  exactly these.
* :func:`fusion_step_ids` — the states a step packet carries after that set-up, as the firmware
  assembles them: :data:`FUSION_STEP_STATES` plus the states the STATE_IF_SETUP frame's two
  checksum bytes name (protocol.md §9), in ascending id order.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

from .codec import fitting_ids
from .commands import CommandSet
from .frames import build_command
from .ids import Command, OutputMode, ProcId, StateId, imu_mag_id

__all__ = ["EXTENSION_STATES", "FUSION_MAG_IMUS", "FUSION_SETUP", "FUSION_STEP_STATES",
           "HEIGHT_COMPENSATION_SLOT", "fusion_output_setup", "fusion_step_ids", "height_compensation_on"]

#: The emulator's extension states: a real OpenShoe module has none of them, and leaves them
#: out of every output it is asked for (an id with no state is ignored, protocol.md §4).
EXTENSION_STATES: frozenset[int] = frozenset({StateId.SWING_TIME, StateId.THETA_INIT, StateId.THETA_GROUND})

#: The slot HEIGHT_COMPENSATION runs in: after STATE_OUTPUT_IF (slot 9) of the tracking
#: sequence that 0x34 sets up; slots 10 and 11 are empty there.
HEIGHT_COMPENSATION_SLOT = 10

#: The IMUs whose magnetometer a fusion step packet carries: three, because STATE_IF_SETUP takes
#: eight ids and the first five are spoken for (averaging three chips' readings divides their noise
#: by √3; the fourth chip would add little).
FUSION_MAG_IMUS: tuple[int, ...] = (0, 1, 2)

#: The states of a step packet with the host-side aids' set-up, in the order asked for.
FUSION_STEP_STATES: tuple[int, ...] = (StateId.DX, StateId.DP, StateId.STEP_COUNTER, StateId.SWING_TIME,
                                       StateId.QUATERNION, *(imu_mag_id(i) for i in FUSION_MAG_IMUS))


def height_compensation_on() -> tuple[Command, dict[str, Any]]:
    """The command (meaning and payload fields) that turns height compensation on."""
    return Command.RUN_PROC, {"proc_id": int(ProcId.HEIGHT_COMPENSATION), "slot": HEIGHT_COMPENSATION_SLOT}


def fusion_output_setup() -> tuple[Command, dict[str, Any]]:
    """The command (meaning and payload fields) of the step output the host-side aids need:
    the flag and mode 0x34 uses (FILTER_RESET_FLAG, pull), and :data:`FUSION_STEP_STATES`.
    The firmware also takes the frame's checksum bytes as two more ids (protocol.md §9)."""
    ids = [int(s) for s in FUSION_STEP_STATES] + [0] * (8 - len(FUSION_STEP_STATES))
    assert len(ids) == 8
    return Command.STATE_IF_SETUP, {"flag_id": int(StateId.FILTER_RESET_FLAG), "mode": int(OutputMode.PULL),
                                    "state_ids": ids}


#: The commands (meaning, payload fields) a host using the host-side aids sends after the ack of
#: 0x34, in order, each once the module acknowledged the one before: the fusion step output
#: (:func:`fusion_output_setup`), then MCU_ID (0x04: the module outputs its serial number once,
#: in a packet of its own, before its first step).
FUSION_SETUP: tuple[tuple[Command, Mapping[str, Any]], ...] = tuple(
    (meaning, MappingProxyType({k: tuple(v) if isinstance(v, list) else v for k, v in fields.items()}))
    for meaning, fields in (fusion_output_setup(), (Command.MCU_ID, {}))
)


def fusion_step_ids(command_set: CommandSet | None = None) -> tuple[int, ...]:
    """The states of a step packet after :data:`FUSION_SETUP`, in payload order, as the firmware
    assembles them: the 8 ids of the STATE_IF_SETUP frame and its two checksum bytes taken as
    ids (protocol.md §9), those with a state, ascending. With the current numbering the checksum
    is ``03 12``: GP_DT (0x03) and T_INT_K (0x12, the timestamp of the measurement the filter
    processed, which times the step) ride along.

    A real module, which lacks :data:`EXTENSION_STATES`, sends the same without them."""
    meaning, fields = fusion_output_setup()
    frame = build_command(meaning, command_set=command_set, **fields)
    return tuple(fitting_ids([*fields["state_ids"], frame[-2], frame[-1]]))
