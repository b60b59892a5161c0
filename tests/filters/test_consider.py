"""The Schmidt-Kalman consider update: the ordinary update when every state is kept, a
consider state unmoved with Joseph's covariance, and honest variances under a constant
unknown offset (Monte Carlo)."""

from __future__ import annotations

import numpy as np

from sideslip.filters.consider import robust_consider_nb, scalar_consider_nb
from sideslip.filters.kalman import update_scalar_ws_nb


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
