"""Fidelity: the emulated firmware tracks as well as the OpenShoe reference, and sims close.

The main acceptance test replays the six shared closed-loop walks (OpenShoe,
MicroStrain 3DM-GX2, 250 Hz) through the emulated module exactly as a host
sees it (``run_replay``: 0x34 over Bluetooth, every packet acknowledged), sums
the steps from the wire with :class:`hostlib.track.steps.StepTracker`, and takes
the horizontal closure error as % of the distance walked (sum of horizontal
step lengths). The OpenShoe MATLAB implementation (GLRT detector, W = 3,
γ = 0.3e5, σ_a = 0.01 m/s², σ_g = 0.1 °/s; filter σ_acc = 0.5 m/s²,
σ_gyro = 0.5 °/s, σ_vel = 0.01 m/s; full-rate INS) gets the figures of
``REFERENCE`` (tests/oracle reproduces them). The module navigates a walk with the
recording's sensor profile (firmware_sim.nav.profiles: the 3DM-GX2's published
noise figures, its rates bias-compensated) and the recording served time-centred
(sensors/replay.py, Timing),
with the module's own detector and thresholds. Ours must close
within 0.55 % on average and 0.80 % on every walk, with one set of constants for
all walks (no per-walk tuning). Measured (pure-Python reference path; the tests
run on the compiled path when numba is there, whose bytes are the reference's:
tests/nav/test_fastpath.py replays the six walks on both paths and holds them to
the pinned bytes of tests/e2e/test_wire_golden.py):

    walk   ref %   ours %
    2      0.903   0.483
    3      0.770   0.535
    30     0.620   0.384
    31     0.502   0.238
    32     0.352   0.087
    33     0.548   0.316
    mean   0.616   0.340

With the module's own noise figures scaled to 250 Hz (before the profiles) it was
0.595 % on average and 0.939 % on walk 2: docs/accuracy.md has the trace against
the oracle that found why.
"""

from __future__ import annotations

import numpy as np
import pytest

from firmware_sim.nav.firmware import build_module
from firmware_sim.sensors.imu_array import make_source
from firmware_sim.sensors.replay import ReplaySource
from protocol.ids import StateId
from tests.conftest import WALK_IDS, requires_walks, walk_path

from .helpers import closure_percent, reference_config, replay_track

#: The module's path: compiled when numba is there (the same bytes as the pure-Python reference),
#: else the reference (and with OPENSHOE_PURE=1).
PATH = None

#: OpenShoe MATLAB reference closure errors [%] of the six shared walks.
REFERENCE = {"2": 0.903, "3": 0.770, "30": 0.620, "31": 0.502, "32": 0.352, "33": 0.548}
MAX_MEAN = 0.55
MAX_PER_WALK = 0.80


@pytest.fixture(scope="module")
def walk_results():
    out = {}
    for w in WALK_IDS:
        _, tracker = replay_track(ReplaySource.from_file(walk_path(w)), compiled=PATH)
        out[w] = (closure_percent(tracker), len(tracker), tracker.distance)
    table = "\n".join(f"  walk {w:>2}: ref {REFERENCE[w]:.3f} %  ours {e:.3f} %  ({n} steps, {d:.1f} m)"
                      for w, (e, n, d) in out.items())
    print("\nclosure error, % of distance walked:\n" + table)
    return out


@pytest.mark.slow
@pytest.mark.walks
@requires_walks
def test_every_walk_closes_within_0_80_percent(walk_results):
    for w, (err, steps, dist) in walk_results.items():
        assert steps > 40 and 70 < dist < 90, (w, steps, dist)  # ~1 min loops of ~78 m
        assert err <= MAX_PER_WALK, f"walk {w}: {err:.3f} %"


@pytest.mark.slow
@pytest.mark.walks
@requires_walks
def test_mean_closure_is_within_0_55_percent_and_no_worse_than_the_openshoe_reference(walk_results):
    ours = np.mean([walk_results[w][0] for w in WALK_IDS])
    ref = np.mean(list(REFERENCE.values()))
    assert ours <= MAX_MEAN, f"ours {ours:.3f} %"
    assert ours <= ref, f"ours {ours:.3f} % vs reference {ref:.3f} %"


@pytest.mark.slow
def test_straight_100_m_walk_length_within_0_5_percent():
    src = make_source("walk", seed=1, rate_hz=1000.0)
    _, tracker = replay_track(src, compiled=PATH)
    truth = src.truth.pos[-1] - src.truth.pos[0]
    length = float(np.hypot(*tracker.position[:2]))
    assert abs(length - np.hypot(*truth[:2])) <= 0.005 * 100.0


@pytest.mark.slow
def test_closed_loop_closes_within_0_5_percent():
    src = make_source("rectangle", seed=1, rate_hz=250.0)
    _, tracker = replay_track(src, compiled=PATH)
    truth = src.truth.pos[-1] - src.truth.pos[0]
    assert np.hypot(*truth[:2]) < 0.01  # the scenario is a closed loop
    assert closure_percent(tracker) <= 0.5


@pytest.mark.slow
@pytest.mark.parametrize("stance_sway, parting_m", [(False, 0.02), (True, 0.06)], ids=["still", "swaying"])
def test_stepwise_sum_reproduces_the_full_rate_ins(stance_sway, parting_m):
    """Steps summed on the host end where the full-rate INS (0x33) ends, to 2 cm after 100 m with
    still stances, to 6 cm with a real foot's swaying ones.

    The two are not the same filter (each reset zeroes position and heading and their
    covariance), so with a real module's gyro errors (g-sensitivity, bias instability:
    docs/sensor-errors.md) they part by about a centimetre per 100 m; error-free they agree to
    millimetres. On swaying stances the ZARU seldom holds and both headings drift more, and the
    ZUPTs correct a drifting heading differently with and without the reset's correlations: seeds
    1–4 part by 1.5–4.3 cm, well inside the fleet's 0.25 m across-track spread."""
    src = make_source("walk", seed=1, rate_hz=250.0, stance_sway=stance_sway)
    _, tracker = replay_track(src, compiled=PATH)
    full = build_module(reference_config(250.0, compiled=PATH), sensors=src)
    full.usb.port.host_write(bytes.fromhex("330033"))
    full.run(len(src))
    pos = full.memory[StateId.POSITION]
    assert float(np.hypot(*tracker.position[:2])) > 99.0
    assert float(np.hypot(*(pos[:2] - tracker.position[:2]))) <= parting_m
