"""The local compass deviation as a state of the host's filter: a Gauss–Markov process in the
distance walked, shared by both feet; not held, the filters are as they were, bit for bit; held,
readings that share one deviation count once, and the heading's σ is honest."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hostlib.aids.compass import StanceReading
from hostlib.fusion.deviation import INDOORS, OUTDOORS, WHITE_SIGMA_RAD, CompassDeviation
from hostlib.fusion.feet import FOOT_SIDES, TwoFeetTracker
from hostlib.fusion.module_errors import ModuleErrors
from hostlib.fusion.tracker import FusionSettings, FusionTracker
from hostlib.track.steps import StepTracker, rotation_z

from .covariance_checks import assert_symmetric_psd, walk_two_feet_at_random
from .pins import assert_as_pinned

DP = np.diag([1e-4, 1e-4, 1e-4, 1e-6])
FIELD_NED = 51.5 * np.array([math.cos(math.radians(72.5)), 0.0, math.sin(math.radians(72.5))])
STRIDE = 1.4


def _reading(true_heading: float, error: float = 0.0) -> StanceReading:
    """A level board facing *true_heading* [rad] whose compass reads *error* [rad] less than the
    truth (a field turned by *error* east: declination, deviation, noise); yaw 0, just reset."""
    return StanceReading(rotation_z(true_heading).T @ rotation_z(error) @ FIELD_NED, np.eye(3), 3)


def _heading_error(chi: float, truth: float) -> float:
    return math.remainder(chi - truth, 2 * math.pi)


# -- not held: as before ------------------------------------------------------------------


def _pinned_walks() -> list:
    """The aided filters on fixed walks (one foot with the compass, GPS and the module's errors;
    two feet with the compass and GPS): their states and covariances."""
    rng = np.random.default_rng(11)
    out = []
    times = np.arange(0.0, 120.0, 1.0)
    fixes = np.column_stack([0.7 * times, 0.05 * times]) + rng.normal(0.0, 2.0, (times.size, 2))
    for errors in (None, ModuleErrors(0.001, 0.0017, 0.001)):
        for mode in ("step", "every-reset"):
            f = FusionTracker(FusionSettings(compass=True, gps=True, compass_sigma_rad=math.radians(5.0),
                                             declination_rad=math.radians(7.7), module_errors=errors,
                                             compass_mode=mode, gps_interval_s=5.0))
            f.add_fixes(times, fixes)
            for k in range(110):
                length = 0.002 if k % 17 == 5 else 0.7 + 0.05 * rng.standard_normal()
                dx = [length, 0.02 * rng.standard_normal(), 0.01 * rng.standard_normal(),
                      0.01 * rng.standard_normal()]
                reading = _reading(0.07, math.radians(6.0 + 3 * rng.standard_normal()))
                f.add_step(dx, DP, k + 1, reading=reading, time_s=float(k + 1))
            out += [f.track.poses, f.track.covariances, f.state_covariance, [f.declination]]
    feet = TwoFeetTracker(aids=FusionSettings(compass=True, gps=True, compass_sigma_rad=math.radians(5.0),
                                              declination_rad=math.radians(7.7)))
    feet.add_fixes(times, fixes)
    counter = {side: 0 for side in FOOT_SIDES}
    for n in range(150):
        side = FOOT_SIDES[(n + 1) % 2]
        counter[side] += 1
        dx = [STRIDE * (0.5 if n == 0 else 1.0), 0.0, 0.0, 0.01 * rng.standard_normal()]
        feet.foot(side).add_step(dx, DP, counter[side], 0.4,
                                 reading=_reading(0.07, math.radians(6.0 + 3 * rng.standard_normal())),
                                 time_s=0.55 * (n + 1))
    body = feet.body
    out += [feet.filter.x, feet.filter.P, body.poses, body.covariances, feet.average.poses,
            [feet.separation()[-1]]]
    return out


#: The fingerprint (tests/hostlib/pins.py) of :func:`_pinned_walks`, from the filters as they were
#: before the local deviation could be held (where their bytes had SHA-256 a878469b…3d70ff):
#: without it no state or covariance may change by more than a machine's rounding.
#: The two feet's arrays (the 17th to the 22nd) were pinned again when the inter-foot constraint
#: came to project onto the sphere exactly (hostlib/fusion/feet.py): they moved by that change alone.
PINNED = [
    -31.570051524460354, -58.553214041472785, -18.355310582557237, -0.08785795611409503,
    -32.059024211420116, -59.86574646314091, -18.218473462198695, -0.08328535785016196, -31.804956133453583,
    -57.3364330946556, 11.639902406568005, -0.08514546875202005, -32.043524719448854, -56.60832518573564,
    11.364458537124355, -0.0836512896862849, 10.91050079529878, 8.330811058690855, -44.77994636036815,
    -141.97808525212884, -40.69759788862815, -0.725837405094194,
]


def test_not_held_the_aided_filters_are_as_they_were():
    assert_as_pinned(_pinned_walks(), PINNED)


def test_not_held_there_is_no_deviation_state():
    f = FusionTracker(FusionSettings(compass=True))
    assert f.deviation is None and f.deviation_sigma is None
    assert f.state_covariance.shape == (5, 5) and f.module_errors is None
    feet = TwoFeetTracker(aids=FusionSettings(compass=True))
    assert feet.filter.P.shape == (9, 9) and feet.deviation is None


# -- the process ------------------------------------------------------------------------


def test_presets_and_the_process_over_distance():
    # the emulator's fields' integral lengths: 0.18 of their 50 m and 3 m waves
    assert OUTDOORS == CompassDeviation(math.radians(3.0), 9.0)
    assert INDOORS == CompassDeviation(math.radians(20.0), 0.5)
    phi_a, q_a = OUTDOORS.transition(4.0)
    phi_b, q_b = OUTDOORS.transition(5.0)
    phi, q = OUTDOORS.transition(9.0)
    assert phi == pytest.approx(phi_a * phi_b) and phi == pytest.approx(math.exp(-1.0))
    assert q == pytest.approx(phi_b ** 2 * q_a + q_b)  # two walks are one walk of both lengths
    assert OUTDOORS.transition(0.0) == (1.0, 0.0)  # standing, the deviation is the same
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ValueError):
            CompassDeviation(bad, 10.0)
        with pytest.raises(ValueError):
            CompassDeviation(0.1, bad)


@settings(max_examples=40, deadline=None)
@given(sigma_deg=st.floats(0.5, 40.0), length=st.floats(0.5, 100.0), v0=st.floats(0.0, 1.0),
       d0=st.floats(-0.5, 0.5), steps=st.lists(st.floats(0.0, 2.0), min_size=1, max_size=60))
def test_walked_without_readings_the_deviation_relaxes_to_its_stationary_variance(sigma_deg, length, v0, d0,
                                                                                   steps):
    """From any estimate d₀ with variance v₀ σ_d², a walk of s metres without a reading leaves
    exp(−s/ℓ) d₀ and exp(−2s/ℓ) v₀ σ_d² + (1 − exp(−2s/ℓ)) σ_d²: σ_d² after a long walk. The
    track is the plain sum."""
    dev = CompassDeviation(math.radians(sigma_deg), length)
    f, plain = FusionTracker(FusionSettings(compass_deviation=dev)), StepTracker()
    x, p = f.filter.x, f.filter.P
    x[-2], p[-2, -2] = d0, v0 * dev.variance
    for k, s in enumerate(steps):
        for t in (f, plain):
            t.add_step([0.6 * s, 0.8 * s, 0.01, 0.0], DP, k + 1)
    walked = math.fsum(steps)
    decay = math.exp(-walked / length)
    assert f.deviation == pytest.approx(decay * d0, abs=1e-12)
    expected = decay ** 2 * v0 * dev.variance + (1.0 - decay ** 2) * dev.variance
    assert f.deviation_sigma ** 2 == pytest.approx(expected, rel=1e-9)
    assert np.array_equal(f.track.poses, plain.track.poses)
    assert np.array_equal(f.track.covariances, plain.track.covariances)
    f.add_step([20.0 * length, 0.0, 0.0, 0.0], DP, len(steps) + 1)  # twenty correlation lengths on
    assert f.deviation_sigma == pytest.approx(dev.sigma_rad, rel=1e-9) and abs(f.deviation) < 1e-8


def test_a_long_walk_without_aids_keeps_the_deviation_at_its_stationary_variance():
    f = FusionTracker(FusionSettings(compass_deviation=INDOORS))
    for k in range(400):
        f.add_step([0.7, 0.0, 0.0, 0.001], DP, k + 1)
    assert f.deviation == 0.0 and f.deviation_sigma == pytest.approx(INDOORS.sigma_rad)
    assert f.state_covariance.shape == (6, 6)
    assert np.all(f.state_covariance[4, :4] == 0.0)  # no aid ever tied it to the pose


# -- held: what the compass measures ------------------------------------------------------


def _held(dev: CompassDeviation) -> FusionSettings:
    """The compass with the deviation held, σ_c the white part."""
    return FusionSettings(compass=True, compass_sigma_rad=WHITE_SIGMA_RAD, compass_deviation=dev)


def _white(dev: CompassDeviation) -> FusionSettings:
    """The compass with the same readings taken as white: σ_c² = σ² + σ_d²."""
    return FusionSettings(compass=True, compass_sigma_rad=math.hypot(WHITE_SIGMA_RAD, dev.sigma_rad))


def test_the_first_reading_aligns_the_heading_with_the_deviation_and_the_declination():
    """χ ← ψ + D + d: its variance is the reading's white σ² plus D's and d's, and it is correlated
    with both as the sum is."""
    s = FusionSettings(compass=True, gps=True, compass_sigma_rad=WHITE_SIGMA_RAD, compass_deviation=OUTDOORS,
                       declination_rad=math.radians(6.0), declination_sigma_rad=math.radians(15.0))
    f = FusionTracker(s)
    f.add_step([0.7, 0.0, 0.0, 0.0], DP, 1, reading=_reading(0.5, math.radians(6.0)))
    p = f.state_covariance
    assert f.heading == pytest.approx(0.5) and f.fusion.heading_aligned_by == "compass"
    assert p[3, 3] == pytest.approx(WHITE_SIGMA_RAD ** 2 + OUTDOORS.variance + math.radians(15.0) ** 2)
    assert p[3, 4] == pytest.approx(OUTDOORS.variance)  # χ with d
    assert p[3, 5] == pytest.approx(math.radians(15.0) ** 2)  # χ with D
    assert p[4, 5] == 0.0
    # the next reading a step on, the same spot's deviation, measures χ − D − d
    f.add_step([0.7, 0.0, 0.0, 0.0], DP, 2, reading=_reading(0.5, math.radians(6.0)))
    assert f.fusion.compass_updates == 1
    assert f.fusion.compass_innovations[-1][1] == pytest.approx(0.0, abs=1e-12)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2 ** 16), white_deg=st.floats(0.5, 5.0), sigma_deg=st.floats(0.5, 30.0),
       gps=st.booleans())
def test_a_deviation_forgotten_within_a_step_is_white_noise(seed, white_deg, sigma_deg, gps):
    """With ℓ far shorter than a step, d is a fresh draw at every reading: the filter is the one
    without it, whose σ_c² is the white σ² plus σ_d²."""
    white, sigma = math.radians(white_deg), math.radians(sigma_deg)
    base = FusionSettings(compass=True, gps=gps, declination_rad=0.1, gps_interval_s=3.0,
                          gps_align_distance_m=5.0)
    forgotten = CompassDeviation(sigma, 1e-6)  # m: exp(−Δs/ℓ) is 0 for any step that moves the foot
    held = FusionTracker(replace(base, compass_sigma_rad=white, compass_deviation=forgotten))
    plain = FusionTracker(replace(base, compass_sigma_rad=math.hypot(white, sigma)))
    rng = np.random.default_rng(seed)
    times = np.arange(0.0, 40.0, 1.0)
    fixes = np.column_stack([0.7 * times, np.zeros_like(times)]) + rng.normal(0.0, 1.0, (times.size, 2))
    for k in range(40):
        dx = [0.7 + 0.1 * rng.standard_normal(), 0.05 * rng.standard_normal(), 0.0,
              0.01 * rng.standard_normal()]
        reading = _reading(0.2, rng.normal(0.0, math.hypot(white, sigma)))
        for t in (held, plain):
            if gps and k == 0:
                t.add_fixes(times, fixes)
            t.add_step(dx, DP, k + 1, reading=reading, time_s=float(k + 1))
    keep = [0, 1, 2, 3, -1]
    np.testing.assert_allclose(held.track.poses, plain.track.poses, rtol=1e-9, atol=1e-9)
    assert held.declination == pytest.approx(plain.declination, abs=1e-9)
    np.testing.assert_allclose(held.state_covariance[np.ix_(keep, keep)], plain.state_covariance,
                               rtol=1e-7, atol=1e-14)
    held.add_step([0.7, 0.0, 0.0, 0.0], DP, 41)  # a step on, what the last reading taught is forgotten
    assert held.deviation_sigma == pytest.approx(sigma) and held.deviation == 0.0


@pytest.mark.parametrize("dev", [CompassDeviation(OUTDOORS.sigma_rad, 50.0),
                                 CompassDeviation(INDOORS.sigma_rad, 30.0)],
                         ids=["3 deg over 50 m", "20 deg over 30 m"])
def test_readings_sharing_one_deviation_pull_the_heading_less_than_white_readings(dev):
    """Both filters know the heading equally well (one reading, then a walk of ten correlation
    lengths without one); then six readings a step apart (0.7 m, well within ℓ), all off by σ_d: one
    patch of deviation. Taken as white (σ_c² = σ² + σ_d²) they count six times; with d held, about once."""
    held = FusionTracker(_held(dev))
    white = FusionTracker(_white(dev))
    step = 0.7
    free = int(10 * dev.length_m / step)
    for f in (held, white):
        f.add_step([step, 0.0, 0.0, 0.0], DP, 1, reading=_reading(0.0))
        for k in range(free):
            f.add_step([step, 0.0, 0.0, 0.0], DP, k + 2, reading=None)
    assert held.covariance[3, 3] == pytest.approx(white.covariance[3, 3])
    prior = held.covariance[3, 3]
    for f in (held, white):
        for k in range(6):
            f.add_step([step, 0.0, 0.0, 0.0], DP, free + 2 + k, reading=_reading(0.0, dev.sigma_rad))
    pulled = {name: abs(f.heading) / dev.sigma_rad for name, f in (("held", held), ("white", white))}
    assert pulled["held"] < pulled["white"] - 0.2
    # the patch well within ℓ: the six readings weigh as one reading of σ_d (and the white σ / √6)
    assert pulled["held"] == pytest.approx(prior / (prior + dev.variance + WHITE_SIGMA_RAD ** 2 / 6),
                                           abs=0.02)


def _nees(dev: CompassDeviation, seeds: int, steps: int, step_m: float = 0.7) -> dict[str, float]:
    """The mean normalised heading error e² / σ² at the end of a straight walk whose readings are
    off by a Gauss–Markov deviation of *dev*'s σ and ℓ plus white noise, with d held and with the
    readings taken as white (σ_c² = σ² + σ_d²); the module's heading error is the random walk its
    steps' variance says."""
    out = {"held": [], "white": []}
    phi, _ = dev.transition(step_m)
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        trackers = {"held": FusionTracker(_held(dev)), "white": FusionTracker(_white(dev))}
        d = rng.normal(0.0, dev.sigma_rad)
        for k in range(steps):
            turn = rng.normal(0.0, math.sqrt(DP[3, 3]))
            d = phi * d + math.sqrt(1.0 - phi * phi) * dev.sigma_rad * rng.standard_normal()
            reading = _reading(0.0, d + rng.normal(0.0, WHITE_SIGMA_RAD))
            for f in trackers.values():
                f.add_step([step_m, 0.0, 0.0, turn], DP, k + 1, reading=reading)
        for name, f in trackers.items():
            out[name].append(_heading_error(f.heading, 0.0) ** 2 / f.covariance[3, 3])
    return {name: float(np.mean(v)) for name, v in out.items()}


