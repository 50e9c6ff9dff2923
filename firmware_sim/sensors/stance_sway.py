"""A walking stance's residual motion: a real foot's small zero-mean sway and sole vibration.

A walk (:class:`~firmware_sim.sensors.gait.Trajectory`) holds the foot still at each stance's pose;
:meth:`~firmware_sim.sensors.gait.Trajectory.with_stance_sway` adds :class:`StanceSway` to every
walking stance, drawn from the walk's seed (:class:`SwayDraw`). Whether a simulated walk sways when
nobody says: :func:`stance_sway_on` (:data:`STANCE_SWAY_DEFAULT`, on; :data:`STANCE_SWAY_ENV`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from .polynomials import eval3, smoothstep
from .sines import sum_of_sines
from .truth import add_at_rows, euler_to_matrix

__all__ = ["StanceSway", "STANCE_SWAY", "STANCE_SWAY_DEFAULT", "STANCE_SWAY_ENV", "stance_sway_on",
           "SwayDraw"]

DEG = math.pi / 180.0


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
_RAMP = smoothstep(5)


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


class SwayDraw:
    """One walk's stance motion (:class:`StanceSway`): per swaying stance its span, and per motion
    and axis the components' angular frequencies [rad/s], phases and amplitudes (angle [rad],
    displacement [m]).

    *stances* are a walk's (start, end, pose) (:attr:`~firmware_sim.sensors.gait.Trajectory.stances`;
    each pose a :class:`~firmware_sim.sensors.gait.Pose`, typed ``Any`` here as gait imports this
    module)."""

    def __init__(self, stances: list[tuple[float, float, Any]], sway: StanceSway, seed: int):
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

    def add(self, t: np.ndarray, pos: np.ndarray | None, vel: np.ndarray | None, acc: np.ndarray | None,
            ang: np.ndarray, dang: np.ndarray, ddang: np.ndarray | None) -> None:
        """Add the motion at times *t* to the position, the Euler angles and their derivatives (in
        place; each (3, len(t)), a row per axis). Without *pos*, *vel* and *acc* (None) the
        vibration is left out, and without *ddang* the angles' second derivative: what is added
        to the others stays the same."""
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
                r, r1, r2 = eval3(_RAMP, x[near])
                w[near], w1[near], w2[near] = r, sign * r1 / tau[near], r2 / tau[near] ** 2

        def tapered(freq, phase, amp, chord, second):  # a row per axis: each operation along a row
            s, s1, s2 = (x.T for x in sum_of_sines(freq, phase, amp, j, u, second))
            c0 = chord[0].T[:, j]
            slope = chord[1].T[:, j] - c0
            s -= c0  # s − c0 − (c1 − c0)·u/d, s1 − (c1 − c0)/d: in place, in that order
            s -= slope * (u / d)
            s1 -= slope / d
            taper1 = w1 * s
            taper1 += w * s1
            if not second:
                return w * s, taper1, None
            taper2 = w2 * s  # w2 s + 2 w1 s1 + w s2
            taper2 += 2.0 * w1 * s1
            taper2 += w * s2
            return w * s, taper1, taper2

        rotation = tapered(self.rot_freq, self.rot_phase, self.rot_amp, self.rot_chord, ddang is not None)
        for out, value in zip((ang, dang, ddang), rotation, strict=True):
            if out is not None:
                add_at_rows(out, rows, value)
        if self.vibrates and pos is not None:
            foot = self.foot[j]
            vibration = tapered(self.vib_freq, self.vib_phase, self.vib_amp, self.vib_chord, True)
            for out, value in zip((pos, vel, acc), vibration, strict=True):
                # einsum's sums depend on its operands' layout: the foot's and the motion's rows, as ever
                add_at_rows(out, rows, np.einsum("rij,rj->ri", foot, np.ascontiguousarray(value.T)).T)
