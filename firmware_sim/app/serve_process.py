"""``openshoe-emu serve`` as a subprocess, ready to use: for host applications' tests and the benchmarks.

:func:`spawn` starts it and waits for its READY line (:func:`parse_ready`); :class:`ServeProcess` stops it.
:func:`read_until` reads a subprocess's pipe until what it said is enough, by a deadline (spawn's READY line;
a host's page address in the live pages' tests).
"""

from __future__ import annotations

import os
import selectors
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from typing import IO, Any


class ServeProcess:
    """``openshoe-emu serve`` as a subprocess, ready to use (see :func:`spawn`).

    ``ready`` maps the READY line's keys to values (``{"bt-pty": "/tmp/x", …}``).
    Use as a context manager; :meth:`stop` sends SIGTERM and returns the exit status.
    """

    def __init__(self, proc: subprocess.Popen, ready: dict[str, str]):
        self.proc = proc
        self.ready = ready

    def stop(self, timeout: float = 10.0) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if self.proc.stdout is not None:
            self.proc.stdout.close()
        return self.proc.returncode

    def __enter__(self) -> ServeProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def __repr__(self) -> str:
        return f"ServeProcess(pid {self.proc.pid}, {self.ready})"


def parse_ready(line: str) -> dict[str, str]:
    """``READY k=v k=v`` → {k: v}; ValueError for anything else."""
    words = line.split()
    if not words or words[0] != "READY":
        raise ValueError(f"not a READY line: {line!r}")
    return dict(w.split("=", 1) for w in words[1:])


def spawn(*serve_args: str, timeout: float = 20.0, stderr: Any = subprocess.DEVNULL,
          python: str = sys.executable, env: dict[str, str] | None = None) -> ServeProcess:
    """Start ``openshoe-emu serve *serve_args*`` and wait (at most *timeout* s) for its READY line.

    *env*: the process's environment (default: this one's)."""
    proc = subprocess.Popen([python, "-m", "firmware_sim.app.cli", "serve", *serve_args],
                            stdout=subprocess.PIPE, stderr=stderr, stdin=subprocess.DEVNULL, env=env)
    assert proc.stdout is not None
    buf, ended = read_until(proc, proc.stdout, lambda said: b"\n" in said, timeout)
    if ended:
        proc.kill()
        proc.wait()
        why = f"exited with {proc.returncode}" if ended == "exited" else f"no READY line within {timeout} s"
        raise RuntimeError(f"openshoe-emu serve {' '.join(serve_args)}: {why}; stdout {buf!r}")
    return ServeProcess(proc, parse_ready(buf.split(b"\n", 1)[0].decode()))


def read_until(proc: subprocess.Popen, pipe: IO[bytes], enough: Callable[[bytes], bool],
               timeout: float) -> tuple[bytes, str]:
    """Read *pipe* (one of *proc*'s) until ``enough(all read so far)``; the bytes read and ``""``, or
    ``"exited"`` when *proc* ended first, ``"timeout"`` when *timeout* seconds passed first. The pipe
    is blocking again afterwards."""
    fd = pipe.fileno()
    os.set_blocking(fd, False)
    buf = b""
    deadline = time.monotonic() + timeout
    try:
        with selectors.DefaultSelector() as sel:
            sel.register(fd, selectors.EVENT_READ)
            while not enough(buf):
                left = deadline - time.monotonic()
                if left <= 0:
                    return buf, "timeout"
                if proc.poll() is not None:
                    return buf, "exited"
                if sel.select(min(left, 0.2)):
                    buf += os.read(fd, 65536)
        return buf, ""
    finally:
        os.set_blocking(fd, True)
