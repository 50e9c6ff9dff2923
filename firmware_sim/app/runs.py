"""Many batch replays: one run per recording, or per scenario and seed, with its metrics.

A :class:`RunSpec` names what one run replays — a recording file, or a simulated scenario
with a seed — and the settings it changes (:mod:`firmware_sim.app.settings`). :func:`run_one`
replays it exactly as ``openshoe-emu replay`` does (:func:`firmware_sim.app.batch.run_replay`:
the same module, the same lossless host, the same bytes), optionally writes the wire bytes,
and sums the steps the host received (:func:`hostlib.files.replay.replay_bytes`) into a row:

* ``samples``, ``step_packets``, ``steps`` (the step packets that moved the foot,
  :attr:`hostlib.track.steps.Track.motion_steps`), ``distance_m`` (summed horizontal step lengths);
* ``closure_m``, ``closure_pct`` — for a closed loop, the horizontal distance from the end of
  the track to its start, in metres and in % of ``distance_m``. Recordings are taken as closed
  loops (the shared walks are); a scenario is one when its true path ends within 5 cm of its
  start, else both are NaN;
* for a scenario, the error of the track's end against the ground truth, in the frame the
  track starts in (:meth:`~firmware_sim.sensors.truth.GroundTruth.stances_in_start_frame`):
  ``end_along_m`` and ``end_across_m`` along and to the right of the walker's true final heading
  (for a straight walk: the length and across-track errors), ``end_height_m`` (positive: the
  track ends above the truth) and ``end_heading_deg``; NaN for a recording;
* ``wire_bytes`` and ``wire_sha256`` of what the module sent;
* timings: ``parse_s`` (reading the recording, or simulating the scenario: :func:`load`),
  ``nav_s`` (the module's run), ``write_s``, ``time_s`` (all of the run's work, the metrics
  too). Timings are the only columns that differ between two runs of the same spec.
"""

from __future__ import annotations

import csv
import hashlib
import math
import re
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from . import settings as run_settings

__all__ = ["METRICS", "TIMINGS", "Loaded", "RunSpec", "columns", "end_errors", "file_runs", "finish", "load",
           "parse_seeds", "run_group", "run_many", "run_one", "scenario_runs", "summary_lines", "write_csv",
           "write_rows"]

#: The columns every row has, after the run's identity and its settings.
METRICS = ("samples", "filled_samples", "step_packets", "steps", "distance_m", "closure_m", "closure_pct",
           "end_along_m", "end_across_m", "end_height_m", "end_heading_deg", "wire_bytes", "wire_sha256")
#: The timing columns of a run [s]: parsing, navigation, writing and all of it.
TIMINGS = ("parse_s", "nav_s", "write_s", "time_s")
#: A scenario whose true path ends this close [m] to its start is a closed loop.
CLOSED_LOOP_M = 0.05


@dataclass(frozen=True)
class RunSpec:
    """One run: ``kind`` "file" (``source`` a path) or "scenario" (``source`` a name or recipe)."""

    kind: str
    source: str
    seed: int = 0
    rate_hz: float = 1000.0  #: sample rate of a simulated scenario
    settings: tuple[tuple[str, Any], ...] = ()
    name: str = ""  #: output file stem, unique within a batch
    #: the simulated module's identity (its own errors, its serial number); None: the seed's own module
    module: int | None = None
    #: the replayed host (:data:`firmware_sim.app.batch.HOSTS`) and whether it turns height
    #: compensation on; they change the wire bytes, not the row's columns
    host: str = "plain"
    height_compensation: bool = False
    #: the replayed fusion host also runs the in-situ magnetometer calibration (the wiggle's stream)
    calibrate_mag: bool = False
    #: a scenario's walking stances sway and vibrate
    #: (:class:`firmware_sim.sensors.stance_sway.StanceSway`); None:
    #: :data:`~firmware_sim.sensors.stance_sway.STANCE_SWAY_DEFAULT`. It changes the wire bytes and
    #: the truth, not the row's columns
    stance_sway: bool | None = None

    @property
    def walking_module(self) -> int | None:
        """The module that walks a scenario (:attr:`module`, else the seed's own); None for a
        recording, which carries its own module's sensors."""
        if self.kind == "file":
            return None
        return self.seed if self.module is None else self.module

    @property
    def key(self) -> tuple:
        """What rows are sorted by: source, module, seed, then the settings' values in their order."""
        module = self.seed if self.walking_module is None else self.walking_module
        return (self.kind, self.source, module, self.seed, *(v for _, v in self.settings))


