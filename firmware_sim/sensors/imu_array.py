"""The MIMU22BT's four MPU9150s on a moving foot: a simulated :class:`~firmware_sim.mcu.imu_bus.SensorSource`.

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

Everything is computed in numpy when the source is made; ``read(index)`` hands
out views. A DLPF setting other than the one the walk was made at (``set_dlpf``:
a host's SET_IMU_BANDWIDTH) costs nothing when it is set: its registers are
computed when first read, a block of :data:`CHUNK_S` of samples at a time, from
the filter's lead-in before the block (:func:`.mpu9150.dlpf_reach`) — bit for bit
the registers the whole walk computed at that setting holds there, whichever
sample the setting came at and whatever settings came before. So a module never
waits on a whole walk's recomputation while a host waits on the module, and the
walk holds one whole record of registers, not one per setting.

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

from collections import OrderedDict
from dataclasses import replace

import numpy as np

from firmware_sim.board import MIMU22BT, BoardGeometry
from firmware_sim.mcu.imu_bus import RawSample

from .config import DEFAULT_CONFIG, G0, SensorConfig
from .feet import SIDES, foot_module, foot_seed
from .gait import WALKING, GaitParams, Trajectory
from .impacts import ringing
from .magnetic import MagneticWorld
from .mpu9150 import ChipErrors, dlpf_delays, dlpf_filter, dlpf_reach, gauss_markov, white_sigma
from .registers import (
    INT16_MAX,
    INT16_MIN,
    accel_counts,
    gyro_counts,
    mag_to_lsb,
    saturate_int16,
    temp_to_lsb,
)
from .replay import Recording
from .scenarios import environment, feet, list_scenarios, trajectory
from .stance_sway import stance_sway_on
from .truth import GroundTruth, cross_rows, rotate, rotation

__all__ = ["CHUNK_S", "MAX_SAMPLES", "SimulatedSource", "make_feet_sources", "make_foot_source",
           "make_source", "list_scenarios", "module_rng"]

#: Mixed into the seed of a module's generator, so that module N and walk seed N draw apart.
_MODULE_STREAM = 0x4D4F44  # "MOD"
#: Mixed into the seed of a shared building's generator (:class:`SimulatedSource`'s *building_seed*).
_BUILDING_STREAM = 0x424C44  # "BLD"

#: The span [s] of samples whose registers a walk computes at once at a DLPF setting other than
#: the one it was made at (plus the filter's lead-in before them, at most 2047 samples at 1 kHz):
#: a few ms of one main loop, once per block.
CHUNK_S = 0.1
#: The most samples a simulated walk holds (ground truth and registers, about 1.5 kB each): the
#: longest scenario (:data:`~.recipes.MAX_DURATION_S`) at 1 kHz, or the built-in route at 10 kHz.
MAX_SAMPLES = 2_000_000
#: Samples whose registers the whole record computes at once (the DLPF's lead-in carried from one
#: block to the next): a block's temporaries stay in the processor's cache, and their memory is
#: used again.
_BLOCK = 8192
#: Blocks of registers a walk keeps at other settings (the last read ones, 4.8 kB each at 1 kHz):
#: a host that switches among the settings within a block finds them all computed.
_CHUNKS_KEPT = 16


def module_rng(module: int) -> np.random.Generator:
    """The generator of module *module*'s own errors (the same for every walk of that module)."""
    return np.random.default_rng([_MODULE_STREAM, int(module)])


