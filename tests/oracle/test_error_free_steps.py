"""The error-free scenarios' causes (docs/accuracy.md, "Error-free scenarios at 1 kHz"), each shown by
changing one thing in a loop-by-loop run (:mod:`.error_free_steps`)."""

from __future__ import annotations

import numpy as np

from .error_free_steps import (
    detector_events,
    midswing_override,
    resets_in_swings,
    source_of,
    strides,
    trace,
    truth_override,
)


def _end_pct(tr) -> float:
    return 100.0 * float(np.linalg.norm(strides(tr)[-1]["error"][:3])) / tr.truth.distance_m()


def test_side_steps_see_no_stance_in_mid_swing():
    tr = trace(source_of("side_steps"))
    ev = detector_events(tr)
    assert not [f for f in ev["false_stances"] if 0.2 < f["fraction"] < 0.8]
    assert min(s["min_rate_dps"] for s in ev["swings"]) > 2.9  # the slowest real swing's
    assert _end_pct(tr) < 0.1


def test_a_short_step_is_stopped_40_ms_before_it_lands():
    """At 1 kHz the detector's four samples take the end of a short step's deceleration, before its
    landing's impact, for a stance: that early ZUPT alone is the back steps' error."""
    src = source_of("back_steps")
    tr = trace(src)
    early = [f for f in detector_events(tr)["false_stances"] if 0.85 < f["fraction"] < 0.93]
    assert len(early) == 8 and all(f["samples"] <= 4 and 0.03 < f["speed"] < 0.07 for f in early)
    assert _end_pct(tr) > 0.12
    assert _end_pct(trace(src, override=midswing_override(src.truth, 0.05))) < 0.05
    assert _end_pct(trace(src, override=truth_override(src.truth))) < 0.05


def test_the_reset_turns_the_frame_but_not_the_moving_foot_s_velocity():
    """The firmware resets when the ZUPT ends, ~30 ms into the swing with the foot moving: the yaw it
    takes away (the turn before) turns the frame, not the velocity, and the stride goes astray."""
    src = source_of("stand:3+turn:90+walk:3+stand:2")
    tr = trace(src)
    first = [r for r in resets_in_swings(tr) if abs(np.degrees(r["yaw"])) > 40.0 and r["speed"] > 0.02]
    assert len(first) == 1 and 0.02 < first[0]["into_s"] < 0.05
    assert first[0]["velocity_error"] > 0.02
    across = np.linalg.norm(strides(tr)[-1]["error"][:2])
    turned = np.linalg.norm(strides(trace(src, turn_velocity=True))[-1]["error"][:2])
    assert across > 0.004 and turned < 0.3 * across
