"""Writing the module's frame trace (every frame in and out, with virtual time) to a text file."""

from __future__ import annotations

from typing import TYPE_CHECKING

from firmware_sim.mcu.module import Module

if TYPE_CHECKING:  # pragma: no cover
    from .served_module import ServedModule


class TraceWriter:
    """Moves each module's frame trace to a text file: ``cycles module interface dir note hex``."""

    def __init__(self, path: str, modules: list[ServedModule]):
        self.file = open(path, "w", encoding="utf-8")  # noqa: SIM115 - closed in close()
        self.modules = modules
        self.file.write("# cycles module interface direction note bytes\n")

    def flush(self, stopped: bool = False) -> None:
        """Write the frames traced so far; *stopped*: the pacers have ended, take them directly."""
        for m in self.modules:
            def swap(mod: Module) -> list:
                entries, mod.trace = mod.trace or [], []
                return entries

            if stopped:
                entries = swap(m.module)
            else:
                try:
                    entries = m.pacer.call(swap).result(timeout=5.0)
                except Exception:  # noqa: BLE001 - the pacer has stopped: take what is left directly
                    entries = swap(m.module)
            for e in entries:
                self.file.write(f"{e.cycles} m{m.index} {e.interface} {e.direction} {e.note} "
                                f"{e.data.hex(' ').upper()}\n")
        self.file.flush()

    def close(self) -> None:
        self.file.close()
