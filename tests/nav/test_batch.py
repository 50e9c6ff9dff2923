"""Batch replay (`openshoe-emu replay`): a source → exactly the bytes the module sent over Bluetooth."""

from __future__ import annotations

import numpy as np
import pytest

from firmware_sim.app import cli
from firmware_sim.app.batch import START_STEPWISE, run_replay
from firmware_sim.nav.firmware import build_module
from firmware_sim.sensors.imu_array import make_source
from firmware_sim.sensors.replay import Recording, ReplaySource, save_csv
from protocol.codec import decode_states
from protocol.frames import CommandAck, StatePacket, build_command
from protocol.ids import Command, Interface, ProcId, StateId
from protocol.stream import decode_all

from .helpers import reference_config, steps_from_wire

RATE = 250.0


@pytest.fixture(scope="module")
def short_walk():
    return make_source("stand:1.5+walk:8+stand:1.5", seed=2, rate_hz=RATE)


@pytest.fixture(scope="module")
def short_wire(short_walk):
    return run_replay(short_walk, config=reference_config(RATE))


def test_wire_starts_with_the_ack_of_34_and_carries_64_byte_steps(short_wire):
    assert START_STEPWISE == bytes.fromhex("340034")
    assert short_wire[:4] == bytes.fromhex("A03400D4")
    frames = decode_all(bytes(short_wire))
    assert isinstance(frames[0], CommandAck) and frames[0].command_id == 0x34
    packets = [f for f in frames if isinstance(f, StatePacket)]
    assert len(short_wire) == 4 + 64 * len(packets)  # nothing else, no resends (acked at once)
    assert [p.number for p in packets] == list(range(1, len(packets) + 1))


def test_steps_sum_to_the_walked_distance(short_walk, short_wire):
    _, tracker = steps_from_wire(short_wire)
    counters = list(tracker.track.counters)
    assert counters == list(range(1, len(counters) + 1))
    truth = short_walk.truth.pos[-1] - short_walk.truth.pos[0]
    assert np.hypot(*(tracker.position[:2] - truth[:2])) < 0.05  # 8 m walk, a few cm


def test_replay_is_deterministic(short_walk, short_wire):
    assert bytes(run_replay(short_walk, config=reference_config(RATE))) == bytes(short_wire)


def test_cli_replay_writes_the_same_bytes(tmp_path, short_walk, short_wire):
    rec = short_walk.to_recording()  # board-frame signals in our CSV format
    csv = save_csv(Recording(rec.t, rec.acc_g, rec.gyro, rec.mag, rec.rate_hz), tmp_path / "w.csv")
    out = tmp_path / "w.bin"
    assert cli.main(["replay", str(csv), "--wire", str(out), "--quiet"]) == 0
    expect = run_replay(ReplaySource.from_file(csv))
    assert out.read_bytes() == bytes(expect)
    assert out.read_bytes()[:4] == bytes.fromhex("A03400D4")


def test_cli_replay_refuses_a_bad_file(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,ax,ay,az,gx,gy,gz\n0,0,0,-1,0,0,0\n0.004,x,0,-1,0,0,0\n")
    assert cli.main(["replay", str(bad), "--wire", str(tmp_path / "o.bin"), "--quiet"]) == 2
    assert "line 3" in capsys.readouterr().err
    assert not (tmp_path / "o.bin").exists()


@pytest.mark.slow
def test_cli_scenario_writes_ground_truth_beside(tmp_path):
    out = tmp_path / "s.bin"
    assert cli.main(["replay", "--scenario", "stand:2", "--wire", str(out), "--rate", "250", "--quiet"]) == 0
    assert out.read_bytes()[:4] == bytes.fromhex("A03400D4")
    assert (tmp_path / "s.bin.truth.csv").is_file()


def test_hil_gives_the_same_states_as_the_batch_run(short_walk):
    """INPUT_IMU_RD (0x11) fed with the raw registers READ_INERTIAL read gives the same front-end states."""
    ids = [StateId.U_INT_K, StateId.T_INT_K, StateId.U_K, StateId.DT, StateId.T1S2F, StateId.T2S2F,
           StateId.ZUPT, StateId.ZARU]
    procs = [ProcId.FRONTEND_PREPROC, ProcId.FRONTEND_STATDET, ProcId.FRONTEND_BIASEST,
             ProcId.FRONTEND_CONVCOMP]
    n = 120
    # the batch module: the front end reading the sensors itself
    batch = build_module(reference_config(RATE), sensors=short_walk)
    batch.sequence.set_slots([ProcId.READ_INERTIAL, *procs])
    raw, ts, expect = [], [], []
    for _ in range(n):
        batch.step()
        raw.append(batch.memory.imu_raw[:4].copy())
        ts.append(int(batch.memory[StateId.IMU_TS]))
        expect.append({sid: batch.memory[sid].copy() for sid in ids})
    # the HIL module: the host feeds those registers
    hil = build_module(reference_config(RATE))
    port = hil.usb.port
    port.host_write(build_command(Command.SETUP_DEBUG_PROC, proc_ids=list(procs) + [0] * 6,
                                  state_ids=list(ids) + [0] * 2, interface=int(Interface.USB)))
    hil.step()
    port.host_read()
    got = []
    for k in range(n):
        port.host_write(build_command(Command.INPUT_IMU_RD, timestamp=ts[k], imu=raw[k].tolist()))
        hil.step()
        packets = [f for f in decode_all(port.host_read()) if isinstance(f, StatePacket)]
        assert len(packets) == 1
        got.append(decode_states(sorted(ids), packets[0].payload))
    for k in range(n):
        for sid in ids:
            np.testing.assert_array_equal(got[k][sid], expect[k][sid], err_msg=f"sample {k}, 0x{sid:02X}")
