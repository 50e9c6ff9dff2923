"""What a sweep's table says: a leave-one-out choice of settings, and means per group of runs.

Both read the rows of :func:`firmware_sim.app.sweep.run_sweep` (one per run) and nothing else, so
they are the same whichever way the sweep ran.

* :func:`leave_one_out` — for each source (recording or scenario), the combination of settings with
  the smallest mean ``|metric|`` over the *other* sources' runs is chosen, and scored on the
  source left out (its mean over its seeds). It tells whether a setting chosen on some walks holds
  on another: a setting that is right for reasons is chosen the same in every fold.
* :func:`group_table` — runs grouped by some columns (e.g. the scenario, a rate and a sensor
  model), with the mean and standard deviation of metrics per group, in the order first met.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["Fold", "leave_one_out", "leave_one_out_lines", "group_table", "group_lines"]


@dataclass(frozen=True)
class Fold:
    """One source left out."""

    held_out: str
    chosen: tuple[Any, ...]  #: the settings' values chosen on the other sources
    score: float  #: the held-out source's mean |metric| at the chosen settings
    others: float  #: the other sources' mean |metric| there (what was minimised)


def _mean_abs(rows: Sequence[dict[str, Any]], metric: str) -> float:
    values = [abs(r[metric]) for r in rows if not math.isnan(r[metric])]
    return float(np.mean(values)) if values else math.nan


def leave_one_out(rows: Sequence[dict[str, Any]], setting_names: Sequence[str], metric: str) -> list[Fold]:
    """One :class:`Fold` per source, in the order the sources first appear in *rows*; ties go to the
    combination met first. Needs at least two sources."""
    if not setting_names:
        raise ValueError("a leave-one-out needs at least one setting with several values (--set)")
    if rows and metric not in rows[0]:
        raise ValueError(f"no column {metric!r} to choose by")
    sources = list(dict.fromkeys(r["source"] for r in rows))
    if len(sources) < 2:
        raise ValueError("a leave-one-out needs at least two recordings or scenarios")
    combos = list(dict.fromkeys(tuple(r[n] for n in setting_names) for r in rows))

    def at(combo: tuple[Any, ...], keep) -> list[dict[str, Any]]:
        return [r for r in rows if keep(r["source"]) and tuple(r[n] for n in setting_names) == combo]

    folds = []
    for held in sources:
        scores = [_mean_abs(at(c, lambda s, h=held: s != h), metric) for c in combos]
        best = min(range(len(combos)), key=lambda i: (math.isnan(scores[i]), scores[i], i))
        folds.append(Fold(held, combos[best], _mean_abs(at(combos[best], lambda s, h=held: s == h), metric),
                          scores[best]))
    return folds


def _name(source: str) -> str:
    return Path(source).stem if "/" in source or source.endswith((".txt", ".csv")) else source


def leave_one_out_lines(folds: Sequence[Fold], setting_names: Sequence[str], metric: str) -> list[str]:
    """The table a person reads, and a last line: the mean of the held-out scores."""
    short = [n.rsplit(".", 1)[-1] for n in setting_names]
    cells = [["held out", *(f"chosen {s}" for s in short), f"{metric} there", f"{metric} on the others"]]
    cells += [[_name(f.held_out), *(f"{v:g}" if isinstance(v, float) else str(v) for v in f.chosen),
               f"{f.score:.3f}", f"{f.others:.3f}"] for f in folds]
    widths = [max(len(c[i]) for c in cells) for i in range(len(cells[0]))]
    lines = ["  ".join(c.ljust(w) if i == 0 else c.rjust(w)
                       for i, (c, w) in enumerate(zip(row, widths, strict=True))) for row in cells]
    scores = [f.score for f in folds if not math.isnan(f.score)]
    worst = max(scores) if scores else math.nan
    lines.append(f"leave-one-out over {len(folds)} sources: mean {metric} {np.mean(scores):.3f}, "
                 f"worst {worst:.3f}, the same choice in {_same(folds)} of {len(folds)} folds")
    return lines


def _same(folds: Sequence[Fold]) -> int:
    choices = [f.chosen for f in folds]
    return max(choices.count(c) for c in choices)


def group_table(rows: Sequence[dict[str, Any]], by: Sequence[str],
                metrics: Sequence[str]) -> list[dict[str, Any]]:
    """One row per group of equal *by* values: those values, ``runs``, and ``<metric>_mean`` /
    ``<metric>_sd`` (population sd over the group's runs; NaNs left out)."""
    missing = [c for c in (*by, *metrics) if rows and c not in rows[0]]
    if missing:
        raise ValueError(f"no column {', '.join(map(repr, missing))} in the sweep's table")
    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault(tuple(r[c] for c in by), []).append(r)
    out = []
    for key, members in groups.items():
        row: dict[str, Any] = dict(zip(by, key, strict=True))
        row["runs"] = len(members)
        for m in metrics:
            values = np.array([r[m] for r in members if not math.isnan(r[m])], dtype=float)
            row[f"{m}_mean"] = float(values.mean()) if len(values) else math.nan
            row[f"{m}_sd"] = float(values.std()) if len(values) else math.nan
        out.append(row)
    return out


def group_lines(table: Sequence[dict[str, Any]], by: Sequence[str], metrics: Sequence[str]) -> list[str]:
    """*table* (:func:`group_table`) as fixed-width text, ``mean ± sd`` per metric."""
    cells = [[*(b.rsplit(".", 1)[-1] for b in by), "runs", *metrics]]
    for row in table:
        cells.append([*(_name(str(row[b])) if b == "source" else str(row[b]) for b in by), str(row["runs"]),
                      *(f"{row[f'{m}_mean']:+.4f} ± {row[f'{m}_sd']:.4f}" for m in metrics)])
    widths = [max(len(c[i]) for c in cells) for i in range(len(cells[0]))]
    return ["  ".join(c.ljust(w) if i < len(by) else c.rjust(w)
                      for i, (c, w) in enumerate(zip(row, widths, strict=True))) for row in cells]

