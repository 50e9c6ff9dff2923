"""A module's systematic step errors as states of the host's filter: step length, climb and turns.

The covariance dP a module sends with each step describes that step's own noise, and summing the
steps adds those covariances: the track's 1σ grows with the square root of the steps. One module's
errors are partly *systematic*, the same on every step of a walk: its steps are all a little too
long or too short (accelerometer scale, the detector's timing), and it sinks or climbs a little
per metre (the mechanization's skew, g-sensitivity), and it turns a little too much or too little
(the gyros' scale). Such an error grows with the distance or the angle turned itself, so no
per-step covariance describes it: the summed covariance is over-confident along the track, in
height and in heading on routes that turn (docs/accuracy.md, "Is the summed covariance honest?").

:class:`ModuleErrors` models them as three more states of the host's filter
(:class:`hostlib.fusion.FusionTracker`), constant over a walk, zero-mean, with priors:

* the **step-length scale** s: each step's horizontal displacement, turned into the navigation
  frame, is ``(1 + s) R(χ) dp_h``;
* the **climb** c [m per metre walked]: each step's height change is ``dz + c |dp_h|``;
* the **turn scale** k: each step's heading change is ``(1 + k) dψ``.

Without an aid the estimate does not change (the states stay 0) but the covariance grows by
σ_s² d dᵀ horizontally (d: the displacement from the start), σ_c² L² in height (L: the path
walked) and σ_k² Θ² in heading (Θ: the angle turned), with what the heading's does to the
positions after: a straight walk's along-track uncertainty grows with its length, a closed
loop's does not. An aid makes them observable (GPS the scale, the compass the turns), and the
steps after are corrected by the learned values.

:data:`EMULATED_MODULE` holds the priors of the emulated MIMU22BT, estimated from simulated
modules' end errors (``openshoe-accuracy consistency``, the method-of-moments estimate below);
another module has its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["EMULATED_MODULE", "ERROR_STATES", "ModuleErrors", "error_jacobian"]

#: The states a :class:`ModuleErrors` adds: s, c, k.
ERROR_STATES = 3


@dataclass(frozen=True)
class ModuleErrors:
    """Priors (1σ) of a module's step-length scale, climb and turn scale, constant over a walk."""

    #: 1σ of the step-length scale s (a fraction: 0.001 is 1 mm per metre)
    step_scale_sigma: float
    #: 1σ of the climb c [m of height per metre walked horizontally]
    climb_sigma: float
    #: 1σ of the turn scale k (a fraction: 0.01 is 3.6° per full turn)
    turn_scale_sigma: float = 0.0

    def __post_init__(self) -> None:
        for name in ("step_scale_sigma", "climb_sigma", "turn_scale_sigma"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be a finite number ≥ 0, got {value}")

    @property
    def prior(self) -> np.ndarray:
        """The 3×3 prior covariance of [s, c, k]."""
        return np.diag([self.step_scale_sigma ** 2, self.climb_sigma ** 2, self.turn_scale_sigma ** 2])


def error_jacobian(chi: float, dx: np.ndarray) -> np.ndarray:
    """∂pose/∂[s, c, k] (4×3) of one step *dx* (its [dx, dy, dz, dψ]) taken at heading *chi*: the
    step's horizontal displacement in the navigation frame, its horizontal length in height, and
    its heading change in heading."""
    c, s = math.cos(chi), math.sin(chi)
    j = np.zeros((4, ERROR_STATES))
    j[0, 0] = c * dx[0] - s * dx[1]
    j[1, 0] = s * dx[0] + c * dx[1]
    j[2, 1] = math.hypot(dx[0], dx[1])
    j[3, 2] = dx[3]
    return j


#: The emulated MIMU22BT's priors: the method-of-moments estimate on 20 simulated modules each of
#: the straight walk and the rectangle (the default route held out, a check of them:
#: docs/accuracy.md), σ² = Σ(e² − P) / Σ d² pooled over the walks, e the end
#: error along the displacement (scale), in height (climb) or in heading (turn scale, the rectangle's
#: full turn), P its summed 1σ² and d the displacement, path or angle turned
#: (``openshoe-accuracy consistency`` prints them).
EMULATED_MODULE = ModuleErrors(step_scale_sigma=0.00102, climb_sigma=0.00168, turn_scale_sigma=0.00085)
