"""How a foot moves while it stands between two swings: the shared walks' figures and the gait's sway.

**The real feet** (:func:`real_walk`, :func:`real_motion`): the six shared walks (a 3DM-GX2 in the
sole of a right shoe, 250 Hz), in the foot's frame (:func:`~.swing_rotation.foot_frame`: x forward,
y right, z down). The walking stances are the reference detector's (:mod:`.reference_ins`, the
oracle's stance flags) between the first and the last, shorter than :data:`STAND_S`; the sensor's
own noise is measured while the walker stands (the stances of :data:`STAND_S` or more, a quarter
of a second in from either end, in pieces of :data:`NFFT` samples). Per axis:

* the angular rate: its rms about the standing mean, each stance's mean (the sole rolling onto the
  toes), and its variation about that mean, against the standing noise's: the excess is motion;
* its spectrum (a Hann-windowed periodogram of each stance, zero-padded to :data:`NFFT` samples,
  averaged weighted by length) against the standing noise's;
* the specific force's variation about each stance's mean, and the part a rotation of the foot
  about the sensor explains (gravity turned by the measured rate, ḟ = −ω × f);
* the module's detector on the replayed walks at 250 Hz (its window N = 32 samples is 128 ms
  there): T2 and ZARU in the walking stances; and T2 over 32 ms (8 samples) as the module's window
  is at its own 1 kHz, split into its specific-force and rate parts.

**The simulated feet** (:func:`sim_detector`, :func:`end_errors`): the gait's stance sway
(:class:`~firmware_sim.sensors.stance_sway.StanceSway`) off and on, at 1 kHz, traced loop by loop as a
lossless step-wise host: the fraction of walking-stance loops with ZARU (the truth's stances shorter
than :data:`STAND_S`, the filter's loops GYRO_LAG later) and T2 there; the error-free scenarios'
3-D end error in % of the path (as ``python -m lab.accuracy error-free``: the host's end against the
truth's last stance in the start frame, over the 3-D path); and with every sensor error the
straight walk's end heading and horizontal end error over modules 0–19 (seed = module), and, as
before (:mod:`.gyro_bias_response`), with ZARU switched off after the start-up stand.

``python -m tests.oracle.stance_motion [--real] [--sim] [--modules N]`` prints both (default: both,
20 modules).
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from firmware_sim.nav import config as nav_cfg
from protocol.ids import StateId

from .firmware_trace import DESIGN_LAG, HostPose, stepwise_loops
from .gyro_bias_response import GYRO_LAG, _zaru_off_firmware
from .reference_ins import reference_of_recording, stance_phases
from .swing_rotation import foot_frame

__all__ = ["STAND_S", "NFFT", "RATE_BAND_HZ", "RealWalk", "real_walk", "psd", "real_motion",
           "sway_through_estimator", "band_figures", "real_detector", "window_t2", "DetectorRun",
           "trace_detector", "walking_stance_samples", "sim_detector", "end_errors", "error_free_pct"]

#: A stance this long or longer [s] is a stand (as :attr:`StanceSway.longest_stance_s`).
STAND_S = 1.0
#: Samples of the spectra's periodograms (0.512 s at 250 Hz: a walking stance is 0.1–0.3 s).
NFFT = 128
#: Shortest walking stance in the spectrum [samples] (128 ms at 250 Hz).
MIN_PSD_SAMPLES = 32
#: One reduced accelerometer unit (LSB_f, 2^-9 g) in g, one reduced gyro unit (LSB_g) in °/s, and the
#: detector's SR (T2 = var f + SR · var ω, firmware_sim.nav.config).
LSB_F_G = 1.0 / nav_cfg.G_RED
LSB_G_DPS = 4.0 / nav_cfg.GYRO_LSB_PER_DPS
SR = nav_cfg.SR_Q / (1 << nav_cfg.SR_SHIFT)
G0 = 9.80665
DEG = math.pi / 180.0


@dataclass
class RealWalk:
    """One shared walk in the foot's frame."""

    name: str
    rate: float
    acc: np.ndarray  #: (n, 3) specific force [m/s²]
    gyro: np.ndarray  #: (n, 3) angular rate less the standing mean [rad/s]
    walking: list[tuple[int, int]]  #: the walking stances (first, last sample)
    standing: list[tuple[int, int]]  #: the stands, a quarter of a second in from either end


