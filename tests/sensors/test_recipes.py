"""The scenarios' recipe language: every piece's numbers are finite and in range, or the recipe is
refused with a :class:`RecipeError` naming the piece, the number and its range — never another
exception, never a walk that does not end or does not fit in memory."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_sim.sensors import recipes
from firmware_sim.sensors.gait import Trajectory
from firmware_sim.sensors.recipes import MAX_DURATION_S, PIECE_SPECS, RecipeError
from firmware_sim.sensors.scenarios import SCENARIOS, check, feet, trajectory

REFUSED = [
    ("walk:-5", "piece 1 'walk:-5': the length m [m] must be > 0 and at most 2500, got -5"),
    ("stand:3+walk:1e9", "piece 2 'walk:1e9': the length m [m] must be > 0 and at most 2500, got 1e+09"),
    ("walk:nan", "piece 1 'walk:nan': the length m [m] must be > 0 and at most 2500, got nan"),
    ("stand:inf", "piece 1 'stand:inf': the time s [s] must be > 0 and at most 1800, got inf"),
    ("walk:10:89", "the slope deg [deg] must be from -30 to 30, got 89"),
    ("rectangle:0:0:1", "piece 1 'rectangle:0:0:1': the length l [m] must be > 0 and at most 1250, got 0"),
    ("rectangle:4:1:1", "the corner radius r must be at most half the shorter side (0.5), got 1"),
    ("rectangle:1000:1000", "the perimeter 2 (l + w) is 4000 m: at most 2500"),
    ("walk:1:2:3", "piece 1 'walk:1:2:3': walk takes at most 2 numbers (walk[:m[:deg]]), got 3"),
    ("turn:90:1", "turn takes at most 1 number (turn[:deg]), got 2"),
    ("walk:", "piece 1 'walk:': arguments must be numbers: m is ''"),
    ("walk:abc", "piece 1 'walk:abc': arguments must be numbers: m is 'abc'"),
    ("track400:1e6", "the number of laps must be a whole number from 1 to 6, got 1e+06"),
    ("stairs_up:1e7", "the number of stairs n must be a whole number from 1 to 2000, got 1e+07"),
    ("stairs_down:2.5", "the number of stairs n must be a whole number from 1 to 2000, got 2.5"),
    ("back:0", "the number of steps n must be a whole number from 1 to 1000, got 0"),
    ("side:3:0", "the direction dir must be 1 (right) or -1 (left), got 0"),
    ("turn:1e9", "the turn deg [deg, right > 0] must be from -3600 to 3600, got 1e+09"),
    ("arc:0:90", "the radius r [m] must be > 0 and at most 2500, got 0"),
    ("arc:1000:3600", "the arc is 62832 m long (r · deg): at most 2500"),
    ("pace:0", "the walking speed v [m/s] must be from 0.3 to 3, got 0"),
    ("face:-inf", "the heading deg [deg east of north] must be from -360 to 360, got -inf"),
    ("wiggle:1e5", "the time s [s] must be > 0 and at most 600, got 100000"),
    ("walk:10+face:90", "piece 2 'face:90': face sets the heading the walk starts with: it can only be the "
                        "first piece"),
    ("stand:1+moonwalk", "piece 2 'moonwalk': unknown piece 'moonwalk'; known: arc, back,"),
    ("moonwalk", "unknown scenario 'moonwalk'; known: back_steps, default,"),
    ("walk:2000+walk:2000", "piece 2 'walk:2000': the scenario would last 2669 s by its end: at most 1800 s"),
    ("stand:1" + "+turn:1" * 1001, "a recipe has at most 1000 pieces, this one 1002"),
    ("stand:1799+walk:1", "the added piece 'stand:2': the scenario would last 1802 s by its end: at most "
                          "1800 s"),
]


@pytest.mark.parametrize(("text", "said"), REFUSED, ids=[t[:30] for t, _ in REFUSED])
def test_a_bad_recipe_is_refused_naming_the_piece_and_the_range(text, said):
    with pytest.raises(RecipeError) as caught:
        check(text)
    assert said in str(caught.value) and "\n" not in str(caught.value)
    assert isinstance(caught.value, ValueError) and isinstance(caught.value, KeyError)


@pytest.mark.parametrize("text", ["walk:2500:30", "stand:1+walk:1e3", "stairs_up:2000", "track400:2",
                                  "turn:-3600", "arc:0.75:-180", "side:3:-1", "pace:3+walk:10", "face:-360",
                                  "wiggle:600:0", "stand:3++walk:2", " walk : 5 + stand : 1 "])
def test_the_ends_of_each_range_are_walked(text):
    check(text)


def test_every_named_scenario_is_within_the_ranges():
    for name in SCENARIOS:
        check(name)


def test_both_feet_of_a_walker_are_checked_as_one_foot_is():
    with pytest.raises(RecipeError, match="piece 1 'walk:-5'"):
        feet("walk:-5")


def _number_text() -> st.SearchStrategy[str]:
    floats = st.floats(allow_nan=True, allow_infinity=True).map(lambda v: f"{v:g}")
    odd = st.sampled_from(["", " ", "x", "1e", "+1", "0x1", "1_0"])
    return st.one_of(floats, st.integers(-10**9, 10**9).map(str), odd)


#: recipe-like text: known and unknown names, any numbers, any number of them
pieces = st.builds(lambda name, numbers: ":".join([name, *numbers]),
                   st.sampled_from([*PIECE_SPECS, "moonwalk", ""]), st.lists(_number_text(), max_size=4))
recipe_like = st.lists(pieces, min_size=0, max_size=6).map("+".join)
any_text = st.text(alphabet="standwlkrupice0123456789.:+-_ nfx", max_size=40) | st.text(max_size=30)


@settings(max_examples=400, deadline=None)
@given(text=recipe_like | any_text | st.sampled_from(list(SCENARIOS)))
def test_any_text_is_a_scenario_or_refused_with_a_recipe_error(text):
    try:
        tr = trajectory(text)
    except RecipeError as exc:
        assert str(exc) and "\n" not in str(exc)
        return
    assert isinstance(tr, Trajectory) and math.isfinite(tr.duration) and 0 < tr.duration <= MAX_DURATION_S
    assert tr.stances and tr.stances[0][0] == 0.0


def test_parse_keeps_each_piece_with_its_place_and_defaults():
    first, second = recipes.parse("stand+walk:5")
    assert (first.place, first.text, first.values) == (1, "stand", (3.0,))
    assert (second.place, second.name, second.values) == (2, "walk", (5.0, 0.0))
