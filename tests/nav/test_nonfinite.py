"""Numbers a host set that make the firmware's float32 arithmetic give inf or NaN.

The µC's FPU computes on (IEEE, no trap): so does the module, in the pure and the compiled
path alike, bit for bit, with no warning on the console, and it keeps answering. Every case
of docs/protocol-extensions.md ("Numbers that go non-finite") is sent here, in virtual time;
the states that went non-finite are the memory's own report (``nonfinite_states``), which the
real-time pacer's status shows.
"""

from __future__ import annotations

import struct
import warnings

import numpy as np
import pytest

from firmware_sim.app.control import ControlServer
from firmware_sim.app.served_module import ServedModule
from firmware_sim.mcu.imu_bus import still_board
from firmware_sim.mcu.module import Module, ModuleConfig
from firmware_sim.nav import fastpath
from firmware_sim.nav.firmware import build_module
from firmware_sim.transports.pacer import Pacer
from protocol.frames import StatePacket, build_command, build_packet_ack
from protocol.ids import Command, ProcId, StateId
from protocol.states import STATES, state_spec
from protocol.stream import StreamDecoder

P = ProcId
S = StateId
NAN = struct.pack(">f", float("nan"))
INF = struct.pack(">f", float("inf"))
FLOAT_MAX = struct.pack(">f", 3.4028235e38)
PING_ACK = bytes.fromhex("A0 03 00 A3")
NAVIGATION = {"POSITION", "VELOCITY", "QUATERNION", "P"}


def f32(*values: float) -> bytes:
    return b"".join(struct.pack(">f", v) for v in values)


def set_state(sid: int, data: bytes) -> bytes:
    """The smallest SET_STATE_n that the state fits."""
    size = state_spec(sid).size
    sizes = ((Command.SET_STATE_1, 1), (Command.SET_STATE_4, 4), (Command.SET_STATE_12, 12),
             (Command.SET_STATE_24, 24), (Command.SET_STATE_254, 254))
    meaning = next(m for m, n in sizes if size <= n)
    return build_command(meaning, state_id=sid, data=data)


def slots(*ids: int) -> bytes:
    """RUN_MULT_PROC: *ids* in slots 0–7 (the rest of the eight emptied)."""
    return build_command(Command.RUN_MULT_PROC, proc_ids=[int(i) for i in ids] + [0] * (8 - len(ids)))


NO_CONVCOMP = slots(P.READ_INERTIAL, P.FRONTEND_PREPROC, P.FRONTEND_STATDET, P.MECHANIZATION, P.TIME_UPDATE,
                    P.ZUPT_UPDATE)
FRONT_END_THEN = (P.READ_INERTIAL, P.FRONTEND_PREPROC, P.FRONTEND_STATDET, P.FRONTEND_BIASEST,
                  P.FRONTEND_CONVCOMP)
HEIGHT_ON = build_command(Command.RUN_PROC, proc_id=P.HEIGHT_COMPENSATION, slot=10)
STILL = still_board().read(0).imu.tolist()
HIL_REPEATED_TIMESTAMP = [build_command(Command.SETUP_DEBUG_PROC, proc_ids=[
    P.FRONTEND_PREPROC, P.FRONTEND_STATDET, P.FRONTEND_BIASEST, P.FRONTEND_CONVCOMP, P.MECHANIZATION,
    P.TIME_UPDATE, P.ZUPT_UPDATE, 0, 0, 0], state_ids=[S.DT] + [0] * 9, interface=1)] + [
    build_command(Command.INPUT_IMU_RD, timestamp=1234, imu=STILL)] * 60

