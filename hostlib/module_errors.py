"""A module's systematic step errors as states of the host's filter: step-length scale and climb.

The covariance dP a module sends with each step describes that step's own noise, and summing the
steps adds those covariances: the track's 1σ grows with the square root of the steps. One module's
errors are partly *systematic*, the same on every step of a walk: its steps are all a little too
long or too short (accelerometer scale, the detector's timing), and it sinks or climbs a little
per metre (the mechanization's skew, g-sensitivity). Such an error grows with the distance itself,
so no per-step covariance describes it: the summed covariance is over-confident along the track
and in height (docs/accuracy.md, "Is the summed covariance honest?").

:class:`ModuleErrors` models them as two more states of the host's filter
(:class:`hostlib.fusion.FusionTracker`), constant over a walk, zero-mean, with priors:

* the **step-length scale** s: each step's horizontal displacement, turned into the navigation
  frame, is ``(1 + s) R(χ) dp_h``;
* the **climb** c [m per metre walked]: each step's height change is ``dz + c |dp_h|``.

Without an aid the estimate does not change (s and c stay 0) but the covariance grows by
σ_s² d dᵀ horizontally (d: the displacement from the start) and σ_c² L² in height (L: the path
walked): a straight walk's along-track uncertainty grows with its length, a closed loop's does
not. An aid that measures position (GPS) makes s and c observable, and the steps after are
corrected by the learned values.

:data:`EMULATED_MODULE` holds the priors of the emulated MIMU22BT, estimated from simulated
modules' end errors (``openshoe-accuracy consistency``, the method-of-moments estimate below);
another module has its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["EMULATED_MODULE", "ModuleErrors", "error_jacobian"]


@dataclass(frozen=True)
class ModuleErrors:
    """Priors (1σ) of a module's step-length scale and climb, constant over a walk."""

    #: 1σ of the step-length scale s (a fraction: 0.001 is 1 mm per metre)
    step_scale_sigma: float
    #: 1σ of the climb c [m of height per metre walked horizontally]
    climb_sigma: float

    def __post_init__(self) -> None:
        for name in ("step_scale_sigma", "climb_sigma"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be a finite number ≥ 0, got {value}")

    @property
    def prior(self) -> np.ndarray:
        """The 2×2 prior covariance of [s, c]."""
        return np.diag([self.step_scale_sigma ** 2, self.climb_sigma ** 2])


def error_jacobian(chi: float, dx: np.ndarray) -> np.ndarray:
    """∂pose/∂[s, c] (4×2) of one step *dx* (its [dx, dy, dz, dψ]) taken at heading *chi*: the
    step's horizontal displacement in the navigation frame, and its horizontal length in height."""
    c, s = math.cos(chi), math.sin(chi)
    j = np.zeros((4, 2))
    j[0, 0] = c * dx[0] - s * dx[1]
    j[1, 0] = s * dx[0] + c * dx[1]
    j[2, 1] = math.hypot(dx[0], dx[1])
    return j


#: The emulated MIMU22BT's priors: the method-of-moments estimate on 20 simulated modules each of
#: the straight walk and the rectangle (the default route's stairs excluded: their shared error is
#: the gait model's, docs/accuracy.md), σ² = Σ(e² − P) / Σ d² pooled over the walks, e the end
#: error along the displacement (scale) or in height (climb) and P its summed 1σ².
EMULATED_MODULE = ModuleErrors(step_scale_sigma=0.00102, climb_sigma=0.00168)
