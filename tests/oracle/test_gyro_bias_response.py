"""Why the emulated module's heading follows only about 1 % of a vertical gyro bias (docs/accuracy.md,
the module's heading drift), shown on a short walk (:mod:`.gyro_bias_response`)."""

from __future__ import annotations

import pytest

from .gyro_bias_response import biased_source, response, trace_bias

WALK = "stand:3+walk:10+stand:2"


def test_biasest_learns_a_vertical_bias_in_every_still_simulated_stance():
    """The simulated stances are still, so ZARU holds in them: a 1 °/s board z bias (0.9756 °/s in
    the registers) present in the start-up stand is removed there; one that appears after it is
    learnt in the first walking stances (90 % in < 2 s) and the heading keeps only the bias of
    the swings before that, ≈ 0.6 s of it whatever the walk's length. Without ZARU after the stand
    (as in the shared real walks' stances) the heading takes the whole bias × time."""
    base = trace_bias(biased_source(WALK, None))
    rows = {case: response(WALK, 1.0, case, base)
            for case in ("from t=0", "after the stand", "after the stand, no ZARU")}
    b = rows["from t=0"]["register_bias_dps"]
    assert b == pytest.approx(1.0 / 16.4 * 16, abs=1e-6)  # 16.4 LSB rounded to 16
    assert rows["from t=0"]["zaru_walk_stances"] > 0.99
    assert rows["from t=0"]["estimate_at_walk_dps"] == pytest.approx(b, rel=1e-3)
    assert abs(rows["from t=0"]["heading_deg"]) < 0.005

    late = rows["after the stand"]
    assert late["estimate_at_walk_dps"] == pytest.approx(0.0, abs=1e-4)
    assert late["t90_s"] < 2.0 and late["estimate_at_end_dps"] == pytest.approx(b, rel=0.01)
    assert late["heading_deg"] == pytest.approx(late["unlearnt_no_zaru_deg"], rel=0.05)
    assert 0.5 * b < late["heading_deg"] < 0.7 * b  # ≈ the bias of 0.6 s
    assert late["heading_deg"] < 0.1 * late["bias_x_after_deg"]

    free = rows["after the stand, no ZARU"]
    assert free["heading_deg"] == pytest.approx(free["bias_x_after_deg"], rel=0.03)
