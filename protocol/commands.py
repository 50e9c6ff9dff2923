"""The command table: every command's payload layout, under both numberings.

protocol.md §3 (current numbering) and §10 (the 2014 numbering). Payloads are
declared with construct; a command frame is ``id · payload · checksum`` and its
payload length is fixed per command, so the parser knows it from the header byte.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from construct import Array, Bytes, Construct, Int8ub, Int16sb, Int16ub, Int32ub, Pass, Struct

from .ids import NR_IMUS, Command, Command2014


@dataclass(frozen=True)
class CommandSpec:
    """One command: its meaning, wire id under a numbering, and payload layout."""

    command: Command  #: the meaning (current-numbering name)
    wire_id: int  #: the header byte under this numbering
    payload: Construct  #: construct declaration of the payload
    payload_len: int  #: fixed payload length in bytes
    acked: bool = True  #: False only for ACK (0x01)
    doc: str = field(default="", compare=False)

    @property
    def name(self) -> str:
        return self.command.name

    @property
    def frame_len(self) -> int:
        """Bytes of the whole command frame: header + payload + 2 checksum bytes."""
        return 1 + self.payload_len + 2

    def parse_payload(self, data: bytes) -> Any:
        """The fields of a payload *data* (``payload.parse(data)``), parsed by the declaration
        compiled on first use (construct's ``compile``: the same fields, a few times faster — a
        lossless host's ack is parsed once a step)."""
        return _compiled(self.payload).parse(data)

    def __repr__(self) -> str:
        return f"CommandSpec({self.name}, id=0x{self.wire_id:02X}, payload={self.payload_len})"


@functools.cache
def _compiled(payload: Construct) -> Construct:
    return payload.compile()


def _set_state(n: int) -> Construct:
    return Struct("state_id" / Int8ub, "data" / Bytes(n))


#: Payload declarations by meaning. Field names are the host API's keyword names.
PAYLOADS: dict[Command, tuple[Construct, str]] = {
    Command.ACK: (Struct("packet_number" / Int16ub), "acknowledge a lossless packet"),
    Command.PING: (Pass, "nothing; the command ack is the answer"),
    Command.MCU_ID: (Pass, "output state 0x04 (serial number) once"),
    Command.SETUP_DEBUG_PROC: (
        Struct(
            "proc_ids" / Array(10, Int8ub),
            "state_ids" / Array(10, Int8ub),
            "interface" / Int8ub,
        ),
        "hardware-in-the-loop set-up",
    ),
    Command.INPUT_IMU_RD: (
        Struct("timestamp" / Int32ub, "imu" / Array(NR_IMUS, Array(6, Int16sb))),
        "hardware-in-the-loop raw input",
    ),
    Command.SET_STATE_1: (_set_state(1), "set a state of size <= 1"),
    Command.SET_STATE_4: (_set_state(4), "set a state of size <= 4"),
    Command.SET_STATE_12: (_set_state(12), "set a state of size <= 12"),
    Command.SET_STATE_24: (_set_state(24), "set a state of size <= 24"),
    Command.SET_STATE_48: (_set_state(48), "set a state of size <= 48"),
    Command.SET_STATE_254: (_set_state(254), "set a state of size <= 254"),
    Command.OUTPUT_STATE: (Struct("state_id" / Int8ub, "mode" / Int8ub), "output one state"),
    Command.OUTPUT_MULTIPLE_STATES: (
        Struct("state_ids" / Array(8, Int8ub), "mode" / Int8ub),
        "output up to 8 states (0 = none)",
    ),
    Command.OUTPUT_ALL_OFF: (Pass, "all outputs off, queue emptied"),
    Command.STATE_IF_SETUP: (
        Struct("flag_id" / Int8ub, "mode" / Int8ub, "state_ids" / Array(8, Int8ub)),
        "conditional output set-up (firmware reads 10 ids: quirk)",
    ),
    Command.OUTPUT_IMU_RD: (
        Struct("imu_selector" / Int32ub, "mode" / Int8ub),
        "output raw IMU states",
    ),
    Command.SET_IMU_BANDWIDTH: (Struct("dlpf_cfg" / Int8ub), "MPU9150 DLPF_CFG 0..6"),
    Command.RUN_PROC: (Struct("proc_id" / Int8ub, "slot" / Int8ub), "put a function in a slot"),
    Command.RUN_MULT_PROC: (Struct("proc_ids" / Array(8, Int8ub)), "functions in slots 0..7"),
    Command.ALL_PROC_OFF: (Pass, "empty the process sequence"),
    Command.RESET_ZUPT_AIDED_INS: (Pass, "start ZUPT-aided INS"),
    Command.STEPWISE_DEAD_RECKONING: (Pass, "start step-wise dead reckoning"),
    Command.MIMU_FRONTEND: (Pass, "sequence = MIMU front end"),
    Command.RESET_PROC_SETUP: (Struct("flag_id" / Int8ub), "flag for RESTORE_PROC_SEQU_IF"),
    Command.STORE_AND_EMPTY: (Pass, "store the sequence and empty it"),
    Command.RESTORE_PROC_SEQU: (Pass, "restore the stored sequence"),
    Command.NORMAL_IMU: (Struct("mode" / Int8ub), "plain IMU mode"),
    Command.NORMAL_IMU_WITH_BIAS_EST: (Struct("mode" / Int8ub), "plain IMU mode with bias est."),
    Command.GP_TEST: (Struct("a" / Int32ub, "b" / Int32ub), "nothing"),
}


class CommandSet(Mapping[int, CommandSpec]):
    """A numbering: wire id → :class:`CommandSpec`, plus lookup by meaning."""

    def __init__(self, name: str, ids: Mapping[Command, int]):
        self.name = name
        self._by_id: dict[int, CommandSpec] = {}
        self._by_meaning: dict[Command, CommandSpec] = {}
        for meaning, wire_id in ids.items():
            payload, doc = PAYLOADS[meaning]
            spec = CommandSpec(
                command=meaning,
                wire_id=wire_id,
                payload=payload,
                payload_len=payload.sizeof(),
                acked=meaning is not Command.ACK,
                doc=doc,
            )
            if wire_id in self._by_id:
                raise ValueError(f"duplicate wire id 0x{wire_id:02X} in {name}")
            self._by_id[wire_id] = spec
            self._by_meaning[meaning] = spec

    def __getitem__(self, wire_id: int) -> CommandSpec:
        return self._by_id[wire_id]

    def __iter__(self):
        return iter(self._by_id)

    def __len__(self) -> int:
        return len(self._by_id)

    def spec(self, meaning: Command) -> CommandSpec:
        """The spec of a meaning; KeyError if this numbering lacks it."""
        try:
            return self._by_meaning[meaning]
        except KeyError:
            raise KeyError(f"command {meaning.name} does not exist in the {self.name} numbering") from None

    def supports(self, meaning: Command) -> bool:
        return meaning in self._by_meaning

    def is_command(self, wire_id: int) -> bool:
        return wire_id in self._by_id

    def __repr__(self) -> str:
        return f"CommandSet({self.name!r}, {len(self)} commands)"


#: The current numbering (firmware from 2015-01-15).
CURRENT = CommandSet("2015", {c: int(c) for c in Command})
#: The 2014 numbering (protocol.md §10).
LEGACY_2014 = CommandSet("2014", {Command[c.name]: int(c) for c in Command2014})

#: Command sets by the names users type (``--command-set 2014|2015``).
COMMAND_SETS: dict[str, CommandSet] = {"2015": CURRENT, "current": CURRENT, "2014": LEGACY_2014}


def command_set(name: str | CommandSet) -> CommandSet:
    """Look up a numbering by name ('2014', '2015'/'current') or pass one through."""
    if isinstance(name, CommandSet):
        return name
    try:
        return COMMAND_SETS[str(name)]
    except KeyError:
        raise ValueError(f"unknown command set {name!r}; choose 2014 or 2015") from None