@pytest.mark.parametrize("dev", [OUTDOORS, INDOORS], ids=["outdoors", "indoors"])
def test_the_heading_sigma_is_honest_when_the_readings_err_by_the_modelled_deviation(dev):
    """100 walks of 175 m: with d held the normalised heading error is about 1 (one degree of
    freedom); readings taken as white make the filter too sure of its heading — several times
    outdoors, where a step is well within ℓ, a little indoors, where ℓ is shorter than a step."""
    nees = _nees(dev, seeds=100, steps=250)
    assert 0.7 < nees["held"] < 1.35
    assert nees["white"] > (4.0 if dev.length_m > 5 * 0.7 else 1.3)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2 ** 16), sigma_deg=st.floats(0.5, 40.0), length=st.floats(0.1, 200.0),
       errors=st.booleans(), gps=st.booleans(), mode=st.sampled_from(["step", "every-reset"]))
def test_the_covariance_stays_symmetric_and_positive_semi_definite(seed, sigma_deg, length, errors, gps,
                                                                    mode):
    rng = np.random.default_rng(seed)
    s = FusionSettings(compass=True, gps=gps, compass_mode=mode, compass_sigma_rad=WHITE_SIGMA_RAD,
                       compass_deviation=CompassDeviation(math.radians(sigma_deg), length),
                       module_errors=ModuleErrors(0.001, 0.002, 0.01) if errors else None,
                       gps_interval_s=2.0, gps_align_distance_m=5.0)
    f = FusionTracker(s)
    times = np.arange(0.0, 60.0, 1.0)
    f.add_fixes(times, np.column_stack([0.5 * times, 0.1 * times]) + rng.normal(0.0, 2.0, (times.size, 2)))
    for k in range(60):
        length_m = 0.0 if rng.random() < 0.2 else rng.uniform(0.2, 1.5)
        dx = [length_m, 0.05 * rng.standard_normal(), 0.01 * rng.standard_normal(),
              0.2 * rng.standard_normal()]
        reading = None if rng.random() < 0.1 else _reading(rng.uniform(-3, 3), rng.normal(0.0, 0.5))
        f.add_step(dx, np.diag(rng.uniform(1e-6, 1e-2, 4)), k + 1, reading=reading, time_s=float(k + 1))
        assert_symmetric_psd(f.state_covariance)
    assert 0.0 < f.deviation_sigma <= math.radians(sigma_deg) * (1 + 1e-9)


