"""The compass's level diagnosis: a swing B sin ψ + C cos ψ fitted from the readings' errors, and the
table's line per seed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lab.accuracy.compass_level import WAYS, dip_swing, summary_lines, swing_fit


def test_the_fit_recovers_a_swing_and_its_offset_from_a_loop_of_headings():
    psi = np.radians(np.arange(0.0, 360.0, 15.0))
    errors = np.radians(0.2 - 1.5 * np.sin(psi) + 0.7 * np.cos(psi))
    rms, a, b, c = swing_fit(errors, psi)
    assert (a, b, c) == pytest.approx((0.2, -1.5, 0.7), abs=1e-9)
    assert rms == pytest.approx(math.degrees(float(np.sqrt(np.mean(errors ** 2)))))


def test_the_dip_gives_back_the_heading_swing_a_level_error_makes():
    """The fit's sense: errors B sin ψ + C cos ψ come with dips κ (B cos ψ − C sin ψ), κ = cot I."""
    psi = np.radians(np.arange(0.0, 360.0, 15.0))
    inclination = math.radians(72.5)
    kappa = 1.0 / math.tan(inclination)
    dips = np.radians(0.3 + kappa * (-1.5 * np.cos(psi) - 0.7 * np.sin(psi)))
    assert dip_swing(dips, psi, inclination) == pytest.approx((-1.5, 0.7), abs=1e-9)


def test_the_table_has_a_line_per_seed_with_each_levelling_and_the_level_early_and_late():
    row = {"seed": 2, "module": 42, "readings": 686, "lag_ms": {6.0: 686},
           **{way: (1.78 - k, 0.1, -1.48 + k, -0.69) for k, way in enumerate(WAYS)},
           "level_first_minute_deg": (0.06, -0.14), "level_after_five_deg": (0.32, -0.31),
           "gyro_warmup_deg_s": (-0.053, 0.060), "dip_swing_local": (-1.68, -0.89),
           "dip_swing_earth": (-0.89, -1.75)}
    lines = summary_lines([row])
    assert len(lines) == 2
    assert "seed  2: 1.78, -1.48, -0.69  0.78, -0.48, -0.69  -0.22, +0.52, -0.69" in lines[1]
    assert "lag 6: 686" in lines[1] and "level +0.06/-0.14 → +0.32/-0.31" in lines[1]
    assert "dip's swing (local) -1.68, -0.89   dip's swing (earth) -0.89, -1.75" in lines[1]
