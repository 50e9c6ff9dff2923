"""The OpenShoe protocol conformance suite (`openshoe-conformance`).

Written from protocol.md alone: it tells whether any device — a real module or
an emulator — speaks the wire protocol exactly. :data:`checks.CHECKS` is the
registry (each check in a group: ``protocol``, or ``extensions`` — the emulator's own functions
and states, reported present or absent, since a real module lacks them);
:class:`driver.DeviceDriver` talks to a pyserial port; :func:`checks.run` returns a
:class:`results.RunReport`.
"""

from .checks import CHECKS, Check, run
from .driver import CheckFailed, DeviceDriver
from .results import CheckResult, RunReport, Status

__all__ = ["CHECKS", "Check", "CheckFailed", "CheckResult", "DeviceDriver", "RunReport", "Status", "run"]
