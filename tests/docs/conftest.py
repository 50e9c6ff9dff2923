"""What the documentation's examples run with: the project's commands on a PATH of their own, and
the files the examples read (captures, calibrations, a recording), made once per session."""

from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from .examples import ROOT, SHARED, page_files

#: Each command a page names, as the project's interpreter runs it.
COMMANDS = {
    "openshoe-emu": "firmware_sim.app.cli",
    "openshoe-host": "hostlib.cli",
    "openshoe-conformance": "tools.conformance.cli",
}

#: A short walk: 3 s standing, 10 m, 2 s standing (about 12 000 samples).
SHORT = "stand:3+walk:10+stand:2"


def example_env(bin_dir: Path, home: Path) -> dict[str, str]:
    """The environment an example runs in: the commands first on PATH, the clone importable (the
    lab runs from it), nothing written to the user's home; matplotlib's font list made once for
    every example (its config folder beside the shims), not again in each example's home."""
    env = dict(os.environ)
    env["PATH"] = f"{bin_dir}{os.pathsep}{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    env["HOME"] = str(home)
    env["XDG_CONFIG_HOME"] = str(home / ".config")
    env.pop("OPENSHOE_MAGCAL_DIR", None)
    env["MPLBACKEND"] = "Agg"
    env["MPLCONFIGDIR"] = str(bin_dir.with_name("matplotlib"))
    return env


@pytest.fixture(scope="session")
def command_bin(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder of shims: ``openshoe-emu`` … and ``python`` run the project's interpreter."""
    bin_dir = tmp_path_factory.mktemp("bin")
    for name, module in {**COMMANDS, "python": None, "python3": None}.items():
        run = f'exec "{sys.executable}" -m {module} "$@"' if module else f'exec "{sys.executable}" "$@"'
        shim = bin_dir / name
        shim.write_text(f"#!/bin/sh\n{run}\n")
        shim.chmod(0o755)
    return bin_dir


def _run(args: list[str], cwd: Path, env: dict[str, str]) -> None:
    done = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, f"{' '.join(args)}\n{done.stdout[-2000:]}\n{done.stderr[-4000:]}"


@pytest.fixture(scope="session")
def fixture_files(tmp_path_factory: pytest.TempPathFactory, command_bin: Path) -> Path:
    """The files the examples read, made by the tools themselves: ``walk.bin`` (a short walk with
    the fusion set-up, its truth and iron, ``walk.nmea``), ``capture.bin``, a walker's two feet
    (``w.bin.left``, ``w.bin.right``, ``left.bin``, ``right.bin``, each module's drift calibration
    ``left-cal.json``, ``right-cal.json``), ``cal.json``, a closed loop of module 3
    (``loop.bin``), a shared walk as ``walk.txt`` and as a recording in CSV (``walk.csv``), and
    the files the pages show (``<!-- file: NAME -->``)."""
    # made once per run: the workers of a distributed run share them (the examples copy them)
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent
    d, done = root / "doc-fixtures", root / "doc-fixtures.done"
    with open(root / "doc-fixtures.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            shutil.rmtree(d, ignore_errors=True)
            d.mkdir()
            _make_fixture_files(d, command_bin)
            done.touch()
    return d


def _make_fixture_files(d: Path, command_bin: Path) -> None:
    env = example_env(command_bin, d)
    emu = [sys.executable, "-m", COMMANDS["openshoe-emu"]]
    host = [sys.executable, "-m", COMMANDS["openshoe-host"]]
    _run([*emu, "replay", "--scenario", SHORT, "--host", "fusion", "--wire", "walk.bin", "--gps", "walk.nmea",
          "-q"], d, env)
    shutil.copy(d / "walk.bin", d / "capture.bin")
    _run([*emu, "replay", "--scenario", SHORT, "--feet", "2", "--host", "fusion", "--wire", "w.bin", "-q"],
         d, env)
    for side in ("left", "right"):
        shutil.copy(d / f"w.bin.{side}", d / f"{side}.bin")
        _run([*host, "drift", "calibrate", f"w.bin.{side}", "-o", f"{side}-cal.json"], d, env)
    _run([*host, "drift", "calibrate", "walk.bin", "-o", "cal.json"], d, env)
    _run([*emu, "replay", "--scenario", "stand:3+rectangle:20:10:1+stand:2", "--module", "3",
          "--host", "fusion", "--wire", "loop.bin", "-q"], d, env)
    walk = SHARED / "data" / "openshoe-walks" / "walk_100521_2.txt"
    if walk.is_file():
        shutil.copy(walk, d / "walk.txt")
        _run([sys.executable, "-c", "import sys; from firmware_sim.sensors.replay import load_recording, "
              "save_csv; save_csv(load_recording(sys.argv[1]), sys.argv[2])", str(walk), "walk.csv"], d, env)
    for name, text in page_files().items():
        (d / name).write_text(text)
