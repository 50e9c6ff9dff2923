"""The host SDK's data path depends on protocol/ and pyserial only: no emulator, no matplotlib."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_host_sdk_does_not_import_the_emulator_or_matplotlib():
    code = (
        "import sys, hostlib, hostlib.device, hostlib.cli, hostlib.export, hostlib.plot\n"
        "d = hostlib.Device('loop://'); d.close()\n"
        "bad = sorted(m for m in sys.modules if m.split('.')[0] in ('firmware_sim', 'matplotlib', 'tools'))\n"
        "print(bad)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
