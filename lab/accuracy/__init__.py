"""`python -m lab.accuracy`: what the height and drift aids gain, on recordings and on slopes.

Two experiments of the slope-height and drift-correction papers (shared/spec/aids.md §4–5),
each run through the emulated module and the host SDK exactly as a user runs them
(``openshoe-emu replay --host fusion [--height-compensation]``, ``openshoe-host drift``):

``python -m lab.accuracy walks FILE...``
    replays closed-loop recordings (e.g. ``../shared/data/openshoe-walks/walk_*.txt``) with the
    fusion host, with and without the module's height compensation, and corrects each walk's
    drift with a calibration from the *other* walks (leave-one-out: the walk corrected never
    calibrates itself). Prints a per-walk table of horizontal and 3-D closure in % of the
    distance — plain, height compensation, drift correction, both — with the means, and writes
    ``OUT/walks.csv`` and ``OUT/height-walk.png`` (height over distance of the first walk).
``python -m lab.accuracy slopes``
    walks the ramps (``ramp_0``, ``ramp_2.5``, ``ramp_6``, ``ramp_7.5``: 50 m up and back down;
    ``ramp_diagonal``: 7.8° at 45° to the fall line) and, as the flat control, ``walk`` (100 m),
    with simulated modules (``--seeds``), with and without height compensation. Prints the
    height error at the top of the ramp and at the end, mean and largest over the seeds, and
    writes ``OUT/slopes.csv`` and ``OUT/height-ramp.png``; ``--ramps ramp_6,…`` walks only those
    ramps (and the flat control).

The heading aids' and two feet's experiments (§1–3, §6) have their own subcommands, each
documented in its module and listed by ``python -m lab.accuracy --help``: ``navshoe-outage``
(:mod:`.navshoe`), ``navshoe-house`` (:mod:`.house`), ``walks-compass FILE...``
(:mod:`.walks_compass`: the real walks with their magnetometers), ``two-feet-*``
(:mod:`.two_feet`), ``consistency`` (:mod:`.consistency`: is the summed covariance honest?),
``error-free [SCENARIO...]`` (:mod:`.error_free`: what the navigation loses with error-free sensors).

The runs go through the project's Dask runner, :func:`firmware_sim.app.cluster.execute`
(:mod:`lab.runner`): a local cluster of ``--workers`` processes, an existing cluster
(``--scheduler tcp://HOST:PORT``), or here one after the other (``--workers 0``). ``speeds`` is a
sweep spec (``lab/accuracy/speeds.toml``, :mod:`.speeds`).
"""

from __future__ import annotations

from .cli import main

__all__ = ["main"]
