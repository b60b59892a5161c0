"""Seed 004 EKF models: every analytic Jacobian against central finite differences."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from sideslip.filters.kalman import predict_sparse_nb
from sideslip.models.kinematic_ekf import (
    KU,
    NO_INPUT,
    NX,
    gnss_model,
    gnss_model_into,
    gyro_model,
    propagate_covariance,
    steer_model,
    steer_model_into,
    transition,
    transition_into,
    wheel_model,
    wheel_model_into,
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


def _covariance(rng: np.random.Generator) -> np.ndarray:
    a = rng.normal(size=(NX, NX))
    return a @ a.T + NX * np.eye(NX)


@pytest.mark.parametrize("speed", [12.0, 0.0])
def test_propagate_covariance_is_the_generic_sparse_predict(speed):
    """The pattern-specific F P F' + Q equals filters.kalman's generic sparse predict bit for
    bit (same sums in the same order), also at standstill where some Jacobian entries are 0."""
    rng = np.random.default_rng(4)
    x = _state(rng)
    x[3] = speed
    xn, F = transition(x, NO_INPUT, 0.01, SEDAN.lr, 0.99, 0.995)
    P = _covariance(rng)
    Q = np.diag(rng.uniform(0.0, 1e-3, NX))
    Q[0, 1] = Q[1, 0] = 1e-5
    ref_x, ref_P = x.copy(), P.copy()
    predict_sparse_nb(ref_x, ref_P, xn, F, Q)
    got = P.copy()
    propagate_covariance(got, F, Q, np.empty((NX, NX)))
    np.testing.assert_array_equal(got, ref_P)
    np.testing.assert_array_equal(got, got.T)
    # and the dense product, to rounding
    np.testing.assert_allclose(got, F @ P @ F.T + Q, rtol=1e-12, atol=1e-12)


def test_in_place_models_equal_the_allocating_ones():
    """The *_into forms (the filter loop's, no allocation) give the allocating forms' values
    and overwrite every entry of the scratch they are handed."""
    rng = np.random.default_rng(5)
    x = _state(rng)
    xn_ref, F_ref = transition(x, NO_INPUT, 0.02, SEDAN.lr, 0.98, 0.99)
    xn, F = np.full(NX, np.nan), np.full((NX, NX), np.nan)
    transition_into(x, 0.02, SEDAN.lr, 0.98, 0.99, xn, F)
    np.testing.assert_array_equal(xn, xn_ref)
    np.testing.assert_array_equal(F, F_ref)
    for side in (0, 1):
        h = np.full(NX, np.nan)
        pred_ref, h_ref = wheel_model(x, side, SEDAN.track_rear)
        assert wheel_model_into(x, side, SEDAN.track_rear, h) == pred_ref
        np.testing.assert_array_equal(h, h_ref)
    h = np.full(NX, np.nan)
    pred_ref, h_ref = steer_model(x, 0.05, SEDAN.wheelbase)
    assert steer_model_into(x, 0.05, SEDAN.wheelbase, h) == pred_ref
    np.testing.assert_array_equal(h, h_ref)
    he, hn = np.full(NX, np.nan), np.full(NX, np.nan)
    e_ref, n_ref, he_ref, hn_ref = gnss_model(x, 1.0, -0.3)
    assert gnss_model_into(x, 1.0, -0.3, he, hn) == (e_ref, n_ref)
    np.testing.assert_array_equal(he, he_ref)
    np.testing.assert_array_equal(hn, hn_ref)
