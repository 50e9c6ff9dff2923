"""The load of the ``hostile`` target (:mod:`lab.bench.hostile`): hostile clients and well-behaved hosts.

A :class:`HostileClient` is one host misbehaving on one served module, seeded, for a bounded
time, only on the module's pty and its TCP port on 127.0.0.1. At about :attr:`HostileConfig.rate_hz`
actions a second (exponential gaps) it

* sends a well-formed command (:class:`CommandFuzzer`): any command of the current numbering's
  table (``protocol.commands.CURRENT``, all 29 alike), its payload either random bytes or drawn
  field by field (an existing state id, a process id below the limit, a slot, an output mode, a
  state's value with 0, ±inf, NaN, 3.4e38, 1e-42 among its floats …), the checksum right;
* sends a few such commands back to back;
* sends random bytes, 1 B to 1 kB (log-uniform): line noise, a baud-rate mismatch;
* stops reading for 1–10 s (a host app that hangs; the module's bytes pile up in the pty);
* and every :attr:`HostileConfig.session_s` s or so (exponential) closes its port, stays away
  0.2–3 s and comes back on the pty or the TCP port at random.

It reads what the module sends and counts the acks and packets. A :class:`WellBehavedHost`
is the baseline's host: step-wise dead reckoning started, every step packet acknowledged.
Both are driven by one selector loop (:class:`LoadLoop`) in the benchmark's process.
"""

from __future__ import annotations

import math
import os
import random
import selectors
import socket
import struct
import time
import tty
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from protocol.commands import CURRENT, CommandSet, CommandSpec
from protocol.frames import CommandAck, StatePacket, build_packet_ack, checksum_bytes
from protocol.ids import NR_SLOTS, PROC_ID_LIMIT, StateId
from protocol.states import STATES
from protocol.stream import StreamDecoder

__all__ = ["CommandFuzzer", "HostileClient", "HostileConfig", "LoadLoop", "WellBehavedHost",
           "open_pty", "START_STEPWISE"]

#: STEPWISE_DEAD_RECKONING (0x34) with its checksum.
START_STEPWISE = bytes.fromhex("340034")
#: float32 values that make a host's numbers interesting (docs/protocol-extensions.md,
#: "Numbers that go non-finite").
SPECIAL_FLOATS = (0.0, -0.0, math.nan, math.inf, -math.inf, 3.4e38, -3.4e38, 1e-42, 1e30, 1.0, -1.0)
#: The boolean states a conditional output or RESET_PROC_SETUP can be keyed on.
FLAG_STATES = (StateId.ZUPT, StateId.ZARU, StateId.INIT_DONE, StateId.FILTER_RESET_FLAG)
_SET_STATE_SIZES = {"SET_STATE_1": 1, "SET_STATE_4": 4, "SET_STATE_12": 12, "SET_STATE_24": 24,
                    "SET_STATE_48": 48, "SET_STATE_254": 254}
_READ = 65536


def open_pty(path: str) -> int:
    """A host's end of a served pty: raw, non-blocking."""
    fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    try:
        tty.setraw(fd)
    except OSError:
        os.close(fd)
        raise
    return fd


# ---------------------------------------------------------------------------------------------
# frames


