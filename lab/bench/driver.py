"""The batch session the benchmark (and the identity tests) run: a host on Bluetooth that
starts step-wise dead reckoning and acknowledges every packet at once.

It is :func:`firmware_sim.app.batch.run_replay` (``34 00 34`` at power-on, each state packet
acknowledged in the next loop, the sequence emptied when the source ends and the queue
drained) with the path chosen explicitly, plus how many loops ran compiled.
"""

from __future__ import annotations

from dataclasses import dataclass

from firmware_sim.app.batch import START_STEPWISE, run_replay
from firmware_sim.mcu.imu_bus import SensorSource
from firmware_sim.mcu.module import Module, ModuleConfig

__all__ = ["START_STEPWISE", "SessionResult", "run_session"]


@dataclass
class SessionResult:
    """The bytes the module sent on Bluetooth and the run's counters."""

    wire: bytes
    ticks: int
    packets: int
    compiled: bool
    ticks_compiled: int = 0
    module: Module | None = None

    def __repr__(self) -> str:
        return (f"SessionResult({len(self.wire)} B, {self.ticks} loops, {self.packets} packets, "
                f"compiled={self.compiled}, wire[:8]={self.wire[:8].hex(' ').upper()})")


def run_session(source: SensorSource, *, compiled: bool | None,
                rate_hz: float | None = None) -> SessionResult:
    """Run *source* through one module as a lossless Bluetooth host; returns what it sent."""
    rate = float(source.rate_hz if rate_hz is None else rate_hz)
    replay = run_replay(source, config=ModuleConfig(rate_hz=rate, compiled=compiled))
    module = replay.module
    fast = module._fast
    done = 0 if fast is None else fast.ticks_quiet + fast.ticks_single
    return SessionResult(bytes(replay), module.clock.ticks, replay.packets, module.compiled, done, module)
