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
  ``openshoe-host track`` and ``log`` (by default; not with ``--no-fusion``) and the emulator's
  replayed host (``--host fusion``) send exactly these.
* :func:`fusion_step_ids` — the states a step packet carries after that set-up, as the firmware
  assembles them: :data:`FUSION_STEP_STATES` plus the states the STATE_IF_SETUP frame's two
  checksum bytes name (protocol.md §9), in ascending id order.
* :data:`MAG_STREAM_START` and :data:`MAG_STREAM_STOP` — the magnetometer stream of the in-situ
  calibration (shared/spec/aids.md §3): while the wearer wiggles the shoe the host needs the field
  from many orientations, not one reading per step. OUTPUT_MULTIPLE_STATES (0x21, OUTPUT_STATE for
  up to eight states in one frame, so the four switch on and off together) puts
  :data:`MAG_STREAM_STATES` — the magnetometers of :data:`FUSION_MAG_IMUS` and QUATERNION, so that
  the same stream can serve a continuous compass — on periodic output at rate code
  :data:`MAG_STREAM_RATE`, and switches them off again. Sent after :data:`FUSION_SETUP` (the step
  packets already carry these states, so a stream packet that falls in a step's cycle is the step
  packet, protocol.md §6); stopped when the calibration ends, at the first long step.

  The rate: 62.5 Hz at the module's 1 kHz loop (every 16 cycles). The AK8975 gives a new reading
  at 100 Hz and holds it in between, so this is the fastest rate at which no packet repeats the
  reading of the one before (at 125 Hz one in five would). A packet is 4 + 16 + 3 · 6 + 2 = 40
  bytes: 2.5 kB/s, 22 % of the Bluetooth UART's 11.5 kB/s (protocol.md §8), which leaves the
  steps, the acks and a link's bursts their room; a 30 s wiggle gives about 1900 readings.

  The stream is lossy: lossless mode is stop-and-wait, one packet per round trip (over Bluetooth
  20–40 ms each way, 12–25 packets a second), so a lossless stream at this rate — or at the
  slowest, 15.6 Hz — would fill the 2048-byte queue and then drop whole packets, step packets
  too; a lost reading costs the fit nothing. Since OUTPUT_STATE and OUTPUT_MULTIPLE_STATES set the
  interface's lossless flag from the mode byte (protocol.md §9), the step packets are lossy as well
  while the stream runs (a wiggle's step is a few centimetres; a lost one is reported as a gap).
  :data:`MAG_STREAM_STOP` switches the four outputs off (rate 0) with the lossless bit set: the
  step output is lossless again and the conditional output untouched (OUTPUT_ALL_OFF would clear
  it).
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
           "HEIGHT_COMPENSATION_SLOT", "MAG_STREAM_RATE", "MAG_STREAM_START", "MAG_STREAM_STATES",
           "MAG_STREAM_STOP", "fusion_output_setup", "fusion_step_ids", "height_compensation_on",
           "mag_stream"]

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


def _frozen(commands) -> tuple[tuple[Command, Mapping[str, Any]], ...]:
    """(meaning, fields) pairs as constants: the fields read-only, their lists tuples."""
    return tuple((meaning, MappingProxyType({k: tuple(v) if isinstance(v, list) else v
                                              for k, v in fields.items()}))
                 for meaning, fields in commands)


#: The commands (meaning, payload fields) a host using the host-side aids sends after the ack of
#: 0x34, in order, each once the module acknowledged the one before: the fusion step output
#: (:func:`fusion_output_setup`), then MCU_ID (0x04: the module outputs its serial number once,
#: in a packet of its own, before its first step).
FUSION_SETUP: tuple[tuple[Command, Mapping[str, Any]], ...] = _frozen(
    [fusion_output_setup(), (Command.MCU_ID, {})])


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


#: The states of the in-situ calibration's magnetometer stream, ascending: QUATERNION (0x22) and the
#: magnetometers of :data:`FUSION_MAG_IMUS` (0x90–0x92), all of them in every fusion step packet too.
MAG_STREAM_STATES: tuple[int, ...] = (StateId.QUATERNION, *(imu_mag_id(i) for i in FUSION_MAG_IMUS))

#: The stream's rate code (mode bits 0x07): every 2^(5−1) = 16 loop cycles, 62.5 Hz at 1 kHz
#: (module docstring: the AK8975's 100 Hz and the Bluetooth bandwidth).
MAG_STREAM_RATE = 5


def mag_stream(on: bool) -> tuple[Command, dict[str, Any]]:
    """The command (meaning and payload fields) that switches the magnetometer stream on (lossy,
    at :data:`MAG_STREAM_RATE`) or off (rate 0, lossless again): OUTPUT_MULTIPLE_STATES of
    :data:`MAG_STREAM_STATES`, the unused ids 0."""
    ids = [int(s) for s in MAG_STREAM_STATES] + [0] * (8 - len(MAG_STREAM_STATES))
    mode = MAG_STREAM_RATE if on else int(OutputMode.LOSSLESS)
    return Command.OUTPUT_MULTIPLE_STATES, {"state_ids": ids, "mode": mode}


#: The commands (meaning, payload fields) that start the magnetometer stream, sent once the
#: module acknowledged :data:`FUSION_SETUP`'s last: ``21 22 90 91 92 00 00 00 00 05 01 FB``.
MAG_STREAM_START: tuple[tuple[Command, Mapping[str, Any]], ...] = _frozen([mag_stream(True)])

#: The commands that stop it again, the step output lossless as after 0x34:
#: ``21 22 90 91 92 00 00 00 00 10 02 06``.
MAG_STREAM_STOP: tuple[tuple[Command, Mapping[str, Any]], ...] = _frozen([mag_stream(False)])
