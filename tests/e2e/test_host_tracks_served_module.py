"""The host SDK tracking a served module end to end: `openshoe-emu serve` walks a known scenario.

* over a real pty and over socket://: the tracked end position lies within 3σ (of the
  track's own covariance) of the scenario's ground truth, and the track equals what an
  independent decoder makes of the raw bytes the host received (protocol.stream +
  protocol.codec + hostlib.track.steps, offline);
* with faults injected by the emulator's link model and a forced disconnect/reconnect
  (the serve control channel), no step is summed twice and none is lost silently: every
  missing step is reported as a gap.

Real time (a subprocess paced at a few times real time): every wait is on events with a
deadline, never a fixed sleep.
"""

from __future__ import annotations

import io
import socket
import sys
import threading

import numpy as np
import pytest

from firmware_sim.app.serve import spawn
from firmware_sim.sensors import make_source
from hostlib.events import StepOutcome
from hostlib.link.device import Device
from hostlib.track.steps import StepTracker
from protocol.codec import decode_step
from protocol.frames import StatePacket
from protocol.stream import StreamDecoder

pytestmark = [
    pytest.mark.skipif(not sys.platform.startswith("linux"), reason="ptys are tested on Linux"),
    pytest.mark.slow,
]

WALK_M = 20.0
RECIPE = f"stand:4+walk:{WALK_M:g}+stand:3"
SEED = 2
SPEED = "8"  # module seconds per wall second


def control(address: str, line: str) -> str:
    """One line command on the serve control channel; its reply (up to OK/ERR)."""
    host, port = address.rsplit(":", 1)
    with socket.create_connection((host, int(port)), timeout=5) as c:
        f = c.makefile("rw", encoding="utf-8", newline="\n")
        f.write(line + "\n")
        f.flush()
        reply = []
        while True:
            r = f.readline()
            if not r:
                break
            reply.append(r.rstrip("\n"))
            if r.startswith(("OK", "ERR")):
                break
        return "\n".join(reply)


def virtual_s(address: str) -> float:
    """The module's virtual time, from the control channel's status line (``t=…s``)."""
    line = control(address, "status").splitlines()[0]
    return float(line.split("t=", 1)[1].split("s", 1)[0])


def wait_virtual(address: str, seconds: float, deadline_s: float = 30.0) -> None:
    """Wait (on the control channel's answers, with a deadline) until *seconds* of module time pass."""
    t0 = virtual_s(address)
    tick = threading.Event()
    for _ in range(int(deadline_s / 0.02)):
        if virtual_s(address) >= t0 + seconds:
            return
        tick.wait(0.02)  # poll interval while waiting on the module's clock (bounded by the deadline)
    raise AssertionError(f"module time did not advance {seconds} s within {deadline_s} s")


def walk_until_standing(dev: Device, min_distance: float = 0.8 * WALK_M, timeout: float = 60.0) -> None:
    """Steps until the walk is over: *min_distance* covered, then two ~zero steps (standing)."""
    still = 0
    for ev in dev.steps(timeout=timeout):
        moved = float(np.hypot(*ev.step.dx[:2]))
        if dev.track_snapshot().distance >= min_distance:
            still = still + 1 if moved < 0.05 else 0
            if still >= 2:
                return
    raise AssertionError(f"the walk did not end within {timeout} s: {dev.stats}")


def resum_offline(raw: bytes) -> tuple[StepTracker, StreamDecoder, list[StepOutcome]]:
    """Sum the steps in the raw module → host bytes, independently of the Device."""
    dec = StreamDecoder()
    tracker = StepTracker()
    outcomes = []
    for frame in dec.feed(raw) + dec.finish():
        if isinstance(frame, StatePacket) and len(frame.payload) == 58:
            outcomes.append(tracker.add(decode_step(frame.payload)))
    return tracker, dec, outcomes


@pytest.fixture(scope="module")
def truth():
    """The ground truth of the served scenario (same recipe, same seed, same rate)."""
    src = make_source(RECIPE, seed=SEED)
    return src.truth


