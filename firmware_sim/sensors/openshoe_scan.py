"""A compiled reader for the rows of an OpenShoe walk file: the same numbers as the exact parser, faster.

:func:`firmware_sim.sensors.replay.load_openshoe` validates every row with a regular expression
and converts its fields with ``float``: about 75 ms for a 16 000-row walk, more than the
navigation on it. Measured alternatives on the same walk (2 cores, numpy 2.4, pyarrow 26):
``numpy.loadtxt`` with ``usecols`` ≈ 40 ms and no validation at all; ``pyarrow.csv`` cannot
split on runs of blanks, and collapsing them first with ``re.sub`` costs ≈ 100 ms. Here one
compiled pass over the bytes (numba, cached on disk) checks each row against the row grammar
of the exact parser and converts the numbers on the way: about 2.3 ms a walk.

Most rows of a walk look alike: the same fields at the same places, only digits and signs
changing (the shared walks have some 40 shapes of row, two of them — with and without a
magnetometer reading — most of the rows). So a row the scanner accepted field by field becomes a
*template* (16 are kept, the least recently used replaced): for each of its bytes the bytes that
may stand there in a row of the same shape (that byte itself, any digit, either sign, any
hexadecimal digit). A later row that matches a template byte for byte (one vectorised pass) has
the template row's fields, each of the same form, so the grammar accepts it as it accepted that
row; its kept numbers are read at the template's places, eight digits at a time. Any other row
is scanned field by field again. Field by field about 5.6 ms a walk; with templates 2.3 ms.

It is conservative: :func:`scan_rows` returns ``None`` for anything it is not sure of — any row
that breaks the grammar, a non-ASCII byte, a stray carriage return, or a number it cannot
convert exactly — and the caller then runs the exact parser, which accepts the file or refuses
it with the line number and the reason. So the fast path never accepts what the exact parser
refuses, and never gives a different number:

* a field is accepted only when it matches its column's pattern (hexadecimal id and checksum,
  unsigned counter and sample number, finite numbers, ``nan`` allowed only in the frequency
  and magnetometer columns), exactly 17 fields a row, blanks and tabs between them, and only
  carriage returns right before the line feed;
* a number ``±m·10^e`` is converted as ``m × 10^e`` or ``m / 10^−e`` when the integer *m*
  is below 2^53 and |e| ≤ 22: both operands are then exact doubles and the one IEEE
  operation rounds correctly, which is what ``float()`` returns (Clinger's fast path). Other
  numbers (more than 15–16 significant digits, huge exponents) in a column the recording keeps
  send the file to the exact parser; in a column only checked (the id, the checksum, the
  unfiltered and predicted times, the frequency) the form is all that matters.

Without numba (or with ``OPENSHOE_PURE=1``) :data:`AVAILABLE` is false and the caller uses the
exact parser only. numba is imported on the first scan, not before; and the reader built ahead of
time (:func:`build`: numba's ahead-of-time compiler, once, named by the digest of this file, beside
numba's cache) is used without numba at all when it is there (``OPENSHOE_AOT=0`` turns it off).
"""

from __future__ import annotations

import hashlib
import importlib.util
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from firmware_sim import prebuilt
from firmware_sim.numba_use import compiling_wanted

__all__ = ["AVAILABLE", "COLUMNS", "KEPT", "build", "built_path", "scan_rows", "warm_up"]


def built_path() -> Path:
    """Where the reader built ahead of time from this file is (or would be): beside numba's cache
    (``NUMBA_CACHE_DIR``, else this package's ``__pycache__``), named by this file's digest."""
    here = Path(__file__).resolve()
    stamp = hashlib.sha256(here.read_bytes()).hexdigest()[:24]
    return prebuilt.module_path(here.parent, f"openshoe_scan_{stamp}")


#: Whether the compiled reader is used (otherwise :func:`scan_rows` always returns None): the
#: reader built ahead of time, or numba (the optional `fast` extra).
AVAILABLE = compiling_wanted() and (prebuilt.enabled() and built_path().is_file()
                           or importlib.util.find_spec("numba") is not None)

