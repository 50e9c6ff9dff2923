"""Device: commands with acks, timeouts, retries, the reader thread, iterators, reconnects.

Against an in-memory scripted port (tests/hostlib/fakes.py) and pyserial's own
``loop://``. No sleeps: every wait is on an event or a short deadline.
"""

from __future__ import annotations

import inspect
import re
import threading

import numpy as np
import pytest
import serial

from hostlib.errors import AckTimeout, DeviceClosed, NotSupportedByCommandSet
from hostlib.events import CommandAckEvent, GapEvent, LinkEvent, PacketEvent, StepEvent
from hostlib.link.device import Device
from hostlib.link.device_options import DeviceOptions
from protocol.codec import encode_step
from protocol.commands import LEGACY_2014, command_set
from protocol.frames import build_command_ack, build_packet_ack, build_state_packet, parse_command
from protocol.ids import Command, StateId

from .fakes import FakeModulePort


def step_packet(number: int, counter: int, dx=(0.7, 0.0, 0.0, 0.0)) -> bytes:
    return build_state_packet(number, encode_step(np.array(dx), np.eye(4) * 1e-4, counter))


@pytest.fixture
def fake():
    return FakeModulePort()


@pytest.fixture
def dev(fake):
    with Device(fake, ack_timeout=2.0) as d:
        yield d


def test_ping_waits_for_its_ack(dev, fake):
    assert dev.ping().command_id == 0x03
    assert fake.commands == [bytes.fromhex("03 00 03")]


def test_a_command_method_returns_the_ack_it_waited_for_in_the_devices_numbering(dev):
    assert dev.start_stepwise_dead_reckoning() == CommandAckEvent(0x34)
    assert dev.set_state(StateId.TH_ZUPT, 100000, timeout=1.0, retries=0) == CommandAckEvent(0x13)
    with Device(FakeModulePort(LEGACY_2014), command_set="2014") as d:
        assert d.start_stepwise_dead_reckoning() == CommandAckEvent(0x14)


def test_the_packet_ack_is_not_a_command_that_waits(dev, fake):
    with pytest.raises(ValueError, match="ack_packet"):
        dev.command(Command.ACK, packet_number=1)
    assert fake.written == b""


def test_command_methods_declare_what_they_return():
    from hostlib.link.commands import CommandMethods

    methods = {n: f for n, f in vars(CommandMethods).items() if callable(f) and not n.startswith("_")}
    returns = {n: inspect.get_annotations(f)["return"] for n, f in methods.items()}
    assert returns.pop("ack_packet") == "None"
    assert set(returns.values()) == {"CommandAckEvent"}
    untyped = [n for n, f in methods.items() if n != "command"  # its fields depend on the command
               for a in inspect.get_annotations(f).values() if re.search(r"\bAny\b", a)]
    assert untyped == []


def test_typed_commands_send_the_documented_frames(dev, fake):
    dev.set_state(StateId.TH_ZUPT, 100000)
    dev.output_all_off()
    dev.start_stepwise_dead_reckoning()
    dev.output_multiple_states([0x01, 0x13], mode=1)
    dev.input_imu_rd(5, np.zeros((4, 6), dtype=int))
    assert fake.commands[0] == bytes.fromhex("13 19 00 01 86 A0 01 53")
    assert fake.commands[1] == bytes.fromhex("22 00 22")
    assert fake.commands[2] == bytes.fromhex("34 00 34")
    assert fake.commands[3][0] == 0x21 and len(fake.commands[3]) == 12
    assert fake.commands[4][0] == 0x11 and len(fake.commands[4]) == 55


def test_2014_numbering_is_chosen_per_device():
    fake = FakeModulePort(LEGACY_2014)
    with Device(fake, command_set="2014") as d:
        d.start_stepwise_dead_reckoning()
        d.output_all_off()
        assert fake.commands == [bytes.fromhex("14 00 14"), bytes.fromhex("21 00 21")]
        with pytest.raises(NotSupportedByCommandSet):
            d.mimu_frontend()


def test_silent_module_times_out_after_bounded_retries():
    fake = FakeModulePort(mute=True)
    with Device(fake, ack_timeout=0.05, retries=2) as d:
        with pytest.raises(AckTimeout, match="PING") as info:
            d.ping()
        assert info.value.attempts == 3
        assert fake.commands == [bytes.fromhex("03 00 03")] * 3


