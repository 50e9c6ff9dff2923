"""The compiled tracking sequence (firmware_sim.nav.fastpath, numba) sends the same bytes as the
pure-Python reference, and leaves the module in the same state.

The compiled tests skip with a reason when numba is not importable (it is the optional
``fast`` extra); the first run compiles the kernels (≈ 20 s, then cached on disk).
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from firmware_sim.app.batch import START_STEPWISE
from firmware_sim.links.faults import LinkFaults
from firmware_sim.links.link import make_link
from firmware_sim.mcu.module import Module, ModuleConfig
from firmware_sim.nav import fastpath
from firmware_sim.nav.firmware import build_module
from firmware_sim.sensors.imu_array import make_source
from firmware_sim.sensors.playback import served_source
from firmware_sim.sensors.replay import ReplaySource
from protocol.frames import StatePacket, build_command, build_packet_ack
from protocol.ids import Command, StateId
from protocol.states import STATES
from protocol.stream import StreamDecoder
from tests.conftest import WALK_IDS, walk_path
from tests.e2e.test_wire_golden import WALK_SHA256
from tests.nav.helpers import run_session, run_stepwise_host

REPO = Path(__file__).resolve().parents[2]

needs_numba = pytest.mark.skipif(
    not fastpath.available(),
    reason=f"compiled path unavailable: {fastpath.reason_unavailable()} (fast extra: pip install '.[fast]')",
)


def _state_bytes(module: Module) -> dict[int, bytes]:
    return {sid: module.memory.read_wire(sid) for sid in STATES}


def _assert_same_module(a: Module, b: Module) -> None:
    ca, cb = a.clock, b.clock
    assert (ca.ticks, ca.now_cycles, ca.interrupts, ca.overruns, ca.last_loop_cycles) == (
        cb.ticks, cb.now_cycles, cb.interrupts, cb.overruns, cb.last_loop_cycles)
    sa, sb = _state_bytes(a), _state_bytes(b)
    differ = [f"0x{sid:02X}" for sid in STATES if sa[sid] != sb[sid]]
    assert not differ, f"states differ: {differ}"
    assert a.counters() == b.counters()
    assert a.sequence.runs == b.sequence.runs


@needs_numba
def test_synthetic_walk_same_wire_bytes_and_state() -> None:
    """A simulated walk with turns: identical Bluetooth bytes, clock, states and counters."""
    source = make_source("stand:2+walk:4+turn:90+walk:3", seed=3)
    pure = run_session(source, compiled=False)
    fast = run_session(source, compiled=True)
    assert pure.packets >= 5  # steps were sent
    assert fast.wire == pure.wire
    _assert_same_module(fast.module, pure.module)
    # the compiled loop did the work (all but the alignment and the drain)
    assert fast.ticks_compiled > 0.8 * fast.ticks


@needs_numba
def test_loop_by_loop_on_a_bluetooth_link_matches() -> None:
    """Module.step with the compiled sequence (a real link model: never a quiet stretch)."""
    source = make_source("stand:2+walk:2", seed=7)
    mods = [build_module(ModuleConfig(compiled=c), sensors=source, bt_port=make_link("bt", seed=1))
            for c in (False, True)]
    out = [bytearray(), bytearray()]
    for m in mods:
        m.bt.port.host_write(START_STEPWISE)
    for tick in range(len(source)):
        for m, buf in zip(mods, out, strict=True):
            m.step()
            buf += m.bt.port.host_read()
        if tick % 500 == 0:
            _assert_same_module(*mods)
    assert mods[1]._fast is not None and mods[1]._fast.ticks_single > 1000
    assert out[0] == out[1] and len(out[0]) > 4
    _assert_same_module(*mods)


def _acking_host(module: Module, decoder: StreamDecoder, wire: bytearray,
                 arrivals: list[tuple[int, int]] | None = None) -> None:
    """A host that reads the module's Bluetooth link and acknowledges every state packet at once
    (*arrivals*: the loop after which each piece arrived, and its length)."""
    data = module.bt.port.host_read()
    wire += data
    if data and arrivals is not None:
        arrivals.append((module.clock.ticks, len(data)))
    for frame in decoder.feed(data):
        if isinstance(frame, StatePacket):
            module.bt.port.host_write(build_packet_ack(frame.number))


@needs_numba
@pytest.mark.parametrize("link", ["bt", "usb", "ideal", "bt-faults"])
def test_quiet_stretches_on_a_link_model_match_loop_by_loop(link: str) -> None:
    """Module.advance on a link model with an acking host (a served module: scenario played from
    the first read, then its last sample held) sends the bytes of the pure loop-by-loop run.
    Quiet stretches run compiled in one call, also while bytes are in flight (the link then
    moves tick by tick after them); they stop before the loop in which bytes reach the µC or
    the host, before a resend, and short of each seeded disconnect or reconnect."""
    faults = LinkFaults.both(stall_rate_hz=0.5, disconnect_rate_hz=0.2, reconnect_s=(0.2, 0.5)) \
        if link == "bt-faults" else None
    profile = link.split("-")[0]
    source = make_source("stand:2+walk:3", seed=4)
    ticks = len(source) + 1500  # on past the end of the scenario (held still)
    mods, wires, timing = [], [], []
    for compiled in (False, True):
        m = build_module(ModuleConfig(compiled=compiled), sensors=served_source(source),
                   bt_port=make_link(profile, seed=2, faults=faults))
        m.step()  # the module runs before the host starts the mode
        m.bt.port.host_write(START_STEPWISE)
        dec, wire, arrivals = StreamDecoder(), bytearray(), []
        while m.clock.ticks < ticks:
            if compiled:
                m.advance(ticks - m.clock.ticks)
            else:
                m.step()
            _acking_host(m, dec, wire, arrivals)
        mods.append(m)
        wires.append(bytes(wire))
        timing.append(arrivals)
    assert wires[0] == wires[1] and wires[0].count(b"\xaa") >= 5
    assert timing[0] == timing[1], "every piece reached the host after the same loop"
    _assert_same_module(*mods)
    assert mods[1].bt.port.stats() == mods[0].bt.port.stats()
    fast = mods[1]._fast
    # (with faults, packets wait in the queue through each disconnect: fewer quiet loops)
    print("QUIET", link, fast.ticks_quiet / ticks, fast.ticks_single / ticks)
    assert fast is not None and fast.ticks_quiet > (0.2 if faults else 0.5) * ticks


@needs_numba
def test_host_thresholds_and_custom_functions_respected() -> None:
    """Thresholds written by the host reach the kernel; a re-registered function id turns it off."""
    from firmware_sim.mcu.sequence import processing_function
    from firmware_sim.nav.firmware import OPENSHOE

    source = make_source("stand:2+walk:2", seed=2)
    cfg = {"initial_states": {0x19: 3000, 0x1A: 8}}
    results = []
    for c in (False, True):
        m = build_module(ModuleConfig(compiled=c, **cfg), sensors=source)
        m.bt.port.host_write(START_STEPWISE)
        m.run(len(source))
        results.append(m)
    _assert_same_module(*results)
    assert fastpath.FastNav.sequence_matches(results[1])
    no_zupt = processing_function(0x22, cycles=OPENSHOE.functions[0x22].cycles)(lambda module: None)
    other = build_module(ModuleConfig(compiled=True), sensors=source,
                         firmware=OPENSHOE.with_functions(no_zupt))
    other.bt.port.host_write(START_STEPWISE)
    other.run(len(source))
    assert not fastpath.FastNav.sequence_matches(other)


@pytest.fixture
def compiled_path(monkeypatch: pytest.MonkeyPatch) -> str:
    """The compiled path: its kernels compiled with numba, else the same kernels as plain Python."""
    if fastpath.available():
        return "compiled"
    monkeypatch.setattr(fastpath, "available", lambda: True)
    return "plain Python"


START_FULL_RATE_INS = build_command(Command.RESET_ZUPT_AIDED_INS)


def test_full_rate_ins_mode_runs_compiled_with_the_same_states(compiled_path: str) -> None:
    """ZUPT-aided INS (0x33) on a simulated walk: the alignment, then the full-rate INS in quiet
    stretches of the compiled path — the same states, clock and bytes (the command's ack) as the
    processing functions give loop by loop."""
    source = make_source("stand:2+walk:3", seed=6)
    mods = [build_module(ModuleConfig(compiled=c), sensors=source) for c in (False, True)]
    for m in mods:
        m.usb.port.host_write(START_FULL_RATE_INS)
    while mods[0].clock.ticks < len(source):
        mods[0].step()
    while mods[1].clock.ticks < len(source):
        mods[1].advance(len(source) - mods[1].clock.ticks)
    _assert_same_module(*mods)
    assert mods[0].usb.port.host_read() == mods[1].usb.port.host_read() != b""
    assert fastpath.FastNav.kind(mods[1]) == fastpath.FULL_RATE_INS
    assert np.linalg.norm(mods[1].memory[StateId.POSITION]) > 0.5, "the foot walked"
    assert mods[1]._fast.ticks_quiet > 0.8 * len(source), compiled_path


def test_full_rate_ins_with_outputs_on_a_bluetooth_link_matches_loop_by_loop(compiled_path: str) -> None:
    """0x33 with position, velocity and attitude sent every 8th loop over a Bluetooth link model:
    the compiled sequence loop by loop sends the reference's bytes."""
    source = make_source("stand:2+walk:2", seed=8)
    navigation = [StateId.POSITION, StateId.VELOCITY, StateId.QUATERNION, 0, 0, 0, 0, 0]
    outputs = build_command(Command.OUTPUT_MULTIPLE_STATES, state_ids=navigation, mode=4)
    mods = [build_module(ModuleConfig(compiled=c), sensors=source, bt_port=make_link("bt", seed=3))
            for c in (False, True)]
    wires = [bytearray(), bytearray()]
    for m in mods:
        m.bt.port.host_write(START_FULL_RATE_INS + outputs)
    for _ in range(len(source)):
        for m, wire in zip(mods, wires, strict=True):
            m.step()
            wire += m.bt.port.host_read()
    assert wires[0] == wires[1] and wires[0].count(b"\xaa") > 100
    _assert_same_module(*mods)
    assert mods[1]._fast.ticks_single > 0.9 * len(source), compiled_path


def test_an_alignment_restored_on_another_flag_runs_as_the_reference(compiled_path: str) -> None:
    """The host points RESTORE_PROC_SEQU_IF at ZUPT (0x36) after starting 0x33: the tracking
    sequence comes in at the first stationary sample, not at the end of the alignment — in
    quiet stretches too."""
    source = make_source("stand:2+walk:2", seed=9)
    restore_on_zupt = build_command(Command.RESET_PROC_SETUP, flag_id=StateId.ZUPT)
    level = {StateId.QUATERNION: [0, 0, 0, 1]}  # (the INS starts without an attitude of its own)
    mods = [build_module(ModuleConfig(compiled=c, initial_states=level), sensors=source)
            for c in (False, True)]
    for m in mods:
        m.usb.port.host_write(START_FULL_RATE_INS + restore_on_zupt)
    while mods[0].clock.ticks < len(source):
        mods[0].step()
    while mods[1].clock.ticks < len(source):
        mods[1].advance(len(source) - mods[1].clock.ticks)
    _assert_same_module(*mods)
    assert not mods[1].memory.flag(StateId.INIT_DONE), "tracking began before the alignment was done"
    assert np.isfinite(mods[1].memory[StateId.QUATERNION]).all()
    assert mods[1]._fast.ticks_quiet > 0.5 * len(source), compiled_path


#: A host's step output that also carries the position, the slope and the swing time: the states
#: HEIGHT_COMPENSATION writes, read at the step's packet (the flag and mode 0x34 sets up).
SLOPE_STEP_OUTPUT = build_command(Command.STATE_IF_SETUP, flag_id=StateId.FILTER_RESET_FLAG, mode=0x20,
                                  state_ids=[StateId.DX, StateId.DP, StateId.STEP_COUNTER, StateId.POSITION,
                                             StateId.THETA_GROUND, StateId.SWING_TIME, 0, 0])


def test_height_compensation_on_a_slope_same_wire_bytes_and_state(compiled_path: str) -> None:
    """Tracking with HEIGHT_COMPENSATION in slot 10 (turned on after the first step packet) on a walk up a
    6° slope, the step packets also carrying POSITION, THETA_GROUND and SWING_TIME: the compiled path in
    quiet stretches — each ending with a step, whose output runs before the loop's HEIGHT_COMPENSATION —
    sends the reference's bytes and leaves the same states, clock and counters."""
    source = make_source("stand:3+walk:20:6+stand:2", seed=1)
    runs = [run_stepwise_host(source, compiled=c, height=True, setup=SLOPE_STEP_OUTPUT)
            for c in (False, True)]
    assert runs[0].wire == runs[1].wire
    _assert_same_module(runs[0].module, runs[1].module)
    assert runs[1].slots == fastpath.TRACKING_HEIGHT_SLOTS
    # (plus the states the set-up's checksum bytes name: protocol.md §9)
    assert len(runs[1].packets) >= 15 and min(len(p.payload) for p in runs[1].packets) >= 58 + 12 + 8 + 4
    slope = runs[1].module.memory[StateId.THETA_GROUND][0]
    assert abs(np.degrees(slope) - 6) < 1, "the slope was learnt"
    assert runs[1].module._fast.ticks_quiet > 0.8 * len(source), compiled_path


def test_height_compensation_loop_by_loop_on_a_bluetooth_link_matches(compiled_path: str) -> None:
    """The same loop by loop over a Bluetooth link model (the loops in which a step ends run one at a
    time: the output, then HEIGHT_COMPENSATION)."""
    source = make_source("stand:3+walk:8:6+stand:1", seed=2)
    runs = [run_stepwise_host(source, compiled=c, height=True, setup=SLOPE_STEP_OUTPUT, loop_by_loop=True,
                              bt_port=make_link("bt", seed=4)) for c in (False, True)]
    assert runs[0].wire == runs[1].wire and len(runs[0].packets) >= 6
    _assert_same_module(runs[0].module, runs[1].module)
    assert runs[1].module._fast.ticks_single > 0.9 * len(source), compiled_path


def test_pure_path_selected_by_environment() -> None:
    """OPENSHOE_PURE=1 selects the reference even when numba is installed."""
    code = ("from firmware_sim.nav import fastpath; from firmware_sim.nav.firmware import build_module; "
            "print(fastpath.available(), build_module().compiled)")
    env = {**os.environ, "OPENSHOE_PURE": "1", "PYTHONPATH": str(REPO)}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         cwd=REPO, timeout=120, check=True).stdout.split()
    assert out == ["False", "False"]


