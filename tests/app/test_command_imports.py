"""A command imports what it uses: ``--help`` and a mistyped command load no numba, no navigation
kernels and no web stack; the host's commands load the web stack only for a live page."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
#: What a command that runs no module and serves no page has no use for.
HEAVY = ("numba", "llvmlite", "firmware_sim.nav", "asyncio", "aiohttp", "hostlib.web.server")


def loaded_after(module: str, argv: list[str]) -> list[str]:
    """The modules of *HEAVY* a fresh interpreter holds after ``module.main(argv)`` (which exits)."""
    code = (
        "import sys, json, importlib\n"
        f"main = importlib.import_module({module!r}).main\n"
        f"try:\n    main({argv!r})\nexcept SystemExit:\n    pass\n"
        f"heavy = {HEAVY!r}\n"
        "print(json.dumps(sorted(m for m in sys.modules if m.startswith(heavy))))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.splitlines()[-1])


@pytest.mark.parametrize("argv", [["--help"], ["no-such-command"], []])
def test_the_emulators_help_and_usage_errors_import_no_numba_and_no_web_stack(argv):
    assert loaded_after("firmware_sim.app.cli", argv) == []


@pytest.mark.parametrize("argv", [["--help"], ["track", "--help"], ["replay", "--help"], ["info", "--help"]])
def test_the_hosts_help_imports_no_web_stack_and_no_emulator(argv):
    assert loaded_after("hostlib.cli", argv) == []


def test_a_subcommands_help_builds_only_that_subcommand():
    from firmware_sim.app import cli

    chosen = cli.build_parser("sweep")
    sub = next(a for a in chosen._actions if a.dest == "command")
    assert {"serve", "replay", "sweep"} == set(sub.choices)
    assert sub.choices["sweep"]._actions[1:], "the chosen subcommand has its options"
    assert [a.dest for a in sub.choices["serve"]._actions] == ["help"], "the others are only listed"


@pytest.mark.parametrize("module", ["firmware_sim.app.serve", "hostlib.cli.track"])
def test_serving_and_tracking_import_the_web_stack_only_for_a_page(module):
    web = ("asyncio", "aiohttp", "hostlib.web.server")
    code = (f"import sys, importlib; importlib.import_module({module!r})\n"
            f"print(sorted(m for m in sys.modules if m.startswith({web!r})))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize("argv", [["replay", "--help"], ["serve", "--help"], ["sweep", "--help"],
                                  ["replay", "--no-such-option"]])
def test_a_subcommands_help_and_usage_errors_import_no_numba_and_no_web_stack(argv):
    loaded = loaded_after("firmware_sim.app.cli", argv)
    assert [m for m in loaded if not m.startswith("firmware_sim.nav")] == []


def test_runs_in_this_process_load_no_dask_distributed():
    """A sweep with ``--workers 0`` and the lab's serial runs start without Dask's distributed stack
    (it loads for a cluster only)."""
    code = ("import sys, firmware_sim.app.cluster, firmware_sim.app.sweep, lab.runner\n"
            "print(sorted(m for m in sys.modules if m.startswith('distributed')))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
