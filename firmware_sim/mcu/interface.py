"""One external interface of the module (USB or Bluetooth): command parser,
output tables, packet assembly and package queue (protocol.md §5–§7).

Per loop cycle the module calls :meth:`ExternalInterface.receive` (parse and
execute commands) and, after the process sequence, :meth:`ExternalInterface.transmit`
(assemble at most one packet and hand frames to the link). Everything a
command sets up (periodic outputs, pulled states, the lossless flag, the queue,
the packet counter) belongs to the interface the command came from.

Parser (§7): at most 400 bytes are taken from the link per cycle; a byte that
is not a command id of the module's numbering, when a header is expected, is
discarded (counted); a command id opens a frame of payload + 2 checksum bytes;
a complete frame with a good checksum is executed and acknowledged (ACK 0x01
is not acknowledged), one with a bad checksum is dropped silently (counted).
A partial frame is discarded when no byte arrived for :data:`RX_TIMEOUT_CYCLES`
(checked only when the receive ring is empty), or when the interface is not
connected.

Output timing (§5) and assembly (§6) follow the module's tables exactly: per
state a rate divider and a down-counter, scanned in ascending id order at every
assembly; switching an output on with divider D > 1 sets its counter to the
largest ``counter mod D`` over the outputs running on this interface (itself
included if it was running), so it fires in step with them. Pulled states are
due at the next assembly. States that would push a packet past 512 bytes are
left out (and counted); a pulled state that is left out is not kept.

Packet numbers start at 1 after boot and are those of a C ``uint16_t``: after
65535 comes **0** (not skipped — the module does not skip it; the host tells a
packet from a command ack by the header byte, not by the number). A number is
used by every assembled packet, also one then dropped by a full queue, so the
host sees the gap.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NamedTuple, Protocol

from protocol.commands import CommandSet, CommandSpec
from protocol.frames import MAX_PACKET, build_command_ack, build_state_packet, checksum
from protocol.ids import Interface, OutputMode

from .packet_queue import PackageQueue

if TYPE_CHECKING:  # pragma: no cover
    from .clock import Clock, CostModel
    from .memory import StateMemory
    from .port import Port

#: Bytes the parser takes from a link per loop cycle.
MAX_RX_BYTES_PER_CYCLE = 400
#: A partial command frame is discarded after this many cycles without a byte (~3 s).
RX_TIMEOUT_CYCLES = 200_000_000
#: Header (AA, number, length) before a packet's payload.
_PACKET_HEADER_LEN = 4
#: Largest header + payload, leaving room for the checksum.
_MAX_BEFORE_CHECKSUM = MAX_PACKET - 2
_STATE_IDS = 256
_PULL = int(OutputMode.PULL)
_RATE_MASK = int(OutputMode.RATE_MASK)


class TraceEntry(NamedTuple):
    """One frame in or out of an interface, at a virtual time."""

    cycles: int  #: the module's now_cycles when it happened
    interface: str  #: "USB" or "BT"
    direction: str  #: "in" (host → module) or "out" (module → host)
    data: bytes
    note: str  #: "command", "bad checksum", "timeout", "disconnected", "ack", "packet", "resend"

    def __repr__(self) -> str:
        return (f"TraceEntry({self.cycles}, {self.interface} {self.direction}, {self.note}: "
                f"{self.data.hex(' ').upper()})")


class InterfaceOwner(Protocol):
    """What an interface needs of its module: its memory, clock and loop costs, the trace,
    and the command handlers (:meth:`execute`) that act on the whole module."""

    memory: StateMemory
    clock: Clock
    costs: CostModel
    trace: Any  #: None, or anything with ``append(TraceEntry)``

    def execute(self, iface: ExternalInterface, spec: CommandSpec, raw: bytes) -> None: ...


class ExternalInterface:
    """USB or Bluetooth interface of one module."""

    def __init__(self, module: InterfaceOwner, kind: Interface, port: Port, command_set: CommandSet):
        self.module = module
        self.kind = kind
        self.name = "USB" if kind is Interface.USB else "BT"
        #: Bit of this interface in a "from" mask (SETUP_DEBUG_PROC's interface byte).
        self.mask = int(kind)
        self.port = port
        self.command_set = command_set
        self._by_id: list[CommandSpec | None] = [command_set.get(i) for i in range(256)]
        self._ack_frames: dict[int, bytes] = {}
        # parser
        self._frame = bytearray()
        self._spec: CommandSpec | None = None
        self._need = 0
        self._last_rx = 0
        # output tables
        self.divider = [0] * _STATE_IDS
        self.counter = [0] * _STATE_IDS
        self._periodic: list[int] = []  # ids with a divider, ascending
        self._pulled: set[int] = set()
        self.lossless = False
        self.packet_number = 0  # number of the last assembled packet
        self.queue = PackageQueue()
        self.queue.on_send = self._trace_send
        # counters for a host developer
        self.bytes_received = 0
        self.bytes_discarded = 0  #: non-command bytes where a header was expected
        self.frames_executed = 0
        self.bad_checksums = 0
        self.partial_timeouts = 0
        self.partial_disconnects = 0
        self.packets_assembled = 0
        self.states_left_out = 0  #: states left out of a packet by the 512-byte cap
        self.last_packet: bytes = b""

    # ------------------------------------------------------------------ trace
    def _trace(self, direction: str, data: bytes, note: str) -> None:
        tr = self.module.trace
        if tr is not None:
            tr.append(TraceEntry(self.module.clock.now_cycles, self.name, direction, bytes(data), note))

    def _trace_send(self, data: bytes, resend: bool) -> None:
        if self.module.trace is not None:
            note = "resend" if resend else ("ack" if data[0] != 0xAA else "packet")
            self._trace("out", data, note)

    # ---------------------------------------------------------------- receive
    @property
    def connected(self) -> bool:
        return self.port.connected

    @property
    def partial_frame(self) -> bytes:
        """Bytes of the command frame being received (empty between frames)."""
        return bytes(self._frame)

    def _drop_partial(self, note: str) -> None:
        if self._need:
            self._trace("in", self._frame, note)
            if note == "timeout":
                self.partial_timeouts += 1
            else:
                self.partial_disconnects += 1
        self._frame.clear()
        self._need = 0
        self._spec = None

    def receive(self) -> None:
        """rxif_cmd(): parse up to 400 bytes and execute the complete commands."""
        module = self.module
        clock = module.clock
        costs = module.costs
        clock.now_cycles += costs.rx_poll
        if not self.port.connected:
            if self._need:
                self._drop_partial("disconnected")
            return
        data = self.port.rx_read(MAX_RX_BYTES_PER_CYCLE)
        if data:
            n = len(data)
            self.bytes_received += n
            clock.now_cycles += n * costs.rx_per_byte
            self._last_rx = clock.now_cycles
            self._parse(data)
            if n == MAX_RX_BYTES_PER_CYCLE:
                return  # more may be waiting: no timeout check (as on the µC)
        if self._need and clock.now_cycles - self._last_rx > RX_TIMEOUT_CYCLES:
            self._drop_partial("timeout")

    def _parse(self, data: bytes) -> None:
        frame = self._frame
        by_id = self._by_id
        for b in data:
            if not self._need:
                spec = by_id[b]
                if spec is None:
                    self.bytes_discarded += 1
                    continue
                self._spec = spec
                frame.append(b)
                self._need = spec.payload_len + 2
                continue
            frame.append(b)
            self._need -= 1
            if not self._need:
                raw = bytes(frame)
                frame.clear()
                spec = self._spec
                self._spec = None
                if checksum(raw[:-2]) == (raw[-2] << 8 | raw[-1]):
                    self._trace("in", raw, "command")
                    self._execute(spec, raw)
                else:
                    self.bad_checksums += 1
                    self._trace("in", raw, "bad checksum")

    def _execute(self, spec: CommandSpec, raw: bytes) -> None:
        self.frames_executed += 1
        self.module.clock.now_cycles += self.module.costs.command_exec
        self.module.execute(self, spec, raw)
        if spec.acked:
            ack = self._ack_frames.get(spec.wire_id)
            if ack is None:
                ack = self._ack_frames[spec.wire_id] = build_command_ack(spec.wire_id)
            self.queue.add(ack, 0, single=True, is_ack=True)

    def reset_parser(self) -> None:
        """Discard a partial command frame now (what the receive timeout does), counted as a timeout."""
        self._drop_partial("timeout")

    def feed(self, data: bytes) -> None:
        """Run *data* through the parser now, bypassing the link (for tests and HIL tools)."""
        self.bytes_received += len(data)
        self._last_rx = self.module.clock.now_cycles
        self._parse(data)

    # ---------------------------------------------------------------- outputs
    def set_state_output(self, state_id: int, rate: int) -> None:
        """Periodic output of a state: rate code d (mode & 7); 0 switches it off."""
        if not self.module.memory.exists(state_id):
            return
        if rate >= 1:
            d = 1 << ((rate & 0x0F) - 1)
            start = 0
            if d > 1:
                mask = d - 1
                counter = self.counter
                for sid in self._periodic:
                    c = counter[sid] & mask
                    if c > start:
                        start = c
            if not self.divider[state_id]:
                self._periodic.append(state_id)
                self._periodic.sort()
            self.divider[state_id] = d
            self.counter[state_id] = start
        else:
            if self.divider[state_id]:
                self._periodic.remove(state_id)
            self.divider[state_id] = 0
            self.counter[state_id] = 0

    def pull(self, state_id: int) -> None:
        """Output a state once, in the next packet."""
        if self.module.memory.exists(state_id):
            self._pulled.add(state_id)

    def output(self, state_id: int, mode: int) -> None:
        """state_output(): pull if the mode's pull bit is set, else set the periodic rate."""
        if mode & _PULL:
            self.pull(state_id)
        else:
            self.set_state_output(state_id, mode & _RATE_MASK)

    def all_outputs_off(self) -> None:
        """Every periodic output of this interface off (pulled states stay pending, as on the µC)."""
        for sid in self._periodic:
            self.divider[sid] = 0
            self.counter[sid] = 0
        self._periodic.clear()

    def set_lossless(self, on: bool) -> None:
        self.lossless = bool(on)

    @property
    def periodic_outputs(self) -> dict[int, int]:
        """Running periodic outputs: state id → divider D."""
        return {sid: self.divider[sid] for sid in self._periodic}

    @property
    def pulled(self) -> frozenset[int]:
        """States due once at the next assembly."""
        return frozenset(self._pulled)

    # --------------------------------------------------------------- transmit
    def assemble(self) -> bytes | None:
        """assemble_output_data(): the packet of this cycle, or None if no state is due."""
        periodic = self._periodic
        pulled = self._pulled
        if not periodic and not pulled:
            return None
        if periodic:
            due = []
            divider = self.divider
            counter = self.counter
            for sid in periodic:
                c = counter[sid]
                if c == 0:
                    c = divider[sid]
                    due.append(sid)
                counter[sid] = c - 1
            if pulled:
                pulled.update(due)
                due = sorted(pulled)
                pulled.clear()
            elif not due:
                return None
        else:
            due = sorted(pulled)
            pulled.clear()
        memory = self.module.memory
        sizes = memory.sizes
        pos = _PACKET_HEADER_LEN
        parts = []
        for sid in due:
            size = sizes[sid]
            if pos + size <= _MAX_BEFORE_CHECKSUM:
                parts.append(memory.read_wire(sid))
                pos += size
            else:
                self.states_left_out += 1
        if not parts:
            return None
        self.packet_number = (self.packet_number + 1) & 0xFFFF
        self.packets_assembled += 1
        packet = build_state_packet(self.packet_number, b"".join(parts))
        self.last_packet = packet
        self.module.clock.now_cycles += len(packet) * self.module.costs.tx_per_byte
        return packet

    def transmit(self) -> None:
        """txif_data(): one assembly and one queue transmission, only while connected."""
        port = self.port
        if not port.connected:
            return
        module = self.module
        clock = module.clock
        costs = module.costs
        queue = self.queue
        written = 0
        lossless = self.lossless
        if not lossless and queue.frames:
            written += queue.push_lossy(port)
        if self._periodic or self._pulled:
            clock.now_cycles += costs.tx_scan
            packet = self.assemble()
            if packet is not None:
                queue.add(packet, self.packet_number, single=not lossless)
        if queue.frames:
            if lossless:
                written += queue.send_lossless(port)
            else:
                written += queue.push_lossy(port)
        if written:
            clock.now_cycles += written * costs.tx_write_per_byte

    def empty_queue(self) -> None:
        self.queue.clear()

    # ------------------------------------------------------------------- misc
    def counters(self) -> dict[str, int]:
        """Counters a host developer can watch (what was executed, dropped, resent…)."""
        q = self.queue
        return {
            "bytes_received": self.bytes_received,
            "bytes_discarded": self.bytes_discarded,
            "frames_executed": self.frames_executed,
            "bad_checksums": self.bad_checksums,
            "partial_timeouts": self.partial_timeouts,
            "partial_disconnects": self.partial_disconnects,
            "packets_assembled": self.packets_assembled,
            "states_left_out": self.states_left_out,
            "frames_sent": q.sent_frames,
            "queue_full_drops": q.dropped,
            "resends": q.resends,
            "acks_matched": q.acked,
            "acks_ignored": q.acks_ignored,
            "queue_cleared": q.cleared,
        }

    def __repr__(self) -> str:
        mode = "lossless" if self.lossless else "lossy"
        outs = " ".join(f"{s:02X}/{d}" for s, d in self.periodic_outputs.items())
        return (f"ExternalInterface({self.name}, {'connected' if self.connected else 'disconnected'}, "
                f"{mode}, outputs [{outs}], pulled [{' '.join(f'{s:02X}' for s in sorted(self._pulled))}], "
                f"packet {self.packet_number}, {self.queue!r})")

    def is_idle(self) -> bool:
        """Whether receive() and transmit() only poll this interface: no command frame half
        received, no output set up (periodic or pulled). The queue and the link are asked apart."""
        return not (self._need or self._periodic or self._pulled)

    def count_idle_transmissions(self, loops: int) -> None:
        """Account for *loops* calls of transmit() on an idle interface that sent nothing: a
        lossless packet waiting for its ACK counts its resend delay on (the caller made sure
        that no resend fell due in them)."""
        queue = self.queue
        if self.lossless and queue.frames and self.port.connected:
            queue.delay_counter = (queue.delay_counter + loops) % queue.resend_cycles


__all__ = ["ExternalInterface", "MAX_RX_BYTES_PER_CYCLE", "RX_TIMEOUT_CYCLES", "TraceEntry"]
