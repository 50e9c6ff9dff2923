"""What the host's fusion filter applies and how much it trusts it (:class:`FusionSettings`), and what
the aids did (:class:`FusionStats`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..aids.declination import MagneticField
from ..calibration.magcal import MagCalibration
from ..track.rows import Rows
from .compass_swing import CompassSwing
from .deviation import CompassDeviation
from .gps_bias import GpsBias
from .hard_iron import HardIron
from .module_errors import ModuleErrors

__all__ = ["FusionSettings", "FusionStats"]


@dataclass(frozen=True)
class FusionSettings:
    """Which aids the :class:`FusionTracker` applies, and how much it trusts them."""

    #: per-step compass updates on
    compass: bool = False
    #: 1σ of one compass reading [rad]: the local deviation. Our default is indoor: the emulator's
    #: building deviation (5 µT RMS per axis against a 15.5 µT horizontal field) is ≈ 18°. With
    #: :attr:`compass_deviation` held, only the reading's own white error beyond the deviation (the
    #: chips' noise, the attitude): about 1.5° (:data:`hostlib.fusion.deviation.WHITE_SIGMA_RAD`)
    compass_sigma_rad: float = math.radians(20.0)
    #: "step": one update per step that moved the foot (NavShoe); "every-reset": at every reset,
    #: standing ones too (the continuous compass NavShoe warns against, kept for comparison)
    compass_mode: str = "step"
    #: a compass reading is used only if its innovation ν lies within this many σ of what the filter
    #: expects, |ν| ≤ g √(h P hᵀ + σ_c²): a reading that far out is a disturbance the model does not
    #: hold (steel, a magnet, an uncalibrated shoe's iron turned with the foot), not a heading. 3σ
    #: keeps 99.7 % of the readings the model describes. The field check takes as many σ of the
    #: field's magnitude and inclination (:attr:`magnetic_field`). None: every reading is used
    compass_gate_sigmas: float | None = 3.0
    #: the shoe's hard iron b [µT] as three states, learned while the module walks
    #: (:mod:`hostlib.fusion.hard_iron`: :data:`~hostlib.fusion.hard_iron.UNCALIBRATED`,
    #: :data:`~hostlib.fusion.hard_iron.CALIBRATED`; None: not held, the iron is the calibration's)
    hard_iron: HardIron | None = None
    #: a calibrated compass's swing B sin ψ + C cos ψ (what the calibration's iron and the level at
    #: the end of the stance leave) as two states, used while the compass reads with a calibration
    #: (:mod:`hostlib.fusion.compass_swing`: :data:`~hostlib.fusion.compass_swing.CALIBRATED_SWING`;
    #: None: not held; not with :attr:`hard_iron` held, which models the same)
    compass_swing: CompassSwing | None = None
    #: an uncompensated compass weighed for this unknown hard iron: with no :attr:`mag_calibration`
    #: and :attr:`hard_iron` not held, the local deviation's variance (or, not held, each reading's)
    #: gains atan(σ_b / H)² (:mod:`hostlib.fusion.compass_trust`); None: the readings weighed as if
    #: the iron were not there
    uncalibrated_iron: HardIron | None = None
    #: the Earth's field where the walk is (the World Magnetic Model at the first fix or the origin):
    #: each compass reading's magnitude and inclination are checked against it, and its horizontal
    #: intensity is the H an uncalibrated compass is weighed by (None: not known)
    magnetic_field: MagneticField | None = None
    #: the shoe's hard and soft iron, removed before the heading is taken
    mag_calibration: MagCalibration | None = None
    #: GPS updates on (fixes given with :meth:`FusionTracker.add_fixes` / :meth:`FusionTracker.add_fix`)
    gps: bool = False
    #: 1σ [m] of the receiver's horizontal error as specified (the emulator's: 3 m RMS)
    gps_receiver_sigma_m: float = 3.0
    #: 1σ [m] of a horizontal fix as a filter measurement: the receiver's σ inflated for the
    #: correlation of its errors (τ = 120 s: fixes an update interval apart are far from
    #: independent). 3 m · √(2τ / 10 s) ≈ 15 m (NavShoe: 20 m for a 6 m receiver). Not used with
    #: :attr:`gps_bias` held: a fix's σ is then its white part
    gps_sigma_m: float = 15.0
    #: seconds between GPS updates (fixes in between are skipped, counted); None: 10 s, what the
    #: inflated σ assumes, or with :attr:`gps_bias` held every fix (:attr:`gps_update_interval_s`)
    gps_interval_s: float | None = None
    #: added to every fix time [s] to put it on the module's clock
    gps_offset_s: float = 0.0
    #: without a compass, the GPS course aligns the heading after this distance [m] from the first fix
    gps_align_distance_m: float = 50.0
    #: the declination prior D₀ [rad] (east positive) and its 1σ while GPS is used
    declination_rad: float = 0.0
    declination_sigma_rad: float = math.radians(15.0)
    #: the module's step-length scale, climb and turn scale (and, with its prior, heading drift rate)
    #: as states (:mod:`hostlib.fusion.module_errors`; None: not held, and the covariance is the steps' own)
    module_errors: ModuleErrors | None = None
    #: the local compass deviation d as a state, correlated over the distance walked
    #: (:mod:`hostlib.fusion.deviation`: :data:`~hostlib.fusion.deviation.OUTDOORS`,
    #: :data:`~hostlib.fusion.deviation.INDOORS`;
    #: None: not held, each reading's deviation is in σ_c as white noise)
    compass_deviation: CompassDeviation | None = None
    #: the receiver's correlated error b as states, a Gauss–Markov process in time
    #: (:mod:`hostlib.fusion.gps_bias`; None: not held, a fix's error is white, of σ :attr:`gps_sigma_m`)
    gps_bias: GpsBias | None = None

    @property
    def gps_update_interval_s(self) -> float:
        """The seconds between GPS updates: :attr:`gps_interval_s` if given; else 10 s with the
        white model (the interval its inflated σ is worked out for) and 0 with :attr:`gps_bias`
        held: every fix, since the filter knows what fixes a second apart share, and each still
        brings its white part and the bias's news (two scalar updates a fix)."""
        if self.gps_interval_s is not None:
            return self.gps_interval_s
        return 10.0 if self.gps_bias is None else 0.0

    def __post_init__(self) -> None:
        if self.compass_mode not in ("step", "every-reset"):
            raise ValueError(f"compass_mode must be 'step' or 'every-reset', not {self.compass_mode!r}")
        for name in ("compass_sigma_rad", "gps_sigma_m", "gps_receiver_sigma_m", "gps_align_distance_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive")
        if self.compass_gate_sigmas is not None and not self.compass_gate_sigmas > 0:
            raise ValueError(f"compass_gate_sigmas must be > 0 (or None), not {self.compass_gate_sigmas}")
        if self.gps_interval_s is not None and not self.gps_interval_s >= 0:
            raise ValueError(f"gps_interval_s must be ≥ 0 s (or None), not {self.gps_interval_s}")