HEX, NUM, UINT, NUM_OR_NAN = 0, 1, 2, 3
#: The 17 columns of a row, by kind (see the grammar in firmware_sim.sensors.replay).
COLUMNS = np.array([HEX] + [NUM] * 6 + [UINT, HEX, UINT] + [NUM] * 3 + [NUM_OR_NAN] * 4, dtype=np.int8)
#: Output column of each row column (-1: checked, not kept): a, ω, counter, nr, filtered ts, m —
#: the capture groups of the exact parser's row pattern, in order.
KEPT = np.array([-1, 0, 1, 2, 3, 4, 5, 6, -1, 7, 8, -1, -1, -1, 9, 10, 11], dtype=np.int8)
N_KEPT = 12

#: No well-formed row is shorter: 17 fields (two of at least 3 bytes), 16 blanks, a line feed.
MIN_ROW_BYTES = 2 * 3 + 15 + 16 + 1
OK, MALFORMED, INEXACT = 0, 1, 2
_MANTISSA_MAX = 1 << 53  # largest integer below which every integer is an exact double
_STICKY_FROM = 1 << 59  # m·10 + 9 stays within int64 below this
_TOO_BIG = 1 << 62
_POW10 = np.array([10.0**k for k in range(23)])  # 1e0 … 1e22, all exact doubles


def _is_blank(c: int) -> bool:
    return c == 32 or c == 9


def _ends_field(c: int) -> bool:
    return c == 32 or c == 9 or c == 13 or c == 10


def _is_digit(c: int) -> bool:
    return 48 <= c <= 57


def _is_hex(c: int) -> bool:
    return 48 <= c <= 57 or 97 <= c <= 102 or 65 <= c <= 70


# Every scan below stops at the line feed that ends the buffer, so none needs a bounds check.


def _scan_hex(buf: np.ndarray, i: int) -> int:
    """End of a ``0[xX][0-9a-fA-F]+`` field at *i*, or -1."""
    if buf[i] != 48 or (buf[i + 1] != 120 and buf[i + 1] != 88) or not _is_hex(buf[i + 2]):
        return -1
    i += 3
    while _is_hex(buf[i]):
        i += 1
    return i


def _scan_digits(buf: np.ndarray, i: int, m: int) -> tuple[int, int, int]:
    """Digits from *i*: (end, count, m·10^count + their value; past 2^59 it stays at 2^62)."""
    k = i
    while _is_digit(buf[i]):
        m = m * 10 + (buf[i] - 48) if m < _STICKY_FROM else _TOO_BIG
        i += 1
    return i, i - k, m


def _scan_exponent(buf: np.ndarray, i: int) -> tuple[int, int]:
    """An optional ``[eE][+-]?\\d+`` at *i*: (end or -1, value)."""
    if buf[i] != 101 and buf[i] != 69:
        return i, 0
    i += 1
    negative = buf[i] == 45
    if negative or buf[i] == 43:
        i += 1
    if not _is_digit(buf[i]):
        return -1, 0
    e = 0
    while _is_digit(buf[i]):
        e = min(e * 10 + (buf[i] - 48), 100_000)
        i += 1
    return i, -e if negative else e


def _scan_number(buf: np.ndarray, i: int, nan_ok: bool) -> tuple[int, float, int]:
    """A number ``[+-]?(\\d+(\\.\\d*)?|\\.\\d+)([eE][+-]?\\d+)?`` (or ``[+-]?nan`` when *nan_ok*)
    at *i*: (end or -1, value, status)."""
    negative = buf[i] == 45
    if negative or buf[i] == 43:
        i += 1
    if nan_ok and buf[i] == 110 and buf[i + 1] == 97 and buf[i + 2] == 110:
        return i + 3, math.copysign(math.nan, -1.0 if negative else 1.0), OK  # float('-nan') keeps its sign
    i, n_int, m = _scan_digits(buf, i, 0)
    n_frac = 0
    if buf[i] == 46:
        i, n_frac, m = _scan_digits(buf, i + 1, m)
    if n_int + n_frac == 0:
        return -1, 0.0, MALFORMED
    i, e = _scan_exponent(buf, i)
    if i < 0:
        return -1, 0.0, MALFORMED
    e -= n_frac
    if m == 0:
        value = 0.0
    elif m > _MANTISSA_MAX or not -22 <= e <= 22:
        return i, 0.0, INEXACT
    elif e >= 0:
        value = float(m) * _POW10[e]
    else:
        value = float(m) / _POW10[-e]
    return i, -value if negative else value, OK


