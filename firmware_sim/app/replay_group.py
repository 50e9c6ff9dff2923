"""Batch replays run K at a time in lockstep: each module's bytes are those of its replay alone.

:func:`run_replays` takes the hosts of K replays (:func:`firmware_sim.app.batch.start_replay`) and
runs them together: each round every replay still reading its source asks for the loops its
:meth:`~firmware_sim.app.batch.LosslessHost.run_source` would run next, one
:class:`~firmware_sim.nav.lockstep.Lockstep` advances all the modules (their quiet stretches in one
compiled call), and each host then reads and acknowledges what its module sent, as alone. A replay
whose source has ended drains its queue loop by loop while the others go on (the modules share
nothing, so the order between them changes no byte). ``openshoe-emu replay FILE... --wire-dir``
and a sweep's runs go through here (:func:`firmware_sim.app.runs.run_group`).
"""

from __future__ import annotations

from collections.abc import Sequence

from firmware_sim.nav.lockstep import Lockstep

from .batch import LosslessHost, ReplayResult, source_length

__all__ = ["LOCKSTEP_RUNS", "run_replays"]

#: Replays run together by default (``--wire-dir``, sweeps): the K of the lockstep.
LOCKSTEP_RUNS = 16
#: The most loops one round asks of a module (run_replay's progress interval: the same stretches).
_ROUND_LOOPS = 5000


def run_replays(hosts: Sequence[LosslessHost]) -> list[ReplayResult]:
    """Run the replays of *hosts* to their ends together (see the module doc); their results, in order."""
    totals = [source_length(h.module.sensors) for h in hosts]
    group = Lockstep([h.module for h in hosts])
    while True:
        loops = [h.source_loops(total, _ROUND_LOOPS) for h, total in zip(hosts, totals, strict=True)]
        if not any(loops):
            break
        for host, ran in zip(hosts, group.advance(loops), strict=True):
            if ran:
                host.after_loops(ran)
    for host in hosts:
        host.drain()
    return [host.result() for host in hosts]