@dataclass
class FusionStats:
    """What the aids did."""

    compass_updates: int = 0
    compass_skipped: int = 0  #: readings not used (standing resets; no reading in the packet)
    #: readings refused: their heading is not a finite number (a packet's magnetometers or attitude
    #: held a NaN or an infinity); the filter is left as it was
    compass_refused: int = 0
    #: readings rejected by the innovation gate (:attr:`FusionSettings.compass_gate_sigmas`)
    compass_rejected: int = 0
    #: readings rejected by the field check: their magnitude or inclination is not the Earth's field
    #: (:mod:`hostlib.fusion.compass_trust`)
    compass_field_rejected: int = 0
    #: why the field check rejected its first reading ("" none)
    compass_field_first: str = ""
    #: readings whose dip taught the swing (:mod:`hostlib.fusion.compass_dip`), and those the gate rejected
    dip_updates: int = 0
    dip_rejected: int = 0
    gps_updates: int = 0
    gps_skipped: int = 0  #: fixes between updates (:attr:`FusionSettings.gps_update_interval_s`)
    gps_before_alignment: int = 0  #: fixes that arrived before the heading was aligned
    heading_aligned_by: str = ""  #: "compass", "gps" or "" (not aligned: the module's frame)
    #: rows (step index, innovation [rad]) of every compass update, for consistency checks (a
    #: :class:`~hostlib.track.rows.Rows` of 16 bytes each: one a step over a long walk)
    compass_innovations: Rows = field(default_factory=lambda: Rows((2,)))
