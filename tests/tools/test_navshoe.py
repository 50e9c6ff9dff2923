"""openshoe-accuracy navshoe-outage: one seed of NavShoe's outage loop through the module and the
receiver's NMEA, tracked five ways; GPS trains the declination, the compass aligns the heading."""

from __future__ import annotations

import csv
import io

from tools.accuracy import main, navshoe


def test_one_seed_of_the_outage_loop_is_tracked_five_ways(tmp_path):
    out = io.StringIO()
    assert main(["navshoe-outage", "--seeds", "3", "--workers", "0", "--out", str(tmp_path)], out) == 0
    text = out.getvalue()
    assert "630 m walked without GPS" in text and (tmp_path / "navshoe-outage.csv").is_file()
    with (tmp_path / "navshoe-outage.csv").open() as f:
        rows = {r["host"]: r for r in csv.DictReader(f)}
    assert set(rows) == set(navshoe.HOSTS)
    both = rows["compass+gps"]
    assert both["aligned_by"] == "compass" and rows["gps"]["aligned_by"] == "gps"
    assert int(both["gps_updates"]) > 20 and int(both["compass_updates"]) > 500
    assert float(both["declination_sigma_deg"]) < 5.0  # 15° before: GPS made it observable
    assert rows["plain"]["gps_updates"] == rows["plain"]["compass_updates"] == "0"
    uncalibrated = rows["compass+gps uncalibrated"]
    assert float(both["end_error_pct_without_gps"]) < float(uncalibrated["end_error_pct_without_gps"])