def real_walk(path: str | Path) -> RealWalk:
    """The recording *path* in the foot's frame, with its walking stances and stands."""
    from firmware_sim.sensors.replay import load_recording

    rec = load_recording(path)
    acc, gyro, rate = rec.board_acc_g() * G0, rec.board_gyro(), rec.rate_hz
    phases = stance_phases(reference_of_recording(path).stance[:len(gyro)])
    to_foot = foot_frame(acc, gyro, phases, rate)
    acc, gyro = acc @ to_foot.T, gyro @ to_foot.T
    trim = int(0.25 * rate)
    stands = [(a + trim, b - trim) for a, b in phases if b - a + 1 >= STAND_S * rate]
    walking = [(a, b) for a, b in phases[1:-1] if b - a + 1 < STAND_S * rate]
    bias = np.concatenate([gyro[a:b + 1] for a, b in stands]).mean(axis=0)
    return RealWalk(Path(path).stem, rate, acc, gyro - bias, walking, stands)


def psd(segments: list[np.ndarray], rate: float, nfft: int = NFFT) -> tuple[np.ndarray, np.ndarray]:
    """(frequencies [Hz], one-sided spectrum (nfft//2 + 1, 3) [unit²/Hz]) of *segments* (each
    (L ≤ nfft, 3), less its mean, Hann-windowed, zero-padded to *nfft*), averaged weighted by L."""
    out, weight = np.zeros((nfft // 2 + 1, 3)), 0
    for s in segments:
        n = len(s)
        w = np.hanning(n + 2)[1:-1]
        spectrum = np.fft.rfft((s - s.mean(axis=0)) * w[:, None], n=nfft, axis=0)
        p = np.abs(spectrum) ** 2 / (rate * np.sum(w * w))
        p[1:-1] *= 2.0
        out += p * n
        weight += n
    return np.fft.rfftfreq(nfft, 1.0 / rate), out / weight


def _pieces(walk: RealWalk, nfft: int = NFFT) -> list[tuple[int, int]]:
    """The stands cut into half-overlapping pieces of *nfft* samples."""
    return [(k, k + nfft - 1) for a, b in walk.standing for k in range(a, b + 1 - nfft, nfft // 2)]


def _rotated_gravity(f: np.ndarray, w: np.ndarray, rate: float) -> np.ndarray:
    """The specific force a rotation alone (about the sensor) would give: f₀ turned by the rates *w*
    (ḟ = −ω × f, Euler steps), its mean matched to *f*'s."""
    out = np.empty_like(f)
    out[0] = f[0]
    for k in range(1, len(f)):
        out[k] = out[k - 1] - np.cross(w[k - 1], out[k - 1]) / rate
    return out - out.mean(axis=0) + f.mean(axis=0)


def real_motion(walks: list[RealWalk]) -> dict:
    """The real feet's motion in their walking stances against the standing noise (module docstring):
    rates in °/s, specific forces in m/s², spectra in (°/s)²/Hz and (m/s²)²/Hz."""
    rate = walks[0].rate
    stances = [(w.acc[a:b + 1], w.gyro[a:b + 1]) for w in walks for a, b in w.walking]
    pieces = [(w.acc[a:b + 1], w.gyro[a:b + 1]) for w in walks for a, b in _pieces(w)]
    lengths = np.array([len(g) for _, g in stances], dtype=float)
    means = np.array([g.mean(axis=0) for _, g in stances])

    def about_mean(parts: list[np.ndarray]) -> np.ndarray:
        return np.concatenate([p - p.mean(axis=0) for p in parts])

    rate_var = about_mean([g for _, g in stances]).var(axis=0)
    noise_var = about_mean([g for _, g in pieces]).var(axis=0)
    acc_var = about_mean([a for a, _ in stances]).var(axis=0)
    acc_noise_var = about_mean([a for a, _ in pieces]).var(axis=0)
    rotation = about_mean([_rotated_gravity(a, g, rate) for a, g in stances]).var(axis=0)
    in_psd = [(a, g) for a, g in stances if MIN_PSD_SAMPLES <= len(g) <= NFFT]
    f, rate_psd = psd([g for _, g in in_psd], rate)
    _, noise_psd = psd([g for _, g in pieces], rate)
    _, acc_psd = psd([a for a, _ in in_psd], rate)
    _, acc_noise_psd = psd([a for a, _ in pieces], rate)
    return {
        "stances": len(stances), "samples": int(lengths.sum()), "psd_stances": len(in_psd),
        "median_stance_s": float(np.median(lengths)) / rate,
        "rate_rms_dps": np.degrees(np.sqrt(np.concatenate([g for _, g in stances]).var(axis=0)
                                           + np.concatenate([g for _, g in stances]).mean(axis=0) ** 2)),
        "stance_mean_dps": np.degrees(lengths @ means / lengths.sum()),
        "stance_mean_rms_dps": np.degrees(np.sqrt(lengths @ means ** 2 / lengths.sum())),
        "rate_std_dps": np.degrees(np.sqrt(rate_var)), "noise_std_dps": np.degrees(np.sqrt(noise_var)),
        "excess_std_dps": np.degrees(np.sqrt(np.clip(rate_var - noise_var, 0.0, None))),
        "acc_std": np.sqrt(acc_var), "acc_noise_std": np.sqrt(acc_noise_var),
        "acc_rotation_std": np.sqrt(rotation),
        "f": f, "rate_psd": np.degrees(np.degrees(rate_psd)), "noise_psd": np.degrees(np.degrees(noise_psd)),
        "acc_psd": acc_psd, "acc_noise_psd": acc_noise_psd,
        "lengths": lengths.astype(int),
    }


def sway_through_estimator(lengths: np.ndarray, rate: float, sway=None, seed: int = 0) -> dict:
    """The gait's stance sway (default ``STANCE_SWAY``) as :func:`real_motion` sees a real walk's:
    its rate and the sole's acceleration, untapered, in segments of the real stances' *lengths*
    [samples] at *rate*, each with its own draw; its std about each segment's mean (°/s, m/s²) and
    its spectra (:func:`psd`, segments of MIN_PSD_SAMPLES to NFFT samples)."""
    from firmware_sim.sensors.stance_sway import STANCE_SWAY

    sway = sway or STANCE_SWAY
    rng = np.random.default_rng(seed)
    k = sway.components
    rates, accs = [], []
    for n in lengths:
        t = np.arange(n) / rate + rng.uniform(0.0, 10.0)
        u = rng.random((4, 3, k))
        f_rot, f_vib, phases = sway.rotation_hz(u[0]), sway.vibration_hz(u[1]), 2 * math.pi * u[2:]
        rot = np.cos(2 * math.pi * f_rot[..., None] * t + phases[0][..., None]).sum(axis=1).T
        vib = np.cos(2 * math.pi * f_vib[..., None] * t + phases[1][..., None]).sum(axis=1).T
        rates.append(rot * np.asarray(sway.rate_rms_dps) * math.sqrt(2.0 / k))
        accs.append(vib * np.asarray(sway.vibration_ms2) * math.sqrt(2.0 / k))

    def about_mean(parts: list[np.ndarray]) -> np.ndarray:
        return np.concatenate([p - p.mean(axis=0) for p in parts])

    in_psd = [i for i, n in enumerate(lengths) if MIN_PSD_SAMPLES <= n <= NFFT]
    f, rate_psd = psd([rates[i] for i in in_psd], rate)
    _, acc_psd = psd([accs[i] for i in in_psd], rate)
    return {"rate_std_dps": about_mean(rates).std(axis=0), "acc_std": about_mean(accs).std(axis=0),
            "f": f, "rate_psd": rate_psd, "acc_psd": acc_psd}


#: The band [Hz] of the rate's spectrum the sway is matched in (its mean frequency and rms): the bins
#: from 1.95 to 25.4 Hz.
RATE_BAND_HZ = (1.5, 26.0)


def band_figures(f: np.ndarray, spectrum: np.ndarray, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """(rms, mean frequency [Hz]) per axis of the one-sided *spectrum* (len(f), 3) from *lo* to
    *hi* [Hz] (bins f ≥ lo, f < hi; negative bins count as 0)."""
    sel = (f >= lo) & (f < hi)
    p = np.clip(spectrum[sel], 0.0, None)
    return np.sqrt(p.sum(axis=0) * (f[1] - f[0])), (p * f[sel, None]).sum(axis=0) / p.sum(axis=0)


def window_t2(acc: np.ndarray, gyro: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(var f, SR · var ω) [LSB_f²] over every window of *n* samples, summed over the axes, of
    *acc* [m/s²] and *gyro* [rad/s] (the detector's T2 in floating point)."""
    def var(x: np.ndarray) -> np.ndarray:
        return np.lib.stride_tricks.sliding_window_view(x, (n, 3))[:, 0].var(axis=1).sum(axis=-1)

    return var(acc / (G0 * LSB_F_G)), SR * var(np.degrees(gyro) / LSB_G_DPS)


def real_detector(path: str | Path, walk: RealWalk | None = None) -> dict:
    """The module's detector on the replayed walk *path* at 250 Hz: T2 and ZARU in the walking
    stances' samples and while standing; and T2 over 8 samples (32 ms, the module's window at
    1 kHz), its specific-force and rate parts, in the walking stances and the stands."""
    from firmware_sim.sensors.replay import ReplaySource, load_recording

    walk = walk or real_walk(path)
    run = trace_detector(ReplaySource(load_recording(path)))
    n = len(run.t2) - DESIGN_LAG
    t2, zaru = run.t2[DESIGN_LAG:], run.zaru[DESIGN_LAG:]  # index k: the recorded sample k
    stance = np.zeros(n, bool)
    for a, b in walk.walking:
        stance[a:b + 1] = True
    standing = np.zeros(n, bool)
    for a, b in walk.standing:
        standing[a:b + 1] = True
    short = {"walking": ([], []), "standing": ([], [])}
    for kind, spans in (("walking", walk.walking), ("standing", walk.standing)):
        for a, b in spans:
            if b - a + 1 >= 8:
                va, vg = window_t2(walk.acc[a:b + 1], walk.gyro[a:b + 1], 8)
                short[kind][0].append(va)
                short[kind][1].append(vg)
    return {"t2_walking": t2[stance], "zaru_walking": zaru[stance], "t2_standing": t2[standing],
            "zaru_standing": zaru[standing],
            **{f"t2_32ms_{kind}_{part}": np.concatenate(short[kind][i])
               for kind in short for i, part in enumerate(("acc", "gyro"))}}


@dataclass
class DetectorRun:
    """A module's run, per loop (index = loop number)."""

    t2: np.ndarray  #: (n,) the detector's T2 [LSB_f²]
    zupt: np.ndarray  #: (n,) bool
    zaru: np.ndarray  #: (n,) bool
    heading: np.ndarray  #: (n,) the host's heading: summed steps + the INS's yaw [rad]
    position: np.ndarray  #: (n, 3) the host's position: summed steps + the INS's since the reset [m]


def trace_detector(source, *, zaru_off_from: float | None = None) -> DetectorRun:
    """Run a module on *source* loop by loop as a lossless step-wise host and trace its detector and
    the host's pose; *zaru_off_from* [s]: ZARU never holds for the samples from then on."""
    firmware = None
    if zaru_off_from is not None:
        firmware = _zaru_off_firmware(int(round(zaru_off_from * source.rate_hz)) + GYRO_LAG)
    n = len(source)
    t2 = np.zeros(n, np.int64)
    zupt, zaru = np.zeros(n, bool), np.zeros(n, bool)
    heading, position = np.zeros(n), np.zeros((n, 3))
    host = HostPose()
    for k, module in stepwise_loops(source, firmware=firmware):
        mem = module.memory
        t2[k] = int(mem[StateId.T2S2F])
        zupt[k] = mem.flag(StateId.ZUPT)
        zaru[k] = mem.flag(StateId.ZARU)
        position[k], heading[k], _ = host.after_loop(mem)
    return DetectorRun(t2, zupt, zaru, heading, position)


def walking_stance_samples(truth) -> np.ndarray:
    """(n,) bool: the samples of the truth's stances shorter than :data:`STAND_S`."""
    out = np.zeros(len(truth), bool)
    rate = truth.rate_hz
    for t0, t1 in zip(truth.stance_start, truth.stance_end, strict=True):
        if t1 - t0 < STAND_S:
            out[int(math.ceil(t0 * rate - 1e-9)):int(math.ceil(t1 * rate - 1e-9))] = True
    return out


def _loops(samples: np.ndarray, lag: int = GYRO_LAG) -> np.ndarray:
    """The loops whose filter sample is one of *samples* (bool per sample → bool per loop)."""
    return np.r_[np.zeros(lag, bool), samples[:len(samples) - lag]]


def sim_detector(source, run: DetectorRun | None = None) -> dict:
    """ZARU and T2 in the walking stances' loops, and in the start-up stand's, of a simulated walk."""
    run = run or trace_detector(source)
    truth = source.truth
    walking = _loops(walking_stance_samples(truth))
    rate = truth.rate_hz
    stand = _loops(np.arange(len(truth)) < int(truth.stance_end[0] * rate))
    stand[:nav_cfg.N] = False  # the buffer fills
    return {"zaru_walking": float(run.zaru[walking].mean()), "t2_walking": run.t2[walking],
            "zaru_stand": float(run.zaru[stand].mean()), "t2_stand": run.t2[stand],
            "zupt_walking": float(run.zupt[walking].mean())}


def end_errors(source, run: DetectorRun) -> dict:
    """The host's end against the truth's last stance (start frame): 3-D [m] and in % of the 3-D
    path (``python -m lab.accuracy error-free``), horizontal [m], heading [deg]."""
    truth = source.truth
    error = run.position[-1] - truth.stances_in_start_frame()[-1]
    path = truth.distance_m()
    heading = math.remainder(run.heading[-1] - truth.heading_change(), 2 * math.pi)
    return {"error_m": float(np.linalg.norm(error)), "pct": 100 * float(np.linalg.norm(error)) / path,
            "horizontal_m": float(np.hypot(error[0], error[1])), "heading_deg": math.degrees(heading)}


def error_free_pct(scenario: str, stance_sway: bool, rate_hz: float = 1000.0) -> dict:
    """*scenario* walked by an error-free module (seed 0): :func:`end_errors` and :func:`sim_detector`."""
    from firmware_sim.sensors.config import SensorConfig
    from firmware_sim.sensors.imu_array import make_source

    src = make_source(scenario, seed=0, rate_hz=rate_hz, config=SensorConfig.ideal(), stance_sway=stance_sway)
    run = trace_detector(src)
    return {**end_errors(src, run), **sim_detector(src, run)}


def _pct(x: np.ndarray, q=(5, 25, 50, 75, 95)) -> str:
    return " / ".join(f"{v:.0f}" for v in np.percentile(x, q))


def _report_real() -> None:  # pragma: no cover - a report for a person
    from tests.conftest import WALK_IDS, walk_path

    walks = [real_walk(walk_path(w)) for w in WALK_IDS]
    m = real_motion(walks)

    def axes(v, fmt=".2f") -> str:
        return " / ".join(f"{x:{fmt}}" for x in v)

    print(f"the six shared walks: {m['stances']} walking stances (median {m['median_stance_s']:.3f} s, "
          f"{m['samples']} samples at 250 Hz); foot frame, roll / pitch / yaw (x / y / z)")
    print(f"  rate rms about the standing mean      {axes(m['rate_rms_dps'])} °/s")
    print(f"  each stance's mean: mean               {axes(m['stance_mean_dps'])} °/s, "
          f"rms {axes(m['stance_mean_rms_dps'])} °/s")
    print(f"  about each stance's mean: std          {axes(m['rate_std_dps'])} °/s; standing noise "
          f"{axes(m['noise_std_dps'])} °/s; motion (the excess) {axes(m['excess_std_dps'])} °/s")
    print(f"  specific force about the stance's mean {axes(m['acc_std'], '.3f')} m/s²; standing noise "
          f"{axes(m['acc_noise_std'], '.3f')}; a rotation about the sensor explains "
          f"{axes(m['acc_rotation_std'], '.3f')}")
    f, df = m["f"], m["f"][1] - m["f"][0]
    model = sway_through_estimator(m["lengths"], walks[0].rate)
    print(f"  spectra over {m['psd_stances']} stances of {MIN_PSD_SAMPLES}–{NFFT} samples (Hann, {df:.2f} Hz "
          f"bins): rate (°/s)²/Hz stance | standing | excess | the sway's; specific force (mm/s²)²/Hz "
          f"excess | the vibration's")
    acc_excess = m["acc_psd"] - m["acc_noise_psd"]
    for i in range(0, len(f)):
        if i > 16 and i % 4:
            continue
        stance, noise = m["rate_psd"][i], m["noise_psd"][i]
        rates = (stance, noise, stance - noise, model["rate_psd"][i])
        print(f"   {f[i]:5.1f} Hz  " + " | ".join(axes(r, "6.4f") for r in rates)
              + f"   {axes(1e6 * acc_excess[i], '5.0f')} | {axes(1e6 * model['acc_psd'][i], '5.0f')}")
    for lo, hi in ((0, 10), (10, 20), (20, 125)):
        sel = (f >= lo) & (f < hi)
        print(f"  {lo:3d}–{hi:3d} Hz rms: stance {axes(np.sqrt(m['rate_psd'][sel].sum(axis=0) * df))} °/s, "
              f"standing {axes(np.sqrt(m['noise_psd'][sel].sum(axis=0) * df))} °/s")
    rate_rms, rate_f = band_figures(f, m["rate_psd"] - m["noise_psd"], *RATE_BAND_HZ)
    sway_rms, sway_f = band_figures(f, model["rate_psd"], *RATE_BAND_HZ)
    in_band = f[(f >= RATE_BAND_HZ[0]) & (f < RATE_BAND_HZ[1])]
    print(f"  the rate's excess from {in_band[0]:.1f} to {in_band[-1]:.1f} Hz: rms {axes(rate_rms)} °/s, "
          f"mean frequency {axes(rate_f, '.1f')} Hz; the sway's {axes(sway_rms)} °/s, "
          f"{axes(sway_f, '.1f')} Hz; about each stance's mean the sway's std "
          f"{axes(model['rate_std_dps'])} °/s")
    from firmware_sim.sensors.stance_sway import STANCE_SWAY

    f1, f2, f3 = STANCE_SWAY.vibration_band_hz
    low, _ = band_figures(f, acc_excess, f1, f2)
    total, _ = band_figures(f, acc_excess, f1, f3)
    model_total, _ = band_figures(f, model["acc_psd"], f1, f3)
    print(f"  the specific force's excess from {f1:g} to {f3:g} Hz: rms {axes(total, '.3f')} m/s² "
          f"({axes(low ** 2 / total ** 2, '.2f')} of its power below {f2:g} Hz); the vibration's "
          f"{axes(model_total, '.3f')} m/s²")
    det = [real_detector(walk_path(w), walk) for w, walk in zip(WALK_IDS, walks, strict=True)]

    def cat(key: str) -> np.ndarray:
        return np.concatenate([d[key] for d in det])

    print(f"  the module at 250 Hz (T2 over 128 ms): ZARU in {100 * cat('zaru_walking').mean():.2f} % of the "
          f"walking stances' samples, T2 there (5/25/50/75/95 %) {_pct(cat('t2_walking'))}, min "
          f"{cat('t2_walking').min()}; standing: ZARU {100 * cat('zaru_standing').mean():.1f} %, T2 "
          f"{_pct(cat('t2_standing'))}")
    for kind in ("walking", "standing"):
        a, g = cat(f"t2_32ms_{kind}_acc"), cat(f"t2_32ms_{kind}_gyro")
        print(f"  T2 over 32 ms (8 samples), {kind:8s}: total {_pct(a + g)}, < 16 in "
              f"{100 * np.mean(a + g < 16):.1f} %; specific force {_pct(a)}; rate {_pct(g)}, < 16 alone in "
              f"{100 * np.mean(g < 16):.1f} %")


def _report_sim(modules: int) -> None:  # pragma: no cover - a report for a person
    from firmware_sim.sensors.config import DEFAULT_CONFIG, SensorConfig
    from firmware_sim.sensors.imu_array import make_source
    from firmware_sim.sensors.stance_sway import STANCE_SWAY

    print(f"simulated, 1 kHz, the stance sway {STANCE_SWAY}")
    for config, label in ((SensorConfig.ideal(), "error-free"), (DEFAULT_CONFIG, "all errors")):
        for sway in (False, True):
            src = make_source("walk", seed=0, config=config, stance_sway=sway)
            d = sim_detector(src)
            print(f"  walk, seed 0, {label:10s}, sway {'on ' if sway else 'off'}: ZARU in "
                  f"{100 * d['zaru_walking']:.2f} % of the walking stances' loops (ZUPT "
                  f"{100 * d['zupt_walking']:.1f} %), T2 there {_pct(d['t2_walking'])}, min "
                  f"{d['t2_walking'].min()}; start-up stand ZARU {100 * d['zaru_stand']:.1f} %, T2 "
                  f"{_pct(d['t2_stand'])}")
    print("  error-free 3-D end error, % of the path (off → on):")
    for scenario in ("walk", "rectangle", "stairs_up"):
        off, on = error_free_pct(scenario, False), error_free_pct(scenario, True)
        print(f"    {scenario:10s} {off['pct']:.3f} → {on['pct']:.3f} %  (ZARU in walking stances "
              f"{100 * off['zaru_walking']:.1f} → {100 * on['zaru_walking']:.1f} %)")
    print(f"  all sensor errors, walk, modules 0–{modules - 1} (seed = module): end heading and horizontal "
          "error rms")
    for sway, zaru_off in ((False, False), (True, False), (False, True), (True, True)):
        h, e, z = [], [], []
        for m in range(modules):
            src = make_source("walk", seed=m, config=DEFAULT_CONFIG, stance_sway=sway)
            t0 = float(src.truth.stance_end[0]) if zaru_off else None
            run = trace_detector(src, zaru_off_from=t0)
            err = end_errors(src, run)
            h.append(err["heading_deg"])
            e.append(err["horizontal_m"])
            z.append(sim_detector(src, run)["zaru_walking"])
        h, e = np.array(h), np.array(e)
        case = f"sway {'on ' if sway else 'off'}{', ZARU off after the stand' if zaru_off else '':27s}"
        print(f"    {case}: heading {np.sqrt(np.mean(h ** 2)):.3f}° (mean {np.mean(h):+.3f}, max "
              f"|{np.max(np.abs(h)):.3f}|), horizontal {np.sqrt(np.mean(e ** 2)):.3f} m (mean "
              f"{np.mean(e):.3f}, max {np.max(e):.3f}); ZARU in walking stances {100 * np.mean(z):.2f} %")


def main(argv: list[str] | None = None) -> None:  # pragma: no cover - a report for a person
    ap = argparse.ArgumentParser(prog="python -m tests.oracle.stance_motion",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("--real", action="store_true", help="only the shared walks' figures")
    ap.add_argument("--sim", action="store_true", help="only the simulated walks'")
    ap.add_argument("--modules", type=int, default=20, help="modules of the all-errors walks (default 20)")
    args = ap.parse_args(argv)
    if not args.sim:
        from tests.conftest import have_walks

        if not have_walks():
            raise SystemExit("the shared walks are not here (see tests/conftest.py)")
        _report_real()
    if not args.real:
        _report_sim(args.modules)


if __name__ == "__main__":  # pragma: no cover
    main()
