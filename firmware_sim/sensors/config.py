"""Every number the sensor simulation uses, in one documented, overridable place.

The figures marked *datasheet* are the MPU9150 / AK8975 datasheet facts of
``shared/spec/sensors.md`` (InvenSense PS-MPU-9150A, rev. 4.3); the others are
our documented choices (marked *choice*). Everything is a frozen dataclass, so a
variant is made with :func:`dataclasses.replace`, e.g.::

    cfg = replace(DEFAULT_CONFIG, accel=replace(DEFAULT_CONFIG.accel, noise_density_g=0.0))

:meth:`SensorConfig.ideal` (or :data:`IDEAL_CONFIG`) switches every sensor error
off at once: no offsets, scale or cross-axis errors, no noise, no temperature
dependence or drift, no magnetic disturbance, DLPF bypassed. What remains is the
exact specific force and angular rate of the trajectory (plus the lever arm of
each chip, which is geometry, not an error), quantised to the registers.

Units: accelerations in g (1 g = :data:`G0` m/s²) where the register is in g,
angular rates in rad/s, magnetic fields in µT, temperatures in °C, times in s.
Per-chip random quantities are bounds of a uniform draw (±bound) unless said
otherwise. A module's own errors (turn-on offsets, scale and cross-axis,
misalignment, g-sensitivity, temperature coefficients, shoe iron) are drawn from
the generator of its identity, the walk's (noise, drift, bias instability,
heel-strike ringing, the building's field) from the walk's seed; see
:mod:`.imu_array`. ``docs/sensor-errors.md`` gives the source of every figure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from protocol.board import AK8975_AXES, MAG_UT_PER_LSB

#: Standard gravity [m/s²] (the unit "g" of the accelerometer registers).
G0 = 9.80665

DEG = math.pi / 180.0


@dataclass(frozen=True)
class AccelConfig:
    """MPU9150 accelerometer (full scale ±16 g)."""

    lsb_per_g: float = 2048.0  #: datasheet, AFS_SEL = 3
    noise_density_g: float = 400e-6  #: datasheet, one-sided [g/√Hz]
    #: datasheet zero-g offset ±, chip x y z
    offset_bound_g: tuple[float, float, float] = (0.080, 0.080, 0.150)
    sensitivity_tol: float = 0.03  #: datasheet ±3 % scale error
    cross_axis: float = 0.02  #: datasheet ±2 % cross-axis sensitivity (off-diagonal of the scale matrix)
    offset_tempco_g_per_c: tuple[float, float, float] = (0.35e-3, 0.35e-3, 0.75e-3)  #: datasheet ± per °C
    sensitivity_tempco_per_c: float = 0.0002  #: datasheet ±0.02 %/°C
    bias_random_walk_g_per_sqrt_s: float = 20e-6  #: choice: in-run bias drift (random walk)
    #: choice: bias instability, a first-order Gauss–Markov process of this sd and correlation time
    #: (consumer MEMS accelerometers of the MPU-6000 family: tens of µg in Allan-variance analyses)
    bias_instability_g: float = 50e-6
    bias_correlation_s: float = 100.0  #: choice


@dataclass(frozen=True)
class GyroConfig:
    """MPU9150 gyroscope (full scale ±2000 °/s)."""

    lsb_per_dps: float = 16.4  #: datasheet, FS_SEL = 3
    noise_density_rad_s: float = 0.005 * DEG  #: datasheet 0.005 °/s/√Hz, one-sided
    offset_bound_rad_s: float = 20.0 * DEG  #: datasheet zero-rate offset ±20 °/s
    sensitivity_tol: float = 0.03  #: datasheet ±3 %
    cross_axis: float = 0.02  #: datasheet ±2 %
    #: choice: typical ±0.02 °/s/°C (the datasheet bound, ±20 °/s over −40..85 °C, is ±0.16 °/s/°C)
    offset_tempco_rad_s_per_c: float = 0.02 * DEG
    sensitivity_tempco_per_c: float = 0.0002  #: datasheet ±2 % over −40..85 °C ≈ ±0.02 %/°C (rounded)
    bias_random_walk_rad_s_per_sqrt_s: float = 0.0005 * DEG  #: choice: in-run bias drift (random walk)
    #: choice: bias instability, a first-order Gauss–Markov process of this sd and correlation time
    #: (≈ 18 °/h; Allan-variance analyses of MPU-6000-family gyros report 5–20 °/h)
    bias_instability_rad_s: float = 0.005 * DEG
    bias_correlation_s: float = 100.0  #: choice
    #: Sensitivity to linear acceleration [rad/s per g], ± bound of each element of the 3×3
    #: matrix G in ω += G·a. The datasheet gives 0.1 °/s/g typical (sensors.md); choice: elements
    #: within ±0.03 °/s/g, because 0.1 on every element gives twice the module paper's across-track
    #: spread on 100 m walks (docs/sensor-errors.md).
    g_sensitivity_rad_s_per_g: float = 0.03 * DEG


@dataclass(frozen=True)
class DlpfConfig:
    """MPU9150 digital low-pass filter, DLPF_CFG 0..6 (datasheet table).

    Our model (choice): each path is delayed by its datasheet delay and
    smoothed by a one-pole low-pass of the datasheet bandwidth, whose own
    low-frequency delay 1/(2π f_c) is taken out of the pure delay (never below
    zero). ``enabled=False`` bypasses the filter and every delay;
    ``delays_only=True`` keeps the datasheet delays but not the smoothing.
    """

    enabled: bool = True
    delays_only: bool = False
    cfg: int = 0  #: DLPF_CFG at power-on (SET_IMU_BANDWIDTH changes it)
    accel_bandwidth_hz: tuple[float, ...] = (260.0, 184.0, 94.0, 44.0, 21.0, 10.0, 5.0)
    gyro_bandwidth_hz: tuple[float, ...] = (256.0, 188.0, 98.0, 42.0, 20.0, 10.0, 5.0)
    accel_delay_s: tuple[float, ...] = (0.0, 2.0e-3, 3.0e-3, 4.9e-3, 8.5e-3, 13.8e-3, 19.0e-3)
    gyro_delay_s: tuple[float, ...] = (0.98e-3, 1.9e-3, 2.8e-3, 4.8e-3, 8.3e-3, 13.4e-3, 18.6e-3)


@dataclass(frozen=True)
class TemperatureConfig:
    """Die temperature: a warm-up from ambient toward a settled value."""

    lsb_per_c: float = 340.0  #: datasheet: T [°C] = raw/340 + 35
    offset_c: float = 35.0  #: datasheet
    ambient_c: float = 22.0  #: choice: temperature at power-on
    warmup_c: float = 8.0  #: choice: self-heating + foot warmth reached after warm-up
    warmup_tau_s: float = 120.0  #: choice: warm-up time constant
    #: how long the module has been on when the run starts [s]: 0, a power-on at the start (the
    #: default); several τ, a module already warm (walks one after another, as in the module paper)
    powered_s: float = 0.0
    chip_spread_c: float = 0.5  #: choice: ± per-chip offset of the die temperature
    reference_c: float = 25.0  #: datasheet: offsets/sensitivities are specified at 25 °C

    @property
    def settled_s(self) -> float:
        """How long a module has been on when it is warm [s]: five time constants of the warm-up
        (99.3 % of it done). Experiments that compare walks start their modules so (the module
        paper's walks came one after another)."""
        return 5.0 * self.warmup_tau_s


@dataclass(frozen=True)
class ImpactConfig:
    """Ringing of the board after each heel strike (choice, see docs/sensor-errors.md).

    A shoe sole and a small PCB ring when the heel lands: a damped oscillation
    of the whole board, the same for its four chips, in a direction drawn per
    strike. Peak sizes are those seen in recorded foot-mounted IMU data at heel
    strike (about 1 g of high-frequency content over the smooth motion, a few
    °/s); frequency and decay are a choice for a shoe-mounted board.
    """

    accel_g: float = 1.0  #: peak of the accelerometer ringing [g]
    gyro_rad_s: float = 5.0 * DEG  #: peak of the gyro ringing [rad/s]
    frequency_hz: float = 120.0
    decay_s: float = 0.012  #: time constant of the envelope


@dataclass(frozen=True)
class MagConfig:
    """AK8975 magnetometer inside each MPU9150, and the field it sees."""

    ut_per_lsb: float = MAG_UT_PER_LSB  #: datasheet
    full_scale_lsb: int = 4095  #: datasheet, 13 bit signed (±4095)
    rate_hz: float = 100.0  #: datasheet: up to 100 Hz; a new value is held until the next one
    noise_ut: float = 0.6  #: choice: rms noise per reading (≈ 2 LSB)
    #: Chip magnetometer axes from chip accelerometer/gyro axes (datasheet: the AK8975 die
    #: is turned: x_mag = y_acc, y_mag = x_acc, z_mag = −z_acc).
    axes: tuple[tuple[int, int, int], ...] = AK8975_AXES
    # Earth field at the walk (choice: Stockholm, WMM 2020 values rounded)
    intensity_ut: float = 51.5
    inclination_deg: float = 72.5  #: positive: field points down (northern hemisphere)
    declination_deg: float = 6.0  #: positive: magnetic north east of true north
    # Shoe distortion, in the board frame (choice: a steel shank and a battery)
    hard_iron_bound_ut: float = 4.0  #: ± per axis, drawn once per source
    soft_iron_bound: float = 0.05  #: ± per element of (I + S), drawn once per source
    #: Indoor deviation (Foxlin 2005): a smooth random field of this rms per axis, varying over
    #: ``indoor_length_m`` of walking (positions ≥ ``indoor_radius_m`` from the start are indoors).
    indoor_rms_ut: float = 5.0
    indoor_length_m: float = 3.0
    indoor_radius_m: float = 0.0  #: 0: the whole walk is indoors
    #: Outdoors (a scenario's :class:`~firmware_sim.sensors.scenarios.Environment`): the deviation
    #: of open ground — pipes, cars, geology — a few degrees varying over tens of metres (choice:
    #: 0.8 µT per axis against the 15.5 µT horizontal field ≈ 3°, over 50 m).
    outdoor_rms_ut: float = 0.8
    outdoor_length_m: float = 50.0

    def outdoors(self) -> MagConfig:
        """The same magnetometer and Earth field with the deviation of open ground."""
        return replace(self, indoor_rms_ut=self.outdoor_rms_ut, indoor_length_m=self.outdoor_length_m)


@dataclass(frozen=True)
class ArrayConfig:
    """How the four chips sit on the board, beyond the nominal mounting."""

    #: choice: ± per axis of each chip's small rotation from its nominal mounting, left after the
    #: array calibration (a soldered QFN package sits within a few tenths of a degree)
    misalignment_rad: float = 0.1 * DEG


#: Every error switch of :class:`SensorConfig`, off (the DLPF is switched separately).
_ERRORS_OFF = dict(offsets=False, scale_errors=False, noise=False, drift=False,
                   temperature_effects=False, mag_disturbance=False, g_sensitivity=False,
                   misalignment=False, impacts=False)


@dataclass(frozen=True)
class SensorConfig:
    """The whole sensor model: four MPU9150 chips sampled at the same instant."""

    accel: AccelConfig = field(default_factory=AccelConfig)
    gyro: GyroConfig = field(default_factory=GyroConfig)
    dlpf: DlpfConfig = field(default_factory=DlpfConfig)
    temperature: TemperatureConfig = field(default_factory=TemperatureConfig)
    mag: MagConfig = field(default_factory=MagConfig)
    impact: ImpactConfig = field(default_factory=ImpactConfig)
    array: ArrayConfig = field(default_factory=ArrayConfig)
    gravity: float = 9.81  #: [m/s²] local gravity of the simulated world (firmware.md uses 9.81)
    #: The module is calibrated at the factory, but the emulated firmware runs ideal calibration
    #: matrices (mounting only) and no static bias; so the chips carry only the *residual* errors
    #: left after calibration, as fractions of the datasheet's uncalibrated spreads.
    #: Offsets (choice: 2 %, e.g. gyro offsets within ±0.4 °/s, which BIASEST removes at rest):
    offset_residual: float = 0.02
    #: Sensitivity and cross-axis (choice: 15 %, i.e. ±0.45 % scale and ±0.3 % cross-axis: a
    #: six-position calibration leaves a few tenths of a percent; 15 % gives the module paper's
    #: spread of length errors on 100 m walks, docs/sensor-errors.md). 1.0 for both simulates
    #: raw, uncalibrated chips.
    scale_residual: float = 0.15
    #: Master switches, so the categories of error can be turned off one by one.
    offsets: bool = True  #: turn-on offsets (bias) of acc and gyro
    scale_errors: bool = True  #: sensitivity and cross-axis errors
    noise: bool = True  #: white noise of acc, gyro, magnetometer
    drift: bool = True  #: bias random walk
    temperature_effects: bool = True  #: temperature dependence of offsets and sensitivities
    mag_disturbance: bool = True  #: hard/soft iron and indoor deviation
    g_sensitivity: bool = True  #: gyro sensitivity to linear acceleration
    misalignment: bool = True  #: each chip's small rotation from its nominal mounting
    impacts: bool = True  #: board ringing after each heel strike

    @classmethod
    def ideal(cls, keep_delays: bool = False) -> SensorConfig:
        """Every sensor error off (geometry, quantisation and clipping remain).

        By default the DLPF is bypassed altogether: the registers hold the motion
        at the sampling instant. The firmware's READ_INERTIAL delays the
        accelerometer by one sample to match the gyro's ≈ 1 ms filter delay;
        ``keep_delays=True`` keeps the datasheet delays (without smoothing) so
        that an INS fed through that pipeline sees aligned signals.
        """
        return cls(dlpf=DlpfConfig(enabled=keep_delays, delays_only=True), **_ERRORS_OFF)

    def without_errors(self) -> SensorConfig:
        """This configuration with every sensor error switched off."""
        return replace(self, dlpf=replace(self.dlpf, enabled=False), **_ERRORS_OFF)

    def warm(self) -> SensorConfig:
        """This configuration with the module on for :attr:`TemperatureConfig.settled_s` when the run
        starts: its warm-up done (experiments that compare walks, as the module paper's walked one
        after another)."""
        return replace(self, temperature=replace(self.temperature, powered_s=self.temperature.settled_s))


DEFAULT_CONFIG = SensorConfig()
#: Every error off (:meth:`SensorConfig.ideal`).
IDEAL_CONFIG = SensorConfig.ideal()
