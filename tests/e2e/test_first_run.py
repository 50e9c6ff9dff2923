"""A new user's first run: an empty compiled-kernel cache must never make a host wait.

numba compiles the tracking kernels on first use (about 10 s on a 2-core machine)
unless its on-disk cache has them. Each test here runs in a fresh process whose
``NUMBA_CACHE_DIR`` is an empty folder — exactly what a fresh clone looks like —
and drives the module as a host would, with ack timeouts far shorter than a
compile: the demo, ``serve`` with a host on its pty, and the ``openshoe://`` URL
handler in virtual time and in real time.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from urllib.parse import quote

import pytest

from firmware_sim.app.serve import spawn
from firmware_sim.nav import fastpath
from firmware_sim.nav.warmup import FIRST_RUN_NOTICE

pytestmark = [
    pytest.mark.skipif(not sys.platform.startswith("linux"), reason="ptys are tested on Linux"),
    pytest.mark.slow,
]

#: A short walk: alignment, a few steps, rest.
SHORT_WALK = "stand:3+walk:6+stand:2"


def cold_env(tmp_path) -> dict[str, str]:
    """This environment with an empty numba cache (as in a fresh clone), numba optimizing least
    (``NUMBA_OPT=0``): the compile takes half the CPU and still lasts many times an ack timeout,
    which is what these tests need; ``make test`` fills the cache with the full compile first.
    Nothing is built ahead of time (``OPENSHOE_AOT=0``): that build, after the compile and before the
    clock as well, would only double each test's CPU (tests/nav/test_aot.py checks it)."""
    cache = tmp_path / "numba-cache"
    cache.mkdir()
    return {**os.environ, "NUMBA_CACHE_DIR": str(cache), "NUMBA_OPT": "0", "OPENSHOE_AOT": "0"}


def expect_notice(text: str) -> None:
    """With numba the user is told why the first start is slow; without it, nothing compiles."""
    if fastpath.available():
        assert FIRST_RUN_NOTICE in text


def test_demo_succeeds_on_the_first_try_with_an_empty_kernel_cache(tmp_path):
    r = subprocess.run([sys.executable, "-m", "firmware_sim.app.demo", "--scenario", SHORT_WALK,
                        "--out", str(tmp_path / "out")],
                       capture_output=True, text=True, timeout=600, env=cold_env(tmp_path))
    assert r.returncode == 0, r.stdout + r.stderr
    assert "OpenShoe demo — summary" in r.stdout
    expect_notice(r.stdout)
    if fastpath.available():  # said before the module starts, not after a failure
        assert r.stdout.index(FIRST_RUN_NOTICE) < r.stdout.index("[2/4]")
    moved = int(re.search(r"steps with motion\s+(\d+)", r.stdout).group(1))
    walker = int(re.search(r"the walker took (\d+)", r.stdout).group(1))
    assert moved == walker > 0


def test_serve_answers_its_first_host_at_once_with_an_empty_kernel_cache(tmp_path):
    from hostlib import Device

    err = tmp_path / "serve.err"
    with open(err, "w") as err_file, spawn("--pty", str(tmp_path / "shoe"), "--scenario", SHORT_WALK,
                                           "--status-interval", "0", timeout=600, stderr=err_file,
                                           env=cold_env(tmp_path)) as served:
        with Device(served.ready["bt-pty"], ack_timeout=1.0, retries=1) as dev:
            dev.start_stepwise_dead_reckoning()  # AckTimeout if the module were compiling
            step = dev.recv_step(timeout=30.0)
    assert step is not None and step.step.counter >= 1
    expect_notice(err.read_text())


URL_HOSTS = textwrap.dedent("""
    import sys, threading
    from hostlib import Device
    opened = threading.Barrier(len(sys.argv) - 1)

    def host(url):
        opened.wait()  # both ports open at once, while the first of them compiles
        with Device(url, ack_timeout=1.0, retries=1) as dev:
            dev.start_stepwise_dead_reckoning()
            ev = dev.recv_step(timeout=30.0)
            print("STEP", url.rsplit("=", 1)[1], ev.step.counter if ev else None, flush=True)

    threads = [threading.Thread(target=host, args=(url,)) for url in sys.argv[1:]]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
""")


def test_url_handler_answers_at_once_with_an_empty_kernel_cache(tmp_path):
    """In virtual time (speed 0) and in real time (speed 4), opened together: each port prepares the
    kernels before its module's clock starts, so neither host waits on the one compile (a port that
    started its clock first would block on it, and its host's ack would time out)."""
    urls = [f"openshoe://?scenario={quote(SHORT_WALK, safe=':')}&speed={speed}"  # '+' is %2B in a query
            for speed in (0, 4)]
    r = subprocess.run([sys.executable, "-c", URL_HOSTS, *urls], capture_output=True, text=True,
                       timeout=600, env=cold_env(tmp_path))
    assert r.returncode == 0, r.stdout + r.stderr
    for speed in (0, 4):
        assert re.search(rf"STEP {speed} \d+", r.stdout), r.stdout + r.stderr
    expect_notice(r.stderr)
