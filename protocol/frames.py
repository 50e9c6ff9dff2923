"""The four frames of the OpenShoe wire protocol and their checksum (protocol.md §1, §2).

=================  =============  ==============================================
frame              direction      layout
=================  =============  ==============================================
command            host → module  ``cmd · payload · ck ck`` (payload fixed per command)
command ack        module → host  ``A0 · cmd · ck ck`` (4 bytes)
state packet       module → host  ``AA · number(2) · len(1) · payload · ck ck``
packet ack         host → module  ``01 · number(2) · ck ck`` (this *is* command 0x01)
=================  =============  ==============================================

The checksum ``ck ck`` is the 16-bit additive sum of every preceding byte of the
frame, MSB first (not a CRC). The length byte of a state packet is the payload
length **modulo 256** (a firmware quirk, §9); a packet is at most 512 bytes with
its checksum, so a payload is at most :data:`MAX_PAYLOAD` = 506 bytes.

The layouts are declared once with construct (:data:`COMMAND_ACK_FRAME`,
:data:`STATE_PACKET_FRAME`, :data:`PACKET_ACK_FRAME`, :func:`command_frame`);
the parsers below use those declarations and return frozen dataclasses. The
three module-side builders (:func:`build_state_packet`, :func:`build_command_ack`,
:func:`build_packet_ack`) are on every emulated module's hot path, so they write
the same bytes with plain ``bytes`` operations; tests check them against the
construct declarations (:func:`build_state_packet_declared` is the declared build).
Every parse failure is a :class:`FrameError` (a ``ValueError``)
naming the problem and showing the offending bytes in hex.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache
from types import MappingProxyType
from typing import Any

import numpy as np
from construct import (
    Array,
    Bytes,
    Checksum,
    ChecksumError,
    Const,
    Construct,
    ConstructError,
    Container,
    Int8ub,
    Int16ub,
    ListContainer,
    Pass,
    RawCopy,
    Rebuild,
    Struct,
    this,
)

from .commands import CURRENT, LEGACY_2014, CommandSet, CommandSpec
from .ids import ACK_HEADER, PACKET_HEADER, Command, Command2014

__all__ = [
    "ACK_FRAME_LEN",
    "COMMAND_ACK_FRAME",
    "MAX_PACKET",
    "MAX_PAYLOAD",
    "PACKET_ACK_FRAME",
    "PACKET_ACK_FRAME_LEN",
    "PACKET_OVERHEAD",
    "STATE_PACKET_FRAME",
    "CommandAck",
    "CommandFrame",
    "FrameError",
    "PacketAck",
    "StatePacket",
    "build_command",
    "build_command_ack",
    "build_packet_ack",
    "build_state_packet",
    "build_state_packet_declared",
    "checksum",
    "checksum_bytes",
    "command_frame",
    "hexdump",
    "parse_command",
    "parse_command_ack",
    "parse_packet_ack",
    "parse_state_packet",
]

#: A state packet with its checksum is at most this many bytes (protocol.md §9).
MAX_PACKET = 512
#: Bytes of a state packet around its payload: AA, number (2), length (1), checksum (2).
PACKET_OVERHEAD = 6
#: Largest payload of a state packet.
MAX_PAYLOAD = MAX_PACKET - PACKET_OVERHEAD
#: Length of a command ack frame (A0 cmd ck ck).
ACK_FRAME_LEN = 4
#: Length of a packet ack frame (01 num num ck ck).
PACKET_ACK_FRAME_LEN = 5


class FrameError(ValueError):
    """A frame that is not what it claims to be (bad header, length or checksum)."""


def hexdump(data: bytes | bytearray | memoryview, limit: int = 64) -> str:
    """Bytes as ``'AA 00 01 …'`` (uppercase hex, space-separated), cut after *limit* bytes."""
    data = bytes(data)
    text = data[:limit].hex(" ").upper()
    if len(data) > limit:
        text += f" … ({len(data)} bytes)"
    return text


def checksum(data: bytes | bytearray | memoryview) -> int:
    """The protocol checksum of *data*: the sum of its bytes modulo 2^16 (not a CRC)."""
    return sum(memoryview(data).cast("B")) & 0xFFFF


def checksum_bytes(data: bytes | bytearray | memoryview) -> bytes:
    """The two checksum bytes that follow *data* on the wire (MSB first)."""
    return checksum(data).to_bytes(2, "big")


def _with_checksum(body: Construct) -> Construct:
    """``body · checksum(2)`` where the checksum covers the raw bytes of *body*."""
    return Struct(
        "body" / RawCopy(body),
        "checksum" / Checksum(Int16ub, checksum, this.body.data),
    )


#: ``A0 · cmd · ck ck`` — the module's acknowledgement of a command.
COMMAND_ACK_FRAME: Construct = _with_checksum(
    Struct("header" / Const(bytes([ACK_HEADER])), "command_id" / Int8ub)
)

#: ``AA · number(2) · len(1) · payload · ck ck``. The payload length cannot be read
#: from the length byte (it is the length mod 256), so parsing takes it as the
#: context parameter ``payload_len`` (the frame length minus 6).
STATE_PACKET_FRAME: Construct = _with_checksum(
    Struct(
        "header" / Const(bytes([PACKET_HEADER])),
        "number" / Int16ub,
        "length_byte" / Rebuild(Int8ub, lambda ctx: len(ctx.payload) % 256),
        "payload" / Bytes(this._params.payload_len),
    )
)

#: ``01 · number(2) · ck ck`` — the host's acknowledgement of a lossless packet.
PACKET_ACK_FRAME: Construct = _with_checksum(
    Struct("header" / Const(bytes([Command.ACK])), "packet_number" / Int16ub)
)


@cache
def command_frame(spec: CommandSpec) -> Construct:
    """The construct declaration of the whole frame of one command: ``cmd · payload · ck ck``."""
    return _with_checksum(Struct("command_id" / Const(bytes([spec.wire_id])), "payload" / spec.payload))


# --------------------------------------------------------------------------- dataclasses


@dataclass(frozen=True)
class CommandAck:
    """The module's acknowledgement of a command (``A0 cmd ck ck``); *command_id* is the wire id."""

    command_id: int

    def to_bytes(self) -> bytes:
        return build_command_ack(self.command_id)

    def __repr__(self) -> str:
        return f"CommandAck(command_id=0x{self.command_id:02X})"


