"""Processing functions 0x01–0x07: sequence editing and conditional output (firmware.md §2).

They act on the module's process sequence and on its conditional output
(:mod:`firmware_sim.mcu.conditional_output`). Every firmware image has them
(:data:`RUNTIME_FUNCTIONS`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from protocol.ids import ProcId

from .sequence import processing_function

if TYPE_CHECKING:  # pragma: no cover
    from .context import Mcu as Module

_U32 = 0xFFFFFFFF


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
        cond.force(module.interface_list)


@processing_function(ProcId.STATE_OUTPUT_ONCE_IF, cycles=70)
def state_output_once_if(module: Module) -> None:
    """As STATE_OUTPUT_IF, then clear the flag state."""
    cond = module.cond_output
    memory = module.memory
    if memory.flag(cond.flag_id):
        cond.force(module.interface_list)
        memory.clear_flag(cond.flag_id)


@processing_function(ProcId.STATE_OUTPUT_IF_COUNTER, cycles=30)
def state_output_if_counter(module: Module) -> None:
    """Force the conditional output once, when the interrupt counter is wait_cycles past set-up."""
    cond = module.cond_output
    if (module.clock.interrupts - cond.setup_count) & _U32 == cond.wait_cycles:
        cond.force(module.interface_list)


#: The runtime's own processing functions (0x01–0x07), in every firmware image.
RUNTIME_FUNCTIONS = (store_and_empty_proc_sequ, restore_proc_sequ, empty_process_sequence,
                     restore_proc_sequ_if, state_output_if, state_output_once_if, state_output_if_counter)
