"""`python -m lab.spread`: where the end of a straight walk lands, walk after walk, module after module.

The module paper's experiment (OpenShoe / MIMU22BT): fifty 100 m straight walks; the track's
end against the true end, as systematic length and height errors (up to 0.5 % of the distance)
and a spread across the track of a couple of decimetres, plotted as a scatter with its 1σ
ellipse. Here the walks are simulated: ``python -m lab.spread`` walks ``--route`` (default ``walk``,
100 m straight; any scenario or recipe of ``openshoe-emu sweep``) once per seed of ``--seeds``
(default ``1:51``), each walk a new module (its own systematic errors), or, with ``--module N``,
module N every time (only the walk's noise changes).

It prints, for the length (along the true final heading), across-track and height errors of the
track's end, their mean and sample standard deviation (1σ, N−1) in metres and in % of each
walk's tracked distance, the same for the heading error, and the horizontal spread
√trace(cov(along, across)). It writes ``OUT/spread.csv`` (one row per walk: the columns of
:func:`firmware_sim.app.runs.run_one`) and ``OUT/spread.png`` (across-track against along-track
errors with the 1σ ellipse and the mean, like the paper's Fig. 7, beside the height error of
each walk).

``--compare-module N`` walks the seeds twice, with a new module each walk and with module N each
walk, and prints the ratio of module N's horizontal spread to the fleet's: one module's ends
cluster (Bachmann et al.), the fleet's scatter by the modules' own errors.

The walks run on a local Dask cluster of ``--workers`` processes (default 2) or in this process
(``--workers 0``); the figures are the same either way.
"""

from __future__ import annotations

from .cli import main
from .experiment import walk_groups, walk_routes
from .summary import Spread, lines

__all__ = ["Spread", "lines", "main", "walk_groups", "walk_routes"]
