"""Closed-loop drift correction (Bachmann et al. 2012; shared/spec/aids.md §4).

One sensor module's errors are systematic: its closed walks end in the same
area away from their start. A **calibration walk** around a closed loop gives
the difference ``Δp = p_start − p_end`` (3-D) and the swing phases' summed
duration ``T_total``; their ratio is the module's drift velocity
``Δv = Δp / T_total``. From several loops of one module,
``Δv = ΣΔp / ΣT_total``. On a later walk with that module each step's position
is moved by ``Δv · T_swing``, its own swing time, as the steps are summed.

The swing time of each step is state 0x34 SWING_TIME, which the module sends
in every step packet once the host asked for it
(:data:`protocol.extensions.FUSION_SETUP`; ``openshoe-host track/log`` send it unless
``--no-fusion``, ``openshoe-emu replay --host fusion``). A step without one cannot be corrected,
and is refused. The set-up also asks for the module's serial number: a
calibration belongs to the module it was made with, and is refused for another.

**Frame.** Δv is kept in the walk's *start frame*: x along the heading the track
starts with, y to its right, z down. A track summed from heading 0 (the default)
is in that frame; one that starts at heading χ₀ gets Δv rotated by χ₀.

**How it is applied.** The correction moves positions only, never the heading,
so it does not feed back into the summation of later steps: the corrected pose
after step *k* is the summed pose plus ``R(χ₀) Δv · Σ_{j≤k} T_swing,j``. It is
therefore a separate layer over a summed :class:`~hostlib.track.steps.Track`
(:meth:`DriftCalibration.apply`, :meth:`DriftCalibration.offsets`) rather than a
hook inside the tracker: the summation and its covariance stay exactly those of
the module paper, the uncorrected track stays at hand beside the corrected one
(to compare closures), and a live host corrects a snapshot the same way a
replay corrects a capture. The covariances are left as summed (Δv is taken as
exact).

Calibration files are JSON (:data:`FORMAT`, :data:`VERSION`); a bad one is
refused with :class:`DriftError` naming the file and what is wrong with it.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import HostError
from ..inputs import InputFileError, load_json
from ..track.steps import Track, rotation_z

__all__ = ["FORMAT", "VERSION", "DriftCalibration", "DriftError", "LoopClosure", "calibrate", "loop_closure",
           "serial_text"]

#: The ``format`` field of a calibration file.
FORMAT = "openshoe-drift-calibration"
#: The version of the calibration file this host writes and reads.
VERSION = 1
#: What the ``frame`` field of a calibration file says.
FRAME_TEXT = "walk start frame: x along the starting heading, y to its right, z down"

_FUSION_HINT = ("record it with the fusion set-up (openshoe-host track/log send it unless --no-fusion; "
                "openshoe-emu replay --host fusion)")


class DriftError(HostError, ValueError):
    """A drift calibration that cannot be made, read or applied; the message says why."""


def serial_text(serial: bytes | None) -> str:
    """A module serial number as shown: its text when printable ASCII, else its bytes in hex."""
    if serial is None:
        return "(unknown)"
    raw = serial.rstrip(b"\0")
    if raw and all(0x20 <= b < 0x7F for b in raw):
        return raw.decode("ascii")
    return serial.hex(" ").upper()


def _swing_times(track: Track, what: str) -> np.ndarray:
    """The track's swing times; refuses a track with a step that has none."""
    t = track.swing_times
    missing = np.flatnonzero(~np.isfinite(t))
    if missing.size:
        k = int(missing[0])
        raise DriftError(f"{what}: {missing.size} of {len(t)} steps have no swing time (the first is "
                         f"step {k + 1}, counter {int(track.counters[k])}): it was not recorded with the "
                         f"fusion set-up, or the module does not have state 0x34 SWING_TIME; {_FUSION_HINT}")
    return t


