"""The fused estimator's consider (Schmidt-Kalman) update and its combined-slip wheel term."""

from __future__ import annotations

import numpy as np

from sideslip.filters.kalman import update_scalar_ws_nb
from sideslip.methods.fused_updates import robust_consider_nb, scalar_consider_nb, wheel_slip_ratio
from sideslip.signals import speed_raw
from sideslip.vehicle import G, load_vehicle
from tests.conftest import sim_drive


def _random_problem(rng: np.random.Generator, n: int = 6) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    a = rng.normal(size=(n, n))
    return rng.normal(size=n), a @ a.T + n * np.eye(n), rng.normal(size=n)


def test_with_every_state_kept_it_is_the_ordinary_update() -> None:
    rng = np.random.default_rng(1)
    x, P, h = _random_problem(rng)
    x1, P1 = x.copy(), P.copy()
    x2, P2 = x.copy(), P.copy()
    s1 = scalar_consider_nb(x1, P1, 0.7, h, 0.3, np.ones(x.size), np.zeros((2, x.size)))
    s2 = update_scalar_ws_nb(x2, P2, 0.7, h, 0.3, np.zeros((2, x.size)))
    assert s1 == s2
    np.testing.assert_array_equal(x1, x2)
    np.testing.assert_array_equal(P1, P2)


def test_a_consider_state_is_not_moved_and_the_covariance_is_josephs() -> None:
    """Gain row 2 zeroed: x[2] and P[2, 2] unchanged, P the Joseph product of that gain
    (I - k h) P (I - k h)' + r k k' (Simon 2006, eq 5.19), and the other states' variances
    larger than the optimal update's (the consider state's error is not averaged away)."""
    rng = np.random.default_rng(2)
    x, P, h = _random_problem(rng)
    keep = np.ones(x.size)
    keep[2] = 0.0
    r, innov = 0.3, 0.7
    x1, P1 = x.copy(), P.copy()
    scalar_consider_nb(x1, P1, innov, h, r, keep, np.zeros((2, x.size)))
    s = h @ P @ h + r
    k = P @ h / s * keep
    i_kh = np.eye(x.size) - np.outer(k, h)
    np.testing.assert_allclose(P1, i_kh @ P @ i_kh.T + r * np.outer(k, k), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(x1, x + k * innov, rtol=1e-12)
    assert x1[2] == x[2] and P1[2, 2] == P[2, 2]
    x2, P2 = x.copy(), P.copy()
    update_scalar_ws_nb(x2, P2, innov, h, r, np.zeros((2, x.size)))
    others = np.arange(x.size) != 2
    assert np.all(np.diag(P1)[others] >= np.diag(P2)[others] - 1e-12)


def test_repeated_updates_with_a_constant_unknown_offset_stay_honest() -> None:
    """z_k = v + c + noise, c a constant offset (sigma 1) the updates must not learn: after
    50 updates the consider filter's variance of v matches its Monte-Carlo error variance
    (about sigma_c^2: the offset cannot be averaged away), while treating c's variance as
    white measurement noise in each update (the diagonal approximation) claims ~50x less."""
    rng = np.random.default_rng(3)
    sig_v, sig_c, sig_z, n_upd, trials = 2.0, 1.0, 0.5, 50, 2000
    keep = np.array([1.0, 0.0])
    h = np.array([1.0, 1.0])
    err_consider, err_diag = [], []
    p_consider = p_diag = 0.0
    for _ in range(trials):
        v, c = rng.normal(0.0, sig_v), rng.normal(0.0, sig_c)
        xs, Ps = np.zeros(2), np.diag([sig_v**2, sig_c**2])
        xd, pd = 0.0, sig_v**2
        for _ in range(n_upd):
            z = v + c + rng.normal(0.0, sig_z)
            robust_consider_nb(xs, Ps, z - h @ xs, h, sig_z**2, np.inf, keep, np.zeros((2, 2)))
            gain = pd / (pd + sig_z**2 + sig_c**2)
            xd, pd = xd + gain * (z - xd), (1.0 - gain) * pd
        err_consider.append(xs[0] - v)
        err_diag.append(xd - v)
        p_consider, p_diag = Ps[0, 0], pd
    mc_consider = float(np.var(err_consider))
    assert 0.85 < p_consider / mc_consider < 1.15
    assert p_diag < 0.05 * float(np.var(err_diag))


def test_wheel_slip_ratio_is_linear_at_small_slip_and_grows_with_saturation() -> None:
    c_k = 15.0
    # linear range: the secant compliance below 1 / (g C_k): a_x / (g C_k)
    assert wheel_slip_ratio(3.0, 1.0, 0.001, 0.0, 1.0, c_k) == 3.0 / (G * c_k)
    # saturated rear axle: z F_x / F_y (isotropic brush model)
    assert np.isclose(wheel_slip_ratio(0.5, 4.5, 0.09, 0.0, 1.0, c_k), 0.09 * 0.5 / 4.5)
    # cornering drag of the front axle enters the driving force: f_front q_front
    assert np.isclose(wheel_slip_ratio(0.0, 4.5, 0.09, 0.1, 0.8, c_k), 0.09 * (4.5 * 0.8 * 0.1) / 4.5)


def test_wheel_slip_sigma_matches_the_simulated_race_lap_wheel_error_in_limit_corners() -> None:
    """Simulator truth (Magic Formula tyres, load transfer, traction control): in the race
    lap's limit corners (|a_y| > 7 m/s^2, |a_x| < 1 m/s^2) the wheel speed reads 0.77 % RMS
    off the true speed; the relative sigma ``wheel_rel_sigma + slip`` with the combined-slip
    ratio (from the true slip angles) is 0.99 % RMS (error / sigma 0.78), with a_x / (g C_k)
    alone 0.57 % (1.36: overconfident, the wheel speed then pulls v_x and, through the
    cross-covariances, the gyro scale and the slip in the first limit corner)."""
    drive = sim_drive("race_lap")
    v = load_vehicle(drive.meta["vehicle"])
    vx, vy, r = drive["ref_vx"], drive["ref_vy"], drive["ref_r"]
    vw = speed_raw(drive)
    sel = (np.abs(drive["ay"]) > 7.0) & (np.abs(drive["ax"]) < 1.0) & (vx > 10.0) & np.isfinite(vw)
    assert sel.sum() > 500
    rel = vw[sel] / vx[sel] - 1.0
    f_rear = v.lf / (v.lf + v.lr) * drive["ay"]
    rows = zip(drive["ax"][sel], f_rear[sel], vx[sel], vy[sel], r[sel], strict=True)
    slip = np.array(
        [
            wheel_slip_ratio(a, f, -(y - v.lr * w) / u, (y + v.lf * w) / u, v.lr / v.lf, 15.0)
            for a, f, u, y, w in rows
        ]
    )
    old = np.abs(drive["ax"][sel]) / (G * 15.0)
    wheel_rel = 0.003  # FusedSettings.wheel_rel_sigma

    def ratio(s: np.ndarray) -> float:
        return float(np.sqrt(np.mean(rel**2)) / np.sqrt(np.mean((wheel_rel + s) ** 2)))

    assert 0.6 < ratio(slip) < 1.0
    assert ratio(old) > 1.25
