"""The numpy Kalman references: analytic scalar cases and the Joseph form."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.filters.reference import predict, update_joseph


def test_scalar_update_matches_hand_computation() -> None:
    # prior N(0, 4), measurement z = 2 with variance 1: K = 4/5, x+ = 1.6, P+ = 0.8
    x, P, innov, S = update_joseph([0.0], [[4.0]], [2.0], [[1.0]], [[1.0]])
    assert x[0] == pytest.approx(1.6, abs=1e-12)
    assert P[0, 0] == pytest.approx(0.8, abs=1e-12)
    assert innov[0] == pytest.approx(2.0)
    assert S[0, 0] == pytest.approx(5.0)


def test_predict_propagates_mean_and_covariance() -> None:
    F = np.array([[1.0, 0.1], [0.0, 1.0]])
    G = np.array([[0.005], [0.1]])
    x, P = predict([1.0, 2.0], np.eye(2), F, 0.01 * np.eye(2), G, [3.0])
    np.testing.assert_allclose(x, [1.0 + 0.2 + 0.015, 2.3])
    np.testing.assert_allclose(P, F @ F.T + 0.01 * np.eye(2))


def test_joseph_form_keeps_covariance_symmetric_positive_with_suboptimal_round_off() -> None:
    # a nearly singular update (R tiny) is where the short form (I - K H) P loses symmetry
    P = np.array([[1e4, 1e4 - 1e-3], [1e4 - 1e-3, 1e4]])
    _, Pn, _, _ = update_joseph([0.0, 0.0], P, [1.0], [[1.0, 0.0]], [[1e-9]])
    assert np.allclose(Pn, Pn.T, rtol=0, atol=0)
    assert np.all(np.linalg.eigvalsh(Pn) > -1e-9)