def test_compiled_request_without_numba_is_a_clear_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(fastpath, "_disabled", "numba is not installed")
    with pytest.raises(ImportError, match="fast"):
        build_module(ModuleConfig(compiled=True))
    assert build_module(ModuleConfig(compiled=None)).compiled is False


@pytest.mark.slow
@pytest.mark.parametrize("walk_id", WALK_IDS)
def test_six_walks_same_wire_bytes(walks_dir: Path, walk_id: str) -> None:
    """The six OpenShoe recordings (250 Hz): the pure-Python reference sends the bytes pinned in
    tests/e2e/test_wire_golden.py (there the compiled path's are checked), and the compiled path
    the same bytes with the same final state."""
    source = ReplaySource.from_file(walk_path(walk_id))
    pure = run_session(source, compiled=False)
    assert pure.packets > 10
    assert hashlib.sha256(pure.wire).hexdigest() == WALK_SHA256[walk_id]
    if not fastpath.available():
        pytest.skip(f"the pure path's bytes are checked; compiled path unavailable: "
                    f"{fastpath.reason_unavailable()}")
    fast = run_session(source, compiled=True)
    assert fast.wire == pure.wire
    _assert_same_module(fast.module, pure.module)
    assert np.isfinite(np.frombuffer(fast.module.memory.read_wire(0x23), dtype=">f4")).all()
