"""Pole placement for 2-state observers: the closed-loop poles land where asked, at any speed."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from sideslip.filters.pole_placement import (
    bicycle_coupling,
    closed_loop,
    double_pole_step,
    single_output_gain,
    two_output_gain,
)
from sideslip.models.single_track import continuous_arrays
from sideslip.vehicle import load_vehicle

SPEEDS = np.array([5.0, 10.0, 22.2, 38.9, 60.0])  # m/s: parking to motorway (seed 003: 80/140 km/h)


def _poles(M: np.ndarray) -> np.ndarray:
    return np.sort_complex(np.linalg.eigvals(M))


@pytest.mark.parametrize("pole", [-2.0, -10.0, -30.0])
def test_single_output_gain_places_double_pole_at_every_speed(pole: float) -> None:
    veh = load_vehicle("seed003_sedan")
    A, _, _, _ = continuous_arrays(veh, SPEEDS)
    K = single_output_gain(A, pole)
    M = closed_loop(A, K, np.array([[0.0, 1.0]]))
    for m in M:
        # characteristic polynomial s^2 - tr s + det must equal (s - p)^2; a double root is
        # ill-conditioned in its location (error ~ sqrt(eps)), so compare the coefficients.
        assert np.trace(m) == pytest.approx(2 * pole, rel=1e-9)
        assert np.linalg.det(m) == pytest.approx(pole**2, rel=1e-7)
        assert np.allclose(_poles(m), pole, atol=1e-4 * abs(pole))


def test_single_output_gain_matches_ackermann_formula() -> None:
    # Ackermann: K = phi(A) O^-1 e_n with phi(s) = (s - p)^2 and O = [C; C A], C = [0 1].
    rng = np.random.default_rng(3)
    for _ in range(20):
        A = rng.normal(size=(2, 2))
        p = -rng.uniform(0.5, 20.0)
        C = np.array([[0.0, 1.0]])
        O = np.vstack([C, C @ A])
        phi = A @ A - 2 * p * A + p**2 * np.eye(2)
        K_ack = phi @ np.linalg.solve(O, np.array([0.0, 1.0]))
        assert np.allclose(single_output_gain(A, p)[0], K_ack, rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize("pole", [-3.0, -10.0, -25.0])
def test_two_output_gain_places_double_pole_and_decouples_beta(pole: float) -> None:
    veh = load_vehicle("seed003_sedan")
    A, _, C, _ = continuous_arrays(veh, SPEEDS)
    q = bicycle_coupling(veh.cf, veh.cr, veh.lf, veh.lr, veh.yaw_inertia)
    K = two_output_gain(A, C, pole, q)
    M = closed_loop(A, K, C)
    # K12 = 1/v_x (seed 003 eq 36): the beta error no longer depends on itself ...
    assert np.allclose(K[:, 0, 1], 1.0 / SPEEDS, rtol=1e-12)
    assert np.allclose(M[:, 0, 0], 0.0, atol=1e-9)
    # ... and beta~' = -(1 + K11) r~
    assert np.allclose(M[:, 0, 1], -(1.0 + K[:, 0, 0]), rtol=1e-9)
    for m in M:
        assert np.trace(m) == pytest.approx(2 * pole, rel=1e-9)
        assert np.linalg.det(m) == pytest.approx(pole**2, rel=1e-7)


def test_two_output_gain_reproduces_paper_eq37() -> None:
    # Seed 003 eq 37 with per-tyre stiffness Cf, Cr (per axle = 2 x per tyre):
    # K11 = Iz (lf Cf - lr Cr) p^2 / (2 Cf Cr L^2) - 1, K21 = -2p,
    # K22 = m (lf^2 Cf + lr^2 Cr) / (Iz (lf Cf - lr Cr)).
    veh = load_vehicle("seed003_sedan")
    Cf, Cr = veh.cf / 2, veh.cr / 2
    lf, lr, L, m, Iz = veh.lf, veh.lr, veh.wheelbase, veh.mass, veh.yaw_inertia
    p = -7.0
    A, _, C, _ = continuous_arrays(veh, SPEEDS)
    K = two_output_gain(A, C, p, bicycle_coupling(veh.cf, veh.cr, lf, lr, Iz))
    assert np.allclose(K[:, 0, 0], Iz * (lf * Cf - lr * Cr) * p**2 / (2 * Cf * Cr * L**2) - 1)
    assert np.allclose(K[:, 1, 0], -2 * p)
    assert np.allclose(K[:, 1, 1], m * (lf**2 * Cf + lr**2 * Cr) / (Iz * (lf * Cf - lr * Cr)))


def test_bicycle_coupling_stays_finite_for_neutral_steer() -> None:
    # cf lf = cr lr exactly: the paper's K22 = a22/c22 would divide by zero.
    q = bicycle_coupling(cf=1.0e5, cr=1.0e5, lf=1.3, lr=1.3, yaw_inertia=3000.0)
    assert np.isfinite(q) and q < 0


@pytest.mark.parametrize("pole", [0.0, -1e-7, -0.5, -10.0, -400.0])
def test_double_pole_step_is_the_exact_matrix_exponential(pole: float) -> None:
    veh = load_vehicle("seed003_sedan")
    A, _, _, _ = continuous_arrays(veh, SPEEDS)
    K = single_output_gain(A, pole if pole < 0 else -1e-9)
    M = closed_loop(A, K, np.array([[0.0, 1.0]]))
    dt = 0.01
    Phi, Gam = double_pole_step(M, pole if pole < 0 else -1e-9, dt)
    for i in range(M.shape[0]):
        aug = np.zeros((4, 4))
        aug[:2, :2] = M[i]
        aug[:2, 2:] = np.eye(2)
        E = expm(aug * dt)
        scale = np.abs(E[:2, :2]).max()
        assert np.allclose(Phi[i], E[:2, :2], atol=1e-7 * scale)
        assert np.allclose(Gam[i], E[:2, 2:], atol=1e-7 * np.abs(E[:2, 2:]).max())


def test_kinematic_observer_gains_give_double_pole_minus_alpha_r() -> None:
    # Seed 003 eqs 23-25: A_k = [[0, r], [-r, 0]], K = [2a|r|, (a^2 - 1) r] -> (s + a|r|)^2.
    for r in (-0.8, -0.1, 0.05, 0.6):
        for alpha in (0.5, 2.0, 4.0):
            Ak = np.array([[0.0, r], [-r, 0.0]])
            K = np.array([[2 * alpha * abs(r)], [(alpha**2 - 1) * r]])
            M = Ak - K @ np.array([[1.0, 0.0]])
            assert np.trace(M) == pytest.approx(-2 * alpha * abs(r))
            assert np.linalg.det(M) == pytest.approx((alpha * r) ** 2)