def test_the_options_object_and_its_fields_as_keywords_set_a_device_up_alike():
    options = DeviceOptions(command_set="2014", ack_timeout=0.05, retries=0, queue_size=3)
    with Device(FakeModulePort(mute=True), options) as d:
        assert (d.session.command_set.name, d.ack_timeout, d.retries) == ("2014", 0.05, 0)
        with pytest.raises(AckTimeout) as info:
            d.ping()
        assert info.value.attempts == 1
    with Device(FakeModulePort(LEGACY_2014), options, retries=4) as d:  # a keyword wins over the options
        assert d.options == DeviceOptions(command_set="2014", ack_timeout=0.05, retries=4, queue_size=3)
        assert d.ping() == CommandAckEvent(0x03)
    with pytest.raises(TypeError, match="ack_timout"):
        Device(FakeModulePort(), ack_timout=1.0)


def test_retry_succeeds_when_the_first_command_is_lost(fake):
    calls = []

    def lossy(frame):
        calls.append(frame)
        return None if len(calls) == 1 else build_command_ack(frame[0])

    fake.on_command = lossy
    with Device(fake, ack_timeout=0.05, retries=2) as d:
        d.ping()
    assert len(calls) == 2


def test_packet_ack_gets_no_wait(dev, fake):
    assert dev.ack_packet(0x0102) is None
    assert fake.wait_written(lambda f: f.packet_acks == [0x0102])
    assert bytes.fromhex("01 01 02 00 04") in fake.written


def test_steps_are_acked_summed_and_iterated(dev, fake):
    dev.start_stepwise_dead_reckoning()
    for n in range(1, 4):
        fake.inject(step_packet(n, n))
    fake.inject(step_packet(3, 3))  # a resend
    got = []
    for ev in dev.steps(timeout=5.0):
        got.append(ev)
        if len(got) == 3:
            break
    assert [e.step.counter for e in got] == [1, 2, 3]
    assert fake.wait_written(lambda f: len(f.packet_acks) == 4)
    assert fake.packet_acks == [1, 2, 3, 3]
    assert dev.track.distance == pytest.approx(2.1, rel=1e-6)


def test_lossless_ack_waits_behind_data(fake):
    """The command ack comes only after the host acked the queued packets (stop-and-wait)."""
    fake.on_command = lambda frame: None  # we script the reply below
    with Device(fake, ack_timeout=2.0) as d:
        d.session.plan.lossless = True
        d.session.plan.outputs = frozenset({StateId.IMU_TS})
        fake.on_command = lambda frame: build_state_packet(1, bytes(4)) if frame[0] == 0x03 else None

        def module():
            # when the host acks packet 1, send packet 2; when it acks 2, send the command ack
            assert fake.wait_written(lambda f: 1 in f.packet_acks)
            fake.inject(build_state_packet(2, bytes(4)))
            assert fake.wait_written(lambda f: 2 in f.packet_acks)
            fake.inject(build_command_ack(0x03))

        t = threading.Thread(target=module)
        t.start()
        d.ping()
        t.join(5)
        assert d.stats["packets"] == 2


def test_callbacks_get_their_events_in_the_reader_and_a_broken_one_does_not_stop_it(dev, fake):
    seen = threading.Event()
    steps, acks = [], []
    dev.on_step(lambda ev: (steps.append(ev), seen.set()))
    dev.on_ack(acks.append)
    dev.on_packet(lambda ev: 1 / 0)  # a broken callback does not kill the reader
    dev.ping()
    fake.inject(step_packet(1, 1))
    assert seen.wait(5)
    assert isinstance(steps[0], StepEvent) and acks == [CommandAckEvent(0x03)]
    assert dev.recv_packet(timeout=5).number == 1
    assert dev.recv_packet(timeout=0.01) is None
    assert dev.callback_errors == 1


