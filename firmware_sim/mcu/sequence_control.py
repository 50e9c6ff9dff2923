"""Processing functions 0x01–0x07: sequence editing and conditional output
(firmware.md §2), plus the conditional-output set-up they act on.

The **conditional output** is one per module: a flag state, a "from" mask
naming the interface(s) it outputs on (bit 0x01 USB, 0x02 Bluetooth), an output
mode and :data:`COND_OUTPUT_SIZE` = 10 state ids (STATE_IF_SETUP fills ids 9
and 10 with its own checksum bytes — protocol.md §9). "Outputting" the listed
states means what an OUTPUT_STATE with that mode does on the named interface
(pull: once in the next packet; a rate: switch the periodic output on), but
without touching the lossless flag.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from protocol.ids import ProcId

from .sequence import processing_function

if TYPE_CHECKING:  # pragma: no cover
    from .module import Module

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

    def force(self, module: Module) -> None:
        """state_output_once_force(): output the listed states with the mode, now."""
        mask = self.from_mask
        if not mask:
            return
        mode = self.mode
        for iface in module.interface_list:
            if iface.mask & mask:
                for sid in self.state_ids:
                    iface.output(sid, mode)

    def __repr__(self) -> str:
        ids = " ".join(f"{s:02X}" for s in self.state_ids)
        return (f"ConditionalOutput(flag 0x{self.flag_id:02X}, from 0x{self.from_mask:X}, "
                f"mode 0x{self.mode:02X}, ids [{ids}], wait {self.wait_cycles})")


@processing_function(ProcId.STORE_AND_EMPTY_PROC_SEQU, cycles=80)
def store_and_empty_proc_sequ(module: Module) -> None:
    """Copy the running sequence to storage and empty it (it stops after this slot)."""
    module.sequence.store_and_empty()


@processing_function(ProcId.RESTORE_PROC_SEQU, cycles=60)
def restore_proc_sequ(module: Module) -> None:
    """Copy the stored sequence back into the running slots."""
    module.sequence.restore()


@processing_function(ProcId.EMPTY_PROCESS_SEQUENCE, cycles=40)
def empty_process_sequence(module: Module) -> None:
    module.sequence.empty()


@processing_function(ProcId.RESTORE_PROC_SEQU_IF, cycles=30)
def restore_proc_sequ_if(module: Module) -> None:
    """Restore the stored sequence when the flag state set by RESET_PROC_SETUP (0x36) is true."""
    if module.memory.flag(module.restore_if_flag):
        module.sequence.restore()


@processing_function(ProcId.STATE_OUTPUT_IF, cycles=60)
def state_output_if(module: Module) -> None:
    """Output the conditional states while the conditional output's flag state is true."""
    cond = module.cond_output
    if module.memory.flag(cond.flag_id):
        cond.force(module)


@processing_function(ProcId.STATE_OUTPUT_ONCE_IF, cycles=70)
def state_output_once_if(module: Module) -> None:
    """As STATE_OUTPUT_IF, then clear the flag state."""
    cond = module.cond_output
    memory = module.memory
    if memory.flag(cond.flag_id):
        cond.force(module)
        memory.clear_flag(cond.flag_id)


@processing_function(ProcId.STATE_OUTPUT_IF_COUNTER, cycles=30)
def state_output_if_counter(module: Module) -> None:
    """Force the conditional output once, when the interrupt counter is wait_cycles past set-up."""
    cond = module.cond_output
    if (module.clock.interrupts - cond.setup_count) & _U32 == cond.wait_cycles:
        cond.force(module)


#: The runtime's own processing functions (0x01–0x07), in every firmware image.
RUNTIME_FUNCTIONS = (store_and_empty_proc_sequ, restore_proc_sequ, empty_process_sequence,
                     restore_proc_sequ_if, state_output_if, state_output_once_if, state_output_if_counter)
