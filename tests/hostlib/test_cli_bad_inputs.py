"""``openshoe-host`` given what it cannot use, command by command: a file that is not one, not what
it should be or not readable; a URL that names no port, or a port that will not open; a value out
of range. Each ends in one line saying what was wrong — the file's name, and the line where its
format has lines — with exit status 2 for a refused option (before any port opens or capture is
read) and 1 for an input that could not be used; never a traceback, and no output file written."""

from __future__ import annotations

import io
import json
import os
import socket

import pytest
import serial

from hostlib.cli import main

from .test_bad_captures import capture

#: Every output a command may be asked for: none may exist after a refusal.
OUTPUTS = ("out.csv", "out.geojson", "out.png", "raw.bin", "cal.json")


@pytest.fixture(autouse=True)
def fakeshoe_scheme():
    serial.protocol_handler_packages.append("tests.hostlib")
    yield
    serial.protocol_handler_packages.remove("tests.hostlib")


@pytest.fixture(scope="module")
def closed_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def files(tmp_path, closed_port) -> dict[str, str]:
    """The names the table's arguments stand for: a good capture, and files that are not what a
    command wants."""
    made = {"cap": capture(5), "garbage": bytes(range(256)) * 4, "text": b"hello world\n", "empty": b"",
            "trunc": b'{"format": "openshoe-drift', "list": b"[1, 2, 3]",
            "nmea": b"$GPGGA,garbage*00\nnot,nmea\n",
            "magshape": json.dumps({"kind": "openshoe-mag-calibration", "hard_iron_ut": [1, 2],
                                    "soft_iron": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}).encode()}
    names = {}
    for name, data in made.items():
        (tmp_path / name).write_bytes(data)
        names[name] = str(tmp_path / name)
    (tmp_path / "dir").mkdir()
    names.update(dir=str(tmp_path / "dir"), nope=str(tmp_path / "nope"), port=str(closed_port),
                 out=str(tmp_path / "out"), missing=str(tmp_path / "no" / "where"))
    return names


