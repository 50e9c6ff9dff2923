"""Vectors stored a component a row (3, …), as the simulated array computes its chips' signals:
the same numbers, bit for bit, as the stacks of vectors (…, 3) the definitions are written for."""

from __future__ import annotations

import numpy as np
import pytest

from firmware_sim.board import MIMU22BT
from firmware_sim.sensors.mpu9150 import small_rotation
from firmware_sim.sensors.truth import cross, cross_rows, rotate, rotation


def vectors(seed: int, n: int = 5000) -> np.ndarray:
    rng = np.random.default_rng(seed)
    v = rng.standard_normal((n, 3)) * 10.0 ** rng.uniform(-8, 3, (n, 1))
    v[:2] = [[0.0, -0.0, 1.0], [-0.0, 0.0, -0.0]]  # signed zeros
    return v


@pytest.mark.parametrize("matrix", [*MIMU22BT.mounting.astype(float), np.eye(3),
                                    small_rotation(np.array([0.01, -0.02, 0.005])) @ MIMU22BT.mounting[1]])
def test_a_rotation_of_rows_is_the_rotation_of_the_vectors(matrix):
    v = vectors(1)
    want = rotate(matrix, v).tobytes()
    assert rotation(matrix).rows(np.ascontiguousarray(v.T)).T.tobytes() == want
    out = np.empty((3, len(v)))
    assert rotation(matrix).rows(v.T, out=out) is out and out.T.tobytes() == want


def test_a_cross_product_of_rows_is_the_cross_product_of_the_vectors():
    w, r = vectors(2), MIMU22BT.lever_arms  # every sample's rate with every chip's lever arm
    want = cross(w[:, None, :], cross(w[:, None, :], r[None]))
    got = cross_rows(w.T[:, None, :], cross_rows(w.T[:, None, :], r.T[:, :, None]))
    assert np.ascontiguousarray(got.transpose(2, 1, 0)).tobytes() == want.tobytes()
