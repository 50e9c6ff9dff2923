"""The batch session the benchmark (and the identity tests) run: a host on Bluetooth that
starts step-wise dead reckoning and acknowledges every packet at once.

The same session as :func:`firmware_sim.batch.run_replay` (``34 00 34`` at power-on, each
state packet acknowledged in the next loop, the sequence emptied when the source ends and
the queue drained), driven by :meth:`Module.advance` so the compiled path can run quiet
stretches in one call. With the pure path it is loop by loop, and gives run_replay's bytes.
"""

from __future__ import annotations

from dataclasses import dataclass

from firmware_sim.module import Module, ModuleConfig
from firmware_sim.sensors.base import SensorSource
from protocol.frames import StatePacket, build_packet_ack
from protocol.ids import Command
from protocol.stream import StreamDecoder

#: The host's first frame: STEPWISE_DEAD_RECKONING (0x34) with its checksum.
START_STEPWISE = bytes([Command.STEPWISE_DEAD_RECKONING, 0x00, Command.STEPWISE_DEAD_RECKONING])
#: Loop cycles allowed for the queue to drain after the source ended.
DRAIN_TICKS = 2000


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
    module = Module(ModuleConfig(rate_hz=rate, compiled=compiled), sensors=source)
    port = module.bt.port
    decoder = StreamDecoder()
    out = bytearray()
    packets = 0
    total = len(source)  # type: ignore[arg-type]
    port.host_write(START_STEPWISE)

    def host() -> int:
        nonlocal packets
        data = port.host_read()
        if not data:
            return 0
        out.extend(data)
        for frame in decoder.feed(data):
            if isinstance(frame, StatePacket):
                port.host_write(build_packet_ack(frame.number))
                packets += 1
        return len(data)

    clock = module.clock
    while clock.ticks < total:
        module.advance(total - clock.ticks)
        host()
        if module.sensors_exhausted:
            break
    module.sequence.empty()
    quiet = 0
    for _ in range(DRAIN_TICKS):
        module.step()
        if host() == 0 and port.rx_pending() == 0:
            quiet += 1
            if quiet > 2 and len(module.bt.queue) == 0:
                break
        else:
            quiet = 0
    fast = module._fast
    done = 0 if fast is None else fast.ticks_quiet + fast.ticks_single
    return SessionResult(bytes(out), clock.ticks, packets, module.compiled, done, module)
