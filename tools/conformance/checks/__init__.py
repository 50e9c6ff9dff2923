"""The conformance checks: one registry, each check written from protocol.md alone.

Every check starts from a quiet interface (:meth:`DeviceDriver.sync`: outputs
off, queue emptied, processing off, lossy), talks to the device, and either
returns a one-line verdict or raises :class:`CheckFailed`. It records the
exchanges that prove its verdict with :meth:`Context.proof`.

Timings are measured in the device's own loop cycles (the INTERRUPT_COUNTER
state it sends back), never with the host's clock, so a real module and an
emulator running faster than real time get the same verdicts. Wall-clock
deadlines only bound the waiting; checks that must wait state how long.

The checks of the group ``extensions`` look for the emulator's extensions of the protocol
(:mod:`protocol.extensions`, docs/protocol-extensions.md): present and right → PASS, present and
wrong → FAIL, absent → ABSENT, which is no failure (a real module has none of them).

The checks live in one module per part of the protocol, in the order they run: :mod:`.framing`,
:mod:`.commands` and :mod:`.transmission` (the group ``protocol``), then :mod:`.extensions`. Each
module lists its checks in its ``CHECKS``; this package registers the modules' lists, in that
order, in :data:`CHECKS`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from types import ModuleType

from protocol.commands import CommandSet
from protocol.ids import Command, StateId

from ..driver import CheckFailed, CheckSkipped, DeviceDriver, ExtensionAbsent, Received
from ..results import CheckResult, Proof, RunReport, Status

U32 = 1 << 32

@dataclass
class Context:
    """What a check gets: the driver and a place to put its proofs."""

    driver: DeviceDriver
    proofs: list[Proof] = field(default_factory=list)

    @property
    def cs(self) -> CommandSet:
        return self.driver.cs

    def proof(self, label: str, sent: bytes = b"", received: bytes = b"") -> None:
        self.proofs.append(Proof(label, bytes(sent), bytes(received)))

    def fail(self, message: str, sent: bytes = b"", received: bytes = b"") -> None:
        if sent or received:
            self.proof("evidence", sent, received)
        raise CheckFailed(message)

    # shared helpers -----------------------------------------------------------
    def mcu_id(self) -> bytes:
        sent, pkt = self.driver.pull(StateId.MCU_ID)
        self.proof("pull MCU_ID (0x04)", sent, pkt.raw)
        if len(pkt.frame.payload) != 15:
            self.fail(f"MCU_ID must be 15 bytes, got {len(pkt.frame.payload)}", sent, pkt.raw)
        return pkt.frame.payload


@dataclass(frozen=True)
class Check:
    """One conformance check: its name, what it shows, how long it takes, and the code."""

    name: str
    description: str
    duration: str
    fn: Callable[[Context], str | None]
    needs: tuple[Command, ...] = ()
    #: "protocol" (protocol.md) or "extensions" (the emulator's own: absent is no failure)
    group: str = "protocol"

    def applies_to(self, cs: CommandSet) -> bool:
        return all(cs.supports(m) for m in self.needs)


#: Every check, in the order they run.
CHECKS: dict[str, Check] = {}

#: Every check, in the order they run.
CHECKS: dict[str, Check] = {}


def check(name: str, description: str, duration: str = "< 1 s", needs: tuple[Command, ...] = (),
          group: str = "protocol") -> Callable[[Callable[[Context], str | None]], Check]:
    """Make a check function the :class:`Check` *name* (a module of checks lists it in its
    ``CHECKS``, which :func:`register` adds to the registry)."""

    def deco(fn: Callable[[Context], str | None]) -> Check:
        return Check(name, description, duration, fn, needs, group)

    return deco


def register(*modules: ModuleType) -> None:
    """Add the checks each module lists in its ``CHECKS`` to :data:`CHECKS`, module by module in
    that order; a name already taken, or a check a module defines but does not list, raises
    ValueError."""
    for module in modules:
        unlisted = [v.name for v in vars(module).values() if isinstance(v, Check) and v not in module.CHECKS]
        if unlisted:
            raise ValueError(f"{module.__name__} defines checks it does not list in CHECKS: {unlisted}")
        for chk in module.CHECKS:
            if chk.name in CHECKS:
                raise ValueError(f"duplicate check {chk.name}")
            CHECKS[chk.name] = chk


def counter(r: Received, offset: int = 0) -> int:
    """The 32-bit counter at *offset* of a packet's payload."""
    return int.from_bytes(r.frame.payload[offset:offset + 4], "big")


def diffs(values: list[int], modulo: int = U32) -> list[int]:
    """Differences of consecutive values, modulo the counter's width."""
    return [(b - a) % modulo for a, b in zip(values[:-1], values[1:], strict=True)]


def packets(frames: list[Received]) -> list[Received]:
    """The state packets among *frames* (not the acks)."""
    return [r for r in frames if r.is_packet]


def raw(frames: list[Received], limit: int = 12) -> bytes:
    """The bytes of the first *limit* frames, for a proof."""
    return b"".join(r.raw for r in frames[:limit])


# =========================================================================== runner


def select(names: list[str] | None = None) -> list[Check]:
    """The checks to run, in registry order; unknown names raise ValueError listing the known ones."""
    if not names:
        return list(CHECKS.values())
    unknown = [n for n in names if n not in CHECKS]
    if unknown:
        raise ValueError(f"unknown check(s) {unknown}; known: {', '.join(CHECKS)}")
    return [c for c in CHECKS.values() if c.name in names]


def run_check(driver: DeviceDriver, chk: Check) -> CheckResult:
    """Run one check from a quiet interface; never raises (failures become results)."""
    ctx = Context(driver)
    t0 = time.monotonic()
    if not chk.applies_to(driver.cs):
        lacking = [m.name for m in chk.needs if not driver.cs.supports(m)]
        return CheckResult(chk.name, Status.SKIP,
                           f"the {driver.cs.name} numbering has no {', '.join(lacking)}")
    try:
        driver.sync()
        driver.mark()
        message = chk.fn(ctx) or ""
        status = Status.PASS
    except CheckSkipped as exc:
        status, message = Status.SKIP, str(exc)
    except ExtensionAbsent as exc:
        status, message = Status.ABSENT, str(exc)
    except CheckFailed as exc:
        status, message = Status.FAIL, str(exc)
    except Exception as exc:  # noqa: BLE001 - a broken link or a suite bug is reported, not raised
        status, message = Status.ERROR, f"{type(exc).__name__}: {exc}"
    return CheckResult(chk.name, status, message, ctx.proofs, time.monotonic() - t0)


def run(driver: DeviceDriver, names: list[str] | None = None, url: str = "",
        on_result: Callable[[CheckResult], None] | None = None) -> RunReport:
    """Run the selected checks in order; *on_result* is called after each."""
    report = RunReport(url, driver.cs.name)
    try:
        driver.sync()
        dead = ""
    except CheckFailed as exc:  # a device that never answers: say so once, do not wait per check
        dead = f"device does not answer: {exc}"
    for chk in select(names):
        if dead:
            result = CheckResult(chk.name, Status.FAIL, dead)
        else:
            result = run_check(driver, chk)
        report.results.append(result)
        if on_result is not None:
            on_result(result)
    if not dead:
        try:
            driver.sync()
        except Exception:  # noqa: BLE001 - leaving the device as quiet as we can
            pass
    return report


# =========================================================================== the checks, in order

from . import commands, extensions, framing, transmission  # noqa: E402 - they use the registry above
from .framing import RESYNC_DEADLINE_TICKS, closed_garbage  # noqa: E402, F401 - named by tests

register(framing, commands, transmission, extensions)
