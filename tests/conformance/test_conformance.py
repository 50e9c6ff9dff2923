"""The conformance suite passes against our emulator; against broken devices it fails the right check.

Devices are our emulator core behind an in-process, virtual-time serial port
(:class:`firmware_sim.transports.pipe.VirtualPipe`), so every run is deterministic. Each broken
device changes exactly one documented behaviour of protocol.md.
"""

from __future__ import annotations

import pytest

from firmware_sim.mcu.module import Module, ModuleConfig
from firmware_sim.nav.firmware import build_module
from firmware_sim.transports.pipe import VirtualPipe
from protocol.commands import command_set
from protocol.frames import build_command_ack
from protocol.ids import Command
from protocol.stream import StreamDecoder
from tools.conformance import CHECKS, DeviceDriver, Status, run
from tools.conformance.cli import main
from tools.conformance.driver import device_clock


def _driver(module: Module, cs: str = "2015", serial_cls=VirtualPipe) -> DeviceDriver:
    """The suite's driver on the module's USB interface, in virtual time (deterministic)."""
    pipe = serial_cls(module, "usb")
    return DeviceDriver(pipe, command_set(cs), clock=device_clock(pipe))


def _verdicts(driver: DeviceDriver, names: list[str] | None = None) -> dict[str, Status]:
    report = run(driver, names)
    return {r.name: r.status for r in report.results}


@pytest.mark.parametrize("cs", ["2015", "2014"])
def test_our_emulator_conforms(cs):
    module = build_module(ModuleConfig(command_set=cs))
    report = run(_driver(module, cs))
    failed = {r.name: r.message for r in report.results if r.failed}
    assert not failed, failed
    passed = [r.name for r in report.results if r.status is Status.PASS]
    skipped = [r.name for r in report.results if r.status is Status.SKIP]
    assert {"ping", "acks", "lossless", "resend-interval", "phase-sync", "ascending-ids",
            "step-packets"} <= set(passed)
    if cs == "2014":  # only the commands of the 2014 numbering can be checked
        assert "set-state" in skipped and "state-if-setup" in skipped
    else:
        assert not skipped


def test_every_check_proves_its_verdict_with_bytes():
    module = build_module()
    report = run(_driver(module), ["ping", "set-state", "lossless"])
    for r in report.results:
        assert r.status is Status.PASS
        assert r.proofs and any(p.sent and p.received for p in r.proofs), r.name
    ping = report.results[0].render()
    assert "sent     03 00 03" in ping and "received A0 03 00 A3" in ping


# --------------------------------------------------------------------------- broken devices


class SwappedChecksumSerial(VirtualPipe):
    """A device that sends every frame's checksum LSB first."""

    def __init__(self, module: Module, interface: str):
        super().__init__(module, interface)
        self._dec = StreamDecoder()

    def _fill(self) -> None:
        for frame in self._dec.feed(self.port.host_read()):
            raw = frame.to_bytes()
            self._buf += raw[:-2] + raw[-1:] + raw[-2:-1]


def test_checksum_byte_order_is_caught():
    v = _verdicts(_driver(build_module(), serial_cls=SwappedChecksumSerial), ["ping", "garbage"])
    assert v == {"ping": Status.FAIL, "garbage": Status.FAIL}


def test_acking_the_ack_is_caught():
    module = build_module()
    iface = module.usb
    original = iface._execute

    def execute_and_ack_acks(spec, raw):
        original(spec, raw)
        if spec.command is Command.ACK:
            iface.queue.add(build_command_ack(0x01), 0, single=True, is_ack=True)

    iface._execute = execute_and_ack_acks
    v = _verdicts(_driver(module), ["ping", "ack-not-acked"])
    assert v == {"ping": Status.PASS, "ack-not-acked": Status.FAIL}


class _NoSort(list):
    def sort(self, *args, **kwargs):  # keep request order
        pass


def test_states_in_request_order_are_caught(monkeypatch):
    import firmware_sim.mcu.interface as interface_mod

    module = build_module()
    iface = module.usb
    requested: list[int] = []
    original_output = iface.output

    def output(state_id, mode):
        if state_id in requested:
            requested.remove(state_id)
        requested.append(state_id)
        original_output(state_id, mode)

    iface.output = output
    iface._periodic = _NoSort(iface._periodic)
    monkeypatch.setattr(interface_mod, "sorted",
                        lambda ids: sorted(ids, key=lambda i: requested.index(i) if i in requested else -1),
                        raising=False)
    v = _verdicts(_driver(module), ["pull", "ascending-ids", "lossy"])
    assert v == {"pull": Status.PASS, "ascending-ids": Status.FAIL, "lossy": Status.PASS}


