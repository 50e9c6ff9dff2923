"""pty end to end: pyserial opens the stable symlink and talks to a paced module."""

from __future__ import annotations

import os
import sys
import time

import pytest
import serial

from firmware_sim.links.link import make_link
from firmware_sim.nav.firmware import build_module
from firmware_sim.transports.pacer import Pacer
from firmware_sim.transports.pty_endpoint import PtyEndpoint

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="pty pairing detection relies on Linux POLLHUP")

PING = bytes.fromhex("030003")
PING_ACK = bytes.fromhex("A00300A3")


def read_exact(ser: serial.Serial, n: int, deadline_s: float = 5.0) -> bytes:
    """Wait for *n* bytes, at most *deadline_s* (short serial timeouts, no sleeps)."""
    got = bytearray()
    end = time.monotonic() + deadline_s
    while len(got) < n and time.monotonic() < end:
        got += ser.read(n - len(got))
    return bytes(got)


@pytest.fixture
def served(tmp_path):
    module = build_module(usb_port=make_link("usb", seed=1))
    ep = PtyEndpoint(module.usb.port, tmp_path / "openshoe0")
    pacer = Pacer(module, [ep], speed=1.0).start()
    yield ep, pacer
    pacer.stop()


def test_symlink_is_a_raw_pty_and_interface_starts_unpaired(served):
    ep, pacer = served
    assert os.path.islink(ep.link_path)
    assert os.readlink(ep.link_path) == ep.slave_name and ep.slave_name.startswith("/dev/pts/")
    assert not ep.paired
    assert pacer.call(lambda m: m.usb.connected).result(5) is False


def test_pyserial_pings_through_the_symlink(served):
    ep, pacer = served
    with serial.Serial(str(ep.link_path), timeout=0.1) as ser:
        assert ep.wait_paired(True, timeout=5)
        ser.write(PING)
        assert read_exact(ser, 4) == PING_ACK
        assert pacer.call(lambda m: m.usb.connected).result(5) is True


def test_close_and_reopen_disconnects_then_connects_again(served):
    ep, pacer = served
    with serial.Serial(str(ep.link_path), timeout=0.1) as ser:
        assert ep.wait_paired(True, timeout=5)
        ser.write(PING)
        assert read_exact(ser, 4) == PING_ACK
    assert ep.wait_paired(False, timeout=5)
    assert pacer.call(lambda m: m.usb.connected).result(5) is False
    with serial.Serial(str(ep.link_path), timeout=0.1) as ser:
        assert ep.wait_paired(True, timeout=5)
        ser.write(PING)
        assert read_exact(ser, 4) == PING_ACK
    assert ep.wait_paired(False, timeout=5)
    counters = pacer.call(lambda m: m.usb.port.counters).result(5)
    assert (ep.connects, ep.disconnects) == (2, 2)
    assert (counters.connects, counters.disconnects) == (2, 3)  # 3: unplugged at start too


def test_stale_bytes_are_not_delivered_to_a_new_host(served):
    ep, pacer = served
    with serial.Serial(str(ep.link_path), timeout=0.1) as ser:
        assert ep.wait_paired(True, timeout=5)
        # 1 kHz output of the interrupt counter, then leave without reading
        ser.write(bytes.fromhex("20 02 01 00 23"))
        assert len(read_exact(ser, 10)) == 10
    assert ep.wait_paired(False, timeout=5)
    with serial.Serial(str(ep.link_path), timeout=0.1) as ser:
        assert ep.wait_paired(True, timeout=5)
        ser.write(bytes.fromhex("220022"))  # all outputs off
        data = read_exact(ser, 4)
        # the first bytes this host sees start a frame (no half packet from the old session)
        assert data[:1] in (b"\xa0", b"\xaa")


def test_symlink_replaced_atomically_and_removed_on_close(tmp_path):
    path = tmp_path / "dev" / "shoe"
    path.parent.mkdir()
    os.symlink("/nonexistent/old", path)  # a stale link from a crashed run
    module = build_module()
    ep = PtyEndpoint(module.usb.port, path)
    assert os.readlink(path) == ep.slave_name
    assert [p.name for p in path.parent.iterdir()] == ["shoe"]  # no temp names left behind
    ep.close()
    assert not os.path.lexists(path)
    assert not module.usb.connected


def test_a_host_that_does_not_read_gets_drops_counted_not_a_stuck_module(served):
    ep, pacer = served
    with serial.Serial(str(ep.link_path), timeout=0.1) as ser:
        assert ep.wait_paired(True, timeout=5)
        ser.write(bytes.fromhex("20 23 01 00 44"))  # P (180 B) at 1 kHz: ~186 kB/s, never read
        assert pacer.wait_until(lambda m: ep.dropped > 0, timeout=30)  # tested in the loop, after ticks
        assert pacer.wait_ticks(10, timeout=30)  # the loop goes on
        assert pacer.status().running


def test_symlink_removed_when_the_program_exits_without_close(tmp_path):
    import subprocess

    path = tmp_path / "shoe"
    code = ("from firmware_sim.nav.firmware import build_module\n"
            "from firmware_sim.transports.pty_endpoint import PtyEndpoint\n"
            f"ep = PtyEndpoint(build_module().usb.port, {str(path)!r})\n"
            "import os; print(os.readlink(ep.link_path))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                         cwd=os.path.dirname(os.path.dirname(os.path.dirname(__file__))))
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("/dev/pts/")
    assert not os.path.lexists(path)
