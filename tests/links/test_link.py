"""Link models in virtual time: rates, latency, rings, faults (firmware_sim.links.link)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_sim.links.faults import MAX_EVENT_RATE_HZ, DirectionFaults, LinkFaults
from firmware_sim.links.link import CLOCK_HZ, BluetoothLink, Link, UsbLink, make_link
from firmware_sim.mcu.module import ModuleConfig
from firmware_sim.mcu.port import Port
from firmware_sim.nav.firmware import build_module

TICK = CLOCK_HZ // 1000  # one 1 kHz module tick


class Clock:
    """Drives a link the way the module does: advance once per tick."""

    def __init__(self, link: Link):
        self.link = link
        self.tick = 0
        link.advance(0)

    def step(self, n: int = 1) -> None:
        for _ in range(n):
            self.tick += 1
            self.link.advance(self.tick * TICK)


def conservation(link: Link) -> None:
    """Every byte that entered a direction is delivered, lost, or still on the way."""
    fl = link.in_flight()
    for d in ("to_module", "to_host"):
        c = link.counters.direction(d)
        assert c.sent == c.delivered + (c.lost - c.lost_refused) + fl[d], (d, c, fl)


def test_links_are_ports():
    for name in ("bt", "usb", "ideal"):
        assert isinstance(make_link(name), Port)
    assert make_link("bt").profile.rate_bps == 11_520
    assert isinstance(BluetoothLink(), Link) and isinstance(UsbLink(), Link)


def test_unknown_profile_and_bad_faults_are_refused():
    with pytest.raises(ValueError, match="unknown link profile"):
        make_link("wifi")
    with pytest.raises(ValueError, match="probability"):
        DirectionFaults(byte_loss=1.5)
    with pytest.raises(ValueError, match="stall_s"):
        LinkFaults(stall_s=(2.0, 1.0))


@pytest.mark.parametrize("rate", [-1.0, math.nan, math.inf, 1e9])
def test_a_stall_or_disconnect_rate_beyond_one_event_a_tick_is_refused(rate):
    """An infinite rate drew an event every cycle (a tick never ended), 1e9 took half a second a tick."""
    said = f"must be a rate from 0 to 100 a second, got {rate}"
    with pytest.raises(ValueError, match=f"stall_rate_hz {said}"):
        LinkFaults.both(stall_rate_hz=rate)
    with pytest.raises(ValueError, match=f"disconnect_rate_hz {said}"):
        LinkFaults(disconnect_rate_hz=rate)


def test_the_highest_rates_cost_a_tick_at_most_a_few_events():
    link = make_link("bt", seed=1, faults=LinkFaults.both(stall_rate_hz=MAX_EVENT_RATE_HZ,
                                                          disconnect_rate_hz=MAX_EVENT_RATE_HZ))
    m = build_module(ModuleConfig(compiled=False), bt_port=link)
    m.run(1000)
    assert 0 < link.counters.stalls < 1000 and 0 < link.counters.disconnects < 500


def test_bt_module_to_host_throughput_is_11520_bytes_per_second():
    link = make_link("bt", seed=1)
    clk = Clock(link)
    received = 0
    for _ in range(10_000):  # 10 s with the transmit ring kept full
        link.tx_write(b"\x55" * link.tx_free())
        clk.step()
        received += len(link.host_read())
    assert abs(link.counters.to_host.wire - 115_200) <= 1
    # everything that crossed the UART reaches the host, none lost at full rate
    clk.step(200)  # the ring drains (89 ms) and the last chunk lands (≤ 40 ms)
    received += len(link.host_read())
    assert received == link.counters.to_host.sent
    assert link.counters.to_host.lost == 0


def test_bt_host_to_module_throughput_is_11520_bytes_per_second():
    link = make_link("bt", seed=2)
    clk = Clock(link)
    got_at = {}
    for t in range(11_100):
        if link.in_flight()["to_module"] < 2000:
            link.host_write(b"\x33" * 1000)
        clk.step()
        link.rx_read(400)  # the parser's per-cycle budget
        if t + 1 in (1000, 11_000):
            got_at[t + 1] = link.counters.to_module.delivered
    assert abs((got_at[11_000] - got_at[1000]) - 115_200) <= 1
    assert link.counters.to_module.lost == 0


def _ticks_until(clk: Clock, ready, limit: int = 1000) -> int:
    for _ in range(limit):
        clk.step()
        if ready():
            return clk.tick
    raise AssertionError("nothing arrived")


@pytest.mark.parametrize("direction", ["to_module", "to_host"])
def test_bt_latency_is_20_to_40_ms_and_seeded(direction):
    lat = []
    for seed in range(60):
        link = make_link("bt", seed=seed)
        clk = Clock(link)
        clk.step(5)
        t0 = clk.tick
        if direction == "to_module":
            link.host_write(b"\x03\x00\x03")
            t1 = _ticks_until(clk, lambda link=link: link.rx_pending() == 3)
        else:
            link.tx_write(b"\xa0\x03\x00\xa3")
            t1 = _ticks_until(clk, lambda link=link: link.host_pending() == 4)
        lat.append(t1 - t0)  # ms, rounded up to the tick that sees it
    # 20–40 ms on the air, + < 1 ms on the UART for 3–4 bytes, + the tick granularity
    assert min(lat) >= 20 and max(lat) <= 42
    assert min(lat) <= 24 and max(lat) >= 37  # the jitter really spans the window


def test_same_seed_same_latency_other_seed_other():
    def latency(seed):
        link = make_link("bt", seed=seed)
        clk = Clock(link)
        link.host_write(b"\x03\x00\x03")
        return _ticks_until(clk, lambda: link.rx_pending() == 3)
    assert [latency(s) for s in range(10)] == [latency(s) for s in range(10)]
    assert len({latency(s) for s in range(10)}) > 3


def test_bt_delivers_in_order_in_chunks():
    link = make_link("bt", seed=3)
    clk = Clock(link)
    sent = bytes(i & 0xFF for i in range(5000))
    pos = 0
    got = bytearray()
    reads = []
    while len(got) < len(sent):
        n = min(link.tx_free(), len(sent) - pos, 37)
        link.tx_write(sent[pos:pos + n])
        pos += n
        clk.step()
        r = link.host_read()
        if r:
            reads.append(len(r))
        got += r
        assert clk.tick < 2000
    assert bytes(got) == sent
    assert max(reads) > 12  # held-back chunks arrive together, as SPP bursts do
    conservation(link)


def test_bt_receive_ring_overflow_loses_and_counts():
    link = make_link("bt", seed=4)
    clk = Clock(link)
    data = bytes(range(256)) * 8  # 2048 bytes while the µC does not read
    assert link.host_write(data) == 2048
    clk.step(1000)
    assert link.rx_pending() == 512
    assert link.counters.to_module.lost_overflow == 2048 - 512
    assert link.rx_read(1000) == data[:512]  # the first ones fit, the later ones were lost
    conservation(link)


def test_bt_transmit_ring_is_1024_bytes():
    link = make_link("bt")
    Clock(link)
    assert link.tx_free() == 1024
    link.tx_write(b"x" * 1000)
    assert link.tx_free() == 24
    with pytest.raises(ValueError, match="only 24 free"):
        link.tx_write(b"x" * 25)


def _faulty_run(seed: int) -> tuple[bytes, bytes, dict]:
    faults = LinkFaults.both(byte_loss=0.01, corrupt=0.01)
    link = make_link("bt", seed=seed, faults=faults)
    clk = Clock(link)
    to_host = bytearray()
    to_module = bytearray()
    for t in range(3000):
        if t % 10 == 0:
            link.host_write(bytes(range(40)))
        link.tx_write(bytes([t & 0xFF]) * min(12, link.tx_free()))
        clk.step()
        to_module += link.rx_read(400)
        to_host += link.host_read()
    return bytes(to_module), bytes(to_host), link.counters.as_dict()


def test_seeded_faults_lose_the_same_bytes_twice():
    a = _faulty_run(11)
    b = _faulty_run(11)
    c = _faulty_run(12)
    assert a == b
    assert a != c
    counters = a[2]
    for d in ("to_module", "to_host"):
        sent = counters[d]["sent"]
        assert 0.005 * sent < counters[d]["lost_fault"] < 0.02 * sent
        assert 0.005 * sent < counters[d]["corrupted"] < 0.02 * sent


def test_faults_do_not_move_the_jitter():
    """Switching faults on keeps the latency draws: a test can add faults without
    changing the timing it relies on."""
    def arrival(faults):
        link = make_link("bt", seed=5, faults=faults)
        clk = Clock(link)
        link.host_write(b"\x03\x00\x03")
        return _ticks_until(clk, lambda: link.rx_pending() > 0)
    assert arrival(None) == arrival(LinkFaults.both(corrupt=0.5))


def test_default_bt_loses_nothing_without_overflow_stall_or_disconnect():
    link = make_link("bt", seed=6)
    clk = Clock(link)
    for _ in range(2000):
        link.host_write(b"\x03\x00\x03")
        link.tx_write(b"\xa0\x03\x00\xa3")
        clk.step()
        link.rx_read(400)
        link.host_read()
    counters = link.counters
    assert counters.to_module.lost == counters.to_host.lost == 0
    assert counters.to_module.corrupted == counters.to_host.corrupted == 0


def test_usb_is_lossless_with_flow_control_and_fast():
    link = make_link("usb")
    clk = Clock(link)
    data = bytes(i * 7 & 0xFF for i in range(50_000))
    assert link.host_write(data) == len(data)
    got = bytearray()
    while len(got) < len(data):
        clk.step()
        got += link.rx_read(100)  # a slow reader: the ring fills, bytes wait
        assert clk.tick < 1000
    assert bytes(got) == data
    assert link.counters.to_module.lost == 0
    t0 = clk.tick
    link.tx_write(b"\xa0\x03\x00\xa3")
    assert _ticks_until(clk, lambda: link.host_pending() == 4) - t0 <= 2  # ~1 ms


def test_ideal_link_is_immediate_and_unbounded():
    link = make_link("ideal")
    link.advance(0)
    assert link.host_write(b"\x03\x00\x03" * 10_000) == 30_000
    assert link.rx_read(1 << 20) == b"\x03\x00\x03" * 10_000
    link.tx_write(b"\xa0\x03\x00\xa3")
    assert link.host_read() == b"\xa0\x03\x00\xa3"


def test_disconnect_loses_what_is_in_flight_and_refuses_host_bytes():
    link = make_link("bt", seed=8)
    clk = Clock(link)
    link.tx_write(b"z" * 500)
    link.host_write(b"\x03\x00\x03")
    clk.step(2)
    link.disconnect()
    assert not link.connected and link.tx_free() == 0
    assert link.host_write(b"\x03\x00\x03") == 0
    c = link.counters
    assert c.disconnects == 1
    assert c.to_module.lost_refused == 3
    assert c.to_module.lost_disconnect == 3
    assert c.to_host.lost_disconnect + c.to_host.delivered == 500
    conservation(link)
    link.reconnect()
    assert link.connected and c.connects == 1
    link.host_write(b"\x03\x00\x03")
    _ticks_until(clk, lambda: link.rx_pending() == 3)
    assert link.rx_read(3) == b"\x03\x00\x03"


def test_stall_holds_then_delivers_and_overflows_the_radio_buffer():
    link = make_link("bt", seed=9)
    clk = Clock(link)
    link.stall(0.5)
    assert link.stalled()
    got = 0
    for _ in range(499):
        link.tx_write(b"s" * link.tx_free())
        clk.step()
        got += len(link.host_read())
    assert got == 0
    clk.step(1)
    got += len(link.host_read())
    assert got == 1024  # the radio's buffer, delivered when the stall ends
    # 0.5 s × 11 520 B/s crossed the UART; what did not fit the radio's buffer is lost
    assert link.counters.to_host.lost_overflow == link.counters.to_host.wire - 1024
    assert link.counters.to_host.lost_overflow > 4500
    assert link.counters.stalls == 1
    conservation(link)


def test_random_stalls_and_disconnects_are_seeded():
    faults = LinkFaults(to_host=DirectionFaults(stall_rate_hz=1.0), disconnect_rate_hz=0.5,
                        reconnect_s=(0.2, 0.4))

    def run(seed):
        link = make_link("bt", seed=seed, faults=faults)
        clk = Clock(link)
        downs = 0
        for _ in range(20_000):
            if link.connected:
                link.tx_write(b"r" * min(20, link.tx_free()))
            clk.step()
            link.host_read()
            downs += not link.connected
        conservation(link)
        return link.counters.as_dict(), downs

    a, downs = run(3)
    assert a == run(3)[0]
    assert a["stalls"] >= 5 and a["disconnects"] >= 3
    assert a["connects"] in (a["disconnects"], a["disconnects"] - 1)  # came back by itself
    assert 0 < downs < 20_000


def test_corrupt_next_and_drop_next():
    link = make_link("ideal", seed=1)
    link.advance(0)
    link.corrupt_next(2)
    link.tx_write(b"\xa0\x03\x00\xa3")
    got = link.host_read()
    assert got[2:] == b"\x00\xa3" and got[0] != 0xA0 and got[1] != 0x03
    link.drop_next(1, direction="to_module")
    link.host_write(b"\x03\x00\x03")
    assert link.rx_read(10) == b"\x00\x03"
    assert link.counters.to_host.corrupted == 2 and link.counters.to_module.lost_fault == 1


def test_time_cannot_go_backwards():
    link = make_link("bt")
    link.advance(TICK * 5)
    with pytest.raises(ValueError, match="backwards"):
        link.advance(TICK)


ops = st.lists(
    st.tuples(
        st.sampled_from(["host_write", "tx_write", "step", "rx_read", "host_read", "stall", "disconnect",
                         "connect"]),
        st.integers(0, 700),
    ),
    max_size=60,
)


@settings(max_examples=60, deadline=None)
@given(ops=ops, profile=st.sampled_from(["bt", "usb", "ideal"]), seed=st.integers(0, 3),
       lossy=st.booleans())
def test_every_byte_is_accounted_for(ops, profile, seed, lossy):
    faults = LinkFaults.both(byte_loss=0.05, corrupt=0.05) if lossy else None
    link = make_link(profile, seed=seed, faults=faults)
    clk = Clock(link)
    for op, n in ops:
        if op == "host_write":
            link.host_write(bytes(n))
        elif op == "tx_write":
            link.tx_write(bytes(min(n, link.tx_free())))
        elif op == "step":
            clk.step(n // 10 + 1)
        elif op == "rx_read":
            link.rx_read(n)
        elif op == "host_read":
            link.host_read(n)
        elif op == "stall":
            link.stall(n / 1000)
        elif op == "disconnect":
            link.disconnect()
        else:
            link.connect()
        conservation(link)


def test_faults_are_per_direction():
    link = make_link("bt", seed=2, faults=LinkFaults(to_module=DirectionFaults(byte_loss=0.5)))
    clk = Clock(link)
    for _ in range(500):
        link.host_write(b"\x03\x00\x03")
        link.tx_write(b"\xa0\x03\x00\xa3")
        clk.step()
        link.rx_read(400)
        link.host_read()
    assert link.counters.to_module.lost_fault > 0
    assert link.counters.to_host.lost == 0 and link.counters.to_host.corrupted == 0


def test_a_stall_towards_the_module_holds_commands_without_loss():
    link = make_link("bt", seed=3)
    clk = Clock(link)
    link.stall(0.3, direction="to_module")
    link.host_write(b"\x03\x00\x03")
    clk.step(299)
    assert link.rx_pending() == 0
    clk.step(2)
    assert link.rx_read(10) == b"\x03\x00\x03"
    assert link.counters.to_module.lost == 0


def test_quiet_until_bounds_when_the_module_or_the_host_sees_something():
    """The compiled path runs a module's loops ahead of its link only up to quiet_until():
    a lower bound of the first delivery to the µC or the host or the next scheduled
    disconnect or reconnect; idle() says whether the link may then skip the ticks between."""
    link = make_link("bt", seed=1)
    assert link.quiet_until() == 0 and not link.idle(), "not started: the first advance schedules faults"
    clk = Clock(link)
    assert link.quiet_until() is None and link.idle(), "nothing in flight, no faults"
    link.tx_write(b"\xaa" * 10)
    until = link.quiet_until()
    assert until >= link.now_cycles + 20 * TICK and not link.idle(), "on the wire, then ≥ 20 ms in the air"
    seen = 0
    while not link.host_pending():
        clk.step()
        seen += 1
    assert link.now_cycles >= until, "nothing reached the host before the bound"
    assert link.host_read() == b"\xaa" * 10 and 20 <= seen <= 50
    clk.step(30)
    assert link.quiet_until() is None and link.idle()
    link.host_write(b"\x03\x00\x03")
    until = link.quiet_until()
    assert until >= link.now_cycles + 20 * TICK
    while not link.rx_pending():
        clk.step()
    assert link.now_cycles >= until, "nothing reached the µC before the bound"
    assert link.quiet_until() == link.now_cycles, "bytes in the receive ring: not quiet"
    assert link.rx_read(10) == b"\x03\x00\x03"
    faulty = make_link("bt", seed=1, faults=LinkFaults(disconnect_rate_hz=2.0, reconnect_s=(0.1, 0.1)))
    clk = Clock(faulty)
    until = faulty.quiet_until()
    assert until is not None and until > 0 and not faulty.idle()
    while faulty.connected:
        assert faulty.now_cycles < until
        clk.step()
    assert faulty.now_cycles >= until, "the link went down at the time it announced"
    assert faulty.quiet_until() > faulty.now_cycles, "next: the reconnect"


@settings(max_examples=80, deadline=None)
@given(ops=ops, profile=st.sampled_from(["bt", "usb", "ideal"]), seed=st.integers(0, 3),
       faulty=st.booleans())
def test_quiet_until_is_a_lower_bound(ops, profile, seed, faulty):
    """Whatever is in flight, stalled or scheduled: stepping the link tick by tick, nothing
    reaches the µC's receive ring or the host and the connection does not change while the
    time is before quiet_until() (the compiled path relies on it to run loops ahead)."""
    faults = LinkFaults(to_host=DirectionFaults(stall_rate_hz=2.0), disconnect_rate_hz=1.0,
                        reconnect_s=(0.05, 0.1)) if faulty else None
    link = make_link(profile, seed=seed, faults=faults)
    clk = Clock(link)

    def step_checked(ticks: int) -> None:
        for _ in range(ticks):
            until = link.quiet_until()
            state = (link.rx_pending(), link.host_pending(), link.connected)
            clk.step()
            if until is None or link.now_cycles < until:
                assert (link.rx_pending(), link.host_pending(), link.connected) == state, (
                    f"a change at {link.now_cycles} before the bound {until}")

    for op, n in ops:
        if op == "host_write":
            link.host_write(bytes(n))
        elif op == "tx_write":
            link.tx_write(bytes(min(n, link.tx_free())))
        elif op == "stall":
            link.stall(n / 1000)
        elif op in ("rx_read", "host_read"):
            link.rx_read(n) if op == "rx_read" else link.host_read(n)
        else:
            step_checked(n // 10 + 1)
    step_checked(150)  # everything in flight lands (or is held by a stall)


# --------------------------------------------------------------------------- real time: the host's clock


class HostClock:
    """A host clock a test sets by hand (module cycles)."""

    def __init__(self, now: int = 0):
        self.now = now

    def __call__(self) -> int:
        return self.now


def test_module_ahead_of_the_host_its_bytes_reach_the_host_at_the_hosts_time_not_earlier():
    link = make_link("bt", seed=3)
    host = HostClock(0)
    link.host_clock = host
    link.late_tolerance_cycles = TICK  # the host looks once a tick
    link.advance(0)
    link.tx_write(b"\xa0\x03\x00\xa3")
    link.advance(45 * TICK)  # the module ran 45 ms: the ack has arrived on the module's clock
    assert link.host_pending() == 0 and link.in_flight()["to_host"] == 4  # the host is still at 0
    got = b""
    for ms in range(1, 46):  # the host looks every millisecond
        host.now = ms * TICK
        got += link.host_read()
        if got:
            break
    assert got == b"\xa0\x03\x00\xa3" and 20 <= ms <= 41  # at the host's 20–40 ms (+ UART), not at 0
    c = link.counters.to_host
    assert c.delivered == 4 and c.late == 0 and c.late_max_cycles < TICK


def test_host_bytes_leave_at_the_hosts_present_and_arrive_after_the_latency():
    link = make_link("bt", seed=1)
    host = HostClock(100 * TICK)
    link.advance(110 * TICK)  # the module runs 10 ms ahead of the host
    link.host_clock = host
    link.host_write(b"\x03\x00\x03")
    t = 110
    while not link.rx_pending():
        t += 1
        link.advance(t * TICK)
    assert 120 <= t <= 142  # 20–40 ms after the host's 100 ms (+ UART), not after the module's 110
    assert link.counters.to_module.late == 0


def test_bytes_that_reach_the_host_after_their_time_are_counted_late():
    link = make_link("bt", seed=2)
    host = HostClock(0)
    link.host_clock = host
    link.late_tolerance_cycles = 4 * TICK
    link.advance(0)
    link.tx_write(b"\x01\x02")
    link.advance(45 * TICK)
    host.now = 100 * TICK  # the host looks only 100 ms later (its endpoint was not pumped)
    assert link.host_read() == b"\x01\x02"
    c = link.counters.to_host
    assert c.late == 2 and 60 * TICK <= c.late_max_cycles <= 80 * TICK


def test_a_module_ahead_by_more_than_the_latency_counts_the_host_bytes_late():
    link = make_link("bt", seed=0)
    link.advance(100 * TICK)
    link.host_clock = HostClock(0)  # 100 ms ahead: more than the 20 ms the link allows
    link.host_write(b"\x03\x00\x03")
    assert link.counters.to_module.late == 3
    assert link.lookahead_cycles() == 20 * TICK
    assert make_link("usb").lookahead_cycles() == TICK and make_link("ideal").lookahead_cycles() == 0


def test_without_a_host_clock_the_host_lives_on_the_modules_clock():
    link = make_link("bt", seed=3)
    link.advance(0)
    link.tx_write(b"\xa0")
    link.advance(19 * TICK)
    assert link.host_read() == b""  # under the latency on the module's clock: nothing yet
    link.advance(45 * TICK)  # past the latency and the jitter: there, read at once, never late
    assert link.host_read() == b"\xa0" and link.counters.to_host.late == 0
    assert link.next_host_arrival() is None


def test_next_host_arrival_is_known_once_the_module_passed_it():
    link = make_link("bt", seed=4)
    link.advance(0)
    assert link.next_host_arrival() is None  # no host clock: the module's clock delivers
    host = HostClock(0)
    link.host_clock = host
    link.tx_write(b"\xa0\x03\x00\xa3")
    link.advance(10 * TICK)
    assert link.next_host_arrival() is None  # on the air, arriving after the module's present
    link.advance(45 * TICK)
    at = link.next_host_arrival()
    assert at is not None and 20 * TICK <= at <= 41 * TICK
    host.now = at - 1
    assert link.host_read() == b""
    host.now = at
    assert link.host_read() == b"\xa0\x03\x00\xa3" and link.next_host_arrival() is None
