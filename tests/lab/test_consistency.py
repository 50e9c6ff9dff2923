"""``python -m lab.accuracy consistency``: the normalised squared error of the end pose against the covariance
the host summed; its interval is χ²'s, a consistent set of errors reads 1, and a constant inflation
estimated on the other routes is applied to the one left out."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

from lab.accuracy import main
from lab.accuracy.consistency import (
    DOF,
    consistency_run,
    module_error_priors,
    nees_interval,
    nees_with_module_errors,
    sigma_ratio,
    summary_lines,
)


@pytest.mark.parametrize(("seeds", "dof", "low", "high"), [
    (20, 2, 24.433 / 40, 59.342 / 40),  # χ²(40) 2.5 % and 97.5 % quantiles
    (20, 1, 9.591 / 20, 34.170 / 20),  # χ²(20)
])
def test_the_interval_of_a_consistent_mean_is_chi_squareds(seeds, dof, low, high):
    lo, hi = nees_interval(seeds, dof)
    assert lo == pytest.approx(low, rel=0.01) and hi == pytest.approx(high, rel=0.01)


def _rows(scenario: str, scale: float, n: int = 400, seed: int = 0) -> list[dict]:
    """Rows of a filter whose covariance is too small by *scale* in σ: its NEES are scale² χ²."""
    rng = np.random.default_rng(seed)
    return [{"scenario": scenario, "seed": k, "steps": 10, "distance_m": 10.0,
             **{f"nees_{w}": scale ** 2 * float(np.sum(rng.normal(size=d) ** 2)) for w, d in DOF.items()},
             **{f"{kind}_{key}": 0.0 for kind in ("e", "sigma")
                for key in ("north_m", "east_m", "down_m", "heading_deg")}}
            for k in range(n)]


def test_an_honest_covariance_reads_one_and_an_over_confident_one_its_factor():
    assert sigma_ratio(_rows("a", 1.0), "h") == pytest.approx(1.0, abs=0.06)
    assert sigma_ratio(_rows("a", 3.0), "z") == pytest.approx(3.0, rel=0.1)


def test_an_inflation_from_the_other_routes_is_applied_to_the_one_left_out():
    rows = _rows("straight", 2.0, seed=1) + _rows("loop", 2.0, seed=2) + _rows("stairs", 8.0, seed=3)
    lines = {line.split()[0]: line for line in summary_lines(rows)[2:5]}
    k_stairs, after_stairs = (float(v) for v in
                              lines["stairs"].split("k")[-1].replace("→ σ ratio", "").split())
    assert k_stairs == pytest.approx(2.0, rel=0.1)  # what the two others need
    assert after_stairs == pytest.approx(4.0, rel=0.1)  # not enough for the stairs


def test_a_simulated_walk_gives_its_end_error_and_nees():
    row = consistency_run(("rectangle", 0))
    assert row["steps"] > 40 and row["distance_m"] == pytest.approx(90.0, rel=0.05)
    assert all(math.isfinite(row[f"nees_{w}"]) and row[f"nees_{w}"] >= 0.0 for w in DOF)
    e = np.array([row["e_north_m"], row["e_east_m"]])
    assert np.hypot(*e) < 1.0  # a 90 m rectangle closes within 1 %
    assert row["sigma_north_m"] > 0.0 and row["sigma_heading_deg"] > 0.0
    assert np.hypot(row["d_north_m"], row["d_east_m"]) < 1.0 and row["p_zz"] > 0.0  # a loop ends at its start


def test_the_default_host_holds_the_mimu22bt_priors_and_is_wider_than_the_plain_sum():
    """The default host's covariance (``openshoe-host replay`` as it comes) is the plain sum's plus
    the MIMU22BT-class module's errors through the run's Jacobian: its NEES is what the priors give
    by the Jacobian, and no larger than the plain sum's."""
    from hostlib.fusion.module_errors import MIMU22BT

    row = consistency_run(("walk", 3))
    expected = nees_with_module_errors(row, MIMU22BT)
    for w, value in zip(DOF, expected, strict=True):
        assert row[f"host_nees_{w}"] == pytest.approx(value, rel=1e-6)
        assert row[f"host_nees_{w}"] <= row[f"nees_{w}"]
    assert row["host_sigma_down_m"] > row["sigma_down_m"]  # the climb over 100 m


