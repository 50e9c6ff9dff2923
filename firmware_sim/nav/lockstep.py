"""Lockstep: K modules stepped together, their quiet stretches in one compiled call.

:meth:`Lockstep.advance` is :meth:`Module.advance <firmware_sim.mcu.module.Module.advance>` of each of
K modules — the same loops, the same bytes and states as each module advanced alone — with the
quiet stretches of all of them (:meth:`~firmware_sim.nav.fastpath.FastNav.quiet_ticks`) run by one
call of the compiled loop of K modules (:func:`~firmware_sim.nav.driver.run_group`), which runs each
module's loops one module after the other on its own records, reached by their addresses. The
Python before and after a stretch (which loops are quiet, the clock's and the ports' booking, the
packet of a step's end) stays per module, as does every loop that is not quiet (a command received,
an ack, the drain): a module's arithmetic is not touched, so its bytes cannot change.

Where the time goes (measured on the six shared walks replayed one after the other, the loop built
ahead of time, 2 cores shared): about two thirds in the compiled loop, a third in the Python around
a step's end (the packet, the host's ack and the loop that receives it); a call of the compiled
loop costs about a microsecond, some 700 calls for the six walks. So paying the call once per K
modules saves little in a batch; what it gives is one call per group of modules that a caller steps
together (a batch of walks, a sweep's runs, a process's served modules).

On a machine of more than one core, with the compiled loop that releases the GIL (numba's, and the
one built ahead of time in a batch of many replays: :func:`firmware_sim.nav.aot.share_cores`), a
helper thread runs the later
modules' stretches of a call while the caller runs the earlier ones (split at half the loops): the
modules share nothing in the loop, so the bytes stay the same; the wall time of the compiled part
nearly halves, the Python around it does not.

Not vectorised across modules: a SIMD lane per module would do each module's float32 operations
in the reference's order (the bytes could stay), but it needs the states laid out module by
module in each field and every branch (ZUPT, a step's end, the detector's ring buffers) taken by
all lanes alike; the per-sample cost of the compiled loop itself (TIME_UPDATE's 9×9 products
about half of it) is what such a layout would attack, and it is left as it is here.

Modules that share state outside their own memory (a sensor source, a port) must not be stepped
together unless the order in which they run within one call does not matter to them.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import TYPE_CHECKING

import numpy as np

from protocol.ids import NR_IMUS

from . import fastpath

if TYPE_CHECKING:  # pragma: no cover
    from firmware_sim.mcu.module import Module

    from .fastpath import FastNav, QuietRun

__all__ = ["Lockstep"]

#: Bytes of one loop's registers (NR_IMUS × 6 int16), and the most a stretch copies on average into
#: the one block of a call (:meth:`Lockstep._register_addresses`).
_SAMPLE_BYTES = NR_IMUS * 6 * 2
_BLOCK_BYTES_PER_STRETCH = 16_384
#: The helper thread of every group in this process (made on first use; None: not wanted).
_helpers: list[ThreadPoolExecutor | None] = []
_helpers_lock = threading.Lock()


def _forget_helper() -> None:
    """In a process forked from this one: the parent's helper thread is not there (work handed to it
    would wait for ever), so the child makes its own when it needs one."""
    global _helpers_lock
    _helpers.clear()
    _helpers_lock = threading.Lock()


os.register_at_fork(after_in_child=_forget_helper)


def _helper() -> ThreadPoolExecutor | None:
    """The thread that runs part of a call beside its caller, on more than one core (one per process)."""
    with _helpers_lock:
        if not _helpers:
            many = (os.cpu_count() or 1) > 1
            _helpers.append(ThreadPoolExecutor(1, thread_name_prefix="openshoe-lockstep") if many else None)
        return _helpers[0]


class Lockstep:
    """K modules advanced together (see the module doc); each keeps being usable alone.

    *helper* False: never hand part of a call to the helper thread (a real-time loop: its frames
    must not wait on a thread that the machine's other processes can hold up)."""

    def __init__(self, modules: Sequence[Module], *, helper: bool = True):
        self.modules = list(modules)
        self._group = fastpath.group_loop()
        self._helper = _helper() if helper and fastpath.group_releases_gil() else None
        #: Rounds whose quiet stretches ran compiled (one call, or two halves side by side), and the
        #: module stretches they ran (figures for the benchmark).
        self.calls = 0
        self.stretches = 0

    def advance(self, max_ticks: int | Sequence[int]) -> list[int]:
        """Each module k runs between 1 and ``max_ticks[k]`` loops (a number: the same for all; 0 or
        less: none), as many as :meth:`Module.advance <firmware_sim.mcu.module.Module.advance>` runs;
        returns the loops each ran."""
        modules = self.modules
        limits = [max_ticks] * len(modules) if isinstance(max_ticks, int) else list(max_ticks)
        ran = [0] * len(modules)
        quiet: list[tuple[int, FastNav, QuietRun]] = []
        for k, (module, limit) in enumerate(zip(modules, limits, strict=True)):
            run = self._quiet_run(module, limit) if limit > 1 else None
            if run is not None:
                quiet.append((k, run[0], run[1]))
            elif limit >= 1:
                module.step()
                ran[k] = 1
        if quiet:
            done = self._run(quiet)
            for (k, fast, run), n in zip(quiet, done, strict=True):
                ran[k] = fast.finish_quiet(modules[k], run, n)
        return ran

    @staticmethod
    def _quiet_run(module: Module, limit: int) -> tuple[FastNav, QuietRun] | None:
        runner = module.compiled_runner()
        if not isinstance(runner, fastpath.FastNav):
            return None
        kind = fastpath.FastNav.kind(module)
        quiet = kind and runner.quiet_ticks(module, limit, kind)
        run = runner.quiet_run(module, quiet, kind) if quiet else None
        return None if run is None else (runner, run)

    @staticmethod
    def _register_addresses(runs: list[QuietRun], counts: np.ndarray
                            ) -> tuple[np.ndarray | list[int], np.ndarray | None]:
        """Where each stretch's registers are for the compiled call: short stretches (a served
        module's frame) copied one after the other into one block, whose address numpy gives once;
        long ones (a batch's round asks for up to 5000 loops, of which a step's some 250 run) where
        they are, numpy asked for each one's address (some 3 µs, the time to copy some 15 kB).
        Returns the addresses and the block (None: none), which must outlive the call."""
        if int(counts.sum()) * _SAMPLE_BYTES > _BLOCK_BYTES_PER_STRETCH * len(runs):
            return [run.imu.ctypes.data for run in runs], None
        block = np.concatenate([run.imu for run in runs])
        return block.ctypes.data + (counts.cumsum() - counts) * _SAMPLE_BYTES, block

    def _run(self, quiet: list[tuple[int, FastNav, QuietRun]]) -> list[int]:
        """The stretches' loops: one compiled call, or module by module without one; the loops run."""
        self.stretches += len(quiet)
        if self._group is None:
            return [fast.run_loops(run) for _, fast, run in quiet]
        n = len(quiet)
        runs = [run for _, _, run in quiet]
        kinds = np.array([run.kind for run in runs], dtype=np.int64)
        counts = np.array([len(run.imu) for run in runs], dtype=np.int64)
        clocks = np.array([(run.first, run.period, run.ts_offset) for run in runs], dtype=np.int64)
        addresses = np.array([(0, *fast.addresses) for _, fast, _ in quiet], dtype=np.int64)
        addresses[:, 0], block = self._register_addresses(runs, counts)  # (block: alive until the call ends)
        done = np.zeros(n, dtype=np.int64)
        half = int(np.searchsorted(np.cumsum(counts), counts.sum() / 2)) + 1 if self._helper else n
        later = None
        if half < n:
            later = self._helper.submit(self._group, kinds[half:], counts[half:], clocks[half:],  # type: ignore[union-attr]
                                        addresses[half:], done[half:])
        self._group(kinds[:half], counts[:half], clocks[:half], addresses[:half], done[:half])
        if later is not None:
            later.result()
        self.calls += 1
        return done.tolist()
