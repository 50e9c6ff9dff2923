"""Foot motion with exact derivatives: stance, swing, and the trajectory they make.

A foot trajectory is a chain of *segments*. A **stance** segment holds the
foot flat and still at one pose (where it rests on the ground; a walk may
give its walking stances a real foot's small zero-mean sway and sole
vibration, :class:`~firmware_sim.sensors.stance_sway.StanceSway`,
:meth:`Trajectory.with_stance_sway` — on by default,
:data:`~firmware_sim.sensors.stance_sway.STANCE_SWAY_DEFAULT`); a **swing**
segment carries it from one stance pose to the next: lift-off with the toe
down (toe-off pitch), a clearance arc, heel-first landing (heel-strike pitch)
and an optional heel-strike impact. Every quantity of a swing is a polynomial
in the normalised time τ ∈ [0, 1] whose first five derivatives vanish at both
ends (:mod:`~firmware_sim.sensors.polynomials`), so the whole trajectory is C⁵
in position and attitude: acceleration, angular rate and angular acceleration
are smooth and known analytically (and a sampled-data integrator meets no kinks
between the sample points).

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

:class:`~firmware_sim.sensors.gait_builder.GaitBuilder` composes motions — standing,
straight and curved walks, slopes and ramps walked at an angle to their fall line, stairs, turns
on the spot, side and back steps, running, and the wiggle of an in-situ magnetometer calibration
(:meth:`~firmware_sim.sensors.gait_builder.GaitBuilder.wiggle`) — from
:class:`GaitParams` (stride length, stance and swing time (so cadence and
speed), clearance, pitch profile, impact). Named scenarios live in
:mod:`firmware_sim.sensors.scenarios`.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.polynomial import polynomial as P

from .polynomials import eval3, max_abs, normalised, poly_from_roots, smoothstep
from .stance_sway import STANCE_SWAY, StanceSway, SwayDraw
from .truth import GroundTruth, Kinematics, add_at_rows, body_rate

__all__ = ["GaitParams", "WALKING", "RUNNING", "STAIRS_UP", "STAIRS_DOWN", "SHUFFLE", "SHORT_STEPS", "WIGGLE",
           "Pose", "Swing", "Trajectory", "flat_on", "ramp_normal"]

DEG = math.pi / 180.0
STANCE, SWING = 0, 1

# ---------------------------------------------------------------------------------------------
# the swing's basis polynomials (coefficients, lowest order first)


_S = smoothstep(5, shoulder=4.0)  # degree 13: position and attitude C⁵ at the segment joints
_C = 4096.0 * poly_from_roots(6, 6)  # clearance bump (4τ(1−τ))⁶, peak 1 at 1/2
_G1 = normalised(poly_from_roots(6, 10))  # toe-off pitch, peak at τ = 3/8
_G2 = normalised(poly_from_roots(10, 6))  # heel-strike pitch, peak at τ = 5/8
_IMPACT = 4.0**8 * poly_from_roots(8, 8)  # impact bump (4u(1−u))⁸, C⁷ at its ends
_BUMP_PEAK_ACCEL = max_abs(P.polyder(_IMPACT, 2))  # = 64, at u = 1/2


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
#: Stair gait (two stairs a stride, :meth:`~.gait_builder.GaitBuilder.stairs`). On stairs the forefoot
#: lands first, whichever the direction (Riener, Rabuffetti & Frigo 2002, Gait Posture 15:32; McFadyen
#: & Winter 1988, J Biomech 21:733): the pitch late in the swing is toe down, not the heel strike's
#: toe up. The model's figures: climbing, the foot pushes off the lower tread 20° toe down and reaches
#: the upper one nearly flat (10° toe down); descending, it leaves the upper tread with a smaller
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
#: Side and back steps (:meth:`~.gait_builder.GaitBuilder.side_steps`,
#: :meth:`~.gait_builder.GaitBuilder.back_steps`): the shuffle's short steps, and on the way the sole
#: rolled in 7° and the toe turned out 11° as in a stair swing (the shared walks' median straight
#: swing; no recording of side or back steps is at hand). A side step that only pitched stopped
#: rotating at 38 % of its swing (|ω| 0.8 °/s, below the 2.9 °/s of the slowest of the walks' 296 real
#: swings) at 1.7 m/s, just as ‖f‖ passed g, and the module's detector took it for a stance: 3.8 mm
#: short and 0.8 mm low on every 0.35 m step.
SHORT_STEPS = replace(SHUFFLE, swing_roll_deg=STAIRS_UP.swing_roll_deg, swing_yaw_deg=STAIRS_UP.swing_yaw_deg)
#: The wiggle of an in-situ magnetometer calibration (:meth:`~.gait_builder.GaitBuilder.wiggle`): each
#: turn of the foot takes 0.8 s and is held still for 0.4 s — longer than the ZUPT detector's window
#: and delay (a few tens of ms), so every hold is a stance — with no lift, pitch profile or impact.
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


def swing_segment(t0: float, a: Pose, b: Pose, p: GaitParams) -> dict:
    """The segment of a swing from *a* at *t0* [s] to *b* (:class:`Trajectory`'s input)."""
    T = p.swing_s
    w = min(p.impact_width_s, 0.5 * T)
    imp_t0 = max(0.0, p.impact_end * T - w)
    amp = p.impact_g * 9.80665 * w * w / _BUMP_PEAK_ACCEL if p.impact_g > 0 else 0.0
    return dict(t0=t0, dur=T, kind=SWING, A=a, B=b, clear=p.clearance, toe=p.toe_off_pitch_deg * DEG,
                heel=p.heel_strike_pitch_deg * DEG, imp_amp=amp, imp_w=w, imp_t0=imp_t0,
                imp_fwd=p.impact_forward, roll=p.swing_roll_deg * DEG, yaw=p.swing_yaw_deg * DEG)


def stance_segment(t0: float, seconds: float, pose: Pose) -> dict:
    """The segment of the foot still at *pose* from *t0* for *seconds* (:class:`Trajectory`'s input)."""
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
        self._D = self._B - self._A  # each segment's move
        self.stances = stances  #: each stance's start and end [s] and the foot's pose in it
        self.duration = float(self._t0[-1] + self._dur[-1])
        self._sway: SwayDraw | None = None

    def with_stance_sway(self, seed: int, sway: StanceSway = STANCE_SWAY) -> Trajectory:
        """This trajectory with *sway* in every walking stance (:class:`~.stance_sway.StanceSway`),
        drawn from the walk's *seed* (its own stream: the walk's other draws are unchanged)."""
        out = copy.copy(self)
        out._sway = SwayDraw(self.stances, sway, seed)
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
                segments.append(stance_segment(t, until - t, pose))
                stances.append((t, until, pose))
            if swing is not None:
                segments.append(swing_segment(swing.t0, pose, swing.b, swing.params))
                t, pose = swing.end, swing.b
        if not segments or segments[0]["kind"] != STANCE:
            raise ValueError("a trajectory starts at rest: the first swing must come after t = 0")
        return cls(segments, stances)

    def __repr__(self) -> str:
        return f"Trajectory({len(self._t0)} segments, {len(self.stances)} stances, {self.duration:.2f} s)"

    def evaluate(self, t: np.ndarray, gravity: float = 9.81) -> Kinematics:
        """Exact kinematics at times *t* [s] (held at the end pose after the end)."""
        t, seg, swing = self._segments(t)
        swings = self._swing_times(t, seg, swing)
        pos, vel, acc = self._translation(t, seg, swings)
        ang, dang, ddang = self._attitude(t, seg, swings)
        if self._sway is not None:  # the walking stances' residual motion
            self._sway.add(t, pos, vel, acc, ang, dang, ddang)
        pos, vel, acc, ang = (np.ascontiguousarray(x.T) for x in (pos, vel, acc, ang))
        return Kinematics.from_euler(t, pos, vel, acc, ang, dang.T, ddang.T, stance=~swing, gravity=gravity)

    def body_rate(self, t: np.ndarray) -> np.ndarray:
        """The angular rate ω_b [rad/s] at times *t*, (n, 3): ``evaluate(t).omega_b`` bit for bit,
        without the foot's translation and the rest of its kinematics (a gyro's delay evaluates
        the walk earlier only for its rate)."""
        t, seg, swing = self._segments(t)
        ang, dang, _ = self._attitude(t, seg, self._swing_times(t, seg, swing), second=False)
        if self._sway is not None:
            self._sway.add(t, None, None, None, ang, dang, None)
        return body_rate(ang.T, dang.T)

    def _segments(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Times *t* as float64, each one's segment and whether it is a swing's."""
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        seg = np.clip(np.searchsorted(self._t0, t, side="right") - 1, 0, len(self._t0) - 1)
        return t, seg, self._kind[seg] == SWING

    def _swing_times(self, t: np.ndarray, seg: np.ndarray, swing: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The swing samples (rows), their segments, 1/T and 1/T² and their normalised times τ."""
        sw = np.flatnonzero(swing)  # a stance is A = B, still: only swing samples move
        i = seg[sw]
        k1 = 1.0 / self._dur[i]
        k2 = k1 * k1
        tau = np.clip((t[sw] - self._t0[i]) * k1, 0.0, 1.0)
        return sw, i, k1, k2, tau

    def _translation(self, t: np.ndarray, seg: np.ndarray, swings: tuple[np.ndarray, ...]
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity and acceleration at times *t* (in segments *seg*; the swings'
        :meth:`_swing_times`) without the stance sway, each (3, len(t)): a row per axis (every
        operation runs along a row)."""
        n = len(t)
        pos = self._A[:, :3].T[:, seg]
        vel, acc = np.zeros((3, n)), np.zeros((3, n))
        sw, i, k1, k2, tau = swings
        if len(sw):
            d = self._D[:, :3].T[:, i]
            S, S1, S2 = eval3(_S, tau)
            add_at_rows(pos, sw, d * S)
            vel[:, sw] = d * (S1 * k1)
            acc[:, sw] = d * (S2 * k2)
            C, C1, C2 = eval3(_C, tau)
            h = self._clear[i]
            pos[2, sw] -= h * C
            vel[2, sw] -= h * C1 * k1
            acc[2, sw] -= h * C2 * k2
            # heel-strike impact bump
            w = self._imp_w[i]
            u = (t[sw] - self._t0[i] - self._imp_t0[i]) / w
            hit = (self._imp_amp[i] > 0) & (u > 0.0) & (u < 1.0)
            if np.any(hit):
                rows = sw[hit]
                Bv, B1, B2 = eval3(_IMPACT, u[hit])
                ih = i[hit]
                amp, wh, fwd = self._imp_amp[ih], w[hit], self._imp_fwd[ih]
                yaw_b = self._B[ih, 5]
                direction = np.stack([fwd * np.cos(yaw_b), fwd * np.sin(yaw_b), np.ones_like(fwd)])
                add_at_rows(pos, rows, (amp * Bv) * direction)
                add_at_rows(vel, rows, (amp * B1 / wh) * direction)
                add_at_rows(acc, rows, (amp * B2 / wh**2) * direction)
        return pos, vel, acc

    def _attitude(self, t: np.ndarray, seg: np.ndarray, swings: tuple[np.ndarray, ...], second: bool = True
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Euler angles and their first (and, if *second*, second) derivatives at times *t* (as
        :meth:`_translation`'s, each (3, len(t))) without the stance sway."""
        n = len(t)
        ang = self._A[:, 3:].T[:, seg]
        dang = np.zeros((3, n))
        ddang = np.zeros((3, n)) if second else None
        sw, i, k1, k2, tau = swings
        if len(sw):
            d = self._D[:, 3:].T[:, i]
            S, S1, S2 = eval3(_S, tau)
            add_at_rows(ang, sw, d * S)
            dang[:, sw] = d * (S1 * k1)
            if ddang is not None:
                ddang[:, sw] = d * (S2 * k2)
            # the toe-off and heel-strike pitch; the sole's roll and the toe's yaw on the way, only
            # where a swing has them (every other swing's samples stay exactly as without them)
            bumps = [(_G1, self._toe[i], 1, None), (_G2, self._heel[i], 1, None)]
            turning = (self._roll[i] != 0.0) | (self._yaw[i] != 0.0)
            if np.any(turning):
                bumps += [(_G1, self._roll[i], 0, turning), (_C, self._yaw[i], 2, turning)]
            for coeffs, amp, axis, where in bumps:
                rows, tt, a1, a2 = sw, tau, k1, k2
                if where is not None:
                    rows, tt, amp, a1, a2 = sw[where], tau[where], amp[where], k1[where], k2[where]
                G, G1, G2 = eval3(coeffs, tt)
                ang[axis, rows] += amp * G
                dang[axis, rows] += amp * G1 * a1
                if ddang is not None:
                    ddang[axis, rows] += amp * G2 * a2
        return ang, dang, ddang

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
