"""openshoe-host with a module on each foot: two captures replayed and fused into the body's track,
two devices tracked live; a foot that loses its link (or 30 s of its packets) never stops the
fusion."""

from __future__ import annotations

import io
import re
import time

import numpy as np
import pytest
import serial

from hostlib.calibration.drift import DriftCalibration
from hostlib.cli import main
from hostlib.errors import DeviceClosed
from hostlib.files.export import read_csv, read_feet_csv
from hostlib.files.replay import replay_feet
from hostlib.fusion.feet import FOOT_SIDES, STALE_AFTER_STEPS, TwoFeetTracker
from hostlib.fusion.module_errors import MIMU22BT
from hostlib.link.device import Device
from hostlib.run.aid_setup import feet_tracker
from hostlib.run.options import AidOptions

from . import protocol_fakeshoe
from .link_outage import drop_packets
from .test_feet_csv import upper

#: About 45 s: long enough to lose 30 s of one foot's packets in the middle.
SCENARIO = "stand:3+walk:60+stand:2"


@pytest.fixture(scope="module")
def captures(tmp_path_factory) -> dict[str, str]:
    """Side → capture file of the module on that foot (the emulator, with the fusion set-up)."""
    from firmware_sim.app.batch import run_replay
    from firmware_sim.mcu.module import ModuleConfig
    from firmware_sim.sensors.feet import foot_module
    from firmware_sim.sensors.imu_array import make_feet_sources
    from firmware_sim.transports.factory import module_serial

    folder = tmp_path_factory.mktemp("feet")
    paths = {}
    for side, source in make_feet_sources(SCENARIO, seed=1).items():
        path = folder / f"{side}.bin"
        config = ModuleConfig(rate_hz=float(source.rate_hz), mcu_serial=module_serial(foot_module(1, side)))
        path.write_bytes(bytes(run_replay(source, config=config, announce=None, host="fusion")))
        paths[side] = str(path)
    return paths


def _drift_file(folder, side: str, dv=(0.0, 0.1, 0.0), module: int | None = None) -> str:
    """A drift calibration of the module on *side* (or of module *module*)."""
    from firmware_sim.sensors.feet import foot_module
    from firmware_sim.transports.factory import module_serial

    serial = module_serial(foot_module(1, side) if module is None else module)
    path = folder / f"drift-{side}-{module}.json"
    DriftCalibration(dv, 100.0, 100, 1, serial).save(path)
    return str(path)


def _fused(left: str, right: str, options: AidOptions | None = None) -> TwoFeetTracker:
    """The fusion `replay LEFT RIGHT` makes, from the library: with *options*' aids (default: the
    defaults, each module's errors held), or None: the plain tracker."""
    tracker = feet_tracker(options or AidOptions(), defer=True)[0]
    with open(left, "rb") as fl, open(right, "rb") as fr:
        return replay_feet(fl.read(), fr.read(), tracker=tracker)[0]


_SUMMARY = re.compile(r"^(left foot|right foot|fusion|body \((?:fused|average)\))")


def _lines(text: str) -> dict[str, str]:
    """The summary's lines by what they start with (``left foot``, ``fusion``, ``body (fused)``…)."""
    return {m.group(1): line for line in text.splitlines() if (m := _SUMMARY.match(line))}


# -- replay ---------------------------------------------------------------------------------


def test_two_captures_give_the_body_at_the_feet_midpoint_and_each_foot_in_its_columns(captures, tmp_path):
    out, csv_path = io.StringIO(), tmp_path / "feet.csv"
    argv = ["replay", captures["left"], captures["right"], "--csv", str(csv_path),
            "--geojson", str(tmp_path / "feet.geojson")]
    assert main(argv, out) == 0
    tracker = _fused(captures["left"], captures["right"])
    assert tracker.stale_steps == 0  # both feet all the way: the body is their midpoint in every row
    feet = read_feet_csv(csv_path)
    mid = 0.5 * (feet.feet["left"] + feet.feet["right"])
    assert np.allclose(feet.body.poses, mid, rtol=0, atol=1e-12)
    body = read_csv(csv_path)
    expected = tracker.body
    assert np.array_equal(body.poses, expected.poses)
    assert np.array_equal(upper(body.covariances), upper(expected.covariances))
    assert np.array_equal(body.counters, expected.counters) and body.gaps == []
    assert feet.sides == tuple(tracker.sides)
    assert sorted(set(feet.sides)) == ["left", "right"]
    for side in FOOT_SIDES:
        assert np.array_equal(feet.feet[side], tracker.fused_foot(side))
        assert np.array_equal(feet.sigmas[side], tracker.fused_foot_sigmas(side))
    lines = _lines(out.getvalue())
    assert lines["left foot"].startswith(f"left foot ({captures['left']}): 44 step packets")
    assert lines["right foot"].startswith(f"right foot ({captures['right']}): 44 step packets")
    assert "gaps 0 (missing 0)" in lines["left foot"] and "duplicates 0" in lines["right foot"]
    assert "fusion: 88 steps (left 44, right 44)" in lines["fusion"]
    assert "restarts: none" in lines["fusion"]
    x = expected.final_pose[0]
    assert f"x {x:+8.2f}" in lines["body (fused)"] and "body (average)" in lines
    assert (tmp_path / "feet.geojson").stat().st_size > 0


