"""Reading a GPS receiver: NMEA sentences in, fixes out; anything else skipped and counted."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from hostlib.aids.gps import KEEP_GARBLED, NmeaReader, local_positions, read_nmea

GGA = "$GPGGA,120000.00,5823.69400,N,01534.36800,E,1,09,0.9,90.00,M,0.0,M,,*5A"
RMC = "$GPRMC,120000.00,A,5823.69400,N,01534.36800,E,1.50,90.0,241126,,,A*6E"
NO_FIX = "$GPGGA,120001.00,,,,,0,00,,,M,,M,,*4A"


def _with_checksum(body: str) -> str:
    cs = 0
    for ch in body:
        cs ^= ord(ch)
    return f"${body}*{cs:02X}"


def test_garbled_lines_are_skipped_counted_and_named_by_line_and_nothing_else_is_lost(tmp_path):
    gga = _with_checksum(GGA[1:GGA.index("*")])
    rmc = _with_checksum(RMC[1:RMC.index("*")])
    no_fix = _with_checksum(NO_FIX[1:NO_FIX.index("*")])
    bad_sum = gga[:-2] + ("00" if gga[-2:] != "00" else "11")
    lines = [rmc, gga, "noise \x00\xff", bad_sum, "", no_fix, "$GPGSA,A,3,,,,,,,,,,,,,1.0,0.9,0.5*00", gga]
    path = tmp_path / "g.nmea"
    path.write_bytes("\r\n".join(lines).encode("latin-1") + b"\r\n")
    fixes, stats = read_nmea(path)
    assert [f.line for f in fixes] == [2, 8]
    assert (stats.lines, stats.fixes, stats.missing_fix) == (8, 2, 1)
    assert stats.garbled == 4 and [n for n, _ in stats.garbled_lines] == [3, 4, 5, 7]
    assert dict(stats.garbled_lines)[4] == "bad checksum"
    assert stats.other == 1  # the RMC
    assert fixes[0].utc is not None and fixes[0].utc.isoformat() == "2026-11-24T12:00:00+00:00"
    assert abs(fixes[0].lat_deg - (58 + 23.694 / 60)) < 1e-9 and fixes[0].satellites == 9
    assert "2 fixes, 1 without a fix, 4 garbled" in stats.summary()


def test_only_the_first_garbled_lines_are_kept_but_all_are_counted():
    reader = NmeaReader()
    reader.feed_all(["junk"] * (KEEP_GARBLED + 5))
    assert reader.stats.garbled == KEEP_GARBLED + 5 and len(reader.stats.garbled_lines) == KEEP_GARBLED


@given(st.lists(st.one_of(st.text(max_size=90), st.binary(max_size=90)), max_size=20))
def test_no_line_stops_the_reader(lines):
    reader = NmeaReader()
    reader.feed_all(lines)
    s = reader.stats
    assert s.lines == len(lines) == s.fixes + s.missing_fix + s.garbled + s.other


def test_fixes_are_placed_about_the_first_one_or_a_given_origin():
    gga = _with_checksum(GGA[1:GGA.index("*")])
    north = _with_checksum(GGA[1:GGA.index("*")].replace("5823.69400", "5823.74800"))  # +0.054' ≈ 100 m
    fixes = NmeaReader().feed_all([gga, north])
    local = local_positions(fixes)
    np.testing.assert_allclose(local[0], 0.0, atol=1e-6)
    assert local[1, 0] == np.float64(local[1, 0]) and 99.0 < local[1, 0] < 101.0 and abs(local[1, 1]) < 1e-3
    assert local_positions([]).shape == (0, 3)
