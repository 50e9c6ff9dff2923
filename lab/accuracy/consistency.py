"""Is the summed covariance honest? The normalised squared error of the end pose over many seeds.

The host weighs every step by the covariance dP the module sends with it (:mod:`hostlib.track.steps`),
and every aid trusts the track as much as that covariance says: it has to be honest. For each
scenario and seed a simulated module walks, the host sums its steps, and the end pose is compared
with the truth of the last stance in the module's start frame
(:func:`firmware_sim.app.runs.end_errors`'s frame). With ``e`` that error and ``P`` the covariance
the track ends with, the normalised estimation error squared (Bar-Shalom's NEES)::

    ε_h = e_hᵀ P_h⁻¹ e_h   (horizontal, 2 dof),   ε_z = e_z² / P_zz,   ε_χ = e_χ² / P_χχ   (1 dof each)

has mean = dof when ``P`` is the error's covariance. Over N seeds the mean of ε / dof is a
χ²(N·dof) / (N·dof) draw: :func:`nees_interval` gives its 95 % interval. The **σ ratio**
√(mean ε / dof) says by how much the covariance is off: above 1 the track is over-confident (its
1σ too small by that factor), below 1 pessimistic.

**The default host.** Each run is also replayed by the host as ``openshoe-host replay`` does by
default (:class:`hostlib.run.options.AidOptions` as it comes: one module without an aid holds the
module's errors at a MIMU22BT-class module's datasheet priors,
:data:`hostlib.fusion.module_errors.MIMU22BT`); its end covariance gives the ``host_`` columns, and
:func:`summary_lines` leads with its mean ε against the expected 2 (horizontal) and 1 (height,
heading), a factor of 2 either way allowed. The bytes are the fusion set-up's, whose steps carry
the module's time; plain 0x34 packets carry none, so a host given them cannot count the warm-up:
that host's NEES is the same priors without the warm-up (:func:`nees_with_module_errors`, the
warm-up's column of the Jacobian unused), shown beside it.

**Inflating on the host.** ``P`` is linear in the steps' dP (the summation starts from P = 0), so a
host that multiplied every dP by k² would end with k² P and the mean NEES divided by k². A constant
k for a module is only worth having if it holds across routes: :func:`summary_lines` estimates it
on the other scenarios (leave one scenario out: the geometric mean of their horizontal σ ratios)
and shows what it does to the one left out.

**The module's errors as states.** A systematic step-length scale s, climb c, turn scale k and
heading drift rate r (:mod:`hostlib.fusion.module_errors`) add σ_s² d dᵀ to the horizontal covariance
(d: the displacement from the start), σ_c² L² to the height's (L: the path walked) and
σ_k² Θ² + σ_r² T² to the heading's (Θ: the angle turned, T: the time walked, the steps' durations
on the module's clock summed), with what that heading does to the positions after; each run
carries the end pose's Jacobian J with respect to [s, c, k, r], so its covariance with priors Σ is
P + J Σ Jᵀ. The priors are estimated by the method of moments on the other modules — the model
says E[(e·d)²] = dᵀPd + σ_s²|d|⁴, E[e_z²] = P_zz + σ_c² L² and E[e_χ²] = P_χχ + σ_k² Θ² + σ_r² T²,
so :func:`module_error_priors` pools σ_s² = Σ((e·d)² − dᵀPd) / Σ|d|⁴ (over the runs that end away
from their start), σ_c² = Σ(e_z² − P_zz) L² / ΣL⁴ and σ_k², σ_r² as the least-squares fit of
e_χ² − P_χχ on Θ² (over the runs that turned; 0 on the others) and T² over every run, each clipped
at 0 (the other then fitted alone): straight walks, which turn no angle, teach the drift; loops
the turn scale beside it — and :func:`summary_lines` shows each module's NEES with priors
estimated on the other modules.

**The gyros' warm-up.** Each run's Jacobian has a fifth column, w's (:mod:`hostlib.fusion.module_errors`:
the warm-up ramp integrated over the steps since the last still reset). On walks whose stances
sway (the default; ``--no-stance-sway`` stills them), where ZARU no longer re-learns the bias every
stride, a second block
holds w at its sensors' prior (:data:`hostlib.fusion.module_errors.EMULATED_MODULE_SWAYING`, from the
gyros' temperature coefficient and the dies' warm-up; not estimated): its share J_w σ_w² J_wᵀ of
each run's covariance is taken as known, and s, c, k and r are estimated on top of it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from lab.runner import map_runs

if TYPE_CHECKING:
    from hostlib.fusion.module_errors import ModuleErrors

__all__ = ["SCENARIOS", "consistency_rows", "consistency_run", "module_error_priors", "nees_interval",
           "summary_lines"]

#: The routes of the consistency check: a straight, a rectangle with four turns, the default
#: route (two laps with stairs).
SCENARIOS = ("walk", "rectangle", "default")
#: The normal quantiles of a two-sided 95 % interval.
_Z95 = 1.959963984540054
#: The routes the module's error priors are estimated on; the default route is held out, a check of
#: them on a route they were not estimated on (docs/accuracy.md).
PRIOR_SCENARIOS = ("walk", "rectangle")
#: A run teaches the step-length scale only if it ends this far from its start [m]: on a closed
#: loop the scale error cancels, and (e·d)² is then the noise of a tiny number.
SCALE_MIN_DISPLACEMENT_M = 10.0
#: … and the turn scale only if it turned this much in all [rad] (a straight walk's few degrees of
#: net turn are noise against its heading error).
TURN_MIN_RAD = math.pi / 2
#: The dimensions of the NEES: horizontal position, height, heading.
DOF = {"h": 2, "z": 1, "chi": 1}
#: The module's errors, the columns of a run's Jacobian (``j_<row><column>``): step-length scale,
#: climb, turn scale, heading drift rate, the gyros' warm-up (a row without the last ones is a run
#: that drifted by nothing).
_ERRORS = "sckrw"


def nees_interval(seeds: int, dof: int, z: float = _Z95) -> tuple[float, float]:
    """The 95 % interval of mean(ε)/dof over *seeds* draws of a consistent filter's NEES of *dof*
    dimensions: χ²(k)/k with k = seeds·dof, by the Wilson–Hilferty cube-root normal approximation
    (within 1 % of the exact quantiles from k = 10)."""
    k = seeds * dof
    c = 2.0 / (9.0 * k)
    return tuple((1.0 - c + s * z * math.sqrt(c)) ** 3 for s in (-1.0, 1.0))  # type: ignore[return-value]


def consistency_run(job: tuple[str, int] | tuple[str, int, bool | None]) -> dict[str, Any]:
    """One walk: *job* = (scenario, seed[, stance sway]; the sway as ``make_source``'s, None: the
    simulation's default). Its end errors, their 1σ and NEES."""
    from firmware_sim.sensors.imu_array import make_source
    from hostlib.files.replay import replay_bytes, replay_session
    from hostlib.fusion.module_errors import EMULATED_MODULE_SWAYING, ModuleErrors
    from hostlib.fusion.tracker import FusionSettings, FusionTracker
    from hostlib.run.aid_setup import prepare_aids
    from hostlib.run.options import AidOptions

    from .runs import fusion_capture

    scenario, seed, *sway = job
    source = make_source(scenario, seed=seed, stance_sway=sway[0] if sway else None)
    # the fusion set-up's bytes: the same steps as the plain one's, each with its module time
    data = fusion_capture(source)
    track, _ = replay_bytes(data)  # the plain step sum: the steps' own dP
    host = replay_session(data, tracker=prepare_aids(AidOptions()).tracker).tracker.track  # the default host
    # the end pose's Jacobian with respect to the module's errors: their cross-covariance with the
    # pose when held with unit priors (the estimate does not move without an aid; the warm-up's
    # with the emulated module's time constant)
    unit = FusionTracker(FusionSettings(module_errors=ModuleErrors(1.0, 1.0, 1.0, 1.0, 1.0,
                                                                   EMULATED_MODULE_SWAYING.warmup_tau_s)))
    jacobian = replay_session(data, tracker=unit).tracker.state_covariance[:4, 4:4 + len(_ERRORS)]
    truth = source.truth
    e = track.final_pose[:3] - truth.stances_in_start_frame()[-1]
    e_chi = math.remainder(float(track.final_pose[3]) - truth.heading_change(), 2.0 * math.pi)
    if not np.array_equal(host.final_pose, track.final_pose):
        raise AssertionError(f"{scenario} seed {seed}: the default host moved the track without an aid")
    p = track.final_covariance
    sigma = np.sqrt(np.diagonal(p))
    host_sigma = np.sqrt(np.diagonal(host.final_covariance))
    d = track.final_pose[:2] - track.poses[0][:2]
    return {"scenario": scenario, "seed": seed, "stance_sway": source.trajectory.stance_sway is not None,
            "steps": track.motion_steps, "distance_m": track.distance,
            "d_north_m": float(d[0]), "d_east_m": float(d[1]),
            "p_nn": float(p[0, 0]), "p_ne": float(p[0, 1]), "p_ee": float(p[1, 1]), "p_zz": float(p[2, 2]),
            "p_chichi": float(p[3, 3]),
            **{f"j_{r}{c}": float(jacobian[i, k])
               for i, r in enumerate("nezh") for k, c in enumerate(_ERRORS)},
            "e_north_m": float(e[0]), "e_east_m": float(e[1]), "e_down_m": float(e[2]),
            "e_heading_deg": math.degrees(e_chi),
            "sigma_north_m": float(sigma[0]), "sigma_east_m": float(sigma[1]),
            "sigma_down_m": float(sigma[2]), "sigma_heading_deg": math.degrees(float(sigma[3])),
            **_nees(e, e_chi, p),
            "host_sigma_north_m": float(host_sigma[0]), "host_sigma_east_m": float(host_sigma[1]),
            "host_sigma_down_m": float(host_sigma[2]),
            "host_sigma_heading_deg": math.degrees(float(host_sigma[3])),
            **{f"host_{key}": v for key, v in _nees(e, e_chi, host.final_covariance).items()}}


def _nees(e: np.ndarray, e_chi: float, p: np.ndarray) -> dict[str, float]:
    """The horizontal, height and heading NEES of the end error *e* (n, e, d) and *e_chi* against
    the end covariance *p* (4×4)."""
    return {"nees_h": float(e[:2] @ np.linalg.solve(p[:2, :2], e[:2])),
            "nees_z": float(e[2] ** 2 / p[2, 2]), "nees_chi": e_chi ** 2 / float(p[3, 3])}


def consistency_rows(seeds: Sequence[int], workers: int = 2, scenarios: Sequence[str] = SCENARIOS,
                     stance_sway: bool | None = None, scheduler: str | None = None) -> list[dict[str, Any]]:
    """Every scenario × seed, in that order (*stance_sway* as in :func:`consistency_run`;
    :func:`lab.runner.map_runs`)."""
    jobs = [(s, seed, stance_sway) for s in scenarios for seed in seeds]
    return map_runs(consistency_run, jobs, workers, scheduler)


def sigma_ratio(rows: Sequence[dict[str, Any]], what: str) -> float:
    """√(mean NEES / dof) of *rows* for *what* ("h", "z" or "chi")."""
    return math.sqrt(float(np.mean([r[f"nees_{what}"] for r in rows])) / DOF[what])


def module_error_priors(rows: Sequence[dict[str, Any]], warmup: ModuleErrors | None = None) -> ModuleErrors:
    """The step-length scale's, climb's, turn scale's and heading drift rate's 1σ estimated from
    *rows*' end errors (module docstring). With *warmup* (a module whose warm-up prior is known,
    from its sensors' physics), the warm-up is held at that prior: what it adds to each run's
    covariance is taken as known beside the steps' own, and the four are estimated on top."""
    from hostlib.fusion.module_errors import ModuleErrors

    num = np.zeros(2)
    den = np.zeros(2)
    heading, regressors = [], []  # e_χ² − P_χχ against [Θ², T²]
    sigma_w = warmup.heading_warmup_sigma if warmup is not None else 0.0
    for r in rows:
        d, e = _displacement(r), np.array([r["e_north_m"], r["e_east_m"]])
        p = _known_covariance(r, sigma_w)
        if float(np.hypot(*d)) >= SCALE_MIN_DISPLACEMENT_M:
            num[0] += float(e @ d) ** 2 - float(d @ p[:2, :2] @ d)
            den[0] += float(d @ d) ** 2
        length = r["distance_m"]
        num[1] += (r["e_down_m"] ** 2 - p[2, 2]) * length ** 2
        den[1] += length ** 4
        turned = r["j_hk"] if abs(r["j_hk"]) >= TURN_MIN_RAD else 0.0
        heading.append(math.radians(r["e_heading_deg"]) ** 2 - p[3, 3])
        regressors.append((turned ** 2, r.get("j_hr", 0.0) ** 2))
    sigmas = [math.sqrt(max(n / m, 0.0)) if m > 0 else 0.0 for n, m in zip(num, den, strict=True)]
    turn, drift = _non_negative_fit(np.array(regressors).reshape(-1, 2), np.array(heading))
    return ModuleErrors(*sigmas, math.sqrt(turn), math.sqrt(drift),
                        *((sigma_w, warmup.warmup_tau_s) if warmup is not None else ()))


def _known_covariance(r: dict[str, Any], warmup_sigma: float) -> np.ndarray:
    """Run *r*'s end covariance of [n, e, z, χ] (4×4; only the horizontal block, P_zz and P_χχ are
    kept in a row) with the warm-up held at the prior *warmup_sigma* beside the steps' own."""
    p = np.zeros((4, 4))
    p[:2, :2] = _horizontal_p(r)
    p[2, 2], p[3, 3] = r["p_zz"], r["p_chichi"]
    j_w = _jacobian(r)[:, _ERRORS.index("w")]
    return p + warmup_sigma ** 2 * np.outer(j_w, j_w)


def _non_negative_fit(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """The least-squares [a, b] ≥ 0 of y ≈ a x₀ + b x₁ (no intercept): both together if both come
    out ≥ 0, else the better of each alone (clipped at 0), the other 0; a column of zeros is 0."""
    def alone(i: int) -> float:
        den = float(x[:, i] @ x[:, i])
        return max(float(x[:, i] @ y) / den, 0.0) if den > 0 else 0.0

    gram = x.T @ x
    if np.linalg.matrix_rank(gram) == 2:
        both = np.linalg.solve(gram, x.T @ y)
        if np.all(both >= 0.0):
            return float(both[0]), float(both[1])
    fits = [(alone(0), 0.0), (0.0, alone(1))]
    return min(fits, key=lambda ab: float(np.sum((y - x @ np.array(ab)) ** 2)))


def _priors_without(rows: Sequence[dict[str, Any]], seed: int, warmup: ModuleErrors | None = None
                    ) -> ModuleErrors:
    """The priors estimated on every module of *rows* but *seed*'s (leave one module out; *warmup*
    as in :func:`module_error_priors`)."""
    return module_error_priors([r for r in rows if r["seed"] != seed], warmup)


def _displacement(r: dict[str, Any]) -> np.ndarray:
    return np.array([r["d_north_m"], r["d_east_m"]])


def _horizontal_p(r: dict[str, Any]) -> np.ndarray:
    return np.array([[r["p_nn"], r["p_ne"]], [r["p_ne"], r["p_ee"]]])


def _jacobian(r: dict[str, Any]) -> np.ndarray:
    """∂(end pose)/∂[s, c, k, r, w] (4×5) of run *r* (a run without the drift's or the warm-up's
    column: 0)."""
    return np.array([[r.get(f"j_{row}{col}", 0.0) for col in _ERRORS] for row in "nezh"])


def _prior(errors: ModuleErrors) -> np.ndarray:
    """The 5×5 prior covariance of [s, c, k, r, w] (r's and w's 0 when not held)."""
    return np.diag(np.square([errors.step_scale_sigma, errors.climb_sigma, errors.turn_scale_sigma,
                              errors.heading_drift_sigma, errors.heading_warmup_sigma]))


def nees_with_module_errors(r: dict[str, Any], errors: ModuleErrors) -> tuple[float, float, float]:
    """The horizontal, height and heading NEES of run *r* against its covariance with the module's
    errors held at the priors *errors* (the estimate does not move without an aid)."""
    j = _jacobian(r)
    extra = j @ _prior(errors) @ j.T
    e = np.array([r["e_north_m"], r["e_east_m"]])
    p = _horizontal_p(r) + extra[:2, :2]
    e_chi = math.radians(r["e_heading_deg"])
    return (float(e @ np.linalg.solve(p, e)), r["e_down_m"] ** 2 / (r["p_zz"] + extra[2, 2]),
            e_chi ** 2 / (r["p_chichi"] + extra[3, 3]))


def summary_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per scenario: the mean NEES / dof of the horizontal position, the height and the heading
    against their 95 % interval, the σ ratios, and the horizontal one after a constant inflation
    estimated on the other scenarios."""
    scenarios = list(dict.fromkeys(r["scenario"] for r in rows))
    by = {s: [r for r in rows if r["scenario"] == s] for s in scenarios}
    n = min(len(v) for v in by.values())
    lines = _default_host_lines(by) + [
             f"the plain step sum (--no-module-errors: the steps' dP alone): mean NEES / dof over {n} seeds "
             "(consistent: 1, 95 % interval "
             + ", ".join(f"{w} [{lo:.2f}, {hi:.2f}]" for w, (lo, hi) in
                         (("2 dof", nees_interval(n, 2)), ("1 dof", nees_interval(n, 1)))) + ")",
             f"{'scenario':10s} {'steps':>6} {'m':>7}  {'horizontal':>10} {'height':>8} {'heading':>8}   "
             f"{'σ ratio: h / z / χ':>22}   {'h, inflated by the others':>26}"]
    for s in scenarios:
        group = by[s]
        ratios = [sigma_ratio(group, w) for w in DOF]
        others = [sigma_ratio(by[o], "h") for o in scenarios if o != s]
        k = math.exp(float(np.mean(np.log(others)))) if others else math.nan
        lines.append(f"{s:10s} {np.mean([r['steps'] for r in group]):6.0f} "
                     f"{np.mean([r['distance_m'] for r in group]):7.1f}  "
                     + " ".join(f"{ratio ** 2:{w}.2f}" for ratio, w in zip(ratios, (10, 8, 8), strict=True))
                     + f"   {ratios[0]:6.2f} / {ratios[1]:5.2f} / {ratios[2]:5.2f}   "
                     f"k {k:5.2f} → σ ratio {ratios[0] / k:5.2f}")
    lines.append("end error, mean ± sd over the seeds (start frame), against the 1σ the track ends with:")
    for s in scenarios:
        cells = []
        for key in ("north_m", "east_m", "down_m", "heading_deg"):
            e = np.array([r[f"e_{key}"] for r in by[s]])
            sigma = float(np.mean([r[f"sigma_{key}"] for r in by[s]]))
            axis, unit = key.split("_")
            cells.append(f"{axis} {e.mean():+.3f} ± {e.std():.3f} (1σ {sigma:.3f}) {unit}")
        lines.append(f"  {s:10s} " + " | ".join(cells))
    flat = [r for r in rows if r["scenario"] in PRIOR_SCENARIOS]
    if not flat:
        return lines
    lines += _held_lines(by, flat, None, "the module's step-length scale, climb, turn scale and heading "
                         "drift held as states")
    if any(r.get("stance_sway") for r in rows):
        from hostlib.fusion.module_errors import EMULATED_MODULE_SWAYING as swaying

        sigma_w = math.degrees(swaying.heading_warmup_sigma)
        lines += _held_lines(by, flat, swaying,
                             f"the gyros' warm-up held too, at its sensors' prior (σ_w {sigma_w:.3g} °/s, "
                             f"τ {swaying.warmup_tau_s:g} s; not estimated), and the four beside it")
    return lines


def _default_host_lines(by: dict[str, list[dict[str, Any]]]) -> list[str]:
    """Per route the default host's mean ε (module docstring) against the expected dof, on the fusion
    set-up's packets (the warm-up counted) and, from the same runs, on plain packets (it cannot be);
    nothing for rows without the host's columns."""
    from dataclasses import replace

    from hostlib.fusion.module_errors import MIMU22BT

    if not all("host_nees_h" in r for rows in by.values() for r in rows):
        return []
    untimed = replace(MIMU22BT, heading_warmup_sigma=0.0)
    n = min(len(v) for v in by.values())
    lines = [f"the default host (the module's errors held at mimu22bt's priors): mean ε over {n} seeds, "
             "expected 2 / 1 / 1 (h / z / χ), within a factor of 2 either way?",
             f"{'scenario':10s} {'fusion set-up (times): h / z / χ':>34}   "
             f"{'plain packets (no warm-up): h / z / χ':>40}"]
    for s, group in by.items():
        timed = [float(np.mean([r[f"host_nees_{w}"] for r in group])) for w in DOF]
        plain = np.mean([nees_with_module_errors(r, untimed) for r in group], axis=0)
        cells = []
        for means in (timed, plain):
            ok = all(0.5 <= m / DOF[w] <= 2.0 for m, w in zip(means, DOF, strict=True))
            cells.append(" / ".join(f"{m:5.2f}" for m in means) + ("  yes" if ok else "  NO "))
        lines.append(f"{s:10s} {cells[0]:>34}   {cells[1]:>40}")
    return lines


def _held_lines(by: dict[str, list[dict[str, Any]]], flat: Sequence[dict[str, Any]],
                warmup: ModuleErrors | None, what: str) -> list[str]:
    """Each route's σ ratios with *what*, the priors estimated on the other modules' *flat* runs
    (with the warm-up prior *warmup*: :func:`module_error_priors`), and the priors from them all."""
    lines = [f"with {what}, their priors estimated on the other modules' {' and '.join(PRIOR_SCENARIOS)} "
             "(σ ratio h / z / χ):"]
    for s, group in by.items():
        nees = np.array([nees_with_module_errors(r, _priors_without(flat, r["seed"], warmup)) for r in group])
        ratio_h, ratio_z, ratio_chi = (math.sqrt(nees[:, i].mean() / dof) for i, dof in enumerate((2, 1, 1)))
        lines.append(f"  {s:10s} σ ratio {ratio_h:5.2f} / {ratio_z:5.2f} / {ratio_chi:5.2f}")
    errors = module_error_priors(flat, warmup)
    lines.append(f"priors from every module's {' and '.join(PRIOR_SCENARIOS)}: "
                 f"σ_s {errors.step_scale_sigma:.5f}, σ_c {errors.climb_sigma:.5f} m/m, "
                 f"σ_k {errors.turn_scale_sigma:.5f}, σ_r {errors.heading_drift_sigma:.3g} rad/s "
                 f"({math.degrees(errors.heading_drift_sigma) * 3600.0:.2f} °/h)")
    return lines
