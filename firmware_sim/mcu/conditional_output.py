"""The module's conditional output: what STATE_OUTPUT_IF and its relatives output.

The **conditional output** is one per module: a flag state, a "from" mask
naming the interface(s) it outputs on (bit 0x01 USB, 0x02 Bluetooth), an output
mode and :data:`COND_OUTPUT_SIZE` = 10 state ids (STATE_IF_SETUP fills ids 9
and 10 with its own checksum bytes — protocol.md §9). "Outputting" the listed
states means what an OUTPUT_STATE with that mode does on the named interface
(pull: once in the next packet; a rate: switch the periodic output on), but
without touching the lossless flag.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Protocol

__all__ = ["COND_OUTPUT_SIZE", "ConditionalOutput"]


class Outputs(Protocol):
    """An interface as the conditional output uses it."""

    mask: int

    def output(self, state_id: int, mode: int) -> None: ...


#: State ids the conditional output holds (8 from the command + 2 that the firmware reads past them).
COND_OUTPUT_SIZE = 10
_U32 = 0xFFFFFFFF


class ConditionalOutput:
    """state_output_if set-up: flag state, interface mask, mode, 10 ids, counter start."""

    __slots__ = ("flag_id", "from_mask", "mode", "state_ids", "setup_count", "wait_cycles")

    def __init__(self) -> None:
        self.flag_id = 0
        self.from_mask = 0
        self.mode = 0
        self.state_ids: list[int] = [0] * COND_OUTPUT_SIZE
        self.setup_count = 0
        self.wait_cycles = 0

    def setup(self, flag_id: int, from_mask: int, mode: int, state_ids: list[int] | None,
              interrupt_count: int, wait_cycles: int = 0) -> None:
        """state_output_if_setup(); *state_ids* None keeps the current ids."""
        self.flag_id = flag_id
        self.from_mask = from_mask
        self.mode = mode
        if state_ids is not None:
            ids = list(state_ids)[:COND_OUTPUT_SIZE]
            self.state_ids = ids + [0] * (COND_OUTPUT_SIZE - len(ids))
        self.setup_count = interrupt_count & _U32
        self.wait_cycles = wait_cycles

    def clear(self, interrupt_count: int) -> None:
        """What OUTPUT_ALL_OFF does: no flag, no interface, no ids."""
        self.setup(0, 0, 0, [], interrupt_count, 0)

    def force(self, interfaces: Iterable[Outputs]) -> None:
        """state_output_once_force(): output the listed states with the mode, now, on those
        of *interfaces* (the module's) that the "from" mask names."""
        mask = self.from_mask
        if not mask:
            return
        mode = self.mode
        for iface in interfaces:
            if iface.mask & mask:
                for sid in self.state_ids:
                    iface.output(sid, mode)

    def __repr__(self) -> str:
        ids = " ".join(f"{s:02X}" for s in self.state_ids)
        return (f"ConditionalOutput(flag 0x{self.flag_id:02X}, from 0x{self.from_mask:X}, "
                f"mode 0x{self.mode:02X}, ids [{ids}], wait {self.wait_cycles})")
