"""The aid states a tracker's filter holds, registered by name, each with its prior.

Every tracker of :mod:`hostlib.fusion` appends, after its poses and its modules' errors, the aid
states its :class:`~hostlib.fusion.settings.FusionSettings` hold, in the order of
:data:`AID_STATES`:

* ``"gps_bias"`` — the receiver's correlated error ``[b_n, b_e]`` (:mod:`hostlib.fusion.gps_bias`),
  held with :attr:`~hostlib.fusion.settings.FusionSettings.gps_bias`; prior 0 with the
  stationary variance on each axis;
* ``"hard_iron"`` — the shoe's hard iron ``[b_x, b_y, b_z]`` in the board's frame
  (:mod:`hostlib.fusion.hard_iron`), held with
  :attr:`~hostlib.fusion.settings.FusionSettings.hard_iron`; prior 0 with σ_b² on each axis;
* ``"swing"`` — a calibrated compass's swing ``[B, C]`` (:mod:`hostlib.fusion.compass_swing`), held
  with the compass and :attr:`~hostlib.fusion.settings.FusionSettings.compass_swing` but not with
  the hard iron; prior 0 with σ² on each term (used only while the compass reads calibrated); a
  consider block when the swing is not learned (:attr:`~hostlib.fusion.compass_swing.CompassSwing.learned`);
* ``"dip"`` — the levelled field's inclination offset and local deviation ``[o, d_I]``
  (:mod:`hostlib.fusion.compass_dip`), held with a swing learned from the dip; prior 0 with their σ²;
* ``"deviation"`` — the compass's local deviation ``d`` (:mod:`hostlib.fusion.deviation`), held
  with :attr:`~hostlib.fusion.settings.FusionSettings.compass_deviation`; prior 0 with σ_d²;
* ``"declination"`` — the declination ``D``, always held, last: prior the settings' D₀, with
  σ_D² while both the compass and GPS make it observable, else 0 (a constant).

An aid with a state of its own adds one :class:`AidState` here (its name, whether the settings hold
it, its prior) and uses the block by its name in the filter (:class:`~hostlib.fusion.core.StateFilter`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .compass_dip import dip_prior
from .core import StateFilter

if TYPE_CHECKING:
    from .settings import FusionSettings

__all__ = ["AID_STATES", "AidState", "add_aid_states"]


@dataclass(frozen=True)
class AidState:
    """One aid's state block: its *name* in the filter and its prior under some settings
    (None: the settings do not hold it)."""

    name: str
    prior: Callable[[FusionSettings], tuple[np.ndarray, np.ndarray] | None]
    #: whether the settings hold it as a consider block (:class:`~hostlib.fusion.core.StateFilter`)
    considered: Callable[[FusionSettings], bool] = lambda settings: False


def _gps_bias_prior(s: FusionSettings) -> tuple[np.ndarray, np.ndarray] | None:
    if s.gps_bias is None:
        return None
    return np.zeros(2), s.gps_bias.variance * np.eye(2)


def _hard_iron_prior(s: FusionSettings) -> tuple[np.ndarray, np.ndarray] | None:
    if s.hard_iron is None:
        return None
    return np.zeros(3), s.hard_iron.variance * np.eye(3)


def _swing_prior(s: FusionSettings) -> tuple[np.ndarray, np.ndarray] | None:
    if s.compass_swing is None or not s.compass or s.hard_iron is not None:
        return None
    return np.zeros(2), s.compass_swing.variance * np.eye(2)


def _deviation_prior(s: FusionSettings) -> tuple[np.ndarray, np.ndarray] | None:
    if s.compass_deviation is None:
        return None
    return np.zeros(1), np.array([[s.compass_deviation.variance]])


def _declination_prior(s: FusionSettings) -> tuple[np.ndarray, np.ndarray]:
    variance = s.declination_sigma_rad ** 2 if (s.gps and s.compass) else 0.0
    return np.array([float(s.declination_rad)]), np.array([[variance]])


#: The aid states in the order a filter holds them, after the poses and the modules' errors.
AID_STATES: tuple[AidState, ...] = (
    AidState("gps_bias", _gps_bias_prior),
    AidState("hard_iron", _hard_iron_prior),
    AidState("swing", _swing_prior, lambda s: s.compass_swing is not None and not s.compass_swing.learned),
    AidState("dip", dip_prior),
    AidState("deviation", _deviation_prior),
    AidState("declination", _declination_prior),
)


def add_aid_states(core: StateFilter, settings: FusionSettings) -> None:
    """Append to *core* every aid state *settings* hold, with its prior."""
    for state in AID_STATES:
        prior = state.prior(settings)
        if prior is not None:
            core.add_block(state.name, *prior, consider=state.considered(settings))
