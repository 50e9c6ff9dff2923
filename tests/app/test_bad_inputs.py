"""``openshoe-emu`` given what it cannot use, command by command: a recording, a spec or a path that
is not one, a name it does not know, a number out of range, a port in use. Each is refused in one
line saying what was wrong — the file's name, and the line where its format has lines — with the
command's exit status (replay and sweep: 2 for anything refused before a run, as they always did;
serve: 2 for a refused option, 1 for what it could not open), never a traceback, and no output
written: no wire file, no folder, no table, no pty symlink over a file of the user's."""

from __future__ import annotations

import io
import json
import math
import os
import socket

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from firmware_sim.app import cli
from firmware_sim.app.sweep import SweepSpec, load_spec_file, spec_from_doc

from .serve_args import serve_args

WALK_TEXT = b"1 0.01 0.02 9.81 0.001 0.002 0.003\n"


@pytest.fixture
def names(tmp_path) -> dict[str, str]:
    """The names the table's arguments stand for: files that are not what a command wants, and
    where its outputs would go (under out/)."""
    made = {"garbage": b"\x80" + bytes(range(256)) * 4, "text": WALK_TEXT * 3, "empty": b"",
            "trunc.json": b'{"scenarios": ["walk"', "list.json": b"[1, 2, 3]", "nan.json": b"NaN",
            "bad.toml": b'scenarios = ["walk"]\nseeds = \n', "binary.toml": b"\xff\xfe\x00seeds",
            "seeds.json": json.dumps({"scenarios": ["walk"], "seeds": {}}).encode(),
            "settings.json": json.dumps({"scenarios": ["walk"], "settings": [1]}).encode(),
            "group.json": json.dumps({"scenarios": ["walk"], "group_by": 5}).encode(),
            "loo.json": json.dumps({"scenarios": ["walk"], "leave_one_out": ["x"]}).encode(),
            "rate.json": json.dumps({"scenarios": ["walk"], "rate_hz": -5}).encode(),
            "huge.toml": b'scenarios = ["walk"]\nseeds = "0:100000000000"\n'}
    out = {}
    for name, data in made.items():
        (tmp_path / name).write_bytes(data)
        out[name.replace(".", "_")] = str(tmp_path / name)
    (tmp_path / "dir").mkdir()
    (tmp_path / "out").mkdir()
    os.mkfifo(tmp_path / "fifo")  # a named pipe nothing writes to
    with open(tmp_path / "huge", "wb") as f:
        f.truncate(3 * 10**9)  # sparse: 3 GB of nothing, which was read whole into memory
    out.update(fifo=str(tmp_path / "fifo"), huge=str(tmp_path / "huge"), dir=str(tmp_path / "dir"),
               nope=str(tmp_path / "nope"), out=str(tmp_path / "out"), missing=str(tmp_path / "no" / "where"))
    return out


