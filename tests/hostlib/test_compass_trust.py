"""How far the filter trusts a compass reading: the field check of its magnitude and inclination
(against the World Magnetic Model or a calibration's field), and an uncalibrated compass weighed for
the shoe's unknown hard iron."""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pytest

from hostlib.aids.compass import StanceReading
from hostlib.aids.declination import MagneticField, magnetic_field
from hostlib.aids.field_check import (
    TILT_SIGMA_RAD,
    WMM_INCLINATION_SIGMA_RAD,
    WMM_TOTAL_SIGMA_UT,
    FieldCheck,
    level_field,
)
from hostlib.calibration.magcal import MagCalibration
from hostlib.cli.app import build_parser
from hostlib.cli.options import aid_options
from hostlib.cli.outputs import fusion_line
from hostlib.fusion.deviation import OUTDOORS, WHITE_SIGMA_RAD
from hostlib.fusion.feet import FOOT_SIDES, TwoFeetTracker
from hostlib.fusion.hard_iron import CALIBRATED, UNCALIBRATED, iron_heading_sigma
from hostlib.fusion.tracker import FusionSettings, FusionTracker
from hostlib.run.aid_setup import prepare_aids

DP = np.diag([1e-4, 1e-4, 1e-4, 1e-6])
#: the Earth's field a reading holds: F 51.9 µT, I 72.9°, H 15.3 µT (about Stockholm's)
WMM = MagneticField(declination_deg=7.7, inclination_deg=72.9, total_nt=51900.0,
                    horizontal_nt=51900.0 * math.cos(math.radians(72.9)))
H_UT = WMM.horizontal_nt / 1000.0
Z_UT = WMM.total_nt / 1000.0 * math.sin(math.radians(72.9))
STOCKHOLM = "59.35,18.07"
JUNE = dt.date(2026, 6, 1)


def _field(scale: float = 1.0, dip_deg: float = 72.9) -> np.ndarray:
    """A level board's field pointing north with magnitude *scale* × F and inclination *dip_deg*."""
    total = scale * WMM.total_nt / 1000.0
    dip = math.radians(dip_deg)
    return np.array([total * math.cos(dip), 0.0, total * math.sin(dip)])


def _walk(tracker: FusionTracker, fields: list[np.ndarray]) -> None:
    for k, field in enumerate(fields, start=1):
        tracker.add_step([0.7, 0.0, 0.0, 0.0], DP, k, reading=StanceReading(field, np.eye(3), 3))


def _settings(**changes) -> FusionSettings:
    base = dict(compass=True, compass_sigma_rad=WHITE_SIGMA_RAD, compass_deviation=OUTDOORS,
                magnetic_field=WMM)
    return FusionSettings(**{**base, **changes})


CALIBRATION = MagCalibration(np.zeros(3), np.eye(3), field_ut=51.9, rms_residual_ut=0.3)


# -- the field check ---------------------------------------------------------------------------


def test_a_levelled_reading_has_the_fields_magnitude_inclination_and_horizontal_part():
    total, dip, horizontal = level_field(_field(), np.eye(3))
    assert total == pytest.approx(51.9)
    assert math.degrees(dip) == pytest.approx(72.9)
    assert horizontal == pytest.approx(H_UT)


def test_the_tolerance_is_the_references_error_the_disturbance_and_the_level():
    check = FieldCheck(51.9, math.radians(72.9), WMM_TOTAL_SIGMA_UT, WMM_INCLINATION_SIGMA_RAD, "WMM")
    sigma_f, sigma_i = check.tolerance(2.0)
    assert sigma_f == pytest.approx(math.hypot(0.145, 2.0))
    assert sigma_i == pytest.approx(math.sqrt(math.radians(0.21) ** 2 + (2.0 / 51.9) ** 2
                                              + TILT_SIGMA_RAD ** 2))
    assert check.problem(_field(), np.eye(3), 2.0) is None
    assert "magnitude" in check.problem(_field(0.8), np.eye(3), 2.0)
    assert "inclination" in check.problem(_field(dip_deg=60.0), np.eye(3), 2.0)


def test_a_reading_of_the_wrong_magnitude_or_dip_is_rejected_and_counted():
    tracker = FusionTracker(_settings(mag_calibration=CALIBRATION), last_counter=0)
    events = []
    tracker.observe_aids(events.append)
    _walk(tracker, [_field(), _field(), _field(0.7), _field(dip_deg=55.0), _field()])
    f = tracker.fusion
    assert f.compass_field_rejected == 2
    assert f.compass_updates == 2  # and one reading aligned the heading
    assert f.compass_field_first.startswith("magnitude 36.3 µT, the field is 51.9 ±")
    assert [e.outcome for e in events] == ["aligned", "used", "rejected", "rejected", "used"]
    assert "2 rejected by the field check (the first: magnitude 36.3 µT" in fusion_line(tracker)