@dataclass(frozen=True)
class LoopClosure:
    """One closed loop: ``dp = p_start − p_end`` [m] in the walk's start frame, its swing time."""

    name: str
    dp: tuple[float, float, float]
    t_swing_s: float  #: the steps' swing times summed
    steps: int  #: steps summed (step packets)
    distance_m: float  #: horizontal distance walked

    @property
    def closure_m(self) -> float:
        """Horizontal distance between the loop's end and its start."""
        return math.hypot(self.dp[0], self.dp[1])


def loop_closure(track: Track, name: str = "track") -> LoopClosure:
    """The closure of *track* taken as one closed loop (refused without swing times or steps)."""
    if len(track) == 0:
        raise DriftError(f"{name}: no steps: a calibration loop needs a walk")
    t = _swing_times(track, name)
    poses = track.poses
    dp = rotation_z(float(poses[0, 3])).T @ (poses[0, :3] - poses[-1, :3])
    return LoopClosure(name, (float(dp[0]), float(dp[1]), float(dp[2])), float(t.sum()), len(track),
                       float(track.distance))


def calibrate(tracks: Iterable[Track], module_serial: bytes | None = None,
              names: Sequence[str] | None = None) -> DriftCalibration:
    """The drift calibration of one module from closed-loop *tracks* (one loop each):
    ``Δv = Σ(p_start − p_end) / Σ T_total``. *module_serial*: the module they were walked with
    (None: unknown, the calibration then applies to any module). *names* name the tracks in
    errors (default ``track 1``, …)."""
    tracks = list(tracks)
    if not tracks:
        raise DriftError("no closed loop to calibrate from")
    names = list(names) if names is not None else [f"track {i + 1}" for i in range(len(tracks))]
    loops = [loop_closure(t, n) for t, n in zip(tracks, names, strict=True)]
    t_total = sum(lp.t_swing_s for lp in loops)
    if not t_total > 0.0:
        raise DriftError(f"{', '.join(names)}: the steps' swing times sum to {t_total:g} s: the module "
                         "reports state 0x34 SWING_TIME as 0 (its firmware does not fill it)")
    dp = np.sum([lp.dp for lp in loops], axis=0)
    dv = dp / t_total
    return DriftCalibration((float(dv[0]), float(dv[1]), float(dv[2])), float(t_total),
                            sum(lp.steps for lp in loops), len(loops), module_serial)


