"""pyserial URL handler ``fakegps://N`` for CLI tests: a GPS receiver that is pulled out.

Registered by the tests with ``serial.protocol_handler_packages.append("tests.hostlib")``. It says
:func:`epochs` (N epochs of GGA and RMC: a walker one metre north a second from the emulator's
default origin, no receiver error) and a garbled line, all waiting at once; then it is gone: the
next read fails as pyserial's does for a device that went away.
"""

from __future__ import annotations

import numpy as np
import serial

from firmware_sim.sensors.gps import GpsErrors, nmea_lines, simulate_fixes

#: A receiver without errors: its fixes are where the walker is.
EXACT = GpsErrors(horizontal_rms_m=0.0, vertical_rms_m=0.0, white_m=0.0)
GARBLED = b"$GPGGA,garbled*00\r\n"


def epochs(n: int, errors: GpsErrors = EXACT) -> list[str]:
    """GGA and RMC of *n* epochs (1 Hz) of a walker going north at 1 m/s."""
    t = np.arange(0.0, n - 0.5, 0.01)
    pos = np.column_stack([t, np.zeros_like(t), np.zeros_like(t)])
    vel = np.column_stack([np.ones_like(t), np.zeros_like(t), np.zeros_like(t)])
    return list(nmea_lines(simulate_fixes(t, pos, vel, errors=errors)))


class Serial:
    def __init__(self, port=None, *args, timeout=None, **kwargs):
        self.port = port
        self.timeout = timeout
        self.is_open = False
        self._data = b""

    def open(self) -> None:
        n = int(str(self.port).split("://", 1)[1] or "3")
        self._data = "".join(line + "\r\n" for line in epochs(n)).encode("ascii") + GARBLED
        self.is_open = True

    @property
    def in_waiting(self) -> int:
        return len(self._data)

    def read(self, size: int = 1) -> bytes:
        if not self._data:
            raise serial.SerialException("device reports readiness to read but returned no data "
                                         "(device disconnected or multiple access on port?)")
        out, self._data = self._data[:size], self._data[size:]
        return out

    def write(self, data: bytes) -> int:
        return len(data)

    def close(self) -> None:
        self.is_open = False