#: The most seeds one run list takes (a typo's 0:100000000000 ran out of memory).
MAX_SEEDS = 100_000


def parse_seeds(text: str) -> list[int]:
    """``A:B`` (half-open: A … B−1), ``N``, or ``N,M,…``: whole numbers >= 0, at most
    :data:`MAX_SEEDS` of them."""
    try:
        if ":" in text:
            a, b = (int(x) for x in text.split(":"))
            if not 0 <= a < b:
                raise ValueError
            seeds = range(a, b)
        else:
            seeds = [int(x) for x in text.split(",")]
            if min(seeds) < 0:
                raise ValueError
    except ValueError:
        raise ValueError(f"seeds must be A:B (0 <= A < B), N or N,M,… (whole numbers >= 0); got {text!r}"
                         ) from None
    if len(seeds) > MAX_SEEDS:
        raise ValueError(f"seeds {text!r} are {len(seeds)} seeds: at most {MAX_SEEDS} in one run")
    return list(seeds)


def _stem(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("_") or "run"


def _unique(names: Iterable[str]) -> list[str]:
    seen: dict[str, int] = {}
    out = []
    for name in names:
        n = seen[name] = seen.get(name, 0) + 1
        out.append(name if n == 1 else f"{name}-{n}")
    return out


def file_runs(paths: Sequence[str | Path], seeds: Sequence[int] = (0,),
              settings: tuple[tuple[str, Any], ...] = ()) -> list[RunSpec]:
    """Runs of recordings, in the order given; a stem met twice gets ``-2``, ``-3``, …"""
    pairs = [(str(p), s) for p in paths for s in seeds]
    stems = [Path(p).stem + (f"_seed{s}" if len(seeds) > 1 else "") for p, s in pairs]
    return [RunSpec("file", p, s, settings=settings, name=n) for (p, s), n in zip(pairs, _unique(stems),
                                                                                   strict=True)]


def scenario_runs(names: Sequence[str], seeds: Sequence[int], rate_hz: float = 1000.0,
                  settings: tuple[tuple[str, Any], ...] = (), module: int | None = None) -> list[RunSpec]:
    """Runs of simulated scenarios: every name with every seed, output ``<name>_seed<N>``
    (``<name>_module<M>_seed<N>`` for one *module* walked with every seed)."""
    pairs = [(n, s) for n in names for s in seeds]
    tag = "" if module is None else f"_module{module}"
    stems = _unique(f"{_stem(n)}{tag}_seed{s}" for n, s in pairs)
    return [RunSpec("scenario", n, s, rate_hz, settings, stem, module)
            for (n, s), stem in zip(pairs, stems, strict=True)]


@dataclass
class Loaded:
    """A run's sensor source, made ready (:func:`load`): the part of a run that reads a file or
    simulates a walk, which a reader thread may do while the previous run navigates."""

    source: Any
    truth: Any  #: the scenario's ground truth (None for a recording)
    applied: run_settings.Applied
    parse_s: float


def load(spec: RunSpec) -> Loaded:
    """Read the recording (or simulate the scenario) of *spec* with its settings applied."""
    t0 = time.perf_counter()
    applied = run_settings.apply(spec.settings)
    if spec.kind == "file":
        from .batch import load_walk

        source, truth = load_walk(spec.source), None
    else:
        from firmware_sim.sensors.imu_array import make_source

        sway = spec.stance_sway if applied.stance_sway is None else applied.stance_sway
        source = make_source(spec.source, seed=spec.seed, rate_hz=applied.rate_hz or spec.rate_hz,
                             config=applied.sensors, module=spec.module, stance_sway=sway)
        truth = source.truth
    return Loaded(source, truth, applied, time.perf_counter() - t0)


def _closed_loop(truth) -> bool:
    if truth is None:
        return True
    p = truth.stance_positions
    return len(p) > 1 and math.hypot(*(p[-1, :2] - p[0, :2])) <= CLOSED_LOOP_M


def end_errors(track, truth) -> dict[str, float]:
    """The error of *track*'s end against *truth* (see the module docstring); NaN without truth."""
    keys = ("end_along_m", "end_across_m", "end_height_m", "end_heading_deg")
    if truth is None or len(track) == 0:
        return dict.fromkeys(keys, math.nan)
    end = truth.stances_in_start_frame()[-1]
    heading = truth.heading_change()
    d = track.final_pose[:3] - end
    along = (math.cos(heading), math.sin(heading))
    return dict(zip(keys, (d[0] * along[0] + d[1] * along[1], -d[0] * along[1] + d[1] * along[0],
                           -float(d[2]), math.degrees(math.remainder(float(track.final_pose[3]) - heading,
                                                                     2.0 * math.pi))), strict=True))


def _metrics(data: bytes, samples: int, truth, filled: int = 0) -> dict[str, Any]:
    from hostlib.files.replay import replay_bytes

    track, _stats = replay_bytes(data)
    measured = _closed_loop(truth) and len(track) > 0
    return {"samples": samples, "filled_samples": filled, "step_packets": len(track),
            "steps": track.motion_steps,
            "distance_m": float(track.distance),
            "closure_m": track.closure_error() if measured else math.nan,
            "closure_pct": 100.0 * track.relative_closure_error() if measured else math.nan,
            **{k: float(v) for k, v in end_errors(track, truth).items()},
            "wire_bytes": len(data), "wire_sha256": hashlib.sha256(data).hexdigest()}


def run_one(spec: RunSpec, wire_dir: Path | None = None) -> dict[str, Any]:
    """Replay *spec* (writing ``wire_dir/<name>.bin`` and, for a scenario, its ``.truth.csv``);
    returns its row: name, kind, source, seed, the settings, :data:`METRICS`, :data:`TIMINGS`."""
    return finish(spec, load(spec), wire_dir)


def run_many(specs: Sequence[RunSpec], wire_dir: Path | None = None) -> list[dict[str, Any]]:
    """:func:`run_one` of every spec, their replays in lockstep (:func:`run_group`); the rows in order."""
    return run_group(specs, [load(spec) for spec in specs], wire_dir)


def finish(spec: RunSpec, loaded: Loaded, wire_dir: Path | None = None) -> dict[str, Any]:
    """The rest of :func:`run_one` once the source is :func:`load`-ed: run, write, measure."""
    return run_group([spec], [loaded], wire_dir)[0]


def run_group(specs: Sequence[RunSpec], loaded: Sequence[Loaded], wire_dir: Path | None = None
              ) -> list[dict[str, Any]]:
    """:func:`finish` of K runs, their replays in lockstep (:mod:`firmware_sim.app.replay_group`: each
    run's bytes those of its replay alone); a row each, in order. A run's ``nav_s`` is its share
    of the group's navigation (the group's time / K)."""
    from firmware_sim.mcu.module import ModuleConfig, module_serial  # (not transports.factory's: its imports)

    from .batch import start_replay
    from .replay_group import run_replays
    from .truth_files import write_truth_files

    t1 = time.perf_counter()
    configs, hosts = [], []
    for spec, run in zip(specs, loaded, strict=True):
        states = run.applied.initial_states
        configs.append(ModuleConfig(rate_hz=float(run.source.rate_hz), initial_states=states,
                                    mcu_serial=module_serial(spec.module)))
        hosts.append(start_replay(run.source, config=configs[-1], announce=None,
                                  bt_port=run.applied.make_link(spec.seed), host=spec.host,
                                  height_compensation=spec.height_compensation,
                                  calibrate_mag=spec.calibrate_mag))
    results = run_replays(hosts)
    nav_s = (time.perf_counter() - t1) / len(hosts)
    rows = []
    for spec, run, config, data in zip(specs, loaded, configs, results, strict=True):
        t2 = time.perf_counter()
        if wire_dir is not None:
            wire = Path(wire_dir) / f"{spec.name}.bin"
            wire.write_bytes(data)
            if run.truth is not None:
                write_truth_files(run.source, wire, config.mcu_serial)
        t3 = time.perf_counter()
        row: dict[str, Any] = {"name": spec.name, "kind": spec.kind, "source": spec.source, "seed": spec.seed,
                               "module": spec.walking_module}
        row.update(spec.settings)
        row.update(_metrics(data, data.samples, run.truth, getattr(run.source, "filled_samples", 0)))
        row.update(parse_s=run.parse_s, nav_s=nav_s, write_s=t3 - t2,
                   time_s=run.parse_s + nav_s + time.perf_counter() - t2)
        rows.append(row)
    return rows


# ---------------------------------------------------------------------------------------------
# the summary a person reads


def _fmt(value: Any, digits: int | None) -> str:
    if isinstance(value, float):
        return "–" if math.isnan(value) else f"{value:g}" if digits is None else f"{value:.{digits}f}"
    return str(value)


def summary_lines(rows: Sequence[dict[str, Any]], setting_names: Sequence[str] = ()) -> list[str]:
    """A fixed-width table, one line per run, and a last line with the totals."""
    cols = [("name", "name", 0), *((n, n, None) for n in setting_names), ("samples", "samples", 0),
            ("steps", "steps", 0), ("distance_m", "distance [m]", 2), ("closure_m", "closure [m]", 3),
            ("closure_pct", "closure [%]", 2), ("time_s", "time [s]", 3)]
    cells = [[h for _, h, _ in cols]] + [[_fmt(r.get(k, ""), d) for k, _, d in cols] for r in rows]
    widths = [max(len(c[i]) for c in cells) for i in range(len(cols))]
    lines = ["  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths,
                                                                                          strict=True)))
             for row in cells]
    total = sum(r["time_s"] for r in rows)
    closures = [r["closure_pct"] for r in rows if not math.isnan(r["closure_pct"])]
    mean = f"; mean closure {sum(closures) / len(closures):.3f} %" if closures else ""
    parse, nav, write = (sum(r[k] for r in rows) for k in ("parse_s", "nav_s", "write_s"))
    kinds = {r["kind"] for r in rows}
    reading = {frozenset({"file"}): "parsing", frozenset({"scenario"}): "simulating"}.get(
        frozenset(kinds), "parsing/simulating")
    filled = [r for r in rows if r.get("filled_samples")]
    put_back = (f"; {sum(r['filled_samples'] for r in filled)} samples the recorders skipped put back "
                f"(interpolated) in {len(filled)} file{'s' if len(filled) > 1 else ''}") if filled else ""
    lines.append(f"{len(rows)} runs, {total:.2f} s in the runs: {reading} {parse:.2f} s, "
                 f"navigation {nav:.2f} s, writing {write:.2f} s{mean}{put_back}")
    return lines


def columns(setting_names: Sequence[str] = ()) -> list[str]:
    """A row's columns, in order: identity, settings, :data:`METRICS`, :data:`TIMINGS`."""
    return ["name", "kind", "source", "seed", "module", *setting_names, *METRICS, *TIMINGS]


def write_csv(rows: list[dict[str, Any]], path: Path, setting_names: tuple[str, ...] = ()) -> Path:
    """The rows as CSV: identity, settings, metrics, timings (:func:`write_rows`)."""
    return write_rows(rows, path, columns(setting_names))


def write_rows(rows: Sequence[dict[str, Any]], path: Path, header: Sequence[str] | None = None) -> Path:
    """*rows* as CSV, the columns *header* (default: the first row's keys); floats (numpy's too) in
    shortest round-trip form, None as an empty cell."""
    header = list(rows[0]) if header is None and rows else list(header or ())
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for row in rows:
            w.writerow(["" if v is None else float.__repr__(v) if isinstance(v, float) else v
                        for v in (row[k] for k in header)])
    return path
