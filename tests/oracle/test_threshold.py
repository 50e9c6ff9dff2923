"""The 3DM-GX2 profile's ZUPT threshold is the module detector's equal-error point on walking data,
and a choice made on five walks holds on the sixth."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from firmware_sim.nav.profiles import GX2_PROFILE
from tests.conftest import WALK_IDS, requires_walks, walk_path

from .threshold import (
    GRID,
    DetectorSample,
    choose,
    detector_sample,
    error_rates,
    leave_one_out,
    simulated_sample,
)


def _sample(stance_t1, swing_t1) -> DetectorSample:
    stance_t1, swing_t1 = np.asarray(stance_t1), np.asarray(swing_t1)
    t1 = np.concatenate([stance_t1, swing_t1])
    flags = np.concatenate([np.ones(len(stance_t1), bool), np.zeros(len(swing_t1), bool)])
    return DetectorSample(Path("synthetic"), t1, flags, stance_t1[:1], stance_t1, swing_t1)


def test_the_equal_error_point_lies_where_the_missed_stance_rate_meets_the_mid_swing_false_alarm_rate():
    # stance statistics spread evenly over 0…10000, swing over 5000…15000: the rates cross at 7500
    walk = _sample(np.linspace(0, 10000, 1001), np.linspace(5000, 15000, 1001))
    th = choose([walk])
    missed, false_alarm = error_rates([walk], np.array([th - 250, th]))
    assert 7500 <= th <= 7750  # the first grid point (250 apart) at or past the crossing
    assert false_alarm[0] < missed[0] and false_alarm[1] >= missed[1]


def test_rates_fall_and_rise_with_the_threshold():
    walk = _sample(np.arange(0, 20000, 7), np.arange(8000, 90000, 13))
    missed, false_alarm = error_rates([walk], GRID)
    assert np.all(np.diff(missed) <= 0) and np.all(np.diff(false_alarm) >= 0)
    assert missed[-1] == 0.0 and false_alarm[0] == 0.0


@pytest.fixture(scope="module")
def walks() -> list[DetectorSample]:
    return [detector_sample(walk_path(w)) for w in WALK_IDS]


@requires_walks
def test_the_3dm_gx2_profiles_threshold_is_the_equal_error_point_of_the_walks(walks):
    assert choose(walks) == GX2_PROFILE.zupt_threshold


@requires_walks
def test_a_threshold_chosen_on_five_walks_holds_on_the_sixth(walks):
    """Leave-one-out: every fold's choice lies within 10 % of the profile's, and on the walk left out
    the module misses under 0.5 % of stance samples and accepts under 1 % of mid-swing samples."""
    for fold in leave_one_out(walks, GX2_PROFILE.zupt_threshold):
        assert abs(fold.threshold - GX2_PROFILE.zupt_threshold) <= 0.1 * GX2_PROFILE.zupt_threshold, fold
        assert fold.missed < 0.005 and fold.false_alarm < 0.01, fold
        assert fold.agreement > 0.97, fold


@pytest.mark.parametrize("scenario", ["walk", "stairs_down", "run"])
def test_the_modules_own_threshold_tells_its_swaying_stances_from_its_swings_with_margin(scenario):
    """On the emulated module's own data (1 kHz, every sensor error, a real foot's swaying stances)
    the power-on TH_ZUPT misses no sample in the middle 80 % of a walking stance and accepts none in
    the middle 60 % of a swing, with a factor of two to spare on either side."""
    from firmware_sim.nav.config import TH_ZUPT_DEFAULT

    walk = simulated_sample(scenario, seed=1, swing_cut=0.2)
    assert walk.stance.max() < TH_ZUPT_DEFAULT / 2, "a swaying stance nears the threshold"
    assert walk.swing.min() > 2 * TH_ZUPT_DEFAULT, "a swing nears the threshold in its middle"
    missed, false_alarm = error_rates([walk], np.array([TH_ZUPT_DEFAULT]))
    assert missed[0] == 0.0 and false_alarm[0] == 0.0
