"""Shared helpers of the navigation tests: run the module on a source, sum the steps from the wire, drive
it as a host that turns HEIGHT_COMPENSATION on."""

from __future__ import annotations

import dataclasses

import numpy as np

from firmware_sim.app.batch import run_replay
from firmware_sim.mcu.module import Module, ModuleConfig
from firmware_sim.nav.firmware import build_module
from hostlib.track.steps import StepTracker
from protocol.codec import decode_step
from protocol.extensions import height_compensation_on
from protocol.frames import CommandAck, StatePacket, build_command, build_packet_ack
from protocol.ids import Command
from protocol.stream import StreamDecoder, decode_all


def reference_config(rate_hz: float, compiled: bool | None = False) -> ModuleConfig:
    """A module config running the pure-Python processing functions (the reference path); with
    *compiled* None the path the process has (compiled when numba is there: the same bytes)."""
    config = ModuleConfig(rate_hz=rate_hz)
    if any(f.name == "compiled" for f in dataclasses.fields(ModuleConfig)):
        config = dataclasses.replace(config, compiled=compiled)
    return config


@dataclasses.dataclass
class Session:
    """What a lossless Bluetooth host's batch session (:func:`run_session`) leaves: the bytes the
    module sent, the state packets, the module, and how many loops ran compiled."""

    wire: bytes
    packets: int
    module: Module
    ticks_compiled: int

    @property
    def ticks(self) -> int:
        return self.module.clock.ticks


def run_session(source, *, compiled: bool | None) -> Session:
    """:func:`firmware_sim.app.batch.run_replay` of *source* (``34 00 34`` at power-on, each state
    packet acknowledged in the next loop, the sequence emptied when the source ends and the queue
    drained) on the path asked for: the compiled one, the pure-Python reference, or (None) the one
    the process has."""
    replay = run_replay(source, config=ModuleConfig(rate_hz=float(source.rate_hz), compiled=compiled),
                        announce=None)
    fast = replay.module._fast
    done = 0 if fast is None else fast.ticks_quiet + fast.ticks_single
    return Session(bytes(replay), replay.packets, replay.module, done)


def steps_from_wire(data: bytes) -> tuple[list[CommandAck], StepTracker]:
    """Decode the module's Bluetooth bytes and sum the step packets as a host would."""
    tracker = StepTracker()
    acks = []
    for frame in decode_all(bytes(data)):
        if isinstance(frame, StatePacket):
            tracker.add(decode_step(frame.payload))
        else:
            acks.append(frame)
    return acks, tracker


def replay_track(source, rate_hz: float | None = None,
                 compiled: bool | None = False) -> tuple[bytes, StepTracker]:
    """Replay *source* as a lossless host (:func:`run_replay`) on the reference path (*compiled*:
    :func:`reference_config`) and sum the steps from the wire."""
    data = run_replay(source, config=reference_config(rate_hz or float(source.rate_hz), compiled),
                      announce=None)
    return data, steps_from_wire(data)[1]


def closure_percent(tracker: StepTracker) -> float:
    """Horizontal closure error as % of the distance walked (sum of horizontal step lengths)."""
    return float(np.hypot(*tracker.position[:2])) / tracker.distance * 100.0


@dataclasses.dataclass
class HostRun:
    """What :func:`run_stepwise_host` leaves: the Bluetooth bytes, the module, the state packets in
    order, and the running slots when the source ended."""

    wire: bytes
    module: Module
    packets: list[StatePacket]
    slots: list[int]

    def height_change(self) -> float:
        """The summed dz [m] of the step packets (z down: negative is up)."""
        return float(sum(float(decode_step(p.payload).dx[2]) for p in self.packets))


def run_stepwise_host(source, *, compiled: bool | None, height: bool, setup: bytes = b"",
                      after_first_step: bytes = b"", bt_port=None, loop_by_loop: bool = False) -> HostRun:
    """A lossless Bluetooth host on *source*: sends 0x34 (and *setup*, e.g. a STATE_IF_SETUP) at power-on,
    acknowledges every state packet at once and, with *height*, turns HEIGHT_COMPENSATION on when the first
    step packet arrives (tracking then runs: :func:`protocol.extensions.height_compensation_on`), followed
    by *after_first_step* (more commands). The
    module runs in quiet stretches where it can (Module.advance), or *loop_by_loop*; when the source ends
    the sequence is emptied and the queue drains, as in a batch replay. *bt_port*: the Bluetooth port (a
    link model; default ideal)."""
    module = build_module(ModuleConfig(rate_hz=float(source.rate_hz), compiled=compiled), sensors=source,
                          bt_port=bt_port)
    port = module.bt.port
    port.host_write(build_command(Command.STEPWISE_DEAD_RECKONING) + setup)
    decoder, wire, packets = StreamDecoder(), bytearray(), []
    first_step = True

    def serve() -> int:
        nonlocal first_step
        data = port.host_read()
        wire.extend(data)
        for frame in decoder.feed(data):
            if isinstance(frame, StatePacket):
                port.host_write(build_packet_ack(frame.number))
                packets.append(frame)
                if first_step:
                    meaning, fields = height_compensation_on()
                    port.host_write((build_command(meaning, **fields) if height else b"") + after_first_step)
                    first_step = False
        return len(data)

    total = len(source)
    while module.clock.ticks < total:
        if loop_by_loop:
            module.step()
        else:
            module.advance(total - module.clock.ticks)
        serve()
    slots = list(module.sequence.slots)
    module.sequence.empty()
    for _ in range(2000):
        module.step()
        if serve() == 0 and port.rx_pending() == 0 and len(module.bt.queue) == 0:
            break
    return HostRun(bytes(wire), module, packets, slots)


def truth_height_change(source) -> float:
    """The foot's true height change [m] over a simulated walk (z down: negative is up)."""
    z = source.truth.pos[:, 2]
    return float(z[-1] - z[0])
