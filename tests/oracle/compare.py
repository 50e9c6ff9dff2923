"""The emulated firmware against the reference oracle on one recording, stance by stance.

:func:`compare_walk` runs both on a recording, lines the firmware's loops up with the recorded
samples (:func:`~tests.oracle.firmware_trace.align`), pairs each oracle stance with the firmware
stance that overlaps it most, and reports:

* the stance flags: agreement per sample, and how far each stance's start and end are shifted;
* the velocity at the first and last sample of each stance (what the ZUPT has to remove);
* the steps: the horizontal displacement and heading change from one stance's end to the next;
* the height: where the drift builds up (per step, and the end's).

``python -m tests.oracle.compare [--png DIR]`` prints the table for the shared walks and draws a
picture of each: the tracks, the height over time, and the stance flags against the oracle's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .firmware_trace import FirmwareTrace, align, best_lag, trace_of_recording
from .reference_ins import ReferenceRun, reference_of_recording, stance_phases

__all__ = ["WalkComparison", "compare_walk", "closure_pct"]


def closure_pct(position: np.ndarray, stance: np.ndarray) -> tuple[float, float]:
    """(horizontal, 3-D) closure of a track sampled per sample, % of the horizontal distance
    between successive stance ends (``reference.csv``'s definition)."""
    ends = np.array([position[e] for _, e in stance_phases(stance)])
    dist = float(np.sum(np.linalg.norm(np.diff(ends[:, :2], axis=0), axis=1)))
    end = position[-1]
    return 100 * float(np.linalg.norm(end[:2])) / dist, 100 * float(np.linalg.norm(end)) / dist


@dataclass
class WalkComparison:
    name: str
    lag: int  #: the lag (loops) at which the firmware's stance flags match the oracle's best
    agreement: float  #: fraction of samples with the same stance decision
    oracle_only: int  #: samples stationary for the oracle only
    firmware_only: int  #: samples stationary for the firmware only
    start_shift: np.ndarray  #: per paired stance, firmware start − oracle start [samples]
    end_shift: np.ndarray  #: per paired stance, firmware end − oracle end [samples]
    v_first: np.ndarray  #: (stances, 2) |v| at the oracle stance's first sample: oracle, firmware
    v_last: np.ndarray  #: (stances, 2) |v| at its last sample
    step_length: np.ndarray  #: (steps, 2) horizontal step length [m]: oracle, firmware
    step_turn: np.ndarray  #: (steps, 2) heading change [rad]
    step_dz: np.ndarray  #: (steps, 2) height change [m], z down
    closure: tuple[float, float, float, float]  #: horizontal and 3-D %, oracle then firmware
    oracle: ReferenceRun
    firmware: FirmwareTrace

    def row(self) -> str:
        d_len = self.step_length[:, 1] - self.step_length[:, 0]
        d_turn = np.degrees(np.abs(self.step_turn[:, 1] - self.step_turn[:, 0]))
        h_o, d_o, h_f, d_f = self.closure
        return (f"{self.name:>10} {self.lag:3d} {100 * self.agreement:6.2f} {self.oracle_only:5d} "
                f"{self.firmware_only:5d} {np.median(self.start_shift):+5.1f} "
                f"{np.median(self.end_shift):+5.1f} {1e3 * np.mean(d_len):+7.1f} {1e3 * np.std(d_len):6.1f} "
                f"{np.mean(d_turn):6.2f} {np.sum(self.step_dz[:, 0]):+6.3f} "
                f"{np.sum(self.step_dz[:, 1]):+6.3f} {h_o:6.3f} {h_f:6.3f} {d_o:6.3f} {d_f:6.3f}")

    HEADER = ("      walk lag agree% o-only f-only start   end  Δlen mm  sd mm  |Δψ|°  dz ora  dz fw "
              "  h ora   h fw  3d ora  3d fw")


def _pairs(oracle: list[tuple[int, int]], firmware: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """(oracle stance, firmware stance) indices, each oracle stance with the firmware one overlapping
    it most (stances with no overlap are left unpaired)."""
    out = []
    j = 0
    for i, (s, e) in enumerate(oracle):
        best, best_overlap = None, 0
        while j < len(firmware) and firmware[j][1] < s:
            j += 1
        k = j
        while k < len(firmware) and firmware[k][0] <= e:
            overlap = min(e, firmware[k][1]) - max(s, firmware[k][0]) + 1
            if overlap > best_overlap:
                best, best_overlap = k, overlap
            k += 1
        if best is not None:
            out.append((i, best))
    return out


def compare_walk(path: str | Path) -> WalkComparison:
    """Run the oracle and the emulated firmware (as a replay runs it) on the recording *path*."""
    oracle = reference_of_recording(path)
    trace = trace_of_recording(path)
    lag = best_lag(trace, oracle.stance)
    fw = align(trace)
    n = len(fw.zupt)
    o_st, f_st = oracle.stance[:n], fw.zupt
    o_ph, f_ph = stance_phases(o_st), stance_phases(f_st)
    pairs = _pairs(o_ph, f_ph)
    start = np.array([f_ph[j][0] - o_ph[i][0] for i, j in pairs])
    end = np.array([f_ph[j][1] - o_ph[i][1] for i, j in pairs])
    v_first = np.array([[np.linalg.norm(oracle.velocity[o_ph[i][0]]), np.linalg.norm(fw.velocity[o_ph[i][0]])]
                        for i, _ in pairs])
    v_last = np.array([[np.linalg.norm(oracle.velocity[o_ph[i][1]]), np.linalg.norm(fw.velocity[o_ph[i][1]])]
                       for i, _ in pairs])
    # steps between successive paired stances' ends, each track at its own stance end
    o_end = np.array([oracle.position[o_ph[i][1]] for i, _ in pairs])
    f_end = np.array([fw.position[f_ph[j][1]] for _, j in pairs])
    o_psi = np.array([oracle.heading[o_ph[i][1]] for i, _ in pairs])
    f_psi = np.array([fw.heading[f_ph[j][1]] for _, j in pairs])

    def wrap(a: np.ndarray) -> np.ndarray:
        return (a + math.pi) % (2 * math.pi) - math.pi

    step_length = np.stack([np.linalg.norm(np.diff(o_end[:, :2], axis=0), axis=1),
                            np.linalg.norm(np.diff(f_end[:, :2], axis=0), axis=1)], axis=1)
    step_turn = np.stack([wrap(np.diff(o_psi)), wrap(np.diff(f_psi))], axis=1)
    step_dz = np.stack([np.diff(o_end[:, 2]), np.diff(f_end[:, 2])], axis=1)
    o_closure = closure_pct(oracle.position[:n], o_st)
    f_closure = closure_pct(fw.position, f_st)
    return WalkComparison(Path(path).stem, lag, float(np.mean(o_st == f_st)), int(np.sum(o_st & ~f_st)),
                          int(np.sum(f_st & ~o_st)), start, end, v_first, v_last, step_length, step_turn,
                          step_dz, (o_closure[0], o_closure[1], f_closure[0], f_closure[1]), oracle, fw)


def plot_walk(c: WalkComparison, path: Path, rate_hz: float = 250.0) -> Path:  # pragma: no cover - a picture
    """One walk's picture: both tracks in plan, their height over time, and ten seconds of the stance
    flags (the firmware's under the oracle's)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(c.firmware.zupt)
    t = np.arange(n) / rate_hz
    fig = plt.figure(figsize=(11, 8))
    ax = fig.add_subplot(2, 2, (1, 3))
    tracks = ((c.oracle.position[:n], "reference oracle"), (c.firmware.position, "emulated firmware"))
    for pos, label in tracks:
        ax.plot(pos[:, 1], pos[:, 0], label=label)
    ax.plot([0], [0], "ko", label="start = true end")
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.set_aspect("equal")
    ax.legend(loc="best")
    ax.set_title(f"{c.name}: closure {c.closure[0]:.3f} % (oracle), {c.closure[2]:.3f} % (firmware)")
    ax = fig.add_subplot(2, 2, 2)
    ax.plot(t, -c.oracle.position[:n, 2], label="reference oracle")
    ax.plot(t, -c.firmware.position[:, 2], label="emulated firmware")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("height [m] (up)")
    ax.legend(loc="best")
    ax = fig.add_subplot(2, 2, 4)
    window = slice(int(20 * rate_hz), int(30 * rate_hz))
    ax.step(t[window], c.oracle.stance[:n][window] + 1.2, where="post", label="oracle stance")
    ax.step(t[window], c.firmware.zupt[window] * 1.0, where="post", label="firmware ZUPT")
    ax.set_yticks([0.5, 1.7], ["firmware", "oracle"])
    ax.set_xlabel("time [s]")
    ax.set_title(f"stance flags, {100 * c.agreement:.2f} % of samples agree")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> None:  # pragma: no cover - a report for a person
    import argparse

    from tests.conftest import WALK_IDS, have_walks, walk_path

    p = argparse.ArgumentParser(prog="python -m tests.oracle.compare", description=__doc__.split("\n\n")[0])
    p.add_argument("--png", type=Path, metavar="DIR", help="also draw each walk's picture into DIR")
    args = p.parse_args(argv)
    if not have_walks():
        raise SystemExit("the shared walks are not here (see tests/conftest.py)")
    print(WalkComparison.HEADER)
    for w in WALK_IDS:
        c = compare_walk(walk_path(w))
        print(c.row())
        if args.png is not None:
            plot_walk(c, args.png / f"{c.name}.png")


if __name__ == "__main__":  # pragma: no cover
    main()
