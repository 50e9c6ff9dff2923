"""The compiled walk reader: the exact parser's numbers, and nothing the exact parser refuses."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from firmware_sim.sensors import openshoe_scan, replay
from firmware_sim.sensors.replay import RecordingFormatError, load_openshoe
from tests.conftest import WALK_IDS, walk_path
from tests.sensors.test_replay import CORRUPTIONS, TITLE_LINES, openshoe_row, write_openshoe

pytestmark = pytest.mark.skipif(not openshoe_scan.AVAILABLE, reason="compiled reader unavailable (no numba)")

FIELDS = ("t", "acc_g", "gyro", "mag", "nr")


def exact(path, monkeypatch):
    """The exact (regular-expression) parser's reading of *path*."""
    with monkeypatch.context() as m:
        m.setattr(openshoe_scan, "AVAILABLE", False)
        return load_openshoe(path)


def assert_same_bits(a, b):
    for name in FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape, name
        assert x.tobytes() == y.tobytes(), name
    assert a.partial_tail == b.partial_tail


def body(data: bytes) -> tuple[int, int]:
    return data.index(b"\n", data.index(b"Header:")) + 1, data.rfind(b"\n") + 1


@pytest.mark.parametrize("walk", WALK_IDS)
def test_a_walk_reads_bit_for_bit_as_the_exact_parser_reads_it(walks_dir, walk, monkeypatch):
    path = walk_path(walk)
    data = path.read_bytes()
    assert openshoe_scan.scan_rows(data, *body(data)) is not None, "the walk takes the compiled path"
    assert_same_bits(load_openshoe(path), exact(path, monkeypatch))


def number_text(value: float, style: str) -> str:
    if style == "fixed":
        return f"{value:+.8f}"
    if style == "repr":
        return repr(value)
    if style == "exp":
        return f"{value:.6e}"
    if style == "bare_point":  # "12." and ".5" are numbers too
        return f"{value:.0f}." if abs(value) >= 1 else f"{value:.3f}".replace("0.", ".", 1)
    return f"{value:.17g}"  # 17 digits: sometimes past 2^53, then the exact parser converts


numbers = st.tuples(st.floats(-50, 50, allow_nan=False, allow_infinity=False),
                    st.sampled_from(["fixed", "repr", "exp", "bare_point", "long"]))


@settings(max_examples=80, suppress_health_check=[HealthCheck.function_scoped_fixture], deadline=None)
@given(n=st.integers(1, 8), data=st.data(), sep=st.sampled_from([" ", "   ", "\t", " \t "]),
       line_end=st.sampled_from(["\r\n", "\n", "\r\r\n"]), tail=st.sampled_from(["", "   0xcb  -0.1"]))
def test_any_well_formed_file_reads_as_the_exact_parser_reads_it(tmp_path, monkeypatch, n, data, sep,
                                                                  line_end, tail):
    rows = []
    for k in range(n):
        imu = [number_text(*data.draw(numbers)) for _ in range(6)]
        mag = data.draw(st.sampled_from(["-0.12 -0.01 -0.46", "+nan +nan +nan", "nan -nan 1e-3"]))
        toks = openshoe_row(k, mag=mag).split()
        toks[1:7] = imu
        rows.append(sep + sep.join(toks) + data.draw(st.sampled_from(["", " ", "\t"])))
    path = tmp_path / "w.txt"
    path.write_bytes((line_end.join(TITLE_LINES + rows) + line_end + tail).encode("ascii"))
    fast, slow = load_openshoe(path), exact(path, monkeypatch)
    assert_same_bits(fast, slow)
    assert [math.copysign(1, v) for v in fast.mag.ravel()] == [math.copysign(1, v) for v in slow.mag.ravel()]


#: Bytes that stand in for one byte of a row: each class a template accepts, its neighbours, and
#: what no row holds.
STAND_INS = b"0123456789+-,./xXaAfFgGeEnN \t\r:" + bytes([0, 0x7F, 0x80, 0xCB])


