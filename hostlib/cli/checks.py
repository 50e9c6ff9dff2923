"""The values the commands' options take, checked before a port opens or a capture is read: the
argparse types of the link's and the aids' numbers, and :func:`value_refusal` for the rest — a
walk's duration and heading, the plot's ellipses, the origin, the files a command writes, a second
foot's capture that is the first's file again — each refused in one line (exit status 2), so that
nothing is walked or computed for a value the command would refuse at its end, and no output file
is left half written or written for nothing."""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Callable
from pathlib import Path

from ..aids.geodesy import parse_origin
from ..inputs import output_refusal

__all__ = ["OUTPUT_OPTIONS", "baud_rate", "compass_sigma", "declination", "port_url", "seconds",
           "value_refusal"]

#: The options that name a file a command writes: (dest, flag).
OUTPUT_OPTIONS = (("csv", "--csv"), ("geojson", "--geojson"), ("png", "--png"), ("raw", "--raw"),
                  ("output", "--output"))


def _number(text: str, what: str, ok: Callable[[float], bool]) -> float:
    """*text* as a finite number *ok* takes; argparse's refusal saying *what* it must be otherwise."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and ok(value)):
        raise argparse.ArgumentTypeError(f"{what}, not {text!r}")
    return value


def seconds(text: str) -> float:
    """The argparse type of ``--ack-timeout``: a number of seconds > 0."""
    return _number(text, "a number of seconds > 0", lambda v: v > 0)


def compass_sigma(text: str) -> float:
    """The argparse type of ``--compass-sigma``: an angle [deg] > 0 and < 180."""
    return _number(text, "an angle in degrees > 0 and < 180", lambda v: 0 < v < 180)


def declination(text: str) -> float:
    """The argparse type of ``--declination``: an angle [deg] from -180 to 180."""
    return _number(text, "an angle in degrees from -180 to 180", lambda v: abs(v) <= 180)


def baud_rate(text: str) -> int:
    """The argparse type of ``--baudrate``: a whole number of bits per second > 0."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value <= 0:
        raise argparse.ArgumentTypeError(f"a whole number of bits per second > 0, not {text!r}")
    return value


def port_url(text: str) -> str:
    """The argparse type of a module's URL: a device path or pyserial URL, not nothing."""
    if not text.strip():
        raise argparse.ArgumentTypeError("a device path or URL, not an empty one")
    return text


def _same_file(a: str, b: str) -> bool:
    """Whether the names *a* and *b* are one file (False when either is no file: refused when read)."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def value_refusal(args: argparse.Namespace) -> str | None:
    """Why a value of the options of ``track``, ``log``, ``replay`` or ``drift calibrate`` is
    refused, or None (module docstring); an option the command does not have is not looked at."""
    duration = getattr(args, "duration", None)
    if duration is not None and not (math.isfinite(duration) and duration > 0):
        return f"--duration is a number of seconds > 0 (without it: until Ctrl-C), not {duration:g}"
    heading = getattr(args, "heading", 0.0)
    if not math.isfinite(heading):
        return f"--heading is an angle in degrees, not {heading:g}"
    every = getattr(args, "every", 1)
    if every < 1:
        return f"--every is a number of steps >= 1 (an ellipse every N steps in the PNG), not {every}"
    if getattr(args, "origin", None):
        try:
            parse_origin(args.origin)
        except ValueError as exc:
            return f"--{exc}"
    for dest, flag in OUTPUT_OPTIONS:
        refusal = output_refusal(getattr(args, dest, None), flag)
        if refusal is not None:
            return refusal
    first, second = getattr(args, "capture", None), getattr(args, "capture2", None)
    if first and second and _same_file(first, second):
        return (f"{second} is {first} again: the two feet are two modules, each with a capture of its "
                "own (one capture: give it alone)")
    directory = getattr(args, "mag_cal_dir", None)
    if directory and Path(directory).exists() and not Path(directory).is_dir():
        return f"--mag-cal-dir {directory} is not a folder: each module's calibration is kept there"
    return None