def _scan_field(buf: np.ndarray, i: int, kind: int) -> tuple[int, float, int]:
    """The field of *kind* at *i*, up to a blank or the line end: (end, value, status)."""
    value = 0.0
    status = OK
    if kind == HEX:
        j = _scan_hex(buf, i)
    elif kind == UINT:
        j, n, m = _scan_digits(buf, i, 0)
        if n == 0:
            j = -1
        elif m > _MANTISSA_MAX:
            status = INEXACT
        else:
            value = float(m)
    else:
        j, value, status = _scan_number(buf, i, kind == NUM_OR_NAN)
    if j < 0 or not _ends_field(buf[j]):
        return -1, 0.0, MALFORMED
    return j, value, status


def _scan_line(buf: np.ndarray, i: int, columns: np.ndarray, kept: np.ndarray,
               out: np.ndarray, row: int) -> tuple[int, int]:
    """The row at *i* into ``out[row]``: (the position after its line feed, status)."""
    col = 0
    status = OK
    n_columns = len(columns)
    while True:
        while _is_blank(buf[i]):
            i += 1
        c = buf[i]
        if c == 13 or c == 10:
            break
        if col >= n_columns:
            return i, MALFORMED
        i, value, s = _scan_field(buf, i, columns[col])
        if s == MALFORMED:
            return i, MALFORMED
        k = kept[col]
        if k >= 0:  # a number it only checks need not convert exactly
            status = max(status, s)
            out[row, k] = value
        col += 1
    while buf[i] == 13:  # CR only right before the line feed
        i += 1
    if buf[i] != 10 or col != n_columns:
        return i, MALFORMED
    return i + 1, status


# A row's template (the fast path through a file whose rows look alike): for each byte of a row
# the scanner accepted, the bytes that may stand there in a row of the same shape — that byte
# itself, any digit, either sign, any hexadecimal digit — as a range (lo, lo + span), and the
# places where the range is wider than the class (a sign's 43..45, a hexadecimal digit's
# 0x30..0x66), checked exactly; and where each kept number's sign, digits and point are. A row
# that matches a template byte for byte has the template row's fields, each of the same form,
# so the grammar accepts it as it accepted that row, and its numbers are read at those places.
SLOTS = 16  #: the templates kept (the shared walks have some 40 shapes of row, a few of them common)
MAX_ROW = 512  #: the longest row a template is made of
MAX_SPECIAL = 64  #: the most signs and hexadecimal digits in a template row
MAX_DIGITS = 17  #: the most digits of a kept number in a template row (below 2^59: no saturation)
F_KIND, F_SIGN, F_FIRST, F_POINT, F_END, F_FRAC = range(6)  #: a kept number's places in a template
T_NUMBER, T_UINT, T_NAN = 1, 2, 3  #: a kept field's form in a template


def _template_class(lo: np.ndarray, span: np.ndarray, r: int, low: int, width: int) -> None:
    lo[r] = low
    span[r] = width