@dataclass(frozen=True)
class StatePacket:
    """A state packet: its per-interface number and the raw payload (states in ascending id order).

    *length_byte* is the byte the packet announced: ``len(payload) % 256``.
    """

    number: int
    payload: bytes
    length_byte: int | None = None

    def __post_init__(self) -> None:
        if self.length_byte is None:
            object.__setattr__(self, "length_byte", len(self.payload) % 256)

    def to_bytes(self) -> bytes:
        return build_state_packet(self.number, self.payload)

    def __repr__(self) -> str:
        return (
            f"StatePacket(number=0x{self.number:04X}, length_byte=0x{self.length_byte:02X}, "
            f"payload[{len(self.payload)}]={hexdump(self.payload, 32)!r})"
        )


@dataclass(frozen=True)
class PacketAck:
    """The host's acknowledgement of lossless packet *number* (command 0x01)."""

    number: int

    def to_bytes(self) -> bytes:
        return build_packet_ack(self.number)

    def __repr__(self) -> str:
        return f"PacketAck(number=0x{self.number:04X})"


@dataclass(frozen=True, eq=True)
class CommandFrame:
    """A parsed command frame: its spec (meaning, wire id), payload fields and raw bytes.

    *fields* maps the payload's field names (those of
    :data:`protocol.commands.PAYLOADS`) to ints, bytes or lists of ints
    (read-only; it compares equal to a plain dict).
    """

    spec: CommandSpec
    fields: Mapping[str, Any] = field(hash=False)
    raw: bytes

    @property
    def command(self) -> Command:
        """The meaning (current-numbering name)."""
        return self.spec.command

    @property
    def command_id(self) -> int:
        """The header byte on the wire."""
        return self.spec.wire_id

    def __hash__(self) -> int:
        return hash((self.spec, self.raw))

    def __repr__(self) -> str:
        parts = ", ".join(f"{k}={_hexval(v)}" for k, v in self.fields.items())
        head = f"{self.spec.name} 0x{self.spec.wire_id:02X}"
        return f"CommandFrame({head}, {{{parts}}}, raw={hexdump(self.raw)!r})"


def _hexval(v: Any) -> str:
    if isinstance(v, (bytes, bytearray)):
        return repr(hexdump(v))
    if isinstance(v, int):
        return f"0x{v:02X}" if v >= 0 else str(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_hexval(x) for x in v) + "]"
    return repr(v)


# --------------------------------------------------------------------------- commands


def _resolve(meaning_or_id: int, command_set: CommandSet | None) -> tuple[CommandSpec, CommandSet]:
    if isinstance(meaning_or_id, Command2014):
        cs = LEGACY_2014 if command_set is None else command_set
        if cs is not LEGACY_2014:
            raise ValueError(
                f"{meaning_or_id!r} is a 2014 wire id; pass the meaning Command.{meaning_or_id.name} "
                f"to build it under the {cs.name} numbering"
            )
        return cs[int(meaning_or_id)], cs
    cs = CURRENT if command_set is None else command_set
    if isinstance(meaning_or_id, Command):
        return cs.spec(meaning_or_id), cs
    wire_id = int(meaning_or_id)
    if wire_id not in cs:
        raise ValueError(f"0x{wire_id:02X} is not a command id in the {cs.name} numbering")
    return cs[wire_id], cs


