"""Import every processing-function module so the registry is complete.

:data:`firmware_sim.sequence.PROCESSING_FUNCTIONS` is filled as a side effect of
importing the modules that define functions. The navigation modules (front
end, INS) are optional here: while they do not exist yet, their ids are
simply unregistered and slots given those ids stay empty. A function module
may define ``apply_state_defaults(memory)`` (power-on values of its settable
states, e.g. TH_ZUPT/TH_ZARU); it is run at every module's boot (or register a
hook yourself with :func:`firmware_sim.sequence.on_boot`).
"""

from __future__ import annotations

import importlib

from . import inertial, utility  # noqa: F401  (registration side effects)
from .sequence import BOOT_HOOKS, PROCESSING_FUNCTIONS, on_boot

#: Optional function modules, imported when present.
OPTIONAL_MODULES = ("firmware_sim.frontend", "firmware_sim.ins")


def _import_optional() -> list[str]:
    loaded = []
    for name in OPTIONAL_MODULES:
        try:
            mod = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name != name:
                raise
        else:
            loaded.append(name)
            defaults = getattr(mod, "apply_state_defaults", None)
            if callable(defaults) and not any(getattr(h, "__wrapped__", None) is defaults
                                              for h in BOOT_HOOKS):
                _register_defaults(defaults)
    return loaded


def _register_defaults(defaults) -> None:
    """A function module's ``apply_state_defaults(memory)`` becomes a boot hook."""

    def hook(module) -> None:
        defaults(module.memory)

    hook.__wrapped__ = defaults  # type: ignore[attr-defined]
    on_boot(hook)


LOADED_OPTIONAL = _import_optional()

__all__ = ["PROCESSING_FUNCTIONS", "LOADED_OPTIONAL"]
