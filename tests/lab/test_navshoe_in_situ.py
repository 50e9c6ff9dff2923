"""NavShoe's flow through the command lines: the table counts the seeds within the product's marks
(≤ 1 % of the distance without GPS, ≤ half the GPS-only host's error) per flow and host."""

from __future__ import annotations

from lab.accuracy.navshoe_in_situ import HOSTS, end_error_m, summary_lines


def _rows(percent_of) -> list[dict]:
    return [{"seed": seed, "flow": flow, "host": host, "end_error_pct_without_gps": percent_of(seed, host)}
            for seed in (1, 2) for flow, host in HOSTS]


def test_the_table_counts_the_seeds_within_one_percent_and_half_of_gps_alone():
    lines = summary_lines(_rows(lambda seed, host: {"--gps": 3.0}.get(host, 0.5 if seed == 1 else 1.8)))
    compass = next(line for line in lines if "separate" in line and line.rstrip().endswith("0.50 1.80")
                   and "--compass " in line)
    assert "mean  1.15" in compass and "worst  1.80" in compass
    assert "≤ 1 %: 1/2" in compass and "≤ 0.5× --gps: 1/2" in compass
    assert len(lines) == 1 + len(HOSTS)


def test_the_end_error_is_the_tracks_last_row_from_its_first(tmp_path):
    path = tmp_path / "track.csv"
    path.write_text("index,x_north_m,y_east_m\n0,1.0,2.0\n1,5.0,5.0\n2,4.0,6.0\n")
    assert end_error_m(path) == 5.0


def test_the_house_table_counts_the_seeds_each_host_ends_nearer_than_plain():
    from lab.accuracy.house_in_situ import HOSTS as HOUSE_HOSTS
    from lab.accuracy.house_in_situ import summary_lines as house_summary

    pct = {"plain": (0.10, 0.10), "--compass": (0.05, 0.30), "--compass, not calibrated": (0.10, 0.20)}
    rows = [{"seed": seed, "host": host, "end_error_pct": pct[host][k]}
            for k, seed in enumerate((1, 2)) for host in HOUSE_HOSTS]
    lines = house_summary(rows)
    assert len(lines) == 1 + len(HOUSE_HOSTS)
    compass = next(line for line in lines if line.lstrip().startswith("--compass "))
    assert "mean 0.175" in compass and "worst 0.300" in compass and "nearer than plain: 1/2" in compass
    assert "nearer than plain: 0/2" in next(line for line in lines if "not calibrated" in line)
