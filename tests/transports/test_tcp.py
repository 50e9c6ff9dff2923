"""TCP end to end: a host connects to the paced module, pings, disconnects."""

from __future__ import annotations

import socket
import time

import pytest

from firmware_sim.links.link import make_link
from firmware_sim.nav.firmware import build_module
from firmware_sim.transports.pacer import Pacer
from firmware_sim.transports.tcp import TcpEndpoint

PING = bytes.fromhex("030003")
PING_ACK = bytes.fromhex("A00300A3")


def recv_exact(sock: socket.socket, n: int, deadline_s: float = 5.0) -> bytes:
    got = bytearray()
    end = time.monotonic() + deadline_s
    sock.settimeout(0.1)
    while len(got) < n and time.monotonic() < end:
        try:
            chunk = sock.recv(n - len(got))
        except TimeoutError:
            continue
        if not chunk:
            break
        got += chunk
    return bytes(got)


@pytest.fixture
def served():
    module = build_module(bt_port=make_link("bt", seed=3))
    ep = TcpEndpoint(module.bt.port)  # 127.0.0.1, a free port
    pacer = Pacer(module, [ep], speed=1.0).start()
    yield ep, pacer
    pacer.stop()


def test_listens_on_loopback_and_starts_unpaired(served):
    ep, pacer = served
    assert ep.address[0] == "127.0.0.1" and ep.address[1] > 0
    assert pacer.call(lambda m: m.bt.connected).result(5) is False


def test_ping_over_tcp_and_bluetooth_link(served):
    ep, pacer = served
    with socket.create_connection(ep.address, timeout=5) as s:
        assert ep.wait_paired(True, timeout=5)
        s.sendall(PING)
        assert recv_exact(s, 4) == PING_ACK
    assert ep.wait_paired(False, timeout=5)
    assert pacer.call(lambda m: m.bt.connected).result(5) is False


def test_one_host_at_a_time(served):
    ep, _ = served
    with socket.create_connection(ep.address, timeout=5) as first:
        assert ep.wait_paired(True, timeout=5)
        with socket.create_connection(ep.address, timeout=5) as second:
            assert recv_exact(second, 1) == b""  # closed by the server at once
        first.sendall(PING)
        assert recv_exact(first, 4) == PING_ACK
    assert ep.refused_hosts == 1


def test_reconnect_gets_a_fresh_session(served):
    ep, pacer = served
    for _ in range(2):
        with socket.create_connection(ep.address, timeout=5) as s:
            assert ep.wait_paired(True, timeout=5)
            s.sendall(PING)
            assert recv_exact(s, 4) == PING_ACK
        assert ep.wait_paired(False, timeout=5)
    status = pacer.status()
    assert status.endpoints[0]["connects"] == 2
    assert status.running and status.ticks > 0
