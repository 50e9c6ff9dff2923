"""One walker, two feet: both feet's trajectories from one body path.

A scenario's recipe (:mod:`.scenarios`) builds a path of *body poses*: the
:class:`~.gait_builder.GaitBuilder` walks them as one foot on the walker's centre line,
B₀, B₁, … one stride apart. The walker's feet are derived from it, step-through
gait as people walk:

* the **left** foot rests at each body pose, half the step width to the left,
  and swings when the body path swings (B_{k−1} → B_k);
* the **right** foot rests half a stride out of phase, at the midpoint of two
  body poses (position, attitude and heading halved, so on an arc it faces the
  mean heading, on stairs it stands one stair between the left foot's two), half
  the step width to the right. It swings half a stride period before the left
  foot does: from standing, it leads with a half step to mid(B₀, B₁); every
  later step passes the left foot by half a stride; when the body path stops
  (it stands longer than a stride) it closes with a half step beside the left
  foot, so the walker stops and starts with the feet side by side.

Turns on the spot, side and back steps and stairs follow from the same rule: the
feet pivot round the body's centre line, side steps close up, each foot climbs
two stairs a stride. Both feet point along the body's heading (no toe-out: the
modules' initial headings agree, as the host assumes). Each foot's swing keeps
the gait of the body swing it belongs to (its clearance, pitch profile, impact);
a swing's roll and yaw on the way (the stairs' sole turned in and toe out,
:class:`~.gait.GaitParams`) are a right foot's, which the left foot mirrors.

The **body** is the midpoint of the two feet (:meth:`Feet.body`), the point the
host's two-foot fusion reports.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from protocol.board import FOOT_SIDES

from .gait import WIGGLE, GaitParams, Pose, Swing, Trajectory
from .gait_builder import GaitBuilder
from .truth import GroundTruth

__all__ = ["SIDES", "STEP_WIDTH_M", "Feet", "body_truth", "feet_from_body", "foot_module", "foot_seed",
           "write_body_truth"]

#: The two feet, in the order every two-foot result lists them.
SIDES = FOOT_SIDES
#: Lateral distance between the feet's centre lines [m]. Adults walk with a step width of about
#: 0.08–0.13 m (heel centre to heel centre); a module on the forefoot sits a little wider.
STEP_WIDTH_M = 0.12


def foot_seed(seed: int, side: str) -> int:
    """The walk seed of *side*'s module when the walker's walk is *seed*: 2·seed (left) and
    2·seed + 1 (right), so no two feet of any walkers share a draw."""
    return 2 * int(seed) + SIDES.index(side)


def foot_module(walker: int, side: str) -> int:
    """The module identity worn on *side* by walker *walker* (the same rule as :func:`foot_seed`:
    walker w wears modules 2w and 2w + 1, each with its own systematic errors)."""
    return 2 * int(walker) + SIDES.index(side)


@dataclass(frozen=True)
class Feet:
    """Both feet of one walker: a :class:`~.gait.Trajectory` each, over the same time span."""

    left: Trajectory
    right: Trajectory
    step_width: float = STEP_WIDTH_M

    def foot(self, side: str) -> Trajectory:
        if side not in SIDES:
            raise ValueError(f"a foot is {' or '.join(SIDES)}, not {side!r}")
        return self.left if side == "left" else self.right

    @property
    def duration(self) -> float:
        return max(self.left.duration, self.right.duration)

    def body(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The body at times *t* [s]: positions (n, 3) (the feet's midpoint, NED) and heading
        (n,) [rad] (the feet's mean yaw)."""
        left, right = self.left.evaluate(t), self.right.evaluate(t)
        return 0.5 * (left.pos + right.pos), 0.5 * (left.euler[:, 2] + right.euler[:, 2])


def _mid(a: Pose, b: Pose) -> Pose:
    """The pose halfway from *a* to *b* (yaw is continuous along a path, so it halves too)."""
    return Pose(*(0.5 * (a.as_array() + b.as_array())))


def _aside(pose: Pose, right: float) -> Pose:
    return pose.moved(right=right)


def _left_foot(params: GaitParams) -> GaitParams:
    """A right foot's gait as the left foot walks it: the sole turns in and the toe out the other way."""
    if params.swing_roll_deg == 0.0 and params.swing_yaw_deg == 0.0:
        return params
    return replace(params, swing_roll_deg=-params.swing_roll_deg, swing_yaw_deg=-params.swing_yaw_deg)


def _strides(swings: list[Swing]) -> list[list[Swing]]:
    """The body's swings in runs of walking: a run ends where the body stands still for longer
    than a stride (the walker stops, feet side by side)."""
    runs: list[list[Swing]] = []
    for swing in swings:
        if runs:
            last = runs[-1][-1]
            if swing.t0 - last.t0 < 2.0 * last.params.stride_s:
                runs[-1].append(swing)
                continue
        runs.append([swing])
    return runs


def feet_from_body(body: GaitBuilder, step_width: float = STEP_WIDTH_M) -> Feet:
    """The two feet of a walker whose body path *body* built (module docstring). A wiggle (one
    foot's calibration motion, :meth:`~.gait_builder.GaitBuilder.wiggle`) is no step of the body: refused."""
    if any(s.params == WIGGLE for s in body.swings):
        raise ValueError("a wiggle is one foot's magnetometer calibration, not a walker's step: walk a "
                         "scenario with a wiggle with one module")
    half = 0.5 * step_width
    start = body.swings[0].a if body.swings else body.pose
    left = [Swing(s.t0, _aside(s.a, -half), _aside(s.b, -half), _left_foot(s.params)) for s in body.swings]
    right: list[Swing] = []
    for run in _strides(body.swings):
        where = _aside(run[0].a, half)
        for s in run:
            to = _aside(_mid(s.a, s.b), half)
            right.append(Swing(s.t0 - 0.5 * s.params.stride_s, where, to, s.params))
            where = to
        last = run[-1]
        right.append(Swing(last.t0 + 0.5 * last.params.stride_s, where, _aside(last.b, half), last.params))
    end = max([body.t] + [s.end + 0.5 for s in right])
    return Feet(Trajectory.from_swings(_aside(start, -half), left, end),
                Trajectory.from_swings(_aside(start, half), right, end), step_width)


def body_truth(left: GroundTruth, right: GroundTruth
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The body from both feet's truth at the same sample times: t, position (n, 3), velocity
    (n, 3) (the feet's midpoint, NED) and heading (n,) [rad] (their mean yaw, continuous)."""
    if len(left) != len(right) or not np.array_equal(left.t, right.t):
        raise ValueError("the feet's truth must be sampled at the same times")
    return (left.t, 0.5 * (left.pos + right.pos), 0.5 * (left.vel + right.vel),
            0.5 * (left.euler[:, 2] + right.euler[:, 2]))


def write_body_truth(body: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], path: str | Path) -> Path:
    """The body's truth (:func:`body_truth`'s t, position, velocity, heading) as CSV: t, x, y, z,
    vx, vy, vz, yaw (wrapped to ±π)."""
    t, pos, vel, yaw = body
    wrapped = (yaw + np.pi) % (2 * np.pi) - np.pi
    path = Path(path)
    np.savetxt(path, np.column_stack([t, pos, vel, wrapped]), delimiter=",", header="t,x,y,z,vx,vy,vz,yaw",
               comments="", fmt=["%.6f"] + ["%.9f"] * 7)
    return path
