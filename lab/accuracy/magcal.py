"""NavShoe's in-situ magnetometer calibration, simulated (shared/spec/aids.md §3).

One walk of the ``navshoe-calibration`` scenario per seed, each seed its own module (its own shoe
iron): standing outdoors, the wearer wiggles the shoe for 30 s, then walks 76 m. The walk goes once
through the module with the calibrating host (``openshoe-emu replay --host fusion --calibrate-mag``:
the magnetometers stream from the fusion set-up until the first step longer than 0.5 m), and the
host decodes the bytes as ``openshoe-host replay --calibrate-mag`` does
(:class:`hostlib.calibration.wiggle.WiggleCalibration`). Against the iron as simulated (m_b = (I + S) Rᵀ
m_n + h):

* **hard iron** — |ĥ − h| [µT];
* **soft iron** — what is left of the distortion once the fit is applied to the true one:
  M = Â (I + S) would be a scale if the fit were perfect. Its polar decomposition M = U P splits
  off the rotation U, which no ellipsoid fit can see (the readings are the same for any rotation of
  the sphere) and the attitude can (:mod:`hostlib.calibration.iron_rotation`); the residual distortion is
  ‖P / det(P)^⅓ − I‖₂ (the scale does not matter to a heading), and U's angle, the rotation left,
  is reported beside it;
* **compass** — the per-step compass on the walk after the wiggle, each step that moved the foot
  (its reading at the end of its stance): the heading from the packet's magnetometers and attitude
  (:func:`hostlib.aids.compass.compass_heading`) against the true heading less the declination and the
  local deviation (outdoors, a few degrees over tens of metres); its RMS over the walk.

Each with the fitted calibration (the ellipsoid turned by the rotation the attitude shows, as
:class:`~hostlib.calibration.wiggle.WiggleCalibration` gives it); with the ellipsoid fit alone; with the
best any
ellipsoid fit could give (the true iron's symmetric part V⁻¹, where I + S = V U: only the rotation U
left); with the true iron (:func:`.navshoe.shoe_iron`); and uncalibrated. With them, the attitude's
fit: how many readings were held still, the inclination they agree on and their scatter about it,
and the 1σ of its three angles (board x, y, z) from that scatter — how well the attitudes
determine each.

:func:`tilt_rows` is the study behind :data:`hostlib.calibration.wiggle.MIN_COVERAGE_DEG`: the same walk with
wiggles that tilt the shoe less (``wiggle:30:DEG``; DEG = 90 is the scenario's), for each the
readings' coverage (:func:`hostlib.calibration.wiggle.coverage_deg`) and the fit's own worst level-heading
error — against the best any ellipsoid fit could do, the true iron's symmetric part (with U, the
part it cannot see, left out), so that only the fit's error counts; and, against the true iron,
the same fit alone and turned by the attitude's rotation
(:func:`hostlib.calibration.iron_rotation.fit_iron_rotation`, its limits lifted so that it always turns; the
inclination's scatter about it beside, and whether the calibration would have turned it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np

__all__ = ["CALIBRATIONS", "SCENARIO", "TILTS_DEG", "calibration_rows", "calibration_run", "summary_lines",
           "tilt_lines", "tilt_rows", "tilt_run"]

SCENARIO = "navshoe-calibration"
CALIBRATIONS = ("fitted", "ellipsoid only", "best ellipsoid", "true", "none")
#: The wiggles' largest tilts of :func:`tilt_rows` [deg].
TILTS_DEG = (50.0, 60.0, 65.0, 70.0, 80.0, 90.0)
#: The walk after the wiggles of :func:`tilt_rows`: a few strides end the calibration.
_TILT_RECIPE = "face:30+stand:5+wiggle:30:{tilt:g}+stand:3+walk:6+stand:2"
#: Level headings at which :func:`tilt_rows` compares calibrations [deg].
_LEVEL_HEADINGS_DEG = np.arange(0.0, 360.0, 30.0)


def _calibrating_capture(source: Any) -> bytes:
    """The bytes the module sends walking *source* with the calibrating fusion host."""
    from firmware_sim.app.batch import run_replay
    from firmware_sim.mcu.module import ModuleConfig
    from firmware_sim.transports.factory import module_serial

    config = ModuleConfig(rate_hz=float(source.rate_hz), mcu_serial=module_serial(source.module))
    return bytes(run_replay(source, config=config, announce=None, host="fusion", calibrate_mag=True))


def _decode(data: bytes) -> tuple[Any, list[tuple[Any, float, np.ndarray]]]:
    """The capture's calibration (:class:`~hostlib.calibration.wiggle.WiggleCalibration`, as ``openshoe-host
    replay --calibrate-mag`` runs it) and every step packet's (stance reading, module time [s], dx)."""
    from hostlib.aids.compass import stance_reading
    from hostlib.calibration.wiggle import WiggleCalibration
    from hostlib.events import PacketEvent
    from hostlib.files.replay import replay_calibrating
    from hostlib.fusion.tracker import FusionSettings, FusionTracker
    from hostlib.link.module_clock import ModuleClock
    from protocol.ids import StateId

    wiggle = WiggleCalibration()
    steps: list[tuple[Any, float, np.ndarray]] = []
    clock = ModuleClock()

    def keep(events: list) -> None:
        for ev in events:
            if isinstance(ev, PacketEvent) and ev.states is not None and StateId.DX in ev.states:
                steps.append((stance_reading(ev.states), clock.seconds(ev.states),
                              np.asarray(ev.states[StateId.DX], dtype=np.float64)))

    tracker = FusionTracker(FusionSettings(compass=True), last_counter=None)
    replay_calibrating(data, wiggle, tracker, on_events=keep)
    return wiggle, steps


