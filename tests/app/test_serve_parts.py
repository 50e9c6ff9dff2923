"""The parts of `openshoe-emu serve` that need no subprocess: link sharing, held sensors, control commands."""

from __future__ import annotations

import argparse

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from firmware_sim.app.control import ControlServer
from firmware_sim.app.serve import parse_ready, tcp_address
from firmware_sim.app.served_module import ServedModule
from firmware_sim.links.link import make_link
from firmware_sim.mcu.imu_bus import RawSample, ScriptedSource
from firmware_sim.mcu.port import IdealPort
from firmware_sim.sensors.playback import HoldLastSource, StartOnFirstRead, served_source
from firmware_sim.transports.hub import HostHub

from .serve_args import serve_args


def test_one_link_fans_out_to_every_connected_host():
    port = IdealPort()
    hub = HostHub(port)
    assert not port.connected, "no host yet: the link is down"
    pty, tcp = hub.tap("pty"), hub.tap("tcp")
    pty.connect()
    assert port.connected
    port.tx_write(b"\xa0\x03\x00\xa3")
    tcp.connect()  # joins later: does not get what was sent before
    port.tx_write(b"\xaa")
    assert pty.host_read() == b"\xa0\x03\x00\xa3\xaa"
    assert tcp.host_read() == b"\xaa"
    assert tcp.host_write(b"\x03\x00\x03") == 3 and port.rx_read(10) == b"\x03\x00\x03"
    pty.disconnect()
    assert port.connected, "one host is still there"
    tcp.disconnect()
    assert not port.connected


def test_a_finished_source_holds_its_last_sample():
    script = np.arange(2 * 4 * 6, dtype=np.int16).reshape(2, 4, 6)
    src = HoldLastSource(ScriptedSource(script, finite=True))
    first, last = src.read(0), src.read(1)
    assert src.read(2) is not None and np.array_equal(src.read(5).imu, last.imu)
    assert src.ended_at == 2
    assert not np.array_equal(first.imu, last.imu)


def test_a_served_scenario_starts_at_the_first_read_and_then_stands_still():
    script = np.arange(3 * 4 * 6, dtype=np.int16).reshape(3, 4, 6)
    src = served_source(ScriptedSource(script, finite=True))
    first = src.read(500)  # the host started tracking at tick 500
    assert np.array_equal(first.imu, script[0])
    assert np.array_equal(src.read(502).imu, script[2])
    assert np.array_equal(src.read(900).imu, script[2]), "after its end the wearer stands still"
    assert isinstance(src.source, StartOnFirstRead) and src.source.start == 500


class _Record:
    """A finite recording with a whole-record ``imu`` array (like the replay and simulated sources)."""

    rate_hz = 1000.0

    def __init__(self, n: int):
        self.imu = np.arange(n * 4 * 6, dtype=np.int16).reshape(n, 4, 6)

    def __len__(self) -> int:
        return len(self.imu)

    def read(self, index: int):
        if index >= len(self):
            return None
        return RawSample(self.imu[index], np.zeros(4, np.int16), np.zeros((4, 3), np.int16))

    def set_dlpf(self, cfg: int) -> None:
        pass


@given(st.integers(0, 40), st.integers(1, 300), st.integers(1, 40))
def test_a_served_source_block_is_what_reads_give(first: int, n: int, length: int):
    """The compiled path reads a served source in blocks: each block is exactly the samples
    ``read`` gives one by one, the held last sample included; none before the first read."""
    src = served_source(_Record(length))
    assert src.imu_block(first, n) is None, "before the first read the start is not known"
    src.read(first)
    for start in range(first, first + length + 5, 3):
        block = src.imu_block(start, n)
        if block is None:  # the end not yet seen: read one by one until it is
            assert start >= first + length and src.ended_at is None
            src.read(start)
            continue
        assert 1 <= len(block) <= n
        for k in range(len(block)):
            assert np.array_equal(block[k], src.read(start + k).imu)


def test_tcp_address_defaults_to_loopback_and_refuses_junk():
    assert tcp_address("0") == ("127.0.0.1", 0)
    assert tcp_address("0.0.0.0:5000") == ("0.0.0.0", 5000)
    for bad in ("x", "1:2:y", "70000"):
        with pytest.raises(argparse.ArgumentTypeError):
            tcp_address(bad)