def test_no_resend_in_lossless_mode_is_caught():
    module = build_module()
    module.usb.queue.resend_cycles = 10**9
    v = _verdicts(_driver(module), ["lossy", "lossless", "resend-interval"])
    assert v == {"lossy": Status.PASS, "lossless": Status.FAIL, "resend-interval": Status.FAIL}


def test_resend_every_64_cycles_is_caught():
    module = build_module()
    module.usb.queue.resend_cycles = 64
    driver = _driver(module)
    report = run(driver, ["lossless", "resend-interval"])
    v = {r.name: r.status for r in report.results}
    assert v == {"lossless": Status.PASS, "resend-interval": Status.FAIL}
    assert "64.0 cycles apart on average" in report.results[1].message


def test_phase_out_of_step_is_caught():
    """A device that starts every new output at counter 0 (ignoring §5's rule) fails phase-sync."""
    module = build_module()
    iface = module.usb
    original = iface.set_state_output

    def naive(state_id, rate):
        original(state_id, rate)
        if rate:
            iface.counter[state_id] = 0

    iface.set_state_output = naive
    v = _verdicts(_driver(module), ["phase-sync", "output-rates"])
    assert v == {"phase-sync": Status.FAIL, "output-rates": Status.PASS}


def test_unacked_output_all_off_fails_fast_with_error_not_hang():
    """A silent device: every check fails (no ack), none hangs, the run ends."""
    module = build_module()
    module.usb.port.disconnect()
    report = run(_driver(module), ["ping", "acks"])
    assert [r.status for r in report.results] == [Status.FAIL, Status.FAIL]
    assert "OUTPUT_ALL_OFF" in report.results[0].message


# --------------------------------------------------------------------------- CLI


def test_cli_lists_every_check_with_its_duration(capsys):
    assert main(["--list"]) == 0
    out = capsys.readouterr().out
    for name in CHECKS:
        assert name in out
    assert "3.5 s" in out


def test_cli_refuses_unknown_check_and_bad_url(capsys):
    assert main(["loop://", "--only", "no-such-check"]) == 2
    assert "unknown check" in capsys.readouterr().err
    assert main(["/nonexistent/tty-openshoe"]) == 2
    assert "cannot open" in capsys.readouterr().err


def test_cli_against_a_silent_port_fails(capsys):
    # loop:// echoes what we send: nothing a module would answer
    assert main(["loop://", "--only", "ping", "--time-scale", "0.1"]) == 1
    out = capsys.readouterr().out
    assert "FAIL" in out and "DOES NOT CONFORM" in out


def test_lossless_flag_stuck_on_is_caught():
    """A device where a lossy request does not turn lossless mode off (protocol.md §9) fails lossless-flag."""
    module = build_module()
    iface = module.usb
    original = iface.set_lossless

    def only_on(on):
        if on:
            original(True)

    iface.set_lossless = only_on
    v = _verdicts(_driver(module), ["ping", "lossless-flag"])
    assert v == {"ping": Status.PASS, "lossless-flag": Status.FAIL}


def test_run_proc_slot_out_of_range_not_ignored_is_caught():
    """A device that wraps RUN_PROC's slot (12 → 0) instead of ignoring it fails run-proc."""
    from protocol.frames import build_command

    module = build_module()
    iface = module.usb
    original = iface._execute

    def wrapping_slots(spec, raw):
        if spec.command is Command.RUN_PROC and raw[2] >= 12:
            raw = build_command(Command.RUN_PROC, proc_id=raw[1], slot=raw[2] % 12)
        original(spec, raw)

    iface._execute = wrapping_slots
    v = _verdicts(_driver(module), ["run-proc", "store-restore"])
    assert v == {"run-proc": Status.FAIL, "store-restore": Status.PASS}


# --------------------------------------------------------------------------- emulator extensions

EXTENSION_CHECKS = ["ext-states", "ext-height-compensation"]


def test_the_emulator_has_its_extensions():
    report = run(_driver(build_module()), EXTENSION_CHECKS)
    assert {r.name: r.status for r in report.results} == dict.fromkeys(EXTENSION_CHECKS, Status.PASS)
    assert "PS_DT10 = 3020 cycles" in report.results[1].message  # the function's 3000 + the slot call
    assert all(CHECKS[name].group == "extensions" for name in EXTENSION_CHECKS)


