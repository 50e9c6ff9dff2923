"""Declination from the World Magnetic Model (pygeomag), where and when a walk starts."""

from __future__ import annotations

import datetime as dt

import pytest

from hostlib.aids.declination import decimal_year, declination_deg, magnetic_field


def test_a_date_is_a_fraction_of_its_year():
    assert decimal_year(dt.date(2026, 1, 1)) == 2026.0
    midyear = dt.datetime(2026, 7, 2, 12, tzinfo=dt.timezone.utc)
    assert decimal_year(midyear) == pytest.approx(2026.5, abs=1e-3)


def test_stockholm_has_a_few_degrees_east_and_a_steep_field():
    """Sweden's declination in the mid-2020s is 5–10° E (NOAA's charts), the dip about 73°."""
    f = magnetic_field(59.3498, 18.0707, 30.0, dt.date(2026, 6, 1))
    assert 5.0 < f.declination_deg < 10.0
    assert 70.0 < f.inclination_deg < 76.0 and 48_000 < f.total_nt < 55_000


def test_declination_changes_sign_across_the_agonic_line():
    when = dt.date(2026, 6, 1)
    assert declination_deg(40.0, -110.0, 0.0, when) > 5.0  # the western United States: east
    assert declination_deg(45.0, -70.0, 0.0, when) < -5.0  # New England: west


def test_a_date_outside_the_models_lifespan_is_refused_clearly():
    with pytest.raises(ValueError, match="no magnetic model for 1990-01-01"):
        declination_deg(59.0, 18.0, 0.0, dt.date(1990, 1, 1))