SC = "stand:1+walk:2+stand:1"
#: (argv with {name}s, exit status, what the message says)
CASES = [
    # replay: the recording
    ("replay {nope} --wire {out}/w.bin", 2, "{nope}: cannot read the walk recording: No such file"),
    ("replay {dir} --wire {out}/w.bin", 2, "{dir}: cannot read the walk recording: it is a directory"),
    ("replay /dev/zero --wire {out}/w.bin", 2, "/dev/zero: cannot read the walk recording: it is a device"),
    ("replay {huge} --wire {out}/w.bin", 2, "{huge}: cannot read the walk recording: it is 3 GB, past the"),
    ("replay {fifo} --wire {out}/w.bin", 2,
     "{fifo}: cannot read the walk recording: it is a pipe, and a walk recording is read more than once"),
    ("replay {garbage} --wire {out}/w.bin", 2, "{garbage}, line 1: not ASCII text (byte 0x80)"),
    ("replay {empty} --wire {out}/w.bin", 2, "{empty}: missing title line"),
    ("replay /proc/self/mem --wire {out}/w.bin", 2, "/proc/self/mem: cannot read the walk recording: Input/"),
    ("replay {nope} --wire-dir {out}/d", 2, "{nope}: cannot read the walk recording"),
    ("replay /proc/self/mem --wire-dir {out}/d", 2, "/proc/self/mem: cannot read the walk recording: Input/"),
    ("replay {garbage} --wire-dir {out}/d", 2, "openshoe-emu replay: {garbage}, line 1: not ASCII text"),
    # replay: the scenario and the numbers
    ("replay --scenario nope --wire {out}/w.bin", 2, "openshoe-emu replay: unknown scenario 'nope'; known:"),
    ("replay --scenario nope --wire-dir {out}/d", 2, "openshoe-emu replay: nope: unknown scenario 'nope'"),
    ("replay --scenario nope --feet 2 --wire {out}/w.bin", 2, "openshoe-emu replay: unknown scenario 'nope'"),
    ("replay --scenario walk:abc --wire {out}/w.bin", 2, "piece 1 'walk:abc': arguments must be numbers"),
    ("replay --scenario walk:1e9 --wire {out}/w.bin", 2,
     "piece 1 'walk:1e9': the length m [m] must be > 0 and at most 2500, got 1e+09"),
    ("replay --scenario stand:3+walk:nan --feet 2 --wire {out}/w.bin", 2, "piece 2 'walk:nan': the length m"),
    ("replay --scenario stand:inf --seeds 0:2 --wire-dir {out}/d", 2,
     "piece 1 'stand:inf': the time s [s] must be > 0 and at most 1800, got inf"),
    ("replay --scenario stand:1000 --rate 10000 --wire {out}/w.bin", 2,
     "a walk of 1000 s at 10000 Hz is 1e+07 samples: at most 2e+06"),
    ("replay --scenario " + SC + " --rate 0 --wire {out}/w.bin", 2, "argument --rate: a sample rate in Hz"),
    ("replay --scenario " + SC + " --rate nan --wire {out}/w.bin", 2, "argument --rate: a sample rate"),
    ("replay --scenario " + SC + " --rate 1e9 --wire {out}/w.bin", 2, "and at most 10000, not '1e9'"),
    ("replay --scenario " + SC + " --seed -1 --wire {out}/w.bin", 2, "argument --seed: a whole number >= 0"),
    ("replay --scenario " + SC + " --seeds 5:1 --wire-dir {out}/d", 2, "seeds must be A:B (0 <= A < B)"),
    ("replay --scenario " + SC + " --seeds 0:10000000000 --wire-dir {out}/d", 2, "at most 100000 in one run"),
    ("replay --scenario " + SC + " --module -1 --wire {out}/w.bin", 2, "argument --module: a module number"),
    # replay: where it writes, checked before the run
    ("replay --scenario " + SC + " --wire {dir}", 2, "--wire {dir} is a directory: name a file in it"),
    ("replay --scenario " + SC + " --wire {fifo}", 2, "--wire {fifo} is a pipe nothing reads from"),
    ("replay --scenario " + SC + " --wire {missing}.bin", 2, "--wire {missing}.bin: the folder"),
    ("replay --scenario " + SC + " --feet 2 --wire {missing}.bin", 2, "--wire {missing}.bin: the folder"),
    ("replay --scenario " + SC + " --wire-dir {garbage}", 2, "--wire-dir {garbage} is a file, not a folder"),
    ("replay --scenario " + SC + " --wire-dir {out}/d --table {dir}", 2, "--table {dir} is a directory"),
    ("replay --scenario " + SC + " --wire {out}/w.bin --gps {dir}", 2, "--gps {dir} is a directory"),
    ("replay --scenario " + SC + " --wire {out}/w.bin --gps {out}/g.nmea --origin 999,999", 2,
     "origin is LAT,LON[,ALT] in degrees and metres"),
    # sweep: the spec file
    ("sweep --spec {nope} --out {out}/s", 2, "{nope}: cannot read the sweep spec: No such file"),
    ("sweep --spec {dir} --out {out}/s", 2, "{dir}: cannot read the sweep spec: it is a directory"),
    ("sweep --spec /proc/self/mem --out {out}/s", 2, "/proc/self/mem: cannot read the sweep spec: Input/"),
    ("sweep --spec {binary_toml} --out {out}/s", 2, "{binary_toml}: not a sweep spec: not text (line 1 has"),
    ("sweep --spec {bad_toml} --out {out}/s", 2,
     "{bad_toml}: not a sweep spec: invalid TOML (Invalid value (at line 2, column 9))"),
    ("sweep --spec {trunc_json} --out {out}/s", 2, "{trunc_json}: not a sweep spec: invalid JSON ("),
    ("sweep --spec {list_json} --out {out}/s", 2, "{list_json}: a spec is a table of keys"),
    ("sweep --spec {nan_json} --out {out}/s", 2, "{nan_json}: a spec is a table of keys"),
    ("sweep --spec {empty} --out {out}/s", 2, "{empty}: not a sweep spec: invalid JSON (Expecting value"),
    ("sweep --spec {seeds_json} --out {out}/s", 2, "'seeds' is \"A:B\", a whole number >= 0 or a list"),
    ("sweep --spec {settings_json} --out {out}/s", 2, "'settings' is a table of a setting's name"),
    ("sweep --spec {group_json} --out {out}/s", 2, "'group_by' is a name or a list of names, not 5"),
    ("sweep --spec {loo_json} --out {out}/s", 2, "'leave_one_out' is a column's name, not ['x']"),
    ("sweep --spec {rate_json} --out {out}/s", 2, "'rate_hz' is a sample rate in Hz > 0"),
    ("sweep --spec {huge_toml} --out {out}/s", 2, "are 100000000000 seeds: at most 100000"),
    # sweep: the command line
    ("sweep --scenario nope --out {out}/s", 2, "unknown scenario 'nope'; known:"),
    ("sweep --scenario walk --scenario track400:1e6 --out {out}/s", 2,
     "piece 1 'track400:1e6': the number of laps must be a whole number from 1 to 6, got 1e+06"),
    ("sweep {dir} --out {out}/s", 2, "{dir}: cannot read the walk recording: it is a directory"),
    ("sweep {nope} --out {out}/s", 2, "no such recording: {nope}"),
    ("sweep {fifo} --out {out}/s", 2, "{fifo}: cannot read the walk recording: it is a pipe"),
    ("sweep --scenario walk --rate 0 --out {out}/s", 2, "argument --rate: a sample rate in Hz > 0"),
    ("sweep --scenario walk --set link.byte_loss=nan --out {out}/s", 2,
     "setting 'link.byte_loss' takes probabilities from 0 to 1, got 'nan'"),
    ("sweep --scenario walk --set link.stall_rate_hz=-1 --out {out}/s", 2, "takes rates from 0 to 100 [Hz]"),
    ("sweep --scenario walk --set link.disconnect_rate_hz=1e9 --out {out}/s", 2,
     "setting 'link.disconnect_rate_hz' takes rates from 0 to 100 [Hz], got '1e9'"),
    ("sweep --scenario walk --set frontend.zupt_threshold=-5 --out {out}/s", 2, "takes int values from 0 to"),
    ("sweep --scenario walk --seeds x --out {out}/s", 2, "seeds must be A:B"),
    ("sweep --scenario walk --out {garbage}", 2, "--out {garbage} is a file"),
    ("sweep --scenario walk --scheduler bogus --out {out}/s", 2, "--scheduler is a Dask scheduler's tcp://"),
    ("sweep --scenario walk --workers 100000 --out {out}/s", 2,
     "argument --workers: a whole number of processes from 0 (here, one run after the other) to 64 (more: "
     "--scheduler), not '100000'"),
    ("sweep --scenario walk --workers -1 --out {out}/s", 2, "argument --workers: a whole number of"),
]


