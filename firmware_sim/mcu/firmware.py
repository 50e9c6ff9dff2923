"""What a module runs: a firmware image handed to :class:`~firmware_sim.mcu.module.Module`.

The runtime (this package) is the µC's framework: the loop, the interfaces, the
command parser and the process sequence. It knows no navigation. A
:class:`Firmware` bundles what a build adds to it:

* the :class:`~firmware_sim.mcu.sequence.FunctionTable` of processing functions
  (the runtime's own sequence-control functions 0x01–0x07 and whatever the
  build links in, e.g. the front end and the INS);
* power-on hooks ``fn(module)`` that write the build's default states (e.g.
  detector thresholds), run at every boot before ``ModuleConfig.initial_states``;
* optionally a :class:`CompiledPath`: a faster implementation of some running
  sequences that gives the same bytes (the module uses it when asked to).

:data:`RUNTIME_ONLY` is the framework with nothing linked in.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Protocol

from .sequence import FunctionTable, ProcessingFn
from .sequence_control import RUNTIME_FUNCTIONS

if TYPE_CHECKING:  # pragma: no cover
    from .context import Mcu as Module

__all__ = ["RUNTIME_ONLY", "CompiledPath", "CompiledSequence", "Firmware"]


class CompiledSequence(Protocol):
    """One module's compiled runner (see :class:`CompiledPath`)."""

    def sequence_tick(self, module: Module, kind: int) -> None:
        """The process sequence of one loop."""

    def quiet_ticks(self, module: Module, max_ticks: int) -> int:
        """How many loops from now run unobserved (0: run loop by loop)."""

    def run_quiet(self, module: Module, max_ticks: int, kind: int) -> int:
        """Run up to *max_ticks* unobserved loops at once; returns how many ran."""


class CompiledPath(Protocol):
    """A compiled implementation of some running sequences, byte-identical to the functions."""

    def available(self) -> bool:
        """Whether it can run in this process."""

    def reason_unavailable(self) -> str:
        """Why not ("" when available)."""

    def kind(self, module: Module) -> int:
        """Which known sequence the module runs now (0: none; run the functions)."""

    def runner(self, module: Module) -> CompiledSequence:
        """The runner bound to *module*'s memory."""


@dataclass(frozen=True)
class Firmware:
    """A firmware image: its processing functions, power-on hooks and compiled path."""

    functions: FunctionTable
    boot_hooks: tuple[Callable[[Module], None], ...] = ()
    compiled_path: CompiledPath | None = field(default=None, compare=False)
    name: str = "firmware"

    def with_functions(self, *fns: ProcessingFn) -> Firmware:
        """The same image with *fns* linked in as well (a declared id replaces the image's own)."""
        return replace(self, functions=self.functions.with_functions(*fns))

    def with_boot_hooks(self, *hooks: Callable[[Module], None]) -> Firmware:
        """The same image with more power-on hooks, run after its own."""
        return replace(self, boot_hooks=self.boot_hooks + tuple(hooks))


#: The framework alone: sequence control and conditional output, no sensors read, no navigation.
RUNTIME_ONLY = Firmware(FunctionTable.of(*RUNTIME_FUNCTIONS), name="runtime only")
