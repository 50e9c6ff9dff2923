"""The runtime control channel of ``openshoe-emu serve``: line commands over TCP that
disconnect, stall or corrupt the running modules' links on demand."""

from __future__ import annotations

import json
import selectors
import socket
from typing import TYPE_CHECKING, Any

from hostlib.web.address import bind_refusal

if TYPE_CHECKING:  # pragma: no cover
    from .served_module import ServedModule

#: What the control channel answers to ``help``: its commands, one per line.
CONTROL_HELP = """\
commands (one per line; prefix with @I to address module I only, e.g. "@1 disconnect"):
  disconnect       the link goes down (bytes in flight are lost); the host stays attached
  reconnect        the link comes back
  stall S          deliver nothing for S seconds of module time, both directions (S up to 3600)
  corrupt N        corrupt the next N bytes sent to the host (N up to 10^9)
  drop N           lose the next N bytes sent to the host (N up to 10^9)
  status           one status line per module
  status json      the same as one JSON object per line (every counter, lateness classes included)
  help             this text
  quit             close this control connection"""


#: The longest ``stall S`` [s]: an hour (a link held longer is better disconnected).
MAX_STALL_S = 3600.0
#: The most bytes one ``corrupt N`` or ``drop N`` names: a day of the Bluetooth link at full rate.
MAX_FAULT_BYTES = 1_000_000_000


class ControlServer:
    """Line commands over TCP that change the running modules' links (:data:`CONTROL_HELP`)."""

    def __init__(self, modules: list[ServedModule], host: str, port: int):
        self.modules = modules
        try:
            self.server = socket.create_server((host, port), backlog=4)
        except OSError as exc:  # a port in use, an address not this machine's, a name that does not resolve
            raise OSError(bind_refusal("--control", (host, port), exc)) from None
        self.server.setblocking(False)
        self.address = self.server.getsockname()[:2]
        self.clients: dict[socket.socket, bytearray] = {}

    def register(self, sel: selectors.BaseSelector) -> None:
        sel.register(self.server, selectors.EVENT_READ, self)

    def handle(self, sel: selectors.BaseSelector, sock: socket.socket) -> None:
        if sock is self.server:
            try:
                c, _ = self.server.accept()
            except OSError:
                return
            c.setblocking(True)
            self.clients[c] = bytearray()
            sel.register(c, selectors.EVENT_READ, self)
            return
        try:
            data = sock.recv(4096)
        except OSError:
            data = b""
        if not data:
            self._close(sel, sock)
            return
        buf = self.clients[sock]
        buf += data
        while b"\n" in buf:
            line, _, rest = bytes(buf).partition(b"\n")
            buf[:] = rest
            reply = self.execute(line.decode("utf-8", "replace").strip())
            if reply is None:
                self._close(sel, sock)
                return
            try:
                sock.sendall((reply + "\n").encode())
            except OSError:
                self._close(sel, sock)
                return

    def _close(self, sel: selectors.BaseSelector, sock: socket.socket) -> None:
        try:
            sel.unregister(sock)
        except (KeyError, ValueError):
            pass
        self.clients.pop(sock, None)
        sock.close()

    def execute(self, line: str) -> str | None:
        """Run one command line; the reply ("OK …" / "ERR …"), None to close the connection."""
        if not line:
            return "ERR empty command; try help"
        targets = self.modules
        words = line.split()
        if words[0].startswith("@"):
            try:
                i = int(words[0][1:])
                targets = [self.modules[i]]
            except (ValueError, IndexError):
                return f"ERR no module {words[0]} (0..{len(self.modules) - 1})"
            words = words[1:]
            if not words:
                return "ERR missing command after the module"
        cmd, rest = words[0].lower(), words[1:]
        if cmd == "help":
            return CONTROL_HELP + "\nOK"
        if cmd == "quit":
            return None
        if cmd == "status" and rest == ["json"]:
            return "\n".join(json.dumps({"module": m.index, **m.pacer.status().as_dict()})
                             for m in targets) + "\nOK"
        if cmd == "status":
            return "\n".join(f"m{m.index} {m.status_line()}" for m in targets) + "\nOK"
        try:
            action = self._action(cmd, rest)
        except ValueError as exc:
            return f"ERR {exc}"
        for m in targets:
            for link in m.links.values():
                try:
                    m.pacer.call(lambda _mod, link=link: action(link)).result(timeout=5.0)
                except Exception as exc:  # noqa: BLE001 - a command the link refused: said, the module runs on
                    return f"ERR {cmd}: {exc or type(exc).__name__}"
        return f"OK {' '.join(words)}"

    @staticmethod
    def _action(cmd: str, rest: list[str]):
        def number(kind: type, most: float) -> Any:
            if len(rest) != 1:
                raise ValueError(f"{cmd} takes one number")
            try:
                v = kind(rest[0])
            except ValueError:
                raise ValueError(f"{cmd}: {rest[0]!r} is not a number") from None
            if not 0 <= v <= most:  # NaN and inf too: a stall of NaN seconds stopped serve
                raise ValueError(f"{cmd}: must be from 0 to {most:g}, got {rest[0]}")
            return v

        if cmd == "disconnect" and not rest:
            return lambda link: link.disconnect()
        if cmd == "reconnect" and not rest:
            return lambda link: link.reconnect()
        if cmd == "stall":
            s = number(float, MAX_STALL_S)
            return lambda link: link.stall(s)
        if cmd == "corrupt":
            n = number(int, MAX_FAULT_BYTES)
            return lambda link: link.corrupt_next(n)
        if cmd == "drop":
            n = number(int, MAX_FAULT_BYTES)
            return lambda link: link.drop_next(n)
        raise ValueError(f"unknown command {' '.join([cmd, *rest])!r}; try help")

    def close(self) -> None:
        for c in list(self.clients):
            c.close()
        self.clients.clear()
        self.server.close()
