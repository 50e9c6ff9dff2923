"""What a conformance run produces: one result per check, with the bytes that prove it."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

from protocol.frames import hexdump


class Status(str, Enum):
    """Outcome of one check."""

    PASS = "PASS"
    FAIL = "FAIL"
    SKIP = "SKIP"  #: not applicable (e.g. a command the chosen numbering lacks)
    #: an emulator extension the device does not have (a real module has none): not a failure
    ABSENT = "ABSENT"
    ERROR = "ERROR"  #: the check itself broke (link closed, bug); counts as a failure


@dataclass(frozen=True)
class Proof:
    """One exchange with the device: what was sent, what came back, what it shows."""

    label: str
    sent: bytes = b""
    received: bytes = b""

    def lines(self, limit: int = 96) -> list[str]:
        out = [f"  {self.label}"]
        if self.sent:
            out.append(f"    sent     {hexdump(self.sent, limit)}")
        if self.received or self.sent:
            out.append(f"    received {hexdump(self.received, limit) if self.received else '(nothing)'}")
        return out

    def __repr__(self) -> str:
        return (f"Proof({self.label!r}, sent={hexdump(self.sent, 16)!r}, "
                f"received={hexdump(self.received, 16)!r})")


@dataclass
class CheckResult:
    """The verdict of one check, its explanation and its evidence."""

    name: str
    status: Status
    message: str = ""
    proofs: list[Proof] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def failed(self) -> bool:
        return self.status in (Status.FAIL, Status.ERROR)

    def render(self, verbose: bool = True) -> str:
        head = f"{self.status.value:5} {self.name}"
        if self.message:
            head += f" — {self.message}"
        head += f"  [{self.seconds:.2f} s]"
        lines = [head]
        if verbose or self.failed:
            for p in self.proofs:
                lines.extend(p.lines())
        return "\n".join(lines)


@dataclass
class RunReport:
    """All results of one run against one device."""

    url: str
    command_set: str
    results: list[CheckResult] = field(default_factory=list)

    @property
    def failed(self) -> list[CheckResult]:
        return [r for r in self.results if r.failed]

    @property
    def ok(self) -> bool:
        return not self.failed

    def summary(self) -> str:
        counts = {s: sum(r.status is s for r in self.results) for s in Status}
        parts = ", ".join(f"{counts[s]} {s.value.lower()}" for s in Status if counts[s])
        verdict = "CONFORMS" if self.ok else "DOES NOT CONFORM"
        return f"{verdict}: {self.url} (command set {self.command_set}): {parts}"