@dataclass(frozen=True)
class DriftCalibration:
    """One module's drift velocity Δv [m/s] (start frame, z down) and what it was made from."""

    dv: tuple[float, float, float]
    t_total_s: float  #: the calibration loops' summed swing time
    steps: int  #: steps in those loops
    captures: int  #: closed loops it was made from
    module_serial: bytes | None = None  #: the module's MCU serial number; None: any module

    # -- applying ------------------------------------------------------------------

    def check_module(self, module_serial: bytes | None) -> None:
        """Refuse a module other than the calibration's (a calibration for any module fits all)."""
        if self.module_serial is None or module_serial == self.module_serial:
            return
        if module_serial is None:
            raise DriftError(f"the calibration is for module {serial_text(self.module_serial)}, but the "
                             f"track does not say which module made it (no MCU_ID packet): {_FUSION_HINT}")
        raise DriftError(f"the calibration is for module {serial_text(self.module_serial)}, not for module "
                         f"{serial_text(module_serial)}: a drift calibration belongs to one module")

    def velocity(self, start_heading: float) -> np.ndarray:
        """(3,) ``R(χ₀) Δv`` [m/s]: the drift velocity in the frame of a walk that starts at heading
        *start_heading* χ₀ [rad] (Δv is kept in the walk's start frame)."""
        return rotation_z(float(start_heading)) @ np.asarray(self.dv, dtype=np.float64)

    def offsets(self, track: Track, what: str = "the track") -> np.ndarray:
        """(n+1, 3) [m]: the correction of each pose of *track* (row 0, the start, is zero):
        ``R(χ₀) Δv`` times the swing time summed up to that step."""
        t = _swing_times(track, what)
        dv = self.velocity(track.poses[0, 3])
        elapsed = np.concatenate(([0.0], np.cumsum(t)))
        return elapsed[:, None] * dv[None, :]

    def apply(self, track: Track, *, module_serial: bytes | None, what: str = "the track") -> Track:
        """A new track: *track*'s poses corrected (:meth:`offsets`), its steps as received, its
        counters, swing times and covariances unchanged. *module_serial* is the serial number of
        the module that made *track* (:meth:`check_module`)."""
        self.check_module(module_serial)
        poses = track.poses
        poses[:, :3] += self.offsets(track, what)
        return Track.from_arrays(poses, track.covariances, track.steps, track.counters, track.start_counter,
                                 track.swing_times)

    # -- the file ------------------------------------------------------------------

    def to_json(self) -> dict[str, Any]:
        return {"format": FORMAT, "version": VERSION, "dv_m_per_s": list(self.dv), "frame": FRAME_TEXT,
                "t_total_s": self.t_total_s, "steps": self.steps, "captures": self.captures,
                "module_serial": None if self.module_serial is None else self.module_serial.hex()}

    def save(self, path: str | Path) -> None:
        """Write the calibration as JSON."""
        Path(path).write_text(json.dumps(self.to_json(), indent=2) + "\n")

    @classmethod
    def load(cls, path: str | Path) -> DriftCalibration:
        """Read a calibration written by :meth:`save`; a bad file is refused with :class:`DriftError`."""
        try:
            doc = load_json(path, "drift calibration")
        except InputFileError as exc:
            raise DriftError(str(exc)) from None
        try:
            return cls.from_json(doc)
        except ValueError as exc:
            raise DriftError(f"{path}: not a drift calibration: {exc}") from None

    @classmethod
    def from_json(cls, doc: Any) -> DriftCalibration:
        """The calibration in a parsed file; ValueError says what is wrong."""
        if not isinstance(doc, dict):
            raise ValueError(f"expected a JSON object, got {type(doc).__name__}")
        if doc.get("format") != FORMAT:
            raise ValueError(f"'format' is {doc.get('format')!r}, expected {FORMAT!r}")
        if doc.get("version") != VERSION or isinstance(doc.get("version"), bool):
            raise ValueError(f"format version {doc.get('version')!r} is not supported (this host reads "
                             f"version {VERSION})")
        for key in ("dv_m_per_s", "t_total_s", "steps", "captures", "module_serial"):
            if key not in doc:
                raise ValueError(f"missing {key!r}")
        dv = doc["dv_m_per_s"]
        if not (isinstance(dv, list) and len(dv) == 3 and all(_is_finite(v) for v in dv)):
            raise ValueError(f"'dv_m_per_s' must be 3 finite numbers [m/s], got {dv!r}")
        if not (_is_finite(doc["t_total_s"]) and doc["t_total_s"] > 0):
            raise ValueError(f"'t_total_s' must be a number > 0 [s], got {doc['t_total_s']!r}")
        for key in ("steps", "captures"):
            if not (isinstance(doc[key], int) and not isinstance(doc[key], bool) and doc[key] >= 1):
                raise ValueError(f"{key!r} must be an integer >= 1, got {doc[key]!r}")
        return cls((float(dv[0]), float(dv[1]), float(dv[2])), float(doc["t_total_s"]), doc["steps"],
                   doc["captures"], _serial(doc["module_serial"]))

    def __str__(self) -> str:
        dv = ", ".join(f"{v:+.5f}" for v in self.dv)
        return (f"Δv = [{dv}] m/s over T_total {self.t_total_s:.3f} s, {self.steps} steps, "
                f"{self.captures} capture(s), module {serial_text(self.module_serial)}")


def _is_finite(v: Any) -> bool:
    """Whether *v* is a finite JSON number (not true/false, nor an integer too large for a float)."""
    if not isinstance(v, (int, float)) or isinstance(v, bool):
        return False
    try:
        return math.isfinite(v)
    except OverflowError:
        return False


def _serial(value: Any) -> bytes | None:
    if value is None:
        return None
    if isinstance(value, str):
        try:
            serial = bytes.fromhex(value)
        except ValueError:
            serial = b""
        if serial:
            return serial
    raise ValueError(f"'module_serial' must be null or the serial number's bytes in hex, got {value!r}")
