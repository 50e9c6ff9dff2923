"""`make demo` end to end: the demo program runs, tracks the walk through a pty and draws it.

The full demo walks the 233 m built-in route; here the same program walks a
short recipe so the test stays quick, and checks what a user reads: the
summary's numbers against the ground truth, and the PNG and CSV it wrote.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys

import pytest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="ptys are tested on Linux")


@pytest.mark.slow
def test_demo_tracks_a_short_walk_and_draws_it(tmp_path):
    out = tmp_path / "out"
    r = subprocess.run(
        [sys.executable, "-m", "firmware_sim.app.demo",
         "--scenario", "stand:3+walk:12+arc:2:90+walk:4+stand:2", "--out", str(out)],
        capture_output=True, text=True, timeout=240,
    )
    assert r.returncode == 0, r.stdout + r.stderr
    text = r.stdout
    assert "OpenShoe demo — summary" in text
    steps = int(re.search(r"step packets\s+(\d+)", text).group(1))
    moved = int(re.search(r"steps with motion\s+(\d+)", text).group(1))
    walker = int(re.search(r"the walker took (\d+)", text).group(1))
    assert moved == walker, "the host counts the walker's steps by the same rule as the ground truth"
    assert steps >= moved
    distance = float(re.search(r"distance\s+([\d.]+) m", text).group(1))
    error = float(re.search(r"error at the end\s+([\d.]+) m", text).group(1))
    sigma = float(re.search(r"final 1σ\s+([\d.]+) m", text).group(1))
    assert steps >= 10
    assert 17.0 < distance < 21.0  # 12 m + a quarter circle of radius 2 m + 4 m ≈ 19.1 m
    assert error < 1.0
    assert 0.0 < sigma < 1.0
    assert "0 gaps, 0 steps missing" in text
    png = (out / "track.png").read_bytes()
    assert png.startswith(b"\x89PNG\r\n\x1a\n")
    csv_lines = (out / "track.csv").read_text().splitlines()
    assert len(csv_lines) >= steps


def test_demo_reports_a_bad_scenario_in_one_line(tmp_path):
    r = subprocess.run([sys.executable, "-m", "firmware_sim.app.demo", "--scenario", "moonwalk:3", "--out",
                        str(tmp_path)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2  # refused before anything is walked, as a usage error
    assert r.stderr.startswith("demo: --scenario: unknown scenario 'moonwalk:3'")
    assert r.stderr.count("\n") <= 1
    assert "Traceback" not in r.stderr


@pytest.mark.slow
def test_make_demo_walks_the_default_route_faster_than_real_time(tmp_path):
    """What `make demo` runs: the 235 m built-in route, closed loop, no shared data needed."""
    r = subprocess.run([sys.executable, "-m", "firmware_sim.app.demo", "-q", "--out", str(tmp_path)],
                       capture_output=True, text=True, timeout=600,
                       env={**os.environ, "OPENSHOE_WALKS": str(tmp_path / "no-walks")})
    assert r.returncode == 0, r.stdout + r.stderr
    text = r.stdout
    true_distance = float(re.search(r"\(true ([\d.]+) m\)", text).group(1))
    distance = float(re.search(r"distance\s+([\d.]+) m", text).group(1))
    error = float(re.search(r"error at the end\s+([\d.]+) m", text).group(1))
    ratio = float(re.search(r"\(([\d.]+)× real time\)", text).group(1))
    assert true_distance > 200
    assert abs(distance - true_distance) / true_distance < 0.02
    assert error / true_distance < 0.01, "closes within 1 % of the distance"
    assert "loop closure" in text and "0 gaps, 0 steps missing" in text
    assert ratio > 1.0, "virtual time runs faster than real time"
    assert (tmp_path / "track.png").stat().st_size > 10_000