#: name → (the module tracks first?, frames sent, loops run, the states that are then not finite)
CASES = {
    "quaternion all zero": (True, [set_state(S.QUATERNION, bytes(16))], 50, NAVIGATION),
    "quaternion NaN": (True, [set_state(S.QUATERNION, NAN * 4)], 50, NAVIGATION),
    "velocity NaN": (True, [set_state(S.VELOCITY, NAN * 3)], 50, NAVIGATION),
    "velocity inf": (True, [set_state(S.VELOCITY, INF * 3)], 50, NAVIGATION),
    "velocity at the float32 maximum": (True, [set_state(S.VELOCITY, FLOAT_MAX * 3)], 50, NAVIGATION),
    "P at the float32 maximum": (True, [set_state(S.P, FLOAT_MAX * 45)], 50, NAVIGATION),
    "P NaN": (True, [set_state(S.P, NAN * 45)], 50, NAVIGATION),
    "position NaN (until the next step's reset)": (True, [set_state(S.POSITION, NAN * 3)], 3, {"POSITION"}),
    "THETA_GROUND NaN": (True, [HEIGHT_ON, set_state(S.THETA_GROUND, NAN * 2)], 500, {"THETA_GROUND"}),
    "DT 0 without CONVCOMP": (True, [NO_CONVCOMP, set_state(S.DT, f32(0.0))], 50, NAVIGATION),
    "DT subnormal without CONVCOMP": (True, [NO_CONVCOMP, set_state(S.DT, f32(1e-44))], 50, NAVIGATION),
    "DT 1e30 without CONVCOMP": (True, [NO_CONVCOMP, set_state(S.DT, f32(1e30))], 50, NAVIGATION),
    "U_K NaN without PREPROC": (True, [slots(P.MECHANIZATION, P.TIME_UPDATE), set_state(S.U_K, NAN * 6)], 50,
                                {"U_K"} | NAVIGATION),
    "U_K at the float32 maximum without PREPROC": (
        True, [slots(P.MECHANIZATION, P.TIME_UPDATE), set_state(S.U_K, FLOAT_MAX * 6)], 50, NAVIGATION),
    "hardware in the loop, one timestamp repeated (DT 0)": (True, HIL_REPEATED_TIMESTAMP, 3, NAVIGATION),
    "MECHANIZATION before any alignment": (False, [slots(*FRONT_END_THEN, P.MECHANIZATION)], 50,
                                           {"POSITION", "VELOCITY", "QUATERNION"}),
    "ZUPT_UPDATE before any alignment": (False, [slots(*FRONT_END_THEN, P.ZUPT_UPDATE)], 50, {"QUATERNION"}),
    "ZUPT_UPDATE at power-on (DT 0)": (False, [set_state(S.ZUPT, b"\x01"), build_command(
        Command.RUN_PROC, proc_id=P.ZUPT_UPDATE, slot=0)], 50, NAVIGATION),
    "CONV16 of a U_K NaN": (False, [slots(P.FRONTEND_CONV16), set_state(S.U_K, NAN * 6)], 50, {"U_K"}),
    "THETA_INIT NaN": (True, [HEIGHT_ON, set_state(S.THETA_INIT, NAN * 2)], 500, {"THETA_INIT"}),
}
SATURATED = [[32767, -32768, 32767, -32768, 32767, -32768]] * 4
#: Numbers a host may set that leave every navigation number finite: (tracks first?, frames, loops).
FINITE_CASES = {
    "DT negative without CONVCOMP": (True, [NO_CONVCOMP, set_state(S.DT, f32(-1e-3))], 500),
    "THETA_GROUND +pi/2": (True, [HEIGHT_ON, set_state(S.THETA_GROUND, f32(1.5707964, 0.0))], 500),
    "THETA_GROUND -pi/2": (True, [HEIGHT_ON, set_state(S.THETA_GROUND, f32(0.0, -1.5707964))], 500),
    "P's velocity block at -R": (True, [set_state(S.P, b"".join(
        f32(-0.01 if (r == c and 3 <= r < 6) else (1e-4 if r == c else 0.0))
        for r in range(9) for c in range(r, 9)))], 500),
    "TH_ZUPT 0: never still": (True, [set_state(S.TH_ZUPT, bytes(4))], 3000),
    "TH_ZUPT and TH_ZARU at their maximum: always still": (
        True, [set_state(S.TH_ZUPT, b"\xff" * 4), set_state(S.TH_ZARU, b"\xff" * 4)], 3000),
    "saturated raw registers in the loop": (True, HIL_REPEATED_TIMESTAMP[:1] + [
        build_command(Command.INPUT_IMU_RD, timestamp=64_000 * k, imu=SATURATED) for k in range(1, 60)], 3),
    "every bandwidth": (True, [build_command(Command.SET_IMU_BANDWIDTH, dlpf_cfg=c) for c in range(8)], 500),
}

PATHS = [False, pytest.param(True, marks=pytest.mark.skipif(not fastpath.available(),
                                                            reason="the compiled path needs numba"))]


def tracking_module(compiled: bool) -> Module:
    """A module in step-wise dead reckoning (0x34), aligned, on a board lying still."""
    m = build_module(ModuleConfig(compiled=compiled))
    m.usb.port.host_write(build_command(Command.STEPWISE_DEAD_RECKONING))
    m.run(600)
    assert m.memory.flag(S.INIT_DONE)
    m.usb.port.host_read()
    return m


def answers_ping(m: Module, loops: int = 1000) -> bool:
    """A host that acknowledges every packet sends PING: is it answered?"""
    port = m.usb.port
    decoder = StreamDecoder()
    port.host_write(build_command(Command.PING))
    received = bytearray()
    for _ in range(loops):
        m.step()
        data = port.host_read()
        received += data
        for frame in decoder.feed(data):
            if isinstance(frame, StatePacket):
                port.host_write(build_packet_ack(frame.number))
        if PING_ACK in received:
            return True
    return False


def send_and_run(case: str, compiled: bool) -> Module:
    tracks, frames, loops, _ = CASES[case]
    m = tracking_module(compiled) if tracks else build_module(ModuleConfig(compiled=compiled))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for frame in frames:
            m.usb.port.host_write(frame)
            m.step()
        m.run(loops)
    return m