def _argv(template: str, names: dict[str, str]) -> list[str]:
    argv = [word.format(**names) for word in template.split()]
    if argv[0] != "sweep":
        return [*argv, "-q"]
    placed = "--scheduler" in argv or "--workers" in argv
    return [*argv, "-q", "--no-plot", *([] if placed else ["--workers", "0"])]


@pytest.mark.parametrize(("template", "status", "said"), CASES,
                         ids=[c[0].split(" --wire")[0].split(" --out")[0] for c in CASES])
def test_openshoe_emu_refuses_what_it_cannot_use_in_one_line_and_writes_nothing(tmp_path, capsys, names,
                                                                               template, status, said):
    try:
        code = cli.main(_argv(template, names))
    except SystemExit as exc:  # argparse's refusal of an option's value: its usage, then one line
        code = exc.code
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert "Traceback" not in err and code == status
    assert said.format(**names) in lines[-1] and lines[-1].startswith("openshoe-emu")
    assert list((tmp_path / "out").iterdir()) == []


def test_a_sweep_spec_whose_scenarios_are_one_name_sweeps_that_name(tmp_path):
    path = tmp_path / "s.json"
    path.write_text(json.dumps({"scenarios": "walk", "group_by": "source"}))
    spec = load_spec_file(path)
    assert spec.scenarios == ("walk",) and spec.group_by == ("source",)


@pytest.fixture(scope="module")
def busy_port():
    """A TCP port on 127.0.0.1 that something listens on."""
    with socket.create_server(("127.0.0.1", 0)) as s:
        yield s.getsockname()[1]


