"""A served walk and a host tracking it, each in a subprocess with its live page, for the browser
tests and the scripts beside them (:mod:`tests.web.screenshots`, :mod:`tests.web.latency`).

:func:`served` starts ``openshoe-emu serve --web 0 --web-control`` (its panel's URL from the READY
line's ``web=``); :func:`tracking` starts ``openshoe-host track … --web 0`` and reads its page's URL
from the line it says on stderr. Every wait is on a line from the process, with a deadline.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from firmware_sim.app.serve import ServeProcess, spawn
from firmware_sim.app.serve_process import read_until

#: A short walk: alignment, a straight walk, two quarter arcs round a U, back, a stand.
RECIPE = "stand:3+walk:20+arc:4:90+walk:12+arc:4:90+walk:20+stand:3"


def page(address: str) -> str:
    """The URL of a page listening on ``HOST:PORT``."""
    return f"http://{address}/"


@contextmanager
def served(folder: Path, *, feet: int = 2, gps: bool = True, speed: float = 5.0, recipe: str = RECIPE,
           extra: Sequence[str] = (), timeout: float = 60.0) -> Iterator[ServeProcess]:
    """``openshoe-emu serve`` of *recipe* with its panel (buttons on) and a control channel, on ptys
    in *folder*: the walker's two feet (or one module), with a GPS receiver; its READY line within
    *timeout* seconds (a long walk's sensors are simulated before it)."""
    args = ["--scenario", recipe, "--pty", str(folder / "shoe"), "--speed", f"{speed:g}", "--control", "0",
            "--status-interval", "0", "--web", "0", "--web-control", *extra]
    if feet == 2:
        args += ["--feet", "2"]
    if gps:
        args += ["--gps-pty", str(folder / "gps")]
    with spawn(*args, timeout=timeout) as srv:
        yield srv


def module_urls(srv: ServeProcess) -> list[str]:
    """The served modules' ptys, the left foot's first."""
    keys = ("left.bt-pty", "right.bt-pty") if "left.bt-pty" in srv.ready else ("bt-pty",)
    return [srv.ready[k] for k in keys]


class Tracking:
    """``openshoe-host track`` running (:func:`tracking`): its process and its page's URL."""

    def __init__(self, proc: subprocess.Popen, url: str, said: list[str]):
        self.proc = proc
        self.url = url
        self.said = said  #: the last lines it said on stderr

    def stop(self, timeout: float = 30.0) -> int:
        """End the walk as Ctrl-C does (the outputs go off, the summary is written); the exit status."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        try:
            self.proc.wait(timeout)
        except subprocess.TimeoutExpired:  # every thread's stack into said (faulthandler), then gone
            self.proc.send_signal(signal.SIGABRT)
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(10)
        return self.proc.returncode


@contextmanager
def tracking(urls: Sequence[str], *, gps: str | None = None, duration: float = 20.0,
             extra: Sequence[str] = (), timeout: float = 60.0) -> Iterator[Tracking]:
    """``openshoe-host track URLS --web 0`` (with the compass and *gps*'s receiver, fused), until
    *duration* seconds of walk; its page's URL read from its stderr."""
    argv = [sys.executable, "-m", "hostlib.cli", "track", *urls, "--web", "0", "--duration", f"{duration:g}",
            *extra]
    if gps is not None:
        argv += ["--fusion", "--compass", "--gps", gps]
    proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            env={**os.environ, "PYTHONUNBUFFERED": "1", "PYTHONFAULTHANDLER": "1"})
    assert proc.stderr is not None
    said: list[str] = []
    try:
        url = _read_url(proc, said, timeout)
        yield Tracking(proc, url, said)
    finally:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        proc.stderr.close()


#: The line a host says its live page's address in (whole: up to its line feed).
PAGE_LINE = re.compile(rb"live page at (http://\S+)\r?\n")


def _read_url(proc: subprocess.Popen, said: list[str], timeout: float) -> str:
    buf, ended = read_until(proc, proc.stderr, lambda text: PAGE_LINE.search(text) is not None, timeout)
    said += [line.decode(errors="replace") for line in buf.split(b"\n")]
    if ended:
        raise RuntimeError(f"openshoe-host track gave no page URL ({proc.poll()}): {said}")
    _drain(proc, said)
    return PAGE_LINE.search(buf).group(1).decode()


def _drain(proc: subprocess.Popen, said: list[str]) -> None:
    """Read the rest of the host's stderr in a thread (its pipe must not fill up), keeping its last
    lines in *said*."""
    import threading

    def run() -> None:
        for line in proc.stderr:
            said.append(line.decode(errors="replace").rstrip("\n"))
            del said[:-200]

    threading.Thread(target=run, daemon=True).start()