def _make_template(buf: np.ndarray, pos: int, length: int, columns: np.ndarray, kept: np.ndarray,
                   lo: np.ndarray, span: np.ndarray, special: np.ndarray, fields: np.ndarray) -> int:
    """The template of the row of *length* bytes at *pos*, which the scanner accepted: the number
    of its special places, or -1 when the row makes none (an exponent, a long number or row)."""
    if length > MAX_ROW:
        return -1
    i = pos
    col = 0
    n_special = 0
    while True:
        while _is_blank(buf[i]):
            _template_class(lo, span, i - pos, buf[i], 0)
            i += 1
        c = buf[i]
        if c == 13 or c == 10:
            break
        kind = columns[col]
        k = kept[col]
        col += 1
        if kind == HEX:
            _template_class(lo, span, i - pos, buf[i], 0)
            _template_class(lo, span, i - pos + 1, buf[i + 1], 0)
            i += 2
            while _is_hex(buf[i]):
                if n_special == MAX_SPECIAL:
                    return -1
                _template_class(lo, span, i - pos, 48, 54)
                special[n_special] = -(i - pos) - 1  # negative: a hexadecimal digit's place
                n_special += 1
                i += 1
            continue
        sign = -1
        if c == 43 or c == 45:
            if n_special == MAX_SPECIAL:
                return -1
            sign = i - pos
            _template_class(lo, span, sign, 43, 2)
            special[n_special] = sign
            n_special += 1
            i += 1
        if buf[i] == 110:  # nan
            for j in range(3):
                _template_class(lo, span, i - pos + j, buf[i + j], 0)
            i += 3
            if k >= 0:
                fields[k, F_KIND] = T_NAN
                fields[k, F_SIGN] = sign
            continue
        first = i
        point = -1
        while _is_digit(buf[i]) or buf[i] == 46:  # the scanner accepted the row: one point at most
            if buf[i] == 46:
                point = i
                _template_class(lo, span, i - pos, 46, 0)
            else:
                _template_class(lo, span, i - pos, 48, 9)
            i += 1
        if buf[i] == 101 or buf[i] == 69 or i - first - (point >= 0) > MAX_DIGITS:
            return -1  # an exponent, or a number that could pass 2^59
        if k >= 0:
            fields[k, F_KIND] = T_UINT if kind == UINT else T_NUMBER
            fields[k, F_SIGN] = sign
            fields[k, F_FIRST] = first - pos
            fields[k, F_POINT] = (point if point >= 0 else i) - pos
            fields[k, F_END] = i - pos
            fields[k, F_FRAC] = i - point - 1 if point >= 0 else 0
    while i < pos + length:  # the carriage returns and the line feed
        _template_class(lo, span, i - pos, buf[i], 0)
        i += 1
    return n_special


# The hot loops below index with unsigned integers: numba then tests no index for a negative one
# (which would keep LLVM from vectorising the template's test and from reading eight digits as one
# word), and they make no views of arrays (each one a reference count taken and given back).


def _matches(buf: np.ndarray, pos: int, end: int, t: int, length: np.ndarray, lo: np.ndarray,
             span: np.ndarray, special: np.ndarray, n_special: np.ndarray) -> bool:
    """Whether the row at *pos* matches template *t* (``length[t]`` bytes, its line feed last)."""
    n = length[t]
    if n == 0 or pos + n > end or buf[pos + n - 1] != 10:
        return False
    at = np.uint64(pos)
    bad = False
    for r in range(n):  # (written so that it vectorises on bytes)
        bad |= np.uint8(buf[at + np.uint64(r)] - lo[t, r]) > span[t, r]
    if bad:
        return False
    for j in range(n_special[t]):
        r = special[t, j]
        if r < 0:
            if not _is_hex(buf[pos - r - 1]):
                return False
        elif buf[pos + r] == 44:  # a sign's range holds the comma between + and -
            return False
    return True


_U8 = np.uint64(8)
_ZEROS = np.uint64(0x3030303030303030)  # eight '0's
_LOW_BYTES = np.uint64(0x000000FF000000FF)
_BY_100 = np.uint64(100 + (1000000 << 32))
_BY_1 = np.uint64(1 + (10000 << 32))
_U10, _U16, _U32 = np.uint64(10), np.uint64(16), np.uint64(32)


def _eight_digits(buf: np.ndarray, i: int) -> int:
    """The value of the eight digits at *i*, read as one word (the bytes, first one lowest)."""
    at = np.uint64(i)
    x = np.uint64(0)
    for j in range(8):
        x |= np.uint64(buf[at + np.uint64(j)]) << (_U8 * np.uint64(j))
    x -= _ZEROS
    x = x * _U10 + (x >> _U8)  # pairs of digits
    x = ((x & _LOW_BYTES) * _BY_100 + ((x >> _U16) & _LOW_BYTES) * _BY_1) >> _U32
    return np.int64(x)


