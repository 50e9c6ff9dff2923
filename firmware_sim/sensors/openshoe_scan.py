"""A compiled reader for the rows of an OpenShoe walk file: the same numbers as the exact parser, faster.

:func:`firmware_sim.sensors.replay.load_openshoe` validates every row with a regular expression
and converts its fields with ``float``: about 75 ms for a 16 000-row walk, more than the
navigation on it. Measured alternatives on the same walk (2 cores, numpy 2.4, pyarrow 26):
``numpy.loadtxt`` with ``usecols`` ≈ 40 ms and no validation at all; ``pyarrow.csv`` cannot
split on runs of blanks, and collapsing them first with ``re.sub`` costs ≈ 100 ms. Here one
compiled pass over the bytes (numba, cached on disk) checks each row against the row grammar
of the exact parser and converts the numbers on the way: a few milliseconds.

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
  numbers (more than 15–16 significant digits, huge exponents) send the file to the exact parser.

Without numba (or with ``OPENSHOE_PURE=1``) :data:`AVAILABLE` is false and the caller uses the
exact parser only. numba is imported on the first scan, not before; and the reader built ahead of
time (:func:`build`: numba's ahead-of-time compiler, once, named by the digest of this file, beside
numba's cache) is used without numba at all when it is there (``OPENSHOE_AOT=0`` turns it off).
"""

from __future__ import annotations

import hashlib
import importlib.util
import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from firmware_sim import prebuilt

__all__ = ["AVAILABLE", "COLUMNS", "KEPT", "build", "built_path", "scan_rows", "warm_up"]


def built_path() -> Path:
    """Where the reader built ahead of time from this file is (or would be): beside numba's cache
    (``NUMBA_CACHE_DIR``, else this package's ``__pycache__``), named by this file's digest."""
    here = Path(__file__).resolve()
    stamp = hashlib.sha256(here.read_bytes()).hexdigest()[:24]
    return prebuilt.module_path(here.parent, f"openshoe_scan_{stamp}")


def _wanted() -> bool:
    return os.environ.get("OPENSHOE_PURE", "") != "1" and os.environ.get("NUMBA_DISABLE_JIT", "") in ("", "0")


#: Whether the compiled reader is used (otherwise :func:`scan_rows` always returns None): the
#: reader built ahead of time, or numba (the optional `fast` extra).
AVAILABLE = _wanted() and (prebuilt.enabled() and built_path().is_file()
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
        status = max(status, s)
        k = kept[col]
        if k >= 0:
            out[row, k] = value
        col += 1
    while buf[i] == 13:  # CR only right before the line feed
        i += 1
    if buf[i] != 10 or col != n_columns:
        return i, MALFORMED
    return i + 1, status


def _scan(buf: np.ndarray, start: int, end: int, columns: np.ndarray, kept: np.ndarray,
          out: np.ndarray) -> tuple[int, int]:
    """Every line of ``buf[start:end]`` (which ends with a line feed): (rows, status)."""
    pos = start
    row = 0
    while pos < end:
        if row >= len(out):
            return row, MALFORMED
        pos, status = _scan_line(buf, pos, columns, kept, out, row)
        if status != OK:
            return row, status
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
                 "_scan_exponent", "_scan_number", "_scan_field", "_scan_line"):
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
    if not _wanted() or not prebuilt.enabled():
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