def test_two_captures_hold_each_modules_errors_by_default_and_without_them_are_the_plain_fusion(
        captures, tmp_path):
    """Two feet hold each module's errors by default (the MIMU22BT's priors), as the library's
    defaults do; --no-module-errors gives the plain two-feet tracker, bit for bit."""
    out, csv_path = io.StringIO(), tmp_path / "feet.csv"
    assert main(["replay", captures["left"], captures["right"], "--csv", str(csv_path)], out) == 0
    assert "aids: no compass or GPS; module errors held by default (mimu22bt)" \
        in out.getvalue()
    tracker = _fused(captures["left"], captures["right"])
    assert tracker.aids.module_errors == MIMU22BT and tracker.module_errors("left") is not None
    out, plain_csv = io.StringIO(), tmp_path / "plain.csv"
    argv = ["replay", captures["left"], captures["right"], "--no-module-errors", "--csv", str(plain_csv)]
    assert main(argv, out) == 0
    assert "aids:" not in out.getvalue()
    with open(captures["left"], "rb") as fl, open(captures["right"], "rb") as fr:
        plain = replay_feet(fl.read(), fr.read())[0]
    body = read_csv(plain_csv)
    assert np.array_equal(body.poses, plain.body.poses)
    assert np.array_equal(upper(body.covariances), upper(plain.body.covariances))
    held = read_csv(csv_path)
    assert not np.array_equal(upper(held.covariances), upper(body.covariances))  # the errors' growth


def test_a_foot_missing_30_s_of_packets_is_a_gap_on_that_foot_and_the_body_goes_on_to_the_end(
        captures, tmp_path):
    with open(captures["right"], "rb") as fh:
        cut, dropped = drop_packets(fh.read(), 10.0, 40.0)
    assert dropped >= 25
    right = tmp_path / "right-cut.bin"
    right.write_bytes(cut)
    out, csv_path = io.StringIO(), tmp_path / "feet.csv"
    assert main(["replay", captures["left"], str(right), "--csv", str(csv_path)], out) == 0
    lines = _lines(out.getvalue())
    assert f"gaps 1 (missing {dropped})" in lines["right foot"]
    assert "gaps 0 (missing 0)" in lines["left foot"]
    assert "restarts: right at fused step" in lines["fusion"]
    intact = _fused(captures["left"], captures["right"])
    body = read_csv(csv_path)
    assert len(body) == 2 * 44 - dropped
    assert np.hypot(*(body.final_pose[:2] - intact.body.final_pose[:2])) < 1.0
    average = _fused(captures["left"], str(right)).average
    assert np.hypot(*(average.final_pose[:2] - intact.body.final_pose[:2])) > 10.0  # the baseline lost it


def test_without_the_constraint_the_body_is_the_average_and_gamma_is_an_option(captures):
    out = io.StringIO()
    assert main(["replay", captures["left"], captures["right"], "--no-constraint"], out) == 0
    lines = _lines(out.getvalue())
    assert "constraint off" in lines["fusion"]
    assert lines["body (fused)"].split(":", 1)[1].strip() == lines["body (average)"].split(":", 1)[1].strip()
    out = io.StringIO()
    assert main(["replay", captures["left"], captures["right"], "--max-separation", "1.5"], out) == 0
    assert "constraint γ 1.50 m" in out.getvalue()


def test_the_png_shows_the_body_and_both_feet(captures, tmp_path):
    pytest.importorskip("matplotlib")
    png = tmp_path / "feet.png"
    assert main(["replay", captures["left"], captures["right"], "--png", str(png)], io.StringIO()) == 0
    assert png.read_bytes().startswith(b"\x89PNG")