def _digits(buf: np.ndarray, i: int, end: int, m: int) -> int:
    """``m·10^(end−i)`` plus the value of the digits ``buf[i:end]`` (at most 18 digits in all)."""
    while end - i >= 8:
        m = m * 100_000_000 + _eight_digits(buf, i)
        i += 8
    while i < end:
        m = m * 10 + (buf[np.uint64(i)] - 48)
        i += 1
    return m


def _read_template(buf: np.ndarray, pos: int, t: int, fields: np.ndarray, out: np.ndarray, row: int) -> int:
    """The kept numbers of the row at *pos*, which matches template *t* (its kept numbers' places in
    ``fields[t]``), into ``out[row]``: the status (INEXACT for a number past 2^53)."""
    for k in range(N_KEPT):
        sign = fields[t, k, F_SIGN]
        negative = sign >= 0 and buf[np.uint64(pos + sign)] == 45
        if fields[t, k, F_KIND] == T_NAN:
            out[row, k] = math.copysign(math.nan, -1.0 if negative else 1.0)
            continue
        point = pos + fields[t, k, F_POINT]
        m = _digits(buf, pos + fields[t, k, F_FIRST], point, 0)
        m = _digits(buf, point + 1, pos + fields[t, k, F_END], m)
        if m > _MANTISSA_MAX:
            return INEXACT
        value = float(m) / _POW10[fields[t, k, F_FRAC]]
        out[row, k] = -value if negative else value
    return OK


def _to_front(order: np.ndarray, p: int) -> None:
    """Move ``order[p]`` to the front, the ones before it one place back."""
    slot = order[p]
    for j in range(p, 0, -1):
        order[j] = order[j - 1]
    order[0] = slot


def _scan(buf: np.ndarray, start: int, end: int, columns: np.ndarray, kept: np.ndarray,
          out: np.ndarray) -> tuple[int, int]:
    """Every line of ``buf[start:end]`` (which ends with a line feed): (rows, status). A row that
    matches one of the templates (tried the most recently used first) is read through it; any
    other is scanned field by field, and then makes a template in the least recently used slot."""
    lo = np.zeros((SLOTS, MAX_ROW), dtype=np.uint8)
    span = np.zeros((SLOTS, MAX_ROW), dtype=np.uint8)
    special = np.zeros((SLOTS, MAX_SPECIAL), dtype=np.int64)
    fields = np.zeros((SLOTS, N_KEPT, 6), dtype=np.int64)
    length = np.zeros(SLOTS, dtype=np.int64)
    n_special = np.zeros(SLOTS, dtype=np.int64)
    order = np.arange(SLOTS)
    pos = start
    row = 0
    while pos < end:
        if row >= len(out):
            return row, MALFORMED
        p = 0
        while p < SLOTS and not _matches(buf, pos, end, order[p], length, lo, span, special, n_special):
            p += 1
        if p < SLOTS:
            slot = order[p]
            status = _read_template(buf, pos, slot, fields, out, row)
            if status != OK:
                return row, status
            pos += length[slot]
            _to_front(order, p)
        else:
            next_pos, status = _scan_line(buf, pos, columns, kept, out, row)
            if status != OK:
                return row, status
            slot = order[SLOTS - 1]
            made = _make_template(buf, pos, next_pos - pos, columns, kept, lo[slot], span[slot],
                                  special[slot], fields[slot])
            length[slot] = next_pos - pos if made >= 0 else 0
            if made >= 0:
                n_special[slot] = made
                _to_front(order, SLOTS - 1)
            pos = next_pos
        row += 1
    return row, OK


_reader: list[Callable[..., tuple[int, int]] | None] = []  #: the compiled reader once found (one element)


def _compiled() -> Callable[..., tuple[int, int]] | None:
    """The compiled :func:`_scan`: the reader built ahead of time, else numba's (from its cache
    or compiled on first use), else None. Found once per process."""
    if not _reader:
        _reader.append(_built() or _numba_scan() if AVAILABLE else None)
    return _reader[0]


