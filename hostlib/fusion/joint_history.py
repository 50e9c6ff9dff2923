"""What :class:`~hostlib.fusion.feet.TwoFeetTracker` keeps of each fused step, for the whole walk:
:class:`JointHistory`.

A live page opened late draws the whole walk, and the CSV at the end writes every row, so every
step leaves a row; a long walk must not make the host grow by more than a few hundred bytes a
step. Kept per step, in growing arrays (:class:`~hostlib.track.rows.Rows`):

* the feet's poses after the step (8 float64: each foot's fused track, their separation; of the
  rest of the joint state — the modules' errors, the aid states — only the start's is kept, what
  the GPS course's alignment measures the way walked from);
* the body's pose (4) and its 4×4 covariance (what the body track, its ellipses and its CSV
  columns read), and the variances of the two feet's poses (8: each foot's 1σ columns);
* whether a foot was stale, each foot's steps fused so far, which foot stepped (one byte each,
  two int32; the baseline of the two single-module tracks is built from them).

The 8×8 covariance of the feet's poses, which the body's covariance and the feet's variances are
made from, is kept only while the walk's frame may still turn: until the aids align the heading
(the first compass reading or the GPS course turn every row recorded before them,
:meth:`JointHistory.turn`). Its rows are then turned, the body's rows made from them as they were
before, and let go; after that each step's body row is made when the step is recorded. (A tracker
whose heading no aid ever aligns — a compass held through the whole walk — keeps them all, 512
bytes a step.) The body's rows are the same numbers however many are made at once.
"""

from __future__ import annotations

import numpy as np

from protocol.board import FOOT_SIDES

from ..track.rows import Rows

__all__ = ["JointHistory", "body_pose_rows"]


