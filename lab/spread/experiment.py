"""The walks of a spread experiment: one route, many seeds, new modules or one module.

A walk is a run of :mod:`firmware_sim.app.runs` (:func:`~firmware_sim.app.runs.scenario_runs`,
:func:`~firmware_sim.app.runs.run_one`); the runs go through
:func:`firmware_sim.app.cluster.execute` (:func:`lab.runner.execute`), on a local Dask cluster, an
existing one, or one after the other in this process, as ``openshoe-emu sweep`` runs them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from firmware_sim.sensors.config import DEFAULT_CONFIG

__all__ = ["POWERED_S", "Group", "check_route", "walk_groups", "walk_routes"]

#: Seeds to walk and the module that walks them (None: each seed its own, a new module per walk).
Group = tuple[Sequence[int], int | None]

#: How long each module has been on when its walk starts [s], by default: five time constants of
#: the emulated warm-up (``TemperatureConfig.settled_s``, 600 s). The module paper's fifty walks
#: were walked one after another, so its modules were warm for all but the first; a walk of
#: ``openshoe-emu`` starts at power-on instead (``powered_s`` 0).
POWERED_S = DEFAULT_CONFIG.temperature.settled_s


def check_route(route: str) -> None:
    """Raise ValueError unless *route* is a scenario name (``list_scenarios()``) or a recipe of
    pieces that :func:`firmware_sim.sensors.imu_array.make_source` accepts."""
    from firmware_sim.sensors import scenarios

    try:
        scenarios.trajectory(route)  # what make_source builds first; milliseconds even for track400
    except (KeyError, ValueError) as e:
        raise ValueError(e.args[0] if e.args else f"bad route {route!r}") from None


def walk_groups(route: str, groups: Sequence[Group], workers: int = 2, scheduler: str | None = None,
                quiet: bool = True, powered_s: float = POWERED_S) -> list[list[dict[str, Any]]]:
    """The rows of every group's walks of *route*, group by group, each in the order of its seeds;
    all on one cluster (*scheduler*'s, or a local one of *workers* processes), or here in turn
    when *workers* is 0 and there is no *scheduler*. Each module has been on for *powered_s*
    seconds when its walk starts (the setting ``sensors.temperature.powered_s``)."""
    from firmware_sim.app.runs import scenario_runs
    from lab.runner import execute

    warm = (("sensors.temperature.powered_s", float(powered_s)),)
    specs = [scenario_runs([route], list(seeds), settings=warm, module=module) for seeds, module in groups]
    rows = execute([spec for group in specs for spec in group], workers=workers, scheduler=scheduler,
                   quiet=quiet)
    out, start = [], 0
    for group in specs:
        out.append(rows[start:start + len(group)])
        start += len(group)
    return out


def walk_routes(route: str, seeds: Sequence[int], module: int | None = None, workers: int = 2,
                scheduler: str | None = None, quiet: bool = True,
                powered_s: float = POWERED_S) -> list[dict[str, Any]]:
    """The rows of *route* walked once per seed: by *module* every time, or (None) by a new
    module each walk; see :func:`walk_groups`."""
    return walk_groups(route, [(seeds, module)], workers, scheduler, quiet, powered_s)[0]
