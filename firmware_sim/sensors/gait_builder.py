"""Foot trajectories composed from motions: :class:`GaitBuilder`.

Standing, straight and curved walks, slopes and ramps walked at an angle to their fall line, stairs,
turns on the spot, side and back steps, running, and the wiggle of an in-situ magnetometer
calibration (:meth:`GaitBuilder.wiggle`), each in the stride of a
:class:`~firmware_sim.sensors.gait.GaitParams`; :meth:`GaitBuilder.build` compiles them into a
:class:`~firmware_sim.sensors.gait.Trajectory`. Named scenarios live in
:mod:`firmware_sim.sensors.scenarios`.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .gait import (
    DEG,
    RUNNING,
    SHORT_STEPS,
    SHUFFLE,
    STAIRS_DOWN,
    STAIRS_UP,
    STANCE,
    WALKING,
    WIGGLE,
    WIGGLE_LEVER_M,
    WIGGLE_TILT_DEG,
    GaitParams,
    Pose,
    Swing,
    Trajectory,
    flat_on,
    ramp_normal,
    stance_segment,
    swing_segment,
)
from .truth import euler_to_matrix

__all__ = ["GaitBuilder"]

#: The golden angle [rad]: successive tilt directions of a wiggle never repeat and fill the circle
#: evenly.
_GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))


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
        seg = stance_segment(self.t, seconds, self.pose)
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
        self._segments.append(swing_segment(self.t, self.pose, pose, p))
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