def test_a_callback_registered_for_a_kind_is_called_for_that_kind_only(fake):
    got = {"packet": [], "step": [], "gap": []}
    with Device(fake, start=False) as d:
        for kind, events in got.items():
            getattr(d, f"on_{kind}")(events.append)
        d.feed(step_packet(1, 1) + step_packet(2, 4))
    assert [type(e) for e in got["packet"]] == [PacketEvent, PacketEvent]
    assert [e.step.counter for e in got["step"]] == [1, 4]
    assert got["gap"] == [GapEvent(after=1, counter=4, missing=2, index=2)]


def test_a_wrong_callback_kind_or_callback_is_an_error_not_ignored(dev):
    with pytest.raises(AttributeError):
        dev.add_callback("step", print)  # kinds are methods, not strings
    with pytest.raises(AttributeError):
        dev.on_stance(print)
    with pytest.raises(TypeError, match="callable"):
        dev.on_step("step")
    with pytest.raises(ValueError, match="not a callback"):
        dev.remove_callback(print)


def test_a_removed_callback_is_no_longer_called_and_on_methods_decorate(fake):
    calls = []
    with Device(fake, start=False) as d:

        @d.on_packet
        def count(ev: PacketEvent) -> None:
            calls.append(ev.number)

        d.feed(build_state_packet(1, bytes(4)))
        d.remove_callback(count)
        d.feed(build_state_packet(2, bytes(4)))
    assert calls == [1]


def test_single_reads_and_iterators_take_turns_on_the_same_packets_and_steps(fake):
    with Device(fake, start=False) as d:  # no reader thread: feed() hands the bytes in
        d.feed(b"".join(step_packet(n, n) for n in range(1, 5)))
        packets = d.packets(timeout=0)
        assert [d.recv_packet(0).number, next(packets).number, d.recv_packet(0).number] == [1, 2, 3]
        assert [p.number for p in packets] == [4]
        steps = d.steps(timeout=0)
        assert [d.recv_step(0).step.counter, next(steps).step.counter] == [1, 2]
        assert [ev.step.counter for ev in steps] == [3, 4]
        assert d.recv_packet(0) is None and d.recv_step(0) is None


def test_after_close_single_reads_raise_and_iterators_end_once_the_queue_is_read(fake):
    d = Device(fake, start=False)
    d.feed(step_packet(1, 1) + step_packet(2, 2))
    d.close()
    assert d.recv_packet(0).number == 1 and [p.number for p in d.packets()] == [2]
    assert d.recv_step(0).step.counter == 1 and [ev.step.counter for ev in d.steps()] == [2]
    for read in (d.recv_packet, d.recv_step):
        with pytest.raises(DeviceClosed):
            read(0)
    assert list(d.packets()) == [] and list(d.steps()) == []


@pytest.mark.parametrize("kind", ["packet", "step"])
def test_each_queued_kind_has_a_single_read_and_an_iterator(kind):
    assert callable(getattr(Device, f"recv_{kind}")) and callable(getattr(Device, f"{kind}s"))
    assert not hasattr(Device, "recv")


def test_garbage_and_gaps_are_counted(dev, fake):
    fake.inject(b"\x00\x13\x37" + step_packet(1, 1) + b"\xff" + step_packet(2, 5))
    evs = [dev.recv_step(5), dev.recv_step(5)]
    assert [e.step.counter for e in evs] == [1, 5]
    st = dev.stats
    assert st["garbage_bytes"] == 4 and st["missing_steps"] == 3 and st["gaps"] == 1
    assert dev.gap_events[0].missing == 3


def test_full_queue_is_reported_not_silent(fake):
    with Device(fake, queue_size=2) as d:
        with pytest.warns(Warning, match="queue is full"):
            d.feed(b"".join(build_state_packet(n, bytes(4)) for n in range(1, 6)))
        assert d.stats["dropped_packets"] == 3


def test_close_wakes_waiters_and_refuses_commands(fake):
    d = Device(fake)
    result = []
    t = threading.Thread(target=lambda: result.append(list(d.packets())))
    t.start()
    d.close()
    t.join(5)
    assert result == [[]]
    assert not fake.is_open
    with pytest.raises(DeviceClosed):
        d.ping()
    d.close()  # idempotent