@settings(max_examples=150, suppress_health_check=[HealthCheck.function_scoped_fixture], deadline=None)
@given(n=st.integers(2, 7), data=st.data())
def test_a_row_shaped_as_the_rows_before_it_but_for_one_byte_reads_as_the_exact_parser_reads_it(
        tmp_path, monkeypatch, n, data):
    """The rows before it make the templates (samples 3-9: the counters and numbers of as many
    digits); one byte of a later row replaced by another: the compiled reader gives the exact
    parser's numbers when that parser accepts the file, and leaves the file to it when it refuses it."""
    values = st.floats(-9.9, 9.9, allow_nan=False, allow_infinity=False)
    rows = [openshoe_row(k + 2, acc=data.draw(st.tuples(values, values, values)),
                         gyro=data.draw(st.tuples(values, values, values)),
                         mag=data.draw(st.sampled_from(["-0.12 -0.01 -0.46", "+nan +nan +nan",
                                                        "+0.125 -0.5 -0.46"]))).encode("ascii")
            for k in range(n)]
    r = data.draw(st.integers(1, n - 1))
    at = data.draw(st.sampled_from([i for i, c in enumerate(rows[r]) if c not in b" \t"]))
    # a neighbour of the byte (where a range of bytes ends: ',' between the signs, ':' after the
    # digits, 'g' after the hexadecimal letters, the other case), or any stand-in
    near = (rows[r][at] + data.draw(st.sampled_from([-2, -1, 1, 2, -32, 32]))) % 256
    byte = data.draw(st.one_of(st.just(near), st.sampled_from(STAND_INS)))
    rows[r] = rows[r][:at] + bytes([byte]) + rows[r][at + 1:]
    path = tmp_path / "w.txt"
    path.write_bytes(b"\r\n".join([t.encode("ascii") for t in TITLE_LINES] + rows) + b"\r\n")
    raw = path.read_bytes()
    try:
        slow = exact(path, monkeypatch)
    except RecordingFormatError:
        assert openshoe_scan.scan_rows(raw, *body(raw)) is None
        return
    fast = load_openshoe(path)
    assert_same_bits(fast, slow)
    assert [math.copysign(1, v) for v in fast.mag.ravel()] == [math.copysign(1, v) for v in slow.mag.ravel()]


@pytest.mark.parametrize("damaged", [4, 3], ids=["magnetometer", "no magnetometer"])
def test_every_byte_of_a_row_that_has_a_template_changed_reads_as_the_exact_parser_reads_it(
        tmp_path, monkeypatch, damaged):
    """Rows 0-3 make two templates (with a magnetometer reading and without); each byte of a later
    row of the one or the other shape replaced by its neighbours and the stand-ins, one at a time."""
    rows = [openshoe_row(k + 2, mag="+nan +nan +nan" if k % 2 else "-0.12 -0.01 -0.46").encode("ascii")
            for k in range(5)]
    path = tmp_path / "w.txt"
    for at, original in enumerate(rows[damaged]):
        near = {original ^ 32, *((original + d) % 256 for d in (-2, -1, 1, 2))}
        for byte in sorted((near | set(STAND_INS)) - {original}):
            damaged_rows = [*rows[:damaged], rows[damaged][:at] + bytes([byte]) + rows[damaged][at + 1:],
                            *rows[damaged + 1:]]
            raw = b"\r\n".join([t.encode("ascii") for t in TITLE_LINES] + damaged_rows) + b"\r\n"
            path.write_bytes(raw)
            try:
                slow = exact(path, monkeypatch)
            except RecordingFormatError:
                assert openshoe_scan.scan_rows(raw, *body(raw)) is None, (at, chr(byte))
                continue
            assert_same_bits(load_openshoe(path), slow)


def test_rows_of_one_shape_read_through_their_template_as_the_exact_parser_reads_them(tmp_path, monkeypatch):
    """Every digit and sign of the kept numbers changes from row to row, the shape stays."""
    rng = np.random.default_rng(5)
    rows = [openshoe_row(k % 9, acc=tuple(rng.uniform(-9.9, 9.9, 3)), gyro=tuple(rng.uniform(-9.9, 9.9, 3)),
                         mag=" ".join(f"{v:+.8f}" for v in rng.uniform(-0.99, 0.99, 3)))
            for k in range(400)]
    path = write_openshoe(tmp_path / "w.txt", rows)
    data = path.read_bytes()
    assert len(openshoe_scan.scan_rows(data, *body(data))) == 400
    assert_same_bits(load_openshoe(path), exact(path, monkeypatch))


