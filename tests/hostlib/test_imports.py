"""The host SDK's data path depends on protocol/ and pyserial only: no emulator, no matplotlib.

The events and the step summation are lighter still: numpy and the standard library.
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def run_fresh(code: str) -> str:
    """What *code* prints in a fresh interpreter started in the repository (it must succeed)."""
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_host_sdk_does_not_import_the_emulator_or_matplotlib():
    code = (
        "import sys, hostlib, hostlib.link.device, hostlib.cli, hostlib.files.export, hostlib.files.plot\n"
        "d = hostlib.Device('loop://'); d.close()\n"
        "bad = sorted(m for m in sys.modules if m.split('.')[0] in ('firmware_sim', 'matplotlib', 'tools'))\n"
        "print(bad)\n"
    )
    assert run_fresh(code).strip() == "[]"


def _third_party_modules_after(statement: str) -> dict[str, list[str]]:
    """The non-stdlib packages and hostlib modules a fresh interpreter loads for *statement* (after numpy)."""
    code = (
        "import sys, json\n"
        "import numpy\n"
        "before = set(sys.modules)\n"
        f"{statement}\n"
        "new = set(sys.modules) - before\n"
        "top = sorted({m.split('.')[0] for m in new} - set(sys.stdlib_module_names))\n"
        "ours = sorted(m for m in new if m.split('.')[0] == 'hostlib')\n"
        "print(json.dumps({'top': top, 'hostlib': ours}))\n"
    )
    return json.loads(run_fresh(code))


def test_the_events_module_needs_nothing_but_numpy_and_the_standard_library():
    loaded = _third_party_modules_after("import hostlib.events")
    assert loaded["top"] == ["hostlib"]
    assert loaded["hostlib"] == ["hostlib", "hostlib.errors", "hostlib.events", "hostlib.track",
                                 "hostlib.track.rows", "hostlib.track.step_checks", "hostlib.track.steps"]


def test_summing_steps_loads_no_protocol_decoding_and_no_serial_port():
    loaded = _third_party_modules_after(
        "import hostlib.track.steps; from hostlib import StepEvent, StepTracker")
    assert loaded["top"] == ["hostlib"]


def test_the_events_module_source_imports_only_protocol_numpy_and_the_standard_library():
    """Also what it names for type checkers only: the events never reach into the I/O side."""
    tree = ast.parse((REPO / "hostlib" / "events.py").read_text())
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, "hostlib.events imports no other hostlib module"
            imported.add((node.module or "").split(".")[0])
    assert imported - set(sys.stdlib_module_names) <= {"numpy", "protocol"}


def test_every_public_name_of_the_host_sdk_resolves_and_is_documented():
    import hostlib

    for name in hostlib.__all__:
        obj = getattr(hostlib, name)
        assert obj.__doc__, f"hostlib.{name} has no docstring"
        assert name in hostlib.__doc__ or obj.__module__ in ("hostlib.events", "hostlib.errors"), name
