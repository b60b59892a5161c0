"""Windowed NIS consistency: chi^2 behaviour on synthetic innovations with known statistics."""

import numpy as np

from sideslip.filters.consistency import nis_consistency


def test_consistent_innovations_are_rarely_flagged_and_never_inflated_much():
    # NIS of a consistent scalar filter is chi2(1); a 2 s window at 10 Hz sums 20 of them, so
    # the 99 % bound is exceeded about 1 % of the time (windows overlap, so allow 3 %).
    rng = np.random.default_rng(1)
    t = np.arange(0, 600, 0.1)
    nis = rng.standard_normal(t.size) ** 2
    c = nis_consistency(t, nis, 1, window_s=2.0)
    assert c.flagged.mean() < 0.03
    assert np.all(c.inflation >= 1.0)
    assert c.inflation.max() < 2.5
    assert np.all((c.health >= 0) & (c.health <= 1))


def test_innovations_three_times_too_large_are_flagged_with_variance_inflation_near_nine():
    # Innovations 3 sigma instead of 1 in the second half: windowed NIS per dof ~ 9, so the
    # variance inflation there is ~9 (+-30 % for a 20-sample chi2 window) and health > 0.5.
    rng = np.random.default_rng(2)
    t = np.arange(0, 200, 0.1)
    scale = np.where(t > 100, 3.0, 1.0)
    nis = (scale * rng.standard_normal(t.size)) ** 2
    c = nis_consistency(t, nis, 1, window_s=2.0)
    bad = t > 102
    assert c.flagged[bad].mean() > 0.97
    assert 6.0 < np.median(c.inflation[bad]) < 12.0
    assert np.median(c.health[bad]) > 0.5
    assert c.flagged[t < 98].mean() < 0.05
    s = c.summary(t)
    assert s["flagged_share"] > 0.45 and s["n_flagged_spans"] >= 1


def test_rows_without_innovations_are_neutral_and_causal_window_looks_back_only():
    t = np.arange(0, 20, 0.1)
    nis = np.full(t.size, np.nan)
    nis[t > 10] = 25.0  # a 5-sigma innovation on every row after 10 s
    c = nis_consistency(t, nis, 1, window_s=1.0, causal=True)
    assert np.all(c.mean_nis[t < 10] == 1.0) and not c.flagged[t < 10].any()
    assert c.flagged[t > 10.05].all()
    assert np.isfinite(c.inflation).all() and np.isfinite(c.health).all()


def test_a_slow_channel_misfit_hidden_in_the_pooled_mean_shows_in_its_own_test():
    """A 100 Hz channel whose NIS sits at 0.25 (its S four times too wide) and a 1 Hz one 3
    sigma off from t = 100 s: pooled, the window's mean NIS stays near 0.3 and nothing is
    flagged; the slow channel's own test flags its misfit, and ``worst`` keeps that flag and
    inflation while the first half stays unflagged."""
    from sideslip.filters.nis_windows import binned_nis_consistency

    rng = np.random.default_rng(3)
    t = np.round(np.arange(0.0, 200.0, 0.01), 2)
    fast = 0.25 * rng.standard_normal(t.size) ** 2
    slow = np.full(t.size, np.nan)
    every_s = np.flatnonzero(np.isclose(t % 1.0, 0.0))
    scale = np.where(t[every_s] > 100.0, 3.0, 1.0)
    slow[every_s] = (scale * rng.standard_normal(every_s.size)) ** 2
    both = fast + np.nan_to_num(slow)
    dof = 1.0 + np.isfinite(slow)
    pooled = binned_nis_consistency(t, both, dof, 4.0)
    assert pooled.flagged.mean() < 0.01
    own = binned_nis_consistency(t, slow, np.isfinite(slow).astype(float), 4.0)
    merged = pooled.worst(own)
    late = t > 104.0
    assert merged.flagged[late].mean() > 0.5
    assert np.median(merged.inflation[late & merged.flagged]) > 3.0
    assert merged.flagged[t < 96.0].mean() < 0.05
    assert np.all(merged.inflation >= pooled.inflation)