class CommandFuzzer:
    """Well-formed command frames of every command of *command_set*, with random payloads.

    *raw_share* of the payloads are plain random bytes; the rest are drawn field by field so
    that they often mean something to the module (see the module docstring). *only*: command
    names to draw from instead of all (to find which commands cost what); ValueError for a
    name the table lacks."""

    def __init__(self, rng: random.Random, command_set: CommandSet = CURRENT, raw_share: float = 0.4,
                 only: tuple[str, ...] = ()):
        self.rng = rng
        self.specs: list[CommandSpec] = [command_set[i] for i in sorted(command_set)]
        if only:
            unknown = sorted(set(only) - {s.name for s in self.specs})
            if unknown:
                raise ValueError(f"no command {', '.join(unknown)} in the {command_set.name} numbering")
            self.specs = [s for s in self.specs if s.name in only]
        self.raw_share = raw_share
        self._state_ids = sorted(STATES)

    def frame(self) -> tuple[CommandSpec, bytes]:
        """A random command and its whole frame (``id · payload · checksum``)."""
        spec = self.rng.choice(self.specs)
        n = spec.payload_len
        payload = self.rng.randbytes(n) if self.rng.random() < self.raw_share else self.payload(spec)
        assert len(payload) == n, (spec, len(payload))
        body = bytes([spec.wire_id]) + payload
        return spec, body + checksum_bytes(body)

    # -- payloads field by field

    def payload(self, spec: CommandSpec) -> bytes:
        size = _SET_STATE_SIZES.get(spec.name)
        if size is not None:
            return self._set_state(size)
        subcons = getattr(spec.payload, "subcons", ())
        return b"".join(self._field(sc.name, sc.sizeof()) for sc in subcons)

    def _state_id(self, fits: Callable[[int], bool] = lambda _sid: True) -> int:
        r = self.rng
        if r.random() < 0.85:
            ids = [s for s in self._state_ids if fits(s)]
            if ids:
                return r.choice(ids)
        return r.randrange(256)

    def _set_state(self, n: int) -> bytes:
        r = self.rng
        sid = self._state_id(lambda s: STATES[s].size <= n)
        spec = STATES.get(sid)
        data = r.randbytes(n)
        if spec is not None and spec.size <= n:
            roll = r.random()
            if roll < 0.1:
                value = bytes(spec.size)
            elif roll < 0.6 and spec.dtype.kind == "f":
                count = spec.size // 4
                vals = [r.choice(SPECIAL_FLOATS) if r.random() < 0.3 else r.gauss(0.0, 10.0)
                        for _ in range(count)]
                value = struct.pack(f">{count}f", *[_f32(v) for v in vals])
            else:
                value = r.randbytes(spec.size)
            data = value + data[spec.size:]
        return bytes([sid]) + data

    def _mode(self) -> int:
        r = self.rng
        if r.random() < 0.3:
            return r.randrange(256)
        return (r.randrange(8) | r.choice((0, 0x10)) | r.choice((0, 0, 0x20))
                | r.choice((0, 0x40, 0x80, 0x08, 0xC8)))

    def _field(self, name: str, size: int) -> bytes:
        r = self.rng

        def each(draw: Callable[[], int]) -> bytes:
            return bytes(draw() & 0xFF for _ in range(size))

        if name in ("proc_ids", "proc_id"):
            return each(lambda: r.randrange(PROC_ID_LIMIT) if r.random() < 0.85 else r.randrange(256))
        if name == "state_ids":
            return each(lambda: 0 if r.random() < 0.2 else self._state_id())
        if name == "state_id":
            return each(self._state_id)
        if name == "flag_id":
            return each(lambda: r.choice(FLAG_STATES) if r.random() < 0.6 else self._state_id())
        if name == "slot":
            return each(lambda: r.randrange(NR_SLOTS) if r.random() < 0.85 else r.randrange(256))
        if name == "mode":
            return each(self._mode)
        if name == "interface":
            return each(lambda: r.choice((0, 1, 2, 3, r.randrange(256))))
        if name == "dlpf_cfg":
            return each(lambda: r.randrange(8) if r.random() < 0.9 else r.randrange(256))
        if name == "imu_selector" and size == 4:
            return r.choice((r.randrange(1, 16), 0xFFFFFFFF, r.getrandbits(32))).to_bytes(4, "big")
        return r.randbytes(size)  # packet numbers, timestamps, raw IMU registers, GP_TEST's a and b

    def garbage(self, max_bytes: int = 1024) -> bytes:
        """Random bytes, 1 to *max_bytes* long (log-uniform)."""
        n = int(math.exp(self.rng.uniform(0.0, math.log(max_bytes))))
        return self.rng.randbytes(max(1, min(n, max_bytes)))


def _f32(v: float) -> float:
    """*v* as float32 packs it (values beyond its range become ±inf, as on the µC)."""
    if math.isfinite(v) and abs(v) > 3.4028234663852886e38:
        return math.copysign(math.inf, v)
    return v


# ---------------------------------------------------------------------------------------------
# the hosts


@dataclass(frozen=True)
class HostileConfig:
    """How a hostile client behaves (the module docstring); the shares are of its actions."""

    rate_hz: float = 10.0  #: actions a second while connected
    command_share: float = 0.70  #: one well-formed command
    burst_share: float = 0.06  #: 2–8 commands in one write
    garbage_share: float = 0.22  #: random bytes
    max_garbage: int = 1024
    deaf_s: tuple[float, float] = (1.0, 10.0)  #: the rest of the actions: not reading for so long
    session_s: float = 20.0  #: mean time connected before leaving (exponential)
    away_s: tuple[float, float] = (0.2, 3.0)  #: time away before coming back
    tcp_share: float = 0.5  #: comebacks on the TCP port (the rest on the pty)
    raw_payload_share: float = 0.4
    commands: tuple[str, ...] = ()  #: only these commands (names); empty: every command of the table


