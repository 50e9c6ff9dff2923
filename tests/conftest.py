"""Shared test fixtures: where the real walk recordings are, and skipping without them; every test
keeps its magnetometer calibrations in a folder of its own (never the user's)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

#: The tests pin the simulation's own default stance (gait.STANCE_SWAY_DEFAULT), whatever the
#: user's shell asks of the tools.
os.environ.pop("OPENSHOE_STANCE_SWAY", None)

REPO = Path(__file__).resolve().parent.parent
#: The shared recordings live beside the clone (never copied into it);
#: OPENSHOE_WALKS overrides the location.
WALKS_DIR = Path(os.environ.get("OPENSHOE_WALKS", REPO.parent / "shared" / "data" / "openshoe-walks"))
WALK_IDS = ("2", "3", "30", "31", "32", "33")


def walk_path(walk_id: str) -> Path:
    return WALKS_DIR / f"walk_100521_{walk_id}.txt"


def have_walks() -> bool:
    return all(walk_path(w).is_file() for w in WALK_IDS)


requires_walks = pytest.mark.skipif(
    not have_walks(),
    reason=f"the shared OpenShoe walk recordings are not at {WALKS_DIR} "
    "(a plain clone has no ../shared; set OPENSHOE_WALKS to their folder)",
)


@pytest.fixture
def walks_dir() -> Path:
    if not have_walks():
        pytest.skip(f"shared walk recordings not found at {WALKS_DIR}")
    return WALKS_DIR


@pytest.fixture(autouse=True)
def own_magcal_dir(tmp_path_factory, monkeypatch) -> Path:
    """``OPENSHOE_MAGCAL_DIR`` (hostlib.calibration.magcal's per-module calibrations) set to an empty
    folder of
    this test's, for it and the processes it starts: no test reads or writes the user's."""
    folder = tmp_path_factory.mktemp("magcal")
    monkeypatch.setenv("OPENSHOE_MAGCAL_DIR", str(folder))
    return folder
