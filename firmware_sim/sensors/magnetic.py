"""The magnetic field the AK8975s see: Earth, building, shoe.

* Earth: a constant field in the navigation frame (NED) of the configured
  intensity F, inclination I (positive down) and declination D (positive
  east): m_n = F (cos I cos D, cos I sin D, sin I).
* Building (Foxlin 2005: indoor heading errors of tens of degrees): a smooth
  random deviation field d(p) added in the navigation frame, a sum of J plane
  waves Σ a_j cos(k_j·p + φ_j) with |k_j| around 2π/ℓ (ℓ = ``indoor_length_m``)
  and amplitudes so that each axis has the configured rms. Points closer than
  ``indoor_radius_m`` to the start are outdoors (no deviation).
* Shoe: soft iron (a matrix I + S) and hard iron (a constant vector h) in the
  board frame: m_b = (I + S) Rᵀ (m_n + d(p)) + h.

The building's field is drawn once per walk (from the walk's seed; both feet of one walker share
the walker's), the shoe's iron once per module (from its identity).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .config import DEG, SensorConfig
from .truth import mul_transposed

__all__ = ["earth_field_ned", "MagneticWorld"]

_MODES = 12


def earth_field_ned(config: SensorConfig) -> np.ndarray:
    """The Earth's field in NED [µT]."""
    m = config.mag
    inc, dec = m.inclination_deg * DEG, m.declination_deg * DEG
    return m.intensity_ut * np.array([np.cos(inc) * np.cos(dec), np.cos(inc) * np.sin(dec), np.sin(inc)])


@dataclass(frozen=True, eq=False)
class MagneticWorld:
    """Earth + indoor deviation + shoe iron, fixed for one simulated walk."""

    earth_ned: np.ndarray  #: (3,) µT
    wave_vectors: np.ndarray  #: (J, 3) rad/m
    wave_amplitudes: np.ndarray  #: (J, 3) µT
    wave_phases: np.ndarray  #: (J,)
    soft_iron: np.ndarray  #: (3, 3) I + S
    hard_iron: np.ndarray  #: (3,) µT, board frame
    indoor_radius_m: float = 0.0

    @classmethod
    def draw(cls, rng: np.random.Generator, device: np.random.Generator,
             config: SensorConfig) -> MagneticWorld:
        """The building's field from the walk's generator *rng*, the shoe's iron from the
        module's own generator *device* (the module is fixed in its shoe)."""
        m = config.mag
        k, amp, phase = _building(rng, config)
        soft = np.eye(3) + device.uniform(-1, 1, (3, 3)) * m.soft_iron_bound
        hard = device.uniform(-1, 1, 3) * m.hard_iron_bound_ut
        if not config.mag_disturbance:
            soft = np.eye(3)
            hard = np.zeros(3)
        return cls(earth_field_ned(config), k, amp, phase, soft, hard, m.indoor_radius_m)

    def in_building(self, rng: np.random.Generator, config: SensorConfig) -> MagneticWorld:
        """The same shoe in another building's field, drawn from *rng*: how both feet of one
        walker see one building (each foot's walk draws its noise from its own seed, the
        building from the walker's)."""
        k, amp, phase = _building(rng, config)
        return replace(self, wave_vectors=k, wave_amplitudes=amp, wave_phases=phase)

    def deviation_ned(self, pos: np.ndarray) -> np.ndarray:
        """Indoor deviation at NED positions (n, 3) [µT]."""
        arg = pos @ self.wave_vectors.T + self.wave_phases  # (n, J)
        d = np.cos(arg) @ self.wave_amplitudes
        if self.indoor_radius_m > 0:
            d *= (np.linalg.norm(pos, axis=1) >= self.indoor_radius_m)[:, None]
        return d

    def heading_deviation(self, pos: np.ndarray) -> np.ndarray:
        """The compass heading error [rad] the indoor deviation makes at NED positions (n, 3): the
        direction of the horizontal field there minus the Earth's (east positive, in −π..π). A level
        compass free of the shoe's iron reads the true heading minus the declination minus this."""
        m = self.earth_ned + self.deviation_ned(np.atleast_2d(pos))
        error = np.arctan2(m[:, 1], m[:, 0]) - np.arctan2(self.earth_ned[1], self.earth_ned[0])
        return (error + np.pi) % (2 * np.pi) - np.pi

    def board_field(self, pos: np.ndarray, R: np.ndarray) -> np.ndarray:
        """Field in the board frame [µT] at positions (n, 3) with attitudes R (n, 3, 3)."""
        m_n = self.earth_ned + self.deviation_ned(pos)
        m_b = mul_transposed(R, m_n)
        return m_b @ self.soft_iron.T + self.hard_iron


def _building(rng: np.random.Generator, config: SensorConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A building's deviation field: the wave vectors (J, 3), amplitudes (J, 3) and phases (J,)
    (zero amplitudes without ``mag_disturbance``; the draws are the same either way)."""
    m = config.mag
    direction = rng.normal(size=(_MODES, 3))
    direction[:, 2] *= 0.3  # buildings vary mostly along the floor
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    k = direction * (2 * np.pi / m.indoor_length_m) * rng.uniform(0.5, 1.5, (_MODES, 1))
    amp = rng.normal(size=(_MODES, 3)) * m.indoor_rms_ut * np.sqrt(2.0 / _MODES)
    phase = rng.uniform(0, 2 * np.pi, _MODES)
    if not config.mag_disturbance:
        amp = np.zeros_like(amp)
    return k, amp, phase