def _soft_iron_residual(fit_soft: np.ndarray, true_soft: np.ndarray) -> tuple[float, float]:
    """(‖P / det(P)^⅓ − I‖₂, angle of U [deg]) of M = fit_soft · true_soft = U P (module docstring)."""
    w, s, vt = np.linalg.svd(fit_soft @ true_soft)
    u = w @ vt
    p = vt.T @ np.diag(s) @ vt
    p /= np.cbrt(np.linalg.det(p))
    angle = math.degrees(math.acos(float(np.clip((np.trace(u) - 1.0) / 2.0, -1.0, 1.0))))
    return float(np.linalg.norm(p - np.eye(3), 2)), angle


def calibration_run(seed: int) -> list[dict[str, Any]]:
    """Every calibration's row of walk *seed* (module docstring)."""
    from firmware_sim.sensors.imu_array import make_source
    from hostlib.aids.compass import compass_heading, wrap_angle
    from hostlib.calibration.magcal import MagCalibration
    from hostlib.track.steps import is_motion_step

    from .navshoe import shoe_iron

    source = make_source(SCENARIO, seed=seed)
    truth = source.truth
    wiggle, steps = _decode(_calibrating_capture(source))
    lengths = np.array([math.hypot(dx[0], dx[1]) for _, _, dx in steps])
    first_long = int(np.argmax(lengths > wiggle.stop_step_m))
    walk = [(reading, t) for reading, t, dx in steps[first_long:]
            if is_motion_step(dx) and reading is not None]
    index = np.clip(np.rint(np.array([t for _, t in walk]) * source.rate_hz).astype(int), 0, len(truth) - 1)
    declination = math.radians(source.config.mag.declination_deg)
    expected = truth.euler[index, 2] - declination - source.magnetic.heading_deviation(truth.pos[index])
    true_iron = shoe_iron(source)
    best = MagCalibration(true_iron.hard_iron, _best_symmetric(source.magnetic.soft_iron))
    calibrations = {"fitted": wiggle.calibration, "ellipsoid only": wiggle.ellipsoid, "best ellipsoid": best,
                    "true": true_iron, "none": MagCalibration(np.zeros(3), np.eye(3))}
    attitude = _attitude_row(wiggle)
    rows = []
    for name in CALIBRATIONS:
        cal = calibrations[name]
        row: dict[str, Any] = {"seed": seed, "calibration": name, "readings": len(wiggle.readings),
                               "steps_calibrating": wiggle.steps,
                               "longest_wiggle_step_m": float(lengths[:first_long].max()),
                               "coverage_deg": wiggle.coverage_deg,
                               "fit_heading_sigma_deg": wiggle.heading_sigma_deg,
                               "refused": wiggle.refusal or "", **attitude}
        if cal is None:
            rows.append(row)
            continue
        errors = np.array([wrap_angle(compass_heading(cal.apply(r.field_board), r.rotation) - e)
                           for (r, _), e in zip(walk, expected, strict=True)])
        soft, left = _soft_iron_residual(cal.soft_iron, source.magnetic.soft_iron)
        row.update({"hard_iron_error_ut": float(np.linalg.norm(cal.hard_iron - source.magnetic.hard_iron)),
                    "soft_iron_residual": soft, "rotation_left_deg": left,
                    "compass_steps": len(errors),
                    "compass_rms_deg": math.degrees(float(np.sqrt(np.mean(errors ** 2)))),
                    "compass_mean_deg": math.degrees(float(np.mean(errors)))})
        rows.append(row)
    return rows


