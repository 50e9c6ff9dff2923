"""The module as processing functions, command handlers and firmware images see it.

:class:`Mcu` lists what of the µC they may use: the clock, state memory, process
sequence, sensors, conditional output and interfaces, plus private work state
per function. :class:`~firmware_sim.mcu.module.Module` is the implementation;
typing against this protocol keeps the runtime's parts from importing the module
that assembles them (no import cycles).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

if TYPE_CHECKING:  # pragma: no cover
    from protocol.commands import CommandSet
    from protocol.ids import Interface

    from .clock import Clock, CostModel
    from .conditional_output import ConditionalOutput
    from .imu_bus import SensorSource
    from .interface import ExternalInterface
    from .memory import StateMemory
    from .sequence import ProcessSequence

__all__ = ["Mcu"]

#: The type of a processing function's private state (:meth:`Mcu.work`): what its factory makes.
T = TypeVar("T")


class Mcu(Protocol):
    """One emulated µC with its firmware running (see :class:`~firmware_sim.mcu.module.Module`)."""

    config: Any  #: the module's ModuleConfig
    clock: Clock
    costs: CostModel
    memory: StateMemory
    sequence: ProcessSequence
    sensors: SensorSource
    sensors_exhausted: bool
    dlpf_cfg: int
    restore_if_flag: int
    cond_output: ConditionalOutput
    command_set: CommandSet
    trace: Any
    usb: ExternalInterface
    bt: ExternalInterface
    interfaces: dict[Interface, ExternalInterface]
    interface_list: tuple[ExternalInterface, ExternalInterface]

    def work(self, key: str, factory: Callable[[], T]) -> T:
        """Private state of a processing function, created once per module by *factory*."""
        ...

    def interface(self, kind: Interface | int) -> ExternalInterface: ...
