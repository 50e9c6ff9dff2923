"""The shoe's hard iron learned as states of the filter: the reading's linearisation, the iron
learned on a walk whose turns and GPS make it observable, and an uncalibrated compass that then
helps instead of turning the track."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hostlib.aids.compass import StanceReading, quaternion_rotation
from hostlib.cli import main
from hostlib.fusion.hard_iron import CALIBRATED, UNCALIBRATED, HardIron, iron_heading
from hostlib.fusion.tracker import FusionSettings, FusionTracker
from hostlib.run.options import AidOptions
from hostlib.track.steps import rotation_z

FIELD_NED = np.array([15.5, 0.0, 49.0])  # µT: 72.5° inclination
DP = np.diag([1e-4, 1e-4, 1e-4, 1e-6])


@settings(max_examples=50, deadline=None)
@given(q=st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda q: sum(v * v for v in q) > 0.1),
       m=st.lists(st.floats(-60, 60), min_size=3, max_size=3),
       b=st.lists(st.floats(-5, 5), min_size=3, max_size=3))
def test_the_readings_gradient_in_the_iron_is_the_headings(q, m, b):
    r = quaternion_rotation(q)
    psi, g = iron_heading(np.array(m), r, np.array(b))
    n = r @ (np.array(m) - np.array(b))
    if math.hypot(n[0], n[1]) < 5.0:  # the heading of a nearly vertical field is not defined
        return
    eps = 1e-5
    for axis in range(3):
        e = np.eye(3)[axis] * eps
        up = iron_heading(np.array(m), r, np.array(b) + e)[0]
        down = iron_heading(np.array(m), r, np.array(b) - e)[0]
        numeric = math.remainder(up - down, 2 * math.pi) / (2 * eps)
        assert g[axis] == pytest.approx(numeric, rel=1e-4, abs=1e-7)


def _walk_a_square(tracker: FusionTracker, iron: np.ndarray, laps: int = 6) -> None:
    """Laps of a 14 m square, the true heading known by GPS fixes every step; the board reads the
    field turned by the heading plus the shoe's *iron* (board frame)."""
    k, t, pos, chi = 0, 0.0, np.zeros(2), 0.0
    for _ in range(laps * 4):
        for leg_step in range(20):
            turn = math.pi / 2 if leg_step == 0 and k > 0 else 0.0
            chi += turn
            pos = pos + 0.7 * np.array([math.cos(chi), math.sin(chi)])
            k, t = k + 1, t + 1.0
            tracker.add_fix(t, pos)
            field = rotation_z(chi).T @ FIELD_NED + iron
            tracker.add_step([0.7, 0.0, 0.0, turn], DP, k, time_s=t,
                             reading=StanceReading(field, np.eye(3), 3))


def test_turns_and_gps_teach_the_iron_and_the_compass_then_holds_the_heading():
    iron = np.array([4.0, -3.0, 2.0])
    held = FusionTracker(FusionSettings(compass=True, gps=True, hard_iron=UNCALIBRATED,
                                        compass_sigma_rad=math.radians(2.0)), last_counter=0)
    _walk_a_square(held, iron)
    learned = held.filter.mean("hard_iron")
    sigma = np.sqrt(np.diagonal(held.filter.covariance("hard_iron")))
    # level walking: the horizontal axes are learned to a fraction of a microtesla, the vertical not
    assert np.all(np.abs(learned[:2] - iron[:2]) < 0.5) and np.all(sigma[:2] < 0.5)
    assert sigma[2] > 5.0
    assert held.fusion.compass_rejected == 0


def test_an_uncalibrated_compass_with_its_iron_learned_does_not_turn_the_track():
    """The same walk, the iron not held: the uncalibrated compass turns its headings by up to
    15° as the walker turns, and the gate throws most of it away; held, every reading is used and
    the heading ends within 3° of the truth."""
    iron = np.array([4.0, -3.0, 2.0])
    plain = FusionTracker(FusionSettings(compass=True, gps=True, compass_sigma_rad=math.radians(2.0)),
                          last_counter=0)
    held = FusionTracker(FusionSettings(compass=True, gps=True, hard_iron=UNCALIBRATED,
                                        compass_sigma_rad=math.radians(2.0)), last_counter=0)
    _walk_a_square(plain, iron)
    _walk_a_square(held, iron)
    assert plain.fusion.compass_rejected > 10 * max(held.fusion.compass_rejected, 1)
    true_heading = 23 * math.pi / 2  # 24 legs, 23 turns
    held_error = abs(math.remainder(held.heading - true_heading, 2 * math.pi))
    plain_error = abs(math.remainder(plain.heading - true_heading, 2 * math.pi))
    assert held_error < math.radians(3.0) and held_error < 0.5 * plain_error


def test_the_iron_prior_follows_the_calibration_and_the_option_reads_a_sigma(tmp_path, capsys):
    opts = AidOptions(compass=True, hard_iron="auto")
    assert opts.fusion_settings().hard_iron is UNCALIBRATED
    assert AidOptions(compass=True, hard_iron=HardIron(3.0)).fusion_settings().hard_iron == HardIron(3.0)
    with pytest.raises(SystemExit):
        main(["replay", str(tmp_path / "x.bin"), "--compass", "--hard-iron", "-2"], io.StringIO())
    assert "--hard-iron takes the prior" in capsys.readouterr().err
    calibrated = AidOptions(compass=True, hard_iron="auto", mag_calibration="cal.json")
    assert calibrated.fusion_settings().hard_iron is CALIBRATED
    assert CALIBRATED.sigma_ut < UNCALIBRATED.sigma_ut