def _attitude_row(wiggle: Any) -> dict[str, Any]:
    """The attitude's fit of a :class:`~hostlib.calibration.wiggle.WiggleCalibration`: readings held still,
    inclination and its scatter, the rotation's 1σ about the board's axes and on a level compass
    [deg] (NaN where it was not fitted), why it was not."""
    rotation = wiggle.rotation
    if rotation is None:
        sigma, row = np.full(3, math.nan), {"still_readings": 0, "inclination_deg": math.nan,
                                            "inclination_scatter_deg": math.nan,
                                            "rotation_heading_sigma_deg": math.nan}
    else:
        sigma = np.degrees(np.sqrt(np.diag(rotation.covariance)))
        row = {"still_readings": rotation.readings, "inclination_deg": rotation.inclination_deg,
               "inclination_scatter_deg": rotation.scatter_deg,
               "rotation_heading_sigma_deg": rotation.heading_sigma_deg()}
    return {**row, **{f"rotation_sigma_{axis}_deg": float(v) for axis, v in zip("xyz", sigma, strict=True)},
            "rotation_refused": wiggle.rotation_refusal or ""}


def calibration_rows(seeds: Sequence[int], workers: int = 2, scheduler: str | None = None
                     ) -> list[dict[str, Any]]:
    """Every seed's rows, seeds in order (:func:`lab.runner.seeded_rows`)."""
    from lab.runner import seeded_rows

    return seeded_rows(calibration_run, seeds, workers, scheduler)


def _best_symmetric(true_soft: np.ndarray) -> np.ndarray:
    """The best calibration any ellipsoid fit can give of the iron (I + S) = V U (V symmetric, U a
    rotation): V⁻¹, which leaves U."""
    w, s, vt = np.linalg.svd(true_soft)
    return np.linalg.inv(w @ np.diag(s) @ w.T)