def test_the_first_reading_is_checked_before_it_aligns_the_heading():
    tracker = FusionTracker(_settings(mag_calibration=CALIBRATION), last_counter=0)
    _walk(tracker, [_field(1.5), _field()])
    assert tracker.fusion.compass_field_rejected == 1 and tracker.fusion.heading_aligned_by == "compass"


def test_an_uncalibrated_reading_is_allowed_the_whole_iron():
    """Uncalibrated, the shoe's iron (10 µT per axis) may move the field by far more: a reading 20 %
    weaker is still the Earth's field; one at half of it is not."""
    tracker = FusionTracker(_settings(), last_counter=0)
    _walk(tracker, [_field(), _field(0.8), _field(0.4)])
    assert tracker.fusion.compass_field_rejected == 1


def test_without_a_place_or_a_calibrations_field_nothing_is_checked_and_no_gate_checks_nothing():
    for settings in (_settings(magnetic_field=None), _settings(compass_gate_sigmas=None)):
        tracker = FusionTracker(settings, last_counter=0)
        _walk(tracker, [_field(), _field(0.3)])
        assert tracker.fusion.compass_field_rejected == 0


def test_the_calibrations_field_is_the_reference_magnitude():
    """A calibration mapped its readings onto 45 µT: a reading of 45 µT passes, one of the WMM's
    51.9 µT does not."""
    calibration = MagCalibration(np.zeros(3), np.eye(3), field_ut=45.0, rms_residual_ut=0.3)
    tracker = FusionTracker(_settings(mag_calibration=calibration), last_counter=0)
    _walk(tracker, [_field(45.0 / 51.9), _field(), _field(45.0 / 51.9)])
    assert tracker.fusion.compass_field_rejected == 1 and tracker.fusion.compass_updates == 1


# -- an uncalibrated compass -------------------------------------------------------------------


def test_the_iron_weighs_an_uncalibrated_compass_by_atan_of_its_sigma_over_the_horizontal_field():
    weight = iron_heading_sigma(UNCALIBRATED, H_UT)
    assert weight == pytest.approx(math.atan(10.0 / H_UT))
    assert math.degrees(weight) == pytest.approx(33.2, abs=0.1)
    tracker = FusionTracker(_settings(uncalibrated_iron=UNCALIBRATED), last_counter=0)
    assert tracker.iron_weight_rad == pytest.approx(weight)
    assert tracker.filter.sigma("deviation") == pytest.approx(math.hypot(OUTDOORS.sigma_rad, weight))


def test_a_calibrated_or_iron_learning_or_unweighed_compass_is_not_weighed():
    for settings in (_settings(uncalibrated_iron=UNCALIBRATED, mag_calibration=CALIBRATION),
                     _settings(uncalibrated_iron=UNCALIBRATED, hard_iron=CALIBRATED), _settings()):
        tracker = FusionTracker(settings, last_counter=0)
        assert tracker.iron_weight_rad == 0.0
        assert tracker.filter.sigma("deviation") == pytest.approx(OUTDOORS.sigma_rad)


def test_the_weight_stays_through_the_walk_the_deviation_relaxes_to_it():
    tracker = FusionTracker(_settings(uncalibrated_iron=UNCALIBRATED, magnetic_field=None), last_counter=0)
    assert tracker.iron_weight_pending and tracker.iron_weight_rad == 0.0
    # without a place, H is the horizontal field the first reading measures
    _walk(tracker, [_field(0.8)])
    weight = math.atan(10.0 / (0.8 * H_UT))
    assert not tracker.iron_weight_pending
    assert tracker.iron_weight_rad == pytest.approx(weight)
    assert tracker.iron_weight_horizontal_ut == pytest.approx(0.8 * H_UT)
    assert (f"; uncalibrated compass weighed for its iron: {math.degrees(weight):.1f}° "
            f"(H {0.8 * H_UT:.1f} µT)") in fusion_line(tracker)
    # the first reading aligned χ with d's inflated variance in it
    assert tracker.filter.sigma("pose", 3) == pytest.approx(math.sqrt(WHITE_SIGMA_RAD ** 2 + OUTDOORS.variance
                                                                      + weight ** 2))


