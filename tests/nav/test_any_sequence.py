"""Sequences the compiled loop does not know run their numeric slots compiled
(firmware_sim.nav.any_sequence): the same bytes, states, PS_DT and clock as the processing
functions run one by one — bit for bit but for the sign and payload of a NaN, which IEEE 754 leaves
open, as for the compiled loop (docs/protocol-extensions.md, "Numbers that go non-finite").

Skipped with a reason where the compiled slots cannot be had (no numba and none built ahead of time).
"""

from __future__ import annotations

import random
import re

import pytest

from firmware_sim.links.link import make_link
from firmware_sim.mcu.module import Module, ModuleConfig
from firmware_sim.nav import slot_loop
from firmware_sim.nav.any_sequence import SequenceRunner
from firmware_sim.nav.firmware import build_module
from firmware_sim.sensors.imu_array import make_source
from protocol.commands import CURRENT
from protocol.frames import StatePacket, build_command, checksum_bytes
from protocol.ids import PROC_ID_LIMIT, Command, ProcId
from protocol.states import STATES
from protocol.stream import StreamDecoder
from tests.nav.test_fastpath import _state_bytes
from tests.nav.test_nonfinite import _nan_as_one

needs_slots = pytest.mark.skipif(slot_loop.slots_runner() is None,
                                 reason="no compiled slots (numba or the module built ahead of time)")

P = ProcId


def _pair(recipe: str, seed: int, bluetooth: bool = False) -> list[Module]:
    """The pure module and the compiled one, each with its own copy of the walk (a host's DLPF
    setting changes a source)."""
    return [build_module(ModuleConfig(compiled=c), sensors=make_source(recipe, seed=seed),
                         bt_port=make_link("bt", seed=seed) if bluetooth else None) for c in (False, True)]


#: A big-endian float32 NaN in a packet's payload (exponent all ones, mantissa not 0: its quiet bit set).
_NAN = re.compile(rb"[\x7f\xff][\xc0-\xff]..", re.DOTALL)


def _frames(wire: bytes) -> list[tuple[int, bytes]]:
    """The frames of a module's bytes (packet number and payload; an ack's command id), every NaN in
    a payload written as 7FC00000."""
    out = []
    for frame in StreamDecoder().feed(wire):
        if isinstance(frame, StatePacket):
            out.append((frame.number, _NAN.sub(b"\x7f\xc0\x00\x00", bytes(frame.payload))))
        else:
            out.append((-1, bytes([frame.command_id])))
    return out


def _assert_alike(fast: Module, pure: Module, wires: list[bytes]) -> None:
    """The same frames (up to NaNs), clock, states (up to NaNs), counters and PS_DT."""
    assert len(wires[1]) == len(wires[0])
    assert _frames(wires[1]) == _frames(wires[0])
    ca, cb = fast.clock, pure.clock
    assert (ca.ticks, ca.now_cycles, ca.interrupts, ca.overruns, ca.last_loop_cycles) == (
        cb.ticks, cb.now_cycles, cb.interrupts, cb.overruns, cb.last_loop_cycles)
    assert _nan_as_one(fast) == _nan_as_one(pure)
    assert fast.counters() == pure.counters()
    assert fast.sequence.runs == pure.sequence.runs


def _runner(module: Module) -> SequenceRunner:
    fast = module.sequence.fast
    assert isinstance(fast, SequenceRunner)
    return fast


#: Float32 values a hostile host sets (big-endian): NaN, ±inf, the maximum, a subnormal, 0, 1.
_ODD_FLOATS = (b"\x7f\xc0\x00\x00", b"\x7f\x80\x00\x00", b"\xff\x80\x00\x00", b"\x7f\x7f\xff\xff",
               b"\x00\x00\x00\x07", bytes(4), b"\x3f\x80\x00\x00")
_SPECS = [CURRENT[i] for i in sorted(CURRENT)]
_FLOAT_STATES = sorted(sid for sid, spec in STATES.items() if spec.dtype.kind == "f" and spec.size <= 48)


