"""NavShoe's outage experiment, simulated (shared/spec/aids.md §2).

One walk of the ``navshoe-outage`` scenario per seed — a hilly 1 km loop outdoors, started facing
north-east, whose GPS receiver stops giving fixes after the first 400 m — goes once through the
module (``openshoe-emu replay --host fusion``: each step packet carries the magnetometers and the
attitude at the end of its stance) and its receiver's NMEA sentences once through
:class:`hostlib.aids.gps.NmeaReader`. The host then tracks the same bytes four ways
(:class:`hostlib.fusion.tracker.FusionTracker`):

* ``compass+gps``: the per-step compass (σ 5°, outdoors), the declination from the World Magnetic
  Model at the first fix as a state with σ 15°, GPS updates while there are fixes;
* ``gps``: GPS only — the heading is aligned on the GPS course, then transfer-aligned;
* ``compass``: the compass with the WMM declination, no GPS;
* ``compass+gps uncalibrated``: as the first, without removing the shoe's iron;
* ``plain``: the step sum, given the true initial heading (the best plain dead reckoning can do);
* ``compass+gps deviation state`` and ``compass deviation state``: as ``compass+gps`` and
  ``compass`` with the local deviation held as a state (:data:`hostlib.fusion.deviation.OUTDOORS`, each
  reading's own σ :data:`hostlib.fusion.deviation.WHITE_SIGMA_RAD`);
* ``gps bias state`` and ``compass+gps bias state``: as ``gps`` and ``compass+gps`` with the
  receiver's correlated error held as a state (:class:`hostlib.fusion.gps_bias.GpsBias`, its defaults: the
  receiver's 3 m RMS over τ = 120 s, the fix's white 0.3 m) and every fix used;
* ``gps module errors`` and ``compass+gps module errors``: as ``gps`` and ``compass+gps`` with the
  module's errors held as states at the emulated module's priors
  (:data:`hostlib.fusion.module_errors.EMULATED_MODULE`: step-length scale, climb, turn scale and heading
  drift rate), which GPS trains and the outage then carries on;
* ``compass+gps every error state``: ``compass+gps`` with every error the host can hold as a
  state at once: the local deviation, the receiver's bias and the module's errors (each as above);
* ``gps module errors and warm-up``, ``compass+gps module errors and warm-up``, ``compass module
  errors and warm-up`` and ``compass+gps every error state and warm-up``: the same with the
  module's errors at the priors of the emulated module on a real foot's swaying stance
  (:data:`hostlib.fusion.module_errors.EMULATED_MODULE_SWAYING`), the gyros' warm-up among them: the
  hosts for swaying stances (the default), where the module's ZARU no longer re-learns the bias in
  every stance and the warm-up turns the heading (on still stances, ``--no-stance-sway``, the
  warm-up does not, and their prior is wrong);
* ``compass true declination``: the compass without GPS, given the simulated declination (what
  the compass alone holds when the declination is not to be learned);
* two oracles, as ``compass+gps`` with the truth put into each compass reading
  (:class:`OracleCompassTracker`), to show what bounds the compass's gain:
  ``compass+gps deviation removed`` (the simulated open-ground deviation at the true position
  taken out: what remains is the chips' noise and the attitude's error) and
  ``compass+gps perfect compass`` (every reading the true heading minus the true declination:
  what remains is the declination GPS taught and the INS between readings).

The compass runs remove the shoe's hard and soft iron as simulated (the walk has no wiggle for the
in-situ calibration; :mod:`~lab.accuracy.magcal` measures what that leaves). Per run: the horizontal position
error and the heading error at the end of the walk (the end of the outage), the distance walked
without GPS, and the learned declination against the simulated Earth field's. Positions of a GPS
run are about its first fix; they are put back in the walk's frame with that fix's own position
before comparing.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from firmware_sim.app.truth_files import shoe_iron  # the whole iron, the rotation no ellipsoid fit sees
from hostlib.fusion.deviation import OUTDOORS, WHITE_SIGMA_RAD
from hostlib.fusion.gps_bias import GpsBias
from hostlib.fusion.module_errors import EMULATED_MODULE, EMULATED_MODULE_SWAYING
from hostlib.fusion.tracker import FusionSettings, FusionTracker

from .runs import stance_words

__all__ = ["SCENARIO", "HOSTS", "ORACLES", "OracleCompassTracker", "WalkFixes", "error_table", "outage_rows",
           "outage_run", "outdoor_compass", "simulated_warmup",
           "shoe_iron", "summary_lines", "walk_fixes", "wmm_declination_rad"]

SCENARIO = "navshoe-outage"
HOSTS = ("compass+gps", "gps", "compass", "compass+gps uncalibrated", "plain",
         "compass+gps deviation state", "compass deviation state", "gps bias state", "compass+gps bias state",
         "compass true declination", "compass+gps deviation removed", "compass+gps perfect compass",
         "gps module errors", "compass+gps module errors", "compass+gps every error state",
         "gps module errors and warm-up", "compass+gps module errors and warm-up",
         "compass module errors and warm-up", "compass+gps every error state and warm-up")
#: the oracle hosts: what :class:`OracleCompassTracker` takes out of each reading
ORACLES = {"compass+gps deviation removed": "deviation", "compass+gps perfect compass": "all"}
#: 1σ of one compass reading outdoors [deg]: the emulator's open-ground deviation (0.8 µT per axis
#: against a 15.5 µT horizontal field, ≈ 3°) and three chips' noise (≈ 1.3°), rounded up.
OUTDOOR_COMPASS_SIGMA_DEG = 5.0


@dataclass(frozen=True)
class WalkFixes:
    """The fixes of a walk's GPS receiver as the host reads them (its NMEA through
    :class:`hostlib.aids.gps.NmeaReader`)."""

    times_s: np.ndarray  #: (n,) each fix's time, seconds since the receiver started talking
    north_east: np.ndarray  #: (n, 2) [m] each fix about the first fix: what the host's filter takes
    first_fix: np.ndarray  #: (2,) the first fix in the walk's frame: where a GPS run's origin lies
    without_gps_m: float  #: the distance walked after the receiver's last fix [m]


def walk_fixes(scenario: str, t: np.ndarray, pos: np.ndarray, vel: np.ndarray, seed: int) -> WalkFixes:
    """The fixes of a receiver carried along the true path *pos*, *vel* (times *t*) of *scenario*'s
    walk *seed*, at the default origin and start, with the outage the scenario scripts."""
    from firmware_sim.sensors.gps import (
        DEFAULT_ORIGIN,
        DEFAULT_START,
        GpsErrors,
        nmea_lines,
        scenario_errors,
        simulate_fixes,
    )
    from firmware_sim.sensors.truth import walked_distance
    from hostlib.aids.gps import NmeaReader, local_positions, seconds_since

    errors = scenario_errors(GpsErrors(), scenario, t, pos)
    reader = NmeaReader()
    fixes = reader.feed_all(nmea_lines(simulate_fixes(t, pos, vel, DEFAULT_ORIGIN, errors, seed=seed),
                                       DEFAULT_START, errors))
    walked = walked_distance(pos)
    outage_start = errors.outages[-1][0]
    return WalkFixes(seconds_since(reader.stats.first_time, fixes), local_positions(fixes)[:, :2],
                     local_positions(fixes[:1], origin=DEFAULT_ORIGIN)[0, :2],
                     float(walked[-1] - np.interp(outage_start, t, walked)))


def wmm_declination_rad() -> float:
    """The World Magnetic Model's declination [rad] at the simulated walks' default origin and start."""
    from firmware_sim.sensors.gps import DEFAULT_ORIGIN, DEFAULT_START
    from hostlib.aids.declination import declination_deg

    return math.radians(declination_deg(*DEFAULT_ORIGIN, DEFAULT_START))


def outdoor_compass() -> dict[str, Any]:
    """The per-step compass outdoors, as :class:`hostlib.fusion.tracker.FusionSettings` fields: σ
    :data:`OUTDOOR_COMPASS_SIGMA_DEG`, the declination prior from the World Magnetic Model
    (:func:`wmm_declination_rad`)."""
    return {"compass": True, "compass_sigma_rad": math.radians(OUTDOOR_COMPASS_SIGMA_DEG),
            "declination_rad": wmm_declination_rad()}


class OracleCompassTracker(FusionTracker):
    """A :class:`~hostlib.fusion.tracker.FusionTracker` whose compass readings have the simulated truth put
    in, at the step's time (the foot stands at the end of its stance, so the nearest truth sample is
    the reading's pose). *take_out* ``"deviation"`` adds back the heading error the simulated
    deviation makes at the true position
    (:meth:`~firmware_sim.sensors.magnetic.MagneticWorld.heading_deviation`); ``"all"`` replaces
    the reading with the true heading minus the true declination (*source*'s)."""

    def __init__(self, settings: FusionSettings, source: Any, take_out: str, **tracker_args):
        if take_out not in ("deviation", "all"):
            raise ValueError(f"take_out is 'deviation' or 'all', not {take_out!r}")
        super().__init__(settings, **tracker_args)
        self._source = source
        self._take_out = take_out

    def compass_heading(self, reading):
        psi = super().compass_heading(reading)
        if psi is None:
            return None
        truth = self._source.truth
        i = min(int(np.searchsorted(truth.t, self._time)), len(truth.t) - 1)
        if self._take_out == "deviation":
            return psi + float(self._source.magnetic.heading_deviation(truth.pos[i])[0])
        r = truth.R[i]
        return math.atan2(r[1, 0], r[0, 0]) - math.radians(self._source.config.mag.declination_deg)


def outage_run(seed: int, stance_sway: bool | None = None) -> list[dict[str, Any]]:
    """The hosts' rows of one seed (module docstring); a GPS host's also give its horizontal error
    where the receiver fell silent (``last_fix_error_m``: the error the outage starts with).
    *stance_sway*: the walking stances sway as a real foot's
    (:class:`firmware_sim.sensors.stance_sway.StanceSway`; None: the simulation's default)."""
    from firmware_sim.sensors.imu_array import make_source
    from hostlib.aids.compass import wrap_angle
    from hostlib.files.replay import replay_session

    from .runs import fusion_capture

    source = make_source(SCENARIO, seed=seed, stance_sway=stance_sway)
    sway = source.trajectory.stance_sway is not None
    truth = source.truth
    data = fusion_capture(source)
    gps = walk_fixes(SCENARIO, truth.t, truth.pos, truth.vel, seed)
    true_declination = source.config.mag.declination_deg
    end = truth.pos[-1, :2]
    r_end = truth.R[-1]
    true_heading = math.atan2(r_end[1, 0], r_end[0, 0])
    r0 = truth.R[0]
    compass = {**outdoor_compass(), "mag_calibration": shoe_iron(source)}
    wmm = compass["declination_rad"]
    deviation_held = {**compass, "compass_sigma_rad": WHITE_SIGMA_RAD, "compass_deviation": OUTDOORS}
    settings = {
        "compass+gps": FusionSettings(gps=True, **compass),
        "gps": FusionSettings(gps=True),
        "compass": FusionSettings(**compass),
        "compass+gps uncalibrated": FusionSettings(gps=True, **{**compass, "mag_calibration": None}),
        "plain": FusionSettings(),
        "compass+gps deviation state": FusionSettings(gps=True, **deviation_held),
        "compass deviation state": FusionSettings(**deviation_held),
        "gps bias state": FusionSettings(gps=True, gps_bias=GpsBias()),
        "compass+gps bias state": FusionSettings(gps=True, gps_bias=GpsBias(), **compass),
        "compass true declination": FusionSettings(**{**compass,
                                                      "declination_rad": math.radians(true_declination)}),
        **{host: FusionSettings(gps=True, **compass) for host in ORACLES},
        "gps module errors": FusionSettings(gps=True, module_errors=EMULATED_MODULE),
        "compass+gps module errors": FusionSettings(gps=True, module_errors=EMULATED_MODULE, **compass),
        "compass+gps every error state": FusionSettings(gps=True, gps_bias=GpsBias(),
                                                        module_errors=EMULATED_MODULE, **deviation_held),
        "gps module errors and warm-up": FusionSettings(gps=True, module_errors=EMULATED_MODULE_SWAYING),
        "compass+gps module errors and warm-up": FusionSettings(gps=True, **compass,
                                                                module_errors=EMULATED_MODULE_SWAYING),
        "compass module errors and warm-up": FusionSettings(**compass, module_errors=EMULATED_MODULE_SWAYING),
        "compass+gps every error state and warm-up": FusionSettings(gps=True, gps_bias=GpsBias(),
                                                                    module_errors=EMULATED_MODULE_SWAYING,
                                                                    **deviation_held),
    }
    rows = []
    for host in HOSTS:
        cfg = settings[host]
        heading0 = math.atan2(r0[1, 0], r0[0, 0]) if host == "plain" else 0.0
        if host in ORACLES:
            tracker = OracleCompassTracker(cfg, source, ORACLES[host], last_counter=None)
        else:
            tracker = FusionTracker(cfg, last_counter=None, heading=heading0)
        if cfg.gps:
            tracker.add_fixes(gps.times_s, gps.north_east)
        replay_session(data, tracker=tracker)
        pose = tracker.track.final_pose
        position = pose[:2] + (gps.first_fix if cfg.gps else 0.0)
        error = float(np.hypot(*(position - end)))
        # where the receiver fell silent: the first step at or after its last fix
        k = int(np.searchsorted(np.asarray(tracker.step_times), gps.times_s[-1]))
        k = min(k, len(tracker.step_times) - 1)
        at = np.array([np.interp(tracker.step_times[k], truth.t, truth.pos[:, i]) for i in (0, 1)])
        silent_pose, silent_cov = tracker.track.poses[k + 1], tracker.track.covariances[k + 1]
        silent_error = silent_pose[:2] + gps.first_fix - at
        last_fix_error = float(np.hypot(*silent_error))
        i = min(int(np.searchsorted(truth.t, tracker.step_times[k])), len(truth.t) - 1)
        r_silent = truth.R[i]
        silent_heading_error = wrap_angle(float(silent_pose[3]) - math.atan2(r_silent[1, 0], r_silent[0, 0]))
        cov = tracker.state_covariance
        heading_error = wrap_angle(float(pose[3]) - true_heading)
        errors = cfg.module_errors
        first_step_s = next((t for t in tracker.step_times if math.isfinite(t)), math.nan)
        rows.append({
            "seed": seed, "host": host, "stance_sway": sway, "distance_m": round(tracker.track.distance, 1),
            "without_gps_m": round(gps.without_gps_m, 1), "end_error_m": error,
            "end_error_pct_without_gps": 100.0 * error / gps.without_gps_m,
            "heading_error_deg": math.degrees(heading_error),
            # the normalised squared errors at the end: horizontal (2 dof) and heading (1 dof)
            "nees_horizontal": float((position - end) @ np.linalg.solve(cov[:2, :2], position - end)),
            "nees_heading": heading_error ** 2 / float(cov[3, 3]) if cov[3, 3] > 0 else math.nan,
            "declination_deg": math.degrees(tracker.declination),
            "declination_sigma_deg": math.degrees(tracker.declination_sigma),
            "true_declination_deg": true_declination, "wmm_declination_deg": math.degrees(wmm),
            "compass_updates": tracker.fusion.compass_updates, "gps_updates": tracker.fusion.gps_updates,
            "aligned_by": tracker.fusion.heading_aligned_by or "truth",
            "last_fix_error_m": last_fix_error if cfg.gps else math.nan,
            # the same where the receiver fell silent: how honest the GPS training left the filter
            "silent_nees_horizontal": (float(silent_error @ np.linalg.solve(silent_cov[:2, :2], silent_error))
                                       if cfg.gps else math.nan),
            "silent_nees_heading": (silent_heading_error ** 2 / float(silent_cov[3, 3])
                                    if cfg.gps and silent_cov[3, 3] > 0 else math.nan),
            # the gyros' warm-up the host learned, and the simulated dies' (hosts that hold it)
            "warmup_deg_s": (math.degrees(tracker.module_errors[-1])
                             if errors is not None and errors.holds_warmup else math.nan),
            "true_warmup_deg_s": math.degrees(simulated_warmup(source, first_step_s)),
        })
    return rows


def simulated_warmup(source, first_step_s: float) -> float:
    """The warm-up w [rad/s] of :mod:`hostlib.fusion.module_errors` that the simulated dies hold for a host
    whose first step is at module time *first_step_s* [s]: each chip's gyro offset temperature
    coefficient turned into the board's axes (the mounting's transpose), the vertical (z, down when
    the foot is flat) averaged over the four chips as the firmware averages them, times the warm-up
    still to come at the first step (the module on for ``powered_s`` before the run, as the dies'
    temperature has it); with the sign that corrects the heading (the host's w undoes the drift the
    bias turns in)."""
    tc = source.config.temperature
    mounting = source.geometry.mounting.astype(float)
    vertical = float(np.mean([(m.T @ chip.gyro_offset_tempco)[2] for m, chip in zip(mounting, source.chips,
                                                                                        strict=True)]))
    return -vertical * tc.warmup_c * math.exp(-(first_step_s + tc.powered_s) / tc.warmup_tau_s)


def outage_rows(seeds: Sequence[int], workers: int = 2, stance_sway: bool | None = None,
                scheduler: str | None = None) -> list[dict[str, Any]]:
    """Every seed's rows, seeds in order (:func:`lab.runner.seeded_rows`; *stance_sway* as in
    :func:`outage_run`)."""
    from lab.runner import seeded_rows

    return seeded_rows(functools.partial(outage_run, stance_sway=stance_sway), seeds, workers, scheduler)


def summary_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per host: mean ± sd and worst of the end error and |heading error|; the declination learned."""
    sway = stance_words(rows)
    return [f"navshoe-outage, {len({r['seed'] for r in rows})} seeds{sway}: error at the end of the outage "
            f"({np.mean([r['without_gps_m'] for r in rows]):.0f} m walked without GPS)"
            ] + (error_table(rows, "host", HOSTS) + _silent_lines(rows) + _warmup_lines(rows)
                 + _consistency_lines(rows))


def _consistency_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per host whose heading an aid aligned: the mean normalised squared error per degree of
    freedom at the end (1 is consistent), horizontal and heading."""
    out = ["mean NEES per dof (1: the covariance is honest), horizontal / heading, at the end "
           "(and where the receiver fell silent):"]
    for host in HOSTS:
        sel = [r for r in rows if r["host"] == host and r["aligned_by"] != "truth"]
        if sel:
            h = np.mean([r["nees_horizontal"] for r in sel]) / 2.0
            c = np.nanmean([r["nees_heading"] for r in sel])
            line = f"  {host:<30} {h:6.2f} / {c:6.2f}"
            silent = [r for r in sel if math.isfinite(r.get("silent_nees_horizontal", math.nan))]
            if silent:
                hs = np.mean([r["silent_nees_horizontal"] for r in silent]) / 2.0
                cs = np.nanmean([r["silent_nees_heading"] for r in silent])
                line += f"   ({hs:5.2f} / {cs:5.2f})"
            out.append(line)
    return out


def _silent_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per GPS host, mean ± sd of the horizontal error where the receiver fell silent."""
    out = ["error where the receiver fell silent [m]:"]
    for host in HOSTS:
        e = [r["last_fix_error_m"] for r in rows
             if r["host"] == host and math.isfinite(r["last_fix_error_m"])]
        if e:
            out.append(f"  {host:<30} {np.mean(e):5.2f} ± {np.std(e):4.2f}")
    return out


def _warmup_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per host that holds the gyros' warm-up: the learned w against the simulated dies'
    (:func:`simulated_warmup`), mean ± sd of the difference, and the simulated's RMS."""
    held = [h for h in HOSTS if any(r["host"] == h and math.isfinite(r.get("warmup_deg_s", math.nan))
                                    for r in rows)]
    if not held:
        return []
    out = ["the gyros' warm-up w, learned − simulated [°/s]:"]
    for host in held:
        pairs = np.array([(r["warmup_deg_s"], r["true_warmup_deg_s"]) for r in rows if r["host"] == host])
        miss = pairs[:, 0] - pairs[:, 1]
        out.append(f"  {host:<42} {np.mean(miss):+.4f} ± {np.std(miss):.4f}   "
                   f"(simulated {np.sqrt(np.mean(pairs[:, 1] ** 2)):.4f} RMS)")
    return out


def error_table(rows: Sequence[dict[str, Any]], key: str, names: Sequence[str], height: bool = False
                ) -> list[str]:
    """The table of :func:`summary_lines`, a line per *key* in *names*: mean ± sd and worst of the
    end error (horizontal) and |heading error|, the declination (learned where compass and GPS are
    on); with *height*, mean ± sd of |height error| at the end too (the rows' ``height_error_m``)."""
    w = max(26, *(len(n) for n in names))
    out = [f"{key:<{w}} {'end error [m]':>16}" + (f" {'|height| [m]':>14}" if height else "")
           + f" {'% of no-GPS m':>14} {'worst %':>8} {'|heading| [°]':>14} {'declination [°]':>16}"]
    for name in names:
        sel = [r for r in rows if r[key] == name]
        if not sel:
            continue
        e = np.array([r["end_error_m"] for r in sel])
        pct = np.array([r["end_error_pct_without_gps"] for r in sel])
        h = np.abs([r["heading_error_deg"] for r in sel])
        d = np.array([r["declination_deg"] for r in sel])
        learned = "compass+gps" in name
        dec = f"{d.mean():6.2f} ± {d.std():4.2f}" if learned else f"{d.mean():6.2f} (fixed)"
        z = np.abs([r["height_error_m"] for r in sel]) if height else None
        out.append(f"{name:<{w}} {e.mean():7.2f} ± {e.std():5.2f}"
                   + (f" {z.mean():6.2f} ± {z.std():5.2f}" if height else "")
                   + f" {pct.mean():14.2f} {pct.max():8.2f} {h.mean():6.2f} ± {h.std():5.2f} {dec:>16}")
    truth = rows[0]
    out.append(f"simulated declination {truth['true_declination_deg']:.2f}°, WMM prior "
               f"{truth['wmm_declination_deg']:.2f}°")
    return out