class Connection:
    """One open connection of a host: a pty fd or a TCP socket, non-blocking."""

    def __init__(self, kind: str, where: Any):
        self.kind = kind
        self.sock: socket.socket | None = None
        self.fd = -1
        if kind == "pty":
            self.fd = open_pty(where)
        else:
            host, port = where
            self.sock = socket.create_connection((host, int(port)), timeout=2.0)
            self.sock.setblocking(False)
            self.fd = self.sock.fileno()

    def write(self, data: bytes) -> int:
        try:
            return self.sock.send(data) if self.sock is not None else os.write(self.fd, data)
        except (BlockingIOError, InterruptedError):
            return 0

    def read(self) -> bytes:
        """What is there (b"" when nothing); ConnectionError when the other end is gone."""
        try:
            data = self.sock.recv(_READ) if self.sock is not None else os.read(self.fd, _READ)
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError as exc:
            raise ConnectionError(str(exc)) from exc
        if not data:
            raise ConnectionError("closed by the other end")
        return data

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()
        elif self.fd >= 0:
            os.close(self.fd)
        self.fd = -1


class Host:
    """What both kinds of host share: a connection registered in the loop's selector."""

    def __init__(self, name: str):
        self.name = name
        self.conn: Connection | None = None
        self.sel: selectors.BaseSelector | None = None
        self.reading = False
        self.decoder = StreamDecoder()
        self.bytes_read = 0
        self.packets = 0
        self.acks: Counter[int] = Counter()

    def attach(self, sel: selectors.BaseSelector) -> None:
        self.sel = sel

    def _listen(self, on: bool) -> None:
        if self.conn is None or self.sel is None or on == self.reading:
            return
        if on:
            self.sel.register(self.conn.fd, selectors.EVENT_READ, self)
        else:
            self.sel.unregister(self.conn.fd)
        self.reading = on

    def _drop(self) -> None:
        self._listen(False)
        if self.conn is not None:
            self.conn.close()
        self.conn = None
        self.decoder = StreamDecoder()

    def readable(self, now: float) -> None:
        assert self.conn is not None
        try:
            data = self.conn.read()
        except ConnectionError:
            self.lost(now)
            return
        self.bytes_read += len(data)
        for frame in self.decoder.feed(data):
            if isinstance(frame, StatePacket):
                self.packets += 1
                self.on_packet(frame)
            elif isinstance(frame, CommandAck):
                self.acks[frame.command_id] += 1

    def start(self, now: float) -> None:
        """Connect (the loop starts every host at once)."""

    def on_packet(self, frame: StatePacket) -> None:
        pass

    def lost(self, now: float) -> None:
        self._drop()

    def due(self) -> float:
        """When :meth:`act` wants to run next (monotonic s; inf: never)."""
        return math.inf

    def act(self, now: float) -> None:
        pass

    def close(self) -> None:
        self._drop()


class WellBehavedHost(Host):
    """The baseline's host on one module's pty: starts step-wise dead reckoning, acks every step."""

    def __init__(self, name: str, pty_path: str):
        super().__init__(name)
        self.pty_path = pty_path
        self.steps = 0

    def start(self, now: float) -> None:
        self.conn = Connection("pty", self.pty_path)
        self._listen(True)
        self.conn.write(START_STEPWISE)

    def on_packet(self, frame: StatePacket) -> None:
        if self.conn is not None:
            self.conn.write(build_packet_ack(frame.number))
        self.steps += 1

    def summary(self) -> dict[str, Any]:
        return {"name": self.name, "steps": self.steps, "bytes_read": self.bytes_read,
                "acks": sum(self.acks.values())}


