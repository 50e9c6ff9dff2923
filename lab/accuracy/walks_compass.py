"""The per-step compass on the real closed-loop walks: their closure with and without it, and why.

Every recording goes once through the emulated module with the fusion host
(:func:`.runs.fusion_capture`, ``openshoe-emu replay --host fusion``): each step packet carries the
attitude quaternion and the magnetometers at the end of its stance. The capture is then decoded as
``openshoe-host replay`` decodes it (:func:`hostlib.files.replay.replay_session`), three ways:

* ``plain``: the step sum (``openshoe-host replay CAPTURE``);
* ``uncalibrated``: the per-step compass (:func:`hostlib.run.aid_setup.prepare_aids`, no GPS), the field as
  the sensor measured it (``--compass --compass-sigma S``, with the host's defaults for a real
  module turned off: the white compass alone, as this experiment has always measured it);
* ``calibrated``: the same with the shoe's iron removed (``--mag-cal``), the calibration fitted on
  the *other* walks' readings (:func:`hostlib.calibration.level_iron.iron_calibration`; the same
  sensor in the same shoe walked all of them), never on the walk it corrects.

Without GPS the declination is a constant: the compass's headings are magnetic, the whole track
turns by D about its start, and a closed loop's closure does not change. It is left at 0.

**The compass σ** is chosen from the data, leave-one-out, never from the closure: per moved step,
the compass heading minus the INS's heading (the plain track's χ) is the deviation of that reading
plus a constant (the INS frame's unknown heading); about its circular mean per walk, its RMS pooled
over the other walks' moved steps is the σ a walk is tracked with (the calibrated compass's σ with
the calibration fitted on those walks). The filter has no outlier gate, so the σ is the RMS, not a
robust spread.

**Diagnostics** per walk, to explain the result:

* the measured field where the compass reads it: its magnitude and spread along the walk, its
  horizontal part, the inclination — how disturbed the building's field is;
* the spread of the compass heading about the INS's (uncalibrated, and with the leave-one-out
  calibration): what one reading says about the heading;
* the INS's heading drift over the walk as the compass sees it on the spot where the walk starts
  and ends (:func:`start_spot_drift_deg`): what there was for a compass to correct; and the INS's
  own heading σ at the end of the plain track, which sets how much the filter lets a compass
  reading change the heading relative to the start;
* the net turn the compass gave the heading after its first reading: the filter learns mostly the
  INS frame's heading from magnetic north, a turn of the whole track about its start, which a
  closed loop's closure does not see;
* a control (:func:`control_changes`): the closure's change when the readings carry no
  information on the heading's change at all, at the same σ — what the filter alone does to the
  closure while it turns the frame step by step.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hostlib.aids.compass import StanceReading, compass_heading, stance_reading, wrap_angle
from hostlib.calibration.level_iron import IronFit, iron_calibration
from hostlib.calibration.magcal import MagCalibration
from hostlib.events import StepOutcome
from hostlib.fusion.tracker import FusionSettings, FusionTracker
from hostlib.link.module_clock import ModuleClock
from hostlib.track.steps import StepTracker, is_motion_step
from lab.runner import map_runs

from .runs import fusion_capture

__all__ = ["VARIANTS", "StanceLog", "CompassWalkResult", "capture_walk", "compass_walk_results",
           "deviation_sigma", "heading_deviations", "rows", "stance_log", "table_lines"]

#: The ways a walk is tracked: the step sum, the compass as measured, the compass calibrated
#: leave-one-out.
VARIANTS = ("plain", "uncalibrated", "calibrated")
#: Accelerometer samples averaged for the gravity while the wearer stands (32 ms at 250 Hz).
GRAVITY_SAMPLES = 8
#: Draws of the information-free control (:func:`control_changes`).
CONTROL_DRAWS = 200


def capture_walk(path: str) -> bytes:
    """The bytes the module sends replaying the recording at *path* with the fusion host."""
    from firmware_sim.sensors.replay import ReplaySource

    return fusion_capture(ReplaySource.from_file(path))


class _StanceLogger(StepTracker):
    """A step tracker that also keeps each summed step's stance reading, whether it moved the
    foot and its module time (the summation is :class:`StepTracker`'s)."""

    def __init__(self) -> None:
        super().__init__(last_counter=None)
        self._clock = ModuleClock()
        self.log: list[tuple[StanceReading | None, bool, float]] = []

    def add(self, step, swing_time: float = math.nan, states: Mapping[int, np.ndarray] | None = None
            ) -> StepOutcome:
        time_s = self._clock.seconds(states)
        outcome = super().add(step, swing_time, states)
        if outcome.summed:
            reading = stance_reading(states) if states is not None else None
            self.log.append((reading, is_motion_step(step.dx), time_s))
        return outcome


@dataclass
class StanceLog:
    """One walk's capture as the host decodes it: the plain track and every step's reading."""

    name: str
    path: str
    capture: bytes
    track: Any  #: hostlib.track.steps.Track, the plain step sum
    readings: list[StanceReading | None]  #: each summed step's end-of-stance reading (None: none)
    moved: np.ndarray  #: (n,) bool, the step moved the foot (a compass updates on those only)
    headings: np.ndarray  #: (n,) the plain track's χ after each step [rad]
    times_s: np.ndarray  #: (n,) each step's module time [s]

    @property
    def used(self) -> list[int]:
        """The steps a compass updates on: they moved the foot and carry a reading."""
        return [k for k, r in enumerate(self.readings) if r is not None and self.moved[k]]


def stance_log(path: str | Path, capture: bytes) -> StanceLog:
    """Decode *capture* (of the recording at *path*) as ``openshoe-host replay`` does, keeping each
    step's reading."""
    from hostlib.files.replay import replay_session

    logger = _StanceLogger()
    replay_session(capture, tracker=logger)
    return StanceLog(Path(path).stem, str(path), capture, logger.track, [r for r, _, _ in logger.log],
                     np.array([m for _, m, _ in logger.log], dtype=bool), logger.track.headings[1:].copy(),
                     np.array([t for _, _, t in logger.log]))


def _circular_mean(a: np.ndarray) -> float:
    return math.atan2(float(np.mean(np.sin(a))), float(np.mean(np.cos(a))))


def _field(reading: StanceReading, calibration: MagCalibration | None) -> np.ndarray:
    return reading.field_board if calibration is None else calibration.apply(reading.field_board)


def heading_deviations(log: StanceLog, calibration: MagCalibration | None = None) -> np.ndarray:
    """Per step a compass updates on, the compass heading minus the INS's heading [rad], about their
    circular mean (the constant between the INS frame and magnetic north is not a deviation)."""
    d = np.array([wrap_angle(compass_heading(_field(log.readings[k], calibration), log.readings[k].rotation)
                             - log.headings[k]) for k in log.used])
    mean = _circular_mean(d)
    return np.array([wrap_angle(x - mean) for x in d])


def deviation_sigma(logs: Sequence[StanceLog], calibration: MagCalibration | None = None) -> float:
    """The RMS of :func:`heading_deviations` pooled over *logs* [rad]: a compass σ from the data."""
    d = np.concatenate([heading_deviations(log, calibration) for log in logs])
    return float(np.sqrt(np.mean(d ** 2)))


def field_stats(log: StanceLog) -> dict[str, float]:
    """Magnitude, horizontal part and inclination of the measured field at the steps a compass uses."""
    readings = [log.readings[k] for k in log.used]
    board = np.array([r.field_board for r in readings])
    nav = np.array([np.asarray(r.rotation) @ r.field_board for r in readings])
    magnitude = np.linalg.norm(board, axis=1)
    horizontal = np.hypot(nav[:, 0], nav[:, 1])
    inclination = np.degrees(np.arctan2(nav[:, 2], horizontal))
    return {"field_ut": float(magnitude.mean()), "field_sd_ut": float(magnitude.std()),
            "field_min_ut": float(magnitude.min()), "field_max_ut": float(magnitude.max()),
            "horizontal_ut": float(horizontal.mean()), "horizontal_sd_ut": float(horizontal.std()),
            "inclination_deg": float(inclination.mean()), "inclination_sd_deg": float(inclination.std())}


def _recorded_down(acc_g: np.ndarray, rate_hz: float, time_s: float) -> np.ndarray | None:
    """The board-frame down direction the recording's accelerometer shows over the
    :data:`GRAVITY_SAMPLES` up to module time *time_s* (None outside the recording)."""
    k = int(round(time_s * rate_hz)) if math.isfinite(time_s) else -1
    if not GRAVITY_SAMPLES <= k < len(acc_g):
        return None
    down = -acc_g[k - GRAVITY_SAMPLES + 1:k + 1].mean(axis=0)
    return down / np.linalg.norm(down)


def _gravity_levelled(down: np.ndarray) -> np.ndarray:
    """The board → level rotation (yaw 0) whose vertical is *down* (board frame)."""
    roll, pitch = math.atan2(down[1], down[2]), math.asin(max(-1.0, min(1.0, -down[0])))
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    return np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]]) @ np.array(
        [[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])


def start_spot_drift_deg(log: StanceLog, acc_g: np.ndarray, rate_hz: float) -> float:
    """The INS's heading drift over the walk as the compass sees it on the spot where the walk starts
    and ends [deg]: INS minus compass heading while standing after the last step (median of the
    standing resets) less the same while standing before the first. Standing, the recorded gravity
    levels the field better than the INS (no foot motion, no tilt error of the INS's own), and the
    spot's deviation is the same at both ends (the walker returned within a centimetre, facing about
    the same way). NaN when the walk does not start and end standing."""
    if not log.moved.any() or log.moved[0] or log.moved[-1]:
        return math.nan
    last = int(np.flatnonzero(log.moved)[-1])

    def offsets(steps: Sequence[int]) -> list[float]:
        out = []
        for k in steps:
            reading, down = log.readings[k], _recorded_down(acc_g, rate_hz, log.times_s[k])
            if reading is not None and down is not None:
                psi = compass_heading(reading.field_board, _gravity_levelled(down))
                out.append(wrap_angle(log.headings[k] - psi))
        return out

    before, after = offsets([0]), offsets(range(last + 1, len(log.moved)))
    if not before or not after:
        return math.nan
    return math.degrees(wrap_angle(float(np.median(after)) - before[0]))


class _InformationFreeTracker(FusionTracker):
    """A compass tracker whose readings say nothing about the heading's change: each is the plain
    track's own heading after the step plus white noise (:func:`control_changes`)."""

    def __init__(self, sigma: float, headings: np.ndarray, noise: np.ndarray):
        super().__init__(FusionSettings(compass=True, compass_sigma_rad=sigma), last_counter=None)
        self._plain_headings, self._noise = headings, noise

    def compass_heading(self, reading: StanceReading | None) -> float | None:
        if reading is None:
            return None
        k = len(self) - 1  # the step just summed
        return wrap_angle(float(self._plain_headings[k] + self._noise[k]))


def control_changes(log: StanceLog, sigma: float, draws: int = CONTROL_DRAWS) -> np.ndarray:
    """The horizontal closure's change [percentage points] when the compass readings carry no
    information on the heading's change (the INS's heading plus white noise of *sigma*), one per
    draw (seeded 0, 1, …): what the filter alone does to a closed loop at that σ."""
    from hostlib.files.replay import replay_session

    plain = log.track.relative_closure_error()
    out = []
    for seed in range(draws):
        noise = np.random.default_rng(seed).normal(0.0, sigma, len(log.headings))
        tracker = _InformationFreeTracker(sigma, log.headings, noise)
        replay_session(log.capture, tracker=tracker)
        out.append(100.0 * (tracker.track.relative_closure_error() - plain))
    return np.array(out)


@dataclass
class CompassWalkResult:
    """One walk tracked each way of :data:`VARIANTS`, with the diagnostics (module docstring)."""

    name: str
    distance_m: float
    steps: int
    moved_steps: int
    used_steps: int  #: moved steps whose packet carried the magnetometers and the attitude
    horizontal_pct: dict[str, float]  #: variant → horizontal closure [% of the distance]
    closure_3d_pct: dict[str, float]  #: variant → 3-D closure [%]
    sigma_deg: dict[str, float]  #: compass variant → the σ it was tracked with (leave-one-out)
    compass_updates: dict[str, int]  #: compass variant → compass updates the filter made
    spread_deg: dict[str, float]  #: compass variant → RMS of this walk's heading deviations
    turn_deg: dict[str, float]  #: compass variant → net heading turn after the first reading
    iron: IronFit  #: the calibration fitted on the other walks
    field: dict[str, float]  #: the measured field (:func:`field_stats`)
    start_spot_drift_deg: float  #: :func:`start_spot_drift_deg`
    heading_sigma_deg: float  #: the plain track's heading σ at the end
    control_pct: np.ndarray  #: :func:`control_changes` at the uncalibrated σ
    tracks: dict[str, Any] = field(default_factory=dict)  #: variant → Track


def _compass_tracker(log: StanceLog, sigma: float, calibration: MagCalibration | None) -> FusionTracker:
    """The fusion tracker ``openshoe-host replay CAPTURE --compass --compass-sigma S [--mag-cal]
    --no-compass-deviation --no-module-errors --no-uncalibrated-weight`` decodes *log*'s capture with
    (no GPS, no declination; the white compass of σ S alone, the host's defaults off)."""
    from hostlib.files.replay import replay_session
    from hostlib.run.aid_setup import prepare_aids

    aids = prepare_aids(compass=True, mag_calibration=calibration, compass_deviation=None, hard_iron=None,
                        module_errors=None, uncalibrated_weight=False,
                        settings=FusionSettings(compass_sigma_rad=sigma))
    replay_session(log.capture, tracker=aids.tracker)
    return aids.tracker


def _net_turn_deg(plain: Any, aided: Any) -> float:
    """How much the compass turned the heading over the walk after aligning it: the difference
    of the two tracks' last headings less that of their first (the alignment turns them all)."""
    first = aided.headings[0] - plain.headings[0]
    last = aided.headings[-1] - plain.headings[-1]
    return math.degrees(wrap_angle(float(last - first)))


def _walk_result(log: StanceLog, others: Sequence[StanceLog], control_draws: int) -> CompassWalkResult:
    """*log* tracked each way, calibrated and with σ from *others*, and its diagnostics."""
    from firmware_sim.sensors.replay import load_recording

    iron = iron_calibration([o.readings[k] for o in others for k in o.used])
    tracks: dict[str, Any] = {"plain": log.track}
    sigma, updates, spread, turn = {}, {}, {}, {}
    for name, cal in (("uncalibrated", None), ("calibrated", iron.calibration)):
        sigma[name] = math.degrees(deviation_sigma(others, cal))
        tracker = _compass_tracker(log, math.radians(sigma[name]), cal)
        tracks[name] = tracker.track
        updates[name] = tracker.fusion.compass_updates
        spread[name] = math.degrees(float(np.sqrt(np.mean(heading_deviations(log, cal) ** 2))))
        turn[name] = _net_turn_deg(log.track, tracker.track)
    recording = load_recording(log.path)
    acc, rate = recording.board_acc_g(), float(recording.rate_hz)
    return CompassWalkResult(
        log.name, float(log.track.distance), len(log.readings), int(log.moved.sum()), len(log.used),
        {k: 100.0 * t.relative_closure_error() for k, t in tracks.items()},
        {k: 100.0 * t.relative_closure_error(horizontal=False) for k, t in tracks.items()},
        sigma, updates, spread, turn, iron, field_stats(log), start_spot_drift_deg(log, acc, rate),
        math.degrees(math.sqrt(max(float(log.track.final_covariance[3, 3]), 0.0))),
        control_changes(log, math.radians(sigma["uncalibrated"]), control_draws), tracks)


def compass_walk_results(paths: Sequence[str | Path], workers: int = 2,
                         control_draws: int = CONTROL_DRAWS, scheduler: str | None = None
                         ) -> list[CompassWalkResult]:
    """Replay every recording once, then track each plain and with the compass, uncalibrated and
    calibrated on the others (leave-one-out: at least two walks); *control_draws*: draws of the
    information-free control per walk."""
    if len(paths) < 2:
        raise ValueError("the leave-one-out calibration and compass σ need at least two walks")
    paths = [str(p) for p in paths]
    captures = map_runs(capture_walk, paths, workers, scheduler)
    logs = [stance_log(p, c) for p, c in zip(paths, captures, strict=True)]
    return [_walk_result(log, [o for j, o in enumerate(logs) if j != i], control_draws)
            for i, log in enumerate(logs)]


def _mean(results: Sequence[CompassWalkResult], get: Any) -> float:
    return float(np.mean([get(r) for r in results]))


def table_lines(results: Sequence[CompassWalkResult]) -> list[str]:
    """The closures per walk and their means, then the diagnostics and the calibrations."""
    lines = [f"{'walk':<16}{'distance':>9}{'plain h/3-D [%]':>19}{'compass h/3-D [%]':>19}"
             f"{'calibrated h/3-D [%]':>22}{'σ [°]':>13}{'updates/moved':>15}"]
    for r in results:
        h, d = r.horizontal_pct, r.closure_3d_pct
        closures = "".join(f"{h[v]:>12.3f} /{d[v]:>6.3f}" for v in VARIANTS)
        lines.append(f"{r.name:<16}{r.distance_m:>8.1f}m{closures}"
                     + f"{r.sigma_deg['uncalibrated']:>7.1f} /{r.sigma_deg['calibrated']:>4.1f}"
                     + f"{r.compass_updates['uncalibrated']:>9d} /{r.moved_steps:>3d}")
    lines.append(f"{'mean':<16}{'':>9}" + "".join(
        f"{_mean(results, lambda r, v=v: r.horizontal_pct[v]):>12.3f} /"
        f"{_mean(results, lambda r, v=v: r.closure_3d_pct[v]):>6.3f}" for v in VARIANTS))
    lines.append("plain: the step sum; compass: one compass update per moved step, the field as measured; "
                 "calibrated: the shoe's iron fitted on the other walks (leave-one-out); σ: the compass σ, "
                 "uncalibrated / calibrated, the RMS heading deviation of the other walks; no GPS, "
                 "declination 0 (a constant turn of the whole track, which a closed loop's closure "
                 "does not see)")
    lines.append("")
    lines.append(f"{'walk':<16}{'|B| [µT]':>19}{'B_h [µT]':>13}{'incl. [°]':>12}{'spread [°]':>13}"
                 f"{'drift [°]':>10}{'INS σψ [°]':>11}{'turn [°]':>14}{'control [pt]':>16}")
    for r in results:
        f = r.field
        lines.append(f"{r.name:<16}{f['field_ut']:>6.1f} ± {f['field_sd_ut']:>4.1f} "
                     f"({f['field_min_ut']:>2.0f}–{f['field_max_ut']:>2.0f})"
                     f"{f['horizontal_ut']:>6.1f} ± {f['horizontal_sd_ut']:>3.1f}"
                     f"{f['inclination_deg']:>6.1f} ± {f['inclination_sd_deg']:>3.1f}"
                     f"{r.spread_deg['uncalibrated']:>7.1f} /{r.spread_deg['calibrated']:>4.1f}"
                     f"{r.start_spot_drift_deg:>10.1f}{r.heading_sigma_deg:>11.2f}"
                     f"{r.turn_deg['uncalibrated']:>7.1f} /{r.turn_deg['calibrated']:>5.1f}"
                     + "{:>+9.2f} ({:+.2f}…{:+.2f})".format(*np.percentile(r.control_pct, [50, 10, 90])))
    lines.append("|B|: the measured field's magnitude where the compass reads it (the moved steps' "
                 "ends of stance), mean ± sd (range); B_h: its horizontal part; incl.: the inclination; "
                 "spread: RMS of compass minus INS heading about its mean, uncalibrated / calibrated; "
                 "drift: the INS's heading drift over the walk as the compass sees it on the start spot, "
                 "standing before and after, levelled with the recorded gravity; INS σψ: the plain "
                 "track's heading σ at the end; turn: the net turn the compass gave the heading after its "
                 "first reading, uncalibrated / calibrated; control: the closure's change [percentage "
                 "points] with readings that carry no heading information (the INS's heading + white "
                 f"noise of σ), {CONTROL_DRAWS} draws, median (10 %…90 %)")
    lines.append("")
    for r in results:
        fit = r.iron
        radius = f", |B_h| {fit.horizontal_ut:.1f} µT" if math.isfinite(fit.horizontal_ut) else ""
        lines.append(f"{r.name}: iron from the others, {fit.model}: hard iron "
                     f"{np.round(fit.calibration.hard_iron, 1).tolist()} µT (vertical within "
                     f"{fit.tilt_span_deg:.1f}° of its mean, 95 %; residual "
                     f"{fit.calibration.rms_residual_ut:.1f} µT RMS{radius}); ellipsoid fit: {fit.ellipsoid}")
    return lines


def rows(results: Sequence[CompassWalkResult]) -> list[dict[str, Any]]:
    """The tables as rows for a CSV."""
    out = []
    for r in results:
        row: dict[str, Any] = {"walk": r.name, "distance_m": r.distance_m, "steps": r.steps,
                               "moved_steps": r.moved_steps, "compass_steps": r.used_steps}
        for v in VARIANTS:
            row[f"{v}_horizontal_pct"] = r.horizontal_pct[v]
            row[f"{v}_3d_pct"] = r.closure_3d_pct[v]
        for v in VARIANTS[1:]:
            row[f"{v}_sigma_deg"] = r.sigma_deg[v]
            row[f"{v}_updates"] = r.compass_updates[v]
            row[f"{v}_spread_deg"] = r.spread_deg[v]
            row[f"{v}_turn_deg"] = r.turn_deg[v]
        row.update(r.field)
        row["start_spot_drift_deg"] = r.start_spot_drift_deg
        row["ins_heading_sigma_deg"] = r.heading_sigma_deg
        for q in (10, 50, 90):
            row[f"control_p{q}_pt"] = float(np.percentile(r.control_pct, q))
        row["iron_model"] = r.iron.model
        for axis, b in zip("xyz", r.iron.calibration.hard_iron, strict=True):
            row[f"hard_iron_{axis}_ut"] = float(b)
        out.append(row)
    return out
