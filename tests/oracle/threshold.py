"""TH_ZUPT from the detector's statistics on walking data, chosen leave-one-out.

The module's detector computes the reference's GLRT statistic (firmware_sim.nav.config: T1 is the
reference's T times σ_a²) on one window of M samples centred on the sample it judges. A threshold
trades two errors, both measured against the reference's own decisions (the oracle's stance flags,
:mod:`.reference_ins`):

* **a missed stance sample**: the oracle says stationary, T1 ≥ TH. The ZUPT loses that sample;
* **a false alarm in mid-swing**: T1 < TH in the middle 80 % of a swing of at least 0.2 s, where the
  foot moves at metres per second and a ZUPT is wrong beyond doubt (the swing's edges, heel strike
  and toe off, are where the two detectors may legitimately differ by a sample).

The threshold is the detector's equal-error point on walking data: where the fraction of stance
samples missed equals the fraction of mid-swing samples falsely accepted. Leave-one-out: for each
walk, the point is found on the other five (pooled), and scored on the walk left out: its two error
rates, its agreement with the oracle, and, replayed at that threshold, its closure. The closure is
reported, never used to choose. It also reports the miss rate while the module stands still before
each walk (the oracle's first stance), the other statistic a threshold must respect.

Every walk is traced once (T1 per recorded sample, :mod:`.firmware_trace`): the module's decision
at any threshold is then ``T1 < TH``, with no further run.

**The module's own threshold** (:func:`simulated_sample`): the same statistics on the emulated
MIMU22BT at its own 1 kHz, every sensor error on and a real foot's swaying stances (the gait's
:class:`~firmware_sim.sensors.stance_sway.StanceSway`), against the simulation's true stances: the middle
80 % of each walking stance (the truth's stance begins at the heel's touch, the oracle's after the
impact has rung out) and the middle 80 % of each swing, as above. On walking data the two do not
overlap: every threshold between the largest stance T1 and the smallest mid-swing T1 makes neither
error, so the statistics bound the module's power-on TH_ZUPT rather than pick it.

``python -m tests.oracle.threshold`` prints the table; ``--simulated`` the module's own figures.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .firmware_trace import align, trace_module, trace_of_recording
from .reference_ins import reference_of_recording, stance_phases

__all__ = ["DetectorSample", "GRID", "detector_sample", "simulated_sample", "error_rates", "agreement",
           "choose", "leave_one_out", "SIMULATED_SCENARIOS"]

#: Thresholds considered [LSB_f²]: from the reference's γ·σ_a² (8172) halved to five times it.
GRID = np.arange(4000, 40001, 250)


@dataclass
class DetectorSample:
    """One walk, as the detectors see it."""

    path: Path
    t1: np.ndarray  #: (n,) the module's statistic per recorded sample [LSB_f²]
    oracle: np.ndarray  #: (n,) bool, the reference's stance flag per sample
    standing: np.ndarray  #: T1 over the oracle's first stance (standing still before the walk)
    stance: np.ndarray  #: T1 over the oracle's walking stances (all but the first and the last)
    swing: np.ndarray  #: T1 over the middle 80 % of the oracle's swings of at least 0.2 s


#: Shortest gap between two oracle stances counted as a swing [s] (a running swing lasts ~0.4 s).
MIN_SWING_S = 0.2


def detector_sample(path: str | Path) -> DetectorSample:
    """Trace the module's statistic on the recording *path* and run the reference's detector on it."""
    from firmware_sim.sensors.replay import load_recording

    rate_hz = load_recording(path).rate_hz
    oracle = reference_of_recording(path)
    t1 = align(trace_of_recording(path)).t1
    stance = oracle.stance[:len(t1)]
    phases = stance_phases(stance)
    first, last = phases[0]
    walking = [t1[a:b + 1] for a, b in phases[1:-1]]
    swings = []
    for (_, end), (start, _) in zip(phases[:-1], phases[1:], strict=True):
        gap = start - end - 1
        if gap >= MIN_SWING_S * rate_hz:
            swings.append(t1[end + 1 + gap // 10:start - gap // 10])
    return DetectorSample(Path(path), t1, stance, t1[first:last + 1], np.concatenate(walking),
                          np.concatenate(swings))


def _middle(start: int, end: int, mask: np.ndarray, cut: float = 0.1) -> None:
    """Mark samples start…end-1 in *mask* but the fraction *cut* of them at either end."""
    k = int((end - start) * cut)
    mask[start + k:end - k] = True


def simulated_sample(scenario: str, seed: int, stance_sway: bool | None = None,
                     swing_cut: float = 0.1) -> DetectorSample:
    """The emulated module's statistic on a simulated walk of *scenario* (every sensor error, module
    *seed*, at 1 kHz, the stances swaying unless *stance_sway* is False), against the true stances:
    ``oracle`` holds the truth's stance flags, ``standing`` T1 over the start-up stand, ``stance``
    over the middle 80 % of the walking stances (shorter than a second) and ``swing`` over the swings
    of at least :data:`MIN_SWING_S` but the fraction *swing_cut* of each at either end."""
    t1, truth = _simulated_trace(scenario, seed, stance_sway)
    return _against_truth(f"{scenario}#{seed}", t1, truth, swing_cut)


def _simulated_trace(scenario: str, seed: int, stance_sway: bool | None = None) -> tuple[np.ndarray, object]:
    """T1 per sample of the simulated walk (as :func:`simulated_sample` makes it) and its truth."""
    from firmware_sim.sensors.imu_array import make_source

    source = make_source(scenario, seed=seed, stance_sway=stance_sway)
    return align(trace_module(source)).t1, source.truth


def _against_truth(name: str, t1: np.ndarray, truth, swing_cut: float) -> DetectorSample:
    n = len(t1)

    def sample(t: float) -> int:
        return min(n, int(math.ceil(t * truth.rate_hz - 1e-9)))

    flags, stance, swing = (np.zeros(n, bool) for _ in range(3))
    starts = [sample(t) for t in truth.stance_start]
    ends = [sample(t) for t in truth.stance_end]
    for a, b, t_start, t_end in zip(starts, ends, truth.stance_start, truth.stance_end, strict=True):
        flags[a:b] = True
        if t_end - t_start < 1.0:
            _middle(a, b, stance)
    for end, start in zip(ends[:-1], starts[1:], strict=True):
        if start - end >= MIN_SWING_S * truth.rate_hz:
            _middle(end, start, swing, swing_cut)
    return DetectorSample(Path(name), t1, flags, t1[:ends[0]], t1[stance], t1[swing])


#: The scenarios :func:`simulated_sample` is reported on: walking at three speeds, corners, stairs
#: both ways, running, and the short steps and turns on the spot of the house walk.
SIMULATED_SCENARIOS = ("walk", "walk_slow", "walk_fast", "rectangle", "stairs_up", "stairs_down",
                       "default", "run", "side_steps", "back_steps", "navshoe-house")


def error_rates(walks: list[DetectorSample], grid: np.ndarray = GRID) -> tuple[np.ndarray, np.ndarray]:
    """(missed stance samples, mid-swing false alarms) as fractions per threshold, pooled over *walks*."""
    stance = np.sort(np.concatenate([w.stance for w in walks]))
    swing = np.sort(np.concatenate([w.swing for w in walks]))
    missed = 1 - np.searchsorted(stance, grid, side="left") / len(stance)
    false_alarm = np.searchsorted(swing, grid, side="left") / len(swing)
    return missed, false_alarm


def agreement(walk: DetectorSample, grid: np.ndarray = GRID) -> np.ndarray:
    """(len(grid),) samples on which ``T1 < TH`` equals the oracle's flag, per threshold."""
    t1 = np.sort(walk.t1)
    below = np.searchsorted(t1, grid, side="left")  # samples with T1 < TH
    # agree = stationary for both + moving for both, from two counts per threshold
    t1_stance = np.sort(walk.t1[walk.oracle])
    both_stationary = np.searchsorted(t1_stance, grid, side="left")
    n_stance = len(t1_stance)
    firmware_only = below - both_stationary
    oracle_only = n_stance - both_stationary
    return len(walk.t1) - firmware_only - oracle_only


