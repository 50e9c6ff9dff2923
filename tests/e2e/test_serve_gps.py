"""`openshoe-emu serve --gps-pty` as a real subprocess: the receiver's pty in the READY line, GGA and
RMC that pynmea2 parses, each fix written once the module's clock reached it, one a second of module
time; and `openshoe-host track --fusion --compass --gps PTY` walking the served scenario, with one
module and with a module on each foot (`serve --feet 2`: the receiver on the body).

Real time (a subprocess paced at a few times real time): every wait is on bytes or events with a
deadline, never a fixed sleep; no assertion is on how long something took.
"""

from __future__ import annotations

import datetime as dt
import io
import re
import socket
import sys

import pynmea2
import pytest
import serial

from firmware_sim.app.serve import spawn
from firmware_sim.sensors.gps import DEFAULT_ORIGIN, DEFAULT_START
from hostlib.cli import main
from hostlib.files.export import CSV_COLUMNS, GEO_COLUMNS, read_csv

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="ptys are tested on Linux")

RECIPE = "stand:3+walk:40+stand:3"
SPEED = "8"  # module seconds per wall second


def _virtual_s(address: str) -> float:
    """The module's clock, from the control channel's status line (``t=…s``)."""
    host, port = address.rsplit(":", 1)
    with socket.create_connection((host, int(port)), timeout=5) as c:
        f = c.makefile("rw", encoding="utf-8", newline="\n")
        f.write("status\n")
        f.flush()
        line = f.readline()
    return float(line.split("t=", 1)[1].split("s", 1)[0])


def _fix_seconds(msg) -> float:
    """Module time of a sentence: its UTC after the receiver's start (the module's power-on)."""
    stamp = dt.datetime.combine(DEFAULT_START.date(), msg.timestamp.replace(tzinfo=None))
    return (stamp - DEFAULT_START.replace(tzinfo=None)).total_seconds()


def test_the_served_receiver_writes_each_fix_once_the_module_clock_reached_it(tmp_path):
    with spawn("--scenario", RECIPE, "--pty", str(tmp_path / "shoe"), "--gps-pty", str(tmp_path / "gps"),
               "--control", "0", "--speed", SPEED, "--status-interval", "0") as srv:
        assert srv.ready["gps-pty"] == str(tmp_path / "gps") and "bt-pty" in srv.ready
        times = []
        with serial.Serial(srv.ready["gps-pty"], timeout=5) as gps:
            while len(times) < 6:
                line = gps.readline().decode("ascii")
                assert line.endswith("\r\n"), f"a whole sentence, not {line!r}"
                gga = pynmea2.parse(line.strip(), check=True)
                if gga.sentence_type != "GGA":
                    continue  # the reader came in between an epoch's GGA and its RMC
                rmc = pynmea2.parse(gps.readline().decode("ascii").strip(), check=True)
                assert rmc.sentence_type == "RMC" and rmc.timestamp == gga.timestamp and rmc.status == "A"
                assert gga.gps_qual == 1 and abs(gga.latitude - DEFAULT_ORIGIN[0]) < 1e-3
                t = _fix_seconds(gga)
                assert _virtual_s(srv.ready["control"]) >= t, "written once the module's clock reached it"
                times.append(t)
        assert [b - a for a, b in zip(times, times[1:], strict=False)] == [1.0] * 5
        assert srv.stop() == 0
    assert not (tmp_path / "gps").exists(), "its pty symlink is removed on shutdown"


def test_with_two_feet_the_receiver_is_announced_beside_both_feet(tmp_path):
    with spawn("--scenario", RECIPE, "--feet", "2", "--pty", str(tmp_path / "shoe"), "--gps-pty",
               str(tmp_path / "gps"), "--speed", SPEED, "--status-interval", "0") as srv:
        assert set(srv.ready) == {"left.bt-pty", "right.bt-pty", "gps-pty"}
        with serial.Serial(srv.ready["gps-pty"], timeout=5) as gps:
            sentences = [pynmea2.parse(gps.readline().decode("ascii").strip(), check=True) for _ in range(3)]
        assert {s.sentence_type for s in sentences} == {"GGA", "RMC"}
        assert srv.stop() == 0


@pytest.mark.slow
def test_track_fuses_the_compass_and_the_served_receiver_on_the_module_clock(tmp_path, capsys):
    csv = tmp_path / "walk.csv"
    with spawn("--scenario", RECIPE, "--pty", str(tmp_path / "shoe"), "--gps-pty", str(tmp_path / "gps"),
               "--speed", SPEED, "--status-interval", "0") as srv:
        out = io.StringIO()
        argv = ["track", srv.ready["bt-pty"], "--fusion", "--compass", "--gps", srv.ready["gps-pty"],
                "--csv", str(csv), "--duration", "5"]
        assert main(argv, out) == 0
    text = out.getvalue()
    found = re.search(r"fusion: (\d+) compass updates .*?, (\d+) GPS updates", text)
    assert found, text
    assert int(found.group(1)) > 0 and int(found.group(2)) > 0
    assert "WMM at the first fix, 2026-06-01" in text and "0 garbled" in text
    assert "is gone" not in capsys.readouterr().err
    with csv.open() as f:
        header = tuple(f.readline().strip().split(","))
        first = f.readline().strip().split(",")
    assert header == CSV_COLUMNS + GEO_COLUMNS
    lat, lon = float(first[-3]), float(first[-2])
    assert abs(lat - DEFAULT_ORIGIN[0]) < 1e-3 and abs(lon - DEFAULT_ORIGIN[1]) < 1e-3
    assert len(read_csv(csv)) > 1


@pytest.mark.slow
def test_track_with_two_feet_fuses_both_compasses_and_the_served_receiver_on_the_body(tmp_path, capsys):
    with spawn("--scenario", RECIPE, "--feet", "2", "--pty", str(tmp_path / "shoe"), "--gps-pty",
               str(tmp_path / "gps"), "--speed", SPEED, "--status-interval", "0") as srv:
        out = io.StringIO()
        argv = ["track", srv.ready["left.bt-pty"], srv.ready["right.bt-pty"], "--fusion", "--compass",
                "--gps", srv.ready["gps-pty"], "--geojson", str(tmp_path / "body.geojson"), "--duration", "5"]
        assert main(argv, out) == 0
    text = out.getvalue()
    found = re.search(r"fusion: (\d+) compass updates .*?, (\d+) GPS updates", text)
    assert found, text
    assert int(found.group(1)) > 0 and int(found.group(2)) > 0
    steps = re.search(r"fusion: \d+ steps \(left (\d+), right (\d+)\)", text)
    assert steps and int(steps.group(1)) > 0 and int(steps.group(2)) > 0, text
    assert "WMM at the first fix, 2026-06-01" in text and "0 garbled" in text
    assert "is gone" not in capsys.readouterr().err
    assert '"crs": "local-enu-m"' not in (tmp_path / "body.geojson").read_text()
