"""A recording is replayed time-centred: an error-free simulated walk, written as a 250 Hz recording
and replayed, is retraced, neither sinking nor rising (firmware_sim/sensors/replay.py, Timing)."""

from __future__ import annotations

import numpy as np
import pytest

from firmware_sim.app.batch import run_replay
from firmware_sim.sensors.config import SensorConfig
from firmware_sim.sensors.imu_array import make_source
from firmware_sim.sensors.replay import ReplaySource
from tests.nav.helpers import steps_from_wire


def _end_error(scenario: str) -> np.ndarray:
    """Summed steps minus the truth at the last stance [m], (x, y, z), of *scenario* recorded at 250 Hz."""
    src = make_source(scenario, seed=0, rate_hz=250.0, config=SensorConfig.ideal())
    data = run_replay(ReplaySource(src.to_recording()), announce=None)
    track = steps_from_wire(data)[1]
    return np.asarray(track.position[:3]) - np.asarray(src.truth.stances_in_start_frame()[-1][:3])


def test_the_replay_serves_the_accelerometer_half_a_sample_ahead():
    src = make_source("stand:1+walk:2+stand:1", seed=0, rate_hz=250.0, config=SensorConfig.ideal())
    rec = src.to_recording()
    replay = ReplaySource(rec)
    served = replay.imu[:, 0, :3].astype(float)  # chip 0's raw registers, LSB
    own = ReplaySource(rec).imu  # the same again: a deterministic function of the recording
    assert np.array_equal(own, replay.imu)
    # chip 0 sees the board through its mounting: compare magnitudes, which it keeps
    mid = 0.5 * (rec.board_acc_g()[:-1] + rec.board_acc_g()[1:]) * 2048.0
    assert np.allclose(np.linalg.norm(served[:-1], axis=1), np.linalg.norm(mid, axis=1), atol=1.5)


@pytest.mark.slow
@pytest.mark.parametrize("scenario", ["walk", "stairs_up"])
def test_an_error_free_walk_recorded_at_250_hz_is_retraced(scenario):
    """Served as recorded, the 100 m walk sank 0.26 m; one sample ahead, it rose 0.26 m."""
    err = _end_error(scenario)
    assert abs(err[2]) < 0.02, err
    assert np.linalg.norm(err) < 0.04, err
