"""openshoe-host against a scripted module behind a pyserial URL (tests/hostlib/protocol_fakeshoe.py)."""

from __future__ import annotations

import io
import math
import threading

import pytest
import serial

from hostlib.cli import heading_deg, main
from hostlib.files.export import read_csv


@pytest.fixture(autouse=True)
def fakeshoe_scheme():
    serial.protocol_handler_packages.append("tests.hostlib")
    yield
    serial.protocol_handler_packages.remove("tests.hostlib")


def test_track_sums_steps_and_writes_files(tmp_path):
    out = io.StringIO()
    csv_path, png_path = tmp_path / "w.csv", tmp_path / "w.png"
    rc = main(["track", "fakeshoe://5", "--steps", "5", "--duration", "30", "--csv", str(csv_path),
               "--geojson", str(tmp_path / "w.geojson")], out)
    assert rc == 0
    text = out.getvalue()
    assert "packets     5 | steps     5" in text and "5.00 m" in text
    track = read_csv(csv_path)
    assert len(track) == 5 and track.final_pose[0] == pytest.approx(5.0)
    assert (tmp_path / "w.geojson").exists()
    assert not png_path.exists()


def test_track_and_log_stop_once_the_steps_asked_for_came(tmp_path, capsys):
    """--steps N ends a walk after the N-th step packet instead of at --duration: each command
    returns (waited for as an event, the guard far below the 600 s asked for) with at least N
    steps (a scripted module this fast sends the rest while the outputs go off); a count below 1
    is refused."""
    csv_path, raw = tmp_path / "w.csv", tmp_path / "cap.bin"
    for argv in (["track", "fakeshoe://50", "--steps", "3", "--duration", "600", "--csv", str(csv_path)],
                 ["log", "fakeshoe://50", "--raw", str(raw), "--start", "--steps", "3", "--duration", "600"]):
        done = threading.Thread(target=main, args=(argv, io.StringIO()), daemon=True)
        done.start()
        done.join(timeout=60.0)
        assert not done.is_alive(), f"{argv[0]} --steps 3 did not stop"
    assert len(read_csv(csv_path)) >= 3
    assert raw.read_bytes().count(bytes.fromhex("AA 00")) >= 3
    with pytest.raises(SystemExit) as exit_:
        main(["track", "fakeshoe://5", "--steps", "0"], io.StringIO())
    assert exit_.value.code == 2 and "step packets" in capsys.readouterr().err


def test_info_pings_and_reads_the_mcu_id():
    out = io.StringIO()
    assert main(["info", "fakeshoe://0"], out) == 0
    assert "10 11 12 13 14 15 16 17 18 19 1A 1B 1C 1D 1E" in out.getvalue()


def test_log_captures_raw_bytes(tmp_path):
    raw = tmp_path / "cap.bin"
    argv = ["log", "fakeshoe://3", "--raw", str(raw), "--start", "--steps", "3", "--duration", "30"]
    assert main(argv, io.StringIO()) == 0
    data = raw.read_bytes()
    assert data.startswith(bytes.fromhex("A0 34 00 D4"))
    assert data.count(b"\xaa") >= 3 and len(data) >= 4 + 3 * 64


def test_silent_port_fails_with_a_clear_message(capsys):
    assert main(["info", "loop://", "--ack-timeout", "0.05"], io.StringIO()) == 1
    assert "no ack" in capsys.readouterr().err


def test_info_against_the_emulator_url():
    pytest.importorskip("firmware_sim.transports.protocol_openshoe")
    out = io.StringIO()
    assert main(["info", "openshoe://?scenario=stand"], out) == 0
    assert "mcu id" in out.getvalue() and "(no answer)" not in out.getvalue()


def test_attach_does_not_restart_the_module(tmp_path):
    # Without 0x34 the scripted module sends nothing: attaching just listens (for 0.2 s: nothing
    # comes, whatever the clock, as the scripted module steps only after a 0x34 it never gets).
    from protocol.frames import build_command
    from protocol.ids import Command

    from .protocol_fakeshoe import PORTS

    out = io.StringIO()
    assert main(["track", "fakeshoe://3", "--attach", "--duration", "0.2", "--leave-running"], out) == 0
    assert "steps     0" in out.getvalue()
    sent = PORTS[-1].commands
    assert build_command(Command.STEPWISE_DEAD_RECKONING) not in sent, "attaching restarted the module"
    assert build_command(Command.OUTPUT_ALL_OFF) not in sent, "--leave-running switched the outputs off"


def test_initial_heading_rotates_the_track(tmp_path):
    csv_path = tmp_path / "w.csv"
    assert main(["track", "fakeshoe://2", "--steps", "2", "--duration", "30", "--heading", "90",
                 "--csv", str(csv_path)], io.StringIO()) == 0
    x, y, _, _ = read_csv(csv_path).final_pose
    assert x == pytest.approx(0.0, abs=1e-9) and y == pytest.approx(2.0)


def test_missing_device_path_fails_clearly(capsys):
    assert main(["info", "/dev/openshoe-does-not-exist"], io.StringIO()) == 1
    assert "cannot use /dev/openshoe-does-not-exist" in capsys.readouterr().err


def test_a_capture_replays_into_the_same_track(tmp_path):
    raw, live_csv = tmp_path / "cap.bin", tmp_path / "live.csv"
    argv = ["log", "fakeshoe://4", "--raw", str(raw), "--start", "--steps", "4", "--duration", "30"]
    assert main(argv, io.StringIO()) == 0
    out = io.StringIO()
    assert main(["replay", str(raw), "--csv", str(live_csv)], out) == 0
    track = read_csv(live_csv)
    assert len(track) == 4 and track.final_pose[0] == pytest.approx(4.0)
    assert "gaps 0" in out.getvalue()
    assert main(["replay", str(tmp_path / "nope.bin")], io.StringIO()) == 1


def test_track_to_a_file_writes_a_line_per_new_step_and_no_carriage_return():
    out = io.StringIO()  # not a terminal, like a log file
    assert main(["track", "fakeshoe://4", "--steps", "4", "--duration", "30"], out) == 0
    text = out.getvalue()
    assert "\r" not in text
    counts = [int(ln.split()[1]) for ln in text.splitlines() if ln.startswith("packets")]
    assert counts and counts[-1] == 4
    assert counts == sorted(set(counts)), "a new line only when the count changed"


def test_heading_is_shown_in_0_to_360_and_never_as_360():
    assert heading_deg(-0.0) == 0.0 and str(heading_deg(-0.0)) == "0.0"
    assert heading_deg(math.radians(359.96)) == 0.0
    assert heading_deg(-1e-9) == 0.0
    assert heading_deg(math.radians(-90.0)) == pytest.approx(270.0)
    assert f"{heading_deg(math.radians(-0.06)):5.1f}" == "359.9"


def test_track_with_the_module_errors_holds_them_live(tmp_path):
    """A live track with --module-errors sums the same steps; its covariance grows along the track."""
    out, csv_path = io.StringIO(), tmp_path / "w.csv"
    assert main(["track", "fakeshoe://5", "--steps", "5", "--duration", "30", "--module-errors", "0.01,0",
                 "--csv", str(csv_path)], out) == 0
    assert "module errors held" in out.getvalue()
    track = read_csv(csv_path)
    assert len(track) == 5 and track.final_pose[0] == pytest.approx(5.0)
    assert math.sqrt(track.final_covariance[0, 0]) >= 0.01 * 5.0 * 0.999  # 1 % of the 5 m walked
