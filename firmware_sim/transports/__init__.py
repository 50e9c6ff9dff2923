"""Transports: how a host reaches an emulated module (docs/design.md, firmware_sim).

* :mod:`.pipe` — :class:`~.pipe.VirtualPipe` (in-process, virtual time, deterministic) and
  :class:`~.pipe.QueueEndpoint` (in-process, real time, pumped by a pacer);
* :mod:`.pacer` — :class:`~.pacer.single.Pacer`, runs a module's ticks paced to the wall clock
  and pumps endpoints (:class:`~.pacer.group.MultiPacer`: many modules in one loop);
  :class:`~.pacer.status.PacerStatus` for a status line; ``wait_ticks``/``wait_until`` to wait
  on a running module's ticks;
* :mod:`.tcp` — :class:`~.tcp.TcpEndpoint`, one TCP host at a time;
* :mod:`.pty_endpoint` — :class:`~.pty_endpoint.PtyEndpoint`, a pty behind a stable symlink for
  ``serial.Serial(path)``;
* :mod:`.protocol_openshoe` — the pyserial ``openshoe://`` URL handler, registered on import
  of this package (:func:`register_url_handler`);
* :mod:`.factory` — :class:`~.factory.EmulatorSettings` (checked when made) and
  :func:`~.factory.build`: a module, its links and the endpoints asked for; used by ``serve``,
  the URL handler and the demo.
"""

from __future__ import annotations

import serial

PACKAGE = __name__


def register_url_handler() -> None:
    """Make ``serial.serial_for_url("openshoe://...")`` find our handler (idempotent)."""
    if PACKAGE not in serial.protocol_handler_packages:
        serial.protocol_handler_packages.append(PACKAGE)


register_url_handler()

__all__ = ["register_url_handler", "PACKAGE"]
