"""``openshoe-conformance`` given what it cannot use: a URL that names no port, a port that will
not open, options out of range. Each ends with exit status 2 and one line saying what was wrong,
before any check runs; never a traceback, never a run that cannot end (``--time-scale 0``)."""

from __future__ import annotations

import socket

import pytest

from tools.conformance.cli import main


@pytest.fixture(scope="module")
def closed_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


CASES = [
    (["DIR"], "it is a directory, not a serial port"),
    (["FILE"], "it is a regular file, not a serial port"),
    (["NOPE"], "No such file or directory"),
    (["/dev/null"], "it is not a serial port"),
    (["socket://127.0.0.1"], "no port: a TCP URL is socket://HOST:PORT"),
    (["socket://127.0.0.1:99999"], "port '99999' is not a number from 1 to 65535"),
    (["rfc2217://127.0.0.1:x"], "port 'x' is not a number"),
    (["socket://127.0.0.1:CLOSED"], "Connection refused"),
    (["rfc2217://127.0.0.1:CLOSED"], "Connection refused"),
    (["bogus://x"], "protocol 'bogus' not known"),
    (["openshoe://?bogus=1"], "unknown option 'bogus'"),
    ([""], "a URL is required"),
    ([], "a URL is required"),
    (["loop://", "--only", "nope"], "unknown check(s) ['nope']"),
    (["loop://", "--time-scale", "0"], "argument --time-scale: a factor > 0"),
    (["loop://", "--time-scale", "nan"], "argument --time-scale: a factor > 0"),
    (["loop://", "--time-scale", "-1"], "argument --time-scale: a factor > 0"),
    (["loop://", "--baudrate", "-1"], "argument --baudrate: a whole number of bits per second > 0"),
]


@pytest.mark.parametrize(("argv", "said"), CASES, ids=[" ".join(a) or "none" for a, _ in CASES])
def test_the_conformance_command_refuses_what_it_cannot_use_in_one_line(tmp_path, capsys, closed_port, argv,
                                                                      said):
    (tmp_path / "capture.bin").write_bytes(b"\xa0\x34\x00\xd4")
    where = {"DIR": str(tmp_path), "FILE": str(tmp_path / "capture.bin"), "NOPE": str(tmp_path / "nope")}
    argv = [where.get(a, a).replace("CLOSED", str(closed_port)) for a in argv]
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's refusal of an option's value
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and said in err and "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith("openshoe-conformance")
