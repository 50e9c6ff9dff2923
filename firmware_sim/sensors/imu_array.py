"""The MIMU22BT's four MPU9150s on a moving foot: a simulated :class:`SensorSource`.

:class:`SimulatedSource` samples a foot trajectory (a scenario of
:mod:`.scenarios`) at the module's loop rate and turns it into the raw
registers of the four chips, all sampled at the same instant t_k = k / rate:

1. ground truth at the board centre (:class:`~.truth.GroundTruth`);
2. per chip i at lever arm r_i (``board.MIMU22BT``): specific force
   f_b + ω×(ω×r_i) + α×r_i and angular rate ω_b, turned into the chip's raw
   axes by ``mounting[i]`` — the motion is evaluated earlier by the part of
   the DLPF delay the filter itself does not produce (:func:`.mpu9150.dlpf_delays`);
3. the chip's error model and noise (:mod:`.mpu9150`), the DLPF one-pole,
   round-to-nearest and int16 saturation (a running heel strike clips at ±16 g);
4. die temperature (a warm-up) in the temperature register;
5. the AK8975: Earth + building + shoe field (:mod:`.magnetic`) in the
   magnetometer's axes, new every 1/100 s and held in between, ±4095.

Everything is computed once, in numpy, when the source is made (or when
``set_dlpf`` changes the filter); ``read(index)`` hands out views.

Two generators, each drawn from in a fixed order:

* the **module's** (:func:`module_rng`, from its identity ``module``): what
  belongs to the device and stays with it from walk to walk (turn-on offsets,
  scale and cross-axis, misalignment, g-sensitivity, temperature coefficients,
  the shoe's iron);
* the **walk's** (``numpy.random.default_rng(seed)``): noise, in-run drift and
  bias instability, the heel strikes' ringing, the building's field.

Without a module number the module is the seed's own (``module = seed``), so
each seed is a new module. The same (scenario, config, seed, module, rate)
gives the same registers bit for bit. Past the end of the scenario ``read``
returns None.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from firmware_sim.board import MIMU22BT, BoardGeometry
from firmware_sim.mcu.imu_bus import RawSample

from .config import DEFAULT_CONFIG, G0, SensorConfig
from .feet import SIDES, foot_module, foot_seed
from .gait import WALKING, GaitParams, Trajectory, stance_sway_on
from .impacts import ringing
from .magnetic import MagneticWorld
from .mpu9150 import ChipErrors, dlpf_delays, dlpf_filter, gauss_markov, white_sigma
from .registers import INT16_MAX, INT16_MIN, accel_to_lsb, gyro_to_lsb, mag_to_lsb, temp_to_lsb
from .replay import Recording
from .scenarios import environment, feet, list_scenarios, trajectory
from .truth import GroundTruth, Kinematics, cross, rotate

__all__ = ["SimulatedSource", "make_feet_sources", "make_foot_source", "make_source", "list_scenarios",
           "module_rng"]

#: Mixed into the seed of a module's generator, so that module N and walk seed N draw apart.
_MODULE_STREAM = 0x4D4F44  # "MOD"
#: Mixed into the seed of a shared building's generator (:class:`SimulatedSource`'s *building_seed*).
_BUILDING_STREAM = 0x424C44  # "BLD"


def module_rng(module: int) -> np.random.Generator:
    """The generator of module *module*'s own errors (the same for every walk of that module)."""
    return np.random.default_rng([_MODULE_STREAM, int(module)])