def _module_without_extensions() -> Module:
    """A module as a real one answers: no function 0x25, states 0x34–0x36 unknown ids."""
    import dataclasses

    from firmware_sim.mcu.sequence import FunctionTable
    from firmware_sim.mcu.sequence_control import RUNTIME_FUNCTIONS
    from firmware_sim.nav import ins
    from firmware_sim.nav.firmware import NAVIGATION_FUNCTIONS, OPENSHOE

    functions = [f for f in NAVIGATION_FUNCTIONS if f is not ins.ins_height_compensation]
    firmware = dataclasses.replace(OPENSHOE, functions=FunctionTable.of(*RUNTIME_FUNCTIONS, *functions))
    module = build_module(firmware=firmware)
    exists = module.memory.exists
    module.memory.exists = lambda sid: sid not in (0x34, 0x35, 0x36) and exists(sid)
    return module


def test_a_module_without_the_extensions_reports_them_absent_and_conforms():
    """A real module lacks the extensions: ABSENT, which is no failure of the protocol."""
    report = run(_driver(_module_without_extensions()), ["ping", *EXTENSION_CHECKS])
    assert [r.status for r in report.results] == [Status.PASS, Status.ABSENT, Status.ABSENT]
    assert report.ok and "CONFORMS" in report.summary() and "2 absent" in report.summary()
    assert "unknown ids" in report.results[1].message and "slot 10 empty" in report.results[2].message
    assert "ABSENT ext-states" in report.results[1].render()


def test_an_extension_state_of_the_wrong_size_is_caught():
    module = build_module()
    read_wire = module.memory.read_wire
    module.memory.read_wire = lambda sid: read_wire(sid)[:4] if sid == 0x35 else read_wire(sid)
    report = run(_driver(module), ["ext-states"])
    assert report.results[0].status is Status.FAIL
    assert "0x35 answers with 4 bytes, expected 8" in report.results[0].message


def test_extension_checks_skip_in_the_2014_numbering():
    report = run(_driver(build_module(ModuleConfig(command_set="2014")), "2014"), EXTENSION_CHECKS)
    assert [r.status for r in report.results] == [Status.SKIP, Status.SKIP]


def test_cli_lists_the_extension_group(capsys):
    assert main(["--list"]) == 0
    out = capsys.readouterr().out
    assert "(extensions) emulator extension function 0x25 HEIGHT_COMPENSATION" in out


# --------------------------------------------------------------------------- resynchronisation


def test_the_garbage_resync_check_passes_in_both_numberings_within_its_deadline():
    from tools.conformance.checks import RESYNC_DEADLINE_TICKS

    for cs in ("2015", "2014"):
        report = run(_driver(build_module(ModuleConfig(command_set=cs)), cs), ["garbage-resync"])
        result = report.results[0]
        assert result.status is Status.PASS, result.message
        ticks = [int(part.split(", ")[1].split()[0]) for part in result.message.split("; ")]
        assert len(ticks) == 2 and all(t <= RESYNC_DEADLINE_TICKS for t in ticks)


def test_the_check_garbage_holds_frames_that_close_inside_it():
    """The check's random garbage holds command ids whose frames all close, with wrong checksums,
    before its end: a parser following §7 is between frames after it."""
    from protocol.commands import command_set as numbering
    from protocol.frames import checksum
    from tools.conformance.checks import closed_garbage

    for cs in (numbering("2015"), numbering("2014")):
        garbage = closed_garbage(cs, 1024)
        i = frames = 0
        while i < len(garbage):
            if cs.is_command(garbage[i]):
                frame = garbage[i:i + cs[garbage[i]].payload_len + 3]
                assert checksum(frame[:-2]) != int.from_bytes(frame[-2:], "big")
                frames += 1
                i += len(frame)
            else:
                i += 1
        assert i == len(garbage) and frames > 20


def test_a_parser_that_searches_a_dropped_frame_again_is_caught():
    """A device that, on a wrong checksum, drops only the frame's first byte and looks for a header
    in the rest (not what §7 says) passes the short garbage checks but not garbage-resync: a header
    inside the dropped bytes opens a frame that swallows the PING."""
    from protocol.frames import checksum

    module = build_module()
    iface = module.usb
    pending = bytearray()

    def rescanning(data: bytes) -> None:
        pending.extend(data)
        while pending:
            spec = iface._by_id[pending[0]]
            if spec is None:
                del pending[0]
                continue
            n = spec.payload_len + 3
            if len(pending) < n:
                return
            frame = bytes(pending[:n])
            if checksum(frame[:-2]) == int.from_bytes(frame[-2:], "big"):
                del pending[:n]
                iface._execute(spec, frame)
            else:
                del pending[0]

    iface._parse = rescanning
    v = _verdicts(_driver(module), ["ping", "garbage", "bad-checksum", "garbage-resync"])
    assert v == {"ping": Status.PASS, "garbage": Status.PASS, "bad-checksum": Status.PASS,
                 "garbage-resync": Status.FAIL}