def _hostile_command(rng: random.Random) -> bytes:
    """A random well-formed command: any command with random payload bytes, a sequence of random
    processing functions, or a float state set to odd numbers."""
    roll = rng.random()
    if roll < 0.3:
        return _mult(*(rng.randrange(PROC_ID_LIMIT) for _ in range(8)))
    if roll < 0.5:
        sid = rng.choice(_FLOAT_STATES)
        data = b"".join(rng.choice(_ODD_FLOATS) for _ in range(STATES[sid].size // 4))
        return build_command(Command.SET_STATE_48, state_id=sid, data=data)
    spec = rng.choice(_SPECS)
    body = bytes([spec.wire_id]) + rng.randbytes(spec.payload_len)
    return body + checksum_bytes(body)


def _run(mods: list[Module], ticks: int, commands: dict[int, bytes], port: str = "usb") -> list[bytes]:
    """Both modules loop by loop, *commands* written to both at their ticks; the host bytes of each."""
    out = [bytearray(), bytearray()]
    for t in range(ticks):
        for m, o in zip(mods, out, strict=True):
            p = getattr(m, port).port
            if t in commands:
                p.host_write(commands[t])
            m.step()
            o += p.host_read()
    return [bytes(o) for o in out]


def _mult(*ids: int) -> bytes:
    return build_command(Command.RUN_MULT_PROC, proc_ids=list(ids) + [0] * (8 - len(ids)))


@needs_slots
@pytest.mark.parametrize("sequence", [
    pytest.param(build_command(Command.MIMU_FRONTEND), id="front end (0x32)"),
    pytest.param(build_command(Command.NORMAL_IMU, mode=1), id="plain IMU mode"),
    pytest.param(_mult(P.READ_INERTIAL, P.FRONTEND_PREPROC, P.FRONTEND_STATDET, P.FRONTEND_BIASEST,
                       P.FRONTEND_CONVCOMP, P.FRONTEND_CONV16, P.MECHANIZATION, P.TIME_UPDATE),
                 id="front end, CONV16, then the INS unaligned (NaN)"),
    pytest.param(_mult(P.FRONTEND_STATDET, P.READ_INERTIAL, P.FRONTEND_PREPROC, P.ZUPT_UPDATE,
                       P.FRONTEND_CONVCOMP, P.STEPWISE_SYSTEM_RESET, P.STATE_OUTPUT_IF,
                       P.HEIGHT_COMPENSATION),
                 id="scrambled, with the step output between"),
    pytest.param(_mult(P.READ_INERTIAL, P.FRONTEND_PREPROC, P.FRONTEND_STATDET, P.FRONTEND_BIASEST,
                       P.FRONTEND_CONVCOMP, P.FRONTEND_INITIAL_ALIGNMENT, P.MECHANIZATION, P.TIME_UPDATE),
                 id="the INS after an alignment in the same loop"),
])
def test_a_sequence_outside_the_known_ones_runs_as_the_functions(sequence: bytes) -> None:
    """A host's sequence of its own (standing, then walking): the same bytes, states, PS_DT and clock,
    and its loops ran through the compiled slots."""
    mods = _pair("stand:2+walk:3", seed=4)
    output = build_command(Command.OUTPUT_STATE, state_id=0x23, mode=1)  # P every loop
    wires = _run(mods, 5000, {0: sequence, 1: output})
    assert len(wires[0]) > 10_000
    _assert_alike(mods[1], mods[0], wires)
    assert _runner(mods[1]).loops > 4000
    assert _runner(mods[0]).loops == 0  # the pure module ran the functions


@needs_slots
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_hostile_commands_leave_both_paths_alike(seed: int) -> None:
    """A hostile host's random well-formed commands (any sequence, any state set to anything, NaN
    and inf among them, DLPF settings) on a Bluetooth link, after tracking started: the same bytes
    and states on the compiled path as on the functions."""
    mods = _pair("stand:2+walk:6", seed=seed, bluetooth=True)
    rng = random.Random(seed)
    commands = {0: build_command(Command.STEPWISE_DEAD_RECKONING)}
    t = 2500  # after the alignment
    while t < 8000:
        commands[t] = b"".join(_hostile_command(rng) for _ in range(rng.randint(1, 3)))
        t += rng.randint(20, 200)
    wires = _run(mods, 8000, commands, port="bt")
    _assert_alike(mods[1], mods[0], wires)
    assert _runner(mods[1]).loops > 0


@needs_slots
def test_without_a_nan_the_bytes_are_the_same() -> None:
    """A plain IMU mode with the front end's output: the very same bytes and states."""
    mods = _pair("stand:2+walk:3", seed=5)
    output = build_command(Command.OUTPUT_STATE, state_id=0x13, mode=1)  # U_K every loop
    wires = _run(mods, 4000, {0: build_command(Command.MIMU_FRONTEND), 1: output})
    assert wires[1] == wires[0]
    assert _state_bytes(mods[1]) == _state_bytes(mods[0])
    assert _runner(mods[1]).loops > 3000
