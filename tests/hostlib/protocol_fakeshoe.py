"""pyserial URL handler ``fakeshoe://N`` for CLI tests: a scripted module that walks N steps.

Registered by the tests with ``serial.protocol_handler_packages.append("tests.hostlib")``.
On 0x34 it acks, then sends N step packets (1 m north each), stop-and-wait: the
next one only after the host acked the previous one, as a lossless module does.
On 0x04 it sends the MCU id packet.
"""

from __future__ import annotations

import numpy as np

from protocol.codec import encode_state, encode_step
from protocol.frames import build_command_ack, build_state_packet
from protocol.ids import StateId

from .fakes import FakeModulePort

MCU_ID = bytes(range(0x10, 0x1F))


class Serial(FakeModulePort):
    def __init__(self, port=None, *args, timeout=None, **kwargs):
        super().__init__()
        self.timeout = timeout
        self.is_open = False
        self._steps_left = 0
        self._number = 0
        self.on_command = self._reply

    def open(self):
        n = str(self.port).split("://", 1)[1] or "3"
        self._steps_total = int(n)
        self.is_open = True

    def _next_number(self) -> int:
        self._number += 1
        return self._number

    def _reply(self, frame: bytes) -> bytes:
        out = build_command_ack(frame[0])
        if frame[0] == 0x34:
            self._steps_left = self._steps_total
            self._step_counter = 0
            out += self._next_step()
        elif frame[0] == 0x04:
            out += build_state_packet(self._next_number(), encode_state(StateId.MCU_ID, MCU_ID))
        return out

    def _next_step(self) -> bytes:
        if self._steps_left <= 0:
            return b""
        self._steps_left -= 1
        self._step_counter += 1
        self._pending = self._next_number()
        return build_state_packet(self._pending, encode_step(np.array([1.0, 0, 0, 0]), np.eye(4) * 1e-4,
                                                             self._step_counter))

    def _run_parser(self) -> None:
        before = len(self.packet_acks)
        super()._run_parser()
        for n in self.packet_acks[before:]:
            if n == getattr(self, "_pending", None):
                self._pending = None
                self._rx += self._next_step()