# -- two feet: one deviation --------------------------------------------------------------


def _feet(dev: CompassDeviation | None, white: float, **feet_args) -> TwoFeetTracker:
    return TwoFeetTracker(aids=FusionSettings(compass=True, compass_sigma_rad=white, compass_deviation=dev),
                          **feet_args)


def test_two_feet_share_one_deviation_which_walks_with_the_body():
    """[…L, …R, d, D]; the right foot's half stride aligns the heading, correlated σ_d² with d; the
    left foot's stride then moves the body, and d, by half of it."""
    dev = CompassDeviation(math.radians(10.0), 5.0)
    feet = _feet(dev, WHITE_SIGMA_RAD)
    assert feet.filter.P.shape == (10, 10) and feet.deviation_sigma == pytest.approx(dev.sigma_rad)
    feet.right.add_step([0.5 * STRIDE, 0.0, 0.0, 0.0], DP, 1, 0.4, reading=_reading(0.3), time_s=0.55)
    assert feet.filter.P[7, 8] == pytest.approx(dev.variance)
    feet.left.add_step([STRIDE, 0.0, 0.0, 0.0], DP, 1, 0.4, reading=None, time_s=1.1)
    assert feet.filter.P[7, 8] == pytest.approx(math.exp(-0.5 * STRIDE / dev.length_m) * dev.variance)
    assert feet.filter.P[8, 8] == pytest.approx(dev.variance)
    # the left foot's reading, where the right foot's was, says the same: no innovation
    feet.right.add_step([STRIDE, 0.0, 0.0, 0.0], DP, 2, 0.4, reading=_reading(0.3), time_s=1.65)
    assert feet.fusion.compass_innovations[-1][1] == pytest.approx(0.0, abs=1e-12)
    # each foot's own tracker (the baseline) holds its own d
    assert all(feet.foot(side).deviation is not None for side in FOOT_SIDES)