SERVE_CASES = [
    (("--tcp", "0", "--duration", "-1"), 2, "--duration is a number of seconds > 0"),
    (("--tcp", "0", "--duration", "nan"), 2, "--duration is a number of seconds > 0"),
    (("--tcp", "0", "--status-interval", "nan"), 2, "--status-interval is a number of seconds >= 0"),
    (("--tcp", "0", "--frame-ms", "1e9"), 2, "--frame-ms must be a finite number of milliseconds, at most"),
    (("--tcp", "0", "--overrun-ms", "inf"), 2, "--overrun-ms must be a finite number of milliseconds"),
    (("--tcp", "0", "--modules", "100000"), 2, "--modules must be <= 64 (one process's loop paces them all"),
    (("--tcp", "0", "--scenario", "walk:1e9"), 2,
     "--scenario: piece 1 'walk:1e9': the length m [m] must be > 0 and at most 2500, got 1e+09"),
    (("--tcp", "0", "--scenario", "stand:3+turn:90:1"), 2,
     "--scenario: piece 2 'turn:90:1': turn takes at most"),
    (("--pty", "{text}"), 2, "--pty {text} is a file: a pty's path is a symlink serve makes"),
    (("--pty", "{dir}"), 2, "--pty {dir} is a directory"),
    (("--tcp", "0", "--trace", "{dir}"), 2, "--trace {dir} is a directory"),
    (("--tcp", "0", "--trace", "{missing}"), 2, "--trace {missing}: the folder"),
    (("--tcp", "0", "--gps-pty", "{out}/gps", "--scenario", "walk", "--origin", "999,999"), 2,
     "--origin: origin is LAT,LON[,ALT]"),
    (("--tcp", "0", "--replay", "{nope}"), 1, "{nope}: cannot read the walk recording: No such file"),
    (("--tcp", "0", "--replay", "/dev/zero"), 1, "/dev/zero: cannot read the walk recording: it is a device"),
    (("--tcp", "0", "--replay", "{fifo}"), 1, "{fifo}: cannot read the walk recording: it is a pipe"),
]


@pytest.mark.parametrize(("argv", "status", "said"), SERVE_CASES,
                         ids=[" ".join(a[2:] or a) for a, _, _ in SERVE_CASES])
def test_serve_refuses_what_it_cannot_use_in_one_line(tmp_path, capsys, names, argv, status, said):
    """A refused option ends in main (exit 2); what cannot be opened, in serve (exit 1)."""
    from firmware_sim.app.serve import main, serve, settings_from_args

    args = serve_args(*(a.format(**names) for a in argv))
    err = io.StringIO()
    code = main(args) if status == 2 else serve(settings_from_args(args), io.StringIO(), err)
    err = capsys.readouterr().err + err.getvalue()
    lines = [line for line in err.strip().splitlines() if line.startswith("openshoe-emu serve:")]
    assert code == status and "Traceback" not in err and said.format(**names) in lines[-1]
    assert (tmp_path / "text").read_bytes() == WALK_TEXT * 3  # a file where a pty would go is kept


def test_a_control_port_in_use_is_named(busy_port):
    from firmware_sim.app.control import ControlServer

    with pytest.raises(OSError) as caught:
        ControlServer([], "127.0.0.1", busy_port)
    assert str(caught.value) == f"--control 127.0.0.1:{busy_port}: Address already in use"


@pytest.mark.parametrize(("argv", "said"), [
    (["--seed", "-1"], "a whole number >= 0"), (["--tcp", "99999"], "port 99999 out of range"),
    (["--loss", "nan"], "expected a probability 0..1"),
    (["--speed", "nan"], "argument --speed: module time per wall time, >= 0 (1: real time; 0 or inf: as fast "
                         "as possible), not 'nan'"),
    (["--speed", "-1"], "argument --speed: module time per wall time, >= 0"),
    (["--speed=-inf"], "argument --speed: module time per wall time, >= 0"),
    (["--speed", "fast"], "argument --speed: module time per wall time, >= 0"),
])
def test_serve_refuses_a_number_out_of_range_as_argparse_does(capsys, argv, said):
    with pytest.raises(SystemExit) as caught:
        serve_args("--tcp", "0", *argv)
    assert caught.value.code == 2 and said in capsys.readouterr().err


@pytest.mark.parametrize(("text", "speed"), [("inf", math.inf), ("0", 0.0), ("1e3", 1000.0)])
def test_serve_speed_inf_runs_as_fast_as_possible_as_0_does(text, speed):
    from firmware_sim.app.serve import settings_from_args
    from firmware_sim.transports.pacer.schedule import Schedule

    settings = settings_from_args(serve_args("--tcp", "0", "--speed", text))
    assert settings.emulator.speed == speed
    assert Schedule(1, 1000.0, speed, 1, None).asap == (speed in (0.0, math.inf))


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=10), inner, max_size=4),
    max_leaves=8)