@pytest.mark.parametrize("compiled", PATHS, ids=["pure", "compiled"])
@pytest.mark.parametrize("case", list(CASES))
def test_numbers_a_host_set_go_non_finite_quietly_and_the_module_answers_on(case, compiled):
    expected = CASES[case][3]
    m = send_and_run(case, compiled)
    assert {state_spec(s).name for s in m.memory.nonfinite_states()} == expected
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m.run(2000)
        assert answers_ping(m)


def _nan_as_one(m: Module) -> bytes:
    """The module's state memory with every NaN of a float state written as 7FC00000: IEEE 754
    leaves a NaN result's sign and payload open (x86 makes FFC00000 where numpy's order of
    operands keeps the operand's 7FC00000), so the two paths are compared up to that."""
    words = np.frombuffer(bytes(m.memory.arena), dtype=np.uint32).copy()
    for sid, spec in STATES.items():
        if spec.dtype.kind == "f":
            start = m.memory.offsets[sid] // 4
            part = words[start:start + spec.size // 4]
            part[np.isnan(part.view(np.float32))] = 0x7FC00000
    return words.tobytes()


@pytest.mark.parametrize("compiled", PATHS, ids=["pure", "compiled"])
@pytest.mark.parametrize("case", list(FINITE_CASES))
def test_other_extreme_numbers_leave_the_navigation_finite(case, compiled):
    tracks, frames, loops = FINITE_CASES[case]
    m = tracking_module(compiled) if tracks else build_module(ModuleConfig(compiled=compiled))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for frame in frames:
            m.usb.port.host_write(frame)
            m.step()
        m.run(loops)
    assert m.memory.nonfinite_states() == ()


@pytest.mark.skipif(not fastpath.available(), reason="the compiled path needs numba")
@pytest.mark.parametrize("case", list(CASES))
def test_both_paths_compute_the_same_non_finite_numbers(case):
    """Bit for bit, infinities and signed zeros included; a NaN is a NaN (see _nan_as_one)."""
    pure, compiled = send_and_run(case, False), send_and_run(case, True)
    assert _nan_as_one(pure) == _nan_as_one(compiled)


def test_a_position_nan_goes_out_in_the_next_step_and_is_gone_after_it():
    """POSITION's NaN goes out in that step's DX; the step's reset (p ← 0) ends it, and the step
    after has a finite DX again: non-finite numbers need not last."""
    m = send_and_run("position NaN (until the next step's reset)", False)
    steps = int(m.memory[S.STEP_COUNTER])
    m.run_until(lambda mod: int(mod.memory[S.STEP_COUNTER]) == steps + 1, 3000)
    assert np.isnan(m.memory[S.DX][:3]).all()
    assert {state_spec(s).name for s in m.memory.nonfinite_states()} == {"DX"}
    m.run_until(lambda mod: int(mod.memory[S.STEP_COUNTER]) == steps + 2, 3000)
    assert m.memory.nonfinite_states() == ()


def test_the_pacer_status_shows_that_the_numbers_went_non_finite():
    """The pacer notes the memory's report after each frame; its status line and JSON show it."""
    m = tracking_module(False)
    pacer = Pacer(m, [], speed=1.0)
    pacer.check_numbers()
    status = pacer.status()
    assert status.nonfinite == [] and status.nonfinite_frames == 0 and "non-finite" not in status.line()
    m.usb.port.host_write(set_state(S.QUATERNION, bytes(16)))
    m.run(5)
    pacer.check_numbers()
    pacer.check_numbers()
    status = pacer.status()
    assert status.nonfinite == ["POSITION", "VELOCITY", "QUATERNION", "P"]
    assert status.nonfinite_frames == 2
    assert status.nonfinite_first_s == pytest.approx(m.clock.now_cycles / m.clock.cpu_hz)
    assert "| non-finite POSITION VELOCITY QUATERNION P (2 frames since t=" in status.line()
    assert status.as_dict()["nonfinite"] == ["POSITION", "VELOCITY", "QUATERNION", "P"]
    # a new start of tracking makes them finite again; the count stays
    m.usb.port.host_write(build_command(Command.STEPWISE_DEAD_RECKONING))
    m.run(600)
    pacer.check_numbers()
    status = pacer.status()
    assert status.nonfinite == [] and status.nonfinite_frames == 2
    assert "| non-finite none now (2 frames since t=" in status.line()


def test_the_control_channel_reports_it():
    m = tracking_module(False)
    pacer = Pacer(m, [], speed=1.0)
    m.usb.port.host_write(set_state(S.P, NAN * 45))
    m.run(3)
    pacer.check_numbers()
    control = ControlServer([ServedModule(0, m, {}, [], pacer)], "127.0.0.1", 0)
    try:
        assert "non-finite" in control.execute("status")
        assert '"nonfinite": ["POSITION", "VELOCITY", "QUATERNION", "P"]' in control.execute("status json")
    finally:
        control.close()