def _field_names(payload: Construct) -> list[str]:
    if payload is Pass:
        return []
    return [sc.name for sc in payload.subcons if sc.name]


def _plain(value: Any) -> Any:
    """A construct parse result as plain Python (dicts, lists, ints, bytes)."""
    if isinstance(value, Container):
        return {k: _plain(v) for k, v in value.items() if not k.startswith("_")}
    if isinstance(value, ListContainer):
        return [_plain(v) for v in value]
    return value


def _prepare_field(payload: Construct, name: str, value: Any) -> Any:
    """Accept numpy arrays and ints for array fields; zero-pad short byte fields."""
    sub = next(sc for sc in payload.subcons if sc.name == name).subcon
    if isinstance(sub, Bytes):
        n = sub.length
        data = bytes(value)
        if len(data) > n:
            raise ValueError(f"field {name!r} takes at most {n} bytes, got {len(data)}: {hexdump(data)}")
        # SET_STATE_n copies the state's own size; shorter data is padded with zeros.
        return data.ljust(n, b"\x00")
    if isinstance(sub, Array):
        return np.asarray(value).tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def build_command(meaning_or_id: int, *, command_set: CommandSet | None = None, **fields: Any) -> bytes:
    """The bytes of a command frame (host → module).

    *meaning_or_id* is a :class:`Command` (the meaning; its wire id is taken
    from *command_set*, default the current numbering), a :class:`Command2014`
    member (a 2014 wire id; implies ``LEGACY_2014``), or a plain int wire id of
    *command_set*. *fields* are the payload's fields by name, e.g.
    ``build_command(Command.SET_STATE_4, state_id=0x19, data=b"\\x00\\x01\\x86\\xa0")``.
    Byte fields shorter than their width are zero-padded. Missing, unknown or
    out-of-range fields raise ``ValueError``.
    """
    spec, _ = _resolve(meaning_or_id, command_set)
    names = _field_names(spec.payload)
    unknown = sorted(set(fields) - set(names))
    missing = [n for n in names if n not in fields]
    if unknown or missing:
        raise ValueError(
            f"{spec.name} (0x{spec.wire_id:02X}) takes fields {names}; "
            f"missing {missing}, unknown {unknown}"
        )
    payload_value = (
        None if not names else {n: _prepare_field(spec.payload, n, fields[n]) for n in names}
    )
    try:
        return command_frame(spec).build({"body": {"value": {"payload": payload_value}}})
    except (ConstructError, TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"cannot build {spec.name} (0x{spec.wire_id:02X}) with {fields}: {exc}") from exc


def parse_command(frame: bytes, command_set: CommandSet | None = None) -> CommandFrame:
    """Parse one whole command frame (exactly its length) under *command_set* (default current)."""
    frame = bytes(frame)
    cs = CURRENT if command_set is None else command_set
    if not frame:
        raise FrameError("empty command frame")
    if frame[0] not in cs:
        raise FrameError(f"0x{frame[0]:02X} is not a command id in the {cs.name} numbering: {hexdump(frame)}")
    spec = cs[frame[0]]
    if len(frame) != spec.frame_len:
        raise FrameError(
            f"{spec.name} frame must be {spec.frame_len} bytes, got {len(frame)}: {hexdump(frame)}"
        )
    _check_sum(frame, spec.name)
    parsed = command_frame(spec).parse(frame)
    fields = _plain(parsed.body.value.payload) if parsed.body.value.payload is not None else {}
    return CommandFrame(spec=spec, fields=MappingProxyType(fields), raw=frame)


def _check_sum(frame: bytes, what: str) -> None:
    want = checksum(frame[:-2])
    got = int.from_bytes(frame[-2:], "big")
    if want != got:
        raise FrameError(f"{what} frame has checksum 0x{got:04X}, expected 0x{want:04X}: {hexdump(frame)}")


# --------------------------------------------------------------------------- command ack


def build_command_ack(cmd_id: int) -> bytes:
    """The module's ack of command *cmd_id* (its wire id): ``A0 cmd ck ck``."""
    if not 0 <= cmd_id <= 0xFF:
        raise ValueError(f"command id {cmd_id} is not a byte")
    ck = ACK_HEADER + cmd_id  # < 2^16: no wrap
    return bytes((ACK_HEADER, cmd_id, ck >> 8, ck & 0xFF))


