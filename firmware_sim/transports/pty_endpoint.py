"""A pseudo-terminal endpoint with a stable path that ``serial.Serial(path)`` opens.

The pty (POSIX; tested on Linux) is made raw; a symlink at *link_path* points
to its slave (``/dev/pts/N``). The symlink is created atomically — a symlink
under a temporary name, then ``os.replace`` onto the final name — so a host
never sees a half-made path, and it is removed on :meth:`PtyEndpoint.close`
(only if it still points to our slave).

Pairing ("a host holds the slave open"): we keep **no** slave descriptor of our
own. While no process has the slave open, Linux reports ``POLLHUP`` on the
master (and ``read`` on it fails with ``EIO``); opening the slave clears it.
This is the known trick for "has someone opened the slave side?" (there is no
documented interface; see e.g. the Stack Overflow question "How can I detect
when someone opens the slave side of a pty" and unix.stackexchange 538198 on
the EIO). So the loop polls the master with timeout 0 each iteration: no ``POLLHUP`` →
paired (``port.connect()``), ``POLLHUP``/``EIO`` → unpaired
(``port.disconnect()``). The master is not handed to the pacer's selector while
unpaired, since a hung-up master is always "readable".

On connect, stale bytes are flushed: the link's host buffer is emptied, and
the slave's input queue (module bytes written for an earlier host) is flushed
by opening the slave briefly and ``tcflush(TCIFLUSH)`` (the new host keeps it
open, so our brief open/close does not hang anything up). Bytes the new host
already wrote are kept. On hang-up, the master's unread input (bytes the gone
host wrote) is flushed. Writes to the master are non-blocking; what does not
fit (a host that stopped reading) is dropped and counted in ``dropped``.
"""

from __future__ import annotations

import atexit
import errno
import os
import select
import termios
import tty
import weakref
from pathlib import Path

from firmware_sim.mcu.port import Port

from .pairing import PairingEvents

_READ = 65536


class PtyEndpoint(PairingEvents):
    """Serve *port* on a pty reachable at *link_path*."""

    def __init__(self, port: Port, link_path: str | os.PathLike[str]):
        self.port = port
        self.link_path = Path(link_path)
        master, slave = os.openpty()
        try:
            tty.setraw(slave)
            attrs = termios.tcgetattr(slave)
            attrs[3] &= ~termios.ECHO
            termios.tcsetattr(slave, termios.TCSANOW, attrs)
            self.slave_name = os.ttyname(slave)
        finally:
            os.close(slave)  # see the module docstring: we must not hold the slave
        os.set_blocking(master, False)
        self.master = master
        self._poll = select.poll()
        self._poll.register(master, select.POLLIN)
        self._publish()
        self.paired = False
        self.connects = 0
        self.disconnects = 0
        self.dropped = 0  #: module bytes the pty did not take (host not reading)
        self.refused = 0  #: host bytes the link did not accept
        self.closed = False
        self._init_pairing()
        if port.connected:
            port.disconnect()
        # remove the symlink even if the program ends without close() (not on SIGKILL)
        ref = weakref.ref(self)
        self._atexit = lambda: (ep := ref()) is not None and ep.close()
        atexit.register(self._atexit)

    def _publish(self) -> None:
        path = self.link_path
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        try:
            tmp.unlink()
        except FileNotFoundError:
            pass
        os.symlink(self.slave_name, tmp)
        os.replace(tmp, path)

    @property
    def fds(self) -> tuple[int, ...]:
        return (self.master,) if self.paired and not self.closed else ()

    def _poll_master(self) -> tuple[bool, bool]:
        """(a host holds the slave open, the master has bytes to read)."""
        held, readable = True, False
        for _fd, ev in self._poll.poll(0):
            if ev & (select.POLLHUP | select.POLLERR):
                held = False
            if ev & select.POLLIN:
                readable = True
        return held, readable

    def _follow_host(self) -> bool:
        """Pair with a host that opened the slave, unpair from one that left; whether the master
        has bytes to read."""
        held, readable = self._poll_master()
        if held and not self.paired:
            self._connect()
        elif not held and self.paired:
            self._hangup()
        return readable

    def pump(self) -> None:
        if self.closed:
            return
        readable = self._follow_host()
        if not self.paired:
            return
        while readable:
            try:
                data = os.read(self.master, _READ)
            except BlockingIOError:
                break
            except OSError as e:
                if e.errno == errno.EIO:
                    self._hangup()
                    return
                raise
            if not data:
                break
            n = self.port.host_write(data)
            self.refused += len(data) - n
            readable = len(data) == _READ
        out = self.port.host_read()
        if out:
            try:
                sent = os.write(self.master, out)
            except BlockingIOError:
                sent = 0
            except OSError as e:
                if e.errno != errno.EIO:
                    raise
                self.dropped += len(out)
                self._hangup()
                return
            self.dropped += len(out) - sent

    def _connect(self) -> None:
        self.port.host_read()  # stale bytes from while nobody listened
        try:
            fd = os.open(self.slave_name, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        except OSError:
            fd = -1
        if fd >= 0:
            try:
                termios.tcflush(fd, termios.TCIFLUSH)
            except termios.error:
                pass
            finally:
                os.close(fd)
        self.paired = True
        self.connects += 1
        self.port.connect()
        self._notify()

    def _hangup(self) -> None:
        try:
            termios.tcflush(self.master, termios.TCIFLUSH)
        except termios.error:
            pass
        self.paired = False
        self.disconnects += 1
        self.port.disconnect()
        self._notify()

    def close(self) -> None:
        """Unpair, remove the symlink (if still ours), close the master."""
        if self.closed:
            return
        self.closed = True
        atexit.unregister(self._atexit)
        if self.paired:
            self.paired = False
            self.port.disconnect()
            self._notify()
        try:
            if os.readlink(self.link_path) == self.slave_name:
                self.link_path.unlink()
        except OSError:
            pass
        os.close(self.master)

    def status(self) -> dict[str, object]:
        return {"kind": "pty", "path": str(self.link_path), "slave": self.slave_name, "paired": self.paired,
                "connects": self.connects, "dropped": self.dropped}

    def __repr__(self) -> str:
        return (f"PtyEndpoint({self.link_path} -> {self.slave_name}, "
                f"{'paired' if self.paired else 'no host'}, dropped {self.dropped} B)")
