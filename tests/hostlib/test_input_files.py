"""The files a user hands the host (hostlib.inputs) and the calibration files read through it
(hostlib.calibration.magcal, hostlib.calibration.drift): what is not a readable file, not text, not
JSON or not a calibration is refused with an error that names the file and what is wrong, a
HostError and a ValueError; whatever the bytes, a loader parses them or refuses them, never another
exception."""

from __future__ import annotations

import contextlib
import json
import math
import os
import threading

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hostlib import inputs
from hostlib.calibration.drift import DriftCalibration, DriftError
from hostlib.calibration.magcal import MagCalibration, MagCalibrationError
from hostlib.errors import HostError
from hostlib.inputs import InputFileError, check_input, load_json, output_refusal, read_input, read_text

GOOD_MAG = MagCalibration(np.array([1.0, 2.0, 3.0]), np.eye(3), "OSEMU-M00000001", 51.5).to_json()


def test_what_is_not_a_readable_file_is_refused_naming_it_and_why(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    assert check_input(fifo) == fifo  # a pipe is read (a shell's <(…))
    for path, said in ((tmp_path / "nope.json", "No such file or directory"),
                       (tmp_path, "it is a directory"), ("/dev/zero", "it is a device, not a file"),
                       ("", "an empty name")):
        with pytest.raises(InputFileError) as caught:
            read_input(path, "GPS log")
        assert said in str(caught.value) and str(path) in str(caught.value)
        assert isinstance(caught.value, HostError) and isinstance(caught.value, ValueError)


def test_a_pipe_is_read_once_something_writes_to_it(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    data = bytes(range(256)) * 1000

    def write() -> None:
        with open(fifo, "wb") as w:  # waits for the reader, as a shell's writer does
            w.write(data)

    writer = threading.Thread(target=write)
    writer.start()
    assert read_input(fifo, "capture") == data
    writer.join()


def test_a_pipe_nothing_writes_to_is_refused_not_waited_on_for_ever(tmp_path, monkeypatch):
    """A named pipe with no writer: a plain open waited for one for ever, and Ctrl-C was a traceback."""
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    monkeypatch.setattr(inputs, "PIPE_WAIT_S", 0.05)
    with pytest.raises(InputFileError, match="cannot read the capture: a pipe nothing wrote to in 0.05 s"):
        read_input(fifo, "capture")
    with pytest.raises(InputFileError, match="pipe: cannot read the walk recording: it is a pipe, and a walk "
                                             "recording is read more than once: name a file"):
        check_input(fifo, "walk recording", pipes=False)


def test_an_input_larger_than_a_day_of_a_module_s_bytes_is_refused_by_its_size(tmp_path, monkeypatch):
    """A sparse file of 3 GB was read whole into memory (a MemoryError, or the process killed)."""
    big = tmp_path / "big.bin"
    with open(big, "wb") as f:
        f.truncate(3 * 10**9)  # sparse: nothing written
    with pytest.raises(InputFileError, match="big.bin: cannot read the capture: it is 3 GB, past the 1 GB"):
        read_input(big, "capture")
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    monkeypatch.setattr(inputs, "MAX_INPUT_BYTES", 1000)

    def write() -> None:
        with open(fifo, "wb") as w, contextlib.suppress(BrokenPipeError):
            w.write(b"x" * 5000)

    writer = threading.Thread(target=write)
    writer.start()
    with pytest.raises(InputFileError, match="pipe: cannot read the capture: it goes on, past the 1e-06 GB"):
        read_input(fifo, "capture")
    writer.join()


def test_an_output_pipe_nothing_reads_from_is_refused_before_the_run(tmp_path, monkeypatch):
    """Writing to it waited for a reader for ever (``log --raw FIFO`` after the port opened)."""
    fifo = tmp_path / "out.pipe"
    os.mkfifo(fifo)
    said = f"--raw {fifo} is a pipe nothing reads from: start its reader first"
    assert output_refusal(fifo, "--raw") == said
    held: list[int] = []
    monkeypatch.setattr(inputs, "_HELD_PIPES", held)
    reader = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
    try:
        assert output_refusal(fifo, "--raw") is None and len(held) == 1, "held: its reader sees no end yet"
        with open(fifo, "wb") as w:
            w.write(b"walk")
        assert os.read(reader, 10) == b"walk"
        os.close(held.pop())
        assert os.read(reader, 10) == b"", "the end once the process lets go"
    finally:
        os.close(reader)


def test_a_file_that_cannot_be_read_is_refused_with_the_systems_reason():
    with pytest.raises(InputFileError, match=r"/proc/self/mem: cannot read the capture: Input/output error"):
        read_input("/proc/self/mem", "capture")


def test_bytes_that_are_not_text_are_refused_with_their_line(tmp_path):
    path = tmp_path / "x.json"
    path.write_bytes(b'{\n "a": 1,\n "b": "\xff"\n}\n')
    with pytest.raises(InputFileError, match=r"x.json: not a sweep spec: not text \(line 3 has the byte"):
        read_text(path, "sweep spec")


@pytest.mark.parametrize(("text", "said"), [
    ("", "the file is empty"), ("  \n", "the file is empty"),
    ('{"a": 1,\n "b": }', "invalid JSON (Expecting value: line 2 column 7"),
    ('{"format": "openshoe-drift', "Unterminated string starting at: line 1 column 12"),
])
def test_json_that_does_not_parse_is_refused_with_its_line_and_column(tmp_path, text, said):
    path = tmp_path / "c.json"
    path.write_text(text)
    with pytest.raises(InputFileError) as caught:
        load_json(path, "drift calibration")
    assert str(caught.value).startswith(f"{path}: not a drift calibration: ") and said in str(caught.value)


def test_an_output_file_that_could_not_be_written_is_said_before_a_run(tmp_path):
    assert output_refusal(None, "--csv") is None and output_refusal(tmp_path / "o.csv", "--csv") is None
    assert "is a directory" in output_refusal(tmp_path, "--csv")
    assert "does not exist" in output_refusal(tmp_path / "no" / "o.csv", "--png")
    (tmp_path / "f").write_text("")
    assert "is not a folder" in output_refusal(tmp_path / "f" / "o.csv", "--geojson")
    assert "needs a file name" in output_refusal("", "--raw")


@pytest.mark.parametrize(("doc", "said"), [
    ([1, 2, 3], "expected a JSON object, got list"),
    (None, "expected a JSON object, got NoneType"),
    ({**GOOD_MAG, "kind": "gpx"}, "'kind' is 'gpx'"),
    ({k: v for k, v in GOOD_MAG.items() if k != "soft_iron"}, "missing 'soft_iron'"),
    ({**GOOD_MAG, "hard_iron_ut": [1, 2]}, "'hard_iron_ut' must be 3 finite numbers"),
    ({**GOOD_MAG, "hard_iron_ut": "abc"}, "'hard_iron_ut' must be 3 finite numbers [µT], got 'abc'"),
    ({**GOOD_MAG, "hard_iron_ut": [1, True, 3]}, "'hard_iron_ut' must be 3"),
    ({**GOOD_MAG, "soft_iron": [[1, 0, 0], [0, 1, 0]]}, "'soft_iron' must be 3×3 finite numbers"),
    ({**GOOD_MAG, "soft_iron": [[1, 0, 0], [0, 1, 0], [0, 0, 10 ** 400]]}, "'soft_iron' must be 3×3"),
    ({**GOOD_MAG, "module_serial": 7}, "'module_serial' must be text, got 7"),
    ({**GOOD_MAG, "field_ut": "x"}, "'field_ut' must be a number or null"),
], ids=["list", "null", "kind", "no-soft", "hard-2", "hard-text", "hard-bool", "soft-2x3", "soft-huge",
        "serial", "field"])
def test_a_file_that_is_not_a_magnetometer_calibration_says_what_is_wrong(tmp_path, doc, said):
    path = tmp_path / "cal.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(MagCalibrationError) as caught:
        MagCalibration.load(path)
    text = str(caught.value)
    assert text.startswith(f"{path}: not a magnetometer calibration: ") and said in text


def test_a_magnetometer_calibration_without_its_figures_loads_them_as_nan(tmp_path):
    path = tmp_path / "cal.json"
    path.write_text(json.dumps({**GOOD_MAG, "field_ut": None, "rotation_deg": None}))
    cal = MagCalibration.load(path)
    assert math.isnan(cal.field_ut) and math.isnan(cal.rotation_deg)
    assert cal.module_serial == "OSEMU-M00000001"


def test_calibration_files_that_cannot_be_read_raise_each_loaders_own_error(tmp_path):
    for load, error in ((MagCalibration.load, MagCalibrationError), (DriftCalibration.load, DriftError)):
        for path in (tmp_path, tmp_path / "nope.json", "/dev/zero"):
            with pytest.raises(error, match="cannot read the"):
                load(path)


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=12), inner, max_size=5),
    max_leaves=10)
