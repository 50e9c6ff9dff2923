"""`openshoe-emu serve` as a real subprocess: READY line, pty and TCP hosts, control channel, clean stop.

Every wait is on bytes or events with a deadline (pyserial read timeouts,
the READY line), never a fixed sleep.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys

import pytest
import serial

from firmware_sim.app.serve import parse_ready, spawn
from firmware_sim.transports.factory import module_serial
from protocol.frames import StatePacket, build_command, build_packet_ack
from protocol.ids import Command, StateId
from protocol.stream import StreamDecoder

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="ptys are tested on Linux")

#: A short scenario (quick to build) and no status lines.
FAST = ("--scenario", "stand", "--status-interval", "0")
PING = bytes.fromhex("030003")
PING_ACK = bytes.fromhex("A00300A3")
START_STEPWISE = bytes.fromhex("340034")
START_STEPWISE_ACK = bytes.fromhex("A03400D4")


def _read_exact(port, n: int, timeout: float = 3.0) -> bytes:
    port.timeout = timeout
    return port.read(n)


def _control(address: str, *lines: str) -> list[str]:
    host, port = address.rsplit(":", 1)
    with socket.create_connection((host, int(port)), timeout=5) as c:
        f = c.makefile("rw", encoding="utf-8", newline="\n")
        replies = []
        for line in lines:
            f.write(line + "\n")
            f.flush()
            reply = []
            while True:
                r = f.readline().rstrip("\n")
                reply.append(r)
                if r.startswith(("OK", "ERR")):
                    break
            replies.append("\n".join(reply))
        return replies


def test_ready_line_parses():
    ready = parse_ready("READY bt-pty=/tmp/a bt-tcp=127.0.0.1:4")
    assert ready == {"bt-pty": "/tmp/a", "bt-tcp": "127.0.0.1:4"}
    with pytest.raises(ValueError):
        parse_ready("hello")


def test_serve_on_pty_and_tcp_answers_both_hosts(tmp_path):
    pty_path = tmp_path / "openshoe0"
    with spawn("--pty", str(pty_path), "--tcp", "0", "--link", "usb", *FAST) as srv:
        assert srv.ready["bt-pty"] == str(pty_path)
        assert pty_path.is_symlink()
        with serial.Serial(str(pty_path), timeout=3) as host:
            host.write(PING)
            assert _read_exact(host, 4) == PING_ACK
            with serial.serial_for_url(f"socket://{srv.ready['bt-tcp']}", timeout=3) as tcp:
                tcp.write(PING)
                # both hosts share the Bluetooth interface: both see the module's answer
                assert _read_exact(tcp, 4) == PING_ACK
                assert _read_exact(host, 4) == PING_ACK
        assert srv.stop() == 0
    assert not pty_path.exists(), "the pty symlink is removed on shutdown"


def test_serve_streams_lossless_packets_that_the_host_acks(tmp_path):
    pty_path = tmp_path / "os0"
    with spawn("--pty", str(pty_path), *FAST) as srv, \
            serial.Serial(srv.ready["bt-pty"], timeout=2) as host:
        host.write(build_command(Command.OUTPUT_STATE, state_id=StateId.INTERRUPT_COUNTER, mode=0x10 | 3))
        dec = StreamDecoder()
        numbers: list[int] = []
        while len(numbers) < 5:
            chunk = host.read(max(1, host.in_waiting))
            assert chunk, "the module stopped sending"
            for f in dec.feed(chunk):
                if hasattr(f, "number"):
                    if not numbers or f.number != numbers[-1]:
                        numbers.append(f.number)
                    host.write(build_packet_ack(f.number))
        assert [(b - a) % 65536 for a, b in zip(numbers[:-1], numbers[1:], strict=True)] == [1, 1, 1, 1]


def test_control_channel_disconnects_and_reconnects_the_link(tmp_path):
    pty_path = tmp_path / "os1"
    with spawn("--pty", str(pty_path), "--control", "0", *FAST) as srv, \
            serial.Serial(srv.ready["bt-pty"], timeout=1) as host:
        ctl = srv.ready["control"]
        host.write(PING)
        assert _read_exact(host, 4) == PING_ACK
        assert _control(ctl, "disconnect") == ["OK disconnect"]
        host.write(PING)
        assert _read_exact(host, 4, timeout=0.5) == b"", "a disconnected module answers nothing"
        assert _control(ctl, "reconnect") == ["OK reconnect"]
        host.reset_input_buffer()
        host.write(PING)
        assert _read_exact(host, 4) == PING_ACK
        replies = _control(ctl, "corrupt 4", "stall 0.2", "bogus", "status", "@7 stall 1")
        assert replies[0] == "OK corrupt 4" and replies[1] == "OK stall 0.2"
        assert replies[2].startswith("ERR unknown command")
        assert "t=" in replies[3] and replies[3].endswith("OK")
        assert replies[4].startswith("ERR no module")
        host.write(PING)
        got = _read_exact(host, 4)
        assert len(got) == 4 and got != PING_ACK, "the next 4 bytes to the host were corrupted"


def test_two_modules_each_on_its_own_pty(tmp_path):
    base = tmp_path / "mod"
    with spawn("--pty", str(base), "--modules", "2", "--link", "usb", *FAST) as srv:
        assert set(srv.ready) == {"m0.bt-pty", "m1.bt-pty"}
        for key in ("m0.bt-pty", "m1.bt-pty"):
            with serial.Serial(srv.ready[key], timeout=3) as host:
                host.write(PING)
                assert _read_exact(host, 4) == PING_ACK


def _mcu_serial(host) -> bytes:
    """Ask for the module's serial number (MCU_ID) and read it: the packet holding state 0x04 alone
    (15 bytes), acked; step packets arriving meanwhile are acked and passed over."""
    host.write(build_command(Command.MCU_ID))
    dec = StreamDecoder()
    while True:
        chunk = host.read(max(1, host.in_waiting))
        assert chunk, "no serial number"
        for frame in dec.feed(chunk):
            if isinstance(frame, StatePacket):
                host.write(build_packet_ack(frame.number))
                if len(frame.payload) == 15:
                    return frame.payload


def test_two_feet_are_two_modules_each_on_its_own_pty(tmp_path):
    base = tmp_path / "shoe"
    with spawn("--pty", str(base), "--feet", "2", "--link", "usb", "--duration", "60", *FAST) as srv:
        assert srv.ready == {"left.bt-pty": f"{base}-left", "right.bt-pty": f"{base}-right"}
        serials = []
        for side in ("left", "right"):
            with serial.Serial(f"{base}-{side}", timeout=3) as host:
                host.write(START_STEPWISE)
                assert _read_exact(host, 4) == START_STEPWISE_ACK
                serials.append(_mcu_serial(host))
        # a host tells the feet apart by their serial numbers: each foot is its seed's own module
        assert serials == [module_serial(0), module_serial(1)]
        assert srv.stop() == 0
    assert not any(tmp_path.iterdir()), "both pty symlinks are removed on shutdown"


def test_sigint_stops_cleanly_and_bad_usage_is_refused(tmp_path):
    srv = spawn("--pty", str(tmp_path / "p"), *FAST)
    srv.proc.send_signal(__import__("signal").SIGINT)
    assert srv.proc.wait(10) == 0
    srv.stop()
    r = subprocess.run([sys.executable, "-m", "firmware_sim.app.cli", "serve"],
                       capture_output=True, text=True, timeout=30)
    assert r.returncode == 2 and "--pty" in r.stderr
    r = subprocess.run([sys.executable, "-m", "firmware_sim.app.cli", "serve", "--tcp", "x:y"],
                       capture_output=True, text=True, timeout=30)
    assert r.returncode == 2 and "[HOST:]PORT" in r.stderr


def test_conformance_cli_passes_against_serve_on_a_pty(tmp_path):
    """The product's own conformance tool, run as a user would, against a served module."""
    with spawn("--pty", str(tmp_path / "c0"), "--link", "usb", *FAST) as srv:
        r = subprocess.run(
            [sys.executable, "-m", "tools.conformance.cli", srv.ready["bt-pty"], "-q",
             "--only", "ping", "acks", "bad-checksum", "phase-sync", "lossless", "resend-interval"],
            capture_output=True, text=True, timeout=60, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.count("PASS") == 6 and "CONFORMS" in r.stdout


# pyserial's rfc2217 client uses deprecated threading calls
@pytest.mark.filterwarnings("ignore:set(Daemon|Name)\\(\\) is deprecated:DeprecationWarning")
def test_rfc2217_port_speaks_to_pyserial(tmp_path):
    with spawn("--rfc2217", "0", "--link", "usb", *FAST) as srv, \
            serial.serial_for_url(f"rfc2217://{srv.ready['bt-rfc2217']}", timeout=3) as host:
        host.write(PING)
        assert _read_exact(host, 4) == PING_ACK
        # bytes that look like telnet IAC (0xFF) are escaped both ways: garbage skipped, PING answered
        host.write(b"\xff\xff" + PING)
        assert _read_exact(host, 4) == PING_ACK
        assert host.cd, "carrier detect is the link's connected line"


def test_serve_replays_a_recording_at_its_own_rate(tmp_path, walks_dir):
    """--replay: the module runs at the recording's rate (250 Hz) and reads the recorded samples."""
    recording = walks_dir / "walk_100521_2.txt"
    with spawn("--pty", str(tmp_path / "rp"), "--replay", str(recording), "--link", "usb",
               "--status-interval", "0") as srv, serial.Serial(srv.ready["bt-pty"], timeout=3) as host:
        dec = StreamDecoder()

        def pull(state_id: int) -> bytes:
            host.write(build_command(Command.OUTPUT_STATE, state_id=state_id, mode=0x20))
            while True:
                chunk = host.read(max(1, host.in_waiting))
                assert chunk, "no answer"
                for f in dec.feed(chunk):
                    if hasattr(f, "payload"):
                        return f.payload

        host.write(build_command(Command.MIMU_FRONTEND))
        first = [pull(0x40), pull(StateId.IMU_TS)]
        second = [pull(0x40), pull(StateId.IMU_TS)]
        assert first[0] != second[0], "the raw IMU registers follow the recording"
        cycles = (int.from_bytes(second[1], "big") - int.from_bytes(first[1], "big")) % (1 << 32)
        assert cycles % 256_000 == 0, "samples are read every 4 ms (64 MHz / 250 Hz)"


def test_serve_refuses_a_bad_recording_with_its_line(tmp_path):
    bad = tmp_path / "bad.txt"
    bad.write_text("junk line\n1 2 3\n")
    r = subprocess.run([sys.executable, "-m", "firmware_sim.app.cli", "serve", "--pty", str(tmp_path / "x"),
                        "--replay", str(bad)], capture_output=True, text=True, timeout=30)
    assert r.returncode == 1
    assert "bad.txt, line 2" in r.stderr and "READY" not in r.stdout


def test_trace_file_records_every_frame_with_its_cycle(tmp_path):
    trace = tmp_path / "frames.txt"
    with spawn("--pty", str(tmp_path / "t0"), "--trace", str(trace), "--link", "usb", *FAST) as srv:
        with serial.Serial(srv.ready["bt-pty"], timeout=3) as host:
            host.write(PING + bytes.fromhex("030004"))  # a good PING and one with a bad checksum
            assert _read_exact(host, 4) == PING_ACK
        assert srv.stop() == 0
    lines = trace.read_text().splitlines()
    assert lines[0].startswith("# cycles")
    assert any(line.endswith("BT in command 03 00 03") for line in lines)
    assert any(line.endswith("BT out ack A0 03 00 A3") for line in lines)
    assert any(line.endswith("BT in bad checksum 03 00 04") for line in lines)
    cycles = [int(line.split()[0]) for line in lines[1:]]
    assert cycles == sorted(cycles)
