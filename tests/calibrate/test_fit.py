"""The calibration's least squares on analytic cases: priors, nuisance windows, robust sigma."""

from __future__ import annotations

import numpy as np

from sideslip.calibrate.fit import clusters_of, fit_linear, fit_robust, informed, project_windows, window_ids


def test_a_parameter_the_rows_do_not_reach_keeps_its_prior():
    rng = np.random.default_rng(1)
    t = np.arange(2000) * 0.1
    x = rng.standard_normal(2000)
    y = 2.0 * x + 0.1 * rng.standard_normal(2000)
    X = np.column_stack([x, np.zeros(2000)])  # the second parameter has no regressor
    fit = fit_linear(X, y, clusters_of(t), np.array([0.0, 5.0]), np.array([10.0, 0.3]))
    assert abs(fit.theta[0] - 2.0) < 0.01
    assert abs(fit.theta[1] - 5.0) < 1e-9
    assert abs(fit.sigma()[1] - 0.3) < 1e-6
    assert informed(fit.sigma()[0], 10.0) and not informed(fit.sigma()[1], 0.3)


def test_cluster_sigma_is_honest_for_correlated_noise():
    # AR(1) noise with a 2 s correlation time: the naive sigma is ~6x too small; 200 seeded
    # runs give the share of |error| < 2 sigma, which should be near 0.95
    inside = 0
    for seed in range(200):
        rng = np.random.default_rng(seed)
        n = 3000
        t = np.arange(n) * 0.1
        e = np.zeros(n)
        w = rng.standard_normal(n)
        for k in range(1, n):
            e[k] = 0.95 * e[k - 1] + w[k]
        x = np.sin(t / 7.0) + 0.2 * rng.standard_normal(n)
        fit = fit_linear(x[:, None], 1.5 * x + e, clusters_of(t, 10.0))
        inside += abs(fit.theta[0] - 1.5) < 2 * fit.sigma()[0]
    assert 0.85 <= inside / 200 <= 1.0


def test_window_projection_removes_offset_and_slope():
    t = np.arange(600) * 0.1
    use = np.ones(600, dtype=bool)
    use[300:305] = False  # a gap splits the run
    win = window_ids(t, use, 20.0, 0.2)
    assert win[use].min() == 0 and (win[~use] == -1).all()
    x = np.sin(t)
    y = 0.7 * x + 3.0 + 0.2 * t  # offset and slope per window are nuisance
    sel = win >= 0
    P = project_windows(win[sel], t[sel], np.column_stack([y[sel], x[sel]]))
    fit = fit_linear(P[:, 1:], P[:, 0], clusters_of(t[sel]))
    assert abs(fit.theta[0] - 0.7) < 1e-9


def test_robust_fit_drops_multipath_like_outliers():
    rng = np.random.default_rng(3)
    t = np.arange(1000) * 0.1
    x = rng.standard_normal(1000)
    y = 1.0 * x + 0.01 * rng.standard_normal(1000)
    y[::50] += 5.0  # 2 % gross outliers
    fit, keep = fit_robust(x[:, None], y, clusters_of(t))
    assert abs(fit.theta[0] - 1.0) < 0.005
    assert (~keep).sum() == 20
