"""The host's filter core: one state vector ``x`` and its covariance ``P``, made of named blocks.

Every tracker of :mod:`hostlib.fusion` is this filter with some blocks registered:

* a foot's **pose** ``[x, y, z, χ]`` (one block for one module, ``"left"`` and ``"right"`` for two
  feet), moved by each step through the summation map (:meth:`StateFilter.step_pose`);
* a module's **errors** ``[s, c, k, [r,] [w]]`` (:mod:`hostlib.fusion.module_errors`), constant over
  a walk, which a step of that module's foot reads through its Jacobian;
* the **aid states** (:mod:`hostlib.fusion.aid_states`): the receiver's bias ``[b_n, b_e]``, the
  compass's local deviation ``d``, the declination ``D``, each with its prior and its process noise.

A block is registered once, with its prior mean and covariance (:meth:`StateFilter.add_block`), and
from then on addressed by its name: :meth:`~StateFilter.slice`, :meth:`~StateFilter.index` and
:meth:`~StateFilter.row` say where it is, so no code outside this class counts offsets. The filter
itself is the small state-space filter of filterpy's ``KalmanFilter``, in the shapes a step-wise
host needs:

* **predict** — a pose through a step (:meth:`~StateFilter.step_pose`), a Gauss–Markov state
  through a span (:meth:`~StateFilter.decay`), the whole state through a linear map
  (:meth:`~StateFilter.transform`: a turn of the frame);
* **update** — a scalar measurement ``h x`` with its innovation and variance, in Joseph form
  (:meth:`~StateFilter.update`); a block added as a *consider* block keeps its estimate through
  every update (its gain is zero: the Schmidt–Kalman filter) while its covariance and its
  correlations go on, so that an error the filter cannot learn is weighed and not estimated;
* **project** — a constraint moves the estimate and leaves ``P`` (:meth:`~StateFilter.project`).

Everything is float64 and the operations are the trackers' own, in the same order, so a tracker
built on it gives the numbers it gave before, to the last bits the BLAS kernel leaves.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..track.steps import propagate, step_jacobian
from .gauss_markov import decay

__all__ = ["Block", "NonFiniteUpdate", "StateFilter"]


class NonFiniteUpdate(ValueError):
    """A measurement whose innovation or variance is not a finite number: the filter refused it."""


@dataclass(frozen=True)
class Block:
    """Where one named block sits in the state: ``x[start:start + size]``."""

    name: str
    start: int
    size: int

    @property
    def slice(self) -> slice:
        return slice(self.start, self.start + self.size)

    @property
    def indices(self) -> list[int]:
        return list(range(self.start, self.start + self.size))


class StateFilter:
    """The state ``x`` (n,) and covariance ``P`` (n×n) of named blocks, and the filter's operations
    on them (module docstring). Blocks are appended in the order they are added."""

    def __init__(self) -> None:
        self.x = np.zeros(0)
        self.P = np.zeros((0, 0))
        self.blocks: dict[str, Block] = {}
        self._others: dict[str, np.ndarray] = {}  #: others(name), for the blocks held now
        self._considered: list[int] = []  #: the indices of the consider blocks

    # -- registration -----------------------------------------------------------------

    def add_block(self, name: str, mean: Sequence[float] | np.ndarray,
                  cov: np.ndarray | None = None, consider: bool = False) -> Block:
        """Append a block *name* with prior *mean* and covariance *cov* (default: zero,
        uncorrelated with the rest until an operation correlates it); *consider*: no update changes
        its estimate (module docstring)."""
        if name in self.blocks:
            raise ValueError(f"the filter already holds a block {name!r}")
        mean = np.asarray(mean, dtype=np.float64).reshape(-1)
        m = len(mean)
        cov = np.zeros((m, m)) if cov is None else np.asarray(cov, dtype=np.float64)
        if cov.shape != (m, m):
            raise ValueError(f"block {name!r}: a mean of {m} needs a {m}×{m} covariance, got {cov.shape}")
        n = len(self.x)
        block = Block(name, n, m)
        self.x = np.concatenate([self.x, mean])
        p = np.zeros((n + m, n + m))
        p[:n, :n] = self.P
        p[n:, n:] = cov
        self.P = p
        self.blocks[name] = block
        self._others.clear()
        if consider:
            self._considered.extend(block.indices)
        return block

    def __contains__(self, name: str) -> bool:
        return name in self.blocks

    def __len__(self) -> int:
        return len(self.x)

    # -- where the blocks are ---------------------------------------------------------

    def slice(self, name: str) -> slice:
        """The block *name* as a slice of ``x``."""
        return self._block(name).slice

    def index(self, name: str, k: int = 0) -> int:
        """The index in ``x`` of element *k* of block *name*."""
        block = self._block(name)
        if not 0 <= k < block.size:
            raise IndexError(f"block {name!r} has {block.size} elements, not {k + 1}")
        return block.start + k

    def indices(self, *names: str) -> list[int]:
        """The indices of blocks *names*, in that order (names not held are left out)."""
        return [i for name in names if name in self.blocks for i in self.blocks[name].indices]

    def others(self, name: str) -> np.ndarray:
        """Every index of ``x`` but block *name*'s, in order (read-only: kept until a block is added)."""
        found = self._others.get(name)
        if found is None:
            keep = np.ones(len(self.x), dtype=bool)
            keep[self.slice(name)] = False
            found = self._others[name] = np.flatnonzero(keep)
            found.flags.writeable = False
        return found

    def _rest(self, name: str) -> slice | np.ndarray:
        """:meth:`others` as a slice where they are one run (block *name* first or last: a view of ``x``
        and ``P``, not a copy), else as the index array."""
        block = self.slice(name)
        if block.start == 0:
            return slice(block.stop, len(self.x))
        if block.stop == len(self.x):
            return slice(0, block.start)
        return self.others(name)

    def row(self, weights: Mapping[str | tuple[str, int], float]) -> np.ndarray:
        """A measurement row ``h`` (n,): *weights* maps a block name (its element 0) or a
        ``(name, k)`` to its coefficient."""
        h = np.zeros(len(self.x))
        for key, value in weights.items():
            name, k = (key, 0) if isinstance(key, str) else key
            h[self.index(name, k)] += value
        return h

    def mean(self, name: str) -> np.ndarray:
        """Block *name*'s estimate (a copy)."""
        return self.x[self.slice(name)].copy()

    def covariance(self, name: str) -> np.ndarray:
        """Block *name*'s covariance (a copy)."""
        s = self.slice(name)
        return self.P[s, s].copy()

    def sigmas(self, name: str) -> np.ndarray:
        """The 1σ of every element of block *name* (a negative variance's rounding reads 0)."""
        return np.sqrt(np.clip(np.diagonal(self.covariance(name)), 0.0, None))

    def sigma(self, name: str, k: int = 0) -> float:
        """The 1σ of element *k* of block *name*."""
        i = self.index(name, k)
        return math.sqrt(max(float(self.P[i, i]), 0.0))

    def _block(self, name: str) -> Block:
        try:
            return self.blocks[name]
        except KeyError:
            held = ", ".join(self.blocks)
            raise KeyError(f"the filter holds no block {name!r} (it holds {held})") from None

    # -- predict ----------------------------------------------------------------------

    def step_pose(self, pose: str, dx: np.ndarray, dp: np.ndarray, errors: str | None = None,
                  error_jacobian: np.ndarray | None = None) -> None:
        """Pose block *pose* through one step *dx* (4,) with covariance *dp* (4×4): the summation map
        (:func:`hostlib.track.steps.propagate`), its covariance with the rest through the step's
        Jacobian F. With the stepping module's *errors* block and their *error_jacobian* J
        (:meth:`hostlib.fusion.module_errors.ModuleErrors.jacobian`) the pose also reads them
        (:func:`hostlib.fusion.module_errors.through_step`)."""
        from .module_errors import through_step

        b, rest = self.slice(pose), self._rest(pose)
        chi = float(self.x[b.start + 3])
        f = step_jacobian(chi, dx)
        new, cov = propagate(self.x[b], self.P[b, b], dx, dp, f)
        if errors is None:
            cross = f @ self.P[b, rest]
        else:
            e = self.slice(errors)
            # where the errors sit among the rest
            start = e.start - rest.start if isinstance(rest, slice) else int(np.searchsorted(rest, e.start))
            new, cov, cross = through_step(new, cov, self.P[b, rest], f, error_jacobian, self.x[e],
                                           self.P[e, rest], slice(start, start + e.stop - e.start))
        self.P[b, rest] = cross
        self.P[rest, b] = cross.T
        self.x[b] = new
        self.P[b, b] = cov

    def decay(self, name: str, phi: float, q: float) -> None:
        """Block *name*, a first-order Gauss–Markov state, through one span: ``x ← φ x``, its
        covariances with the rest ``φ`` times theirs, its variance ``φ²`` times its own plus *q*
        (:func:`hostlib.fusion.gauss_markov.decay`)."""
        decay(self.x, self.P, self.blocks[name].indices, phi, q)

    def transform(self, t: np.ndarray, shift: np.ndarray | None = None) -> None:
        """The whole state through a linear map: ``x ← T x + shift``, ``P ← T P Tᵀ``."""
        self.x = t @ self.x + (0.0 if shift is None else shift)
        self.P = t @ self.P @ t.T

    # -- update -----------------------------------------------------------------------

    def update(self, h: np.ndarray, innovation: float, r: float) -> None:
        """A scalar Kalman update: the measurement ``h x`` with *innovation* and variance *r*, in
        Joseph form (P stays symmetric and positive; with a consider block's gain zero, P is still
        the covariance of the estimate the update makes). A non-finite innovation or variance is
        refused (:class:`NonFiniteUpdate`) and the state left as it was."""
        if not (math.isfinite(innovation) and math.isfinite(r) and np.isfinite(h).all()):
            raise NonFiniteUpdate(f"a measurement with innovation {innovation} and variance {r} "
                                  "is not finite: not applied")
        x, p = self.x, self.P
        ph = p @ h
        k = ph / (float(h @ ph) + r)
        if self._considered:
            k[self._considered] = 0.0
        x = x + k * innovation
        i_kh = np.eye(len(x)) - np.outer(k, h)
        p = i_kh @ p @ i_kh.T + r * np.outer(k, k)
        self.x, self.P = x, 0.5 * (p + p.T)

    def project(self, x: np.ndarray) -> None:
        """A constraint's projection: the estimate becomes *x*; ``P`` stays (the constraint is an
        inequality the truth keeps inside, not a measurement: :mod:`hostlib.fusion.feet`)."""
        x = np.asarray(x, dtype=np.float64)
        if x.shape != self.x.shape:
            raise ValueError(f"a projection keeps the state's shape {self.x.shape}, got {x.shape}")
        self.x = x

    # -- copies -----------------------------------------------------------------------

    def snapshot(self) -> tuple[np.ndarray, np.ndarray]:
        """(x, P) as copies."""
        return self.x.copy(), self.P.copy()

    def names(self) -> Iterable[str]:
        return iter(self.blocks)

    def __repr__(self) -> str:
        return "StateFilter(" + ", ".join(f"{b.name}[{b.size}]" for b in self.blocks.values()) + ")"
