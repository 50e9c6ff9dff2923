"""``openshoe-host``: track, log and inspect an OpenShoe module (real or emulated) from a terminal.

    openshoe-host info  /dev/rfcomm0
    openshoe-host track /dev/rfcomm0 --duration 60 --csv walk.csv --png walk.png
    openshoe-host log   socket://localhost:5000 --raw capture.bin --duration 10
    openshoe-host track /dev/rfcomm0 --steps 100 --csv walk.csv      # stop after 100 step packets
    openshoe-host replay capture.bin --csv walk.csv

Two feet (a module on each; hostlib.fusion.feet): both streams acked and gap-checked on their own, fused
into one body track (the feet's midpoint); a lost link on one foot degrades the fusion to the
other foot, it never stops it::

    openshoe-host track /dev/rfcomm0 /dev/rfcomm1 --csv walk.csv      # LEFT RIGHT
    openshoe-host replay left.bin right.bin --csv walk.csv --png walk.png
    openshoe-host replay left.bin right.bin --compass --gps walk.nmea --drift left.json right.json

Per-module calibrations (--drift, --mag-cal) then take one file per foot, the left foot's first
(- for none); each is checked against the serial number of the module on its foot.

``track`` and ``log`` send the fusion set-up after 0x34 (protocol.extensions.FUSION_SETUP: each step's
swing time, module time, attitude and magnetometers, and the module's serial number), which the module's
warm-up, the aids, the drift correction and the calibrations matched by serial number need; ``--no-fusion``
leaves it out (plain 0x34 step packets, for an experiment), and a module that does not acknowledge it is
tracked on plain packets, said once. ``--fusion`` is accepted and changes nothing.

Heading aids on a live walk (hostlib.fusion.tracker): a compass update per step, and GPS
fixes from a receiver read as they come (hostlib.run.gps_stream), each put on the module's clock; with a
module on each foot, each foot's compass and the body's fixes, each fix on each module's clock::

    openshoe-host track /dev/rfcomm0 --compass --gps /dev/ttyACM0 --csv walk.csv
    openshoe-host track /dev/rfcomm0 /dev/rfcomm1 --compass --gps /dev/ttyACM0 --csv walk.csv

In-situ magnetometer calibration (hostlib.calibration.wiggle, NavShoe's): once tracking started, wiggle the
shoe in one place for about 30 s — toe down and up, the sole to either side, all round — then walk
off: the first step longer than 0.5 m ends it. It is saved for the module (hostlib.calibration.magcal; the
directory --mag-cal-dir, else $OPENSHOE_MAGCAL_DIR, else $XDG_CONFIG_HOME/openshoe/magcal), and
--compass without --mag-cal takes the saved one of the module it talks to. ``log`` records the
wiggle's stream in its capture (and saves the calibration too), for ``replay`` to fit it again::

    openshoe-host track /dev/rfcomm0 --compass --calibrate-mag --csv walk.csv
    openshoe-host track /dev/rfcomm0 --compass --csv later.csv
    openshoe-host log /dev/rfcomm0 --start --calibrate-mag --raw walk.bin
    openshoe-host replay walk.bin --compass --calibrate-mag --csv walk.csv

Closed-loop drift correction (per module; hostlib.calibration.drift): record closed loops with the fusion
set-up, calibrate from them, then correct the module's later walks::

    openshoe-host log /dev/rfcomm0 --start --raw loop1.bin --duration 120
    openshoe-host drift calibrate loop1.bin -o cal.json
    openshoe-host replay walk.bin --csv walk.csv --drift cal.json
    openshoe-host track /dev/rfcomm0 --drift cal.json --csv walk.csv

URL is anything pyserial opens: a device path (``/dev/rfcomm0``, ``/dev/ttyACM0``,
``COM5``), ``socket://host:port``, ``loop://``, or the emulator's ``openshoe://``.

The package has a module per command (:mod:`~hostlib.cli.track`, :mod:`~hostlib.cli.log`,
:mod:`~hostlib.cli.info`, :mod:`~hostlib.cli.replay`, :mod:`~hostlib.cli.drift`), the parser and
:func:`main` (:mod:`~hostlib.cli.app`), the options the commands share and the objects they become
(:mod:`~hostlib.cli.options`), and what a walk leaves (:mod:`~hostlib.cli.outputs`); a walk with live
modules is a :class:`~hostlib.run.tracking_run.TrackingRun`.
"""

from importlib import import_module
from typing import TYPE_CHECKING

from .app import build_parser, main
from .options import usage_refusal

if TYPE_CHECKING:  # type checkers see the functions the lazy __getattr__ below hands out
    from ..run.status import feet_summary_line, heading_deg, summary_line
    from .outputs import feet_summary

#: What the lazy names come from: ``openshoe-host --help`` imports neither the fusion nor a walk's
#: status (a command imports its own module: :data:`~hostlib.cli.app.COMMANDS`).
_LAZY = {"feet_summary_line": "..run.status", "heading_deg": "..run.status", "summary_line": "..run.status",
         "feet_summary": ".outputs"}

__all__ = ["build_parser", "feet_summary", "feet_summary_line", "heading_deg", "main", "summary_line",
           "usage_refusal"]


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module 'hostlib.cli' has no attribute {name!r}")