def test_two_captures_with_the_compass_turn_both_feet_onto_magnetic_north(captures):
    out = io.StringIO()
    assert main(["replay", captures["left"], captures["right"], "--compass", "--declination", "6"], out) == 0
    text = out.getvalue()
    assert ("aids: compass σ 1.5° per step, local deviation held by default (indoors: σ 20° over 0.5 m); "
            "readings beyond 3σ of their innovation rejected; the readings' field not checked") in text
    assert ("in quadrature with the local deviation's σ; declination +6.00° (given); "
            "module errors held by default (mimu22bt)") in text
    assert "hard iron" not in text  # not by default with two feet
    updates = int(re.search(r"fusion: (\d+) compass updates", text).group(1))
    assert updates > 60 and "heading aligned by compass" in text
    plain = _fused(captures["left"], captures["right"]).body.final_pose
    # the module starts facing 0 whichever way the walker faces; the compass says where that is
    assert lines_heading(text) != pytest.approx(plain[3] % (2 * np.pi), abs=1e-6)


def lines_heading(text: str) -> float:
    """The fused body's end heading [rad] in a two-feet summary."""
    return np.radians(float(re.search(r"body \(fused\):.*heading\s+([\d.]+)°", text).group(1)))


def test_two_captures_with_gps_fixes_of_the_body_count_their_updates(captures, tmp_path):
    from firmware_sim.sensors import scenarios
    from firmware_sim.sensors.gps import simulate_fixes, write_nmea

    t = np.arange(0.0, 70.0, 0.1)
    pos = scenarios.feet(SCENARIO).body(t)[0]  # the receiver on the walker, on the modules' clock
    nmea = write_nmea(tmp_path / "body.nmea", simulate_fixes(t, pos, np.gradient(pos, t, axis=0), seed=2))
    out, geojson = io.StringIO(), tmp_path / "body.geojson"
    argv = ["replay", captures["left"], captures["right"], "--gps", str(nmea), "--geojson", str(geojson)]
    assert main(argv, out) == 0
    text = out.getvalue()
    assert re.search(r"fusion: \d+ compass updates .*, ([1-9]\d*) GPS updates", text)
    assert "heading aligned by gps" in text and "NMEA lines" in text
    assert '"crs": "local-enu-m"' not in geojson.read_text()  # placed on the globe at the first fix


def test_each_foots_drift_calibration_moves_only_that_foot(captures, tmp_path):
    both, left_only = io.StringIO(), io.StringIO()
    files = [_drift_file(tmp_path, side) for side in FOOT_SIDES]
    base = ["replay", captures["left"], captures["right"], "--no-constraint"]
    assert main([*base, "--drift", *files], both) == 0
    assert main([*base, "--drift", files[0], "-"], left_only) == 0
    plain = _fused(captures["left"], captures["right"]).body.final_pose
    assert "drift correction, left foot: Δv = [+0.00000, +0.10000, +0.00000] m/s" in both.getvalue()
    assert "drift correction, right foot" in both.getvalue()
    assert "drift correction, right foot" not in left_only.getvalue()
    end = {name: float(re.search(r"body \(fused\):.*y\s+([-+][\d.]+)", out.getvalue()).group(1))
           for name, out in (("both", both), ("left", left_only))}
    # each foot moves east by 0.1 m/s times its swing time; the body by half of that per foot
    assert end["both"] - plain[1] > 1.0
    assert end["left"] - plain[1] == pytest.approx(0.5 * (end["both"] - plain[1]), rel=0.1)


def test_drift_calibrations_given_in_the_wrong_order_are_refused_as_swapped(captures, tmp_path, capsys):
    files = [_drift_file(tmp_path, side) for side in ("right", "left")]
    assert main(["replay", captures["left"], captures["right"], "--drift", *files], io.StringIO()) == 1
    err = capsys.readouterr().err
    assert "the left foot" in err and "not for module OSEMU-M00000002" in err
    assert "it fits the right foot's module: give the left foot's calibration first" in err
    other = _drift_file(tmp_path, "left", module=7)
    assert main(["replay", captures["left"], captures["right"], "--drift", other, "-"], io.StringIO()) == 1
    assert "fits" not in capsys.readouterr().err


def test_a_magnetometer_calibration_per_foot_is_checked_against_that_foots_module(captures, tmp_path, capsys):
    from hostlib.calibration.magcal import MagCalibration

    cal = tmp_path / "mag.json"
    MagCalibration(np.zeros(3), np.eye(3), module_serial="OSEMU-M00000003").save(cal)
    base = ["replay", captures["left"], captures["right"], "--compass"]
    out = io.StringIO()
    assert main([*base, "--mag-cal", "-", str(cal)], out) == 0
    assert "(calibrated: right foot)" in out.getvalue()
    assert main([*base, "--mag-cal", str(cal), "-"], io.StringIO()) == 1
    assert "the left foot" in capsys.readouterr().err


