"""Extension modules built ahead of time with numba's ``pycc``: where they live, how they are built
once, and how a process loads one — for the compiled loop (:mod:`firmware_sim.nav.aot`) and the
walk reader (:mod:`firmware_sim.sensors.openshoe_scan`).

A module lives beside numba's cache (``NUMBA_CACHE_DIR`` when set, else the ``__pycache__`` of the
package it is built for) and is named by the digest of its sources: an edit names another one. It
is built whole or not at all (in a temporary folder, then moved), so processes beside see either
nothing or the module. A build that fails (no C compiler, a numba without ``pycc``) is remembered
beside it (``.failed``) and not tried again for those sources. ``OPENSHOE_AOT=0`` turns the built
modules off. A built function releases the GIL while it runs (:func:`compile_releasing_gil`), as
numba's ``nogil`` functions do: a reader thread reads walk files while the runs go on, and a
helper thread runs part of a lockstep's modules, without numba imported.
"""

from __future__ import annotations

import importlib.util
import os
import tempfile
import warnings
from collections.abc import Callable
from importlib.machinery import EXTENSION_SUFFIXES
from pathlib import Path
from typing import Any

__all__ = ["build_once", "compile_releasing_gil", "enabled", "load", "module_path"]


def enabled() -> bool:
    """Whether built modules may be used (not ``OPENSHOE_AOT=0``)."""
    return os.environ.get("OPENSHOE_AOT", "") != "0"


def module_path(package_dir: Path, name: str) -> Path:
    """The module *name* (its sources' digest in it) for the package in *package_dir*."""
    cache = os.environ.get("NUMBA_CACHE_DIR", "")
    folder = Path(cache) if cache else package_dir / "__pycache__"
    return folder / (name + EXTENSION_SUFFIXES[0])


def load(path: Path, attr: str) -> Callable[..., Any] | None:
    """The function *attr* of the built module at *path*; None when there is none or it does not
    load (the caller's numba or Python path then)."""
    if not enabled() or not path.is_file():
        return None
    try:
        spec = importlib.util.spec_from_file_location(path.name.split(".")[0], path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return getattr(module, attr)  # type: ignore[no-any-return]
    except Exception:  # noqa: BLE001 - an unusable file: the caller's numba or Python path
        return None


def compile_releasing_gil(cc: Any) -> None:
    """``cc.compile()`` of a numba ``pycc.CC`` whose exported functions release the GIL while they
    run (their Python wrappers take the arguments, let other threads run during the call and take
    the GIL back for the result, as ``njit(nogil=True)``'s do). ``pycc`` has no option for it: its
    compilation flags are made with ``release_gil`` set, for this build only."""
    from numba.core.compiler import Flags
    from numba.pycc import compiler

    class ReleasingGil(Flags):  # type: ignore[misc]
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)
            self.release_gil = True

    plain = compiler.Flags
    compiler.Flags = ReleasingGil
    try:
        cc.compile()
    finally:
        compiler.Flags = plain


def build_once(path: Path, compile_into: Callable[[Path], None]) -> bool:
    """Build the module at *path* — ``compile_into(folder)`` writes it, named as *path*, into a
    temporary folder beside — unless it is there or failed before; whether it is there now."""
    failed = path.with_suffix(".failed")
    if path.is_file() or failed.is_file():
        return path.is_file()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=path.parent, prefix=".openshoe-aot-") as tmp, \
                warnings.catch_warnings():
            warnings.simplefilter("ignore")  # pycc's pending deprecation
            compile_into(Path(tmp))
            os.replace(Path(tmp) / path.name, path)  # whole, or not at all, for the processes beside
    except Exception as exc:  # noqa: BLE001 - no C compiler, no pycc …: the numba path stays
        try:
            failed.write_text(f"{type(exc).__name__}: {exc}\n")
        except OSError:
            pass
        return False
    return True
