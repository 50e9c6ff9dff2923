"""The OpenShoe wire protocol, declared once: ids, command and state tables,
frames and checksum, payload codec and the module→host stream decoder.

No I/O here: the emulator (:mod:`firmware_sim`) and the host SDK (:mod:`hostlib`)
both build on these declarations.
"""

from .commands import COMMAND_SETS, CURRENT, LEGACY_2014, CommandSet, CommandSpec, command_set
from .frames import (
    MAX_PACKET,
    MAX_PAYLOAD,
    CommandAck,
    CommandFrame,
    FrameError,
    PacketAck,
    StatePacket,
    build_command,
    build_command_ack,
    build_packet_ack,
    build_state_packet,
    checksum,
    parse_command,
    parse_command_ack,
    parse_packet_ack,
    parse_state_packet,
)
from .ids import (
    ACK_HEADER,
    NR_IMUS,
    NR_SLOTS,
    PACKET_HEADER,
    Command,
    Command2014,
    Interface,
    OutputMode,
    ProcId,
    StateId,
    rate_divider,
)
from .states import STATES, StateSpec, state_spec

__all__ = [
    "ACK_HEADER",
    "COMMAND_SETS",
    "CURRENT",
    "Command",
    "Command2014",
    "CommandAck",
    "CommandFrame",
    "CommandSet",
    "CommandSpec",
    "FrameError",
    "Interface",
    "LEGACY_2014",
    "MAX_PACKET",
    "MAX_PAYLOAD",
    "NR_IMUS",
    "NR_SLOTS",
    "OutputMode",
    "PACKET_HEADER",
    "PacketAck",
    "ProcId",
    "STATES",
    "StateId",
    "StatePacket",
    "StateSpec",
    "build_command",
    "build_command_ack",
    "build_packet_ack",
    "build_state_packet",
    "checksum",
    "command_set",
    "parse_command",
    "parse_command_ack",
    "parse_packet_ack",
    "parse_state_packet",
    "rate_divider",
    "state_spec",
]