EXTRA_CORRUPTIONS = {
    "uppercase nan": lambda toks: toks[:14] + ["NaN"] + toks[15:],
    "nan timestamp": lambda toks: toks[:10] + ["nan"] + toks[11:],
    "inf magnetometer": lambda toks: toks[:15] + ["inf"] + toks[16:],
    "hex without digits": lambda toks: ["0x"] + toks[1:],
    "exponent without digits": lambda toks: toks[:2] + ["1e"] + toks[3:],
    "lone point": lambda toks: toks[:2] + ["."] + toks[3:],
    "signed counter": lambda toks: toks[:7] + ["+5"] + toks[8:],
    "decimal nr": lambda toks: toks[:9] + ["3.0"] + toks[10:],
    "hex float": lambda toks: toks[:2] + ["0x1p3"] + toks[3:],
    "trailing garbage": lambda toks: toks[:3] + [toks[3] + "x"] + toks[4:],
    "comma": lambda toks: toks[:3] + [toks[3] + ","] + toks[4:],
}


@pytest.mark.parametrize("kind", sorted(CORRUPTIONS) + sorted(EXTRA_CORRUPTIONS))
def test_the_compiled_reader_leaves_every_malformed_row_to_the_exact_parser(tmp_path, kind):
    rows = [openshoe_row(k) for k in range(3)]
    corrupt = {**CORRUPTIONS, **EXTRA_CORRUPTIONS}[kind]
    rows[1] = "   ".join(corrupt(rows[1].split()))
    data = write_openshoe(tmp_path / "w.txt", rows).read_bytes()
    assert openshoe_scan.scan_rows(data, *body(data)) is None
    with pytest.raises(RecordingFormatError) as err:
        load_openshoe(tmp_path / "w.txt")
    assert err.value.line == len(TITLE_LINES) + 2


@pytest.mark.parametrize("damage", [b"\r", b"\xcb", b"\x00"])
def test_a_stray_byte_inside_a_row_goes_to_the_exact_parser(tmp_path, damage):
    rows = [openshoe_row(k) for k in range(3)]
    data = bytearray(write_openshoe(tmp_path / "w.txt", rows).read_bytes())
    at = data.index(b"0x15fd", body(bytes(data))[0] + 10)
    data[at:at] = damage
    path = tmp_path / "w.txt"
    path.write_bytes(bytes(data))
    assert openshoe_scan.scan_rows(bytes(data), *body(bytes(data))) is None
    with pytest.raises(RecordingFormatError, match="line 5"):
        load_openshoe(path)


def test_numbers_past_the_exact_range_are_converted_by_the_exact_parser(tmp_path, monkeypatch):
    row = openshoe_row(0).split()
    row[1] = "0.12345678901234567890"  # 20 significant digits: past 2^53
    row[2] = "1e-30"  # exponent past 10^22
    path = write_openshoe(tmp_path / "w.txt", ["   ".join(row)])
    data = path.read_bytes()
    assert openshoe_scan.scan_rows(data, *body(data)) is None
    rec = load_openshoe(path)
    assert struct.pack("<d", rec.acc_g[0, 0]) == struct.pack("<d", float(row[1]))
    assert rec.acc_g[0, 1] == 1e-30
    assert_same_bits(rec, exact(path, monkeypatch))


def test_a_file_without_rows_is_refused_as_before(tmp_path):
    path = write_openshoe(tmp_path / "w.txt", [])
    with pytest.raises(RecordingFormatError, match="no samples"):
        load_openshoe(path)
    assert replay._load_openshoe_compiled(path, path.read_bytes()) is None


def test_kept_columns_are_the_exact_parsers_groups():
    assert openshoe_scan.N_KEPT == replay._OPENSHOE_ROW.groups
    assert len(openshoe_scan.COLUMNS) == len(openshoe_scan.KEPT) == len(replay._COLUMN_NAMES)
    kept = openshoe_scan.KEPT
    assert np.array_equal(np.sort(kept[kept >= 0]), np.arange(openshoe_scan.N_KEPT))


def test_warming_up_reads_a_sample_row():
    assert openshoe_scan.warm_up() is True


def test_the_shortest_rows_fit_the_room_made_for_them(tmp_path, monkeypatch):
    short = "0x0 1 2 3 4 5 6 7 0x0 8 9 1 2 3 4 5 6"
    assert len(short) + 1 == openshoe_scan.MIN_ROW_BYTES
    path = tmp_path / "w.txt"
    path.write_bytes(("\n".join(TITLE_LINES + [short] * 50) + "\n").encode())
    data = path.read_bytes()
    assert len(openshoe_scan.scan_rows(data, *body(data))) == 50
    assert_same_bits(load_openshoe(path), exact(path, monkeypatch))
