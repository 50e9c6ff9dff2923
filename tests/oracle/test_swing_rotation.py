"""Real feet keep rotating through the swing: the shared walks' figures that the stair gait takes its
roll and yaw from, and that the simulated swings are checked against (tests/sensors/test_gait.py)."""

from __future__ import annotations

import pytest

from firmware_sim.sensors.gait import STAIRS_DOWN, STAIRS_UP
from tests.conftest import WALK_IDS, requires_walks, walk_path
from tests.sensors.test_gait import REAL_SWING_MIN_RATE_P5_DPS

from .swing_rotation import summary, swing_rotations


@requires_walks
@pytest.mark.slow
def test_real_feet_keep_rotating_and_roll_and_turn_a_little_in_the_swing():
    """Over the 296 swings of the six walks the smallest |ω| in the middle of a swing is 2.9 °/s (5 %
    of swings below 8.9 °/s, the median 25 °/s); a straight swing rolls the sole 7° and turns the toe
    11° away from the stance (medians), which the stair gait takes."""
    figures = summary([s for w in WALK_IDS for s in swing_rotations(walk_path(w))])
    assert figures["swings"] == 296 and figures["straight_swings"] == 152
    assert figures["min_rate_floor_dps"] == pytest.approx(2.9, abs=0.05)
    assert figures["min_rate_p5_dps"] == pytest.approx(REAL_SWING_MIN_RATE_P5_DPS, abs=0.05)
    assert figures["min_rate_median_dps"] == pytest.approx(25.0, abs=0.05)
    for gait in (STAIRS_UP, STAIRS_DOWN):
        assert gait.swing_roll_deg == pytest.approx(figures["roll_median_deg"], abs=0.5)
        assert gait.swing_yaw_deg == pytest.approx(figures["yaw_median_deg"], abs=0.5)
