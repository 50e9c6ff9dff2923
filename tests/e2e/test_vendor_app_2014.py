"""A host app written for the 2014 firmware tracks a walk against `openshoe-emu serve --command-set 2014`.

The app below is deliberately *not* our SDK: it is what vendor apps of the
time did — open the serial port, send the 2014 step-wise command ``14 00 14``,
read the 4-byte ack, then read fixed 64-byte frames, check header and
checksum, acknowledge each with ``01 · number · checksum`` and sum the steps
itself. It only uses ``struct`` and pyserial, so it shows that the emulator
speaks the 2014 protocol the way those apps expect, byte for byte.
"""

from __future__ import annotations

import math
import struct
import sys

import pytest
import serial

from firmware_sim.app.serve import spawn

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="ptys are tested on Linux")

#: A short walk: 3 s still (alignment), 10 m straight, 2 s still.
RECIPE = "stand:3+walk:10+stand:2"


class VendorApp2014:
    """A minimal 2014-era host: fixed 64-byte step frames, acked one by one."""

    START = bytes([0x14, 0x00, 0x14])  # step-wise dead reckoning, 2014 numbering
    START_ACK = bytes([0xA0, 0x14, 0x00, 0xB4])

    def __init__(self, port: serial.Serial):
        self.port = port
        self.x = self.y = self.heading = 0.0
        self.counters: list[int] = []
        self.frames = 0

    @staticmethod
    def checksum(data: bytes) -> bytes:
        return struct.pack(">H", sum(data) & 0xFFFF)

    def start(self) -> bytes:
        self.port.write(self.START)
        return self.port.read(4)

    def read_step(self) -> bool:
        frame = self.port.read(64)
        if len(frame) < 64:
            return False
        self.frames += 1
        assert frame[0] == 0xAA and frame[3] == 0x3A, frame.hex(" ")
        assert frame[-2:] == self.checksum(frame[:-2]), f"bad checksum: {frame.hex(' ')}"
        number = frame[1:3]
        self.port.write(b"\x01" + number + self.checksum(b"\x01" + number))
        dx, dy, _dz, dpsi = struct.unpack(">4f", frame[4:20])
        (counter,) = struct.unpack(">H", frame[60:62])
        if self.counters and counter == self.counters[-1]:
            return True  # a resend: the ack crossed it
        self.counters.append(counter)
        c, s = math.cos(self.heading), math.sin(self.heading)
        self.x += c * dx - s * dy
        self.y += s * dx + c * dy
        self.heading += dpsi
        return True


@pytest.mark.slow
def test_2014_vendor_app_tracks_a_walk(tmp_path):
    with spawn("--pty", str(tmp_path / "rfcomm0"), "--command-set", "2014", "--scenario", RECIPE,
               "--speed", "0", "--status-interval", "0") as srv, \
            serial.Serial(srv.ready["bt-pty"], timeout=10) as port:
        app = VendorApp2014(port)
        assert app.start() == VendorApp2014.START_ACK
        while math.hypot(app.x, app.y) < 9.0 or len(app.counters) < 6:
            assert app.read_step(), f"no step frame within 10 s after {app.counters}"
        # the served scenario goes on standing still: steps keep coming, with ~zero length
        assert app.counters == list(range(1, len(app.counters) + 1))
    assert 9.0 <= math.hypot(app.x, app.y) <= 11.0
    assert abs(app.y) < 1.0, "walked straight ahead (x is the initial heading)"


def test_2014_app_gets_silence_from_a_2015_module(tmp_path):
    """protocol.md §10: `14 00 14` is an incomplete SET_STATE_12 for the current firmware."""
    with spawn("--pty", str(tmp_path / "new"), "--scenario", "stand", "--link", "usb",
               "--status-interval", "0") as srv, serial.Serial(srv.ready["bt-pty"], timeout=0.5) as port:
        app = VendorApp2014(port)
        assert app.start() == b""
        assert port.read(64) == b""
