"""A module's systematic step errors as states of the host's filter: step length, climb, turns and drift.

The covariance dP a module sends with each step describes that step's own noise, and summing the
steps adds those covariances: the track's 1σ grows with the square root of the steps. One module's
errors are partly *systematic*, the same on every step of a walk: its steps are all a little too
long or too short (accelerometer scale, the detector's timing), and it sinks or climbs a little
per metre (the mechanization's skew, g-sensitivity), and it turns a little too much or too little
(the gyros' scale), and its heading drifts at a rate of its own (what its INS lets through of the
vertical gyro's bias, and of the gyros' sensitivity to the swing's acceleration). Such an error
grows with the distance, the angle turned or the time walked itself, so no per-step covariance
describes it: the summed covariance is over-confident along the track, in height and in heading
(docs/accuracy.md, "Is the summed covariance honest?").

:class:`ModuleErrors` models them as three or four more states of the host's filter
(:class:`hostlib.fusion.tracker.FusionTracker`; with a module on each foot,
:class:`hostlib.fusion.feet.TwoFeetTracker`
holds each module's own), constant over a walk, zero-mean, with priors:

* the **step-length scale** s: each step's horizontal displacement, turned into the navigation
  frame, is ``(1 + s) R(χ) dp_h``;
* the **climb** c [m per metre walked]: each step's height change is ``dz + c |dp_h|``;
* the **turn scale** k: each step's heading change is ``(1 + k) dψ``;
* the **heading drift rate** r [rad/s], held only with a prior above 0
  (:attr:`ModuleErrors.heading_drift_sigma`): each step's heading change is
  ``(1 + k) dψ + r Δt``, Δt the step's duration on the module's clock (the time since the step
  before). The module's INS integrates its gyros the whole step, and a ZUPT observes velocity,
  not heading: what is left of the vertical rate's bias turns the heading wherever the foot is
  not really still. While it is (ZARU) the module drops the vertical rate and re-learns the
  bias, so a reset while the wearer stands still (a step that did not move the foot) drifts by
  nothing: its Δt is 0 (:func:`step_duration`). A real foot's walking stances are never that
  still (on the shared walks ZARU holds in none), so there the bias turns the heading through
  swing and stance alike; the emulated module's simulated stances are, and ZARU re-learns the
  bias in each, so its drift is mostly the gyros' g-sensitivity in the swing (docs/accuracy.md):
  Δt, the whole step, stands for the swing, a steady share of it.
* the **warm-up** w [rad/s], held only with a prior above 0
  (:attr:`ModuleErrors.heading_warmup_sigma`): how far the vertical rate's bias moves while the
  module's dies warm up (the gyros' offset temperature coefficient times the warm-up), a ramp
  ``1 − e^(−t/τ)`` with the warm-up's time constant τ (:attr:`ModuleErrors.warmup_tau_s`). What the
  module learned of the bias while it last stood still (ZARU) it removes; what the dies' warming
  has added since, it integrates: each step's heading change gains ``w W``, W the ramp's integral
  over the step less its value where the module last stood (:class:`DriftClock`). Time is counted
  from the first step the host sees, so w is the part of the warm-up still to come then (a module
  switched on long before has less of it left). On a real foot's walking stance, where ZARU never
  holds (:class:`firmware_sim.sensors.stance_sway.StanceSway`), this, not a constant rate, is how the
  heading drifts: it grows with T − τ(1 − e^(−T/τ)), slowly at first (docs/accuracy.md).

Without an aid the estimate does not change (the states stay 0) but the covariance grows by
σ_s² d dᵀ horizontally (d: the displacement from the start), σ_c² L² in height (L: the path
walked) and σ_k² Θ² + σ_r² T² in heading (Θ: the angle turned, T: the time walked), with what the
heading's does to the positions after: a straight walk's along-track uncertainty grows with its
length, a closed loop's does not. An aid makes them observable (GPS the scale, the compass the
turns and the drift), and the steps after are corrected by the learned values.

:data:`MIMU22BT` holds the priors of a MIMU22BT-class module worked out from the MPU9150's datasheet
and the physics of the four-die array, without looking at any walk: the host's default, with an aid or
without (:class:`hostlib.run.options.AidOptions`). :data:`EMULATED_MODULE` and
:data:`EMULATED_MODULE_SWAYING` hold the emulated MIMU22BT's, estimated from simulated modules' end
errors (``python -m lab.accuracy consistency``, the method-of-moments estimate below), for
experiments on the emulator; another module has its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..track.steps import is_motion_step

__all__ = ["DRIFT_STATE", "EMULATED_MODULE", "EMULATED_MODULE_SWAYING", "ERROR_STATES", "MIMU22BT", "PRESETS",
           "DriftClock", "DriftSpan", "ModuleErrors", "error_jacobian", "preset_name", "step_duration",
           "through_step"]

#: The states every :class:`ModuleErrors` adds: s, c, k (:attr:`ModuleErrors.states`: one more, r,
#: with a heading drift prior above 0, and one more, w, last, with a warm-up prior above 0).
ERROR_STATES = 3
#: Where the heading drift rate r sits among the module's errors, when held: after s, c, k.
DRIFT_STATE = 3


@dataclass(frozen=True)
class ModuleErrors:
    """Priors (1σ) of a module's step-length scale, climb, turn scale and heading drift rate,
    constant over a walk."""

    #: 1σ of the step-length scale s (a fraction: 0.001 is 1 mm per metre)
    step_scale_sigma: float
    #: 1σ of the climb c [m of height per metre walked horizontally]
    climb_sigma: float
    #: 1σ of the turn scale k (a fraction: 0.01 is 3.6° per full turn)
    turn_scale_sigma: float = 0.0
    #: 1σ of the heading drift rate r [rad/s] (0: not held, the filter the three states make; 1e-5
    #: is about 2 °/h)
    heading_drift_sigma: float = 0.0
    #: 1σ of the warm-up w [rad/s]: the settled change of the vertical rate's bias as the dies warm
    #: up (0: not held)
    heading_warmup_sigma: float = 0.0
    #: the warm-up's time constant τ [s]
    warmup_tau_s: float = 120.0

    def __post_init__(self) -> None:
        for name in ("step_scale_sigma", "climb_sigma", "turn_scale_sigma", "heading_drift_sigma",
                     "heading_warmup_sigma"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be a finite number ≥ 0, got {value}")
        if not (math.isfinite(self.warmup_tau_s) and self.warmup_tau_s > 0.0):
            raise ValueError(f"warmup_tau_s must be a finite number > 0, got {self.warmup_tau_s}")

    @property
    def holds_drift(self) -> bool:
        """Whether the heading drift rate r is a state (its prior above 0)."""
        return self.heading_drift_sigma > 0.0

    @property
    def holds_warmup(self) -> bool:
        """Whether the warm-up w is a state (its prior above 0)."""
        return self.heading_warmup_sigma > 0.0

    @property
    def states(self) -> int:
        """How many states these errors add: s, c, k, with a drift prior r, with a warm-up prior w."""
        return ERROR_STATES + self.holds_drift + self.holds_warmup

    @property
    def prior(self) -> np.ndarray:
        """The prior covariance of [s, c, k] (3×3), with [r] and [w] after them where held."""
        sigmas = [self.step_scale_sigma, self.climb_sigma, self.turn_scale_sigma]
        if self.holds_drift:
            sigmas.append(self.heading_drift_sigma)
        if self.holds_warmup:
            sigmas.append(self.heading_warmup_sigma)
        return np.diag([sigma ** 2 for sigma in sigmas])

    @classmethod
    def parse(cls, text: str) -> ModuleErrors:
        """The priors a word or a list of numbers names: 'mimu22bt' (a MIMU22BT-class module, from its
        datasheet: :data:`MIMU22BT`), 'emulated' or 'emulated-sway' (the emulated module as it walks by
        default, on swaying stances: :data:`EMULATED_MODULE_SWAYING`), 'emulated-still' (on still
        stances: :data:`EMULATED_MODULE`), or
        ``SCALE,CLIMB[,TURN[,DRIFT_DEG_PER_H[,WARMUP_DEG_PER_S[,TAU_S]]]]``: numbers ≥ 0 and τ > 0, the
        heading drift rate's 1σ in °/h and the warm-up's in °/s (held as rad/s). A ValueError says
        what is expected otherwise."""
        word = text.strip().lower()
        if word in PRESETS:
            return PRESETS[word]
        try:
            sigmas = [float(v) for v in text.split(",")]
            if not 2 <= len(sigmas) <= 6:
                raise ValueError(f"{len(sigmas)} numbers")
            if len(sigmas) >= 4:
                sigmas[3] = math.radians(sigmas[3]) / 3600.0  # °/h → rad/s
            if len(sigmas) >= 5:
                sigmas[4] = math.radians(sigmas[4])  # °/s → rad/s
            return cls(*sigmas)
        except ValueError:
            raise ValueError(
                f"expected SCALE,CLIMB[,TURN[,DRIFT_DEG_PER_H[,WARMUP_DEG_PER_S[,TAU_S]]]] (1σ, numbers ≥ 0, "
                f"τ > 0, e.g. 0.001,0.0017,0.01,20,0.05,120), 'mimu22bt', 'emulated', 'emulated-sway' or "
                f"'emulated-still', got {text!r}") from None

    def clock(self) -> DriftClock:
        """A new :class:`DriftClock` for one module's steps, with this warm-up's τ."""
        return DriftClock(self.warmup_tau_s)

    def jacobian(self, chi: float, dx: np.ndarray, span: DriftSpan) -> np.ndarray:
        """∂pose/∂errors (4 × :attr:`states`) of one step *dx* taken at heading *chi*
        (:func:`error_jacobian`), the drift and the warm-up held over the step's *span*
        (:meth:`DriftClock.span`)."""
        return error_jacobian(chi, dx, span.duration_s if self.holds_drift else None,
                              span.warmup_s if self.holds_warmup else None)


@dataclass(frozen=True)
class DriftSpan:
    """What one step turned the heading over, per unit of the drift rate r and of the warm-up w."""

    duration_s: float  #: Δt [s] (:func:`step_duration`)
    warmup_s: float  #: W [s]: the warm-up's ramp integrated over the step, as far as ZARU left it


class DriftClock:
    """One module's step times as its heading drift sees them: the step before's, where the first
    step was (the warm-up's t = 0) and where the module last stood still.

    The module's BIASEST re-learns the vertical rate's bias while ZARU holds (a foot standing still:
    a reset that did not move it), so after it the warm-up's ramp turns the heading by what it has
    risen *since*: at time t (from the first step) the rate is ``w (e^(−t_s/τ) − e^(−t/τ))``, t_s
    the last still reset's (0 before any). A step from t₀ to t₁ integrates it to
    ``W = (t₁ − t₀) e^(−t_s/τ) − τ (e^(−t₀/τ) − e^(−t₁/τ))``, 0 for a still reset and where a time
    is unknown."""

    def __init__(self, tau_s: float) -> None:
        self.tau_s = float(tau_s)
        self.origin_s = math.nan  #: module time of the first step with a time [s]
        self.previous_s = math.nan  #: module time of the step before [s]
        self.still_s = 0.0  #: when the module last stood still [s from the origin]

    def span(self, dx: np.ndarray, time_s: float) -> DriftSpan:
        """The span of a step *dx* that ended at module time *time_s* [s] (NaN: unknown), and the
        clock moved on to it."""
        dt = step_duration(dx, time_s, self.previous_s)
        warmup = 0.0
        if math.isfinite(time_s):
            if not math.isfinite(self.origin_s):
                self.origin_s = time_s
            t1 = time_s - self.origin_s
            if dt > 0.0:
                t0, tau = t1 - dt, self.tau_s
                warmup = (dt * math.exp(-self.still_s / tau)
                          - tau * (math.exp(-t0 / tau) - math.exp(-t1 / tau)))
            elif not is_motion_step(dx):
                self.still_s = t1
        self.previous_s = time_s
        return DriftSpan(dt, warmup)

    def lose_previous(self) -> None:
        """Packets were lost: the next step's duration is unknown (its span 0)."""
        self.previous_s = math.nan


def step_duration(dx: np.ndarray, time_s: float, previous_time_s: float) -> float:
    """The Δt [s] over which a step *dx* drifted in heading: the module time *time_s* of its end
    less *previous_time_s*, the step before's; 0 for a reset while the wearer stands still (the
    module's ZARU holds the heading of a still foot) and where either time is unknown (NaN: a
    packet without its time, or the first step)."""
    dt = time_s - previous_time_s
    if not math.isfinite(dt) or dt <= 0.0 or not is_motion_step(dx):
        return 0.0
    return dt


def error_jacobian(chi: float, dx: np.ndarray, dt: float | None = None, warmup: float | None = None
                   ) -> np.ndarray:
    """∂pose/∂[s, c, k] (4×3) of one step *dx* (its [dx, dy, dz, dψ]) taken at heading *chi*: the
    step's horizontal displacement in the navigation frame, its horizontal length in height, and
    its heading change in heading. With *dt* (the step's duration, :func:`step_duration`),
    ∂pose/∂[s, c, k, r] (4×4): the drift rate turns the heading by Δt; with *warmup* (W,
    :class:`DriftClock`) one more column after them, the warm-up w's: it turns the heading by W."""
    c, s = math.cos(chi), math.sin(chi)
    j = np.zeros((4, ERROR_STATES + (dt is not None) + (warmup is not None)))
    j[0, 0] = c * dx[0] - s * dx[1]
    j[1, 0] = s * dx[0] + c * dx[1]
    j[2, 1] = math.hypot(dx[0], dx[1])
    j[3, 2] = dx[3]
    if dt is not None:
        j[3, DRIFT_STATE] = dt
    if warmup is not None:
        j[3, -1] = warmup
    return j


def through_step(pose: np.ndarray, cov: np.ndarray, cross: np.ndarray, f: np.ndarray, j: np.ndarray,
                 errors: np.ndarray, errors_cov: np.ndarray, columns: slice
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One pose of a filter's state through a step with its module's errors held, beside the rest
    of the state, which the step does not change: the pose *pose* and its 4×4 covariance *cov*
    after the summation map (:func:`hostlib.track.steps.propagate`: the step's own dP is in), *cross*
    (4, m) its covariance with the rest before the step, *f* the step's Jacobian F, *j* its
    :func:`error_jacobian` J, *errors* (k,) the module's errors' estimate, *errors_cov* (k, m) their
    covariance with the rest, and *columns* where those errors [s, c, k, [r], [w]] sit in the rest.
    Returns the pose, its covariance and its covariance with the rest after the step.

    With A the (4, m) J in those columns, the pose moves by J e (e the errors' estimate: nothing
    while it is 0), its covariance gains F C Aᵀ + A Cᵀ Fᵀ + A R Aᵀ (C: *cross*, R: the rest's
    covariance, of which A reads only the errors' rows, *errors_cov*) and cross ← F C + A R (without
    the errors it would be F C: the rest does not move the pose). One foot's
    :class:`hostlib.fusion.tracker.FusionTracker` (the rest: its errors, then the aid states) and
    each foot of :class:`hostlib.fusion.feet.TwoFeetTracker` (the rest: the other foot, both modules'
    errors and the aid states) step through it."""
    if np.any(errors != 0.0):
        pose = pose + j @ errors
    c = f @ (cross[:, columns] @ j.T)  # F C Aᵀ
    ar = j @ errors_cov  # A R
    p = cov + c + c.T + ar[:, columns] @ j.T
    return pose, 0.5 * (p + p.T), f @ cross + ar


#: The emulated MIMU22BT's priors: the method-of-moments estimate on 20 simulated modules each of
#: the straight walk and the rectangle (the default route held out, a check of them:
#: docs/accuracy.md), σ² = Σ(e² − P) / Σ d² pooled over the walks, e the end
#: error along the displacement (scale), in height (climb) or in heading, P its summed 1σ² and d the
#: displacement, path, or (for the heading, fitted together) the angle turned and the time walked:
#: the rectangle's full turn teaches the turn scale, the straight walks' 67 s the drift rate
#: (3.2e-5 rad/s, 6.6 °/h) (``python -m lab.accuracy consistency`` prints them).
EMULATED_MODULE = ModuleErrors(step_scale_sigma=0.00102, climb_sigma=0.00168, turn_scale_sigma=0.00079,
                               heading_drift_sigma=3.2e-5)

#: The emulated MIMU22BT on a real foot's walking stance
#: (:class:`firmware_sim.sensors.stance_sway.StanceSway`),
#: where ZARU never holds while walking and the dies' warm-up turns the heading. The warm-up w is
#: not estimated but follows from the sensors' physics (docs/sensor-errors.md): each MPU9150's gyro
#: offset moves by up to ±0.02 °/s per °C on each axis (uniform: 1σ 0.02/√3), the module averages
#: four dies (÷√4), and they warm by 8 °C with τ 120 s after power-on, so the vertical rate's bias
#: settles 0.02/√3/2 × 8 = 0.046 °/s (8.06e-4 rad/s, 1σ) away from where it started. Beside it,
#: the step-length scale, climb and turn scale are estimated as for :data:`EMULATED_MODULE`, on
#: swaying modules (``python -m lab.accuracy consistency --stance-sway``, 20 modules' walk and
#: rectangle): σ_s 0.00108, σ_c 0.00173 m/m, σ_k 0.00042; the constant drift rate's estimate is 0
#: (the warm-up leaves it nothing), so it is not held.
EMULATED_MODULE_SWAYING = ModuleErrors(step_scale_sigma=0.00108, climb_sigma=0.00173,
                                       turn_scale_sigma=0.00042, heading_warmup_sigma=8.06e-4,
                                       warmup_tau_s=120.0)

#: A MIMU22BT-class module (four MPU9150 averaged, factory-calibrated), its priors from the datasheet
#: and physics alone (shared/spec/sensors.md, docs/sensor-errors.md), never fitted to a walk:
#:
#: * **step-length scale** σ_s 0.0013: a step's length is the twice-integrated specific force, so its
#:   scale is the accelerometers'. The MPU9150's sensitivity tolerance is ±3 % (datasheet); a
#:   six-position factory calibration leaves a few tenths of a percent of it, ±0.45 % (15 % of the
#:   tolerance). Uniform, that is 0.45 %/√3 = 0.26 % per die, and the module averages four
#:   independent dies: 0.26 %/√4 = 0.13 %.
#: * **turn scale** σ_k 0.0013: a step's heading change is the vertical gyro's integral, its scale
#:   the gyros' sensitivity, with the same ±3 % tolerance and the same calibration: 0.13 %.
#: * **climb** σ_c 0.002 m/m: a step's height error per metre is a tilt of its integrated
#:   displacement, what the accelerometers' cross-axis residual (±2 % uncalibrated, ±0.3 % left)
#:   and the dies' misalignment (±0.1°) leave after the four dies are averaged: about 0.001 m/m. The
#:   module paper's fifty 100 m walks with real modules end with systematic height errors up to
#:   0.5 % (shared/spec/sensors.md), the largest of fifty draws about 2.3σ: 0.002 m/m. The prior
#:   takes the paper's, the larger, since a real foot adds what no datasheet holds (the sole's
#:   flex, the mounting).
#: * **warm-up** σ_w 8.06e-4 rad/s, τ 120 s: the gyros' zero-rate offset moves with temperature,
#:   typically ±0.02 °/s per °C (the datasheet bounds ±20 °/s over −40…85 °C), and the dies warm by
#:   about 8 °C after power-on (their own heat and the foot's), with a time constant of about two
#:   minutes. Uniform, 0.02/√3 °/s/°C per die, over four dies ÷√4, times 8 °C: 0.046 °/s, the
#:   distance the vertical rate's bias settles from where the module learned it. On a real foot's
#:   walking stance the module's ZARU does not hold, so this, not a constant rate, turns the
#:   heading (the constant part is what the module learned while it stood at the start).
#: * the **heading drift rate** r is not held: what the module's bias estimate left of the
#:   vertical rate's bias at the start is learned again at every stand, and the part that changes
#:   while walking is the warm-up's.
MIMU22BT = ModuleErrors(step_scale_sigma=0.0013, climb_sigma=0.002, turn_scale_sigma=0.0013,
                        heading_warmup_sigma=8.06e-4, warmup_tau_s=120.0)

#: The presets' words (:meth:`ModuleErrors.parse`).
PRESETS = {"mimu22bt": MIMU22BT, "emulated": EMULATED_MODULE_SWAYING,
           "emulated-sway": EMULATED_MODULE_SWAYING, "emulated-still": EMULATED_MODULE}


def preset_name(errors: ModuleErrors) -> str | None:
    """The word of the preset *errors* are (:data:`PRESETS`: 'mimu22bt', 'emulated', 'emulated-still'),
    or None for priors of one's own."""
    return next((word for word, preset in PRESETS.items() if preset == errors), None)
