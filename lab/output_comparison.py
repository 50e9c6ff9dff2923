"""How ``lab/host_outputs.py compare`` compares a run's output files with the baseline's: numbers
within relative :data:`REL_TOL` (absolute :data:`ABS_TOL` near zero), integers exactly; CSV cell by
cell, JSON value by value, text line by line (the emulator's non-deterministic lines dropped or
masked), PNG by its pixel data, anything else byte for byte. Each ``compare_*`` returns its first
differences (at most :data:`MAX_DIFFS`) as lines to print, none when the two are the same.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
import struct
import zlib

import numpy as np

__all__ = ["ABS_TOL", "MAX_DIFFS", "REL_TOL", "as_text", "compare_bytes", "compare_csv", "compare_json",
           "compare_png", "compare_text"]

#: Two numbers within this relative difference are the same.
REL_TOL = 1e-9
#: Two numbers within this absolute difference are the same (near zero, where REL_TOL is none).
ABS_TOL = 1e-12
#: The differences a compare_* returns at most.
MAX_DIFFS = 5
DROP_LINES = [re.compile(r"preparing the compiled tracking path"),
              re.compile(r"compiled tracking path ready \(")]
MASKS = [(re.compile(r"samples in [0-9.]+ s"), "samples in X s")]

NUMBER = re.compile(r"([-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?)")


def numbers_close(a: float, b: float) -> bool:
    """Equal within relative REL_TOL, or absolute ABS_TOL near zero (NaN equals NaN)."""
    if a == b or (math.isnan(a) and math.isnan(b)):
        return True
    if math.isinf(a) or math.isinf(b):
        return False
    return abs(a - b) <= max(REL_TOL * max(abs(a), abs(b)), ABS_TOL)


def is_integer_text(text: str) -> bool:
    return re.fullmatch(r"[-+]?\d+", text.strip()) is not None


def tokens_equal(a: str, b: str) -> bool:
    """Two number tokens or cells: integers exactly, other numbers within tolerance, else text."""
    if a == b:
        return True
    if is_integer_text(a) and is_integer_text(b):
        return False
    try:
        return numbers_close(float(a), float(b))
    except ValueError:
        return False


def compare_text(a: str, b: str, name: str) -> list[str]:
    """Line by line: the words exactly, the numbers in them within tolerance."""
    la, lb = clean_lines(a), clean_lines(b)
    diffs = [] if len(la) == len(lb) else [f"{name}: {len(la)} lines vs {len(lb)}"]
    for i, (x, y) in enumerate(zip(la, lb, strict=False), 1):
        where = first_difference(x, y)
        if where is not None:
            diffs.append(f"{name} line {i}: {where}")
        if len(diffs) >= MAX_DIFFS:
            break
    return diffs


def clean_lines(text: str) -> list[str]:
    """The lines of *text* without the dropped ones, masked."""
    lines = [line for line in text.splitlines() if not any(p.search(line) for p in DROP_LINES)]
    for pattern, repl in MASKS:
        lines = [pattern.sub(repl, line) for line in lines]
    return lines


def first_difference(a: str, b: str) -> str | None:
    """None when two lines have the same words between numbers and numbers equal within tolerance;
    else the first differing piece of each, with the text before it."""
    pa, pb = NUMBER.split(a), NUMBER.split(b)
    for k, (x, y) in enumerate(zip(pa, pb, strict=False)):
        same = x == y if k % 2 == 0 else tokens_equal(x, y)
        if not same:
            before = "".join(pa[:k])[-60:].lstrip()
            return f"{x[:60]!r} vs {y[:60]!r} after {before!r}"
    if len(pa) != len(pb):
        return f"{a.strip()[:100]!r} vs {b.strip()[:100]!r}"
    return None


def compare_csv(a: str, b: str, name: str) -> list[str]:
    """Row by row, cell by cell; numbers within tolerance."""
    ra, rb = list(csv.reader(io.StringIO(a))), list(csv.reader(io.StringIO(b)))
    diffs = [] if len(ra) == len(rb) else [f"{name}: {len(ra)} rows vs {len(rb)}"]
    header = ra[0] if ra else []
    for i, (x, y) in enumerate(zip(ra, rb, strict=False)):
        diffs += row_diffs(x, y, header, f"{name} row {i}")
        if len(diffs) >= MAX_DIFFS:
            break
    return diffs


def row_diffs(x: list[str], y: list[str], header: list[str], where: str) -> list[str]:
    """The differing cells of one CSV row, named by their column."""
    if len(x) != len(y):
        return [f"{where}: {len(x)} cells vs {len(y)}"]
    out = []
    for j, (p, q) in enumerate(zip(x, y, strict=True)):
        if not tokens_equal(p, q):
            column = header[j] if j < len(header) else str(j)
            out.append(f"{where} {column}: {p} vs {q}")
    return out


def compare_json(a: str, b: str, name: str) -> list[str]:
    """The same structure; numbers within tolerance, strings and booleans exactly."""
    try:
        ja, jb = json.loads(a), json.loads(b)
    except json.JSONDecodeError:
        return compare_text(a, b, name)
    diffs: list[str] = []
    json_diffs(ja, jb, name, diffs)
    return diffs


def json_diffs(a: object, b: object, where: str, diffs: list[str]) -> None:
    """Append the differences between two JSON values to *diffs* (at most MAX_DIFFS)."""
    if len(diffs) >= MAX_DIFFS:
        return
    if isinstance(a, dict) and isinstance(b, dict):
        if list(a) != list(b):
            diffs.append(f"{where}: keys {list(a)} vs {list(b)}")
            return
        for key in a:
            json_diffs(a[key], b[key], f"{where}.{key}", diffs)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            diffs.append(f"{where}: {len(a)} items vs {len(b)}")
            return
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            json_diffs(x, y, f"{where}[{i}]", diffs)
    elif not json_scalars_equal(a, b):
        diffs.append(f"{where}: {a!r} vs {b!r}")


def json_scalars_equal(a: object, b: object) -> bool:
    """Two JSON scalars: numbers (not booleans) within tolerance, anything else exactly."""
    numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (a, b))
    if not numeric:
        return a == b and type(a) is type(b)
    if isinstance(a, int) and isinstance(b, int):
        return a == b
    return numbers_close(float(a), float(b))


PNG_KEPT = {b"IHDR", b"PLTE", b"tRNS", b"pHYs"}


def png_pixels(data: bytes) -> bytes:
    """A PNG's image data: the kept chunks and the decompressed IDAT, without text or time."""
    pos, kept, idat = 8, [], []
    while pos + 8 <= len(data):
        size, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + size]
        if kind == b"IDAT":
            idat.append(body)
        elif kind in PNG_KEPT:
            kept.append(kind + body)
        pos += 12 + size
    return b"".join(kept) + zlib.decompress(b"".join(idat))


def compare_png(a: bytes, b: bytes, name: str) -> list[str]:
    """The pixels exactly; says how many bytes of image data differ."""
    pa, pb = png_pixels(a), png_pixels(b)
    if pa == pb:
        return []
    if len(pa) != len(pb):
        return [f"{name}: image data of {len(pa)} bytes vs {len(pb)}"]
    changed = int(np.count_nonzero(np.frombuffer(pa, np.uint8) != np.frombuffer(pb, np.uint8)))
    return [f"{name}: {changed} of {len(pa)} bytes of image data differ"]


def compare_bytes(a: bytes, b: bytes, name: str) -> list[str]:
    """Byte for byte; names the first differing offset."""
    if a == b:
        return []
    first = next((i for i, (x, y) in enumerate(zip(a, b, strict=False)) if x != y), min(len(a), len(b)))
    return [f"{name}: {len(a)} vs {len(b)} bytes, first difference at byte {first}"]


def as_text(data: bytes) -> str | None:
    """The UTF-8 text of a file, or None for binary data."""
    if b"\0" in data:
        return None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return None
