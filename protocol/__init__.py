"""The OpenShoe wire protocol, declared once: ids, command and state tables,
frames and checksum, payload codec and the module→host stream decoder.

No I/O here: the emulator (:mod:`firmware_sim`) and the host SDK (:mod:`hostlib`)
both build on these declarations.
"""

from .commands import COMMAND_SETS, CURRENT, LEGACY_2014, CommandSet, CommandSpec, command_set
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
    "CommandSet",
    "CommandSpec",
    "Interface",
    "LEGACY_2014",
    "NR_IMUS",
    "NR_SLOTS",
    "OutputMode",
    "PACKET_HEADER",
    "ProcId",
    "STATES",
    "StateId",
    "StateSpec",
    "command_set",
    "rate_divider",
    "state_spec",
]