#: documents near a spec: its keys with any values
spec_docs = st.fixed_dictionaries({}, optional={k: json_values for k in (
    "recordings", "scenarios", "seeds", "rate_hz", "settings", "leave_one_out", "group_by", "group_metrics")})


@settings(max_examples=120, deadline=None)
@given(doc=json_values | spec_docs)
def test_any_json_document_is_a_sweep_spec_or_refused_with_a_value_error(doc):
    try:
        spec = spec_from_doc(doc)
    except ValueError:
        return
    assert isinstance(spec, SweepSpec) and all(isinstance(s, int) and s >= 0 for s in spec.seeds)


@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.binary(max_size=200) | st.text(max_size=200).map(str.encode), toml=st.booleans())
def test_any_bytes_in_a_spec_file_are_a_spec_or_refused_naming_the_file(tmp_path, data, toml):
    path = tmp_path / ("any.toml" if toml else "any.json")
    path.write_bytes(data)
    try:
        load_spec_file(path)
    except ValueError as exc:
        assert str(exc).startswith(str(path)) and "\n" not in str(exc)


@pytest.mark.parametrize("argv", [("--tcp", "{port}"), ("--rfc2217", "{port}"),
                                  ("--tcp", "0", "--usb-tcp", "{port}"),
                                  ("--pty", "{pty}", "--tcp", "{port}", "--feet", "2")])
def test_a_port_in_use_is_named_with_its_option_and_address(tmp_path, busy_port, argv):
    """What serve cannot open ends with status 1 and one line: the option, the address, the reason."""
    from firmware_sim.app.serve import serve, settings_from_args

    words = (a.format(port=busy_port, pty=tmp_path / "shoe") for a in argv)
    args = serve_args("--scenario", "stand:1", *words)
    err = io.StringIO()
    assert serve(settings_from_args(args), io.StringIO(), err) == 1
    option = "--usb-tcp" if "--usb-tcp" in argv else argv[0] if argv[0] != "--pty" else "--tcp"
    said = f"openshoe-emu serve: {option} 127.0.0.1:{busy_port}: Address already in use"
    assert err.getvalue().splitlines() == [said]
    assert list(tmp_path.iterdir()) == [], "the pty opened before the port is closed and its symlink removed"


@pytest.mark.parametrize("option", ["--tcp", "--control"])
def test_an_address_that_does_not_resolve_is_named_with_the_resolver_s_words(option):
    """It read ``--tcp 999.1.1.1:5000: Unknown error -2`` (the resolver's code taken for an errno)."""
    from firmware_sim.app.serve import serve, settings_from_args

    argv = ("--tcp", "999.1.1.1:5000") if option == "--tcp" else ("--tcp", "0", "--control", "999.1.1.1:5000")
    err = io.StringIO()
    assert serve(settings_from_args(serve_args("--scenario", "stand:1", *argv)), io.StringIO(), err) == 1
    (line,) = err.getvalue().splitlines()
    assert line.startswith(f"openshoe-emu serve: {option} 999.1.1.1:5000: ")
    assert "Unknown error" not in line and "Errno" not in line and "while attempting" not in line


@pytest.mark.parametrize(("argv", "said"), [
    (["--scenario", "walk:1e9"], "demo: --scenario: piece 1 'walk:1e9': the length m [m] must be > 0"),
    (["--scenario", "nope"], "demo: --scenario: unknown scenario 'nope'; known:"),
    (["--out", "{text}"], "demo: --out {text} is a file: name a folder for track.png and track.csv"),
    (["--speed", "nan"], "argument --speed: module time per wall time, >= 0"),
    (["--timeout", "-1"], "argument --timeout: a number of seconds > 0, not '-1'"),
    (["--seed", "-1"], "argument --seed: a whole number >= 0, not '-1'"),
])
def test_the_demo_refuses_a_bad_option_before_anything_is_walked(capsys, names, argv, said):
    """They were 'demo failed: RecipeError: …' after the compile, 'SettingsError: …', a FileExistsError at the
    end of the walk, a timeout of NaN that never gave up, a negative one that gave up at once."""
    from firmware_sim.app import demo

    try:
        code = demo.main([a.format(**names) for a in argv] + ["--no-plot", "-q"])
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err and said.format(**names) in err.strip().splitlines()[-1]
