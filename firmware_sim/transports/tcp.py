"""A TCP server endpoint: one host at a time talks to one module interface.

A host connecting is the interface getting paired / plugged in
(``port.connect()``); the host closing (or the connection failing) unpairs it
(``port.disconnect()``). A second host trying to connect while one is served
is accepted and closed at once (counted in ``refused_hosts``). Listens on
127.0.0.1 by default; port 0 picks a free port (see :attr:`TcpEndpoint.address`).
Everything is non-blocking and runs in the pacer's loop.
"""

from __future__ import annotations

import errno
import socket

from firmware_sim.mcu.port import Port

from .pairing import PairingEvents

_RECV = 65536


class TcpEndpoint(PairingEvents):
    """Serve *port* to one TCP host at a time."""

    def __init__(self, port: Port, host: str = "127.0.0.1", tcp_port: int = 0, out_buffer: int = 256 * 1024):
        self.port = port
        self.out_buffer = out_buffer
        self.server = socket.create_server((host, tcp_port), backlog=4)
        self.server.setblocking(False)
        self.address: tuple[str, int] = self.server.getsockname()[:2]
        self.client: socket.socket | None = None
        self.peer: tuple | None = None
        self._out = bytearray()
        self.connects = 0
        self.disconnects = 0
        self.refused_hosts = 0
        self.dropped = 0  #: module bytes dropped because the host did not read them
        self.refused = 0  #: host bytes the link did not accept
        self.closed = False
        self._init_pairing()
        if port.connected:
            port.disconnect()

    @property
    def paired(self) -> bool:
        return self.client is not None

    @property
    def fds(self) -> tuple[int, ...]:
        if self.closed:
            return ()
        if self.client is not None:
            return (self.server.fileno(), self.client.fileno())
        return (self.server.fileno(),)

    def pump(self) -> None:
        if self.closed:
            return
        self._accept()
        c = self.client
        if c is None:
            return
        while True:
            try:
                data = c.recv(_RECV)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:
                self._hangup()
                return
            if not data:
                self._hangup()
                return
            data = self._from_host(data)
            n = self.port.host_write(data)
            self.refused += len(data) - n
        out = self.port.host_read()
        if out:
            self._out += self._to_host(out)
        if self._out:
            try:
                sent = c.send(self._out)
            except (BlockingIOError, InterruptedError):
                sent = 0
            except OSError as e:
                if e.errno not in (errno.EAGAIN, errno.EWOULDBLOCK):
                    self._hangup()
                    return
                sent = 0
            del self._out[:sent]
            if len(self._out) > self.out_buffer:
                self.dropped += len(self._out) - self.out_buffer
                del self._out[self.out_buffer:]

    def _accept(self) -> None:
        while True:
            try:
                sock, peer = self.server.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                return
            if self.client is not None:
                self.refused_hosts += 1
                sock.close()
                continue
            sock.setblocking(False)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self.client, self.peer = sock, peer
            self._out.clear()
            self._on_pair()
            self.port.host_read()  # stale bytes from before this host are not its business
            self.port.connect()
            self.connects += 1
            self._notify()

    # hooks for protocols layered on the byte stream (RFC 2217): identity for plain TCP
    def _on_pair(self) -> None:
        """A new host was accepted (before the link connects)."""

    def _from_host(self, data: bytes) -> bytes:
        """Host bytes → module bytes."""
        return data

    def _to_host(self, data: bytes) -> bytes:
        """Module bytes → host bytes."""
        return data

    def _hangup(self) -> None:
        if self.client is not None:
            try:
                self.client.close()
            finally:
                self.client = None
                self.peer = None
        self._out.clear()
        self.port.disconnect()
        self.disconnects += 1
        self._notify()

    def close(self) -> None:
        if self.closed:
            return
        if self.client is not None:
            self._hangup()
        self.server.close()
        self.closed = True

    kind = "tcp"

    def status(self) -> dict[str, object]:
        return {"kind": self.kind, "address": f"{self.address[0]}:{self.address[1]}", "paired": self.paired,
                "connects": self.connects, "dropped": self.dropped, "refused_hosts": self.refused_hosts}

    def __repr__(self) -> str:
        return (f"{type(self).__name__}({self.address[0]}:{self.address[1]}, "
                f"{'host ' + str(self.peer) if self.paired else 'no host'})")
