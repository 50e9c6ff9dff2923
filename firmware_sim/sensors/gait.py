"""Foot motion with exact derivatives: stance, swing, and the routes built from them.

A foot trajectory is a chain of *segments*. A **stance** segment holds the
foot flat and still at one pose (where it rests on the ground; a walk may
give its walking stances a real foot's small zero-mean sway and sole
vibration, :class:`StanceSway`, :meth:`Trajectory.with_stance_sway` — on by
default, :data:`STANCE_SWAY_DEFAULT`); a **swing**
segment carries it from one stance pose to the next: lift-off with the toe
down (toe-off pitch), a clearance arc, heel-first landing (heel-strike pitch)
and an optional heel-strike impact. Every quantity of a swing is a polynomial
in the normalised time τ ∈ [0, 1] whose first five derivatives vanish at both
ends, so the whole trajectory is C⁵ in position and attitude: acceleration,
angular rate and angular acceleration are smooth and known analytically (and
a sampled-data integrator meets no kinks between the sample points).

* position: p = p_A + (p_B − p_A)·S(τ) − h·C(τ)·e_z + impact, with S the
  degree-13 smoothstep ∫τ⁵(1−τ)⁵(1 + 4(2τ−1)²) (normalised; its speed peaks at
  2.07 × the mean, its acceleration at 9.2 L/T²), C = (4τ(1−τ))⁶ (peak 1 at
  mid-swing, h = clearance; e_z points down in NED so −h lifts the foot);
* attitude (ZYX Euler: yaw ψ, pitch θ, roll φ; body → navigation R =
  Rz(ψ)Ry(θ)Rx(φ)): each angle goes from A to B by S(τ), and the pitch adds
  toe-off θ_toe·G₁(τ) + heel-strike θ_heel·G₂(τ), with G₁ ∝ τ⁶(1−τ)¹⁰ (peak
  at τ = 3/8) and G₂ ∝ τ¹⁰(1−τ)⁶ (peak at τ = 5/8), both normalised to peak 1;
  a swing that turns the sole and the toe on the way (stairs, side and back steps) adds
  φ_swing·G₁(τ) to the roll and ψ_swing·C(τ) to the yaw (every other swing
  has φ_swing = ψ_swing = 0 and is evaluated without them);
* impact: a short bump of width w ending just before touch-down,
  p += A·B(u)·d with B(u) = (4u(1−u))⁸, u = (t − t_i)/w, d = (k·cos ψ_B,
  k·sin ψ_B, 1); its peak acceleration is 64·A/w², upward (the sole stops the
  falling foot), and A is chosen from the requested peak in g.

Frames (firmware.md §4): navigation x north, y east, z down; gravity
g_n = (0, 0, +g); body = board frame (x forward, y right, z down). Outputs:
specific force f_b = Rᵀ(a − g_n) (at rest (0, 0, −g)), angular rate ω_b and
angular acceleration α_b from the Euler-angle rates. Evaluation is
vectorised over any array of times (:meth:`Trajectory.evaluate`).

:class:`GaitBuilder` composes motions — standing, straight and curved walks,
slopes and ramps walked at an angle to their fall line, stairs, turns on the
spot, side and back steps, running, and the wiggle of an in-situ magnetometer
calibration (:meth:`GaitBuilder.wiggle`) — from
:class:`GaitParams` (stride length, stance and swing time (so cadence and
speed), clearance, pitch profile, impact). Named scenarios live in
:mod:`firmware_sim.sensors.scenarios`.
"""

from __future__ import annotations

import copy
import math
import os
from dataclasses import dataclass, replace

import numpy as np
from numpy.polynomial import polynomial as P

from .truth import GroundTruth, Kinematics, euler_to_matrix

__all__ = ["GaitParams", "WALKING", "RUNNING", "STAIRS_UP", "STAIRS_DOWN", "SHUFFLE", "SHORT_STEPS", "WIGGLE",
           "StanceSway", "STANCE_SWAY", "STANCE_SWAY_DEFAULT", "STANCE_SWAY_ENV", "stance_sway_on", "Pose",
           "Swing", "GaitBuilder", "Trajectory", "flat_on", "ramp_normal"]

DEG = math.pi / 180.0
STANCE, SWING = 0, 1

# ---------------------------------------------------------------------------------------------
# basis polynomials (coefficients, lowest order first)


def _poly_from_roots(zero_order: int, one_order: int) -> np.ndarray:
    """Coefficients of τ^a (1−τ)^b."""
    return P.polymul(np.r_[np.zeros(zero_order), 1.0], P.polypow([1.0, -1.0], one_order))


def _normalised(c: np.ndarray) -> np.ndarray:
    tau = np.linspace(0.0, 1.0, 20001)
    return c / np.max(np.abs(P.polyval(tau, c)))


def _smoothstep(order: int, shoulder: float = 0.0) -> np.ndarray:
    """0 → 1 on [0, 1], first *order* derivatives zero at both ends: ∫ τ^k (1−τ)^k (1 + c(2τ−1)²).

    The shoulder term c flattens the speed profile (peak/mean speed 2.07 for
    k = 5, c = 4, against 2.71 for c = 0), closer to a real swing.
    """
    shape = [1.0 + shoulder, -4.0 * shoulder, 4.0 * shoulder]  # 1 + c(2τ−1)²
    c = P.polyint(P.polymul(_poly_from_roots(order, order), shape))
    return c / P.polyval(1.0, c)


def _max_abs(c: np.ndarray) -> float:
    return float(np.max(np.abs(P.polyval(np.linspace(0.0, 1.0, 20001), c))))


_S = _smoothstep(5, shoulder=4.0)  # degree 13: position and attitude C⁵ at the segment joints
_C = 4096.0 * _poly_from_roots(6, 6)  # clearance bump (4τ(1−τ))⁶, peak 1 at 1/2
_G1 = _normalised(_poly_from_roots(6, 10))  # toe-off pitch, peak at τ = 3/8
_G2 = _normalised(_poly_from_roots(10, 6))  # heel-strike pitch, peak at τ = 5/8
_IMPACT = 4.0**8 * _poly_from_roots(8, 8)  # impact bump (4u(1−u))⁸, C⁷ at its ends
_BUMP_PEAK_ACCEL = _max_abs(P.polyder(_IMPACT, 2))  # = 64, at u = 1/2


