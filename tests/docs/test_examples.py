"""Every shell and Python example in README.md, hostlib/README.md and docs/ is marked, and runs or
is checked as its marker says (:mod:`tests.docs.examples`)."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import pytest

from .conftest import example_env
from .examples import KINDS, ROOT, Block, code_blocks, parse_jobs, shell_script, substituted

BLOCKS = code_blocks()
RUN = [b for b in BLOCKS if b.kind == "example"]
CHECKED = [b for b in BLOCKS if b.kind in ("needs-hardware", "long-run")]
LONG = [b for b in BLOCKS if b.kind == "long-run"]
TIMEOUT_S = 300


def test_every_example_is_marked():
    unmarked = [f"{b.name} ({b.lang})" for b in BLOCKS if b.kind not in KINDS]
    assert unmarked == [], "mark each block <!-- example -->, <!-- needs-hardware -->, <!-- long-run --> " \
                           "or <!-- not-run: why -->"
    counts = Counter(b.kind for b in BLOCKS)
    print(f"\nexamples: {counts['example']} run, {counts['needs-hardware']} need hardware, "
          f"{counts['long-run']} long runs, {counts['not-run']} not run")


def test_no_command_hides_in_an_indented_block():
    """An indented (unfenced) block cannot carry a marker: commands go in fenced blocks."""
    command = re.compile(r"^ {4}(openshoe-(emu|host|conformance)|python -m|make )")
    found = []
    for page in {ROOT / b.page for b in BLOCKS} | {ROOT / "README.md"}:
        in_fence = False
        for k, line in enumerate(page.read_text().splitlines(), start=1):
            if line.lstrip().startswith(("```", "~~~")):
                in_fence = not in_fence
            elif not in_fence and command.match(line):
                found.append(f"{page.relative_to(ROOT)}:{k}: {line.strip()}")
    assert found == []


def _copy_fixtures(src: Path, dst: Path) -> None:
    for item in src.iterdir():
        (shutil.copytree if item.is_dir() else shutil.copy)(item, dst / item.name)


def _run_block(block: Block, tmp_path: Path, fixture_files: Path, command_bin: Path) -> None:
    _copy_fixtures(fixture_files, tmp_path)
    env = example_env(command_bin, tmp_path)
    if block.lang in ("python", "py"):
        script, args = tmp_path / "example.py", [sys.executable, "example.py"]
        script.write_text(substituted(block, tmp_path))
    else:
        script, args = tmp_path / "example.sh", ["bash", "example.sh"]
        script.write_text(shell_script(block, tmp_path))
    start = time.monotonic()
    try:
        done = subprocess.run(args, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=TIMEOUT_S,
                              start_new_session=True)
    except subprocess.TimeoutExpired as exc:
        pytest.fail(f"{block.name}: still running after {TIMEOUT_S} s\n{exc.stdout}\n{exc.stderr}")
    took = time.monotonic() - start
    assert done.returncode == 0, (f"{block.name} failed ({took:.1f} s):\n{script.read_text()}\n--- stdout\n"
                                  f"{done.stdout[-3000:]}\n--- stderr\n{done.stderr[-5000:]}")
    print(f"{block.name}: {took:.1f} s")


@pytest.mark.slow
@pytest.mark.parametrize("block", RUN, ids=[b.name for b in RUN])
def test_example_runs(block, tmp_path, fixture_files, command_bin):
    _run_block(block, tmp_path, fixture_files, command_bin)


@pytest.mark.parametrize("block", LONG, ids=[b.name for b in LONG])
def test_long_run(block, tmp_path, fixture_files, command_bin):
    if os.environ.get("OPENSHOE_DOCS_LONG") != "1":
        pytest.skip("an experiment of minutes: OPENSHOE_DOCS_LONG=1 runs it")
    _run_block(block, tmp_path, fixture_files, command_bin)


def test_unrun_examples_parse():
    """The commands of the examples that do not run here have options their parsers take; their
    Python compiles. The parsers run in a process of their own."""
    jobs, where = [], []
    for block in CHECKED:
        if block.lang in ("python", "py"):
            compile(block.text, block.name, "exec")
            continue
        for parser, args in parse_jobs(block):
            jobs.append((parser, args))
            where.append(f"{block.name}: {parser} {' '.join(args)}")
    done = subprocess.run([sys.executable, str(Path(__file__).with_name("parse_commands.py"))],
                          input=json.dumps(jobs), capture_output=True, text=True, cwd=ROOT, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr
    errors = [f"{w}\n    {e}" for w, e in zip(where, json.loads(done.stdout), strict=True) if e]
    assert errors == []
    assert len(jobs) > 20


def test_the_makefile_has_the_targets_the_pages_name():
    makefile = (ROOT / "Makefile").read_text()
    targets = set(re.findall(r"^([\w-]+):", makefile, re.M))
    named = {m for b in BLOCKS if b.kind == "not-run" for m in re.findall(r"^make (\w+)", b.text, re.M)}
    assert named and named <= targets
    readme = (ROOT / "README.md").read_text()
    assert "make demo" in readme and "make test" in readme