def test_two_captures_with_the_compass_take_each_modules_saved_magnetometer_calibration(captures, tmp_path):
    from hostlib.calibration.magcal import MagCalibration, save_for_module

    saved = save_for_module(MagCalibration(np.zeros(3), np.eye(3), module_serial="OSEMU-M00000003"), tmp_path)
    out = io.StringIO()
    assert main(["replay", captures["left"], captures["right"], "--compass", "--mag-cal-dir", str(tmp_path)],
                out) == 0
    assert f"(calibrated: right foot, saved {saved})" in out.getvalue(), "none saved for the left module"


@pytest.mark.parametrize("option", ["--drift", "--mag-cal"])
def test_a_per_module_calibration_takes_one_file_per_foot(captures, capsys, option):
    assert main(["replay", captures["left"], captures["right"], option, "a.json"], io.StringIO()) == 2
    assert f"{option} takes one file per module with two captures" in capsys.readouterr().err
    assert main(["replay", captures["left"], option, "a.json", "b.json"], io.StringIO()) == 2
    assert f"{option} takes one file with one capture" in capsys.readouterr().err


@pytest.mark.parametrize("options", [["--no-constraint"], ["--max-separation", "1.5"]])
def test_two_feet_options_with_one_capture_are_refused(captures, capsys, options):
    assert main(["replay", captures["left"], *options], io.StringIO()) == 2
    assert "needs two captures" in capsys.readouterr().err


def test_a_missing_second_capture_is_named(captures, tmp_path, capsys):
    missing = str(tmp_path / "nope.bin")
    assert main(["replay", captures["left"], missing], io.StringIO()) == 1
    assert missing in capsys.readouterr().err


# -- live -----------------------------------------------------------------------------------


@pytest.fixture
def fakeshoe_scheme():
    serial.protocol_handler_packages.append("tests.hostlib")
    protocol_fakeshoe.PORTS.clear()
    yield protocol_fakeshoe.PORTS
    serial.protocol_handler_packages.remove("tests.hostlib")


def test_track_with_two_devices_acks_each_stream_and_fuses_both_feet(fakeshoe_scheme, tmp_path):
    out, csv_path = io.StringIO(), tmp_path / "live.csv"
    # two modules of four steps each (serial numbers apart); the run stops on the steps, not a clock
    left, right = "fakeshoe://4", "fakeshoe://4/module2"
    argv = ["track", left, right, "--steps", "4", "--duration", "30", "--csv", str(csv_path)]
    assert main(argv, out) == 0
    ports = {p.port: p for p in fakeshoe_scheme}
    # each module's four step packets and the serial number packet the fusion set-up asks for
    assert sorted(set(ports[left].packet_acks)) == [1, 2, 3, 4, 5]
    assert sorted(set(ports[right].packet_acks)) == [1, 2, 3, 4, 5]
    text = out.getvalue()
    live = [line for line in text.splitlines() if line.startswith("left ") and "| body x" in line]
    # the live line shows both feet; the last one counts every step
    assert live and re.search(r"left +4/ +4 steps", live[-1])
    assert re.search(r"right +4/ +4 steps", live[-1])
    lines = _lines(text)
    assert lines["left foot"].startswith(f"left foot ({left}): 4 step packets")
    assert lines["right foot"].startswith(f"right foot ({right}): 4 step packets")
    feet = read_feet_csv(csv_path)
    assert feet.sides.count("left") == 4 and feet.sides.count("right") == 4
    assert len(feet.body) == 8  # the joint filter took every step of both, in arrival order


def test_track_goes_on_with_one_foot_when_the_other_foots_link_is_lost(fakeshoe_scheme, tmp_path, capsys):
    out, csv_path = io.StringIO(), tmp_path / "live.csv"
    # the run stops once the foot still walking has all its six steps: the left foot, back on a
    # re-opened port that stays silent, is not waited for until the duration is over
    argv = ["track", "fakeshoe://6/drop2", "fakeshoe://6", "--steps", "6", "--duration", "30",
            "--csv", str(csv_path)]
    started = time.monotonic()
    assert main(argv, out) == 0
    assert time.monotonic() - started < 15.0  # ended on its step count, not after the 30 s
    err = capsys.readouterr().err
    assert "the left foot (fakeshoe://6/drop2): link lost" in err
    lines = _lines(out.getvalue())
    assert "2 step packets" in lines["left foot"] and "6 step packets" in lines["right foot"]
    feet = read_feet_csv(csv_path)
    assert feet.sides.count("right") == 6
    after_left = len(feet.sides) - 1 - max(k for k, side in enumerate(feet.sides) if side == "left")
    assert after_left >= STALE_AFTER_STEPS  # the left foot went quiet early (its module starts first)
    assert np.array_equal(feet.body.final_pose, feet.feet["right"][-1])  # the body follows the walking foot