#: documents near a calibration: its keys with any values
mag_docs = st.fixed_dictionaries({"kind": st.just("openshoe-mag-calibration")},
                                 optional={k: json_values for k in GOOD_MAG if k != "kind"})
drift_docs = st.fixed_dictionaries({"format": st.just("openshoe-drift-calibration"), "version": st.just(1)},
                                   optional={k: json_values for k in ("dv_m_per_s", "t_total_s", "steps",
                                                                      "captures", "module_serial")})


@settings(max_examples=80, deadline=None)
@given(doc=json_values | mag_docs)
def test_any_json_document_is_a_magnetometer_calibration_or_refused_with_a_value_error(doc):
    try:
        cal = MagCalibration.from_json(doc)
    except ValueError:
        return
    assert cal.hard_iron.shape == (3,) and np.isfinite(cal.soft_iron).all()


@settings(max_examples=80, deadline=None)
@given(doc=json_values | drift_docs)
def test_any_json_document_is_a_drift_calibration_or_refused_with_a_value_error(doc):
    try:
        cal = DriftCalibration.from_json(doc)
    except ValueError:
        return
    assert all(math.isfinite(v) for v in cal.dv) and cal.t_total_s > 0


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.binary(max_size=300) | st.text(max_size=300).map(str.encode))
def test_any_bytes_in_a_calibration_file_load_or_are_refused_naming_the_file(tmp_path, data):
    path = tmp_path / "any.json"
    path.write_bytes(data)
    for load, error in ((MagCalibration.load, MagCalibrationError), (DriftCalibration.load, DriftError)):
        try:
            load(path)
        except error as exc:
            assert str(exc).startswith(str(path)) and "\n" not in str(exc)
