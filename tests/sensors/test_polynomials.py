"""The swing's and the sway's polynomials evaluated in place: numpy's ``polyval``, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.polynomial import polynomial as P

from firmware_sim.sensors import gait, stance_sway
from firmware_sim.sensors.polynomials import eval3


@pytest.mark.parametrize("coeffs", [gait._S, gait._C, gait._G1, gait._G2, gait._IMPACT, stance_sway._RAMP,
                                    np.array([2.5]), np.array([-1.0, 3.0])])
def test_a_polynomial_and_its_derivatives_are_numpys_polyval(coeffs):
    x = np.concatenate([np.random.default_rng(len(coeffs)).uniform(-0.5, 1.5, 4000), [0.0, -0.0, 1.0]])
    want = (P.polyval(x, coeffs), P.polyval(x, P.polyder(coeffs)), P.polyval(x, P.polyder(P.polyder(coeffs))))
    for got, expected in zip(eval3(coeffs, x), want, strict=True):
        assert got.tobytes() == expected.tobytes()