def test_reconnects_after_a_dropped_link():
    ports = [FakeModulePort(), FakeModulePort()]
    made = []

    def factory():
        made.append(ports[len(made)])
        return made[-1]

    links = []
    back = threading.Event()
    with Device(port_factory=factory, reconnect_interval=0.01) as d:
        d.on_link(lambda ev: (links.append(ev.up), ev.up and back.set()))
        d.start_stepwise_dead_reckoning()
        ports[0].inject(step_packet(1, 1))
        assert d.recv_step(5).step.counter == 1
        ports[0].drop()
        assert back.wait(5)
        assert links == [False, True] and d.link_up
        # the module resends the unacked packet, then the next step
        ports[1].inject(step_packet(1, 1) + step_packet(2, 2))
        assert d.recv_step(5).step.counter == 2
        assert d.stats["link_drops"] == 1 and d.stats["reconnects"] == 1
        assert d.stats["duplicate_packets"] == 1
        assert isinstance(LinkEvent(True), LinkEvent)


def test_without_reconnect_a_drop_closes_the_device(fake):
    d = Device(fake, reconnect=False)
    fake.drop()
    with pytest.raises(DeviceClosed):
        d.recv_packet(timeout=5)
    assert d.closed


# -- pyserial's loop:// (a real pyserial port object) ---------------------------------------


def test_loop_url_commands_time_out_and_packets_flow():
    # loop:// echoes what the host writes: commands come back as garbage, never as acks.
    with Device("loop://", ack_timeout=0.05, retries=0) as d:
        with pytest.raises(AckTimeout):
            d.ping()
        d.send_raw(step_packet(1, 1))  # bytes written to loop:// arrive as module bytes
        ev = d.recv_step(5)
        assert ev.step.counter == 1
        assert d.stats["acks_sent"] == 1
        assert d.stats["garbage_bytes"] >= 3  # the echoed ping


def test_already_open_serial_object():
    port = serial.serial_for_url("loop://", timeout=0.05)
    with Device(port) as d:
        d.send_raw(build_state_packet(4, bytes(4)) + build_packet_ack(0))
        assert d.recv_packet(timeout=5).number == 4
    assert not port.is_open


def test_openshoe_url_needs_the_emulator_package(monkeypatch):
    import hostlib.link.connection as conn

    monkeypatch.setattr(conn, "EMULATOR_HANDLER_PACKAGE", "no_such_package_here")
    with pytest.raises(ValueError, match="emulator"):
        Device("openshoe://")


def test_needs_a_target():
    with pytest.raises(ValueError, match="needs"):
        Device()


# every typed method sends the frame of its command, in both numberings where it exists
METHOD_CALLS = [
    ("ping", (), Command.PING),
    ("request_mcu_id", (), Command.MCU_ID),
    ("set_state", (StateId.GP_ID, 7), Command.SET_STATE_1),
    ("set_state", (StateId.TH_ZARU, 5), Command.SET_STATE_4),
    ("set_state", (StateId.POSITION, [1.0, 2.0, 3.0]), Command.SET_STATE_12),
    ("set_state", (StateId.U_K, [0.0] * 6), Command.SET_STATE_24),
    ("set_state", (StateId.DP, [0.0] * 10), Command.SET_STATE_48),
    ("set_state", (StateId.P, [0.0] * 45), Command.SET_STATE_254),
    ("output_state", (0x01, 1), Command.OUTPUT_STATE),
    ("output_multiple_states", ([0x01, 0x02], 1), Command.OUTPUT_MULTIPLE_STATES),
    ("output_all_off", (), Command.OUTPUT_ALL_OFF),
    ("state_if_setup", (0x33, 0x20, [0x30]), Command.STATE_IF_SETUP),
    ("output_imu_rd", (0xF, 0x41), Command.OUTPUT_IMU_RD),
    ("set_imu_bandwidth", (3,), Command.SET_IMU_BANDWIDTH),
    ("run_proc", (0x13, 0), Command.RUN_PROC),
    ("run_mult_proc", ([0x13, 0x10],), Command.RUN_MULT_PROC),
    ("all_proc_off", (), Command.ALL_PROC_OFF),
    ("start_zupt_aided_ins", (), Command.RESET_ZUPT_AIDED_INS),
    ("start_stepwise_dead_reckoning", (), Command.STEPWISE_DEAD_RECKONING),
    ("mimu_frontend", (), Command.MIMU_FRONTEND),
    ("reset_proc_setup", (0x24,), Command.RESET_PROC_SETUP),
    ("store_and_empty", (), Command.STORE_AND_EMPTY),
    ("restore_proc_sequ", (), Command.RESTORE_PROC_SEQU),
    ("normal_imu", (1,), Command.NORMAL_IMU),
    ("normal_imu_with_bias_est", (1,), Command.NORMAL_IMU_WITH_BIAS_EST),
    ("setup_debug_proc", ([0x10, 0x11], [0x13]), Command.SETUP_DEBUG_PROC),
    ("input_imu_rd", (1, np.ones((4, 6), dtype=int)), Command.INPUT_IMU_RD),
    ("gp_test", (1, 2), Command.GP_TEST),
]


