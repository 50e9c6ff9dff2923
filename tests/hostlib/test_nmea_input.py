"""The GPS log reader (hostlib.aids.gps) on what a file may hold: whatever a line is — bytes, text,
a sentence with a good checksum and fields out of form — it is a fix, or counted; a file that
cannot be read, or holds no fix, is refused naming it (GpsLogError, a ValueError)."""

from __future__ import annotations

import functools
import operator

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hostlib.aids.gps import GpsLogError, NmeaReader, fixes_of_log, read_nmea

GGA = "$GPGGA,100000.00,5920.98858,N,01804.23538,E,1,09,0.9,32.48,M,0.0,M,,*58"


def sentence(body: str) -> str:
    """*body* (between ``$`` and ``*``) with its checksum: a sentence any reader takes as sent."""
    return f"${body}*{functools.reduce(operator.xor, body.encode('ascii', 'replace'), 0):02X}"


@pytest.mark.parametrize(("path", "said"), [
    ("nope.nmea", "cannot read the GPS log: No such file or directory"),
    (".", "cannot read the GPS log: it is a directory"),
    ("/dev/zero", "it is a device, not a file"),
])
def test_a_gps_log_that_cannot_be_read_is_refused_naming_it(tmp_path, path, said):
    path = tmp_path / path if not path.startswith("/") else path
    with pytest.raises(GpsLogError, match=said):
        read_nmea(path)


def test_a_gps_log_without_a_fix_is_refused_with_its_first_garbled_lines(tmp_path):
    path = tmp_path / "g.nmea"
    no_fix = sentence("GPGGA,100000.00,,,,,0,00,,,M,,M,,")
    path.write_bytes(b"\x00\xff garbage\n$GPGGA,1*00\n" + no_fix.encode())
    with pytest.raises(GpsLogError) as caught:
        fixes_of_log(path)
    text = str(caught.value)
    assert text.startswith(f"{path}: no GPS fix in 3 lines") and "\n" not in text
    assert "line 1 (not an NMEA sentence), line 2 (bad checksum)" in text and "1 without a fix" in text
    assert isinstance(caught.value, ValueError)


def test_a_good_sentence_among_garbage_is_a_fix_and_the_garbage_is_counted(tmp_path):
    path = tmp_path / "g.nmea"
    path.write_bytes(b"\xde\xad\xbe\xef\n" + GGA.encode() + b"\r\n\n")
    fixes, stats = fixes_of_log(path)
    assert len(fixes) == 1 and fixes[0].line == 2 and stats.garbled == 2 and stats.lines == 3


GOOD_FIELDS = {"GPGGA": GGA[1:-3].split(",")[1:],
               "GPRMC": "100000.00,A,5920.98858,N,01804.23538,E,0.00,0.0,010626,,,A".split(",")}
#: what may stand in a field instead of its value
junk = st.one_of(st.text(alphabet="0123456789.-+eE:NSWEXnaif ", max_size=12),
                 st.sampled_from(["", "999999", "996199.00", "nan", "inf", "-1", "1e400", "99999.9", "X"]))


@settings(max_examples=200, deadline=None)
@given(kind=st.sampled_from(sorted(GOOD_FIELDS)), data=st.data())
def test_any_sentence_with_a_good_checksum_is_a_fix_on_the_globe_or_counted(kind, data):
    """A receiver's sentence with any of its fields replaced by junk (a checksum of its own)."""
    fields = list(GOOD_FIELDS[kind])
    for i in data.draw(st.lists(st.integers(0, len(fields) - 1), max_size=4)):
        fields[i] = data.draw(junk)
    reader = NmeaReader()
    fix = reader.feed(sentence(",".join([kind, *fields])))
    stats = reader.stats
    assert stats.lines == 1 and stats.fixes + stats.missing_fix + stats.garbled + stats.other == 1
    if fix is not None:
        assert abs(fix.lat_deg) <= 90.0 and abs(fix.lon_deg) <= 180.0 and fix.utc is None
    assert reader.date is None or reader.date.year >= 2000


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.binary(max_size=400) | st.text(max_size=400).map(str.encode))
def test_any_bytes_in_a_gps_log_are_read_or_refused_with_a_gps_log_error(tmp_path, data):
    path = tmp_path / "any.nmea"
    path.write_bytes(data + b"\n" + GGA.encode())
    fixes, stats = read_nmea(path)
    assert fixes and stats.lines >= 1
    path.write_bytes(data)
    try:
        fixes_of_log(path)
    except GpsLogError as exc:
        assert str(exc).startswith(str(path)) and "\n" not in str(exc)