def test_two_feet_heading_sigma_is_honest_with_one_shared_deviation():
    """Both feet read one Gauss–Markov deviation along the walk (plus each reading's white noise):
    the body's normalised heading error is about 1 with d held; taken as white, both feet's
    readings count as independent and the filter is far too sure of the heading."""
    dev = OUTDOORS
    nees: dict[str, list[float]] = {"held": [], "white": []}
    phi, _ = dev.transition(0.5 * STRIDE)
    for seed in range(40):
        rng = np.random.default_rng(seed)
        trackers = {"held": _feet(dev, WHITE_SIGMA_RAD),
                    "white": _feet(None, math.hypot(WHITE_SIGMA_RAD, dev.sigma_rad))}
        d = rng.normal(0.0, dev.sigma_rad)
        counter = {side: 0 for side in FOOT_SIDES}
        for n in range(201):
            side = FOOT_SIDES[(n + 1) % 2]  # the right foot's half stride first
            half = n == 0
            step_phi = math.sqrt(phi) if half else phi
            d = step_phi * d + math.sqrt(1.0 - step_phi ** 2) * dev.sigma_rad * rng.standard_normal()
            reading = _reading(0.0, d + rng.normal(0.0, WHITE_SIGMA_RAD))
            dx = [STRIDE * (0.5 if half else 1.0), 0.0, 0.0, rng.normal(0.0, math.sqrt(DP[3, 3]))]
            counter[side] += 1
            for t in trackers.values():
                t.foot(side).add_step(dx, DP, counter[side], 0.4, reading=reading, time_s=0.55 * (n + 1))
        for name, t in trackers.items():
            body = t.body
            nees[name].append(_heading_error(body.final_pose[3], 0.0) ** 2 / body.final_covariance[3, 3])
    assert 0.6 < np.mean(nees["held"]) < 1.4
    assert np.mean(nees["white"]) > 4.0


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2 ** 16), sigma_deg=st.floats(0.5, 40.0), length=st.floats(0.1, 200.0),
       gps=st.booleans())
def test_two_feet_covariance_stays_symmetric_and_positive_semi_definite(seed, sigma_deg, length, gps):
    rng = np.random.default_rng(seed)
    dev = CompassDeviation(math.radians(sigma_deg), length)
    feet = TwoFeetTracker(aids=FusionSettings(compass=True, gps=gps, compass_sigma_rad=WHITE_SIGMA_RAD,
                                              compass_deviation=dev, gps_interval_s=2.0,
                                              gps_align_distance_m=5.0))
    times = np.arange(0.0, 40.0, 1.0)
    feet.add_fixes(times, np.column_stack([0.6 * times, 0.1 * times]) + rng.normal(0.0, 2.0, (times.size, 2)))
    walk_two_feet_at_random(feet, rng)