class _FakePacer:
    """Runs control actions at once (the real pacer runs them between two ticks)."""

    def __init__(self):
        from concurrent.futures import Future

        self._future = Future

    def call(self, fn):
        f = self._future()
        f.set_result(fn(None))
        return f

    def status(self):
        class S:
            def line(self):
                return "t=1.000s"

            def as_dict(self):
                return {"overruns": 0, "lag_frames": {"<1ms": 9}}

        return S()


def test_control_commands_drive_the_link():
    link = make_link("bt", seed=1)
    served = ServedModule(0, None, {"bt": link}, [], _FakePacer())  # type: ignore[arg-type]
    ctl = ControlServer.__new__(ControlServer)
    ctl.modules = [served]
    assert ctl.execute("disconnect") == "OK disconnect" and not link.connected
    assert ctl.execute("reconnect") == "OK reconnect" and link.connected
    assert ctl.execute("stall 0.5") == "OK stall 0.5" and link.counters.stalls == 1
    assert ctl.execute("stall nan") == "ERR stall: must be from 0 to 3600, got nan"
    assert ctl.execute("stall inf") == "ERR stall: must be from 0 to 3600, got inf"
    assert ctl.execute("drop 1e9") == "ERR drop: '1e9' is not a number"
    assert ctl.execute("@0 corrupt 3") == "OK corrupt 3"
    assert ctl.execute("status") == "m0 t=1.000s\nOK"
    assert ctl.execute("status json") == '{"module": 0, "overruns": 0, "lag_frames": {"<1ms": 9}}\nOK'
    assert ctl.execute("stall -1") == "ERR stall: must be from 0 to 3600, got -1"
    assert ctl.execute("corrupt x").startswith("ERR corrupt: 'x' is not a number")
    assert ctl.execute("@3 stall 1").startswith("ERR no module @3")
    assert ctl.execute("jump").startswith("ERR unknown command")
    assert ctl.execute("quit") is None


_commands = st.sampled_from(["stall", "corrupt", "drop", "disconnect", "reconnect", "@0 stall", "@9 drop",
                             "status"])
_words = st.sampled_from(["nan", "inf", "-inf", "1e300", "-0", "1e9", "99999999999999999999", "x", "0.5",
                          "3"])


@given(_commands, st.lists(_words | st.text(max_size=8), max_size=3))
def test_any_control_line_is_answered_and_the_module_runs_on(cmd, words):
    """A host's line on the control channel is answered OK or ERR; 'stall nan' stopped serve with a
    traceback (a NaN stall's cycles raised in the module's loop)."""
    link = make_link("bt", seed=1)
    ctl = ControlServer.__new__(ControlServer)
    ctl.modules = [ServedModule(0, None, {"bt": link}, [], _FakePacer())]  # type: ignore[arg-type]
    reply = ctl.execute(" ".join([cmd, *words]))
    assert reply is not None and reply.splitlines()[-1].split()[0] in ("OK", "ERR")
    link.advance(64_000)  # the link still runs


_keys = st.from_regex(r"[a-z0-9][a-z0-9.\-]{0,15}", fullmatch=True)
_values = st.from_regex(r"[A-Za-z0-9/:._\-]{1,30}", fullmatch=True)


@given(st.dictionaries(_keys, _values, max_size=6))
def test_ready_line_round_trips(fields):
    line = "READY " + " ".join(f"{k}={v}" for k, v in fields.items())
    assert parse_ready(line) == fields


@given(st.text(max_size=30))
def test_anything_not_a_ready_line_is_refused(text):
    if text.split()[:1] == ["READY"]:
        return
    with pytest.raises(ValueError):
        parse_ready(text)


@given(st.ip_addresses(v=4).map(str), st.integers(0, 65535))
def test_tcp_address_round_trips(host, port):
    assert tcp_address(f"{host}:{port}") == (host, port)
    assert tcp_address(str(port)) == ("127.0.0.1", port)


def test_the_command_line_becomes_settings():
    from firmware_sim.app.serve import MANY_MODULES_FRAME_MS, frame_ticks, settings_from_args

    s = settings_from_args(serve_args("--pty", "/tmp/p", "--tcp", "5000", "--modules", "3", "--seed", "7",
                                       "--frame-ms", "2", "--trace", "/tmp/t"))
    e = s.emulator
    assert (e.pty, e.tcp, e.modules, e.seed, e.speed) == ("/tmp/p", ("127.0.0.1", 5000), 3, 7, 1.0)
    assert (e.interface, e.link, e.served_interface) == ("bt", "bt", "bt"), "the link follows the interface"
    assert (s.frame_ms, s.trace, s.control, s.status_interval) == (2.0, "/tmp/t", None, 1.0)
    usb = settings_from_args(serve_args("--tcp", "0", "--interface", "usb", "--link", "ideal")).emulator
    assert (usb.link, usb.served_interface, usb.pty) == ("ideal", "usb", "")
    feet = settings_from_args(serve_args("--pty", "/tmp/shoe", "--feet", "2", "--module", "4"))
    assert (feet.emulator.feet, feet.emulator.module_count, feet.emulator.module) == (2, 2, 4)
    assert frame_ticks(feet, 1000.0) == round(MANY_MODULES_FRAME_MS), "frames as for several modules (1 kHz)"