class HostileClient(Host):
    """One hostile host on one module (the module docstring), seeded; stops at :meth:`close`.

    *pty_path* and *tcp* (``(host, port)``, 127.0.0.1) are the module's endpoints on one
    interface; the client is connected to at most one of them at a time."""

    def __init__(self, name: str, pty_path: str, tcp: tuple[str, int] | None, seed: int,
                 config: HostileConfig = HostileConfig()):
        super().__init__(name)
        self.pty_path = pty_path
        self.tcp = tcp
        self.config = config
        self.rng = random.Random(seed)
        self.fuzzer = CommandFuzzer(self.rng, raw_share=config.raw_payload_share, only=config.commands)
        self._next = math.inf
        self._leave_at = math.inf
        self._deaf_until = 0.0
        self.sent: Counter[str] = Counter()  #: command frames sent, by command name
        self.sent_ids: Counter[int] = Counter()  #: the same by wire id (the acks' key)
        self.counts: Counter[str] = Counter()  #: bytes, garbage, sessions, reconnects, refusals …

    # -- connecting

    def start(self, now: float) -> None:
        self._connect(now, "pty")

    def _connect(self, now: float, kind: str | None = None) -> None:
        cfg = self.config
        if kind is None:
            kind = "tcp" if self.tcp is not None and self.rng.random() < cfg.tcp_share else "pty"
        try:
            self.conn = Connection(kind, self.pty_path if kind == "pty" else self.tcp)
        except OSError:
            self.counts["connect_errors"] += 1
            self._next = now + self.rng.uniform(*cfg.away_s)
            return
        self.counts[f"sessions_{kind}"] += 1
        self._listen(True)
        self._leave_at = now + self.rng.expovariate(1.0 / cfg.session_s)
        self._next = now + self.rng.expovariate(cfg.rate_hz)

    def lost(self, now: float) -> None:
        self.counts["lost"] += 1
        self._drop()
        self._leave_at = math.inf
        self._next = now + self.rng.uniform(*self.config.away_s)

    def due(self) -> float:
        return self._next

    # -- acting

    def act(self, now: float) -> None:
        cfg = self.config
        if self.conn is None:
            self._connect(now)
            if self.conn is not None:
                self.counts["reconnects"] += 1
            return
        if now >= self._leave_at:
            self.counts["leaves"] += 1
            self._drop()
            self._leave_at = math.inf
            self._next = now + self.rng.uniform(*cfg.away_s)
            return
        if not self.reading and now >= self._deaf_until:
            self._listen(True)
        self._next = max(self._next, now) + self.rng.expovariate(cfg.rate_hz)
        roll = self.rng.random()
        if roll < cfg.command_share:
            self._send(self._command())
        elif roll < cfg.command_share + cfg.burst_share:
            self.counts["bursts"] += 1
            self._send(b"".join(self._command() for _ in range(self.rng.randint(2, 8))))
        elif roll < cfg.command_share + cfg.burst_share + cfg.garbage_share:
            junk = self.fuzzer.garbage(cfg.max_garbage)
            self.counts["garbage_chunks"] += 1
            self.counts["garbage_bytes"] += len(junk)
            self._send(junk)
        else:
            self.counts["deaf_periods"] += 1
            self._deaf_until = now + self.rng.uniform(*cfg.deaf_s)
            self._listen(False)

    def _command(self) -> bytes:
        spec, frame = self.fuzzer.frame()
        self.sent[spec.name] += 1
        self.sent_ids[spec.wire_id] += 1
        return frame

    def _send(self, data: bytes) -> None:
        assert self.conn is not None
        try:
            n = self.conn.write(data)
        except OSError:
            self.lost(time.monotonic())
            return
        self.counts["bytes_sent"] += n
        if n < len(data):
            self.counts["bytes_refused"] += len(data) - n  # the pty or socket is full

    def summary(self) -> dict[str, Any]:
        """What it did (JSON-ready)."""
        acked = sum(n for cid, n in self.acks.items() if cid in self.sent_ids)
        return {"name": self.name, "commands": sum(self.sent.values()), "acks": acked,
                "packets": self.packets, "bytes_read": self.bytes_read, **dict(self.counts),
                "sessions": self.counts["sessions_pty"] + self.counts["sessions_tcp"],
                "by_command": dict(sorted(self.sent.items()))}


# ---------------------------------------------------------------------------------------------
# the loop


class LoadLoop:
    """Drives hosts (hostile or well-behaved) in one thread until a deadline: their reads,
    their actions when due, and *tick* (e.g. sampling the serve processes) every *tick_s*."""

    def __init__(self, hosts: list[Host]):
        self.hosts = hosts
        self.sel = selectors.DefaultSelector()
        for h in hosts:
            h.attach(self.sel)

    def run(self, seconds: float, tick: Callable[[float], None] | None = None, tick_s: float = 10.0) -> None:
        """Start the hosts, drive them for *seconds*, close them (always)."""
        now = time.monotonic()
        end = now + seconds
        next_tick = now
        try:
            for h in self.hosts:
                h.start(now)
            while True:
                now = time.monotonic()
                if tick is not None and now >= next_tick:
                    tick(now)
                    next_tick = now + tick_s
                if now >= end:
                    break
                wake = min([end, next_tick if tick is not None else end, *(h.due() for h in self.hosts)])
                for key, _ in self.sel.select(max(0.0, min(wake - now, 0.5))):
                    key.data.readable(time.monotonic())
                now = time.monotonic()
                for h in self.hosts:
                    if h.due() <= now:
                        h.act(now)
        finally:
            for h in self.hosts:
                h.close()
            self.sel.close()

    def __repr__(self) -> str:
        return f"LoadLoop({len(self.hosts)} hosts)"