@pytest.mark.parametrize("endpoint", ["bt-pty", "bt-tcp"])
def test_tracked_walk_ends_within_3_sigma_of_the_truth_and_matches_the_wire_bytes(tmp_path, truth, endpoint):
    with spawn("--pty", str(tmp_path / "rfcomm0"), "--tcp", "0", "--scenario", RECIPE, "--seed", str(SEED),
               "--speed", SPEED, "--status-interval", "0") as srv:
        addr = srv.ready[endpoint]
        url = addr if endpoint.endswith("pty") else f"socket://{addr}"
        raw = io.BytesIO()
        with Device(url, ack_timeout=2.0, retries=5, raw_log=raw) as dev:
            dev.start_stepwise_dead_reckoning()
            walk_until_standing(dev)
            track, stats = dev.track_snapshot(), dev.stats
    # the module's view: every step once, no gap
    assert track.gaps == [] and stats["duplicate_steps"] == 0
    np.testing.assert_array_equal(track.counters, np.arange(1, len(track) + 1))
    # within 3σ of its own covariance, per axis and as a whole (x, y)
    pos0 = truth.pos[0]
    true_end = truth.pos[-1] - pos0
    err = track.final_pose[:3] - true_end
    cov = track.covariances[-1][:3, :3]
    sigma = np.sqrt(np.diag(cov))
    assert np.all(np.abs(err[:2]) <= 3 * sigma[:2]), (err, sigma)
    d2 = err[:2] @ np.linalg.solve(cov[:2, :2], err[:2])
    assert d2 <= 3.0**2, (err, cov[:2, :2])
    assert np.hypot(*true_end[:2]) == pytest.approx(WALK_M, rel=0.02)
    # an independent sum of the bytes that crossed the link gives the same track
    offline, dec, outcomes = resum_offline(raw.getvalue())
    assert dec.bad_frames == 0
    np.testing.assert_array_equal(offline.track.counters, track.counters)
    np.testing.assert_allclose(offline.track.poses, track.poses, rtol=0, atol=1e-12)
    np.testing.assert_allclose(offline.track.covariances, track.covariances, rtol=0, atol=1e-15)


def test_faults_and_a_forced_reconnect_never_sum_a_step_twice_or_lose_one_silently(tmp_path, truth):
    """Lossy, corrupting link (≈ 20 % of the 64-byte step packets hit: 0.18 % of the bytes lost
    and 0.18 % corrupted, each way) and a forced disconnect/reconnect in the middle of the walk."""
    with spawn("--tcp", "0", "--control", "0", "--scenario", RECIPE, "--seed", str(SEED),
               "--speed", SPEED, "--loss", "0.0018", "--corrupt", "0.0018", "--status-interval", "0") as srv:
        url = f"socket://{srv.ready['bt-tcp']}"
        raw = io.BytesIO()
        with Device(url, ack_timeout=2.0, retries=8, raw_log=raw) as dev:
            dev.start_stepwise_dead_reckoning()
            for _ in dev.steps(timeout=60):
                if dev.track_snapshot().distance > 6.0:
                    break
            seen_before = len(dev.track_snapshot())
            assert control(srv.ready["control"], "disconnect").startswith("OK")
            wait_virtual(srv.ready["control"], 3.0)  # ≥ 2 steps counted that nobody receives
            assert control(srv.ready["control"], "reconnect").startswith("OK")
            walk_until_standing(dev, min_distance=0.0)  # the steps missed shorten the sum
            track, stats, gaps = dev.track_snapshot(), dev.stats, list(dev.gap_events)
    assert stats["bad_frames"] + stats["garbage_bytes"] > 0  # the faults did hit
    assert stats["duplicate_packets"] > 0  # resends of packets whose ack was lost: not summed again
    counters = list(track.counters)
    assert len(set(counters)) == len(counters)  # no step summed twice
    assert counters == sorted(counters)
    # every missing counter is inside a reported gap
    missing = sorted(set(range(1, counters[-1] + 1)) - set(counters))
    reported = sorted(c for g in gaps for c in range(g.counter - g.missing, g.counter))
    assert missing == reported
    assert gaps and stats["missing_steps"] == len(missing) >= 1
    assert len(track) > seen_before
    # the offline sum of the same bytes sees the same steps and the same gaps
    offline, dec, outcomes = resum_offline(raw.getvalue())
    np.testing.assert_array_equal(offline.track.counters, track.counters)
    np.testing.assert_allclose(offline.track.poses, track.poses, rtol=0, atol=1e-12)