@pytest.mark.parametrize(("argv", "message"), [
    ((), "openshoe-emu serve: say where hosts connect: --pty PATH and/or --tcp [HOST:]PORT"),
    (("--tcp", "0", "--modules", "0"), "openshoe-emu serve: --modules must be >= 1"),
    (("--tcp", "0", "--frame-ms", "-1"), "openshoe-emu serve: --frame-ms must be >= 0"),
    (("--tcp", "0", "--overrun-ms", "nan"), "openshoe-emu serve: --overrun-ms must be >= 0"),
    (("--tcp", "0", "--interface", "usb", "--usb-tcp", "0"),
     "openshoe-emu serve: --usb-pty/--usb-tcp need --interface bt"),
    (("--tcp", "0", "--stall-rate", "-2"),
     "openshoe-emu serve: --stall-rate must be a rate from 0 to 100 a second"),
    (("--tcp", "0", "--stall-rate", "inf"),
     "openshoe-emu serve: --stall-rate must be a rate from 0 to 100 a second"),
    (("--tcp", "0", "--disconnect-rate", "1e9"),
     "openshoe-emu serve: --disconnect-rate must be a rate from 0 to 100 a second"),
    (("--pty", "/tmp/shoe", "--feet", "2", "--modules", "2"),
     "openshoe-emu serve: --feet 2 is one walker's two modules: it does not go with --modules N"),
    (("--pty", "/tmp/shoe", "--feet", "2", "--replay", "walk.txt"),
     "openshoe-emu serve: --feet 2 walks a scenario on both feet, not --replay FILE: a recording is one "
     "module's"),
])
def test_refused_options_exit_with_status_2_and_name_the_option(argv, message, capsys):
    from firmware_sim.app.serve import main

    assert main(serve_args(*argv)) == 2
    captured = capsys.readouterr()
    assert captured.err == message + "\n" and captured.out == ""


def test_serve_settings_refuse_bad_values_by_name():
    from firmware_sim.app.serve import ServeSettings
    from firmware_sim.transports.factory import EmulatorSettings, SettingsError

    with pytest.raises(SettingsError, match="say where hosts connect: pty PATH and/or tcp"):
        ServeSettings(EmulatorSettings())
    with pytest.raises(SettingsError, match="frame_ms must be >= 0, got -1.0") as caught:
        ServeSettings(EmulatorSettings(pty="/tmp/p"), frame_ms=-1.0)
    assert caught.value.options == ("frame_ms",)


def test_the_real_time_priority_is_a_level_from_1_to_99():
    from firmware_sim.app.serve import ServeSettings, settings_from_args
    from firmware_sim.transports.factory import EmulatorSettings, SettingsError

    assert settings_from_args(serve_args("--pty", "/tmp/p", "--rt-priority", "20")).rt_priority == 20
    assert settings_from_args(serve_args("--pty", "/tmp/p")).rt_priority is None
    with pytest.raises(SettingsError, match="rt_priority is a real-time level from 1 to 99") as caught:
        ServeSettings(EmulatorSettings(pty="/tmp/p"), rt_priority=100)
    assert caught.value.options == ("rt_priority",)
    with pytest.raises(SystemExit):
        serve_args("--pty", "/tmp/p", "--rt-priority", "0")


def test_the_cpu_is_one_this_process_may_run_on():
    from firmware_sim.app.serve import settings_from_args
    from firmware_sim.transports.pacer.priority import allowed_cpus

    first = min(allowed_cpus())
    assert settings_from_args(serve_args("--pty", "/tmp/p", "--cpu", str(first))).cpu == first
    assert settings_from_args(serve_args("--pty", "/tmp/p")).cpu is None
    with pytest.raises(SystemExit):
        serve_args("--pty", "/tmp/p", "--cpu", str(max(allowed_cpus()) + 1))