def test_without_the_deviation_the_weight_goes_into_each_reading():
    tracker = FusionTracker(_settings(uncalibrated_iron=UNCALIBRATED, compass_deviation=None), last_counter=0)
    weight = math.atan(10.0 / H_UT)
    _walk(tracker, [_field()])
    assert tracker.filter.sigma("pose", 3) == pytest.approx(math.hypot(WHITE_SIGMA_RAD, weight))


def test_a_calibration_released_later_ends_the_weight():
    """The in-situ calibration: the compass waits, the weight is the uncalibrated one; released with
    the calibration, the weight goes and the deviation starts again from σ_d."""
    tracker = FusionTracker(_settings(uncalibrated_iron=UNCALIBRATED), last_counter=0)
    tracker.hold_compass()
    _walk(tracker, [_field()])
    assert tracker.iron_weight_rad > 0.0
    tracker.release_compass(CALIBRATION)
    assert tracker.iron_weight_rad == 0.0
    assert tracker.filter.sigma("deviation") == pytest.approx(OUTDOORS.sigma_rad)


# -- what the aids: line says ----------------------------------------------------------------


def test_the_aids_line_says_the_compass_is_uncalibrated_and_how_it_is_weighed():
    here = magnetic_field(59.35, 18.07, 0.0, JUNE)
    weight = math.degrees(math.atan(10.0 / (here.horizontal_nt / 1000.0)))
    line = prepare_aids(compass=True, origin=STOCKHOLM, date=JUNE).describe()
    assert (f"compass uncalibrated (no calibration, the shoe's iron not learned): weighed for an "
            f"unknown iron of σ 10 µT per axis, atan(σ / H) with H the horizontal field (WMM: "
            f"{here.horizontal_nt / 1000.0:.1f} µT) = {weight:.1f}° in quadrature with the local "
            f"deviation's σ") in line
    assert (f"each reading's field checked against {here.total_nt / 1000.0:.1f} µT, inclination "
            f"{here.inclination_deg:.1f}° (WMM)") in line


def test_the_aids_line_of_a_calibrated_or_unweighed_or_placeless_compass():
    calibrated = prepare_aids(compass=True, origin=STOCKHOLM, date=JUNE,
                              mag_calibration=CALIBRATION).describe()
    assert "uncalibrated" not in calibrated
    assert ("each reading's field checked against 51.9 µT, inclination 72.9° (the calibration's field, "
            "the WMM's inclination)") in calibrated
    assert "uncalibrated" not in prepare_aids(compass=True, uncalibrated_weight=False).describe()
    placeless = prepare_aids(compass=True).describe()
    assert "with H the horizontal field (its first reading's) in quadrature" in placeless
    assert ("the readings' field not checked (no place and no calibration's field to check it "
            "against)") in placeless


def test_the_command_line_turns_the_weight_off(tmp_path):
    args = build_parser().parse_args(["replay", str(tmp_path / "walk.bin"), "--compass",
                                      "--no-uncalibrated-weight"])
    assert aid_options(args, None).uncalibrated_weight is False
    assert aid_options(build_parser().parse_args(["replay", str(tmp_path / "walk.bin"), "--compass"]),
                       None).uncalibrated_weight is True


# -- two feet ------------------------------------------------------------------------------------


def test_two_feet_weigh_an_uncalibrated_foots_compass_and_check_each_foots_field():
    aids = _settings(uncalibrated_iron=UNCALIBRATED)
    feet = TwoFeetTracker(aids=aids, defer=False)
    assert feet.iron_weight_rad == pytest.approx(math.atan(10.0 / H_UT))
    weighed = math.hypot(OUTDOORS.sigma_rad, feet.iron_weight_rad)
    assert feet.filter.sigma("deviation") == pytest.approx(weighed)
    both = TwoFeetTracker(aids=aids, defer=False, mag_calibrations=dict.fromkeys(FOOT_SIDES, CALIBRATION))
    assert both.iron_weight_rad == 0.0
    counter = dict.fromkeys(FOOT_SIDES, 0)
    for k, scale in enumerate([1.0, 1.0, 0.7, 1.0]):
        side = FOOT_SIDES[k % 2]
        counter[side] += 1
        both.foot(side).add_step([0.7, 0.0, 0.0, 0.0], DP, counter[side],
                                 reading=StanceReading(_field(scale), np.eye(3), 3), time_s=float(k + 1))
    assert both.fusion.compass_field_rejected == 1
    assert both.fusion.compass_field_first.startswith("magnitude 36.3 µT")