#: (argv with {name}s, exit status, what the message says)
CASES = [
    # replay: the capture
    ("replay {nope} --csv {out}.csv", 1, "{nope}: cannot read the capture: No such file or directory"),
    ("replay {dir} --csv {out}.csv", 1, "{dir}: cannot read the capture: it is a directory"),
    ("replay /dev/zero --csv {out}.csv", 1, "/dev/zero: cannot read the capture: it is a device, not a file"),
    ("replay /proc/self/mem --csv {out}.csv", 1, "/proc/self/mem: cannot read the capture: Input/output"),
    ("replay {garbage} --csv {out}.csv", 1, "{garbage}: no OpenShoe frame in its 1024 bytes"),
    ("replay {cap} {nope} --csv {out}.csv", 1, "{nope}: cannot read the capture"),
    ("replay {cap} {cap} --csv {out}.csv", 2,  # it was fused as two modules, 25σ apart
     "{cap} is {cap} again: the two feet are two modules, each with a capture of its own"),
    ("replay '' --csv {out}.csv", 1, "an empty name was given for the capture"),
    # replay: the files the aids read
    ("replay {cap} --gps {nope} --csv {out}.csv", 1, "{nope}: cannot read the GPS log: No such file"),
    ("replay {cap} --gps {dir} --csv {out}.csv", 1, "{dir}: cannot read the GPS log: it is a directory"),
    ("replay {cap} --gps /dev/zero --csv {out}.csv", 1, "/dev/zero: cannot read the GPS log: it is a device"),
    ("replay {cap} --gps {garbage} --csv {out}.csv", 1, "{garbage}: no GPS fix in"),
    ("replay {cap} --gps {nmea} --csv {out}.csv", 1,
     "{nmea}: no GPS fix in 2 lines (2 NMEA lines: 0 fixes, 0 without a fix, 2 garbled (skipped); "
     "first: line 1 (bad checksum), line 2 (not an NMEA sentence)"),
    ("replay {cap} --compass --mag-cal {nope} --csv {out}.csv", 1,
     "{nope}: cannot read the magnetometer calibration: No such file"),
    ("replay {cap} --compass --mag-cal {garbage} --csv {out}.csv", 1,
     "{garbage}: not a magnetometer calibration: not text (line 2 has the byte 0x80)"),
    ("replay {cap} --compass --mag-cal {trunc} --csv {out}.csv", 1,
     "{trunc}: not a magnetometer calibration: invalid JSON (Unterminated string starting at: line 1 "
     "column 12"),
    ("replay {cap} --compass --mag-cal {list} --csv {out}.csv", 1,
     "{list}: not a magnetometer calibration: expected a JSON object, got list"),
    ("replay {cap} --compass --mag-cal {magshape} --csv {out}.csv", 1,
     "{magshape}: not a magnetometer calibration: 'hard_iron_ut' must be 3 finite numbers"),
    ("replay {cap} --drift {empty} --csv {out}.csv", 1, "{empty}: not a drift calibration: the file is"),
    ("replay {cap} --drift {dir} --csv {out}.csv", 1, "{dir}: cannot read the drift calibration: it is a"),
    ("replay {cap} --drift {magshape} --csv {out}.csv", 1,
     "{magshape}: not a drift calibration: 'format' is None"),
    # replay: values, refused before the capture is read
    ("replay {cap} --origin 999,999 --geojson {out}.geojson", 2, "--origin is LAT,LON[,ALT] in degrees"),
    ("replay {cap} --origin nan,0 --geojson {out}.geojson", 2, "--origin is LAT,LON[,ALT]"),
    ("replay {cap} --every 0 --png {out}.png", 2, "--every is a number of steps >= 1"),
    ("replay {cap} --compass --declination nan --csv {out}.csv", 2,
     "argument --declination: an angle in degrees from -180 to 180, not 'nan'"),
    ("replay {cap} --compass --compass-sigma 0 --csv {out}.csv", 2,
     "argument --compass-sigma: an angle in degrees > 0 and < 180"),
    ("replay {cap} {cap} --max-separation nan --csv {out}.csv", 2, "argument --max-separation: a distance"),
    ("replay {cap} --csv {dir}", 2, "--csv {dir} is a directory: name a file in it"),
    ("replay {cap} --csv {out}.csv --png {missing}.png", 2, "--png {missing}.png: the folder"),
    ("replay {cap} --compass --mag-cal-dir {text} --csv {out}.csv", 2, "--mag-cal-dir {text} is not a"),
    # drift calibrate
    ("drift calibrate {nope} -o {out}.json", 1, "{nope}: cannot read the capture: No such file"),
    ("drift calibrate /dev/null -o {out}.json", 1, "/dev/null: cannot read the capture: it is a device"),
    ("drift calibrate {cap} -o {dir}", 2, "--output {dir} is a directory"),
    ("drift calibrate {cap} -o {missing}.json", 2, "the folder"),
    # track, log, info: the port
    ("info {nope}", 1, "cannot use {nope}: No such file or directory"),
    ("info {dir}", 1, "cannot use {dir}: it is a directory, not a serial port"),
    ("info {text}", 1, "cannot use {text}: it is a regular file, not a serial port"),
    ("info /dev/null", 1, "cannot use /dev/null: it is not a serial port"),
    ("info socket://127.0.0.1:{port}", 1, "cannot use socket://127.0.0.1:{port}: Connection refused"),
    ("info rfc2217://127.0.0.1:{port}", 1, "cannot use rfc2217://127.0.0.1:{port}: Connection refused"),
    ("info socket://127.0.0.1", 1, "cannot use socket://127.0.0.1: no port: a TCP URL is socket://HOST:PORT"),
    ("info socket://127.0.0.1:99999", 1, "port '99999' is not a number from 1 to 65535"),
    ("info bogus://x", 1, "cannot use bogus://x: invalid URL, protocol 'bogus' not known"),
    ("info ''", 2, "argument url: a device path or URL, not an empty one"),
    ("info loop:// --ack-timeout 0.05", 1, "no ack (A0 03 ..) for PING"),
    ("info fakeshoe://0 --ack-timeout nan", 2, "argument --ack-timeout: a number of seconds > 0, not 'nan'"),
    ("info fakeshoe://0 --ack-timeout -1", 2, "argument --ack-timeout: a number of seconds > 0"),
    ("info fakeshoe://0 --baudrate 0", 2, "argument --baudrate: a whole number of bits per second > 0"),
    ("track {nope} --csv {out}.csv", 1, "cannot use {nope}: No such file or directory"),
    ("track fakeshoe://5 {nope} --csv {out}.csv", 1, "cannot use {nope}: No such file or directory"),
    ("log socket://127.0.0.1:{port} --raw {out}.bin", 1, "Connection refused"),
    # track, log: values, refused before the port opens
    ("track fakeshoe://5 --duration -1 --csv {out}.csv", 2, "--duration is a number of seconds > 0"),
    ("track fakeshoe://5 --duration nan --csv {out}.csv", 2, "--duration is a number of seconds > 0"),
    ("track fakeshoe://5 --heading inf --csv {out}.csv", 2, "--heading is an angle in degrees, not inf"),
    ("track fakeshoe://5 --every 0 --png {out}.png", 2, "--every is a number of steps >= 1"),
    ("track fakeshoe://5 --origin 91,0 --geojson {out}.geojson", 2, "--origin is LAT,LON[,ALT]"),
    ("track fakeshoe://5 --csv {dir}", 2, "--csv {dir} is a directory"),
    ("track fakeshoe://5 --steps 0", 2, "argument --steps: a whole number of step packets"),
    ("track fakeshoe://5 --fusion --drift {trunc} --csv {out}.csv", 1,
     "{trunc}: not a drift calibration: invalid JSON"),
    ("track fakeshoe://5 --fusion --gps {garbage} --duration 5 --csv {out}.csv", 1, "{garbage}: no GPS fix"),
    ("log fakeshoe://5 --raw {dir}", 2, "--raw {dir} is a directory"),
    ("log fakeshoe://5 --raw {missing}.bin", 2, "--raw {missing}.bin: the folder"),
    ("log fakeshoe://5 --raw {out}.bin --duration inf", 2, "--duration is a number of seconds > 0"),
]


