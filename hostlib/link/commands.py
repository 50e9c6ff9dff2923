"""Typed methods for every command of protocol.md §3, in the module's words.

:class:`CommandMethods` is a mixin: the class using it provides
``command(meaning, *, timeout=None, retries=None, **fields)`` which builds the
frame in the device's numbering (2014 or 2015), sends it and waits for the ack,
and ``_send_command(meaning, **fields)`` which sends a frame that gets no ack
(the packet ACK). Each method here only names the command and its fields;
layouts come from :mod:`protocol.commands`. A command the device's numbering
lacks raises :class:`hostlib.errors.NotSupportedByCommandSet` before anything
is sent.

Every method that waits returns the :class:`hostlib.events.CommandAckEvent` it
waited for (its ``command_id`` is the wire id in the device's numbering) and
takes the keyword options of :class:`AckOptions`; :meth:`~CommandMethods.ack_packet`
returns None.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, TypedDict

import numpy as np
from numpy.typing import ArrayLike

from protocol.ids import NR_IMUS, Command, Interface, OutputMode
from protocol.states import state_spec

from ..events import CommandAckEvent

if TYPE_CHECKING:
    from typing_extensions import Unpack  # typing.Unpack from Python 3.11; for type checkers only

__all__ = ["SET_STATE_SIZES", "AckOptions", "CommandMethods"]


class AckOptions(TypedDict, total=False):
    """The keyword options of every command method that waits for its ack."""

    timeout: float | None  #: seconds per attempt (default: the device's ack_timeout)
    retries: int | None  #: extra attempts after a timeout (default: the device's retries)


#: SET_STATE_n commands by the largest state size they can carry.
SET_STATE_SIZES: tuple[tuple[int, Command], ...] = (
    (1, Command.SET_STATE_1),
    (4, Command.SET_STATE_4),
    (12, Command.SET_STATE_12),
    (24, Command.SET_STATE_24),
    (48, Command.SET_STATE_48),
    (254, Command.SET_STATE_254),
)


def _ids(ids: Sequence[int], n: int, what: str) -> list[int]:
    ids = [int(i) for i in ids]
    if len(ids) > n:
        raise ValueError(f"{what} takes at most {n} ids, got {len(ids)}")
    return ids + [0] * (n - len(ids))


class CommandMethods:
    """One method per command; each returns the module's ack of it (ACK itself gets none)."""

    def command(self, meaning: Command, *, timeout: float | None = None, retries: int | None = None,
                **fields: Any) -> CommandAckEvent:  # pragma: no cover - provided by the device
        raise NotImplementedError

    def _send_command(self, meaning: Command, **fields: Any) -> None:  # pragma: no cover - the device's
        raise NotImplementedError

    # -- basics ---------------------------------------------------------------------

    def ping(self, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """PING (0x03): the ack is the answer; proves the link and the command set."""
        return self.command(Command.PING, **kw)

    def request_mcu_id(self, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """MCU_ID (0x04): the module outputs its serial number (state 0x04) once."""
        return self.command(Command.MCU_ID, **kw)

    def ack_packet(self, packet_number: int) -> None:
        """ACK (0x01) a lossless packet by number; sent once, since the module sends no ack for it."""
        self._send_command(Command.ACK, packet_number=packet_number)

    # -- states and outputs ---------------------------------------------------------

    def set_state(self, state_id: int, value: bytes | bytearray | ArrayLike,
                  **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """Set a settable state (e.g. TH_ZUPT 0x19) with the smallest SET_STATE_n that fits it.

        *value* is raw big-endian bytes of the state's size, or a value numpy
        casts to the state's type (encoded by :mod:`protocol.codec`).
        """
        from protocol.codec import encode_state

        spec = state_spec(state_id)
        data = bytes(value) if isinstance(value, (bytes, bytearray)) else encode_state(state_id, value)
        if len(data) != spec.size:
            raise ValueError(f"state 0x{state_id:02X} {spec.name} is {spec.size} bytes, got {len(data)}")
        meaning = next(cmd for size, cmd in SET_STATE_SIZES if spec.size <= size)
        return self.command(meaning, state_id=state_id, data=data, **kw)

    def output_state(self, state_id: int, mode: int, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """OUTPUT_STATE (0x20): output one state per the mode byte (sets the lossless flag from it)."""
        return self.command(Command.OUTPUT_STATE, state_id=state_id, mode=int(mode), **kw)

    def output_multiple_states(self, state_ids: Sequence[int], mode: int,
                               **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """OUTPUT_MULTIPLE_STATES (0x21): up to 8 states with one mode."""
        return self.command(Command.OUTPUT_MULTIPLE_STATES, state_ids=_ids(state_ids, 8, "0x21"),
                            mode=int(mode), **kw)

    def output_all_off(self, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """OUTPUT_ALL_OFF (0x22): periodic and conditional outputs off, packet queue emptied."""
        return self.command(Command.OUTPUT_ALL_OFF, **kw)

    def state_if_setup(self, flag_id: int, mode: int, state_ids: Sequence[int],
                       **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """STATE_IF_SETUP (0x23): conditional output of up to 8 states while *flag_id* is true.

        The firmware also copies the frame's two checksum bytes as ids (quirk §9):
        the states they name ride along; the host expects them.
        """
        return self.command(Command.STATE_IF_SETUP, flag_id=flag_id, mode=int(mode),
                            state_ids=_ids(state_ids, 8, "0x23"), **kw)

    def output_imu_rd(self, imu_selector: int, mode: int, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """OUTPUT_IMU_RD (0x28): raw inertial/temperature/magnetometer of the selected IMUs."""
        return self.command(Command.OUTPUT_IMU_RD, imu_selector=int(imu_selector), mode=int(mode), **kw)

    def set_imu_bandwidth(self, dlpf_cfg: int, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """SET_IMU_BANDWIDTH (0x29): MPU9150 DLPF_CFG 0–6."""
        return self.command(Command.SET_IMU_BANDWIDTH, dlpf_cfg=int(dlpf_cfg), **kw)

    # -- process sequence -----------------------------------------------------------

    def run_proc(self, proc_id: int, slot: int, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """RUN_PROC (0x30): put a processing function in a slot of the process sequence."""
        return self.command(Command.RUN_PROC, proc_id=int(proc_id), slot=int(slot), **kw)

    def run_mult_proc(self, proc_ids: Sequence[int], **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """RUN_MULT_PROC (0x31): processing functions in slots 0–7."""
        return self.command(Command.RUN_MULT_PROC, proc_ids=_ids(proc_ids, 8, "0x31"), **kw)

    def all_proc_off(self, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """ALL_PROC_OFF (0x32): empty the process sequence."""
        return self.command(Command.ALL_PROC_OFF, **kw)

    def mimu_frontend(self, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """MIMU_FRONTEND (0x35): sequence = read, preproc, statdet, biasest, convcomp."""
        return self.command(Command.MIMU_FRONTEND, **kw)

    def reset_proc_setup(self, flag_id: int, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """RESET_PROC_SETUP (0x36): the flag RESTORE_PROC_SEQU_IF watches."""
        return self.command(Command.RESET_PROC_SETUP, flag_id=int(flag_id), **kw)

    def store_and_empty(self, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """STORE_AND_EMPTY (0x37): copy the sequence to storage and empty it."""
        return self.command(Command.STORE_AND_EMPTY, **kw)

    def restore_proc_sequ(self, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """RESTORE_PROC_SEQU (0x38): copy the storage back to the sequence."""
        return self.command(Command.RESTORE_PROC_SEQU, **kw)

    # -- modes ----------------------------------------------------------------------

    def start_zupt_aided_ins(self, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """RESET_ZUPT_AIDED_INS (0x33; 0x10 in 2014): start the full-rate ZUPT-aided INS."""
        return self.command(Command.RESET_ZUPT_AIDED_INS, **kw)

    def start_stepwise_dead_reckoning(self, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """STEPWISE_DEAD_RECKONING (0x34; 0x14 in 2014): lossless step packets, counter from 0."""
        return self.command(Command.STEPWISE_DEAD_RECKONING, **kw)

    # -- the emulator's extensions (protocol.extensions) ---------------------------

    def height_compensation_on(self, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """RUN_PROC putting HEIGHT_COMPENSATION (0x25) in the tracking sequence
        (:func:`protocol.extensions.height_compensation_on`): send it once tracking runs, i.e.
        when the first step packet after 0x34 arrived."""
        from protocol.extensions import height_compensation_on

        meaning, fields = height_compensation_on()
        return self.command(meaning, **fields, **kw)

    def normal_imu(self, mode: int = 1, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """NORMAL_IMU (0x40): plain IMU mode, timestamp and U_K output per *mode*."""
        return self.command(Command.NORMAL_IMU, mode=int(mode), **kw)

    def normal_imu_with_bias_est(self, mode: int = 1, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """NORMAL_IMU_WITH_BIAS_EST (0x41): as 0x40 with gyro bias estimation."""
        return self.command(Command.NORMAL_IMU_WITH_BIAS_EST, mode=int(mode), **kw)

    # -- hardware in the loop -------------------------------------------------------

    def setup_debug_proc(self, proc_ids: Sequence[int], state_ids: Sequence[int],
                         interface: int = Interface.USB, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """SETUP_DEBUG_PROC (0x10): 10 functions, 10 states pulled after each INPUT_IMU_RD."""
        return self.command(Command.SETUP_DEBUG_PROC, proc_ids=_ids(proc_ids, 10, "0x10"),
                            state_ids=_ids(state_ids, 10, "0x10"), interface=int(interface), **kw)

    def input_imu_rd(self, timestamp: int, imu: ArrayLike, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """INPUT_IMU_RD (0x11): feed one raw sample (uint32 timestamp, int16 NR_IMUS×6)."""
        arr = np.asarray(imu, dtype=np.int64)
        if arr.shape != (NR_IMUS, 6):
            raise ValueError(f"imu must be {NR_IMUS}×6 raw int16 values, got shape {arr.shape}")
        return self.command(Command.INPUT_IMU_RD, timestamp=int(timestamp), imu=arr.tolist(), **kw)

    def gp_test(self, a: int = 0, b: int = 0, **kw: Unpack[AckOptions]) -> CommandAckEvent:
        """GP_TEST (0x42): does nothing but ack."""
        return self.command(Command.GP_TEST, a=int(a), b=int(b), **kw)


#: Mode byte for a pulled, lossless output (handy with output_state).
PULL_LOSSLESS = int(OutputMode.PULL | OutputMode.LOSSLESS)