@pytest.mark.parametrize("numbering", ["2015", "2014"])
def test_every_typed_method_sends_its_command(numbering):
    cs = command_set(numbering)
    fake = FakeModulePort(cs)
    with Device(fake, command_set=numbering, ack_timeout=2.0) as d:
        for name, args, meaning in METHOD_CALLS:
            if not cs.supports(meaning):
                with pytest.raises(NotSupportedByCommandSet):
                    getattr(d, name)(*args)
                continue
            n = len(fake.commands)
            ack = getattr(d, name)(*args)
            frame = parse_command(fake.commands[n], cs)
            assert frame.command is meaning, name
            assert ack == CommandAckEvent(cs.spec(meaning).wire_id), name
    assert {m for _, _, m in METHOD_CALLS} | {Command.ACK} == set(Command)


def test_an_already_open_port_object_is_reopened_after_a_drop(fake):
    back = threading.Event()
    with Device(fake, reconnect_interval=0.01) as d:
        d.on_link(lambda ev: ev.up and back.set())
        fake.drop()
        assert back.wait(5)
        assert fake.reopens == 1
        d.ping()


def test_stray_header_before_an_ack_is_resolved_by_the_reader(fake):
    fake.on_command = lambda frame: b"\xaa\x00\x01\x10" + build_command_ack(frame[0])
    with Device(fake, ack_timeout=5.0, retries=0) as d:
        d.ping()
        assert d.stats["garbage_bytes"] == 4


def test_close_while_waiting_for_an_ack_raises_device_closed():
    fake = FakeModulePort(mute=True)
    d = Device(fake, ack_timeout=30.0, retries=0)
    errors = []

    def waiter():
        try:
            d.ping()
        except DeviceClosed as exc:
            errors.append(exc)

    t = threading.Thread(target=waiter)
    t.start()
    assert fake.wait_written(lambda f: len(f.commands) == 1)
    d.close()
    t.join(5)
    assert len(errors) == 1 and "closed" in str(errors[0])


def test_close_ends_an_iterator_even_when_its_queue_is_full(fake):
    d = Device(fake, queue_size=2, start=False)
    with pytest.warns(Warning, match="queue is full"):
        d.feed(b"".join(build_state_packet(n, bytes(4)) for n in range(1, 5)))
    d.close()
    assert [p.number for p in d.packets()] == [1, 2]  # no timeout, yet it ends


def test_ack_behind_lossless_data_extends_the_wait(fake, monkeypatch):
    """The module acks only after 10 data packets, 0.05 s apart (on a test clock): longer than the
    0.1 s ack timeout, but the data keeps flowing, so the host keeps waiting (and acking)."""
    import hostlib.link.device as device_module

    clock = [1000.0]
    monkeypatch.setattr(device_module, "_now", lambda: clock[0])
    state = {}
    fake.on_command = lambda frame: None  # the ping is answered below, behind the data
    with Device(fake, ack_timeout=0.1, retries=0) as d:
        d.session.plan.lossless = True
        d.session.plan.outputs = frozenset({StateId.IMU_TS})

        def run():
            assert fake.wait_written(lambda f: len(f.commands) == 1)
            for n in range(1, 11):
                clock[0] += 0.05
                fake.inject(build_state_packet(n, bytes(4)))
                assert fake.wait_written(lambda f, n=n: n in f.packet_acks)
            fake.inject(build_command_ack(0x03))
            state["done"] = True

        t = threading.Thread(target=run)
        t.start()
        d.ping()
        t.join(5)
    assert state.get("done") and clock[0] - 1000.0 > 0.1