def tilt_run(seed: int) -> list[dict[str, Any]]:
    """One module's rows of :func:`tilt_rows`: a row per tilt of :data:`TILTS_DEG`."""
    from firmware_sim.sensors.config import DEFAULT_CONFIG
    from firmware_sim.sensors.imu_array import make_source
    from firmware_sim.sensors.magnetic import earth_field_ned
    from hostlib.calibration.iron_rotation import fit_iron_rotation
    from hostlib.calibration.magcal import MagCalibration, MagCalibrationError, fit_quadric
    from hostlib.calibration.wiggle import MAX_FIT_HEADING_SIGMA_DEG, coverage_deg, fit_heading_sigma_deg

    from .navshoe import shoe_iron

    outdoors = replace(DEFAULT_CONFIG, mag=DEFAULT_CONFIG.mag.outdoors())
    field = earth_field_ned(outdoors)
    rows = []
    for tilt in TILTS_DEG:
        source = make_source(_TILT_RECIPE.format(tilt=tilt), seed=seed, config=outdoors)
        wiggle, _ = _decode(_calibrating_capture(source))
        best = MagCalibration(source.magnetic.hard_iron, _best_symmetric(source.magnetic.soft_iron))
        true_iron = shoe_iron(source)
        row: dict[str, Any] = {"seed": seed, "tilt_deg": tilt, "readings": len(wiggle.readings),
                               "refused": wiggle.refusal or ""}
        try:
            fit = fit_quadric([r.field_board for r in wiggle.readings])
            cal = fit.calibration()
        except MagCalibrationError as exc:
            rows.append({**row, "coverage_deg": math.nan, "fit_heading_sigma_deg": math.nan,
                         "fit_error_deg": math.inf, "fit": str(exc), "ellipsoid_true_error_deg": math.inf,
                         "attitude_error_deg": math.inf, "attitude_scatter_deg": math.nan, "attitude": ""})
            continue
        try:
            fit_iron_rotation(cal, wiggle.readings, MAX_FIT_HEADING_SIGMA_DEG)
            attitude = "turned"
        except MagCalibrationError as exc:
            attitude = str(exc)
        rotation = fit_iron_rotation(cal, wiggle.readings, math.inf, max_scatter_deg=math.inf)
        alone, turned = (_worst_level_error_deg(c, true_iron, source.magnetic, field)
                         for c in (cal, cal.turned(rotation.rotation)))
        rows.append({**row, "coverage_deg": coverage_deg(cal, wiggle.readings),
                     "fit_heading_sigma_deg": fit_heading_sigma_deg(fit, cal, wiggle.readings),
                     "fit_error_deg": _worst_level_error_deg(cal, best, source.magnetic, field),
                     "fit": "ellipsoid", "ellipsoid_true_error_deg": alone, "attitude": attitude,
                     "attitude_scatter_deg": rotation.scatter_deg, "attitude_error_deg": turned})
    return rows


def _worst_level_error_deg(calibration: Any, against: Any, magnetic: Any, field: np.ndarray) -> float:
    """The worst difference [deg] of a level compass's heading with *calibration* and with
    *against*, over the headings of :data:`_LEVEL_HEADINGS_DEG`, in the Earth's *field* (NED) as
    *magnetic*'s shoe iron distorts it."""
    from hostlib.aids.compass import compass_heading, wrap_angle
    from hostlib.track.steps import rotation_z

    worst = 0.0
    for psi in np.radians(_LEVEL_HEADINGS_DEG):
        r = rotation_z(float(psi))
        m = magnetic.soft_iron @ (r.T @ field) + magnetic.hard_iron
        worst = max(worst, abs(wrap_angle(compass_heading(calibration.apply(m), r)
                                          - compass_heading(against.apply(m), r))))
    return math.degrees(worst)


def tilt_rows(seeds: Sequence[int], workers: int = 2, scheduler: str | None = None) -> list[dict[str, Any]]:
    """Every seed's rows of the tilt study (module docstring), seeds in order."""
    from lab.runner import seeded_rows

    return seeded_rows(tilt_run, seeds, workers, scheduler)


