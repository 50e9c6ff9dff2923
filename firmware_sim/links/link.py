"""Bluetooth and USB link models in virtual time, with seeded fault injection.

A link is a :class:`~firmware_sim.mcu.port.Port`: the µC's driver sees a receive
ring and a transmit ring, the host (a transport or a test) sees
``host_write``/``host_read``. Time is the module's 64 MHz cycle counter, moved
forward by :meth:`Link.advance` once per module tick; nothing here reads the
wall clock, so the same seed and the same calls give the same bytes.

The two directions (protocol.md §8):

    host → module:  host_write → air (latency + jitter, in order) → radio's
                    UART-out buffer → wire at *rate* B/s → µC receive ring
    module → host:  tx_write → µC transmit ring → wire at *rate* B/s →
                    radio buffer / air (latency + jitter, in order, in chunks)
                    → host receive buffer → host_read

Bluetooth (profile ``"bt"``), USB (``"usb"``) and ``"ideal"``: their rates, rings, latency
and losses are in :mod:`firmware_sim.links.profiles`.

In real time a pacer may run the module ahead of the wall clock, by less than
the link's latency (:meth:`Link.lookahead_cycles`), and hands the link a *host
clock* (:attr:`Link.host_clock`, the host's present in module cycles): bytes
then reach the host when the host's clock passes their arrival time, whatever
the module's clock says, and the host's bytes leave at the host's present. So
the module may be early or late by up to the latency without a host seeing a
difference; a byte reaching the host after its arrival time is counted in
``late`` with the largest lateness in ``late_max_cycles``. Without a host clock
(the default, virtual time) the host lives on the module's clock, as before.

Fault injection (:class:`~firmware_sim.links.faults.LinkFaults`, per direction) adds seeded
byte loss, corruption, stalls and disconnects on top (:mod:`firmware_sim.links.faults`); runtime
controls (:meth:`Link.disconnect`, :meth:`Link.reconnect`, :meth:`Link.stall`,
:meth:`Link.corrupt_next`, :meth:`Link.drop_next`) let a control channel drive them. Every lost or
corrupted byte is counted in :attr:`Link.counters` (:mod:`firmware_sim.links.counters`).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import replace
from typing import Literal

import numpy as np

from protocol.states import TIMESTAMP_HZ

from .air import Chunk, Stall
from .counters import DirectionCounters, LinkCounters
from .faults import DIRECTIONS, Direction, LinkFaults, random_byte_faults
from .profiles import BLUETOOTH, PROFILES, USB, LinkProfile

#: The µC's cycle counter rate (firmware.md §1).
CLOCK_HZ = TIMESTAMP_HZ


def _cycles(seconds: float) -> int:
    return int(round(seconds * CLOCK_HZ))


#: What ``tx_free`` reports for an unbounded transmit ring.
UNLIMITED = 1 << 30


# --------------------------------------------------------------------------- the link


class Link:
    """One module↔host link in virtual time (a :class:`~firmware_sim.mcu.port.Port`).

    ``seed`` fixes the jitter and every injected fault; two links built with the
    same profile, seed and faults and driven by the same calls behave
    identically. Starts connected unless ``connected=False``.
    """

    def __init__(self, profile: LinkProfile = BLUETOOTH, seed: int = 0, faults: LinkFaults | None = None,
                 connected: bool = True):
        self.profile = profile
        self.seed = seed
        self.faults = faults if faults is not None else LinkFaults()
        self.connected = connected
        self.counters = LinkCounters()  #: what the link delivered, lost and corrupted, per direction
        self.now_cycles = 0
        #: The host's present in module cycles, in real time (set by the pacer); None = the
        #: module's clock (virtual time): see the module doc.
        self.host_clock: Callable[[], int] | None = None
        #: Lateness [cycles] of a delivery that still counts as on time (the pacer sets one
        #: frame: the loop hands bytes over when they are due, give or take its wake-ups).
        self.late_tolerance_cycles = 0
        self._started = False
        p = profile
        self._rate = p.rate_bps
        self._latency = _cycles(p.latency_s)
        self._jitter = _cycles(p.jitter_s)
        self._jitter_period = max(1, _cycles(p.jitter_period_s))
        # Independent random streams, so switching one fault on does not move another's draws.
        ss = np.random.SeedSequence(seed)
        jit_m, jit_h, flt_m, flt_h, evt = (np.random.default_rng(s) for s in ss.spawn(5))
        self._rng_jitter = {"to_module": jit_m, "to_host": jit_h}
        self._rng_fault = {"to_module": flt_m, "to_host": flt_h}
        self._rng_events = evt
        self._jitter_value = {"to_module": 0, "to_host": 0}
        self._jitter_until = {"to_module": -1, "to_host": -1}
        self._last_at = {"to_module": 0, "to_host": 0}
        self._stall = {"to_module": Stall(), "to_host": Stall()}
        self._force_corrupt = {"to_module": 0, "to_host": 0}
        self._force_drop = {"to_module": 0, "to_host": 0}
        self._next_stall: dict[Direction, int | None] = {"to_module": None, "to_host": None}
        self._next_disconnect: int | None = None
        self._reconnect_at: int | None = None
        # host → module
        self._air_m: deque[Chunk] = deque()  # on the air, not yet at the radio
        self._air_m_bytes = 0
        self._radio_m: deque[Chunk] = deque()  # at the radio, waiting for the UART (at = arrival)
        self._radio_m_bytes = 0
        self._rx = bytearray()  # the µC's receive ring
        self._rx_wire_u = 0  # wire free time, in cycles × rate
        # module → host
        self._tx = bytearray()  # the µC's transmit ring
        self._tx_wire_u = 0
        self._air_h: deque[Chunk] = deque()
        self._air_h_bytes = 0
        self._host = bytearray()  # the host's receive buffer

    # ------------------------------------------------------------------ module side
    def advance(self, now_cycles: int) -> None:
        """Move the link to virtual time *now_cycles* (once per module tick, before receive)."""
        if now_cycles < self.now_cycles:
            raise ValueError(f"virtual time went backwards: {now_cycles} < {self.now_cycles}")
        self.now_cycles = now_cycles
        if not self._started:
            self._started = True
            self._schedule_random_events(now_cycles)
        self._random_events(now_cycles)
        self._pump(now_cycles)

    def rx_read(self, max_n: int) -> bytes:
        """Up to *max_n* bytes from the µC's receive ring."""
        if self.profile.latency_s == 0:
            self._pump(self.now_cycles)
        if not self._rx or max_n <= 0:
            return b""
        data = bytes(self._rx[:max_n])
        del self._rx[:max_n]
        self.counters.to_module.delivered += len(data)
        if self.profile.flow_control and self._radio_m:
            self._pump_to_module(self.now_cycles)
        return data

    def rx_pending(self) -> int:
        """Bytes waiting in the µC's receive ring."""
        return len(self._rx)

    def tx_free(self) -> int:
        """Bytes the µC's transmit ring accepts now (0 while disconnected)."""
        if not self.connected:
            return 0
        if self.profile.tx_ring is None:
            return UNLIMITED
        return self.profile.tx_ring - len(self._tx)

    def tx_write(self, data: bytes) -> None:
        """Put *data* (at most :meth:`tx_free` bytes) into the µC's transmit ring."""
        if not data:
            return
        if len(data) > self.tx_free():
            raise ValueError(f"tx_write of {len(data)} bytes but only {self.tx_free()} free "
                             f"(connected={self.connected})")
        if not self._tx and self._rate is not None:
            # An idle UART starts shifting the first byte now.
            self._tx_wire_u = max(self._tx_wire_u, self.now_cycles * self._rate)
        self._tx += data
        self.counters.to_host.sent += len(data)
        if self._rate is None and self.profile.latency_s == 0:
            self._pump_to_host(self.now_cycles)

    # ------------------------------------------------------------------ host side
    def host_write(self, data: bytes) -> int:
        """Host sends *data* now; returns the bytes accepted (the rest is lost and counted)."""
        c = self.counters.to_module
        n = len(data)
        if not n:
            return 0
        if not self.connected:
            c.lost_refused += n
            return 0
        cap = self.profile.host_tx_buffer
        if cap is not None:
            room = max(0, cap - self._air_m_bytes - self._radio_m_bytes)
            if n > room:
                c.lost_refused += n - room
                n = room
        if not n:
            return 0
        c.sent += n
        now = self.now_cycles
        sent_at = now if self.host_clock is None else self.host_clock()  # the host's present
        at = self._arrival("to_module", sent_at)
        # (if the module already ran past that moment — ahead of the host by more than the
        # latency — the bytes reach it at its next loop, late)
        self._note_lateness(c, now - at, n)
        self._air_m.append(Chunk(at, bytearray(data[:n])))
        self._air_m_bytes += n
        if self.profile.latency_s == 0:
            self._pump_to_module(now)
        return n

    def host_read(self, max_n: int = -1) -> bytes:
        """Bytes the module sent that have reached the host (all of them with -1)."""
        self._reach_host()
        if max_n < 0 or max_n >= len(self._host):
            data = bytes(self._host)
            self._host.clear()
            return data
        data = bytes(self._host[:max_n])
        del self._host[:max_n]
        return data

    def host_pending(self) -> int:
        """Bytes the host can read now."""
        self._reach_host()
        return len(self._host)

    def _reach_host(self) -> None:
        """Before the host looks: what has arrived by its present (see the module doc)."""
        if self.profile.latency_s == 0:
            self._pump_to_host(self.now_cycles)
        elif self.host_clock is not None and self._air_h and self.connected:
            self._deliver_to_host(self.now_cycles)

    def next_host_arrival(self) -> int | None:
        """With a host clock: the cycle at which the next bytes on the air reach the host, if
        the module's clock has passed it (None: nothing known to arrive by the module's
        present, or no host clock), so a pacer can wake for it."""
        if self.host_clock is None or not self._air_h or not self.connected:
            return None
        at = self._stall["to_host"].hold(self._air_h[0].at)
        return at if at <= self.now_cycles else None

    def lookahead_cycles(self) -> int:
        """How far the module's clock may run ahead of the host's without any host byte
        arriving in the module's past: the one-way latency (jitter only adds to it)."""
        return self._latency

    def in_flight(self) -> dict[str, int]:
        """Bytes on the way in each direction (rings, wire queue, radio, air)."""
        return {
            "to_module": self._air_m_bytes + self._radio_m_bytes + len(self._rx),
            "to_host": len(self._tx) + self._air_h_bytes,
        }

    def quiet_until(self) -> int | None:
        """A lower bound of the first cycle at which :meth:`advance` changes what the module
        or the host sees — bytes reaching the µC's receive ring or the host's buffer, the
        connection going down or up — if the host writes nothing; None = never.

        The current time (or earlier) = not quiet now. Before that bound the link may be
        advanced after the module's loops instead of between them (see :meth:`idle`)."""
        now = self.now_cycles
        if not self._started or self._rx:
            return now
        due = [t for t in (self._next_disconnect, self._reconnect_at) if t is not None]
        if self.connected:
            if self._air_h and self.host_clock is None:
                # (with a host clock the host takes what reached it when it looks: _reach_host)
                due.append(self._stall["to_host"].hold(self._air_h[0].at))
            if self._tx:
                if self._rate is None:
                    return now
                # the next byte off the wire, then at least the latency in the air
                due.append(-(-(self._tx_wire_u + CLOCK_HZ) // self._rate) + self._latency)
            if self._air_m:
                due.append(self._stall["to_module"].hold(self._air_m[0].at))
            if self._radio_m:
                if self._rate is None:
                    return now
                start = max(self._rx_wire_u, self._radio_m[0].at * self._rate)
                due.append(-(-(start + CLOCK_HZ) // self._rate))
        return min(due) if due else None

    def idle(self) -> bool:
        """Nothing in flight and no stall, disconnect or reconnect scheduled: advancing once
        to a later time equals advancing tick by tick to it (while :meth:`quiet_until` allows).
        A busy link must still be advanced tick by tick, for the same chunks on the air."""
        return not (self._tx or self._air_h or self._air_m or self._radio_m or self._rx
                    or self._next_stall["to_module"] is not None or self._next_stall["to_host"] is not None
                    or self._next_disconnect is not None or self._reconnect_at is not None
                    or not self._started)

    def connect(self) -> None:
        """The host pairs / the cable is plugged in."""
        self._reconnect_at = None
        if self.connected:
            return
        self.connected = True
        self.counters.connects += 1
        now = self.now_cycles
        if self._rate is not None:
            self._rx_wire_u = max(self._rx_wire_u, now * self._rate)
            self._tx_wire_u = max(self._tx_wire_u, now * self._rate)

    reconnect = connect

    def disconnect(self) -> None:
        """The link goes down: everything in flight is lost (counted); bytes the host
        already received stay readable."""
        self._reconnect_at = None
        self._disconnect()

    def _disconnect(self) -> None:
        if not self.connected:
            return
        self.connected = False
        self.counters.disconnects += 1
        self.counters.to_module.lost_disconnect += self._air_m_bytes + self._radio_m_bytes + len(self._rx)
        self.counters.to_host.lost_disconnect += len(self._tx) + self._air_h_bytes
        self._air_m.clear()
        self._radio_m.clear()
        self._air_m_bytes = self._radio_m_bytes = 0
        self._rx.clear()
        self._tx.clear()
        self._air_h.clear()
        self._air_h_bytes = 0

    # ------------------------------------------------------------------ runtime fault controls
    def stall(self, seconds: float, direction: Direction | Literal["both"] = "both") -> None:
        """Deliver nothing for *seconds* of virtual time from now (held chunks arrive at its end)."""
        if seconds < 0:
            raise ValueError(f"stall of {seconds} s")
        dirs = DIRECTIONS if direction == "both" else (direction,)
        for d in dirs:
            self._start_stall(d, self.now_cycles, _cycles(seconds))
        self.counters.stalls += 1

    def corrupt_next(self, n: int = 1, direction: Direction = "to_host") -> None:
        """Corrupt the next *n* bytes delivered in *direction*."""
        self._force_corrupt[direction] += n

    def drop_next(self, n: int = 1, direction: Direction = "to_host") -> None:
        """Lose the next *n* bytes delivered in *direction*."""
        self._force_drop[direction] += n

    def stalled(self, direction: Direction = "to_host") -> bool:
        s = self._stall[direction]
        return s.start <= self.now_cycles < s.end

    # ------------------------------------------------------------------ internals
    def _start_stall(self, d: Direction, now: int, length: int) -> None:
        s = self._stall[d]
        if s.start <= now < s.end:
            s.end = max(s.end, now + length)
        else:
            s.start, s.end = now, now + length

    def _arrival(self, d: Direction, t: int) -> int:
        """When bytes leaving at *t* arrive: latency + jitter, never before earlier ones."""
        jitter = 0
        if self._jitter:
            if t >= self._jitter_until[d]:
                self._jitter_value[d] = int(self._rng_jitter[d].integers(0, self._jitter))
                self._jitter_until[d] = t + self._jitter_period
            jitter = self._jitter_value[d]
        at = max(self._last_at[d], t + self._latency + jitter)
        self._last_at[d] = at
        return at

    def _gap(self, rate_hz: float) -> int:
        """Cycles to the next event of a Poisson process of *rate_hz* (seeded)."""
        return max(1, _cycles(self._rng_events.exponential(1.0 / rate_hz)))

    def _schedule_random_events(self, now: int) -> None:
        for d in DIRECTIONS:
            rate = self.faults.direction(d).stall_rate_hz
            if rate > 0:
                self._next_stall[d] = now + self._gap(rate)
        if self.faults.disconnect_rate_hz > 0:
            self._next_disconnect = now + self._gap(self.faults.disconnect_rate_hz)

    def _random_events(self, now: int) -> None:
        for d in DIRECTIONS:
            t = self._next_stall[d]
            while t is not None and t <= now:
                lo, hi = self.faults.stall_s
                self._start_stall(d, t, _cycles(self._rng_events.uniform(lo, hi)))
                self.counters.stalls += 1
                t = t + self._gap(self.faults.direction(d).stall_rate_hz)
                self._next_stall[d] = t
        t = self._next_disconnect
        while t is not None and t <= now:
            if self.connected:
                self._disconnect()
                if self.faults.reconnect_s is not None:
                    lo, hi = self.faults.reconnect_s
                    self._reconnect_at = t + _cycles(self._rng_events.uniform(lo, hi))
            t = t + self._gap(self.faults.disconnect_rate_hz)
            self._next_disconnect = t
        if self._reconnect_at is not None and self._reconnect_at <= now:
            self.connect()

    def _pump(self, now: int) -> None:
        if not self.connected:
            return
        self._pump_to_host(now)
        self._pump_to_module(now)

    def _apply_faults(self, d: Direction, data: bytearray) -> bytearray:
        """Injected loss and corruption on bytes being delivered in direction *d*."""
        c = self.counters.direction(d)
        f = self.faults.direction(d)
        if self._force_drop[d]:
            k = min(self._force_drop[d], len(data))
            self._force_drop[d] -= k
            c.lost_fault += k
            data = data[k:]
        if self._force_corrupt[d] and data:
            k = min(self._force_corrupt[d], len(data))
            self._force_corrupt[d] -= k
            rng = self._rng_fault[d]
            for i in range(k):
                data[i] ^= int(rng.integers(1, 256))
            c.corrupted += k
        if (f.byte_loss or f.corrupt) and data:
            data, corrupted, lost = random_byte_faults(data, f, self._rng_fault[d])
            c.corrupted += corrupted
            c.lost_fault += lost
        return data

    def _pump_to_host(self, now: int) -> None:
        """µC transmit ring → wire → radio/air → host buffer, up to *now*."""
        if not self.connected:
            return
        c = self.counters.to_host
        p = self.profile
        if self._tx:
            if self._rate is None:
                k, done = len(self._tx), now
            else:
                byte_u = CLOCK_HZ
                k = min(len(self._tx), max(0, (now * self._rate - self._tx_wire_u) // byte_u))
                self._tx_wire_u += k * byte_u
                done = -(-self._tx_wire_u // self._rate)  # cycle the last of them finished
            if k:
                chunk = bytearray(self._tx[:k])
                del self._tx[:k]
                c.wire += k
                if p.radio_buffer is not None:
                    room = max(0, p.radio_buffer - self._air_h_bytes)
                    if k > room:
                        c.lost_overflow += k - room
                        del chunk[room:]
                if chunk:
                    self._air_h.append(Chunk(self._arrival("to_host", done), chunk))
                    self._air_h_bytes += len(chunk)
        self._deliver_to_host(now)

    def _note_lateness(self, c: DirectionCounters, late: int, n: int) -> None:
        """*n* bytes reached their far end *late* cycles after their arrival time (≤ 0: on time)."""
        if late > self.late_tolerance_cycles:
            c.late += n
        if late > c.late_max_cycles:
            c.late_max_cycles = late

    def _arrived(self, air: deque[Chunk], direction: str, until: int) -> Iterator[tuple[int, Chunk]]:
        """Take the chunks of *air* that arrived by *until*, in order, each with its arrival time
        (held back by a stall of *direction*); the first one still on its way keeps its held time."""
        stall = self._stall[direction]
        while air:
            ch = air[0]
            at = stall.hold(ch.at)
            if at > until:
                ch.at = at
                return
            air.popleft()
            yield at, ch

    def _deliver_to_host(self, now: int) -> None:
        """air → host buffer: the chunks that arrived by *now* (module cycles) and, with a
        host clock, by the host's present (the stall windows are known up to *now* only)."""
        if not self._air_h:
            return
        c = self.counters.to_host
        p = self.profile
        host_now = None if self.host_clock is None else self.host_clock()
        until = now if host_now is None else min(now, host_now)
        for at, ch in self._arrived(self._air_h, "to_host", until):
            if host_now is not None:
                self._note_lateness(c, host_now - at, len(ch.data))
            self._air_h_bytes -= len(ch.data)
            data = self._apply_faults("to_host", ch.data)
            if p.host_rx_buffer is not None:
                room = max(0, p.host_rx_buffer - len(self._host))
                if len(data) > room:
                    c.lost_overflow += len(data) - room
                    del data[room:]
            self._host += data
            c.delivered += len(data)

    def _pump_to_module(self, now: int) -> None:
        """air → radio → wire → µC receive ring, up to *now*."""
        if not self.connected:
            return
        c = self.counters.to_module
        p = self.profile
        for at, ch in self._arrived(self._air_m, "to_module", now):
            self._air_m_bytes -= len(ch.data)
            data = self._apply_faults("to_module", ch.data)
            if data:
                self._radio_m.append(Chunk(at, data))
                self._radio_m_bytes += len(data)
        while self._radio_m:
            ch = self._radio_m[0]
            n = len(ch.data)
            if self._rate is None:
                k = n
            else:
                start = max(self._rx_wire_u, ch.at * self._rate)
                k = min(n, max(0, (now * self._rate - start) // CLOCK_HZ))
            if p.flow_control and p.rx_ring is not None:
                k = min(k, p.rx_ring - len(self._rx))
            if k <= 0:
                if p.flow_control and self._rate is not None:
                    # held back by a full ring: the wire resumes when the µC reads
                    self._rx_wire_u = max(self._rx_wire_u, now * self._rate)
                break
            if self._rate is not None:
                self._rx_wire_u = start + k * CLOCK_HZ
            c.wire += k
            take = ch.data[:k]
            if p.rx_ring is not None:
                room = max(0, p.rx_ring - len(self._rx))
                if k > room:
                    c.lost_overflow += k - room
                    take = take[:room]
            self._rx += take
            self._radio_m_bytes -= k
            if k < n:
                del ch.data[:k]
                break
            self._radio_m.popleft()

    def stats(self) -> dict[str, object]:
        """A snapshot for a status line: profile, connection, counters, bytes in flight."""
        return {
            "profile": self.profile.name,
            "connected": self.connected,
            "stalled": self.stalled("to_host") or self.stalled("to_module"),
            "in_flight": self.in_flight(),
            **self.counters.as_dict(),
        }

    def __repr__(self) -> str:
        state = "connected" if self.connected else "disconnected"
        fl = self.in_flight()
        return (f"{type(self).__name__}({self.profile.name}, {state}, seed={self.seed}, "
                f"in flight to module {fl['to_module']} B / to host {fl['to_host']} B, "
                f"lost {self.counters.to_module.lost}/{self.counters.to_host.lost} B)")


class BluetoothLink(Link):
    """The SPP Bluetooth link over the 115200-baud UART (profile ``"bt"``)."""

    def __init__(self, seed: int = 0, faults: LinkFaults | None = None, connected: bool = True,
                 **overrides: object):
        super().__init__(replace(BLUETOOTH, **overrides), seed, faults, connected)  # type: ignore[arg-type]


class UsbLink(Link):
    """The full-speed USB CDC link (profile ``"usb"``): fast, lossless unless faults are asked for."""

    def __init__(self, seed: int = 0, faults: LinkFaults | None = None, connected: bool = True,
                 **overrides: object):
        super().__init__(replace(USB, **overrides), seed, faults, connected)  # type: ignore[arg-type]


def make_link(profile: str | LinkProfile = "bt", seed: int = 0, faults: LinkFaults | None = None,
              connected: bool = True, **overrides: object) -> Link:
    """A link by profile name (``"bt"``, ``"usb"``, ``"ideal"``) or :class:`LinkProfile`.

    ``overrides`` replace profile fields, e.g. ``make_link("bt", rx_ring=256)``.
    """
    if isinstance(profile, str):
        try:
            prof = PROFILES[profile.lower()]
        except KeyError:
            raise ValueError(f"unknown link profile {profile!r}; known: bt, usb, ideal") from None
    else:
        prof = profile
    if overrides:
        prof = replace(prof, **overrides)  # type: ignore[arg-type]
    return Link(prof, seed, faults, connected)
