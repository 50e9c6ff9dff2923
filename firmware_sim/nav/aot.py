"""The compiled loop built ahead of time: an extension module that runs without numba.

Importing numba and loading the compiled loop (:func:`firmware_sim.nav.driver.run_loops`) from
its cache take most of a fresh process's start: about 0.15 s and 0.1 s of a 0.5 s replay. So the
preparation that compiles or loads the loop with numba (:mod:`firmware_sim.nav.warmup`) also
builds it once with numba's ahead-of-time compiler (``numba.pycc``), for the argument types every
caller gives it (:data:`~firmware_sim.nav.driver.RUN_LOOPS_SIGNATURE`), and beside it the loop of K
modules in one call (:func:`~firmware_sim.nav.driver.run_group`, :func:`run_group`): the same kernels,
an extension module of its own (about 7 s, once). Later processes import that module in well under
a millisecond and never import numba (:func:`run_loops`); tests check its bytes against numba's
loop. Like numba's, the built loops release the GIL while they run
(:func:`firmware_sim.prebuilt.compile_releasing_gil`): a batch of many replays reads its next walks
in a thread beside them, and, once it asks for it (:func:`share_cores`), a lockstep's helper
thread runs half of its modules; a served process keeps its modules on its own thread, as it
always did with the built loop.

The module lives beside numba's cache (``NUMBA_CACHE_DIR`` when set, else the ``__pycache__``
of this package) and is named by the digest of the kernels' sources
(:func:`~firmware_sim.nav.kernel_sources.sources_stamp`): an edit of any of them names another
module, which the next preparation builds. A build that fails (no C compiler, a numba without
``pycc``) is remembered beside it and not tried again for those sources; the loop then stays
numba's. ``OPENSHOE_AOT=0`` turns the built loop off, and so does ``OPENSHOE_PURE=1``.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from firmware_sim import prebuilt
from firmware_sim.numba_use import pure_requested
from firmware_sim.sensors import openshoe_scan

from .kernel_sources import sources_stamp

__all__ = ["build", "module_path", "run_group", "run_loops", "share_cores", "shares_cores", "wanted"]

_HERE = Path(__file__).resolve().parent
_loaded: list[Callable[..., int] | None] = []  #: the loop once looked for (one element)
_loaded_group: list[Callable[..., int] | None] = []  #: the loop of K modules once looked for
_sharing: list[bool] = []  #: whether this process split the built loop of K modules (one element)


def wanted() -> bool:
    """Whether the loop built ahead of time may be used (neither ``OPENSHOE_AOT=0`` nor
    ``OPENSHOE_PURE=1``)."""
    return prebuilt.enabled() and not pure_requested()


def _name() -> str:
    return f"openshoe_loop_{sources_stamp().hex()[:24]}"


def module_path() -> Path:
    """Where the module built from the present sources is (or would be)."""
    return prebuilt.module_path(_HERE, _name())


def run_loops() -> Callable[..., int] | None:
    """The built loop (the arguments and result of :func:`firmware_sim.nav.driver.run_loops`,
    without numba), or None when there is none for the present sources or it is not wanted.
    Looked for once per process."""
    if not _loaded:
        _loaded.append(prebuilt.load(module_path(), "run_loops") if wanted() else None)
    return _loaded[0]


def run_group() -> Callable[..., int] | None:
    """The built loop of K modules in one call (:func:`firmware_sim.nav.driver.run_group`), from the
    same module as :func:`run_loops`; None when that one is None."""
    if run_loops() is None:
        return None
    if not _loaded_group:
        _loaded_group.append(prebuilt.load(module_path(), "run_group"))
    return _loaded_group[0]


def share_cores(share: bool = True) -> None:
    """Let a lockstep split each call of the built loop of K modules with a helper thread in this
    process (:mod:`firmware_sim.nav.lockstep`; numba's is split anyway): for a batch of many
    replays, which has the cores to itself; *share* False stops it (a worker process of a batch,
    which has one core of them)."""
    _sharing[:] = [share]


def shares_cores() -> bool:
    """Whether :func:`share_cores` was called in this process."""
    return bool(_sharing and _sharing[0])


def build() -> bool:
    """Build the loop for the present sources unless it is there, unwanted, or failed before, and
    the walk reader likewise (:func:`firmware_sim.sensors.openshoe_scan.build`); whether the loop
    is there now. Needs numba (its ``pycc``) and a C compiler; takes seconds. A process that looked
    for the loop before building it (the one that compiled numba's) then has :func:`run_loops`
    and :func:`run_group` look again: the modules it starts after the build run the built loop,
    and a lockstep of them no longer splits its calls with a helper thread (numba's would)."""
    openshoe_scan.build()
    if not wanted():
        return module_path().is_file()
    if module_path().is_file():
        return True
    built = prebuilt.build_once(module_path(), _compile)
    if built and _loaded == [None]:  # looked for before this build: the modules started next take it
        _loaded.clear()
        _loaded_group.clear()
    return built


def _compile(folder: Path) -> None:
    from numba.pycc import CC

    from .driver import RUN_GROUP_SIGNATURE, RUN_LOOPS_SIGNATURE
    from .driver import run_group as group
    from .driver import run_loops as loop

    cc: Any = CC(_name())
    cc.output_dir = str(folder)
    cc.verbose = False
    cc.export("run_loops", RUN_LOOPS_SIGNATURE)(getattr(loop, "py_func", loop))
    cc.export("run_group", RUN_GROUP_SIGNATURE)(getattr(group, "py_func", group))
    prebuilt.compile_releasing_gil(cc)