def choose(walks: list[DetectorSample], grid: np.ndarray = GRID) -> int:
    """The equal-error threshold of *walks*: the first on *grid* at which the mid-swing false-alarm
    rate reaches the missed-stance rate (the miss rate falls and the false-alarm rate rises with TH)."""
    missed, false_alarm = error_rates(walks, grid)
    return int(grid[int(np.argmax(false_alarm >= missed))])


@dataclass
class Fold:
    held_out: Path
    threshold: int  #: chosen on the other walks
    missed: float  #: the held-out walk's missed-stance rate at that threshold
    false_alarm: float  #: and its mid-swing false-alarm rate
    agreement: float  #: the held-out walk's, at that threshold
    agreement_default: float  #: the held-out walk's, at the power-on TH_ZUPT
    standing_max: int  #: the held-out walk's largest T1 while standing still


def leave_one_out(walks: list[DetectorSample], default: int) -> list[Fold]:
    """Choose on all but one walk, score that one; one fold per walk."""
    folds = []
    for i, w in enumerate(walks):
        th = choose(walks[:i] + walks[i + 1:])
        at = agreement(w, np.array([th, default]))
        n = len(w.t1)
        missed, false_alarm = error_rates([w], np.array([th]))
        folds.append(Fold(w.path, th, float(missed[0]), float(false_alarm[0]), float(at[0]) / n,
                          float(at[1]) / n, int(w.standing.max())))
    return folds


