"""The host SDK against the emulated module behind its ``openshoe://`` pyserial URL.

Virtual time (speed=0): the reader thread drives the emulator, so these run
faster than real time and wait only on packets with deadlines.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("firmware_sim.transports.protocol_openshoe")

from hostlib.errors import AckTimeout  # noqa: E402
from hostlib.link.device import Device  # noqa: E402
from hostlib.link.device_options import DeviceOptions  # noqa: E402
from protocol.ids import OutputMode, StateId  # noqa: E402


def test_ping_and_mcu_id_over_the_emulator():
    with Device("openshoe://?scenario=stand&seed=1") as dev:
        assert dev.serialize_io  # the virtual-time port is driven by the reader thread only
        dev.ping()
        dev.request_mcu_id()
        pkt = dev.recv_packet(timeout=10)
        assert list(pkt.states) == [StateId.MCU_ID]
        assert pkt.states[StateId.MCU_ID].shape == (15,)


def test_2014_numbering_against_a_2014_module_and_silence_across_numberings():
    with Device("openshoe://?scenario=stand&command_set=2014", command_set="2014") as dev:
        dev.ping()
        dev.start_stepwise_dead_reckoning()  # 14 00 14
        dev.output_all_off()  # 21 00 21
    # An old app talking to a new module gets silence (protocol.md §10).
    url = "openshoe://?scenario=stand&command_set=2015"
    with Device(url, command_set="2014", ack_timeout=0.2, retries=0) as dev:
        with pytest.raises(AckTimeout):
            dev.output_all_off()


def test_lossless_output_is_acked_and_flows_in_order():
    with Device("openshoe://?scenario=stand&seed=2") as dev:
        dev.output_state(StateId.INTERRUPT_COUNTER, 1 | OutputMode.LOSSLESS)
        got = []
        for pkt in dev.packets(timeout=20):
            got.append(pkt)
            if len(got) == 150:
                break
        dev.output_all_off()
        numbers = [p.number for p in got]
        assert numbers == list(range(numbers[0], numbers[0] + 150))
        st = dev.stats
        assert st["acks_sent"] >= 150 and st["duplicate_packets"] == 0


def test_lossless_over_a_faulty_bluetooth_link_loses_nothing():
    """Lost and corrupted bytes: bad frames are counted, resends fill the holes, none is seen twice."""
    url = "openshoe://?scenario=stand&seed=3&link=bt&loss=0.003&corrupt=0.003"
    with Device(url, ack_timeout=2.0, retries=5) as dev:
        dev.output_state(StateId.INTERRUPT_COUNTER, 6 | OutputMode.LOSSLESS)  # every 32 loop cycles
        got = []
        for pkt in dev.packets(timeout=30):
            got.append(pkt)
            if len(got) == 100:
                break
        numbers = [p.number for p in got]
        counts = [int(p.states[StateId.INTERRUPT_COUNTER]) for p in got]
        assert numbers == list(range(numbers[0], numbers[0] + 100))
        assert all(b > a for a, b in zip(counts, counts[1:], strict=False))
        st = dev.stats
        assert st["bad_frames"] + st["garbage_bytes"] > 0  # the faults did happen


def _walking_available() -> bool:
    try:
        from firmware_sim.sensors import make_source  # noqa: F401
    except ImportError:
        return False
    return True


@pytest.mark.slow
@pytest.mark.skipif(not _walking_available(), reason="the emulator has no walking sensor scenarios yet")
def test_steps_of_a_straight_walk_are_summed():
    """A 12 m walk north: every step acked once, none twice, no gaps, the sum ends near (12, 0)."""
    recipe = "stand:3%2Bwalk:12%2Bstand:3"  # '+' must be %2B in a URL query
    with Device(f"openshoe://?scenario={recipe}&seed=1") as dev:
        dev.start_stepwise_dead_reckoning()
        for _ev in dev.steps(timeout=120):
            if dev.track.final_pose[0] > 11.0:
                break
        for _ev in dev.steps(timeout=2.0):  # the last step(s) of the stance at the end
            pass
        track, st = dev.track, dev.stats
    assert len(track) >= 10
    assert track.gaps == [] and st["duplicate_steps"] == 0
    assert st["acks_sent"] == st["packets"] + st["duplicate_packets"]
    x, y, _, chi = track.final_pose
    assert 11.0 < x < 13.0 and abs(y) < 0.5 and abs(chi) < 0.05
    assert track.distance == pytest.approx(x, rel=0.05)


@pytest.mark.slow
@pytest.mark.skipif(not _walking_available(), reason="the emulator has no walking sensor scenarios yet")
def test_a_right_turn_sends_the_next_steps_east():
    """5 m north, turn right 90° on the spot, 5 m: the summed track ends near (5 N, 5 E), χ = +90°.

    Checks the host's rotation R(χ) against the module's frame (x north, y east, z down).
    """
    recipe = "stand:3%2Bwalk:5%2Bturn:90%2Bwalk:5%2Bstand:3"
    with Device(f"openshoe://?scenario={recipe}&seed=1") as dev:
        dev.start_stepwise_dead_reckoning()
        for ev in dev.steps(timeout=120):
            if ev.pose[1] > 4.5:
                break
        for _ev in dev.steps(timeout=2.0):
            pass
        track = dev.track_snapshot()
    x, y, _, chi = track.final_pose
    assert x == pytest.approx(5.0, abs=0.3) and y == pytest.approx(5.0, abs=0.3)
    assert chi == pytest.approx(np.pi / 2, abs=0.05)
    assert track.distance == pytest.approx(10.0, rel=0.05)


def _walk_8m(url: str):
    with Device(url, ack_timeout=2.0, retries=5) as dev:
        dev.start_stepwise_dead_reckoning()
        for ev in dev.steps(timeout=120):
            if ev.pose[0] > 7.5:
                break
        for _ev in dev.steps(timeout=2.0):
            pass
        return dev.track_snapshot(), dev.stats


@pytest.mark.slow
@pytest.mark.skipif(not _walking_available(), reason="the emulator has no walking sensor scenarios yet")
def test_a_faulty_bluetooth_link_loses_no_step():
    """1 % of the bytes lost and 1 % corrupted each way: resends fill every hole, none is summed twice.

    (Not bit-identical to a clean run: the link delays 0x34, so alignment starts on another tick.)
    """
    url = "openshoe://?scenario=stand:3%2Bwalk:8%2Bstand:3&seed=1&link=bt&loss=0.01&corrupt=0.01"
    track, stats = _walk_8m(url)
    assert stats["bad_frames"] > 0 and stats["garbage_bytes"] > 0  # the faults did hit packets
    assert len(track) >= 8 and track.gaps == [] and stats["duplicate_steps"] == 0
    np.testing.assert_array_equal(track.counters, np.arange(1, len(track) + 1))
    x, y, _, _ = track.final_pose
    assert x == pytest.approx(8.0, abs=0.3) and abs(y) < 0.3


def test_a_device_that_reads_only_steps_queues_no_packets_and_sums_every_step():
    """``openshoe-host track`` reads steps only: its devices leave the packet queue out (a long
    walk's unread packets would fill it and be dropped with a warning); the steps all come."""
    recipe = "stand:3%2Bwalk:12%2Bstand:3"
    with Device(f"openshoe://?scenario={recipe}&seed=1", DeviceOptions(queue_packets=False)) as dev:
        dev.start_stepwise_dead_reckoning()
        for _ev in dev.steps(timeout=120):
            if dev.track.final_pose[0] > 11.0:
                break
        assert dev.recv_packet(timeout=0.0) is None
        st = dev.stats
    assert st["packets"] > 10 and st["dropped_packets"] == 0
    assert len(dev.track) >= 10 and dev.track.gaps == []