class SimulatedSource:
    """Raw registers of the 4-IMU array on a simulated foot (see the module docstring).

    Attributes: ``rate_hz``, ``seed`` (the walk's), ``module`` (the module's
    identity), ``truth`` (:class:`GroundTruth` at the sample times), ``imu``
    int16 (n, 4, 6), ``temp`` int16 (n, 4), ``mag`` int16 (n, 4, 3), ``chips``
    the module's :class:`ChipErrors`, ``clipped`` the number of saturated
    accelerometer/gyro registers, ``magnetic`` the :class:`MagneticWorld`.

    *building_seed* (None: the walk's own *seed*) draws the building's magnetic field instead,
    so that two walks share one building: both feet of a walker do.

    *stance_sway*: the foot turns a little in every walking stance (:class:`~.gait.StanceSway`,
    drawn from the walk's *seed* on its own stream; a trajectory that already sways keeps its own);
    None: :data:`~.gait.STANCE_SWAY_DEFAULT`.
    """

    def __init__(self, motion: Trajectory | str = "default", config: SensorConfig | None = None,
                 seed: int = 0, rate_hz: float = 1000.0, geometry: BoardGeometry = MIMU22BT,
                 params: GaitParams = WALKING, module: int | None = None, building_seed: int | None = None,
                 stance_sway: bool | None = None):
        self.config = config or DEFAULT_CONFIG
        if isinstance(motion, str) and environment(motion).outdoors:
            self.config = replace(self.config, mag=self.config.mag.outdoors())
        self.name = motion if isinstance(motion, str) else "<trajectory>"
        self.trajectory = trajectory(motion, params) if isinstance(motion, str) else motion
        if stance_sway_on(stance_sway) and self.trajectory.stance_sway is None:
            self.trajectory = self.trajectory.with_stance_sway(seed)
        self.seed = seed
        self.module = seed if module is None else int(module)
        self.rate_hz = float(rate_hz)
        #: The simulated sensor, as a sensor profile's name: the module's own array.
        self.sensor = "mimu22bt"
        self.geometry = geometry
        cfg = self.config
        self.truth: GroundTruth = self.trajectory.sample(self.rate_hz, gravity=cfg.gravity)
        n, chips = len(self.truth), geometry.mounting.shape[0]
        t = self.truth.t

        # --- every random draw, in a fixed order ---------------------------------------------
        device = module_rng(self.module)
        self.chips = [ChipErrors.draw(device, cfg) for _ in range(chips)]
        rng = np.random.default_rng(seed)
        self.magnetic = MagneticWorld.draw(rng, device, cfg)
        if building_seed is not None:  # another walk's building (the walker's, on a foot)
            building = np.random.default_rng([_BUILDING_STREAM, int(building_seed)])
            self.magnetic = self.magnetic.in_building(building, cfg)
        sa = white_sigma(cfg.accel.noise_density_g, self.rate_hz) if cfg.noise else 0.0
        sg = white_sigma(cfg.gyro.noise_density_rad_s, self.rate_hz) if cfg.noise else 0.0
        sm = cfg.mag.noise_ut if cfg.noise else 0.0
        noise_acc = rng.standard_normal((n, chips, 3)) * sa
        noise_gyro = rng.standard_normal((n, chips, 3)) * sg
        rw_a = cfg.accel.bias_random_walk_g_per_sqrt_s if cfg.drift else 0.0
        rw_g = cfg.gyro.bias_random_walk_rad_s_per_sqrt_s if cfg.drift else 0.0
        step = np.sqrt(1.0 / self.rate_hz)
        # random part of each register before the DLPF: white noise + bias random walk
        noise_acc += np.cumsum(rng.standard_normal((n, chips, 3)) * (rw_a * step), axis=0)
        noise_gyro += np.cumsum(rng.standard_normal((n, chips, 3)) * (rw_g * step), axis=0)
        # + bias instability (first-order Gauss–Markov)
        gm_a = gauss_markov(rng, (n, chips, 3), cfg.accel.bias_instability_g, cfg.accel.bias_correlation_s,
                            self.rate_hz)
        gm_g = gauss_markov(rng, (n, chips, 3), cfg.gyro.bias_instability_rad_s, cfg.gyro.bias_correlation_s,
                            self.rate_hz)
        if cfg.drift:
            noise_acc += gm_a
            noise_gyro += gm_g
        self._random_acc, self._random_gyro = noise_acc, noise_gyro

        # --- temperature ----------------------------------------------------------------------
        tc = cfg.temperature
        warm = tc.ambient_c + tc.warmup_c * (1.0 - np.exp(-(t + tc.powered_s) / tc.warmup_tau_s))
        self.die_temp_c = warm[:, None] + np.array([c.temp_offset_c for c in self.chips])[None, :]
        self.temp = temp_to_lsb(self.die_temp_c, cfg)

        # --- magnetometer: sampled at its own rate, held in between ----------------------------
        mag_rate = min(cfg.mag.rate_hz, self.rate_hz)
        held = np.floor(np.floor(t * mag_rate + 1e-9) / mag_rate * self.rate_hz + 1e-6).astype(np.int64)
        updates, which = np.unique(np.clip(held, 0, n - 1), return_inverse=True)
        field_b = self.magnetic.board_field(self.truth.pos[updates], self.truth.R[updates])  # µT
        noise_mag = rng.standard_normal((len(updates), chips, 3)) * sm
        axes = np.asarray(cfg.mag.axes, dtype=float)
        mount = geometry.mounting.astype(float)
        field_chip = np.stack([rotate(axes @ m, field_b) for m in mount], axis=1) + noise_mag
        self.mag = mag_to_lsb(field_chip, cfg)[which]

        # --- the board's ringing after each heel strike (drawn last: it came last) ------------
        self._ringing = ringing(rng, t, self.truth.stance_start[1:], cfg)

        self.dlpf_cfg = cfg.dlpf.cfg
        self._build_imu()

    # -------------------------------------------------------------------------------------------

    def __repr__(self) -> str:
        return (f"SimulatedSource({self.name!r}, seed={self.seed}, module={self.module}, "
                f"rate_hz={self.rate_hz:g}, samples={len(self)}, dlpf_cfg={self.dlpf_cfg})")

    def __len__(self) -> int:
        return len(self.imu)

    def _kinematics(self, delay: float) -> Kinematics:
        if delay == 0.0:
            return self.truth.kinematics
        return self.trajectory.evaluate(self.truth.t - delay, gravity=self.config.gravity)

    def chip_motion(self, delay_acc: float = 0.0, delay_gyro: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Error-free chip signals: specific force [m/s²] and rate [rad/s], (n, chips, 3), chip axes.

        Includes each chip's lever-arm acceleration ω×(ω×r) + α×r.
        """
        ka, kg = self._kinematics(delay_acc), self._kinematics(delay_gyro)
        r = self.geometry.lever_arms[None, :, :]  # (1, chips, 3)
        w = ka.omega_b[:, None, :]
        al = ka.alpha_b[:, None, :]
        f = ka.f_b[:, None, :] + cross(w, cross(w, r)) + cross(al, r)
        mount = self.geometry.mounting.astype(float)
        f_chip = np.stack([rotate(m, f[:, k]) for k, m in enumerate(mount)], axis=1)
        w_chip = np.stack([rotate(m, kg.omega_b) for m in mount], axis=1)
        return f_chip, w_chip

    def _build_imu(self) -> None:
        cfg = self.config
        d_acc, d_gyro = dlpf_delays(cfg, self.dlpf_cfg, self.rate_hz)
        f_chip, w_chip = self.chip_motion(d_acc, d_gyro)
        a_true = f_chip / G0
        if cfg.impacts:
            ring_acc, ring_gyro = self._ringing
            mount = self.geometry.mounting.astype(float)
            for k, m in enumerate(mount):
                a_true[:, k] += rotate(m, ring_acc)
                w_chip[:, k] += rotate(m, ring_gyro)
        dtemp = self.die_temp_c - cfg.temperature.reference_c
        acc = np.empty_like(a_true)
        gyro = np.empty_like(w_chip)
        for k, chip in enumerate(self.chips):
            acc[:, k] = chip.apply_accel(a_true[:, k], dtemp[:, k])
            gyro[:, k] = chip.apply_gyro(w_chip[:, k], dtemp[:, k], a_true[:, k])
        acc += self._random_acc
        gyro += self._random_gyro
        if cfg.dlpf.enabled and not cfg.dlpf.delays_only:
            acc = dlpf_filter(acc, cfg.dlpf.accel_bandwidth_hz[self.dlpf_cfg], self.rate_hz)
            gyro = dlpf_filter(gyro, cfg.dlpf.gyro_bandwidth_hz[self.dlpf_cfg], self.rate_hz)
        imu = np.empty(acc.shape[:2] + (6,), dtype=np.int16)
        imu[..., :3] = accel_to_lsb(acc, cfg)
        imu[..., 3:] = gyro_to_lsb(gyro, cfg)
        self.imu = imu
        self.clipped = int(np.count_nonzero((imu == INT16_MAX) | (imu == INT16_MIN)))

    def to_recording(self) -> Recording:
        """The error-free board-centre signals as a :class:`Recording` (board frame, g, rad/s, gauss).

        With :func:`.replay.save_csv` this writes a simulated walk in our CSV
        format, e.g. to feed other tools or to replay it at another rate.
        """
        field_b = self.magnetic.board_field(self.truth.pos, self.truth.R) / 100.0  # µT → gauss
        return Recording(t=self.truth.t.copy(), acc_g=self.truth.f_b / G0, gyro=self.truth.omega_b.copy(),
                         mag=field_b, rate_hz=self.rate_hz, path=None, format="simulated")

    # --- SensorSource ------------------------------------------------------------------------

    def read(self, index: int) -> RawSample | None:
        if index < 0:
            raise IndexError(f"sample index must be ≥ 0, got {index}")
        if index >= len(self.imu):
            return None
        return RawSample(self.imu[index], self.temp[index], self.mag[index])

    def set_dlpf(self, cfg: int) -> None:
        """Apply DLPF_CFG 0..6: the registers are recomputed with that filter (same noise draws)."""
        if not 0 <= cfg <= 6:
            raise ValueError(f"DLPF_CFG must be 0..6, got {cfg}")
        if cfg != self.dlpf_cfg:
            self.dlpf_cfg = cfg
            self._build_imu()


def make_source(scenario: str = "default", seed: int = 0, rate_hz: float = 1000.0,
                config: SensorConfig | None = None, geometry: BoardGeometry = MIMU22BT,
                module: int | None = None, stance_sway: bool | None = None) -> SimulatedSource:
    """A simulated 4-IMU source for a named scenario (``list_scenarios()``) or a recipe.

    *seed* draws the walk (noise, drift, ringing, the stance sway); *module* is the module's
    identity, which draws its own systematic errors (None: the seed's own, so
    each seed is a new module). *stance_sway*: the foot turns a little in every walking stance
    (:class:`~.gait.StanceSway`; None: :data:`~.gait.STANCE_SWAY_DEFAULT`).
    """
    return SimulatedSource(scenario, config=config, seed=seed, rate_hz=rate_hz, geometry=geometry,
                           module=module, stance_sway=stance_sway)


def make_foot_source(scenario: str, side: str, seed: int = 0, rate_hz: float = 1000.0,
                     config: SensorConfig | None = None, geometry: BoardGeometry = MIMU22BT,
                     module: int | None = None, walker_seed: int | None = None,
                     stance_sway: bool | None = None) -> SimulatedSource:
    """The module on the *side* foot of a walker walking *scenario* (:func:`.scenarios.feet`).

    *seed* draws this foot's walk and *module* is this module's identity (None: the seed's own),
    and *stance_sway* sways its walking stances, as in :func:`make_source`;
    :func:`make_feet_sources` gives both feet of a walker their own.
    *walker_seed* draws the building's magnetic field, which both feet of that walker walk
    through (None: the foot's own). The scenario's environment (outdoors or not) applies.
    """
    config = config or DEFAULT_CONFIG
    if environment(scenario).outdoors:
        config = replace(config, mag=config.mag.outdoors())
    source = SimulatedSource(feet(scenario).foot(side), config=config, seed=seed, rate_hz=rate_hz,
                             geometry=geometry, module=module, building_seed=walker_seed,
                             stance_sway=stance_sway)
    source.name = f"{scenario} ({side} foot)"
    return source


def make_feet_sources(scenario: str = "default", seed: int = 0, rate_hz: float = 1000.0,
                      config: SensorConfig | None = None, geometry: BoardGeometry = MIMU22BT,
                      walker: int | None = None, stance_sway: bool | None = None
                      ) -> dict[str, SimulatedSource]:
    """A module on each foot of one walker walking *scenario* (:func:`make_foot_source`): side →
    source, :data:`~.feet.SIDES` order.

    Each foot's module draws its own walk (and stance sway, *stance_sway* as in :func:`make_source`)
    from :func:`~.feet.foot_seed` (*seed*, side) and, with *walker*, is module
    :func:`~.feet.foot_module` (*walker*, side) (None: each seed's own); both walk through the one
    building *seed* draws.
    """
    return {side: make_foot_source(scenario, side, seed=foot_seed(seed, side), rate_hz=rate_hz,
                                   config=config, geometry=geometry,
                                   module=None if walker is None else foot_module(walker, side),
                                   walker_seed=seed, stance_sway=stance_sway)
            for side in SIDES}