def main(argv: list[str] | None = None) -> None:  # pragma: no cover - a report for a person
    import argparse

    from firmware_sim.nav import config as nav_cfg
    from firmware_sim.nav.profiles import GX2_PROFILE
    from firmware_sim.sensors.replay import ReplaySource, load_recording
    from tests.conftest import WALK_IDS, have_walks, walk_path

    from .compare import closure_pct

    p = argparse.ArgumentParser(prog="python -m tests.oracle.threshold", description=__doc__.split("\n\n")[0])
    p.add_argument("--simulated", action="store_true",
                   help="the emulated module's own statistics at 1 kHz, against the true stances")
    p.add_argument("--seeds", type=int, default=5, help="modules per scenario with --simulated (default 5)")
    args = p.parse_args(argv)
    if args.simulated:
        _report_simulated(args.seeds, nav_cfg.TH_ZUPT_DEFAULT)
        return
    if not have_walks():
        raise SystemExit("the shared walks are not here (see tests/conftest.py)")
    walks = [detector_sample(walk_path(w)) for w in WALK_IDS]
    default = GX2_PROFILE.zupt_threshold
    print(f"all six: equal-error TH_ZUPT {choose(walks)} (profile {default}, module power-on "
          f"{nav_cfg.TH_ZUPT_DEFAULT}); "
          f"best agreement with the oracle at {GRID[np.argmax(sum(agreement(w) for w in walks))]}")
    print("held out  | chosen on five | missed / false alarm % | agreement there / at profile's % "
          "| standing T1 max | closure h / 3-D %")
    for f in leave_one_out(walks, default):
        trace = align(trace_module(ReplaySource(load_recording(f.held_out)), th_zupt=f.threshold))
        h, d = closure_pct(trace.position, trace.zupt)
        rates = f"{100 * f.missed:6.3f} / {100 * f.false_alarm:6.3f}"
        print(f"{f.held_out.stem[5:]:9s} | {f.threshold:14d} | {rates}"
              f"       | {100 * f.agreement:6.2f} / {100 * f.agreement_default:6.2f}"
              f"                 | {f.standing_max:15d} | {h:.3f} / {d:.3f}")


def _report_simulated(seeds: int, default: int) -> None:  # pragma: no cover - a report for a person
    print(f"the emulated module at 1 kHz, every sensor error, swaying stances, modules 1–{seeds}; "
          f"power-on TH_ZUPT {default}")
    print("scenario      | stance T1 99.9 % / max | swing T1 min, middle 80 % / 60 % "
          "| at TH_ZUPT, middle 80 %: missed / false alarm %")
    for scenario in SIMULATED_SCENARIOS:
        walks: dict[float, list[DetectorSample]] = {0.1: [], 0.2: []}
        for seed in range(1, seeds + 1):
            t1, truth = _simulated_trace(scenario, seed)
            for cut, found in walks.items():
                found.append(_against_truth(scenario, t1, truth, cut))
        stance = np.concatenate([w.stance for w in walks[0.1]])
        swing80, swing60 = (np.concatenate([w.swing for w in walks[cut]]) for cut in (0.1, 0.2))
        missed, false_alarm = error_rates(walks[0.1], np.array([default]))
        print(f"{scenario:13s} | {np.percentile(stance, 99.9):8.0f} / {stance.max():6d}    "
              f"| {swing80.min():8d} / {swing60.min():8d}             "
              f"| {100 * missed[0]:6.3f} / {100 * false_alarm[0]:6.3f}")


if __name__ == "__main__":  # pragma: no cover
    main()