def summary_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per calibration: mean ± sd of the hard-iron error, the soft-iron residual, the rotation left
    and the compass's RMS on the walk (and its worst walk); the wiggle's figures and the attitude's
    fit's."""
    seeds = sorted({r["seed"] for r in rows})
    fitted = [r for r in rows if r["calibration"] == "fitted"]
    refused = [r for r in fitted if r["refused"]]
    out = [f"{SCENARIO}, {len(seeds)} modules: {np.mean([r['readings'] for r in fitted]):.0f} readings, "
           f"{np.mean([r['steps_calibrating'] for r in fitted]):.0f} steps until the first long one (the "
           f"longest before it {max(r['longest_wiggle_step_m'] for r in fitted):.2f} m), coverage "
           f"{np.mean([r['coverage_deg'] for r in fitted]):+.1f}°, fit σ "
           f"{np.mean([r['fit_heading_sigma_deg'] for r in fitted]):.2f}°; refused {len(refused)}"]
    turned = [r for r in fitted if not r["refused"] and not r["rotation_refused"]]
    if turned:
        def mean(key: str) -> float:
            return float(np.mean([r[key] for r in turned]))

        incl = np.array([r["inclination_deg"] for r in turned])
        out.append(f"with the attitude: {mean('still_readings'):.0f} readings held still, inclination "
                   f"{incl.mean():.2f} ± {incl.std():.2f}°, scattering "
                   f"{mean('inclination_scatter_deg'):.2f}° RMS; the rotation's 1σ about board x/y/z "
                   f"{mean('rotation_sigma_x_deg'):.3f}/"
                   f"{mean('rotation_sigma_y_deg'):.3f}/{mean('rotation_sigma_z_deg'):.3f}°, "
                   f"{mean('rotation_heading_sigma_deg'):.2f}° on a level compass; not turned "
                   f"{len(fitted) - len(refused) - len(turned)}")
    out.append(f"{'calibration':<14} {'hard iron [µT]':>15} {'soft iron resid.':>17} {'rot. left [°]':>16} "
               f"{'compass RMS [°]':>16} {'worst [°]':>10}")
    for name in CALIBRATIONS:
        sel = [r for r in rows if r["calibration"] == name and "compass_rms_deg" in r]
        if not sel:
            continue

        def ms(key: str, digits: int = 2, sel=sel) -> str:
            v = np.array([r[key] for r in sel])
            return f"{v.mean():.{digits}f} ± {v.std():.{digits}f}"

        worst = max(r["compass_rms_deg"] for r in sel)
        out.append(f"{name:<14} {ms('hard_iron_error_ut'):>15} {ms('soft_iron_residual', 4):>17} "
                   f"{ms('rotation_left_deg'):>16} {ms('compass_rms_deg'):>16} {worst:>10.2f}")
    return out


def tilt_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per tilt: the coverage, the fit's σ from its scatter and its own worst level-heading error
    (mean ± sd, worst) of the modules whose readings an ellipsoid fits; against the true iron, the
    fit's worst level-heading error alone and turned by the attitude (mean ± sd), and the
    inclination's scatter about the attitude's fit; how many fit no ellipsoid, how many the
    calibration refused, how many of the rest the attitude would not turn."""
    out = [f"wiggles of less tilt, {len({r['seed'] for r in rows})} modules: the fit's own worst "
           "level-heading error; against the true iron, the ellipsoid alone and turned by the attitude",
           f"{'tilt [°]':>8} {'coverage [°]':>14} {'fit σ [°]':>10} {'fit error [°]':>15} {'worst [°]':>10} "
           f"{'alone [°]':>15} {'turned [°]':>15} {'scatter [°]':>12} {'no fit':>7} {'refused':>8} "
           f"{'not turned':>11}"]
    for tilt in TILTS_DEG:
        sel = [r for r in rows if r["tilt_deg"] == tilt]
        fitted = [r for r in sel if math.isfinite(r["fit_error_deg"])]
        refused = f"{sum(bool(r['refused']) for r in sel)}/{len(sel)}"
        if not fitted:
            out.append(f"{tilt:8.0f} {'—':>14} {'—':>10} {'—':>15} {'—':>10} {'—':>15} {'—':>15} {'—':>12} "
                       f"{len(sel):7d} {refused:>8} {'—':>11}")
            continue

        def ms(key: str, fitted=fitted) -> str:
            v = np.array([r[key] for r in fitted])
            return f"{v.mean():7.2f} ± {v.std():5.2f}"

        cov = np.array([r["coverage_deg"] for r in fitted])
        err = np.array([r["fit_error_deg"] for r in fitted])
        sigma = np.mean([r["fit_heading_sigma_deg"] for r in fitted])
        scatter = np.mean([r["attitude_scatter_deg"] for r in fitted])
        not_turned = f"{sum(r['attitude'] != 'turned' for r in fitted)}/{len(fitted)}"
        out.append(f"{tilt:8.0f} {cov.mean():+7.1f} ± {cov.std():4.1f} {sigma:10.2f} {ms('fit_error_deg')} "
                   f"{err.max():10.2f} {ms('ellipsoid_true_error_deg')} {ms('attitude_error_deg')} "
                   f"{scatter:12.2f} {len(sel) - len(fitted):7d} {refused:>8} {not_turned:>11}")
    return out