class SimulatedSource:
    """Raw registers of the 4-IMU array on a simulated foot (see the module docstring).

    Attributes: ``rate_hz``, ``seed`` (the walk's), ``module`` (the module's
    identity), ``truth`` (:class:`GroundTruth` at the sample times), ``imu``
    int16 (n, 4, 6) the whole record at the current DLPF setting, ``temp`` int16
    (n, 4), ``mag`` int16 (n, 4, 3), ``chips`` the module's :class:`ChipErrors`,
    ``clipped`` the number of saturated accelerometer/gyro registers in the whole
    record last computed, ``magnetic`` the :class:`MagneticWorld`,
    ``computed_samples`` how many samples' registers were computed so far (at any
    setting, lead-ins included).

    ``read`` and ``imu_block`` at a setting other than the whole record's compute
    it by blocks (module docstring); ``imu`` computes the whole record at the
    current setting when asked (it then replaces the one held).

    *building_seed* (None: the walk's own *seed*) draws the building's magnetic field instead,
    so that two walks share one building: both feet of a walker do.

    *stance_sway*: the foot turns a little in every walking stance (:class:`~.stance_sway.StanceSway`,
    drawn from the walk's *seed* on its own stream; a trajectory that already sways keeps its own);
    None: :data:`~.stance_sway.STANCE_SWAY_DEFAULT`.
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
        self._mounted = [rotation(m) for m in geometry.mounting.astype(float)]  # board → chip i's axes
        cfg = self.config
        samples = self.trajectory.duration * self.rate_hz
        if not samples <= MAX_SAMPLES:
            raise ValueError(f"a walk of {self.trajectory.duration:.0f} s at {self.rate_hz:g} Hz is "
                             f"{samples:.3g} samples: at most {MAX_SAMPLES:.3g} (a shorter scenario or a "
                             "lower rate)")
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
        noise_acc = rng.standard_normal((n, chips, 3))
        noise_acc *= sa
        noise_gyro = rng.standard_normal((n, chips, 3))
        noise_gyro *= sg
        rw_a = cfg.accel.bias_random_walk_g_per_sqrt_s if cfg.drift else 0.0
        rw_g = cfg.gyro.bias_random_walk_rad_s_per_sqrt_s if cfg.drift else 0.0
        step = np.sqrt(1.0 / self.rate_hz)
        # random part of each register before the DLPF: white noise + bias random walk (each
        # walk's steps drawn, scaled and summed in one array)
        walk = np.empty((n, chips, 3))
        steps = walk.reshape(n, -1).T  # a chip axis's steps a row: each sum runs along its row
        for noise, rw in ((noise_acc, rw_a), (noise_gyro, rw_g)):
            rng.standard_normal(out=walk)
            walk *= rw * step
            np.cumsum(steps, axis=1, out=steps)  # the same sums as along axis 0, faster
            noise += walk
        # + bias instability (first-order Gauss–Markov), each drawn into the walk's array in turn
        for noise, sigma, tau in ((noise_acc, cfg.accel.bias_instability_g, cfg.accel.bias_correlation_s),
                                  (noise_gyro, cfg.gyro.bias_instability_rad_s, cfg.gyro.bias_correlation_s)):
            gauss_markov(rng, walk.shape, sigma, tau, self.rate_hz, out=walk)
            if cfg.drift:
                noise += walk
        self._random_acc, self._random_gyro = noise_acc, noise_gyro
        del walk  # its memory serves what comes next (a walk's memory is new to the process)

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
        #: Samples of registers computed at once at another setting (CHUNK_S of them).
        self.chunk_samples = max(1, int(round(CHUNK_S * self.rate_hz)))
        self.computed_samples = 0
        self._n = n
        self._whole: tuple[int, np.ndarray] | None = None  # (setting, registers of every sample)
        self._now: np.ndarray | None = None  # the whole record, if it is at the current setting
        self._chunks: OrderedDict[tuple[int, int], np.ndarray] = OrderedDict()  # (setting, block)
        # per setting, the unfiltered inputs before the end of its last block: setting → (end, acc, gyro)
        self._leads: dict[int, tuple[int, np.ndarray, np.ndarray]] = {}
        self._build_imu()

    # -------------------------------------------------------------------------------------------

    def __repr__(self) -> str:
        return (f"SimulatedSource({self.name!r}, seed={self.seed}, module={self.module}, "
                f"rate_hz={self.rate_hz:g}, samples={len(self)}, dlpf_cfg={self.dlpf_cfg})")

    def __len__(self) -> int:
        return self._n

    def _kinematics(self, delay_acc: float, delay_gyro: float, lo: int, hi: int
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Rate, angular acceleration and specific force (body frame) of samples *lo*:*hi* evaluated
        *delay_acc* [s] earlier, and the rate *delay_gyro* earlier (every sample on its own: the
        trajectory is evaluated at the times of a delay that is not 0, for the gyro's only its rate)."""
        k = self.truth.kinematics
        t = self.truth.t[lo:hi]
        gravity = self.config.gravity
        if delay_acc == 0.0:
            omega, alpha, f_b = k.omega_b[lo:hi], k.alpha_b[lo:hi], k.f_b[lo:hi]
        else:
            e = self.trajectory.evaluate(t - delay_acc, gravity=gravity)
            omega, alpha, f_b = e.omega_b, e.alpha_b, e.f_b
        if delay_gyro == delay_acc:
            return omega, alpha, f_b, omega
        rate = k.omega_b[lo:hi] if delay_gyro == 0.0 else self.trajectory.body_rate(t - delay_gyro)
        return omega, alpha, f_b, rate

    def chip_motion(self, delay_acc: float = 0.0, delay_gyro: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Error-free chip signals: specific force [m/s²] and rate [rad/s], (n, chips, 3), chip axes.

        Includes each chip's lever-arm acceleration ω×(ω×r) + α×r.
        """
        motion = self._kinematics(delay_acc, delay_gyro, 0, self._n)
        f_chip = np.empty((self._n, len(self._mounted), 3))
        w_chip = np.empty_like(f_chip)
        for a, b in _blocks(self._n):
            f, w = self._chip_rows(tuple(m[a:b] for m in motion))
            f_chip[a:b], w_chip[a:b] = f.transpose(2, 0, 1), w.transpose(2, 0, 1)
        return f_chip, w_chip

    def _chip_rows(self, motion: tuple[np.ndarray, ...]) -> tuple[np.ndarray, np.ndarray]:
        """Specific force and rate of the chips (chip_motion's) of the samples of *motion*
        (:meth:`_kinematics`'), each (chips, 3, samples): a row per chip and axis, so that every
        operation runs along a row."""
        omega, alpha, f_b, omega_g = (m.T for m in motion)
        r = self.geometry.lever_arms.T[:, :, None]  # (3, chips, 1)
        w = omega[:, None, :]  # (3, 1, samples)
        f = cross_rows(w, cross_rows(w, r))  # f_b + ω×(ω×r) + α×r, summed in that order
        f += f_b[:, None, :]
        f += cross_rows(alpha[:, None, :], r)
        f_chip = np.empty((len(self._mounted), 3, omega.shape[1]))
        w_chip = np.empty_like(f_chip)
        for k, mount in enumerate(self._mounted):
            mount.rows(f[:, k], out=f_chip[k])
            mount.rows(omega_g, out=w_chip[k])
        return f_chip, w_chip

    def _unfiltered(self, cfg: int, lo: int, hi: int, motion: tuple[np.ndarray, ...] | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
        """Accelerometer [g] and gyro [rad/s] of samples *lo*:*hi* at DLPF setting *cfg*, errors
        and noise in, before the low-pass: (hi − lo, chips, 3) each. *motion*: the whole record's
        :meth:`_kinematics` at the setting's delays, when computed (else those of *lo*:*hi* are)."""
        c = self.config
        if motion is None:
            motion, rows = self._kinematics(*dlpf_delays(c, cfg, self.rate_hz), lo, hi), slice(None)
        else:
            rows = slice(lo, hi)
        a_true, w_chip = self._chip_rows(tuple(m[rows] for m in motion))
        a_true /= G0
        if c.impacts:
            ring_acc, ring_gyro = (r[lo:hi].T for r in self._ringing)
            for k, mount in enumerate(self._mounted):
                a_true[k] += mount.rows(ring_acc)
                w_chip[k] += mount.rows(ring_gyro)
        dtemp = self.die_temp_c[lo:hi].T - c.temperature.reference_c  # (chips, samples)
        acc = np.empty((hi - lo, len(self.chips), 3))
        gyro = np.empty_like(acc)
        for k, chip in enumerate(self.chips):
            acc[:, k] = chip.apply_accel(a_true[k], dtemp[k]).T
            gyro[:, k] = chip.apply_gyro(w_chip[k], dtemp[k], a_true[k]).T
        acc += self._random_acc[lo:hi]
        gyro += self._random_gyro[lo:hi]
        self.computed_samples += hi - lo
        return acc, gyro

    def _registers(self, cfg: int, acc: np.ndarray, gyro: np.ndarray, from_rest: bool) -> np.ndarray:
        """The registers of unfiltered inputs *acc*, *gyro* through the DLPF at *cfg* (started at
        rest on the first input if *from_rest*, else the first inputs are its lead-in); *acc* and
        *gyro* are used up (filtered and scaled in place)."""
        d = self.config.dlpf
        imu = np.empty(acc.shape[:2] + (6,), dtype=np.int16)
        for x, bandwidth_hz, counts, part in ((acc, d.accel_bandwidth_hz[cfg], accel_counts, imu[..., :3]),
                                              (gyro, d.gyro_bandwidth_hz[cfg], gyro_counts, imu[..., 3:])):
            if d.enabled and not d.delays_only:  # each step in place: x is used up
                dlpf_filter(x, bandwidth_hz, self.rate_hz, from_rest, out=x)
            saturate_int16(counts(x, self.config, out=x), out=part)
        return imu

    def lead_in(self, cfg: int) -> int:
        """How many samples before a block the DLPF at setting *cfg* needs to give that block's
        registers as the whole record has them (:func:`.mpu9150.dlpf_reach`; 0 without a filter)."""
        d = self.config.dlpf
        if not d.enabled or d.delays_only:
            return 0
        return max(dlpf_reach(d.accel_bandwidth_hz[cfg], self.rate_hz),
                   dlpf_reach(d.gyro_bandwidth_hz[cfg], self.rate_hz))

    def _build_imu(self) -> None:
        """Compute the whole record of registers at the current setting (and forget the blocks
        computed before: the inputs may have changed), a block of :data:`_BLOCK` samples at a
        time (:meth:`_block`: the block before's inputs are the next one's lead-in)."""
        cfg = self.dlpf_cfg
        self._chunks.clear()
        self._leads.clear()
        motion = self._kinematics(*dlpf_delays(self.config, cfg, self.rate_hz), 0, self._n)
        imu = np.empty((self._n, len(self.chips), 6), dtype=np.int16)
        for a, b in _blocks(self._n):
            imu[a:b] = self._block(cfg, a, b, motion)
        self._leads.clear()
        self._whole = (cfg, imu)
        self._now = imu
        self.clipped = int(np.count_nonzero((imu == INT16_MAX) | (imu == INT16_MIN)))

    @property
    def imu(self) -> np.ndarray:
        """The whole record of registers at the current DLPF setting, int16 (n, chips, 6)
        (computed now if the walk holds another setting's)."""
        if self._now is None:
            self._build_imu()
        assert self._now is not None
        return self._now

    def _chunk(self, k: int) -> np.ndarray:
        """Registers of block *k* (samples k·chunk_samples …) at the current setting, computed
        from the DLPF's lead-in before it unless kept (the block before's inputs serve as the
        lead-in when the blocks are read in order)."""
        cfg = self.dlpf_cfg
        key = (cfg, k)
        chunks = self._chunks
        imu = chunks.get(key)
        if imu is not None:
            chunks.move_to_end(key)
            return imu
        start = k * self.chunk_samples
        imu = self._block(cfg, start, min(start + self.chunk_samples, self._n))
        chunks[key] = imu
        while len(chunks) > _CHUNKS_KEPT:
            chunks.popitem(last=False)
        return imu

    def _block(self, cfg: int, start: int, stop: int, motion: tuple[np.ndarray, ...] | None = None
               ) -> np.ndarray:
        """Registers of samples *start*:*stop* at setting *cfg*, computed from the DLPF's lead-in
        before them: the inputs kept from the block before when it ended at *start*, else
        computed now (*motion* as :meth:`_unfiltered`'s). Keeps this block's last inputs, the
        next block's lead-in."""
        reach = self.lead_in(cfg)
        lo = max(0, start - reach)
        lead = self._leads.get(cfg)
        if lead is not None and lead[0] == start:
            _, lead_acc, lead_gyro = lead  # its last start − lo samples are lo … start − 1
            new_acc, new_gyro = self._unfiltered(cfg, start, stop, motion)
            acc = np.concatenate([lead_acc[len(lead_acc) - (start - lo):], new_acc])
            gyro = np.concatenate([lead_gyro[len(lead_gyro) - (start - lo):], new_gyro])
        else:
            acc, gyro = self._unfiltered(cfg, lo, stop, motion)
        keep = stop - max(0, stop - reach)  # the next block's lead-in
        self._leads[cfg] = (stop, acc[len(acc) - keep:].copy(), gyro[len(gyro) - keep:].copy())
        return self._registers(cfg, acc, gyro, from_rest=lo == 0)[start - lo:]

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
        if index >= self._n:
            return None
        now = self._now
        if now is not None:
            return RawSample(now[index], self.temp[index], self.mag[index])
        k, i = divmod(index, self.chunk_samples)
        return RawSample(self._chunk(k)[i], self.temp[index], self.mag[index])

    def imu_block(self, start: int, n: int) -> np.ndarray | None:
        """Registers of samples *start* … (at most *n*, at least one; to the end of a block at
        another setting than the whole record's), as ``read`` gives them; None past the end."""
        if start < 0 or start >= self._n or n < 1:
            return None
        now = self._now
        if now is not None:
            return now[start:start + n]
        k, i = divmod(start, self.chunk_samples)
        return self._chunk(k)[i:i + n]

    def set_dlpf(self, cfg: int) -> None:
        """Apply DLPF_CFG 0..6: from now on the registers are those of that filter (same noise
        draws), computed block by block as they are read (the module docstring); nothing is
        computed here."""
        if not 0 <= cfg <= 6:
            raise ValueError(f"DLPF_CFG must be 0..6, got {cfg}")
        self.dlpf_cfg = cfg
        whole = self._whole
        self._now = whole[1] if whole is not None and whole[0] == cfg else None


def _blocks(n: int) -> list[tuple[int, int]]:
    """The blocks of :data:`_BLOCK` samples (the last shorter) that make up *n* samples."""
    return [(a, min(a + _BLOCK, n)) for a in range(0, n, _BLOCK)]


def make_source(scenario: str = "default", seed: int = 0, rate_hz: float = 1000.0,
                config: SensorConfig | None = None, geometry: BoardGeometry = MIMU22BT,
                module: int | None = None, stance_sway: bool | None = None) -> SimulatedSource:
    """A simulated 4-IMU source for a named scenario (``list_scenarios()``) or a recipe.

    *seed* draws the walk (noise, drift, ringing, the stance sway); *module* is the module's
    identity, which draws its own systematic errors (None: the seed's own, so
    each seed is a new module). *stance_sway*: the foot turns a little in every walking stance
    (:class:`~.stance_sway.StanceSway`; None: :data:`~.stance_sway.STANCE_SWAY_DEFAULT`).
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