def test_the_command_writes_its_table(tmp_path):
    out = io.StringIO()
    argv = ["consistency", "--seeds", "0:2", "--workers", "0", "--out", str(tmp_path)]
    assert main(argv, out) == 0
    text = out.getvalue()
    assert "mean NEES / dof over 2 seeds" in text
    assert "the default host (the module's errors held at mimu22bt's priors): mean ε over 2 seeds" in text
    assert all(s in text for s in ("walk", "rectangle", "default"))
    assert (tmp_path / "consistency.csv").read_text().count("\n") == 1 + 3 * 2


def test_the_module_error_priors_are_recovered_from_end_errors_drawn_from_their_model():
    """Straight walks and loops with a step-length scale of 1σ 0.2 %, a climb of 1σ 3 mm/m and a
    turn scale of 1σ 1 % on top of the steps' own noise: the method-of-moments estimate gives all
    three back; straight walks teach no turn scale, closed loops no step-length scale."""
    rng = np.random.default_rng(7)
    rows = []
    for k in range(4000):
        length = 100.0
        straight = bool(k % 2)
        d = np.array([length, 0.0]) if straight else np.array([0.3, -0.2])
        turned = 0.05 if straight else 4 * math.pi
        p = np.diag([0.03 ** 2, 0.25 ** 2])
        e = rng.multivariate_normal(np.zeros(2), p) + rng.normal(0.0, 0.002) * d
        e_z = rng.normal(0.0, 0.03) + rng.normal(0.0, 0.003) * length
        e_chi = rng.normal(0.0, 0.004) + rng.normal(0.0, 0.01) * turned
        jac = {"j_ns": d[0], "j_es": d[1], "j_zc": length, "j_hk": turned}
        rows.append({"seed": k, "distance_m": length, "d_north_m": d[0], "d_east_m": d[1],
                     "e_north_m": e[0], "e_east_m": e[1], "e_down_m": e_z,
                     "e_heading_deg": math.degrees(e_chi),
                     "p_nn": p[0, 0], "p_ne": 0.0, "p_ee": p[1, 1], "p_zz": 0.03 ** 2, "p_chichi": 0.004 ** 2,
                     **{f"j_{r}{c}": jac.get(f"j_{r}{c}", 0.0) for r in "nezh" for c in "sck"}})
    errors = module_error_priors(rows)
    assert errors.step_scale_sigma == pytest.approx(0.002, rel=0.1)
    assert errors.climb_sigma == pytest.approx(0.003, rel=0.1)
    assert errors.turn_scale_sigma == pytest.approx(0.01, rel=0.1)
    assert module_error_priors(rows[::2]).step_scale_sigma == 0.0  # loops only: no scale to learn
    assert module_error_priors(rows[1::2]).turn_scale_sigma == 0.0  # straight only: no turns
    nees = np.array([nees_with_module_errors(r, errors) for r in rows])
    assert nees[:, 0].mean() / 2 == pytest.approx(1.0, abs=0.1)
    assert nees[:, 1].mean() == pytest.approx(1.0, abs=0.1)
    assert nees[:, 2].mean() == pytest.approx(1.0, abs=0.1)