def _built() -> Callable[..., tuple[int, int]] | None:
    return prebuilt.load(built_path(), "scan")


def _numba_scan() -> Callable[..., tuple[int, int]] | None:
    """:func:`_scan` compiled with numba (its helpers inlined: a call per byte costs more than the
    byte); None without numba."""
    global _scan
    try:
        import numba
        from numba.core import caching
        from numba.core.runtime import rtsys
    except ImportError:  # pragma: no cover - depends on the environment
        return None
    if hasattr(_scan, "py_func"):
        return _scan
    options = {"cache": True, "nogil": True, "error_model": "numpy"}
    for name in ("_is_blank", "_ends_field", "_is_digit", "_is_hex", "_scan_hex", "_scan_digits",
                 "_scan_exponent", "_scan_number", "_scan_field", "_scan_line", "_template_class",
                 "_make_template", "_matches", "_eight_digits", "_digits", "_read_template",
                 "_to_front"):
        globals()[name] = numba.njit(inline="always", **options)(globals()[name])
    _scan = numba.njit(**options)(_scan)

    class QuickLoadCache(caching.FunctionCache):
        """numba's cache of the reader, loading it with only numba's runtime started: not the typing
        and lowering registries numba's own load refreshes first, which only a compile needs (and
        sets up itself) — most of a cache load (as the navigation kernels', firmware_sim.nav.jit)."""

        def load_overload(self, sig: Any, target_context: Any) -> Any:
            rtsys.initialize(target_context)
            return self._load_overload(sig, target_context)

    _scan._cache = QuickLoadCache(_scan.py_func)
    return _scan


def build() -> bool:
    """Build the reader ahead of time for this file unless it is there or failed before (remembered
    beside it: :func:`firmware_sim.prebuilt.build_once`); whether it is there now. Needs numba (its
    ``pycc``) and a C compiler; seconds."""
    path = built_path()
    if not compiling_wanted() or not prebuilt.enabled():
        return path.is_file()
    return prebuilt.build_once(path, _compile)


def _compile(folder: Path) -> None:
    from numba import types
    from numba.pycc import CC

    scan = _numba_scan()
    assert scan is not None, "numba is needed to build the reader"
    cc: Any = CC(built_path().name.split(".")[0])
    cc.output_dir = str(folder)
    cc.verbose = False
    i8 = types.Array(types.int8, 1, "C")
    cc.export("scan", types.UniTuple(types.int64, 2)(
        types.Array(types.uint8, 1, "C", readonly=True), types.int64, types.int64, i8, i8,
        types.Array(types.float64, 2, "C")))(scan.py_func)
    prebuilt.compile_releasing_gil(cc)  # a reader thread reads while the runs go on


def scan_rows(data: bytes, start: int, end: int) -> np.ndarray | None:
    """The kept fields of the rows in ``data[start:end]`` ((rows, 12) float64: a_x…ar_z, counter,
    nr, filtered ts, m_x…m_z), or None when the exact parser must decide (module docstring).

    ``data[start:end]`` must be whole lines, the last one ended by a line feed.
    """
    scan = _compiled() if AVAILABLE and end > start and data[end - 1] == 10 else None
    if scan is None:
        return None
    buf = np.frombuffer(data, dtype=np.uint8)
    out = np.empty(((end - start) // MIN_ROW_BYTES + 1, N_KEPT))  # room for every possible row
    rows, status = scan(buf, start, end, COLUMNS, KEPT, out)
    if status != OK:
        return None
    return out[:rows]


#: One well-formed row (the first of a shared walk), for :func:`warm_up`.
_SAMPLE_ROW = (b"   0xcb   -0.10581776   +0.15830289   +0.99007481   +0.00535047   -0.01242570   +0.00101861"
               b"     130516848    0x15fd       1 1274434048.503018 1274434048.503018 1274434048.507018"
               b"  250.000001   -0.12299968   -0.01066045   -0.46057537 \r\n")


def warm_up() -> bool:
    """Compile the reader, or load it from numba's cache, now rather than on the first file;
    whether it is available."""
    return scan_rows(_SAMPLE_ROW, 0, len(_SAMPLE_ROW)) is not None
