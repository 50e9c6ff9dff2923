"""pyserial URL handler ``fakeshoe://N`` for CLI tests: a scripted module that walks N steps.

Registered by the tests with ``serial.protocol_handler_packages.append("tests.hostlib")``.
On 0x34 it acks, then sends N step packets (1 m north each), stop-and-wait: the
next one only after the host acked the previous one, as a lossless module does.
On 0x04 it sends the MCU id packet.

``fakeshoe://N/fusion`` is a module with the emulator's extensions: after 0x34 it
"aligns" until the host's MCU_ID (0x04, the last command of the fusion set-up),
then walks; its step packets carry the conditional output a STATE_IF_SETUP set up
(the 8 ids and the frame's checksum bytes, protocol.md §9), each step with a swing
time of :data:`SWING_TIME_S`. ``fakeshoe://N/fusion/wiggle`` is worn through an in-situ
calibration: after MCU_ID it waits for the magnetometer stream (0x21 with a rate), then sends a
wiggle's stream packets (:func:`.wiggles.wiggle_packets`) and walks; 0x21 with rate 0 stops it.
``fakeshoe://N/dropK`` loses its link once the host acked its K-th step packet (a port re-opened
after that is a module that was never started: silent). ``fakeshoe://N/fusion/moduleK`` is another
module: its serial number is :func:`module_id` (K). ``fakeshoe://N/nosetup`` ignores STATE_IF_SETUP
(0x23: no ack, its step output unchanged), as a firmware without it would; ``fakeshoe://N/fusion/real``
takes it as a real OpenShoe module does, leaving the emulator's extension states (SWING_TIME) out of its
step packets. Every port made is kept in :data:`PORTS`.
"""

from __future__ import annotations

import numpy as np

from protocol.codec import STEP_IDS, encode_state, encode_states, fitting_ids
from protocol.extensions import EXTENSION_STATES, MAG_STREAM_STATES
from protocol.frames import build_command_ack, build_state_packet
from protocol.ids import OutputMode, StateId

from .fakes import FakeModulePort
from .loops import STANCE_STATES

MCU_ID = bytes(range(0x10, 0x1F))


def module_id(k: int) -> bytes:
    """The serial number of ``fakeshoe://…/moduleK``: :data:`MCU_ID` with its last byte K."""
    return MCU_ID[:-1] + bytes([k])


#: The swing time of every step of a ``/fusion`` module [s].
SWING_TIME_S = 0.5
#: Every port opened, in order (a test reads what the host sent from the last one).
PORTS: list[Serial] = []


class Serial(FakeModulePort):
    def __init__(self, port=None, *args, timeout=None, **kwargs):
        super().__init__()
        self.timeout = timeout
        self.is_open = False
        self._steps_left = 0
        self._step_counter = 0
        self._number = 0
        self.on_command = self._reply
        self.fusion = False
        self.wiggle = False
        self.drop_after: int | None = None
        self._output_ids: tuple[int, ...] = STEP_IDS
        PORTS.append(self)

    def open(self):
        n, *variants = (str(self.port).split("://", 1)[1] or "3").split("/")
        self._steps_total = int(n)
        self.fusion = "fusion" in variants
        self.wiggle = "wiggle" in variants
        self.no_setup = "nosetup" in variants
        self.real = "real" in variants
        drops = [int(v[4:]) for v in variants if v.startswith("drop")]
        self.drop_after = drops[0] if drops else None
        modules = [int(v[6:]) for v in variants if v.startswith("module")]
        self.mcu_id = module_id(modules[0]) if modules else MCU_ID
        self.is_open = True

    def _next_number(self) -> int:
        self._number += 1
        return self._number

    def _reply(self, frame: bytes) -> bytes:
        if frame[0] == 0x23 and self.no_setup:
            return b""
        out = build_command_ack(frame[0])
        if frame[0] == 0x34:
            self._steps_left = self._steps_total
            self._step_counter = 0
            self._output_ids = STEP_IDS
            if not self.fusion:
                out += self._next_step()
        elif frame[0] == 0x23:  # quirk: the frame's checksum bytes are ids 9 and 10
            ids = fitting_ids([*frame[3:11], frame[-2], frame[-1]])
            self._output_ids = tuple(i for i in ids if not (self.real and i in EXTENSION_STATES))
        elif frame[0] == 0x04:
            out += build_state_packet(self._next_number(), encode_state(StateId.MCU_ID, self.mcu_id))
            if self.fusion and not self.wiggle and self._step_counter == 0:
                out += self._next_step()
        elif frame[0] == 0x21 and self.wiggle and frame[9] & OutputMode.RATE_MASK:
            from .wiggles import wiggle_packets

            for states in wiggle_packets()[0]:
                out += build_state_packet(self._next_number(), encode_states(MAG_STREAM_STATES, states))
            out += self._next_step()
        return out

    def _next_step(self) -> bytes:
        if self._steps_left <= 0:
            return b""
        self._steps_left -= 1
        self._step_counter += 1
        self._pending = self._next_number()
        values = {StateId.DX: np.array([1.0, 0, 0, 0]), StateId.DP: (np.eye(4) * 1e-4)[np.triu_indices(4)],
                  StateId.STEP_COUNTER: self._step_counter, StateId.SWING_TIME: SWING_TIME_S,
                  **STANCE_STATES, StateId.T_INT_K: 64_000 * self._step_counter}
        return build_state_packet(self._pending, encode_states(self._output_ids, values))

    def _run_parser(self) -> None:
        before = len(self.packet_acks)
        super()._run_parser()
        for n in self.packet_acks[before:]:
            if n == getattr(self, "_pending", None):
                self._pending = None
                if self._step_counter == self.drop_after:
                    self.drop()
                    return
                self._rx += self._next_step()