def _argv(template: str, files: dict[str, str]) -> list[str]:
    return [word.strip("'").format(**files) for word in template.split()]


@pytest.mark.parametrize(("template", "status", "said"), CASES, ids=[c[0].split(" {out}")[0] for c in CASES])
def test_openshoe_host_refuses_what_it_cannot_use_in_one_line_and_writes_nothing(tmp_path, capsys, files,
                                                                                template, status, said):
    try:
        code = main(_argv(template, files), io.StringIO())
    except SystemExit as exc:  # argparse's refusal of an option's value: its usage, then one line
        code = exc.code
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert code == status and said.format(**files) in lines[-1]
    assert lines[-1].startswith("openshoe-host")
    if status == 1:
        assert len(lines) == 1
    assert not [p for p in tmp_path.iterdir() if p.name.startswith("out")]


def test_log_to_a_port_that_does_not_open_leaves_an_earlier_capture_as_it_was(tmp_path, capsys, closed_port):
    raw = tmp_path / "walk.bin"
    raw.write_bytes(b"an earlier walk")
    assert main(["log", f"socket://127.0.0.1:{closed_port}", "--raw", str(raw)], io.StringIO()) == 1
    assert raw.read_bytes() == b"an earlier walk" and "Connection refused" in capsys.readouterr().err


def test_log_writes_what_came_before_its_file_was_open(tmp_path):
    raw = tmp_path / "cap.bin"
    assert main(["log", "fakeshoe://3", "--raw", str(raw), "--start", "--steps", "3", "--duration", "30"],
                io.StringIO()) == 0
    assert raw.read_bytes().startswith(bytes.fromhex("A0 34 00 D4"))


@pytest.mark.parametrize("template", ["replay {fifo}", "replay {cap} --gps {fifo}",
                                      "drift calibrate {fifo} -o {out}.json"])
def test_a_named_pipe_nothing_writes_to_is_refused_in_one_line(tmp_path, capsys, monkeypatch, files,
                                                               template):
    """It was waited on for ever (the open blocks until a writer comes), and Ctrl-C was a traceback."""
    from hostlib import inputs

    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    monkeypatch.setattr(inputs, "PIPE_WAIT_S", 0.05)
    assert main(_argv(template, {**files, "fifo": str(fifo)}), io.StringIO()) == 1
    err = capsys.readouterr().err
    assert err.splitlines()[-1].startswith("openshoe-host") and "Traceback" not in err
    assert f"{fifo}: cannot read the " in err and "a pipe nothing wrote to in 0.05 s" in err


def test_log_to_a_named_pipe_nothing_reads_from_is_refused_before_the_port_opens(tmp_path, capsys, files):
    """It opened the port, then waited for a reader for ever."""
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    assert main(["log", f"socket://127.0.0.1:{files['port']}", "--raw", str(fifo)], io.StringIO()) == 2
    said = f"openshoe-host log: --raw {fifo} is a pipe nothing reads from: start its reader first\n"
    assert capsys.readouterr().err == said
