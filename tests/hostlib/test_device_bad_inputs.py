"""``hostlib.Device`` given what it cannot use: a target that is no port, a URL that names none, a
port that will not open, options out of range, a closed device. Each is refused at once, with the
exception of its kind and a message saying what is wrong — never a device that loops on a dead link,
never a wait of NaN seconds."""

from __future__ import annotations

import math
import re
import socket
from pathlib import Path

import pytest
import serial

from hostlib import Device, DeviceOptions
from hostlib.errors import DeviceClosed
from hostlib.link.connection import url_refusal
from protocol.ids import Command


@pytest.fixture(scope="module")
def closed_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize(("target", "error", "said"), [
    (None, ValueError, "needs a port path/URL"),
    ("", ValueError, "a port is a device path or URL string, got ''"),
    (123, TypeError, "a port object with read, write and close, got int"),
    ("socket://127.0.0.1", ValueError, "no port: a TCP URL is socket://HOST:PORT"),
    ("socket://:5000", ValueError, "no host"),
    ("socket://127.0.0.1:99999", ValueError, "port '99999' is not a number from 1 to 65535"),
    ("rfc2217://127.0.0.1:abc", ValueError, "port 'abc' is not a number"),
    ("bogus://x", ValueError, "protocol 'bogus' not known"),
    ("/dev/null", serial.SerialException, "not a serial port (a device that is no terminal)"),
    ("DIR", serial.SerialException, "it is a directory, not a serial port"),
    ("FILE", serial.SerialException, "a regular file, not a serial port"),
    ("NOPE", serial.SerialException, "No such file or directory"),
], ids=["none", "empty", "int", "no-port", "no-host", "port-range", "port-text", "scheme", "dev-null", "dir",
        "file", "missing"])
def test_a_target_that_names_no_port_is_refused_saying_what_it_is(tmp_path, target, error, said):
    (tmp_path / "capture.bin").write_bytes(b"\xa0\x34\x00\xd4")
    paths = {"DIR": tmp_path, "FILE": tmp_path / "capture.bin", "NOPE": tmp_path / "nope"}
    target = paths.get(target, target) if isinstance(target, str) else target
    with pytest.raises(error, match=re.escape(said)):
        Device(target)


def test_a_refused_tcp_port_says_connection_refused_once(closed_port):
    with pytest.raises(serial.SerialException) as caught:
        Device(f"socket://127.0.0.1:{closed_port}")
    assert str(caught.value) == "Connection refused"


def test_a_path_object_is_a_port_path():
    assert url_refusal("socket://127.0.0.1:5000") is None and url_refusal("/dev/rfcomm0") is None
    with pytest.raises(serial.SerialException, match="No such file"):
        Device(Path("/nonexistent/tty-openshoe"))


@pytest.mark.parametrize(("options", "error", "said"), [
    ({"ack_timeout": -1}, ValueError, "ack_timeout must be a number of seconds > 0, got -1"),
    ({"ack_timeout": math.nan}, ValueError, "ack_timeout must be a number of seconds > 0, got nan"),
    ({"ack_timeout": "2"}, TypeError, "ack_timeout must be a number of seconds > 0, got '2'"),
    ({"read_timeout": 0}, ValueError, "read_timeout must be a number of seconds > 0"),
    ({"reconnect_interval": math.inf}, ValueError, "reconnect_interval must be"),
    ({"retries": -1}, ValueError, "retries must be a whole number >= 0"),
    ({"retries": 1.5}, TypeError, "retries must be a whole number"),
    ({"queue_size": 0}, ValueError, "queue_size must be a whole number >= 1"),
    ({"baudrate": -1}, ValueError, "baudrate must be a whole number of bits per second > 0"),
    ({"command_set": "1999"}, ValueError, "unknown command set '1999'"),
    ({"ack_policy": "sometimes"}, ValueError, "ack_policy must be 'auto', 'always' or 'never'"),
    ({"bogus": 1}, TypeError, "Device has no option 'bogus'"),
    ({"raw_log": "capture.bin"}, TypeError, "raw_log must be a binary file open for writing"),
    ({"tracker": 5}, TypeError, "tracker must be a StepTracker"),
], ids=lambda v: str(v) if not isinstance(v, dict) else "-".join(map(str, v)))
def test_options_out_of_range_are_refused_naming_the_option(options, error, said):
    with pytest.raises(error, match=said):
        Device("loop://", **options)


def test_options_that_are_not_device_options_are_refused():
    with pytest.raises(TypeError, match="options must be a DeviceOptions, got dict"):
        Device("loop://", {"ack_timeout": 1.0})
    with pytest.raises(ValueError, match="ack_timeout"):
        DeviceOptions(ack_timeout=0)


def test_a_closed_device_refuses_what_needs_the_link_and_still_tells_what_it_had():
    dev = Device("loop://", ack_timeout=0.05)
    with pytest.raises(ValueError, match="timeout > 0 s and retries >= 0"):
        dev.command(Command.PING, timeout=-1)
    with pytest.raises(ValueError, match="timeout > 0 s and retries >= 0"):
        dev.command(Command.PING, retries=-1)
    with pytest.raises(TypeError, match="send_raw takes bytes, got str"):
        dev.send_raw("34 00 34")
    with pytest.raises(TypeError, match="feed takes bytes, got str"):
        dev.feed("text")
    dev.close()
    for call in (dev.ping, dev.start_stepwise_dead_reckoning, lambda: dev.send_raw(b"\x03\x00\x03"),
                 lambda: dev.recv_packet(0.01), lambda: dev.recv_step(0.01), dev.__enter__):
        with pytest.raises(DeviceClosed, match="loop:// is closed"):
            call()
    assert list(dev.steps(0.01)) == [] and len(dev.track_snapshot()) == 0 and dev.stats["steps"] == 0
    assert dev.wait_link(True, timeout=0.01) is False and dev.wait_link(False, timeout=0.01) is True
    dev.close()  # twice: nothing
