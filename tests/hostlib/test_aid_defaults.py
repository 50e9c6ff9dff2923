"""The host's defaults: the module's errors (a MIMU22BT-class module's priors) with an aid or
without, and with their aid the compass's local deviation, the receiver's bias and, with one module,
the swing a calibrated compass gains as the module warms are held (the shoe's hard iron only when asked for);
each ``--no-…`` switch turns one off; the command line and the Python API resolve them in one
place (:meth:`hostlib.run.options.AidOptions.resolved`) and the ``aids:`` line says why each is on
or off."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

from hostlib.cli import main
from hostlib.cli.app import build_parser
from hostlib.cli.options import aid_options
from hostlib.files.export import read_csv
from hostlib.fusion.compass_swing import CALIBRATED_SWING, WARMING_SWING
from hostlib.fusion.deviation import INDOORS, OUTDOORS
from hostlib.fusion.gps_bias import GpsBias
from hostlib.fusion.hard_iron import CALIBRATED, UNCALIBRATED, HardIron
from hostlib.fusion.module_errors import EMULATED_MODULE_SWAYING, MIMU22BT, ModuleErrors
from hostlib.run.aid_setup import feet_tracker, prepare_aids
from hostlib.run.options import AUTO, AidOptions

from .loops import fusion_capture, rectangle


def _resolved(options: AidOptions, feet: bool = False) -> tuple:
    r = options.resolved(feet)
    return r.module_errors, r.compass_deviation, r.gps_bias


def test_the_defaults_hold_what_the_walk_has():
    """With no aid one module holds its errors (its covariance honest, the steps where they are); the
    compass holds them and a building's deviation; GPS the module's errors and the receiver's bias;
    both, the open ground's deviation; two feet, each module's errors. The shoe's hard iron is
    learned only when asked for, its prior by the calibration."""
    assert AidOptions().module_errors == AUTO and AidOptions().uses_aids
    assert _resolved(AidOptions()) == (MIMU22BT, None, None)
    assert not AidOptions(module_errors=None).uses_aids  # the plain step sum
    assert _resolved(AidOptions(), feet=True) == (MIMU22BT, None, None)
    assert _resolved(AidOptions(compass=True)) == (MIMU22BT, INDOORS, None)
    assert _resolved(AidOptions(gps_log="walk.nmea")) == (MIMU22BT, None, GpsBias())
    both = AidOptions(compass=True, gps_receiver="socket://gps:1")
    assert _resolved(both) == (MIMU22BT, OUTDOORS, GpsBias())
    assert _resolved(AidOptions(compass=True), feet=True) == (MIMU22BT, INDOORS, None)
    assert AidOptions(compass=True).resolved().hard_iron is None
    assert AidOptions(compass=True, hard_iron=AUTO).resolved().hard_iron is UNCALIBRATED
    calibrated = AidOptions(compass=True, hard_iron=AUTO, mag_calibration="c.json")
    assert calibrated.resolved().hard_iron is CALIBRATED
    settings = AidOptions(compass=True, gps_log="walk.nmea").fusion_settings()
    assert (settings.module_errors, settings.compass_deviation, settings.gps_bias) == (MIMU22BT, OUTDOORS,
                                                                                       GpsBias())
    assert settings.hard_iron is None
    assert settings.compass_sigma_rad == pytest.approx(math.radians(1.5))  # the deviation is a state
    assert settings.gps_update_interval_s == 0.0  # with the bias held, every fix
    assert settings.compass_swing is WARMING_SWING and not WARMING_SWING.learned
    assert AidOptions(compass=True).resolved(feet=True).compass_swing is None  # one module's only
    assert AidOptions(gps_log="walk.nmea").resolved().compass_swing is None  # a compass's


def test_none_turns_a_default_off_and_a_word_or_a_model_chooses_another():
    options = AidOptions(compass=True, gps_log="walk.nmea", module_errors=None, compass_deviation=None,
                         gps_bias=None)
    assert _resolved(options) == (None, None, None)
    assert options.fusion_settings().compass_sigma_rad == pytest.approx(math.radians(20.0))
    chosen = AidOptions(compass=True, module_errors="emulated", compass_deviation="indoors")
    assert _resolved(chosen)[:2] == (EMULATED_MODULE_SWAYING, INDOORS)
    own = ModuleErrors(0.001, 0.002)
    assert AidOptions(module_errors=own).uses_aids  # given, the errors are held without an aid
    assert _resolved(AidOptions(module_errors=own))[0] is own
    with pytest.raises(ValueError, match="gps_bias"):
        AidOptions(gps_log="walk.nmea", gps_bias="yes").resolved()


def test_the_reasons_say_what_is_held_by_default_given_or_turned_off():
    options = AidOptions(compass=True, gps_log="walk.nmea", gps_bias=None, module_errors="emulated")
    assert options.defaulted() == {"module_errors": "given", "compass_deviation": "by default",
                                   "gps_bias": "off", "compass_swing": "by default"}
    assert AidOptions().defaulted() == {"module_errors": "by default"}
    assert AidOptions(module_errors=None).defaulted() == {"module_errors": "off"}
    assert AidOptions().defaulted(feet=True) == {"module_errors": "by default"}


OFF = {"module_errors": None, "compass_deviation": None, "gps_bias": None, "compass_swing": None}
#: ``replay``'s options, and the AidOptions a user of the API writes for the same walk
CASES = [
    ([], {}),
    (["--compass"], {"compass": True, "saved_calibration": True}),
    (["--gps", "walk.nmea"], {"gps_log": "walk.nmea"}),
    (["--compass", "--gps", "walk.nmea"],
     {"compass": True, "saved_calibration": True, "gps_log": "walk.nmea"}),
    (["--compass", "--gps", "walk.nmea", "--no-module-errors", "--no-compass-deviation", "--no-gps-bias",
      "--no-compass-swing"],
     {"compass": True, "saved_calibration": True, "gps_log": "walk.nmea", **OFF}),
    (["--compass", "--gps", "walk.nmea", "--module-errors", "emulated", "--compass-deviation", "indoors",
      "--hard-iron", "3", "--gps-bias"],
     {"compass": True, "saved_calibration": True, "gps_log": "walk.nmea", "module_errors": "emulated",
      "compass_deviation": "indoors", "hard_iron": HardIron(3.0), "gps_bias": GpsBias()}),
    (["--compass", "--gps", "walk.nmea", "--compass-swing"],
     {"compass": True, "saved_calibration": True, "gps_log": "walk.nmea", "compass_swing": CALIBRATED_SWING}),
    (["--compass", "--no-compass-deviation", "--compass-sigma", "5", "--hard-iron"],
     {"compass": True, "saved_calibration": True, "compass_deviation": None, "compass_sigma_deg": 5.0,
      "hard_iron": AUTO}),
]


@pytest.mark.parametrize(("argv", "api"), CASES, ids=lambda a: " ".join(a) if isinstance(a, list) else "")
@pytest.mark.parametrize("feet", [False, True], ids=["one module", "two feet"])
def test_the_command_line_and_the_python_api_resolve_the_same_settings(argv, api, feet):
    """What ``replay`` makes of its options is what the same AidOptions, written with the API's
    own defaults, resolve to: one place decides."""
    captures = ["a.bin", "b.bin"] if feet else ["a.bin"]
    cli = aid_options(build_parser().parse_args(["replay", *captures, *argv]), None)
    options = AidOptions(**api)
    assert cli.fusion_settings(feet) == options.fusion_settings(feet)
    assert cli.defaulted(feet) == options.defaulted(feet)
    assert cli.resolved(feet).uses_aids == options.resolved(feet).uses_aids


@pytest.mark.parametrize("name", ["module-errors", "compass-deviation", "gps-bias", "compass-swing"])
def test_a_model_and_its_off_switch_together_are_refused(name, capsys):
    value = {"module-errors": ["emulated"], "compass-deviation": ["indoors"], "gps-bias": [],
             "compass-swing": []}[name]
    argv = ["replay", "a.bin", "--compass", "--gps", "walk.nmea", f"--{name}", *value, f"--no-{name}"]
    assert main(argv, io.StringIO()) == 2
    assert f"--{name} or --no-{name}: one or the other" in capsys.readouterr().err


def test_the_aids_line_says_what_is_held_by_default_and_what_was_turned_off():
    held = prepare_aids(compass=True, gps_receiver="socket://gps:1").describe()
    assert "local deviation held by default (outdoors: σ 3° over 9 m)" in held
    assert "GPS receiver's bias held by default (σ 2.1 m per axis" in held
    assert "hard iron" not in held
    assert "a calibrated compass's swing held by default (σ 0.6° on B sin ψ + C cos ψ grown as the module " \
           "warms (τ 120 s), weighed, not learned, while it reads with a calibration)" in held
    assert "module errors held by default (mimu22bt): step-length scale σ 0.0013, climb σ 0.002 m/m" in held
    off = prepare_aids(compass=True, gps_receiver="socket://gps:1", **OFF).describe()
    for text in ("local deviation not held (off: --no-compass-deviation)",
                 "GPS receiver's bias not held (off: --no-gps-bias)",
                 "module errors not held (off: --no-module-errors)",
                 "a calibrated compass's swing not held (off: --no-compass-swing)"):
        assert text in off
    assert "by default" not in off and "compass σ 20° per step" in off
    given = prepare_aids(compass=True, compass_deviation="indoors", module_errors="emulated",
                         compass_swing=CALIBRATED_SWING).describe()
    assert "local deviation held (indoors: σ 20° over 0.5 m)" in given
    assert ("a calibrated compass's swing held (σ 4° on B sin ψ + C cos ψ, learned from the headings and, "
            "with a place, the levelled field's inclination, while it reads") in given
    assert "module errors held (emulated)" in given and "by default" not in given


def test_two_feet_hold_each_modules_errors_by_default_and_the_plain_fusion_without_them():
    tracker, aids = feet_tracker(AidOptions())
    assert aids is not None and tracker.aids.module_errors == MIMU22BT
    assert tracker.module_errors("left") == (0.0,) * MIMU22BT.states
    assert "module errors held by default (mimu22bt)" in aids.describe()
    plain, none = feet_tracker(AidOptions(module_errors=None))
    assert none is None and plain.aids.module_errors is None


@pytest.mark.parametrize("setup", [True, False], ids=["fusion set-up", "plain step packets"])
def test_one_module_without_an_aid_holds_its_errors_and_leaves_every_pose_where_it_was(tmp_path, setup):
    """``replay`` of one module with no aid holds a MIMU22BT-class module's errors by default: every
    pose is where the plain step sum puts it (``--no-module-errors``), the height's 1σ grows by the
    climb over the path, and the ``aids:`` line says what is held and why; plain step packets carry
    no module time, so it says the warm-up was not counted."""
    capture = tmp_path / "walk.bin"
    capture.write_bytes(fusion_capture(rectangle((0.0, 0.0, 0.0)), b"OSEMU-M00000003", with_setup=setup))
    plain_csv, held_csv = tmp_path / "plain.csv", tmp_path / "held.csv"
    plain_out, held_out = io.StringIO(), io.StringIO()
    assert main(["replay", str(capture), "--no-module-errors", "--csv", str(plain_csv)], plain_out) == 0
    assert main(["replay", str(capture), "--csv", str(held_csv)], held_out) == 0
    assert "aids:" not in plain_out.getvalue()
    text = held_out.getvalue()
    assert ("aids: no compass or GPS; module errors held by default (mimu22bt): "
            "step-length scale σ 0.0013, climb σ 0.002 m/m") in text
    assert ("warm-up not counted: no step carried the module's time" in text) is not setup
    assert "fusion:" not in text  # no aid, nothing it did
    plain, held = read_csv(plain_csv), read_csv(held_csv)
    np.testing.assert_array_equal(held.poses, plain.poses)
    path = float(np.hypot(*held.steps[:, :2].T).sum())
    assert held.covariances[-1, 2, 2] == pytest.approx(plain.covariances[-1, 2, 2]
                                                       + (MIMU22BT.climb_sigma * path) ** 2, rel=1e-6)


def test_the_replay_of_one_module_with_the_compass_holds_the_defaults(tmp_path):
    capture = tmp_path / "walk.bin"
    capture.write_bytes(fusion_capture(rectangle((0.0, 0.0, 0.0)), b"OSEMU-M00000003"))
    out = io.StringIO()
    assert main(["replay", str(capture), "--compass", "--declination", "0", "--mag-cal-dir", str(tmp_path)],
                out) == 0
    text = out.getvalue()
    assert "local deviation held by default (indoors" in text and "module errors held by default" in text
    assert "local deviation at the end" in text and "hard iron" not in text


def test_the_mimu22bt_priors_are_the_datasheets_arithmetic():
    """Not fitted to any walk: a factory calibration leaves ±0.45 % of the ±3 % sensitivity
    tolerance, uniform (÷√3), over four averaged dies (÷√4); the module paper's height errors up to
    0.5 % over fifty walks (≈ 2.3σ); the gyro offset's ±0.02 °/s/°C, uniform, over four dies, times
    the 8 °C warm-up."""
    scale = 0.0045 / math.sqrt(3.0) / math.sqrt(4.0)
    assert MIMU22BT.step_scale_sigma == pytest.approx(scale, rel=0.01)
    assert MIMU22BT.turn_scale_sigma == pytest.approx(scale, rel=0.01)
    assert MIMU22BT.climb_sigma == pytest.approx(0.005 / 2.3, rel=0.1)
    warmup = math.radians(0.02 / math.sqrt(3.0) / math.sqrt(4.0) * 8.0)
    assert MIMU22BT.heading_warmup_sigma == pytest.approx(warmup, rel=1e-3)
    assert MIMU22BT.warmup_tau_s == 120.0 and not MIMU22BT.holds_drift
    assert ModuleErrors.parse("MIMU22BT") is MIMU22BT
    assert np.isclose(MIMU22BT.prior[3, 3], warmup ** 2, rtol=2e-3)
