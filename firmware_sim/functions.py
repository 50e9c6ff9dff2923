"""Import every processing-function module so the registry is complete.

:data:`firmware_sim.sequence.PROCESSING_FUNCTIONS` is filled as a side effect of
importing the modules that define functions. The navigation modules (front
end, INS) are optional here: while they do not exist yet, their ids are
simply unregistered and slots given those ids stay empty.
"""

from __future__ import annotations

import importlib

from . import inertial, utility  # noqa: F401  (registration side effects)
from .sequence import PROCESSING_FUNCTIONS

#: Optional function modules, imported when present.
OPTIONAL_MODULES = ("firmware_sim.frontend", "firmware_sim.ins")


def _import_optional() -> list[str]:
    loaded = []
    for name in OPTIONAL_MODULES:
        try:
            importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name != name:
                raise
        else:
            loaded.append(name)
    return loaded


LOADED_OPTIONAL = _import_optional()

__all__ = ["PROCESSING_FUNCTIONS", "LOADED_OPTIONAL"]