def _eval3(c: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Value, first and second derivative of the polynomial c at x."""
    c1 = P.polyder(c)
    return P.polyval(x, c), P.polyval(x, c1), P.polyval(x, P.polyder(c1))


# ---------------------------------------------------------------------------------------------
# parameters


@dataclass(frozen=True)
class GaitParams:
    """How one foot moves in one stride (stance then swing)."""

    # defaults: 5.4 km/h at 120 steps/min; peaks ≈ 7 g and 515 °/s (the shared 5–7 km/h
    # recordings peak at ≈ 5 g and 440 °/s behind their sensor's own filter)
    stride_length: float = 1.5  #: [m] from one rest of this foot to the next
    stance_s: float = 0.55  #: [s] foot flat and still
    swing_s: float = 0.45  #: [s] from lift-off to foot flat again
    clearance: float = 0.10  #: [m] lift at mid-swing, above the straight line from A to B
    toe_off_pitch_deg: float = -30.0  #: pitch peak early in the swing (negative: toe down)
    #: pitch peak late in the swing (positive: toe up, the heel lands first; negative: the forefoot does)
    heel_strike_pitch_deg: float = 18.0
    impact_g: float = 3.0  #: [g] peak acceleration of the heel-strike bump (0: none)
    impact_width_s: float = 0.03  #: [s] duration of the bump
    impact_forward: float = 0.3  #: forward share of the impact direction (1 = vertical)
    impact_end: float = 0.97  #: the bump ends at this fraction of the swing
    #: roll peak early in the swing (at τ = 3/8), flat again at landing (positive: right side down, a
    #: right foot's sole turned in; a walker's left foot mirrors it)
    swing_roll_deg: float = 0.0
    #: yaw peak in mid-swing (at τ = 1/2), back to the landing's heading at landing (positive: toe
    #: turned right, a right foot's toe out; a walker's left foot mirrors it)
    swing_yaw_deg: float = 0.0

    @property
    def stride_s(self) -> float:
        return self.stance_s + self.swing_s

    @property
    def cadence_steps_per_min(self) -> float:
        """Steps of both feet per minute."""
        return 120.0 / self.stride_s

    @property
    def speed(self) -> float:
        """Mean walking speed [m/s]."""
        return self.stride_length / self.stride_s

    def with_speed(self, speed: float, cadence_steps_per_min: float | None = None) -> GaitParams:
        """Same style at another speed: the stride length follows (and cadence if given)."""
        p = self
        if cadence_steps_per_min is not None:
            stride_s = 120.0 / cadence_steps_per_min
            p = replace(p, stance_s=stride_s - p.swing_s)
            if p.stance_s <= 0:
                raise ValueError("cadence too high for this swing time")
        return replace(p, stride_length=speed * p.stride_s)


WALKING = GaitParams()
RUNNING = GaitParams(
    stride_length=2.6, stance_s=0.2, swing_s=0.5, clearance=0.25, toe_off_pitch_deg=-45.0,
    heel_strike_pitch_deg=15.0, impact_g=20.0, impact_width_s=0.02,
)
#: Stair gait (two stairs a stride, :meth:`GaitBuilder.stairs`). On stairs the forefoot lands first,
#: whichever the direction (Riener, Rabuffetti & Frigo 2002, Gait Posture 15:32; McFadyen & Winter
#: 1988, J Biomech 21:733): the pitch late in the swing is toe down, not the heel strike's toe up.
#: The model's figures: climbing, the foot pushes off the lower tread 20° toe down and reaches the
#: upper one nearly flat (10° toe down); descending, it leaves the upper tread with a smaller
#: push-off (15°) and reaches down for the lower one toe first, 25° toe down, a little less than the
#: ankle's peak plantarflexion in stair descent (28° in a public dataset of 101 walkers on a 13-step
#: staircase, wearable sensors).
#: A real foot also rolls and turns out in the swing. Over the 152 straight swings of the shared
#: walks (a right shoe; tests/oracle/swing_rotation.py) the sole's roll away from the stance's
#: peaks at a median 7° (turned in) and the heading's at 11° (toe out); no stair recording is at
#: hand, so a stair swing has the flat walks' figures. With them the foot keeps rotating through
#: mid-swing as real feet do: its slowest |ω| in the middle 80 % of the swing is 14.8 °/s climbing
#: and 22.5 °/s descending, against 2.9 °/s for the slowest of the walks' 296 real swings and
#: 25 °/s for the median one. Without them a straight stair swing stopped rotating (roll and yaw
#: rates exactly 0) where the pitch turned, and the module's ZUPT detector took it for a stance.
STAIRS_UP = GaitParams(stride_length=0.56, stance_s=0.6, swing_s=0.5, clearance=0.12,
                       toe_off_pitch_deg=-20.0, heel_strike_pitch_deg=-10.0, impact_g=2.0,
                       swing_roll_deg=7.0, swing_yaw_deg=11.0)
#: The stair gait going down: toe-off and heel strike pitched the other way.
STAIRS_DOWN = replace(STAIRS_UP, toe_off_pitch_deg=-15.0, heel_strike_pitch_deg=-25.0)
SHUFFLE = GaitParams(stride_length=0.4, stance_s=0.5, swing_s=0.4, clearance=0.04,
                     toe_off_pitch_deg=-5.0, heel_strike_pitch_deg=3.0, impact_g=1.0)
#: Side and back steps (:meth:`GaitBuilder.side_steps`, :meth:`GaitBuilder.back_steps`): the shuffle's
#: short steps, and on the way the sole rolled in 7° and the toe turned out 11° as in a stair swing
#: (the shared walks' median straight swing; no recording of side or back steps is at hand). A side
#: step that only pitched stopped rotating at 38 % of its swing (|ω| 0.8 °/s, below the 2.9 °/s of
#: the slowest of the walks' 296 real swings) at 1.7 m/s, just as ‖f‖ passed g, and the module's
#: detector took it for a stance: 3.8 mm short and 0.8 mm low on every 0.35 m step.
SHORT_STEPS = replace(SHUFFLE, swing_roll_deg=STAIRS_UP.swing_roll_deg, swing_yaw_deg=STAIRS_UP.swing_yaw_deg)
#: The wiggle of an in-situ magnetometer calibration (:meth:`GaitBuilder.wiggle`): each turn of the
#: foot takes 0.8 s and is held still for 0.4 s — longer than the ZUPT detector's window and delay
#: (a few tens of ms), so every hold is a stance — with no lift, pitch profile or impact.
WIGGLE = GaitParams(stride_length=0.0, stance_s=0.4, swing_s=0.8, clearance=0.0, toe_off_pitch_deg=0.0,
                    heel_strike_pitch_deg=0.0, impact_g=0.0)
#: Where the module sits from the point the foot turns about (the ankle), in the board frame
#: (x forward, y right, z down) [m]: 5 cm ahead and 8 cm below it. Turning about the ankle moves
#: the module by at most twice this (19 cm) from one held orientation to the next.
WIGGLE_LEVER_M = (0.05, 0.0, 0.08)
#: The largest pitch or roll of a wiggle [deg]: the toe pointing straight down (the foot lifted
#: behind) or up, the sole turned to face sideways. An ellipsoid fit needs the field seen from
#: nearly every side: at the emulator's inclination (72.5°, Stockholm) tilts of at most 65° keep it
#: within 78° of the board's z axis, a cap on which the fit cannot pin the centre and extent along
#: that axis (the fit's own heading error 3.4° on level ground, and hostlib.calibration.wiggle refuses it);
#: 90° takes it to 102°, and the error to 0.1° (``python -m lab.accuracy magcal``, docs/heading-aids.md).
WIGGLE_TILT_DEG = 90.0
#: The golden angle [rad]: successive tilt directions of a wiggle never repeat and fill the circle
#: evenly.
_GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))


# ---------------------------------------------------------------------------------------------
# a walking stance's residual motion


@dataclass(frozen=True)
class StanceSway:
    """How a foot keeps moving a little while it stands on the ground between two swings.

    A real foot is never perfectly still in a walking stance: the shank rotates over it, the sole
    rolls from heel to toe and flexes, muscles tremble. Two zero-mean motions, new in every stance,
    each a sum of :attr:`components` sinusoids per axis of equal size and random phases, less its
    chord (the straight line between its values at the stance's ends) and tapered to 0 over
    :attr:`taper_s` at either end of the stance (C⁵ ramps: the swings and the stance's pose are
    unchanged, and the ramps add no jolt: |ω| is 3.3 °/s rms in a stance's first and last tenth,
    2.7–3.2 °/s in between):

    * the **sway**: a rotation of the foot about the module, added to the stance's attitude per
      axis of the board (x roll, y pitch, z yaw): rate rms :attr:`rate_rms_dps`, frequencies drawn
      from the one-sided spectrum S(f) ∝ exp(−(f − f_lo)/f_c) above f_lo (:attr:`lowest_hz`, f_c
      :attr:`corner_hz`);
    * the **sole's vibration**: a translation of the module along the foot's axes, acceleration rms
      :attr:`vibration_ms2`, frequencies drawn from a spectrum flat from f₁ to f₂ with
      :attr:`vibration_low_share` of its power and flat from f₂ to f₃ with the rest
      (:attr:`vibration_band_hz`) — micrometres and about a millimetre per second, so the module
      stays where the stance put it and the ZUPT's zero velocity holds to far within its σ_v
      (10 mm/s).

    The truth's attitude, angular rate and acceleration, position, velocity and acceleration, and
    so the specific force and the chips' lever-arm terms, all carry them. A stance of
    :attr:`longest_stance_s` or more is a stand and stays still (a standing walker's feet pass the
    module's ZARU test on the real walks).

    The figures are the six shared walks' (a 3DM-GX2 in the sole of a right shoe at 250 Hz: 318
    walking stances of the reference detector, median 0.26 s, in the foot's frame; ``python -m
    tests.oracle.stance_motion``). About each stance's mean the rate varies by 2.9, 2.2, 2.9 °/s rms
    (roll, pitch, yaw) where the standing walker's varies by 0.55, 0.46, 0.36 °/s (the sensor's
    noise): 2.9, 2.2, 2.9 °/s are motion. Its spectrum over the noise's (Hann-windowed stances)
    holds 2.0, 1.5, 1.5 °/s from 2 to 25 Hz at a mean frequency of 5.2, 5.0, 5.7 Hz, falling off as
    exp(−f/2.5 Hz) from 4 Hz to the noise's level at 20–25 Hz (yaw's stays within 4 times it to
    50 Hz). Through the same estimator on stances of the same lengths the sway has that spectrum:
    f_lo 2 Hz, f_c 2.5, 2.0, 3.0 Hz (mean frequency 5.4, 4.9, 5.8 Hz), rms 2.25, 1.75, 1.6 °/s. The
    rest of the variation, 2.0, 1.3, 2.4 °/s, comes at the stances' ends (the window weighs a
    stance's middle; about a straight line through each stance the rate varies by 2.1, 1.9,
    1.9 °/s), with the sole rolling onto the toes: like each stance's mean rate (−8.5 °/s of pitch,
    −2.1 °/s of roll) it is not modelled, as it would change the pose the next swing starts from.

    The specific force varies by 0.34, 0.31, 0.20 m/s² about each stance's mean (standing: 0.02),
    and a rotation about the sensor explains 0.12, 0.05, 0.01 of it: the rest is the module's own
    acceleration, the sole flexing under it. From 10 to 125 Hz it is 0.11, 0.15, 0.055 m/s² rms,
    three quarters of its power over a flat spectrum from 10 to 60 Hz and the rest from 60 to
    125 Hz, where it falls off (the sensor's own filter begins there). It is what keeps the
    detector's T2 high: over 32 ms (the module's window at 1 kHz) its part of T2 in a real walking
    stance is 45 LSB_f² (median), the rate's 32, the standing noise's 8. Without it a swaying foot's
    T2 dips below TH_ZARU wherever the slow rates pass a turning point (ZARU in 7.7 % of the 100 m
    walk's walking-stance loops with every sensor error, 36 % error-free), and BIASEST learns the
    rate there as a bias: 8.2° and 4.6° of heading lost. One such loop long after the last costs
    degrees (BIASEST's gain has grown meanwhile): with the vibration only from 10 to 60 Hz (0.096,
    0.129, 0.045 m/s²), 9 of 10 error-free walks dipped below TH_ZARU in 2–19 loops and 7 lost
    1.3–37°; up to 125 Hz, 2 of 40 did, in 3–4 loops within 5 ms of a stance's end, where the foot
    turns at 0.02 °/s or less: they lost nothing (all 40 end 0.082–0.083 % off).

    Not modelled either: the specific force below 10 Hz (0.09, 0.08, 0.09 m/s² from 2 to 10 Hz: the
    real stances' ends, the foot still settling or already lifting at centimetres per second).
    """

    #: rms of the sway's rate about the board's x, y, z in the stance's middle [°/s]
    rate_rms_dps: tuple[float, float, float] = (2.25, 1.75, 1.6)
    lowest_hz: float = 2.0  #: f_lo: no component below it (a stance lasts half a second)
    corner_hz: tuple[float, float, float] = (2.5, 2.0, 3.0)  #: f_c per axis: the spectrum's fall
    #: rms of the sole's vibration along the foot's x, y, z (the module's acceleration) [m/s²]
    vibration_ms2: tuple[float, float, float] = (0.11, 0.15, 0.055)
    #: f₁, f₂, f₃ [Hz]: its spectrum is flat from f₁ to f₂ and from f₂ to f₃, 0 elsewhere
    vibration_band_hz: tuple[float, float, float] = (10.0, 60.0, 125.0)
    vibration_low_share: float = 0.75  #: the share of its power from f₁ to f₂
    #: the ramps at either end (at most half the stance); short, as real feet keep moving to the
    #: stance's ends (with 0.1 s ramps ZARU held in 7.8 % of an error-free walk's stance loops, at
    #: their ends, and the bias BIASEST learnt there cost 0.43° of heading)
    taper_s: float = 0.03
    longest_stance_s: float = 1.0  #: a stance this long or longer is a stand: still
    components: int = 16  #: sinusoids per axis, motion and stance

    def rotation_hz(self, u: np.ndarray) -> np.ndarray:
        """The sway's frequencies [Hz] for uniform draws *u* in [0, 1), (…, 3, n): per axis."""
        corner = np.asarray(self.corner_hz, dtype=float)[:, None]
        return self.lowest_hz - corner * np.log1p(-u)

    def vibration_hz(self, u: np.ndarray) -> np.ndarray:
        """The vibration's frequencies [Hz] for uniform draws *u* in [0, 1)."""
        f1, f2, f3 = self.vibration_band_hz
        p = min(max(self.vibration_low_share, 1e-12), 1.0 - 1e-12)
        return np.where(u < p, f1 + (f2 - f1) * u / p, f2 + (f3 - f2) * (u - p) / (1.0 - p))


#: The stance motion of the shared walks' feet (:class:`StanceSway`).
STANCE_SWAY = StanceSway()
#: THE switch: whether a simulated walk (:func:`~.imu_array.make_source`,
#: :func:`~.imu_array.make_foot_source`, :func:`~.imu_array.make_feet_sources`,
#: :class:`~.imu_array.SimulatedSource`) carries :data:`STANCE_SWAY` in its walking stances when its
#: ``stance_sway`` argument is None. On: a real foot never stands perfectly still in a walking
#: stance, and a module's heading drifts as a real one's does only with the sway
#: (docs/sensor-errors.md). ``stance_sway=False`` gives the still stances of before, byte for byte.
STANCE_SWAY_DEFAULT = True
#: Mixed into the seed of a walk's stance-sway generator (apart from the walk's other draws).
_SWAY_STREAM = 0x535759  # "SWY"
#: 0 → 1 on [0, 1] with five derivatives zero at both ends: the sway's taper.
_RAMP = _smoothstep(5)


#: The environment variable that overrides :data:`STANCE_SWAY_DEFAULT` in a process and its
#: workers: ``1`` swaying, ``0`` still stances (e.g. ``OPENSHOE_STANCE_SWAY=0 python -m lab.accuracy
#: two-feet-straight`` reproduces a table measured before the sway became the default).
STANCE_SWAY_ENV = "OPENSHOE_STANCE_SWAY"


def stance_sway_on(stance_sway: bool | None) -> bool:
    """Whether a walk carries the stance sway: *stance_sway* itself or, if it is None,
    :data:`STANCE_SWAY_ENV` when set, else :data:`STANCE_SWAY_DEFAULT` (both read when called).
    Raises ValueError for a value of the variable other than 1 or 0."""
    if stance_sway is not None:
        return bool(stance_sway)
    env = os.environ.get(STANCE_SWAY_ENV, "").strip()
    if env == "":
        return STANCE_SWAY_DEFAULT
    if env not in ("0", "1"):
        raise ValueError(f"{STANCE_SWAY_ENV}={env!r}: give 1 (stances sway) or 0 (still stances)")
    return env == "1"


def _sum_of_sines(freq: np.ndarray, phase: np.ndarray, amp: np.ndarray, u: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Σ a·sin(ω u + φ) over the last axis and its first two derivatives in u, (rows, 3) each."""
    arg = freq * u[:, None, None] + phase
    sin, cos = np.sin(arg), np.cos(arg)
    return (np.sum(amp * sin, axis=2), np.sum(amp * freq * cos, axis=2),
            -np.sum(amp * freq * freq * sin, axis=2))


class _SwayDraw:
    """One walk's stance motion (:class:`StanceSway`): per swaying stance its span, and per motion
    and axis the components' angular frequencies [rad/s], phases and amplitudes (angle [rad],
    displacement [m])."""

    def __init__(self, stances: list[tuple[float, float, Pose]], sway: StanceSway, seed: int):
        spans = [(t0, t1, pose) for t0, t1, pose in stances if t1 - t0 < sway.longest_stance_s]
        self.sway = sway
        self.start = np.array([a for a, _, _ in spans], dtype=float)
        self.end = np.array([b for _, b, _ in spans], dtype=float)
        self.taper = np.minimum(sway.taper_s, 0.5 * (self.end - self.start))
        poses = np.array([p.as_array() for _, _, p in spans]).reshape(-1, 6)
        self.foot = euler_to_matrix(*poses[:, 3:].T)  # foot → NED at each stance's pose
        k = sway.components
        # every stance draws its own block, in time order: a longer walk keeps the earlier stances'
        u = np.random.default_rng([_SWAY_STREAM, int(seed)]).random((len(spans), 4, 3, k))
        self.rot_freq = 2.0 * math.pi * sway.rotation_hz(u[:, 0])
        self.rot_phase = 2.0 * math.pi * u[:, 1]
        rate_amp = np.asarray(sway.rate_rms_dps, dtype=float) * DEG * math.sqrt(2.0 / k)
        self.rot_amp = rate_amp[None, :, None] / self.rot_freq
        self.vib_freq = 2.0 * math.pi * sway.vibration_hz(u[:, 2])
        self.vib_phase = 2.0 * math.pi * u[:, 3]
        acc_amp = np.asarray(sway.vibration_ms2, dtype=float) * math.sqrt(2.0 / k)
        self.vib_amp = acc_amp[None, :, None] / self.vib_freq ** 2
        self.vibrates = bool(np.any(acc_amp))
        # each motion less its chord (the straight line between its values at the stance's ends), so
        # that the taper multiplies something that is 0 at both ends: no ramp turns a sizeable angle
        # into a jolt of rate
        d = self.end - self.start

        def ends(freq: np.ndarray, phase: np.ndarray, amp: np.ndarray) -> list[np.ndarray]:
            return [np.sum(amp * np.sin(freq * x[:, None, None] + phase), axis=2) for x in (0.0 * d, d)]

        self.rot_chord = ends(self.rot_freq, self.rot_phase, self.rot_amp)
        self.vib_chord = ends(self.vib_freq, self.vib_phase, self.vib_amp)

    def add(self, t: np.ndarray, pos: np.ndarray, vel: np.ndarray, acc: np.ndarray, ang: np.ndarray,
            dang: np.ndarray, ddang: np.ndarray) -> None:
        """Add the motion at times *t* to the position, the Euler angles and their derivatives (in
        place)."""
        if not len(self.start):
            return
        i = np.clip(np.searchsorted(self.start, t, side="right") - 1, 0, None)
        rows = np.flatnonzero((t >= self.start[i]) & (t < self.end[i]))
        if not len(rows):
            return
        j = i[rows]
        u = t[rows] - self.start[j]
        tau, d = self.taper[j], self.end[j] - self.start[j]
        w, w1, w2 = np.ones(len(rows)), np.zeros(len(rows)), np.zeros(len(rows))
        for near, x, sign in ((u < tau, u / tau, 1.0), (u > d - tau, (d - u) / tau, -1.0)):
            if np.any(near):
                r, r1, r2 = _eval3(_RAMP, x[near])
                w[near], w1[near], w2[near] = r, sign * r1 / tau[near], r2 / tau[near] ** 2
        w, w1, w2 = w[:, None], w1[:, None], w2[:, None]

        def tapered(freq, phase, amp, chord):
            s, s1, s2 = _sum_of_sines(freq[j], phase[j], amp[j], u)
            c0, c1 = chord[0][j], chord[1][j]
            s = s - c0 - (c1 - c0) * (u / d)[:, None]
            s1 = s1 - (c1 - c0) / d[:, None]
            return w * s, w1 * s + w * s1, w2 * s + 2.0 * w1 * s1 + w * s2

        rotation = tapered(self.rot_freq, self.rot_phase, self.rot_amp, self.rot_chord)
        for out, value in zip((ang, dang, ddang), rotation, strict=True):
            out[rows] += value
        if self.vibrates:
            foot = self.foot[j]
            vibration = tapered(self.vib_freq, self.vib_phase, self.vib_amp, self.vib_chord)
            for out, value in zip((pos, vel, acc), vibration, strict=True):
                out[rows] += np.einsum("rij,rj->ri", foot, value)


@dataclass(frozen=True)
class Pose:
    """A foot at rest: position [m] (NED) and attitude [rad] (roll, pitch, yaw)."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    roll: float = 0.0
    pitch: float = 0.0
    yaw: float = 0.0

    def as_array(self) -> np.ndarray:
        return np.array([self.x, self.y, self.z, self.roll, self.pitch, self.yaw])

    def moved(self, forward: float = 0.0, right: float = 0.0, down: float = 0.0, **attitude: float) -> Pose:
        """This pose moved in its own heading frame (forward/right along yaw, down along z)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return replace(self, x=self.x + c * forward - s * right, y=self.y + s * forward + c * right,
                       z=self.z + down, **attitude)

    def ground_normal(self) -> np.ndarray:
        """The normal of the ground this foot lies flat on: its z axis in NED (down into the ground)."""
        cr, sr = math.cos(self.roll), math.sin(self.roll)
        cp, sp = math.cos(self.pitch), math.sin(self.pitch)
        cy, sy = math.cos(self.yaw), math.sin(self.yaw)
        return np.array([cy * sp * cr + sy * sr, sy * sp * cr - cy * sr, cp * cr])


def ramp_normal(slope_deg: float, uphill_yaw: float) -> np.ndarray:
    """Unit normal (NED, pointing down into the ground) of a plane rising at *slope_deg*
    towards the heading *uphill_yaw* [rad]."""
    a = slope_deg * DEG
    return np.array([math.sin(a) * math.cos(uphill_yaw), math.sin(a) * math.sin(uphill_yaw), math.cos(a)])


def flat_on(normal: np.ndarray, yaw: float) -> tuple[float, float]:
    """(roll, pitch) of a foot heading *yaw* that lies flat on a plane of unit *normal* (NED, down).

    The foot's x axis lies in the plane above the heading, so tan θ = (n_x cos ψ + n_y sin ψ)/n_z
    (nose up where the plane rises ahead); its z axis is the normal, so with n' the normal in the
    heading frame (Rz(−ψ) n = (sin θ cos φ, −sin φ, cos θ cos φ)), tan φ = −n'_y cos θ / n_z
    (positive, right side down, where the plane falls to the right). On a plane of slope α whose
    uphill direction lies β to the left of the heading: θ = atan(tan α cos β),
    φ = atan(tan α sin β cos θ). Level ground gives exactly (0, 0).
    """
    c, s = math.cos(yaw), math.sin(yaw)
    nx, ny, nz = (float(v) for v in normal)
    pitch = math.atan2(nx * c + ny * s, nz)
    roll = math.atan2((s * nx - c * ny) * math.cos(pitch), nz)
    return roll + 0.0, pitch + 0.0  # + 0.0: level ground gives +0, never −0


@dataclass(frozen=True)
class Swing:
    """One swing of a foot: it lifts off at *t0* [s] from pose *a* and comes to rest at pose *b*,
    moving as *params* say (its swing time, clearance, pitch profile and impact)."""

    t0: float
    a: Pose
    b: Pose
    params: GaitParams

    @property
    def end(self) -> float:
        """When the foot is at rest again [s]."""
        return self.t0 + self.params.swing_s


def _swing_segment(t0: float, a: Pose, b: Pose, p: GaitParams) -> dict:
    T = p.swing_s
    w = min(p.impact_width_s, 0.5 * T)
    imp_t0 = max(0.0, p.impact_end * T - w)
    amp = p.impact_g * 9.80665 * w * w / _BUMP_PEAK_ACCEL if p.impact_g > 0 else 0.0
    return dict(t0=t0, dur=T, kind=SWING, A=a, B=b, clear=p.clearance, toe=p.toe_off_pitch_deg * DEG,
                heel=p.heel_strike_pitch_deg * DEG, imp_amp=amp, imp_w=w, imp_t0=imp_t0,
                imp_fwd=p.impact_forward, roll=p.swing_roll_deg * DEG, yaw=p.swing_yaw_deg * DEG)


def _stance_segment(t0: float, seconds: float, pose: Pose) -> dict:
    return dict(t0=t0, dur=seconds, kind=STANCE, A=pose, B=pose, clear=0.0, toe=0.0, heel=0.0, imp_amp=0.0,
                imp_w=1.0, imp_t0=0.0, imp_fwd=0.0, roll=0.0, yaw=0.0)


# ---------------------------------------------------------------------------------------------
# the trajectory


_FIELDS = ("t0", "dur", "kind", "clear", "toe", "heel", "imp_amp", "imp_w", "imp_t0", "imp_fwd", "roll",
           "yaw")


class Trajectory:
    """A compiled chain of stance and swing segments; evaluate it at any times."""

    def __init__(self, segments: list[dict], stances: list[tuple[float, float, Pose]]):
        if not segments:
            raise ValueError("a trajectory needs at least one segment")
        for name in _FIELDS:
            setattr(self, "_" + name, np.array([s[name] for s in segments], dtype=float))
        self._A = np.array([s["A"].as_array() for s in segments])
        self._B = np.array([s["B"].as_array() for s in segments])
        self.stances = stances
        self.duration = float(self._t0[-1] + self._dur[-1])
        self._sway: _SwayDraw | None = None

    def with_stance_sway(self, seed: int, sway: StanceSway = STANCE_SWAY) -> Trajectory:
        """This trajectory with *sway* in every walking stance (:class:`StanceSway`), drawn from the
        walk's *seed* (its own stream: the walk's other draws are unchanged)."""
        out = copy.copy(self)
        out._sway = _SwayDraw(self.stances, sway, seed)
        return out

    @property
    def stance_sway(self) -> StanceSway | None:
        """The sway of its walking stances (None: they are still)."""
        return None if self._sway is None else self._sway.sway

    @classmethod
    def from_swings(cls, start: Pose, swings: list[Swing], duration: float) -> Trajectory:
        """The foot at rest at *start*, then making *swings* (in time order, each from where the
        one before put it), at rest between them and after the last until *duration* [s]."""
        segments: list[dict] = []
        stances: list[tuple[float, float, Pose]] = []
        t, pose = 0.0, start
        for swing in [*swings, None]:
            until = duration if swing is None else swing.t0
            if until < t - 1e-9:
                raise ValueError(f"a swing at {until:.3f} s starts before the foot is at rest ({t:.3f} s)")
            if until > t:
                segments.append(_stance_segment(t, until - t, pose))
                stances.append((t, until, pose))
            if swing is not None:
                segments.append(_swing_segment(swing.t0, pose, swing.b, swing.params))
                t, pose = swing.end, swing.b
        if not segments or segments[0]["kind"] != STANCE:
            raise ValueError("a trajectory starts at rest: the first swing must come after t = 0")
        return cls(segments, stances)

    def __repr__(self) -> str:
        return f"Trajectory({len(self._t0)} segments, {len(self.stances)} stances, {self.duration:.2f} s)"

    def evaluate(self, t: np.ndarray, gravity: float = 9.81) -> Kinematics:
        """Exact kinematics at times *t* [s] (held at the end pose after the end)."""
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        n = len(t)
        seg = np.clip(np.searchsorted(self._t0, t, side="right") - 1, 0, len(self._t0) - 1)
        swing = self._kind[seg] == SWING
        A = self._A[seg]
        pos = A[:, :3].copy()
        ang = A[:, 3:].copy()
        vel, acc = np.zeros((n, 3)), np.zeros((n, 3))
        dang, ddang = np.zeros((n, 3)), np.zeros((n, 3))
        sw = np.flatnonzero(swing)  # a stance is A = B, still: only swing samples move
        if len(sw):
            i = seg[sw]
            ts = t[sw]
            k1 = 1.0 / self._dur[i]
            k2 = k1 * k1
            tau = np.clip((ts - self._t0[i]) * k1, 0.0, 1.0)
            d = self._B[i] - self._A[i]
            S, S1, S2 = _eval3(_S, tau)
            pos[sw] += d[:, :3] * S[:, None]
            vel[sw] = d[:, :3] * (S1 * k1)[:, None]
            acc[sw] = d[:, :3] * (S2 * k2)[:, None]
            ang[sw] += d[:, 3:] * S[:, None]
            dang[sw] = d[:, 3:] * (S1 * k1)[:, None]
            ddang[sw] = d[:, 3:] * (S2 * k2)[:, None]
            C, C1, C2 = _eval3(_C, tau)
            h = self._clear[i]
            pos[sw, 2] -= h * C
            vel[sw, 2] -= h * C1 * k1
            acc[sw, 2] -= h * C2 * k2
            for coeffs, amp in ((_G1, self._toe[i]), (_G2, self._heel[i])):
                G, G1, G2 = _eval3(coeffs, tau)
                ang[sw, 1] += amp * G
                dang[sw, 1] += amp * G1 * k1
                ddang[sw, 1] += amp * G2 * k2
            # the sole's roll and the toe's yaw on the way, only where a swing has them (every other
            # swing's samples stay exactly as without them)
            turning = (self._roll[i] != 0.0) | (self._yaw[i] != 0.0)
            if np.any(turning):
                rows, it, tt = sw[turning], i[turning], tau[turning]
                kt1, kt2 = k1[turning], k2[turning]
                for coeffs, amp, axis in ((_G1, self._roll[it], 0), (_C, self._yaw[it], 2)):
                    G, G1, G2 = _eval3(coeffs, tt)
                    ang[rows, axis] += amp * G
                    dang[rows, axis] += amp * G1 * kt1
                    ddang[rows, axis] += amp * G2 * kt2
            # heel-strike impact bump
            w = self._imp_w[i]
            u = (ts - self._t0[i] - self._imp_t0[i]) / w
            hit = (self._imp_amp[i] > 0) & (u > 0.0) & (u < 1.0)
            if np.any(hit):
                rows = sw[hit]
                Bv, B1, B2 = _eval3(_IMPACT, u[hit])
                ih = i[hit]
                amp, wh, fwd = self._imp_amp[ih], w[hit], self._imp_fwd[ih]
                yaw_b = self._B[ih, 5]
                direction = np.stack([fwd * np.cos(yaw_b), fwd * np.sin(yaw_b), np.ones_like(fwd)], axis=1)
                pos[rows] += (amp * Bv)[:, None] * direction
                vel[rows] += (amp * B1 / wh)[:, None] * direction
                acc[rows] += (amp * B2 / wh**2)[:, None] * direction
        if self._sway is not None:  # the walking stances' residual motion
            self._sway.add(t, pos, vel, acc, ang, dang, ddang)
        return Kinematics.from_euler(t, pos, vel, acc, ang, dang, ddang, stance=~swing, gravity=gravity)

    def sample(self, rate_hz: float, gravity: float = 9.81, duration: float | None = None) -> GroundTruth:
        """Ground truth at t_k = k / rate_hz, k = 0 … ⌊duration·rate⌋."""
        duration = self.duration if duration is None else duration
        n = int(math.floor(duration * rate_hz + 1e-9)) + 1
        t = np.arange(n, dtype=np.float64) / rate_hz
        kin = self.evaluate(t, gravity)
        starts = np.array([s[0] for s in self.stances])
        ends = np.array([s[1] for s in self.stances])
        poses = np.array([s[2].as_array() for s in self.stances]).reshape(-1, 6)
        return GroundTruth(kin, rate_hz, starts, ends, poses)


# ---------------------------------------------------------------------------------------------
# building


class GaitBuilder:
    """Compose a foot trajectory from motions; every method returns the builder.

    The foot starts at rest at ``start`` (default: origin, level, heading
    north). Each stride is a swing to the next rest pose followed by a stance
    of ``params.stance_s``; :meth:`stand` lengthens the current stance.
    """

    def __init__(self, params: GaitParams = WALKING, start: Pose | None = None):
        self.params = params
        self.pose = start or Pose()
        self.t = 0.0
        self._segments: list[dict] = []
        self._stances: list[tuple[float, float, Pose]] = []
        #: every swing so far, in time order (:mod:`~firmware_sim.sensors.feet` derives a walker's two
        #: feet from them)
        self.swings: list[Swing] = []

    # -- primitives ------------------------------------------------------------------------------

    def _stance(self, seconds: float) -> None:
        if seconds <= 0:
            return
        seg = _stance_segment(self.t, seconds, self.pose)
        if self._stances and self._stances[-1][1] == self.t and self._stances[-1][2] == self.pose:
            t0, _, pose = self._stances[-1]
            self._stances[-1] = (t0, self.t + seconds, pose)
        else:
            self._stances.append((self.t, self.t + seconds, self.pose))
        self._segments.append(seg)
        self.t += seconds

    def step_to(self, pose: Pose, params: GaitParams | None = None) -> GaitBuilder:
        """One stride: swing to *pose*, then stand there for the stance time."""
        p = params or self.params
        self._segments.append(_swing_segment(self.t, self.pose, pose, p))
        self.swings.append(Swing(self.t, self.pose, pose, p))
        self.t += p.swing_s
        self.pose = pose
        self._stance(p.stance_s)
        return self

    # -- motions ---------------------------------------------------------------------------------

    def face(self, deg: float) -> GaitBuilder:
        """Start facing *deg* (east of north): only before anything else has happened."""
        if self._segments:
            raise ValueError("'face' sets the start, so it can only be the first piece")
        self.pose = replace(self.pose, yaw=deg * DEG)
        return self

    def stand(self, seconds: float) -> GaitBuilder:
        """Stand still (foot flat) for *seconds*."""
        self._stance(seconds)
        return self

    def walk(self, distance: float, *, slope_deg: float = 0.0,
             params: GaitParams | None = None) -> GaitBuilder:
        """Walk straight ahead *distance* metres along the ground (uphill for slope > 0).

        The foot lands flat on the slope: pitch = slope, roll 0; each step rises
        tan(slope) × its horizontal length.
        """
        p = params or self.params
        n = max(1, round(abs(distance) / p.stride_length))
        step = distance / n
        slope = slope_deg * DEG
        for _ in range(n):
            self.step_to(self.pose.moved(forward=step * math.cos(slope), down=-step * math.sin(slope),
                                         pitch=slope, roll=0.0), p)
        return self

    def ramp(self, distance: float, slope_deg: float, across_deg: float = 0.0,
             params: GaitParams | None = None) -> GaitBuilder:
        """Walk straight ahead *distance* metres along a plane of slope *slope_deg* whose uphill
        direction lies *across_deg* to the left of the walking direction (0: straight up the fall
        line, 90: along the contour with the ground falling to the right, 180: straight down).

        The plane begins where the foot stands (it passes through its position) and the walk keeps
        the current heading; the foot lands flat on it (:func:`flat_on`: pitch θ = atan(tan α cos β),
        roll φ = atan(tan α sin β cos θ), right side down for 0 < β < 180°), and each step rises
        tan α cos β × its horizontal length (the distance is measured along the ground, like
        :meth:`walk`). Arcs, stairs, side and back steps are level-ground motions: they land the
        foot level.
        """
        p = params or self.params
        n = max(1, round(abs(distance) / p.stride_length))
        step = distance / n
        yaw = self.pose.yaw
        roll, pitch = flat_on(ramp_normal(slope_deg, yaw - across_deg * DEG), yaw)
        for _ in range(n):
            self.step_to(self.pose.moved(forward=step * math.cos(pitch), down=-step * math.sin(pitch),
                                         pitch=pitch, roll=roll), p)
        return self

    def arc(self, radius: float, angle_deg: float, params: GaitParams | None = None) -> GaitBuilder:
        """Walk along a circular arc; positive angle turns right (clockwise seen from above)."""
        p = params or self.params
        angle = angle_deg * DEG
        n = max(1, round(abs(angle) * radius / p.stride_length))
        dpsi = angle / n
        chord = 2.0 * radius * math.sin(abs(dpsi) / 2.0)
        for _ in range(n):
            mid = self.pose.moved()  # heading along the chord is the mean heading
            mid = replace(mid, yaw=self.pose.yaw + dpsi / 2.0)
            target = mid.moved(forward=chord)
            self.step_to(replace(target, yaw=self.pose.yaw + dpsi, pitch=0.0, roll=0.0), p)
        return self

    def turn_on_spot(self, angle_deg: float, max_step_deg: float = 45.0,
                     params: GaitParams = SHUFFLE) -> GaitBuilder:
        """Turn in place (positive: right), at most *max_step_deg* per stride.

        The foot stays flat on the ground it stands on: on a slope its pitch and roll follow
        the plane as the heading turns (a half turn on a 6° ramp goes from +6° to −6° pitch).
        """
        n = max(1, math.ceil(abs(angle_deg) / max_step_deg))
        normal = self.pose.ground_normal()
        for _ in range(n):
            yaw = self.pose.yaw + angle_deg * DEG / n
            roll, pitch = flat_on(normal, yaw)
            self.step_to(replace(self.pose, yaw=yaw, roll=roll, pitch=pitch), params)
        return self

    def wiggle(self, seconds: float = 30.0, tilt_deg: float = WIGGLE_TILT_DEG,
               params: GaitParams = WIGGLE) -> GaitBuilder:
        """Wiggle the foot in place for about *seconds*, as a wearer does to calibrate the shoe's
        magnetometers (shared/spec/aids.md §3): turns about the ankle (:data:`WIGGLE_LEVER_M`), each
        held still for a moment, through many orientations, then back to where it started.

        The k-th of n orientations (n = *seconds* / the turn and hold time, at least 4) turns the
        heading by 180° · sin(2πk/n) from the start's — all round, left then right, and back — and
        tilts the foot by *tilt_deg* (odd k) or half of it (even k) towards a direction
        that advances by the golden angle each time: pitch α cos β, roll α sin β on top of the
        start's. The last orientation is the start's own pose, so the foot ends where it began,
        flat on the ground it stood on. The module moves along the chord between its positions at
        two orientations (within a centimetre or two of the arc it would follow about the ankle).

        The module's ZUPT detector sees every hold as a stance: its INS resets once per turn and
        each step it reports is a few centimetres long (the module's own drift during a 0.8 s turn
        adds a few more), far below the half metre that ends NavShoe's calibration.
        """
        n = max(4, round(seconds / params.stride_s))
        start = self.pose
        lever = np.asarray(WIGGLE_LEVER_M)

        def at(roll: float, pitch: float, yaw: float) -> np.ndarray:
            return euler_to_matrix(np.array(roll), np.array(pitch), np.array(yaw)) @ lever

        ankle = np.array([start.x, start.y, start.z]) - at(start.roll, start.pitch, start.yaw)
        for k in range(1, n + 1):
            if k == n:
                self.step_to(start, params)
                break
            tilt = tilt_deg * DEG * (1.0 if k % 2 else 0.5)
            direction = k * _GOLDEN_ANGLE
            roll = start.roll + tilt * math.sin(direction)
            pitch = start.pitch + tilt * math.cos(direction)
            yaw = start.yaw + math.pi * math.sin(2.0 * math.pi * k / n)
            x, y, z = ankle + at(roll, pitch, yaw)
            self.step_to(Pose(float(x), float(y), float(z), roll, pitch, yaw), params)
        return self

    def stairs(self, n_stairs: int, up: bool = True, rise: float = 0.17, tread: float = 0.28,
               params: GaitParams | None = None) -> GaitBuilder:
        """Climb (or descend) *n_stairs* stairs; this foot takes two stairs per stride, in the stair
        gait of its direction (default :data:`STAIRS_UP` or :data:`STAIRS_DOWN`)."""
        params = params or (STAIRS_UP if up else STAIRS_DOWN)
        left = n_stairs
        sign = -1.0 if up else 1.0  # z is down
        while left > 0:
            k = min(2, left)
            left -= k
            # going up, lift higher to clear the stair edge
            p = replace(params, clearance=params.clearance + (0.5 * k * rise if up else 0.0))
            self.step_to(self.pose.moved(forward=k * tread, down=sign * k * rise, pitch=0.0, roll=0.0), p)
        return self

    def side_steps(self, n: int, right: bool = True, width: float = 0.35,
                   params: GaitParams = SHORT_STEPS) -> GaitBuilder:
        """Step sideways *n* times without turning."""
        for _ in range(n):
            self.step_to(self.pose.moved(right=width if right else -width, pitch=0.0, roll=0.0), params)
        return self

    def back_steps(self, n: int, length: float = 0.5, params: GaitParams = SHORT_STEPS) -> GaitBuilder:
        """Step backwards *n* times. Walking backwards reverses the forward step in time: the foot
        lifts off toe up, the heel last, and lands toe first (the forward step's toe-off pitch comes
        late, its heel-strike pitch early)."""
        p = replace(params, toe_off_pitch_deg=params.heel_strike_pitch_deg,
                    heel_strike_pitch_deg=params.toe_off_pitch_deg, impact_forward=-params.impact_forward)
        for _ in range(n):
            self.step_to(self.pose.moved(forward=-length, pitch=0.0, roll=0.0), p)
        return self

    def run(self, distance: float, params: GaitParams = RUNNING) -> GaitBuilder:
        """Run straight ahead *distance* metres."""
        return self.walk(distance, params=params)

    def rectangle(self, length: float, width: float, corner_radius: float = 1.0,
                  params: GaitParams | None = None) -> GaitBuilder:
        """Walk once around a rectangle with rounded corners, turning right; ends where it started."""
        for side in (length, width, length, width):
            self.walk(side - 2 * corner_radius, params=params)
            self.arc(corner_radius, 90.0, params=params)
        return self

    def track_400m(self, params: GaitParams | None = None, laps: int = 1) -> GaitBuilder:
        """Laps of a 400 m track (lane 1: straights 84.39 m, bends of radius 36.80 m), turning left."""
        for _ in range(laps):
            for _ in range(2):
                self.walk(84.39, params=params)
                self.arc(36.80, -180.0, params=params)
        return self

    def build(self) -> Trajectory:
        if not self._segments or self._segments[0]["kind"] != STANCE:
            raise ValueError("a trajectory starts at rest: call stand() first")
        return Trajectory(self._segments, self._stances)