def test_the_heading_drift_and_the_turn_scale_are_told_apart_by_the_angle_and_the_time():
    """Straight walks of 70 s and loops of 4π in 60 s, the heading drifting at 1σ 10 °/h and its
    turns off by 1σ 1 %: the joint fit gives both back, and the heading NEES with them is 1; without
    the drift the turn scale alone would take the loops' drift for turns."""
    rng = np.random.default_rng(11)
    sigma_r = math.radians(10.0) / 3600.0
    rows = []
    for k in range(4000):
        straight = bool(k % 2)
        turned, duration = (0.02, 70.0) if straight else (4 * math.pi, 60.0)
        e_chi = rng.normal(0.0, 0.004) + rng.normal(0.0, 0.01) * turned + rng.normal(0.0, sigma_r) * duration
        rows.append({"seed": k, "distance_m": 90.0, "d_north_m": 0.0, "d_east_m": 0.0,
                     "e_north_m": 0.0, "e_east_m": 0.0, "e_down_m": 0.0, "e_heading_deg": math.degrees(e_chi),
                     "p_nn": 1.0, "p_ne": 0.0, "p_ee": 1.0, "p_zz": 1.0, "p_chichi": 0.004 ** 2,
                     **{f"j_{r}{c}": 0.0 for r in "nezh" for c in "sckr"}, "j_hk": turned, "j_hr": duration})
    errors = module_error_priors(rows)
    assert errors.heading_drift_sigma == pytest.approx(sigma_r, rel=0.1)
    assert errors.turn_scale_sigma == pytest.approx(0.01, rel=0.1)
    nees = np.array([nees_with_module_errors(r, errors) for r in rows])
    assert nees[:, 2].mean() == pytest.approx(1.0, abs=0.1)
    assert module_error_priors(rows[1::2]).turn_scale_sigma == 0.0  # straight only: drift, no turns


def test_with_the_warmup_held_at_its_prior_the_drift_and_turn_scale_are_estimated_beside_it():
    """Straight walks and loops, turns off by 1σ 0.2 %, drifting at 1σ 30 °/h, and turned by a
    warm-up w of 1σ 0.02 °/s (its Jacobian, the ramp's integral, is not the drift's time): given
    the warm-up's prior, the fit gives σ_r and σ_k back and the heading NEES is 1; without it the
    drift rate takes the warm-up's share and reads high."""
    from hostlib.fusion.module_errors import ModuleErrors

    rng = np.random.default_rng(13)
    sigma_r, sigma_w, tau = math.radians(30.0) / 3600.0, math.radians(0.02), 120.0
    rows = []
    for k in range(4000):
        straight = bool(k % 2)
        turned, duration = (0.02, 70.0) if straight else (4 * math.pi, 60.0 + 120.0 * (k % 4 == 0))
        ramp = duration - tau * (1.0 - math.exp(-duration / tau))
        e_chi = (rng.normal(0.0, 0.004) + rng.normal(0.0, 0.002) * turned
                 + rng.normal(0.0, sigma_r) * duration + rng.normal(0.0, sigma_w) * ramp)
        rows.append({"seed": k, "distance_m": 90.0, "d_north_m": 0.0, "d_east_m": 0.0,
                     "e_north_m": 0.0, "e_east_m": 0.0, "e_down_m": 0.0, "e_heading_deg": math.degrees(e_chi),
                     "p_nn": 1.0, "p_ne": 0.0, "p_ee": 1.0, "p_zz": 1.0, "p_chichi": 0.004 ** 2,
                     **{f"j_{r}{c}": 0.0 for r in "nezh" for c in "sckrw"}, "j_hk": turned, "j_hr": duration,
                     "j_hw": ramp})
    warmup = ModuleErrors(0.0, 0.0, heading_warmup_sigma=sigma_w, warmup_tau_s=tau)
    errors = module_error_priors(rows, warmup)
    assert errors.heading_drift_sigma == pytest.approx(sigma_r, rel=0.15)
    assert errors.turn_scale_sigma == pytest.approx(0.002, rel=0.1)
    assert errors.heading_warmup_sigma == sigma_w and errors.warmup_tau_s == tau
    nees = np.array([nees_with_module_errors(r, errors) for r in rows])
    assert nees[:, 2].mean() == pytest.approx(1.0, abs=0.1)
    assert module_error_priors(rows).heading_drift_sigma > 1.4 * sigma_r


def test_a_simulated_walk_carries_the_time_it_drifted():
    """The Jacobian's drift column is the time the foot moved: the straight walk's 100 m in about 67 s."""
    row = consistency_run(("walk", 0))
    assert row["j_hr"] == pytest.approx(67.0, abs=3.0)
    assert row["j_nr"] != 0.0 or row["j_er"] != 0.0  # the drifting heading carries the positions
