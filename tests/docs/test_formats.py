"""docs/reference/formats.md's tables name exactly the columns and keys the tools write: each table
after ``<!-- format: FILE -->`` against FILE as the tools make it."""

from __future__ import annotations

import csv
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from .conftest import COMMANDS, SHORT, example_env
from .examples import ROOT

PAGE = ROOT / "docs" / "reference" / "formats.md"


def documented() -> dict[str, list[str]]:
    """FILE → the names in the first column of the table after its marker."""
    out: dict[str, list[str]] = {}
    lines = PAGE.read_text().splitlines()
    for k, line in enumerate(lines):
        m = re.match(r"<!-- format: (\S+) -->", line)
        if not m:
            continue
        names: list[str] = []
        for row in lines[k + 1:]:
            if not row.startswith("|"):
                break
            first = row.split("|")[1]
            names += re.findall(r"`([^`]+)`", first)
        out[m.group(1)] = names
    return out


TABLES = documented()


@pytest.fixture(scope="module")
def written(fixture_files, command_bin, tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("formats")
    for name in ("walk.bin.truth.csv", "walk.bin.iron.json", "cal.json"):
        (d / name).write_bytes((fixture_files / name).read_bytes())
    subprocess.run([sys.executable, "-m", COMMANDS["openshoe-emu"], "replay", "--scenario", SHORT,
                    "--seeds", "0:1", "--wire-dir", "wire", "--table", "runs.csv", "-q"], cwd=d,
                   check=True, env=example_env(command_bin, d), capture_output=True, timeout=600)
    return d


def test_every_table_names_a_file():
    assert set(TABLES) >= {"walk.bin.truth.csv", "walk.bin.iron.json", "cal.json", "runs.csv"}


@pytest.mark.parametrize("name", sorted(TABLES))
def test_the_table_is_the_file(name, written):
    path = written / name
    if path.suffix == ".json":
        actual = list(json.loads(path.read_text()))
    else:
        with path.open(newline="") as f:
            actual = next(csv.reader(f))
    assert TABLES[name] == actual