def test_track_goes_on_when_one_devices_walk_fails_and_stops_when_both_do(fakeshoe_scheme, monkeypatch,
                                                                         tmp_path, capsys):
    recv_step = Device.recv_step
    failing: set[str] = set()

    def recv_step_or_fail(self, timeout=None):
        if self.name in failing and len(self.track) >= 2:
            raise DeviceClosed(f"{self.name} is closed")
        return recv_step(self, timeout)

    monkeypatch.setattr(Device, "recv_step", recv_step_or_fail)
    failing.add("fakeshoe://3")
    csv_path = tmp_path / "live.csv"
    argv = ["track", "fakeshoe://3", "fakeshoe://5", "--steps", "5", "--duration", "30", "--csv",
            str(csv_path)]
    assert main(argv, io.StringIO()) == 0
    assert "the left foot (fakeshoe://3): fakeshoe://3 is closed; tracking goes on without it" in \
        capsys.readouterr().err
    assert read_feet_csv(csv_path).sides.count("right") == 5
    failing.add("fakeshoe://5")
    assert main(["track", "fakeshoe://3", "fakeshoe://5", "--duration", "30"], io.StringIO()) == 1


def test_track_with_two_devices_corrects_each_foots_drift(fakeshoe_scheme, tmp_path):
    cal = tmp_path / "drift.json"
    DriftCalibration((0.0, 0.2, 0.0), 100.0, 100, 1, protocol_fakeshoe.MCU_ID).save(cal)
    csv_path = tmp_path / "live.csv"
    argv = ["track", "fakeshoe://4/fusion", "fakeshoe://4/fusion", "--fusion", "--steps", "4",
            "--duration", "30",
            "--drift", str(cal), str(cal), "--no-constraint", "--csv", str(csv_path)]
    assert main(argv, io.StringIO()) == 0
    feet = read_feet_csv(csv_path).feet
    # four steps of 1 m north a foot, each moved 0.2 m/s · 0.5 s east
    east = 4 * 0.2 * protocol_fakeshoe.SWING_TIME_S
    assert feet["left"][-1][:2] == pytest.approx([4.0, -0.06 + east], abs=1e-6)
    assert feet["right"][-1][:2] == pytest.approx([4.0, 0.06 + east], abs=1e-6)


def test_track_refuses_another_modules_drift_calibration_for_a_foot(fakeshoe_scheme, tmp_path, capsys):
    cal = tmp_path / "drift.json"
    DriftCalibration((0.0, 0.2, 0.0), 100.0, 100, 1, b"ANOTHER-MODULE-").save(cal)
    argv = ["track", "fakeshoe://4/fusion", "fakeshoe://4/fusion", "--fusion", "--steps", "4",
            "--duration", "30",
            "--drift", "-", str(cal)]
    assert main(argv, io.StringIO()) == 1
    assert "the right foot (fakeshoe://4/fusion): drift calibration" in capsys.readouterr().err


def test_track_with_two_devices_needs_the_fusion_set_up_for_drift(fakeshoe_scheme, capsys):
    argv = ["track", "fakeshoe://3", "fakeshoe://3", "--no-fusion", "--drift", "a.json", "b.json"]
    assert main(argv, io.StringIO()) == 2
    assert "--drift needs the fusion set-up, which --no-fusion turns off" in capsys.readouterr().err
    assert fakeshoe_scheme == []  # refused before any port opened


def test_track_with_two_devices_starts_the_feet_facing_the_initial_heading(fakeshoe_scheme, tmp_path):
    csv_path = tmp_path / "live.csv"
    argv = ["track", "fakeshoe://1", "fakeshoe://1", "--steps", "1", "--duration", "30", "--heading", "90",
            "--csv",
            str(csv_path)]
    assert main(argv, io.StringIO()) == 0
    feet = read_feet_csv(csv_path)
    assert feet.feet["left"][0][:2] == pytest.approx([0.06, 0.0])  # facing east, the left foot is north
    assert feet.feet["right"][0][:2] == pytest.approx([-0.06, 0.0])
