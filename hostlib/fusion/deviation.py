"""The local magnetic deviation as a state of the host's filter: correlated over the distance walked.

A per-step compass reading is the true heading less the declination D, less the local deviation
d(p) of the field where the foot stands, plus the compass's own error (the chips' noise, the
attitude at the end of stance). The deviation is not white: it is a property of the place, so two
readings a step apart carry almost the same d, and thirty readings over one patch of deviation are
worth about one. Taken as white noise (:attr:`hostlib.fusion.tracker.FusionSettings.compass_sigma_rad`
alone) they make the filter too sure of its heading, and two feet a step apart read the same d
twice.

:class:`CompassDeviation` models d as a first-order Gauss–Markov process in the distance walked:
over a step of horizontal length Δs,

    d ← φ d,   var d ← φ² var d + (1 − φ²) σ_d²,   φ = exp(−Δs / ℓ),

stationary with variance σ_d², the correlation of two readings Δs apart exp(−Δs / ℓ). The filter
starts it at 0 with variance σ_d², and a compass reading then measures χ − D − d with only the
compass's own, white error (σ_c, e.g. :data:`WHITE_SIGMA_RAD`). Standing, the foot does not move
and d does not change: the resets while the wearer stands read the same d again.

The presets are the emulator's worlds (``firmware_sim.sensors.config.MagConfig``): a deviation
field whose horizontal part against the Earth's 15.5 µT gives the heading's σ, made of plane waves
about λ long. Along a walked line that field is correlated 0.5 at λ/4 and about 0 from λ/2 on; its
correlation integrates to ln 3 / 2π · λ ≈ 0.18 λ (measured on 400 simulated worlds: 0.18 λ). A
Gauss–Markov process with that integral length ℓ credits a long walk with as many independent
readings as the field gives (the variance of a long average is the same), so ℓ = 0.18 λ:

* :data:`OUTDOORS`: 0.8 µT per axis over λ = 50 m (pipes, cars, geology): atan(0.8 / 15.5) ≈ 3°,
  ℓ = 9 m;
* :data:`INDOORS`: 5 µT per axis over λ = 3 m (a building): about 20° (18.9° RMS at the foot's rests
  on the house walk), ℓ = 0.5 m — a step apart, nearly uncorrelated, as NavShoe found indoors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .gauss_markov import require_positive, transition

__all__ = ["INDOORS", "OUTDOORS", "WHITE_SIGMA_RAD", "CompassDeviation"]


@dataclass(frozen=True)
class CompassDeviation:
    """The local compass deviation d as a Gauss–Markov process in the distance walked (module
    docstring): its 1σ *sigma_rad* and its correlation length *length_m*."""

    #: σ_d: the deviation's RMS [rad]
    sigma_rad: float
    #: ℓ: two readings Δs apart are correlated exp(−Δs / ℓ) [m]
    length_m: float

    def __post_init__(self) -> None:
        require_positive(self, ("sigma_rad", "length_m"))

    @property
    def variance(self) -> float:
        """σ_d², the stationary (and initial) variance of d [rad²]."""
        return self.sigma_rad ** 2

    def transition(self, distance_m: float) -> tuple[float, float]:
        """(φ, q) over a walk of *distance_m* [m]: d ← φ d, var d ← φ² var d + q."""
        return transition(distance_m, self.length_m, self.variance)

    @classmethod
    def parse(cls, text: str) -> CompassDeviation:
        """The deviation a word or two numbers name: 'outdoors' (:data:`OUTDOORS`), 'indoors'
        (:data:`INDOORS`) or ``SIGMA_DEG,LENGTH_M`` (numbers > 0). A ValueError says what is expected
        otherwise."""
        presets = {"outdoors": OUTDOORS, "indoors": INDOORS}
        word = text.strip().lower()
        if word in presets:
            return presets[word]
        try:
            values = [float(v) for v in text.split(",")]
            if len(values) != 2:
                raise ValueError(f"{len(values)} numbers")
            return cls(math.radians(values[0]), values[1])
        except ValueError:
            raise ValueError(f"expected 'outdoors', 'indoors' or SIGMA_DEG,LENGTH_M (numbers > 0, e.g. "
                             f"3,50), got {text!r}") from None

    def describe(self) -> str:
        return f"σ {math.degrees(self.sigma_rad):g}° over {self.length_m:g} m"


#: Open ground, the emulator's outdoor deviation: 0.8 µT per axis against 15.5 µT, waves 50 m long.
OUTDOORS = CompassDeviation(math.radians(3.0), 9.0)
#: A building, the emulator's indoor deviation: 5 µT per axis against 15.5 µT, waves 3 m long.
INDOORS = CompassDeviation(math.radians(20.0), 0.5)
#: The compass's own error beyond the deviation, the σ_c to use with a deviation state: the chips'
#: noise, the attitude at the end of stance and the held 100 Hz samples, 1.4–1.5° RMS per reading
#: in the emulator (measured against the simulated deviation, outdoors and in the house).
WHITE_SIGMA_RAD = math.radians(1.5)
