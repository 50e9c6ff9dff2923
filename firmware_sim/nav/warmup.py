"""Getting the compiled tracking path ready before a module's clock starts.

With numba the INS sequences run compiled (:mod:`firmware_sim.nav.fastpath`).
numba compiles a kernel on its first call, or loads it from its on-disk cache
(``__pycache__`` beside the source, or ``NUMBA_CACHE_DIR``): about 20 s the first
time on a 2-core machine, well under a second after that. Whatever drives a
module's clock against a host — the real-time pacer, the ``openshoe://`` URL
handler in virtual time, a batch replay, ``serve`` before its READY line, the
demo, the benchmarks — calls
:func:`prepare_module` first, so no host ever waits on a compile for a command
ack.

Preparing finds the compiled loop built ahead of time (:mod:`firmware_sim.nav.aot`:
ready at once, no numba); else it loads numba's loop
(:func:`firmware_sim.nav.driver.run_loops`, every kernel compiled into it) for
the argument types every module calls it with, those of a scratch module's
records, without running a loop (from the cache that is numba's runtime and one
library, no typing), and then builds the loop ahead of time: the modules this process starts
after that run it, and so do the next processes. It happens once per process. While it takes
longer than a moment, *announce* is told why the first start is slower. If the compiled path
cannot be had (numba missing, or a compile that fails), modules fall back to the pure-Python
reference — the same bytes, slower — and *announce* is told that too, once. The numeric slots of
any other sequence (:mod:`firmware_sim.nav.slot_loop`) are prepared and built alike.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from firmware_sim.mcu.module import Module, ModuleConfig
from firmware_sim.nav.firmware import build_module

from . import aot, fastpath, slot_loop

__all__ = ["FIRST_RUN_NOTICE", "CompiledPath", "prepare_compiled_path", "prepare_module", "to_stderr"]

#: What a user reads while the kernels compile.
FIRST_RUN_NOTICE = "preparing the compiled tracking path (first run only, about 20 s) …"
#: A preparation that takes longer than this [s] is announced while it runs (a cache load takes less).
ANNOUNCE_AFTER_S = 0.5

Announce = Callable[[str], None]


def to_stderr(text: str) -> None:
    """The default *announce*: one line on stderr."""
    print(text, file=sys.stderr, flush=True)


@dataclass(frozen=True)
class CompiledPath:
    """What preparing found: whether modules run compiled, how long it took, and why not."""

    compiled: bool
    seconds: float = 0.0
    reason: str = ""  #: why the pure path is used ("" when compiled)

    def describe(self) -> str:
        if self.compiled:
            return f"compiled tracking path ready ({self.seconds:.1f} s)"
        return (f"compiled tracking path unavailable ({self.reason}); running the pure-Python "
                "reference: the same bytes, slower")


_lock = threading.Lock()
_prepared: CompiledPath | None = None
_fallback_said = False


def _warm_up() -> None:
    fastpath.FastNav(build_module(ModuleConfig(compiled=True))).load()
    slot_loop.load()  # the numeric slots of any other sequence (firmware_sim.nav.any_sequence)
    aot.build()  # for the modules started next and the next processes (nothing when built)
    slot_loop.build()


def prepare_compiled_path(announce: Announce | None = to_stderr,
                          warm_up: Callable[[], None] = _warm_up) -> CompiledPath:
    """Compile or load the tracking kernels once per process; returns what was found.

    Thread-safe and idempotent: later calls return the first result at once.
    *warm_up* exercises the kernels (tests replace it to simulate a failing compile).
    """
    global _prepared
    with _lock:
        if _prepared is not None:
            return _prepared
        if not fastpath.available():
            _prepared = CompiledPath(False, reason=fastpath.reason_unavailable())
            return _prepared
        announced = threading.Event()

        def notice() -> None:
            announced.set()
            if announce is not None:
                announce(FIRST_RUN_NOTICE)

        slow = threading.Timer(ANNOUNCE_AFTER_S, notice)
        slow.daemon = True
        t0 = time.monotonic()
        slow.start()
        try:
            warm_up()
        except Exception as exc:  # noqa: BLE001 - any compile failure: fall back to the reference
            fastpath.disable(f"the compile failed: {type(exc).__name__}: {exc}")
            _prepared = CompiledPath(False, time.monotonic() - t0, fastpath.reason_unavailable())
        else:
            _prepared = CompiledPath(True, time.monotonic() - t0)
        finally:
            slow.cancel()
        if announce is not None and announced.is_set() and _prepared.compiled:
            announce(_prepared.describe())
        return _prepared


def prepare_module(module: Module, announce: Announce | None = to_stderr) -> CompiledPath | None:
    """Make *module* ready to run with no compile ahead of it; call before its clock starts.

    A module set to run compiled gets the kernels prepared (and falls back to
    the pure path if they cannot be had). A module that runs pure only because
    numba is missing says so once per process. Returns the preparation's
    result, or None for a module that runs pure by request.
    """
    global _fallback_said
    wants_compiled = module.compiled or (module.config.compiled is None and not fastpath.pure_requested())
    if not wants_compiled:
        return None
    found = prepare_compiled_path(announce)
    if not found.compiled:
        module.use_pure_path()
        with _lock:
            say, _fallback_said = not _fallback_said, True
        if say and announce is not None:
            announce(found.describe())
    return found


def _reset_for_tests() -> None:
    """Forget the preparation (tests of the announcements and the fallback)."""
    global _prepared, _fallback_said
    with _lock:
        _prepared = None
        _fallback_said = False