def parse_command_ack(frame: bytes, command_set: CommandSet | None = None) -> CommandAck:
    """Parse ``A0 cmd ck ck``. With *command_set*, *cmd* must be an acked command of that numbering."""
    frame = bytes(frame)
    if len(frame) != ACK_FRAME_LEN:
        raise FrameError(f"command ack must be {ACK_FRAME_LEN} bytes, got {len(frame)}: {hexdump(frame)}")
    if frame[0] != ACK_HEADER:
        raise FrameError(f"command ack must start with A0: {hexdump(frame)}")
    _check_sum(frame, "command ack")
    cmd = COMMAND_ACK_FRAME.parse(frame).body.value.command_id
    if command_set is not None and not (cmd in command_set and command_set[cmd].acked):
        raise FrameError(f"0x{cmd:02X} is not an acknowledged command of the {command_set.name} "
                         f"numbering: {hexdump(frame)}")
    return CommandAck(cmd)


# --------------------------------------------------------------------------- state packet


def build_state_packet(number: int, payload: bytes) -> bytes:
    """``AA · number · len%256 · payload · ck ck`` for packet *number* (0..65535)."""
    n = len(payload)
    if not 0 <= number <= 0xFFFF:
        raise ValueError(f"packet number {number} out of range 0..0xFFFF")
    if n > MAX_PAYLOAD:
        raise ValueError(f"payload of {n} bytes exceeds the {MAX_PAYLOAD}-byte cap")
    # The hot path of every emulated module: plain bytes, the layout of STATE_PACKET_FRAME
    # (tests/protocol/test_frames_fast.py checks both agree for random inputs).
    frame = bytearray(n + PACKET_OVERHEAD)
    frame[0] = PACKET_HEADER
    frame[1] = number >> 8
    frame[2] = number & 0xFF
    frame[3] = n & 0xFF
    frame[4:4 + n] = payload
    ck = sum(frame) & 0xFFFF  # the two checksum bytes are still 0
    frame[-2] = ck >> 8
    frame[-1] = ck & 0xFF
    return bytes(frame)


def build_state_packet_declared(number: int, payload: bytes) -> bytes:
    """:func:`build_state_packet` through the construct declaration (the reference layout; slower)."""
    payload = bytes(payload)
    if not 0 <= number <= 0xFFFF:
        raise ValueError(f"packet number {number} out of range 0..0xFFFF")
    if len(payload) > MAX_PAYLOAD:
        raise ValueError(f"payload of {len(payload)} bytes exceeds the {MAX_PAYLOAD}-byte cap")
    return STATE_PACKET_FRAME.build(
        {"body": {"value": {"number": number, "payload": payload}}}, payload_len=len(payload)
    )


def parse_state_packet(frame: bytes) -> StatePacket:
    """Parse one whole state packet; the payload length is ``len(frame) - 6``.

    The length byte must equal that modulo 256 (the firmware's quirk).
    """
    frame = bytes(frame)
    if len(frame) < PACKET_OVERHEAD or len(frame) > MAX_PACKET:
        raise FrameError(
            f"state packet must be {PACKET_OVERHEAD}..{MAX_PACKET} bytes, got {len(frame)}: {hexdump(frame)}"
        )
    if frame[0] != PACKET_HEADER:
        raise FrameError(f"state packet must start with AA: {hexdump(frame)}")
    n = len(frame) - PACKET_OVERHEAD
    if frame[3] != n % 256:
        raise FrameError(
            f"state packet length byte 0x{frame[3]:02X} does not match its {n}-byte payload: {hexdump(frame)}"
        )
    _check_sum(frame, "state packet")
    try:
        v = STATE_PACKET_FRAME.parse(frame, payload_len=n).body.value
    except ChecksumError as exc:  # pragma: no cover - checked above
        raise FrameError(str(exc)) from exc
    return StatePacket(number=v.number, payload=bytes(v.payload), length_byte=v.length_byte)


# --------------------------------------------------------------------------- packet ack


def build_packet_ack(number: int) -> bytes:
    """The host's ack of lossless packet *number*: ``01 num num ck ck`` (command 0x01)."""
    if not 0 <= number <= 0xFFFF:
        raise ValueError(f"packet number {number} out of range 0..0xFFFF")
    hi, lo = number >> 8, number & 0xFF
    ck = Command.ACK + hi + lo
    return bytes((Command.ACK, hi, lo, ck >> 8, ck & 0xFF))


def parse_packet_ack(frame: bytes) -> PacketAck:
    """Parse ``01 num num ck ck`` (the same in both numberings)."""
    frame = bytes(frame)
    if len(frame) != PACKET_ACK_FRAME_LEN:
        raise FrameError(
            f"packet ack must be {PACKET_ACK_FRAME_LEN} bytes, got {len(frame)}: {hexdump(frame)}"
        )
    if frame[0] != Command.ACK:
        raise FrameError(f"packet ack must start with 01: {hexdump(frame)}")
    _check_sum(frame, "packet ack")
    return PacketAck(PACKET_ACK_FRAME.parse(frame).body.value.packet_number)
