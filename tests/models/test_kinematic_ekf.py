"""Seed 004 EKF models: every analytic Jacobian against central finite differences."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from sideslip.models.kinematic_ekf import (
    KU,
    NO_INPUT,
    NX,
    gnss_model,
    gyro_model,
    steer_model,
    transition,
    wheel_model,
)
from sideslip.vehicle import load_vehicle

SEDAN = load_vehicle("midsize_sedan")


def _state(rng: np.random.Generator) -> np.ndarray:
    x = np.zeros(NX)
    x[:5] = [10.0, -4.0, 0.7, 12.0, 0.15]
    x[5:] = rng.normal(0.0, 1e-3, NX - 5)
    x[KU] = 0.0025
    return x


def _num_jac(f: Callable[[np.ndarray], Any], x: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    cols = []
    for i in range(x.size):
        dx = np.zeros_like(x)
        dx[i] = eps
        cols.append((np.asarray(f(x + dx)) - np.asarray(f(x - dx))) / (2 * eps))
    return np.array(cols).T


def test_transition_jacobian_matches_finite_differences():
    x = _state(np.random.default_rng(1))
    args = (NO_INPUT, 0.02, SEDAN.lr, 0.99, 0.98)
    num = _num_jac(lambda z: transition(z, *args)[0], x)
    np.testing.assert_allclose(transition(x, *args)[1], num, rtol=0, atol=1e-8)


@pytest.mark.parametrize("side", [0, 1])
def test_wheel_measurement_jacobian_matches_finite_differences(side):
    x = _state(np.random.default_rng(2))
    num = _num_jac(lambda z: wheel_model(z, side, SEDAN.track_rear)[0], x)
    np.testing.assert_allclose(wheel_model(x, side, SEDAN.track_rear)[1], num, atol=1e-7)


def test_steer_measurement_jacobian_matches_finite_differences():
    x = _state(np.random.default_rng(3))
    num = _num_jac(lambda z: steer_model(z, 0.08, SEDAN.wheelbase)[0], x)
    np.testing.assert_allclose(steer_model(x, 0.08, SEDAN.wheelbase)[1], num, atol=1e-7)


def test_gnss_measurement_jacobian_matches_finite_differences():
    x = _state(np.random.default_rng(4))
    for k in range(2):
        num = _num_jac(lambda z, k=k: gnss_model(z, 0.8, -0.3)[k], x)
        np.testing.assert_allclose(gnss_model(x, 0.8, -0.3)[2 + k], num, atol=1e-8)




def test_gyro_measurement_jacobian_matches_finite_differences():
    x = _state(np.random.default_rng(5))
    num = _num_jac(lambda z: gyro_model(z)[0], x)
    np.testing.assert_allclose(gyro_model(x)[1], num, atol=1e-8)


def test_steer_jacobian_on_the_oversteer_clamp_matches_finite_differences():
    x = _state(np.random.default_rng(6))
    x[KU] = -0.01  # L + K v^2 below L/2 at 12 m/s: the clamped branch
    num = _num_jac(lambda z: steer_model(z, 0.08, SEDAN.wheelbase)[0], x)
    np.testing.assert_allclose(steer_model(x, 0.08, SEDAN.wheelbase)[1], num, atol=1e-7)
