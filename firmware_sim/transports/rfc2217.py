"""An RFC 2217 endpoint (pyserial's PortManager) for hosts that need modem lines over TCP.

Clients open it with pyserial's ``rfc2217://HOST:PORT``; line settings are
accepted and reported back but change nothing (the emulated UART has no baud
rate of its own on this side of the link).
"""

from __future__ import annotations

from typing import Any

from firmware_sim.mcu.port import Port

from .tcp import TcpEndpoint


class _EmulatedLineSettings:
    """What an RFC 2217 client may read or set on the "serial port": a UART at 115200 8N1.

    The emulated link ignores the settings (its rate is the link model's); CD
    is the link's connected line.
    """

    def __init__(self, port: Port):
        self._port = port
        self.baudrate = 115200
        self.bytesize = 8
        self.parity = "N"
        self.stopbits = 1
        self.xonxoff = False
        self.rtscts = False
        self.break_condition = False
        self.dtr = True
        self.rts = True
        self.cts = True
        self.dsr = True
        self.ri = False

    @property
    def cd(self) -> bool:
        return bool(self._port.connected)

    def reset_input_buffer(self) -> None:
        pass

    def reset_output_buffer(self) -> None:
        pass


class Rfc2217Endpoint(TcpEndpoint):
    """Serve *port* over RFC 2217 (telnet COM-port control) to one TCP host at a time.

    Hosts open it with pyserial as ``rfc2217://HOST:PORT``. Telnet negotiation
    and escaping are pyserial's :class:`serial.rfc2217.PortManager`; everything
    else (accepting, pairing, hang-up, buffering) is the plain TCP endpoint's.
    """

    kind = "rfc2217"

    def __init__(self, port: Port, host: str = "127.0.0.1", tcp_port: int = 0):
        super().__init__(port, host, tcp_port)
        self.manager: Any = None

    def write(self, data: bytes) -> None:
        """The PortManager's "connection": its telnet replies go to the host."""
        self._out += data

    def _on_pair(self) -> None:
        from serial.rfc2217 import PortManager

        self.manager = PortManager(_EmulatedLineSettings(self.port), self)

    def _from_host(self, data: bytes) -> bytes:
        return b"".join(self.manager.filter(data))

    def _to_host(self, data: bytes) -> bytes:
        return b"".join(self.manager.escape(data))
