"""pyserial URL handler: ``serial.serial_for_url("openshoe://?...")`` opens an emulated module.

Registered by importing :mod:`firmware_sim.transports` (which appends that
package to ``serial.protocol_handler_packages``)::

    import serial, firmware_sim.transports
    s = serial.serial_for_url("openshoe://?scenario=default&seed=1&link=ideal&command_set=2015&speed=0",
                              timeout=0.5)
    s.write(bytes.fromhex("030003")); s.read(4)      # b'\\xa0\\x03\\x00\\xa3'

Options: see :mod:`firmware_sim.transports.factory`. With ``speed=0`` (the
default) the module runs in the caller's thread, in virtual time: ``read``
runs ticks until the bytes came or ``timeout`` seconds of *virtual* time
passed; ``in_waiting`` runs one tick when nothing is waiting, so a host
polling it sees time pass. Deterministic and fast. With ``speed=s > 0`` a
:class:`~firmware_sim.transports.pacer.Pacer` runs the module in a thread at
``s`` × real time and ``timeout`` is wall time. Either way the compiled path is
prepared when the port opens (:mod:`firmware_sim.nav.warmup`), so no read waits on a
compile. ``cd`` (carrier detect) is the link's connected line. The module is at
``.module`` (touch it only with speed=0, or through ``.pacer.call``).
"""

from __future__ import annotations

from serial.serialutil import PortNotOpenError, SerialBase, SerialException, to_bytes

from firmware_sim.links.link import Link
from firmware_sim.mcu.module import Module
from firmware_sim.nav.warmup import prepare_module

from .factory import EmulatorSettings, build
from .pacer import Pacer
from .pipe import QueueEndpoint, VirtualPipe


class Serial(SerialBase):
    """A pyserial port backed by an in-process emulated OpenShoe module."""

    def __init__(self, *args, **kwargs):
        self.settings: EmulatorSettings | None = None
        self.module: Module | None = None
        self.link: Link | None = None
        self.pacer: Pacer | None = None
        self._pipe: VirtualPipe | None = None
        self._endpoint: QueueEndpoint | None = None
        super().__init__(*args, **kwargs)

    # ------------------------------------------------------------------ open / close
    def open(self) -> None:
        if self.is_open:
            raise SerialException("Port is already open.")
        if self._port is None:
            raise SerialException("Port must be configured before it can be used.")
        try:
            self.settings = s = EmulatorSettings.from_url(self._port)
            built = build(s)
        except ValueError as e:
            raise SerialException(f"bad openshoe URL {self._port!r}: {e}") from e
        self.module, self.link = built.module, built.link
        iface = built.interface
        if s.speed == 0:
            prepare_module(self.module)  # reads run the clock: no compile may happen inside one
            self._pipe = VirtualPipe(self.module, iface)
        else:
            port = self.module.usb.port if iface == "usb" else self.module.bt.port
            self._endpoint = QueueEndpoint(port)
            self.pacer = Pacer(self.module, [self._endpoint], speed=s.speed).start()
        self.is_open = True

    def close(self) -> None:
        if self.is_open:
            self.is_open = False
            if self.pacer is not None:
                self._endpoint.close()  # type: ignore[union-attr]
                self.pacer.stop()
            if self._pipe is not None:
                self._pipe.close()

    def from_url(self, url: str) -> EmulatorSettings:
        return EmulatorSettings.from_url(url)

    def _reconfigure_port(self, *args, **kwargs) -> None:
        """Baud rate and framing mean nothing here; the link model sets the pace."""

    # ------------------------------------------------------------------ data
    def _check(self) -> None:
        if not self.is_open:
            raise PortNotOpenError()

    @property
    def in_waiting(self) -> int:
        self._check()
        if self._pipe is not None:
            return self._pipe.in_waiting
        return self._endpoint.in_waiting  # type: ignore[union-attr]

    def read(self, size: int = 1) -> bytes:
        self._check()
        if size <= 0:
            return b""
        if self._pipe is not None:
            return self._pipe.read(size, timeout=self._timeout)
        return self._endpoint.read(size, timeout=self._timeout)  # type: ignore[union-attr]

    def write(self, data) -> int:
        self._check()
        data = to_bytes(data)
        if self._pipe is not None:
            self._pipe.write(data)
        else:
            self._endpoint.write(data)  # type: ignore[union-attr]
        return len(data)

    def flush(self) -> None:
        """Nothing to flush: writes reach the link at once."""

    def reset_input_buffer(self) -> None:
        self._check()
        if self._pipe is not None:
            self._pipe.reset_input_buffer()
        else:
            self._endpoint.reset_input_buffer()  # type: ignore[union-attr]

    def reset_output_buffer(self) -> None:
        self._check()

    @property
    def out_waiting(self) -> int:
        return 0

    # ------------------------------------------------------------------ modem lines
    def _update_break_state(self) -> None:
        pass

    def _update_rts_state(self) -> None:
        pass

    def _update_dtr_state(self) -> None:
        pass

    @property
    def cts(self) -> bool:
        self._check()
        return True

    @property
    def dsr(self) -> bool:
        self._check()
        return True

    @property
    def ri(self) -> bool:
        self._check()
        return False

    @property
    def cd(self) -> bool:
        self._check()
        return bool(self.link is not None and self.link.connected)
