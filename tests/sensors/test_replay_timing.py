"""A recording is replayed time-centred: an error-free simulated walk, written as a 250 Hz recording
and replayed, is retraced, neither sinking nor rising (firmware_sim/sensors/replay.py, Timing); and
the samples its recorder skipped are put back, so that its time stays the sensor's."""

from __future__ import annotations

from dataclasses import replace

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


def test_a_recording_missing_samples_is_retraced_as_the_whole_one():
    """Ten samples of a 10 m error-free walk left out of its recording: served with them put back,
    the walk ends within 2 mm of the whole recording's end; served one after the other as written,
    the walk would come out 0.19 m short and 0.15 m off in height."""
    src = make_source("stand:2+walk:10+stand:2", seed=0, rate_hz=250.0, config=SensorConfig.ideal())
    whole = src.to_recording()
    whole = replace(whole, nr=np.arange(1, len(whole) + 1))
    skipped = np.random.default_rng(1).choice(np.arange(600, len(whole) - 600), 10, replace=False)
    kept = np.setdiff1d(np.arange(len(whole)), skipped)
    gappy = replace(whole, t=whole.t[kept], acc_g=whole.acc_g[kept], gyro=whole.gyro[kept],
                    mag=whole.mag[kept], nr=whole.nr[kept])

    def end(recording) -> np.ndarray:
        return np.asarray(steps_from_wire(run_replay(ReplaySource(recording), announce=None))[1].position[:3])

    reference = end(whole)
    assert np.linalg.norm(end(gappy) - reference) < 0.002
    assert np.linalg.norm(end(replace(gappy, nr=None)) - reference) > 0.1, "the gaps would matter"