class JointHistory:
    """The rows of a two-feet fusion (module docstring). *size* is the joint state's length, *poses*
    the slice of the feet's poses in it (both, side by side), *body_rows* (3, 4, size) the body's
    pose from the joint state: the midpoint, the right foot while the left is stale, the left foot
    while the right is stale."""

    def __init__(self, size: int, poses: slice, body_rows: np.ndarray):
        self.poses = poses
        self._body_rows = np.asarray(body_rows, dtype=np.float64)
        width = poses.stop - poses.start
        self._size = size
        self._start: np.ndarray | None = None  # the joint state at the start (row 0), turned with the rows
        self._feet = Rows((width,))  # the feet's poses, side by side
        self._stale = Rows((), np.int8)  # 0: both feet fresh; 1: the left foot stale; 2: the right
        self._counts = Rows((2,), np.int32)  # each foot's steps through the filter
        self._sides = Rows((), np.int8)  # which foot made each step (its index in FOOT_SIDES)
        # the feet's poses' covariance of the rows not reduced yet (the frame may still turn)
        self._covs = Rows((width, width))
        self._body_poses = Rows((4,))
        self._body_covs = Rows((4, 4))
        self._variances = Rows((width,))  # the diagonal of the feet's poses' covariance

    def record(self, state: np.ndarray, poses_cov: np.ndarray, stale: int, counts: tuple[int, int],
               side: str | None, settled: bool) -> None:
        """One row: the joint *state* after a step of *side* (None: the start), the feet's poses'
        covariance *poses_cov*, which foot is *stale* and the *counts* of each foot's steps; with the
        frame *settled* (it turns no more) the body's row is made now and the covariance let go."""
        if self._start is None:
            self._start = np.array(state, dtype=np.float64)
        self._feet.append(state[self.poses])
        self._covs.append(poses_cov)
        self._stale.append(stale)
        self._counts.append(counts)
        if side is not None:
            self._sides.append(FOOT_SIDES.index(side))
        if settled:
            self._reduce()

    def turn(self, t: np.ndarray, shift: np.ndarray) -> None:
        """Every recorded row through the joint state's linear map ``s ← t s + shift`` (a turn of the
        frame: *t* turns only the feet's poses), each covariance by its pose block. The turned rows
        are new arrays: what :meth:`views` handed out before stays as it was."""
        self._start = t @ self._start + shift
        feet, state = self._feet.copy(), np.zeros(self._size)
        for k in range(len(feet)):  # each row as a joint state (t is the identity off the poses)
            state[self.poses] = feet[k]
            feet[k] = (t @ state + shift)[self.poses]
        self._feet = Rows.of(feet)
        tp = t[self.poses, self.poses]
        covs = self._covs.copy()
        for k in range(len(covs)):
            covs[k] = tp @ covs[k] @ tp.T
        self._covs = Rows.of(covs)
        if len(self._body_poses):  # rows made before a turn: turned as a pose is (x, y by t's turn)
            body = t[self.poses.start:self.poses.start + 4, self.poses.start:self.poses.start + 4]
            turn = shift[self.poses.start + 3]
            poses, body_covs = self._body_poses.view(), self._body_covs.view()
            self._body_poses = Rows.of(poses @ body.T + np.array([0.0, 0.0, 0.0, turn]))
            self._body_covs = Rows.of(body @ body_covs @ body.T)

    def _reduce(self) -> None:
        """Make the body's rows of the rows not reduced yet, keep the feet's variances, let the
        covariances go."""
        done = len(self._body_poses)
        if done == len(self._feet):
            return
        poses, covs = self._body_of(done, len(self._feet))
        for pose, cov in zip(poses, covs, strict=True):
            self._body_poses.append(pose)
            self._body_covs.append(cov)
        for cov in self._covs.view():
            self._variances.append(np.diagonal(cov))
        self._covs = Rows(self._covs.shape)

    def _body_of(self, lo: int, hi: int) -> tuple[np.ndarray, np.ndarray]:
        """The body's poses and covariances of rows *lo* to *hi* (not reduced yet: their
        covariances are kept)."""
        done = len(self._body_poses)
        stale = self._stale.view()[lo:hi].astype(np.int64)
        covs = self._covs.view()[lo - done:hi - done].copy()
        return body_pose_rows(self._feet.view()[lo:hi], covs, self._body_rows[stale][:, :, self.poses])

    # -- reading ------------------------------------------------------------------------------

    def __len__(self) -> int:
        """Rows recorded (the start's and one a fused step)."""
        return len(self._feet)

    @property
    def start(self) -> np.ndarray:
        """The joint state at the start (row 0), as turned since (a copy)."""
        return self._start.copy()

    def feet(self) -> np.ndarray:
        """(n + 1, width) the feet's poses after each step (row 0: the start), side by side as in
        the joint state from the slice ``poses``' start; read-only."""
        return self._feet.view()

    def body(self) -> tuple[np.ndarray, np.ndarray]:
        """(n + 1, 4) the body's poses and (n + 1, 4, 4) their covariances (copies)."""
        done, n = len(self._body_poses), len(self._feet)
        if done == n:
            return self._body_poses.copy(), self._body_covs.copy()
        poses, covs = self._body_of(done, n)
        return (np.concatenate([self._body_poses.view(), poses]),
                np.concatenate([self._body_covs.view(), covs]))

    def views(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The body's (n + 1, 4) poses and (n + 1, 4, 4) covariances and the feet's (n + 1, width)
        poses, read-only and not copied (the rows not reduced yet made now): for a reader that
        takes them under the lock steps are fused under and reads them after it (the rows recorded
        later, and a turn of the frame, do not show in them)."""
        if len(self._body_poses) < len(self._feet):
            poses, covs = self.body()
        else:
            poses, covs = self._body_poses.view(), self._body_covs.view()
        return poses, covs, self._feet.view()

    def body_row(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """The body's pose and covariance at row *k* (negative: from the end), made alone (copies)."""
        k = range(len(self._feet))[k]
        if k < len(self._body_poses):
            return self._body_poses[k].copy(), self._body_covs[k].copy()
        poses, covs = self._body_of(k, k + 1)
        return poses[0], covs[0]

    def variances(self) -> np.ndarray:
        """(n + 1, width) the variances of the feet's poses after each step."""
        kept = np.diagonal(self._covs.view(), axis1=1, axis2=2)
        return np.concatenate([self._variances.view(), kept])

    def stale(self) -> np.ndarray:
        """(n + 1,) which foot was stale at each row (0: none; 1: the left; 2: the right)."""
        return self._stale.view().astype(np.int64)

    def counts(self) -> np.ndarray:
        """(n + 1, 2) each foot's steps fused by each row."""
        return self._counts.copy()

    def sides(self) -> list[str]:
        """Which foot made each fused step."""
        return [FOOT_SIDES[i] for i in self._sides.view().tolist()]

    def rows_of(self, foot: int) -> np.ndarray:
        """The rows (1…n) that steps of foot *foot* (its index in FOOT_SIDES) made."""
        return np.flatnonzero(self._sides.view() == foot) + 1

    @property
    def nbytes(self) -> int:
        """The bytes its arrays take (filled or not)."""
        return sum(r.nbytes for r in (self._feet, self._stale, self._counts, self._sides, self._covs,
                                      self._body_poses, self._body_covs, self._variances))


def body_pose_rows(states: np.ndarray, covs: np.ndarray, m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The body's (n, 4) poses and (n, 4, 4) covariances from (n, k) joint states, their (n, k, k)
    covariances and each row's (4, k) body rows *m*."""
    return np.einsum("kij,kj->ki", m, states), m @ covs @ np.transpose(m, (0, 2, 1))
