"""Ctrl-C ends ``openshoe-host track``'s walk — the outputs go off, the summary is written — also in
a process started with SIGINT ignored (a script's background job, a test runner's worker), where
Python would keep the ignore and the walk would run on."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="signals as on Linux")


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def test_sigint_ends_the_walk_of_a_host_started_with_sigint_ignored():
    argv = [sys.executable, "-m", "hostlib.cli", "track", "openshoe://?scenario=stand:600&speed=1",
            "--duration", "300"]
    proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, preexec_fn=_ignore_sigint, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        said = []
        for line in proc.stderr:  # waits on the host's own line: it is tracking
            said.append(line)
            if line.startswith("tracking "):
                break
        assert said and said[-1].startswith("tracking "), said
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    assert "Track(" in out and "Traceback" not in err
